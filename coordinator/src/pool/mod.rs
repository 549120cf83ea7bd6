//! The evaluator pool: hands chunks of a generation to worker processes and
//! survives their failures, over any [`Transport`]: iceoryx2 on one host
//! ([`iceoryx`]), zenoh across hosts ([`zenoh`]).
//!
//! Each generation is split into chunks, several per worker and largest
//! first, queued round-robin up to [`DEPTH`] per worker; any left over go
//! to whichever worker has room first. Once none is left to hand out, a
//! worker that has answered everything takes the last queued chunk of a
//! busy one (`Pool::rebalance`). The pool sleeps on its `wake` event
//! between results, never spinning. A chunk whose worker dies (its process
//! exits, its node is found dead, or its server disconnects) or misses its
//! deadline goes back in the queue; a late duplicate is dropped
//! by job id. Results are placed by chunk, so they are identical however the
//! work was spread.

pub mod iceoryx;
mod spawn;
pub mod zenoh;

use crate::evaluator::{Batch, EvalError, Evaluator, Trainer};
use crate::stop::Stop;
use lander_model::{Action, Evaluation, TrainJob, TrainResult};
use lander_protocol::host::host_clock_ns;
use lander_protocol::wire::{
    decode_training, ChunkResult, JobHeader, ResultHeader, Status, WireError, WireGene,
    KIND_EVALUATE, KIND_TRAIN, PROTOCOL_VERSION,
};
use spawn::Children;
pub use spawn::{kill_worker_child, worker_children};
use std::collections::{HashSet, VecDeque};
use std::ops::Range;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// How long the pool sleeps at most before looking after its workers.
const SLICE: Duration = Duration::from_millis(25);

/// Chunks queued at a worker at once. With four chunks per worker, a
/// generation is handed out whole as it starts, round-robin, and the
/// coordinator need not wake until a worker has answered all it holds.
pub const DEPTH: usize = 4;

/// A worker that announced itself.
#[derive(Clone, Copy, Debug)]
pub struct Arrival {
    pub id: u64,
    pub pid: u32,
    pub version: u32,
}

/// One answered job, its body checked but not decoded.
pub struct Answer {
    pub job: usize,
    pub body: Vec<u8>,
    pub timing: ChunkTiming,
}

/// How a chunk went, seen from both ends, in nanoseconds of the host's
/// monotonic clock ([`host_clock_ns`]). The worker's two stamps are on the
/// coordinator's clock only when both run on one host.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChunkTiming {
    /// The worker that answered.
    pub worker: u64,
    /// The coordinator sent the request.
    pub sent_ns: u64,
    /// The coordinator read the answer.
    pub read_ns: u64,
    /// The worker started the job.
    pub started_ns: u64,
    /// The worker finished the job.
    pub finished_ns: u64,
}

impl ChunkTiming {
    /// The timing of an answer under `h` read now, to a request sent to
    /// `worker` at `sent_ns`.
    pub fn read_now(worker: u64, sent_ns: u64, h: &ResultHeader) -> ChunkTiming {
        ChunkTiming {
            worker,
            sent_ns,
            read_ns: host_clock_ns(),
            started_ns: h.started_ns,
            finished_ns: h.finished_ns,
        }
    }

    /// From sending the request to reading the answer.
    pub fn round_trip(&self) -> Duration {
        Duration::from_nanos(self.read_ns.saturating_sub(self.sent_ns))
    }

    /// The worker's own time on the job.
    pub fn compute(&self) -> Duration {
        Duration::from_nanos(self.finished_ns.saturating_sub(self.started_ns))
    }
}

/// How a transport finds its workers and waits for them.
pub trait Transport {
    type Link: WorkerLink;
    /// Workers that announced themselves since the last look.
    fn arrivals(&mut self) -> Result<Vec<Arrival>, EvalError>;
    fn connect(&mut self, arrival: &Arrival) -> Result<Self::Link, String>;
    /// Workers the transport has seen go since the last look.
    fn departures(&mut self) -> Vec<u64>;
    /// Sleeps until a worker may have said something, at most `max`.
    fn sleep(&mut self, max: Duration) -> Result<(), EvalError>;
    /// What a spawned `lander-worker` needs on its command line to find
    /// this transport.
    fn worker_args(&self) -> Vec<String>;
    /// How long, when the pool ends, to wait for workers told to leave to
    /// be seen going, so that closing cannot overtake the message telling
    /// them. Zero where a worker also learns it from the transport itself.
    fn farewell(&self) -> Duration {
        Duration::ZERO
    }
    /// Tidies up when the pool ends.
    fn close(&mut self);
}

/// The coordinator's end of one worker: the chunks it is working on.
pub trait WorkerLink {
    fn id(&self) -> u64;
    fn pid(&self) -> u32;
    /// True while the worker can queue another chunk.
    fn has_room(&self) -> bool;
    fn is_broken(&self) -> bool;
    fn deadline(&self) -> Option<Instant>;
    /// Gives up on the jobs in flight, returning them.
    fn abandon(&mut self) -> Vec<usize>;
    /// Jobs sent and not yet answered.
    fn in_flight(&self) -> usize;
    /// Takes back the last job queued, one the worker has not started, so
    /// that an idle worker can run it; `None` where the transport cannot
    /// tell the worker to skip it, since it would then be flown twice.
    fn take_back(&mut self) -> Option<usize> {
        None
    }
    /// Sends `genes` under `header` as the pool's job `job`; the worker
    /// may not look until [`WorkerLink::notify`].
    fn send(
        &mut self,
        header: JobHeader,
        genes: &[WireGene],
        job: usize,
        deadline: Option<Duration>,
    ) -> Result<(), String>;
    /// Tells the worker about the jobs sent since the last call, where the
    /// transport needs telling.
    fn notify(&mut self) -> Result<(), String> {
        Ok(())
    }
    /// Collects the answers that arrived, checked against the jobs they
    /// answer but not yet decoded. An answer that fails its checks breaks
    /// the link and is reported beside the good ones; the jobs still in
    /// flight, the refused one among them, are then run elsewhere.
    fn poll(&mut self) -> (Vec<Answer>, Option<String>);
    /// Marks the link unusable, for an answer the caller refused.
    fn break_off(&mut self);
    /// Tells the worker the run is over.
    fn shut_down(&self);
}

