//! The evaluator pool: hands chunks of a generation to worker processes and
//! survives their failures, over any [`Transport`]: iceoryx2 on one host
//! ([`iceoryx`]), zenoh across hosts ([`zenoh`]).
//!
//! Each generation is split into chunks, several per worker and largest
//! first, queued round-robin up to [`DEPTH`] per worker
//! ([`SHARED_STEP_DEPTH`] in a single trial's step that the coordinator
//! flies a share of); any left over go to whichever worker has room
//! first. Once none is left to hand out, a
//! worker that has answered everything takes the last queued chunk of a
//! busy one (`Pool::rebalance`). The pool sleeps on its `wake` event
//! between results; where it has a CPU that would otherwise idle
//! ([`PoolOptions::share`]), it first flies a queued chunk itself
//! (`Pool::fly_a_share`); it flies so the share of the worker on its own
//! CPU, which is sent no evaluation chunk ([`PoolOptions::stand_in`]),
//! from the start, while that worker is still starting, and
//! there, with that CPU to itself, polls for answers for a bounded,
//! adaptive time before it sleeps (`Pool::spin_for_answers`, iceoryx2
//! only). A chunk whose worker dies (its process exits, its node is found
//! dead, or its server disconnects) or misses its deadline goes back in
//! the queue; a late duplicate is dropped by job id. Results are placed by
//! chunk, so they are identical however the work was spread.
//!
//! The pool's unit of work is a [`Chunk`]; each time one is sent it goes
//! as a job of the wire (a [`JobHeader`] under a fresh job id).
//!
//! - `link`: the [`Transport`] and [`WorkerLink`] seam, and the checks
//!   every answer passes;
//! - `workers`: the workers' lifecycle: accepting, waiting, reaping,
//!   respawning (with `spawn`), shutting down;
//! - `schedule`: cutting a generation into chunks, handing them out,
//!   taking them back, the coordinator's share, [`Pool::run_chunks`];
//! - `progress`: where a generation's chunks stand while they run;
//! - `verify`: `--verify`, answers held until another worker (or this
//!   process) has flown their chunks again;
//! - `backend`: the [`Evaluator`] and [`Trainer`] impls;
//! - `timing`: [`ChunkTiming`], the stamps of both ends.
//!
//! What happens to workers is told as [`Event`]s through the pool's
//! [`Telemetry`]: logged, appended to the run's `events.jsonl`, counted in
//! the metrics.
//!
//! [`Event`]: lander_telemetry::Event
//!
//! [`JobHeader`]: lander_protocol::wire::JobHeader
//! [`Evaluator`]: crate::evaluator::Evaluator
//! [`Trainer`]: crate::evaluator::Trainer

mod backend;
pub mod iceoryx;
mod link;
mod progress;
mod schedule;
mod spawn;
mod timing;
mod verify;
mod workers;
pub mod zenoh;

#[cfg(test)]
mod tests;

pub use link::{Answer, Arrival, Transport, WorkerLink};
pub use schedule::Chunk;
pub use spawn::{cpu_to_spare, kill_worker_child, worker_children};
pub use timing::ChunkTiming;

use crate::stop::Stop;
use lander_telemetry::Telemetry;
use spawn::Children;
use std::collections::{HashMap, HashSet};
use std::path::PathBuf;
use std::time::Duration;

/// Chunks queued at a worker at once. With four chunks per worker, a
/// generation is handed out whole as it starts, round-robin, and the
/// coordinator need not wake until a worker has answered all it holds.
pub const DEPTH: usize = 4;

/// Chunks queued at a worker at once in a step of a single batch that the
/// coordinator flies a share of (`Pool::depth_for`). Such a step is cut
/// into chunks of a few genomes, largest first, and the first go out while
/// the rest are bred: four of them would hold the step's largest chunks
/// at the worker to its end, where the coordinator, run dry, could take
/// back only chunks that large, and the worker would wait for the last
/// one taken. Two keep the
/// worker busy for as long as the coordinator flies a chunk of its own,
/// and the step ends on the small ones.
pub const SHARED_STEP_DEPTH: usize = 2;