fn overdue(link: &impl WorkerLink, now: Instant) -> bool {
    link.deadline().is_some_and(|d| now >= d)
}

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
    /// Asked to stop, the pool ends the run at its next look.
    pub stop: Stop,
}

/// Messages for the user, such as "waiting for workers".
pub type Say = Box<dyn Fn(&str) + Send>;

/// The pool over iceoryx2, for workers on this host.
pub type IpcPool = Pool<iceoryx::Iceoryx>;
/// The pool over zenoh, for workers on any host.
pub type ZenohPool = Pool<zenoh::Zenoh>;

pub struct Pool<T: Transport> {
    opts: PoolOptions,
    transport: T,
    links: Vec<T::Link>,
    /// Workers dropped once are not taken back: a worker that restarts
    /// comes back under a new id.
    dropped: HashSet<u64>,
    children: Children,
    next_job: u64,
    /// Chunks moved from a busy worker's queue to an idle worker.
    taken_back: u64,
    told_waiting: bool,
    /// Kept only when asked for, so long runs do not accumulate them.
    timings: Option<Vec<ChunkTiming>>,
    say: Say,
}

impl IpcPool {
    /// Opens the run's iceoryx2 services and, when asked to, spawns its
    /// workers.
    pub fn start(opts: PoolOptions, say: Say) -> Result<IpcPool, EvalError> {
        let transport = iceoryx::Iceoryx::open(&opts.run_id)?;
        Pool::with_transport(transport, opts, say)
    }
}

impl<T: Transport> Pool<T> {
    /// A pool over `transport` that spawns `opts.spawn` workers.
    pub fn with_transport(transport: T, opts: PoolOptions, say: Say) -> Result<Pool<T>, EvalError> {
        let mut pool = Pool {
            children: Children::new(
                opts.worker_exe.clone(),
                opts.run_id.clone(),
                transport.worker_args(),
                opts.max_respawns,
                cpus_for(&opts),
            ),
            transport,
            links: Vec::new(),
            dropped: HashSet::new(),
            next_job: 0,
            taken_back: 0,
            told_waiting: false,
            timings: None,
            say,
            opts,
        };
        for _ in 0..pool.opts.spawn {
            pool.children.spawn()?;
        }
        Ok(pool)
    }

    /// Workers connected now.
    pub fn workers(&self) -> usize {
        self.links.len()
    }

    /// Waits until `n` workers have announced themselves.
    pub fn wait_for_workers(&mut self, n: usize, patience: Duration) -> Result<(), EvalError> {
        let end = Instant::now() + patience;
        let mut todo = VecDeque::new();
        while self.links.len() < n {
            if self.opts.stop.asked() {
                return Err(EvalError::Interrupted);
            }
            if Instant::now() >= end {
                return Err(EvalError::WorkersLate {
                    wanted: n,
                    got: self.links.len(),
                    secs: patience.as_secs(),
                });
            }
            self.accept()?;
            self.reap(&mut todo)?;
            self.sleep()?;
        }
        Ok(())
    }

    /// Chunks moved so far from a busy worker to an idle one.
    pub fn taken_back(&self) -> u64 {
        self.taken_back
    }

    /// Starts keeping the timing of every chunk answered.
    pub fn record_timings(&mut self) {
        self.timings.get_or_insert_with(Vec::new);
    }

    /// The timings kept since the last call.
    pub fn take_timings(&mut self) -> Vec<ChunkTiming> {
        self.timings
            .as_mut()
            .map(std::mem::take)
            .unwrap_or_default()
    }

    /// Connects to workers that announced themselves since the last look.
    fn accept(&mut self) -> Result<(), EvalError> {
        for w in self.transport.arrivals()? {
            if self.dropped.contains(&w.id) || self.links.iter().any(|l| l.id() == w.id) {
                continue;
            }
            if w.version != PROTOCOL_VERSION {
                // One this pool started will never speak another version:
                // the executables come from different builds, and none of
                // its workers is of use.
                if self.children.started(w.pid) {
                    self.children.kill_all();
                    return Err(EvalError::WorkerVersion {
                        exe: self.opts.worker_exe.display().to_string(),
                        got: w.version,
                    });
                }
                (self.say)(&format!(
                    "refusing worker {:016x} (pid {}): it speaks protocol version {}, this coordinator {}",
                    w.id, w.pid, w.version, PROTOCOL_VERSION
                ));
                // It re-announces until served; say so once.
                self.dropped.insert(w.id);
                continue;
            }
            match self.transport.connect(&w) {
                Ok(link) => self.links.push(link),
                Err(e) => (self.say)(&format!("cannot reach worker {:016x}: {e}", w.id)),
            }
        }
        Ok(())
    }

    /// Drops links whose process exited or whose node died, and replaces
    /// spawned workers that are gone. Their chunks go back in `todo`.
    fn reap(&mut self, todo: &mut VecDeque<usize>) -> Result<(), EvalError> {
        for pid in self.children.exited() {
            let replaced = self.children.respawn()?;
            (self.say)(&format!(
                "worker process {pid} exited; {}",
                if replaced {
                    "starting another"
                } else {
                    "no respawns left"
                }
            ));
            self.drop_links(todo, |l| l.pid() == pid, "exited");
        }
        let gone = self.transport.departures();
        self.drop_links(todo, |l| gone.contains(&l.id()), "left");
        let now = Instant::now();
        self.drop_links(todo, |l| overdue(l, now), "missed its deadline");
        Ok(())
    }

    /// Forgets the links `gone` picks, putting their chunks back first.
    fn drop_links(
        &mut self,
        todo: &mut VecDeque<usize>,
        gone: impl Fn(&T::Link) -> bool,
        why: &str,
    ) {
        let mut dropped = Vec::new();
        self.links.retain_mut(|link| {
            if !gone(link) {
                return true;
            }
            let chunks = link.abandon();
            for &chunk in chunks.iter().rev() {
                todo.push_front(chunk);
            }
            // A worker we stop trusting is told to leave and, if we
            // spawned it, killed (the next reap replaces it).
            link.shut_down();
            dropped.push((link.id(), link.pid(), !chunks.is_empty()));
            false
        });
        for (id, pid, requeued) in dropped {
            self.children.kill(pid);
            self.dropped.insert(id);
            let then = if requeued {
                "; its chunks go to other workers"
            } else {
                ""
            };
            (self.say)(&format!("worker {id:016x} {why}{then}"));
        }
    }

    /// Sleeps until a worker says something or the next deadline is due.
    fn sleep(&mut self) -> Result<(), EvalError> {
        let until_deadline = self
            .links
            .iter()
            .filter_map(|l| l.deadline())
            .min()
            .map(|d| d.saturating_duration_since(Instant::now()));
        let slice = until_deadline.map_or(SLICE, |d| d.min(SLICE));
        self.transport.sleep(slice)
    }

    fn tell_waiting(&mut self) {
        if self.links.is_empty() && self.opts.spawn == 0 && !self.told_waiting {
            (self.say)(&format!(
                "waiting for workers: start them with `lander-worker --run {}{}`",
                self.opts.run_id,
                self.transport
                    .worker_args()
                    .iter()
                    .map(|a| format!(" {a}"))
                    .collect::<String>()
            ));
            self.told_waiting = true;
        }
    }
}

/// The CPUs to pin `opts.spawn` workers to: one each, or none at all when
/// pinning is off or there are fewer CPUs than workers.
fn cpus_for(opts: &PoolOptions) -> Vec<usize> {
    let cpus = lander_protocol::host::allowed_cpus();
    if !opts.pin || opts.spawn == 0 || opts.spawn > cpus.len() {
        return Vec::new();
    }
    cpus[..opts.spawn].to_vec()
}

/// Splits `n` genomes into about `parts` contiguous chunks, largest first,
/// for `workers` workers. The chunks are dealt round-robin, so each round of
/// them is smaller than the last (with four chunks each, 4, 3, 2 and 1
/// tenths of a worker's share): a worker that finishes early then waits
/// for a small chunk rather than a large one, and the chunk it takes back
/// from a busy worker is small too. Measured against equal chunks, 28
/// alternated `lander bench` runs: ipc efficiency better in 18, scaling in 19.
fn chunks(n: usize, parts: usize, workers: usize) -> Vec<Range<usize>> {
    let (parts, workers) = (parts.clamp(1, n.max(1)), workers.max(1));
    let rounds = parts.div_ceil(workers);
    let weights: Vec<usize> = (0..parts).map(|j| rounds - j / workers).collect();
    let total: usize = weights.iter().sum();
    let mut ranges = Vec::with_capacity(parts);
    let (mut weight, mut start) = (0, 0);
    for w in weights {
        weight += w;
        let end = (n * weight + total / 2) / total;
        if end > start {
            ranges.push(start..end);
            start = end;
        }
    }
    ranges
}

/// One job for the pool: its header (the job id is filled in when sent),
/// its genes, and whether the pool's deadline applies to it.
pub struct Job {
    pub header: JobHeader,
    pub genes: Vec<WireGene>,
    /// A whole Q(λ) trial may rightly take minutes, so only evaluation
    /// chunks have deadlines; a dead trainer is still found by its exit or
    /// its node's death.
    pub timed: bool,
}