/// How a pool finds its workers.
#[derive(Clone, Debug)]
pub struct PoolOptions {
    /// The run id that names every service.
    pub run_id: String,
    /// Workers to spawn and keep alive; 0 means workers attach themselves.
    pub spawn: usize,
    /// The `lander-worker` executable for spawned workers.
    pub worker_exe: PathBuf,
    /// Chunks per worker in each generation.
    pub chunks_per_worker: usize,
    /// A chunk not answered within this goes to another worker.
    pub deadline: Duration,
    /// Spawned workers replaced after dying, at most.
    pub max_respawns: usize,
    /// Pin each spawned worker to a CPU of its own, when there are at
    /// least as many CPUs as workers (`worker/src/cpu.rs` says why).
    pub pin: bool,
    /// Attached workers to wait for before the first chunk goes out, so
    /// that the first generation is spread over all of them; later
    /// generations use whoever is there.
    pub min_workers: usize,
    /// How long a spawned iceoryx2 worker polls for its next chunk before
    /// it sleeps, when it has a CPU of its own, and the coordinator for
    /// its workers' answers where it stands in for the worker on its CPU
    /// (`lander_protocol::spin` says how it adapts); zero never spins.
    pub spin: Duration,
    /// The share of answered evaluation chunks flown again in-process and
    /// compared, 0 to 1 (`verify`).
    pub verify: f64,
    /// The coordinator flies a share of each generation itself, between
    /// answers, rather than sleeping while chunks wait for room at a
    /// worker: for when a CPU of its own would otherwise idle
    /// (`schedule.rs`, `Pool::fly_a_share`).
    pub share: bool,
    /// In a step of evaluation, the coordinator flies the share of the
    /// worker on its CPU itself, rather than hand it chunks and wake it
    /// there (`Pool::stands_in_for`): the worker beside a pinned
    /// coordinator, with a worker on every CPU.
    pub stand_in: bool,
    /// Asked to stop, the pool ends the run at its next look.
    pub stop: Stop,
}

/// The pool over iceoryx2, for workers on this host.
pub type IpcPool = Pool<iceoryx::Iceoryx>;
/// The pool over zenoh, for workers on any host.
pub type ZenohPool = Pool<zenoh::Zenoh>;

/// What one look at a link found.
struct Polled {
    /// Its worker's id and pid.
    id: u64,
    pid: u32,
    answers: Vec<Answer>,
    /// Why an answer was refused, if one was.
    refused: Option<String>,
}

pub struct Pool<T: Transport> {
    opts: PoolOptions,
    transport: T,
    links: Vec<T::Link>,
    /// Workers dropped once are not taken back: a worker that restarts
    /// comes back under a new id.
    dropped: HashSet<u64>,
    /// Workers refused since their links were last dropped: the refusal is
    /// told as it is made. A link broken otherwise (a send that failed, a
    /// worker gone) is dropped as its worker's death.
    refused: HashSet<u64>,
    children: Children,
    /// The job id the next chunk sent goes under.
    next_job: u64,
    /// Chunks moved from a busy worker's queue to an idle worker.
    taken_back: u64,
    /// Chunks the coordinator flew itself (`PoolOptions::share`).
    flown_here: u64,
    /// Chunks handed out while the rest of their step was bred
    /// (`Pool::hand_early`).
    handed_early: u64,
    /// The CPU the thread running the pool's loop shares with the last
    /// worker, where there is a worker on every CPU (`Placement`).
    beside: Option<usize>,
    /// The CPUs this process may run on, at least one.
    cpus: usize,
    /// During the evaluation step under way, the coordinator flies the
    /// chunks that would go to the worker beside it
    /// (`Pool::stands_in_for`). Not while training: a Q(λ) leg flown here
    /// would keep the coordinator from the answers for as long as it
    /// lasts.
    stands_in: bool,
    /// Chunks a worker may hold in the step under way: [`DEPTH`], or
    /// [`SHARED_STEP_DEPTH`] (`Pool::depth_for`).
    depth: usize,
    /// The most episodes of a Q(λ) trial one chunk flies
    /// ([`lander_protocol::wire::MOST_EPISODES_PER_CHUNK`]; fewer in tests).
    episodes_per_chunk: u32,
    /// Whether the pool said it waits for workers since it last had one.
    told_waiting: bool,
    /// Answers read while a step was still being bred, so that their
    /// workers had room for more (`Pool::hand_early`), or while the
    /// coordinator polled for them (`Pool::spin_for_answers`): the step's
    /// loop takes them first.
    arrived: Vec<Polled>,
    /// How long the coordinator polls for answers before it sleeps, where
    /// it has its CPU to itself.
    answer_spin: lander_protocol::spin::Spin,
    /// Kept only when asked for, so long runs do not accumulate them.
    timings: Option<Vec<ChunkTiming>>,
    /// The workers' own time on every chunk answered, summed, and the
    /// coordinator's on the chunks it flew itself.
    busy: crate::evaluator::Busy,
    /// What the last step of several batches cost to breed and to fly.
    pace: backend::Pace,
    /// The host each connected worker announced, by worker id.
    hosts: HashMap<u64, String>,
    /// Workers that have had an answer taken (`--verify` checks every
    /// worker's first).
    vetted: HashSet<u64>,
    /// Where worker events go: the log, events.jsonl, the metrics.
    telemetry: Telemetry,
    /// What the workers are told as the pool goes: that the run stopped,
    /// unless its command said it is over ([`Evaluator::run_over`]).
    ///
    /// [`Evaluator::run_over`]: crate::evaluator::Evaluator::run_over
    ending: lander_protocol::Farewell,
}