impl<T: Transport> Pool<T> {
    /// Runs every job on the workers and returns the answers in job order.
    /// `decode` checks and decodes the answer to job `i`; an answer it
    /// refuses costs its worker the link, and the job runs elsewhere.
    pub fn run_jobs<R>(
        &mut self,
        jobs: &[Job],
        decode: impl Fn(usize, &[u8]) -> Result<R, String>,
        mut finished: impl FnMut(usize, &R),
    ) -> Result<Vec<R>, EvalError> {
        let mut todo: VecDeque<usize> = (0..jobs.len()).collect();
        let mut done: Vec<Option<R>> = (0..jobs.len()).map(|_| None).collect();
        // Jobs with an answer in hand, decoded or not.
        let mut answered = vec![false; jobs.len()];
        let mut remaining = jobs.len();
        while remaining > 0 {
            if self.opts.stop.asked() {
                return Err(EvalError::Interrupted);
            }
            self.accept()?;
            self.reap(&mut todo)?;
            let fresh = self.collect(&mut answered);
            self.drop_links(&mut todo, |l| l.is_broken(), "disconnected");
            // A worker that ran dry gets more before anything is decoded:
            // decoding can wait, an idle worker should not.
            todo.retain(|&j| !answered[j]);
            self.rebalance(jobs, &mut todo);
            self.dispatch(jobs, &mut todo);
            let mut refused = false;
            for (worker, a) in fresh {
                match decode(a.job, &a.body) {
                    Ok(value) => {
                        finished(a.job, &value);
                        done[a.job] = Some(value);
                        remaining -= 1;
                    }
                    Err(e) => {
                        (self.say)(&format!("refusing a result from worker {worker:016x}: {e}"));
                        for link in self.links.iter_mut().filter(|l| l.id() == worker) {
                            link.break_off();
                        }
                        answered[a.job] = false;
                        todo.push_front(a.job);
                        refused = true;
                    }
                }
            }
            self.drop_links(&mut todo, |l| l.is_broken(), "disconnected");
            if remaining == 0 {
                break;
            }
            if self.links.is_empty() && self.children.is_empty() && self.opts.spawn > 0 {
                return Err(EvalError::NoWorkers {
                    respawns: self.opts.max_respawns,
                });
            }
            self.tell_waiting();
            // A refused job goes out again at once, not after a sleep.
            if !refused {
                self.sleep()?;
            }
        }
        Ok(done.into_iter().flatten().collect())
    }

    /// The answers that arrived, each with the worker that gave it, to jobs
    /// not answered before (a job run twice keeps its first answer);
    /// checked, not yet decoded.
    fn collect(&mut self, answered: &mut [bool]) -> Vec<(u64, Answer)> {
        let mut fresh = Vec::new();
        for link in &mut self.links {
            let (answers, refused) = link.poll();
            if let Some(e) = refused {
                (self.say)(&format!(
                    "refusing a result from worker {:016x}: {e}",
                    link.id()
                ));
            }
            for a in answers {
                if let Some(t) = &mut self.timings {
                    t.push(a.timing);
                }
                if !std::mem::replace(&mut answered[a.job], true) {
                    fresh.push((link.id(), a));
                }
            }
        }
        fresh
    }
}

impl<T: Transport> Pool<T> {
    /// Once nothing is left to hand out, gives each idle worker the last
    /// queued chunk of the worker with the longest backlog. Chunks of one
    /// generation cost unevenly (one lander crashes at once, another flies
    /// its whole plan), so without this a worker that drew cheap chunks
    /// would wait for one that drew dear ones.
    fn rebalance(&mut self, jobs: &[Job], todo: &mut VecDeque<usize>) {
        if !todo.is_empty() {
            return;
        }
        for idle in 0..self.links.len() {
            if self.links[idle].in_flight() > 0 || !self.links[idle].has_room() {
                continue;
            }
            // Two or more in flight: one being flown, the last one queued.
            let backlog = self
                .links
                .iter_mut()
                .filter(|l| l.in_flight() >= 2)
                .max_by_key(|l| l.in_flight());
            let Some(job) = backlog.and_then(|l| l.take_back()) else {
                break;
            };
            self.taken_back += 1;
            self.hand(idle, jobs, job, todo);
        }
    }

    /// Sends queued jobs to workers with room, one per worker per pass, so
    /// that a generation of few chunks is spread over every worker rather
    /// than queued at the first. Workers are told after the first pass, so
    /// that their waking up overlaps the rest of the hand-out, and again
    /// at the end.
    fn dispatch(&mut self, jobs: &[Job], todo: &mut VecDeque<usize>) {
        let mut sent = true;
        let mut pass = 0;
        while sent && !todo.is_empty() {
            if pass == 1 {
                self.notify_all();
            }
            pass += 1;
            sent = false;
            for i in 0..self.links.len() {
                if !self.links[i].has_room() {
                    continue;
                }
                let Some(job) = todo.pop_front() else { break };
                sent |= self.hand(i, jobs, job, todo);
            }
        }
        self.notify_all();
    }

    /// Sends job `job` to link `i` under a fresh job id; if it cannot be
    /// sent, the job goes back at the head of `todo`.
    fn hand(&mut self, i: usize, jobs: &[Job], job: usize, todo: &mut VecDeque<usize>) -> bool {
        let mut header = jobs[job].header;
        header.job_id = self.next_job;
        self.next_job += 1;
        let deadline = jobs[job].timed.then_some(self.opts.deadline);
        let link = &mut self.links[i];
        match link.send(header, &jobs[job].genes, job, deadline) {
            Ok(()) => true,
            Err(e) => {
                (self.say)(&format!("cannot send to worker {:016x}: {e}", link.id()));
                todo.push_front(job);
                false
            }
        }
    }

    /// Tells every worker about the jobs sent to it since it was last told.
    fn notify_all(&mut self) {
        for link in &mut self.links {
            if let Err(e) = link.notify() {
                // Its jobs go elsewhere when the broken link is dropped.
                (self.say)(&format!("cannot notify worker {:016x}: {e}", link.id()));
            }
        }
    }
}

impl<T: Transport> Trainer for Pool<T> {
    /// One job per trial, with no deadline: a dead trainer is still found
    /// by its exit or its node's death.
    fn train(
        &mut self,
        trials: &[TrainJob],
        done: &mut dyn FnMut(usize, &TrainResult),
    ) -> Result<Vec<TrainResult>, EvalError> {
        let jobs: Vec<Job> = trials
            .iter()
            .map(|t| Job {
                header: JobHeader {
                    version: PROTOCOL_VERSION,
                    kind: KIND_TRAIN,
                    key: t.key,
                    env: t.env,
                    guide: t.guide,
                    learn: t.learn,
                    ..JobHeader::default()
                },
                genes: Vec::new(),
                timed: false,
            })
            .collect();
        self.run_jobs(
            &jobs,
            |i, body| decode_training(body, trials[i].learn.episodes).map_err(|e| e.to_string()),
            done,
        )
    }
}

impl<T: Transport> Evaluator for Pool<T> {
    fn evaluate_many(
        &mut self,
        mut batches: Vec<Batch<'_>>,
    ) -> Result<Vec<Vec<Evaluation>>, EvalError> {
        let workers = self.links.len().max(self.opts.spawn).max(1);
        // About `chunks_per_worker` chunks per worker in all, however many
        // batches share them.
        let per_batch = (workers * self.opts.chunks_per_worker).div_ceil(batches.len().max(1));
        let mut jobs = Vec::new();
        // For each job: its batch, the genomes it covers, their length.
        let mut spans = Vec::new();
        for (b, batch) in batches.iter().enumerate() {
            let length = batch.genomes.first().map_or(0, Vec::len);
            if batch.genomes.iter().any(|g| g.len() != length) {
                return Err(EvalError::Ragged);
            }
            for range in chunks(batch.genomes.len(), per_batch, workers) {
                jobs.push(chunk_job(batch, range.clone(), length));
                spans.push((b, range, length, batch.method));
            }
        }
        // The guided actions go back into the genomes as each answer
        // arrives, while other workers still fly: at a generation's end
        // only the last answers' are left to write.
        let results = self.run_jobs(
            &jobs,
            |i, body| {
                let (_, range, length, method) = &spans[i];
                ChunkResult::decode(body, *method, range.len(), *length).map_err(|e| e.to_string())
            },
            |i, result| {
                let (b, range, _, _) = &spans[i];
                write_back(&mut batches[*b].genomes[range.clone()], &result.actions);
            },
        )?;
        let mut evaluations: Vec<Vec<Evaluation>> = batches
            .iter()
            .map(|b| Vec::with_capacity(b.genomes.len()))
            .collect();
        for ((b, _, _, _), result) in spans.iter().zip(results) {
            evaluations[*b].extend(result.evaluations);
        }
        Ok(evaluations)
    }
}

/// The job that flies `range` of a batch's genomes.
fn chunk_job(batch: &Batch<'_>, range: Range<usize>, length: usize) -> Job {
    let genomes = &batch.genomes[range.clone()];
    Job {
        header: JobHeader {
            version: PROTOCOL_VERSION,
            kind: KIND_EVALUATE,
            method: batch.method.code(),
            key: batch.key,
            first_index: range.start as u64,
            genomes: genomes.len() as u32,
            genome_length: length as u32,
            max_duration: u32::from(batch.max_duration),
            env: batch.env,
            guide: batch.guide,
            ..JobHeader::default()
        },
        genes: wire_genes(genomes, length),
        timed: true,
    }
}

/// The genes of `genomes`, each `length` long, end to end. Genome by genome
/// rather than through one flattening iterator: this runs for every genome
/// of every generation, and the flattening version profiled at 14% of the
/// coordinator's time in one.
fn wire_genes(genomes: &[crate::ga::Genome], length: usize) -> Vec<WireGene> {
    let mut genes = Vec::with_capacity(genomes.len() * length);
    for genome in genomes {
        genes.extend(genome.iter().map(|&g| WireGene::from(g)));
    }
    genes
}

/// Writes the guided pass's actions into the genomes it rewrote. A chunk
/// of the general GA brings no actions, and leaves its genomes alone.
fn write_back(genomes: &mut [crate::ga::Genome], actions: &[u8]) {
    let length = genomes.first().map_or(0, Vec::len).max(1);
    for (genome, actions) in genomes.iter_mut().zip(actions.chunks(length)) {
        for (gene, &a) in genome.iter_mut().zip(actions) {
            // Checked on decoding: every action is 0..=3.
            gene.action = Action::from_index(a).unwrap_or(gene.action);
        }
    }
}

impl<T: Transport> Drop for Pool<T> {
    fn drop(&mut self) {
        for link in &self.links {
            link.shut_down();
        }
        self.await_leaving(self.transport.farewell());
        self.children.stop_all();
        self.transport.close();
    }
}

impl<T: Transport> Pool<T> {
    /// Waits at most `grace` for every worker to be seen going.
    fn await_leaving(&mut self, grace: Duration) {
        let mut staying: HashSet<u64> = self.links.iter().map(WorkerLink::id).collect();
        let end = Instant::now() + grace;
        while !staying.is_empty() {
            let left = end.saturating_duration_since(Instant::now());
            if left.is_zero() || self.transport.sleep(left).is_err() {
                break;
            }
            for id in self.transport.departures() {
                staying.remove(&id);
            }
        }
    }
}

/// Checks a response against the job it answers and returns its body.
fn check(job_id: u64, h: &ResultHeader, body: &[u8]) -> Result<Vec<u8>, String> {
    if h.version != PROTOCOL_VERSION {
        return Err(WireError::Version { got: h.version }.to_string());
    }
    if h.job_id != job_id {
        return Err(format!(
            "answer to job {} while job {job_id} was asked",
            h.job_id
        ));
    }
    match Status::from_code(h.status) {
        Some(Status::Done) => Ok(body.to_vec()),
        Some(status) => Err(format!(
            "the worker refused the job ({status:?}): {}",
            String::from_utf8_lossy(body)
        )),
        None => Err(format!("unknown status {}", h.status)),
    }
}

#[cfg(test)]
mod tests {
    use super::chunks;

    #[test]
    fn chunks_cover_everything_once_in_order() {
        for (n, parts, workers) in [
            (100, 8, 2),
            (100, 1, 1),
            (7, 20, 2),
            (1, 4, 1),
            (0, 3, 2),
            (10_000, 12, 3),
            (100, 3, 8),
        ] {
            let c = chunks(n, parts, workers);
            let flat: Vec<usize> = c.iter().flat_map(|r| r.clone()).collect();
            assert_eq!(flat, (0..n).collect::<Vec<_>>(), "n={n} parts={parts}");
            assert!(c.len() <= parts.max(1));
        }
    }

    #[test]
    fn each_round_of_chunks_is_smaller_than_the_last() {
        // Two workers, four chunks each: weights 4, 4, 3, 3, 2, 2, 1, 1 of 20.
        let sizes: Vec<usize> = chunks(100, 8, 2).iter().map(|r| r.len()).collect();
        assert_eq!(sizes, [20, 20, 15, 15, 10, 10, 5, 5]);
        // Each worker's share is still even: 20 + 15 + 10 + 5 = 50.
        let one: Vec<usize> = chunks(100, 4, 1).iter().map(|r| r.len()).collect();
        assert_eq!(one, [40, 30, 20, 10]);
    }

    /// A pool over made-up links: no processes, no transport.
    mod fake {
        use super::super::*;

        /// Records what it is sent; with an `answer`, answers every job
        /// with it at the next poll, or, if it `fails_checks`, all but the
        /// last, whose answer fails the link's own checks and breaks it.
        pub struct Recorder {
            pub id: u64,
            pub jobs: Vec<usize>,
            pub answer: Option<Vec<u8>>,
            pub fails_checks: bool,
            pub broken: bool,
        }

        impl Recorder {
            pub fn holding(id: u64, jobs: Vec<usize>) -> Recorder {
                Recorder {
                    id,
                    jobs,
                    answer: None,
                    fails_checks: false,
                    broken: false,
                }
            }
        }

        impl WorkerLink for Recorder {
            fn id(&self) -> u64 {
                self.id
            }
            fn pid(&self) -> u32 {
                0
            }
            fn has_room(&self) -> bool {
                self.jobs.len() < DEPTH && !self.broken
            }
            fn is_broken(&self) -> bool {
                self.broken
            }
            fn deadline(&self) -> Option<Instant> {
                None
            }
            fn abandon(&mut self) -> Vec<usize> {
                std::mem::take(&mut self.jobs)
            }
            fn in_flight(&self) -> usize {
                self.jobs.len()
            }
            fn take_back(&mut self) -> Option<usize> {
                self.jobs.pop()
            }
            fn send(
                &mut self,
                _: JobHeader,
                _: &[WireGene],
                job: usize,
                _: Option<Duration>,
            ) -> Result<(), String> {
                self.jobs.push(job);
                Ok(())
            }
            fn poll(&mut self) -> (Vec<Answer>, Option<String>) {
                let Some(body) = &self.answer else {
                    return (Vec::new(), None);
                };
                let timing = ChunkTiming {
                    worker: self.id,
                    sent_ns: 0,
                    read_ns: 0,
                    started_ns: 0,
                    finished_ns: 0,
                };
                let keep = usize::from(self.fails_checks && !self.jobs.is_empty());
                let good = self.jobs.len() - keep;
                let answers = self
                    .jobs
                    .drain(..good)
                    .map(|job| Answer {
                        job,
                        body: body.clone(),
                        timing,
                    })
                    .collect();
                if keep == 0 {
                    return (answers, None);
                }
                // As a real link: the refused job stays in flight, to be
                // put back when the broken link is dropped.
                self.broken = true;
                (answers, Some("answer to the wrong job".into()))
            }
            fn break_off(&mut self) {
                self.broken = true;
            }
            fn shut_down(&self) {}
        }

        pub struct Nowhere;

        impl Transport for Nowhere {
            type Link = Recorder;
            fn arrivals(&mut self) -> Result<Vec<Arrival>, EvalError> {
                Ok(Vec::new())
            }
            fn connect(&mut self, _: &Arrival) -> Result<Recorder, String> {
                Err("no".into())
            }
            fn departures(&mut self) -> Vec<u64> {
                Vec::new()
            }
            fn sleep(&mut self, _: Duration) -> Result<(), EvalError> {
                Ok(())
            }
            fn worker_args(&self) -> Vec<String> {
                Vec::new()
            }
            fn close(&mut self) {}
        }

        pub fn pool(links: Vec<Recorder>, say: Say) -> Pool<Nowhere> {
            let opts = PoolOptions {
                run_id: "t".into(),
                spawn: 0,
                worker_exe: PathBuf::new(),
                chunks_per_worker: 1,
                deadline: Duration::from_secs(1),
                max_respawns: 0,
                pin: false,
                stop: Stop::new(),
            };
            let mut pool = Pool::with_transport(Nowhere, opts, say).unwrap();
            pool.links = links;
            pool
        }

        pub fn no_jobs(n: usize) -> Vec<Job> {
            (0..n)
                .map(|_| Job {
                    header: JobHeader::default(),
                    genes: Vec::new(),
                    timed: true,
                })
                .collect()
        }
    }

    /// `dispatch` alone, over links that only record what they are sent.
    mod dispatch {
        use super::super::*;
        use super::fake::{no_jobs, Nowhere, Recorder};

        fn pool(links: Vec<Vec<usize>>) -> Pool<Nowhere> {
            let links = (0..)
                .zip(links)
                .map(|(id, jobs)| Recorder::holding(id, jobs));
            super::fake::pool(links.collect(), Box::new(|_| ()))
        }

        /// Which jobs each of `workers` links is sent, from `n` queued.
        fn spread(workers: usize, n: usize) -> (Vec<Vec<usize>>, usize) {
            let mut pool = pool(vec![Vec::new(); workers]);
            let jobs = no_jobs(n);
            let mut todo: VecDeque<usize> = (0..n).collect();
            pool.dispatch(&jobs, &mut todo);
            let sent = pool.links.iter().map(|l| l.jobs.clone()).collect();
            (sent, todo.len())
        }

        #[test]
        fn few_chunks_go_one_to_each_worker() {
            assert_eq!(spread(2, 2), (vec![vec![0], vec![1]], 0));
            assert_eq!(spread(3, 2), (vec![vec![0], vec![1], vec![]], 0));
        }

        #[test]
        fn many_chunks_fill_every_queue_and_wait() {
            assert_eq!(DEPTH, 4, "the cases below assume four queued per worker");
            assert_eq!(spread(2, 12), (vec![vec![0, 2, 4, 6], vec![1, 3, 5, 7]], 4));
            assert_eq!(spread(0, 3), (vec![], 3));
        }

        /// What each link holds after one rebalancing, and what is queued.
        fn rebalanced(links: Vec<Vec<usize>>, todo: &[usize]) -> (Vec<Vec<usize>>, Vec<usize>) {
            let mut pool = pool(links);
            let jobs = no_jobs(6);
            let mut todo: VecDeque<usize> = todo.iter().copied().collect();
            pool.rebalance(&jobs, &mut todo);
            let held = pool.links.iter().map(|l| l.jobs.clone()).collect();
            (held, todo.into())
        }

        #[test]
        fn an_idle_worker_takes_the_last_queued_chunk_of_the_busiest() {
            assert_eq!(
                rebalanced(vec![vec![], vec![1, 3], vec![0, 2, 4]], &[]),
                (vec![vec![4], vec![1, 3], vec![0, 2]], vec![])
            );
            assert_eq!(
                rebalanced(vec![vec![], vec![], vec![0, 2, 4]], &[]),
                (vec![vec![4], vec![2], vec![0]], vec![])
            );
        }

        #[test]
        fn nothing_moves_while_chunks_wait_or_no_one_has_a_backlog() {
            let waiting = rebalanced(vec![vec![], vec![0, 1, 2]], &[3]);
            assert_eq!(waiting, (vec![vec![], vec![0, 1, 2]], vec![3]));
            let flying = rebalanced(vec![vec![], vec![0], vec![1]], &[]);
            assert_eq!(flying, (vec![vec![], vec![0], vec![1]], vec![]));
            let busy = rebalanced(vec![vec![5], vec![0, 1, 2]], &[]);
            assert_eq!(busy, (vec![vec![5], vec![0, 1, 2]], vec![]));
        }
    }

    /// `run_jobs` over links that answer at once, one of them with
    /// answers that fail to decode.
    mod refusals {
        use super::fake::{no_jobs, pool, Recorder};
        use std::sync::{Arc, Mutex};

        #[test]
        fn a_refused_answer_costs_its_worker_and_the_job_runs_elsewhere() {
            let said = Arc::new(Mutex::new(Vec::<String>::new()));
            let log = said.clone();
            let links = [(7, b"garbage"), (8, b"fine!!!")]
                .into_iter()
                .map(|(id, body)| Recorder {
                    answer: Some(body.to_vec()),
                    ..Recorder::holding(id, Vec::new())
                })
                .collect();
            let say = Box::new(move |m: &str| log.lock().unwrap().push(m.to_string()));
            let mut pool = pool(links, say);
            let decode = |i: usize, body: &[u8]| match body {
                b"fine!!!" => Ok(i * 10),
                _ => Err("does not decode".to_string()),
            };
            let mut seen = Vec::new();
            let results = pool
                .run_jobs(&no_jobs(6), decode, |i, _| seen.push(i))
                .unwrap();
            assert_eq!(results, [0, 10, 20, 30, 40, 50]);
            seen.sort_unstable();
            assert_eq!(seen, [0, 1, 2, 3, 4, 5], "each job finished once");
            let ids: Vec<u64> = pool.links.iter().map(|l| l.id).collect();
            assert_eq!(ids, [8], "the worker that answered badly is dropped");
            assert!(pool.dropped.contains(&7));
            let said = said.lock().unwrap();
            assert!(
                said.iter()
                    .any(|m| m.contains("0000000000000007") && m.contains("does not decode")),
                "{said:?}"
            );
        }

        #[test]
        fn a_link_that_fails_its_checks_keeps_its_good_answers() {
            let links = [(7, true), (8, false)]
                .into_iter()
                .map(|(id, fails_checks)| Recorder {
                    answer: Some(b"fine".to_vec()),
                    fails_checks,
                    ..Recorder::holding(id, Vec::new())
                })
                .collect();
            let mut pool = pool(links, Box::new(|_| ()));
            pool.record_timings();
            let mut seen = Vec::new();
            let results = pool
                .run_jobs(&no_jobs(8), |i, _| Ok::<_, String>(i), |i, _| seen.push(i))
                .unwrap();
            assert_eq!(results, (0..8).collect::<Vec<_>>());
            // Worker 7 was dealt four jobs and answered three well before
            // the fourth failed: those three are not flown again.
            let answers = pool.take_timings();
            assert_eq!(answers.len(), 8, "no job flown twice");
            assert_eq!(answers.iter().filter(|t| t.worker == 7).count(), 3);
            seen.sort_unstable();
            assert_eq!(seen, (0..8).collect::<Vec<_>>(), "each job finished once");
            let ids: Vec<u64> = pool.links.iter().map(|l| l.id).collect();
            assert_eq!(ids, [8]);
        }
    }

    mod answers {
        use super::super::*;
        use lander_model::{Evaluation, Outcome, State};
        use lander_protocol::wire::ChunkResult;

        fn header(version: u32, status: Status, job_id: u64) -> ResultHeader {
            ResultHeader {
                version,
                status: status as u32,
                job_id,
                ..ResultHeader::default()
            }
        }

        fn body() -> Vec<u8> {
            let e = Evaluation {
                outcome: Outcome {
                    state: State {
                        x: 1.0,
                        y: 60.0,
                        vx: 0.0,
                        vy: -0.1,
                        rot: 0.0,
                    },
                    ticks: 10,
                    n: 10,
                    touched_down: true,
                    safe: false,
                    fitness: 700.0,
                },
                simulated_ticks: 10,
            };
            ChunkResult {
                evaluations: vec![e],
                actions: Vec::new(),
            }
            .encode()
        }

        #[test]
        fn a_good_answer_passes() {
            let h = header(PROTOCOL_VERSION, Status::Done, 7);
            assert_eq!(check(7, &h, &body()), Ok(body()));
        }

        #[test]
        fn answers_it_cannot_check_are_refused_with_the_reason() {
            let other = header(PROTOCOL_VERSION + 1, Status::Done, 7);
            let e = check(7, &other, &body()).unwrap_err();
            assert!(e.contains("protocol version"), "{e}");
            let wrong_job = header(PROTOCOL_VERSION, Status::Done, 8);
            assert!(check(7, &wrong_job, &body()).unwrap_err().contains("job 8"));
            let refused = header(PROTOCOL_VERSION, Status::WrongVersion, 7);
            let e = check(7, &refused, b"speaks version 9").unwrap_err();
            assert!(
                e.contains("refused") && e.contains("speaks version 9"),
                "{e}"
            );
        }
    }

    /// A worker this pool started that speaks another protocol version.
    mod versions {
        use super::super::*;
        use std::io::Write;
        use std::os::unix::fs::PermissionsExt;

        /// Announces whichever process wrote its pid to `pid_file`, with
        /// a version this build does not speak.
        struct OtherBuild {
            pid_file: PathBuf,
        }

        impl Transport for OtherBuild {
            type Link = super::fake::Recorder;
            fn arrivals(&mut self) -> Result<Vec<Arrival>, EvalError> {
                let pid = std::fs::read_to_string(&self.pid_file).unwrap_or_default();
                Ok(pid
                    .trim()
                    .parse()
                    .ok()
                    .into_iter()
                    .map(|pid| Arrival {
                        id: 1,
                        pid,
                        version: PROTOCOL_VERSION + 1,
                    })
                    .collect())
            }
            fn connect(&mut self, _: &Arrival) -> Result<Self::Link, String> {
                Err("never asked: the version is refused first".into())
            }
            fn departures(&mut self) -> Vec<u64> {
                Vec::new()
            }
            fn sleep(&mut self, max: Duration) -> Result<(), EvalError> {
                std::thread::sleep(max.min(Duration::from_millis(5)));
                Ok(())
            }
            fn worker_args(&self) -> Vec<String> {
                Vec::new()
            }
            fn close(&mut self) {}
        }

        #[test]
        fn a_spawned_worker_of_another_build_ends_the_wait_at_once() {
            let dir = tempfile::tempdir().unwrap();
            let pid_file = dir.path().join("pid");
            let exe = dir.path().join("lander-worker");
            let mut script = std::fs::File::create(&exe).unwrap();
            writeln!(
                script,
                "#!/bin/sh\necho $$ > {}\nexec sleep 60",
                pid_file.display()
            )
            .unwrap();
            drop(script);
            std::fs::set_permissions(&exe, std::fs::Permissions::from_mode(0o755)).unwrap();
            let opts = PoolOptions {
                run_id: "t".into(),
                spawn: 1,
                worker_exe: exe.clone(),
                chunks_per_worker: 1,
                deadline: Duration::from_secs(1),
                max_respawns: 0,
                pin: false,
                stop: Stop::new(),
            };
            let mut pool =
                Pool::with_transport(OtherBuild { pid_file }, opts, Box::new(|_| ())).unwrap();
            let started = Instant::now();
            let e = pool
                .wait_for_workers(1, Duration::from_secs(60))
                .unwrap_err();
            assert!(
                matches!(&e, EvalError::WorkerVersion { got, .. } if *got == PROTOCOL_VERSION + 1),
                "{e}"
            );
            let message = e.to_string();
            assert!(
                message.contains(&exe.display().to_string())
                    && message.contains("different builds"),
                "{message}"
            );
            // Refused at its announcement, not after the patience ran out,
            // and its process killed rather than waited for.
            assert!(started.elapsed() < Duration::from_secs(30));
            let before_drop = Instant::now();
            drop(pool);
            assert!(before_drop.elapsed() < Duration::from_secs(4));
        }
    }
}
