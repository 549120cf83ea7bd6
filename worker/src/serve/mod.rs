//! The worker process's loop, over either transport: [`iceoryx`] for a
//! coordinator on this host, [`zenoh`] for one on any host. Both answer a
//! job the same way, with [`answer`].

pub mod iceoryx;
pub mod zenoh;

use lander_model::learn::run_training;
use lander_protocol::host::host_clock_ns;
use lander_protocol::wire::{
    self, ChunkResult, Job, JobHeader, ResultHeader, Status, WireError, WireGene, PROTOCOL_VERSION,
};

pub use iceoryx::serve;

use lander_telemetry::WorkerMetrics;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::OnceLock;
use std::time::Duration;

/// The worker's metrics, once `--metrics` turned them on.
static METRICS: OnceLock<WorkerMetrics> = OnceLock::new();

/// Counts every job from now on, and returns the metrics to serve.
pub fn count_jobs() -> &'static WorkerMetrics {
    METRICS.get_or_init(WorkerMetrics::new)
}

/// Counts a frame refused before it became a job.
pub fn count_rejected_frame() {
    if let Some(m) = METRICS.get() {
        m.rejected_frames.inc();
    }
}

/// Jobs this process has answered, refusals included: one worker per
/// process, so one count.
static ANSWERED: AtomicU64 = AtomicU64::new(0);

/// Jobs answered so far.
pub fn answered() -> u64 {
    ANSWERED.load(Ordering::Relaxed)
}

/// Set by the hidden `--lie` flag, for the tests of `--verify` only.
static LYING: AtomicBool = AtomicBool::new(false);

/// Makes this worker answer every evaluation with its fitness raised by
/// one: well-formed, plausible and wrong, as a worker with bad memory or
/// another build might answer. Only `lander run --verify` catches it.
pub fn start_lying() {
    LYING.store(true, Ordering::Relaxed);
}

fn lie(mut result: ChunkResult) -> ChunkResult {
    if LYING.load(Ordering::Relaxed) {
        for e in &mut result.evaluations {
            e.outcome.fitness += 1.0;
        }
    }
    result
}

/// Why a worker stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Exit {
    /// The coordinator told it to leave: the run is over, or it was
    /// dropped or refused.
    Told(lander_protocol::Farewell),
    /// The coordinator's node is gone.
    CoordinatorGone,
    /// SIGINT or SIGTERM.
    Signal,
}

/// What a worker tells its user.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Note {
    /// Progress: waiting, serving.
    Info,
    /// Something refused; always worth showing.
    Warning,
}

/// Runs one job and says how it went: the result's header and body (the
/// encoded result, or the reason for a refusal).
pub fn answer(
    header: &JobHeader,
    genes: &[WireGene],
    id: u64,
    say: &dyn Fn(Note, &str),
) -> (ResultHeader, Vec<u8>) {
    let started_ns = host_clock_ns();
    let (status, body) = match Job::from_wire(header, genes) {
        Ok(Job::Evaluate(job)) => (Status::Done, lie(job.run()).encode()),
        Ok(Job::Train(job)) => match run_training(&job) {
            Ok(result) => (Status::Done, wire::encode(&result)),
            Err(e) => {
                let why = format!("the leg's starting state does not fit its trial: {e}");
                say(
                    Note::Warning,
                    &format!("refusing job {}: {why}", header.job_id),
                );
                (Status::BadJob, why.into_bytes())
            }
        },
        Err(e) => {
            say(
                Note::Warning,
                &format!("refusing job {}: {e}", header.job_id),
            );
            let status = match e {
                WireError::Version { .. } => Status::WrongVersion,
                _ => Status::BadJob,
            };
            (status, e.to_string().into_bytes())
        }
    };
    ANSWERED.fetch_add(1, Ordering::Relaxed);
    let finished_ns = host_clock_ns();
    if let Some(m) = METRICS.get() {
        let done = status == Status::Done;
        let genomes = if done { u64::from(header.genomes) } else { 0 };
        let took = Duration::from_nanos(finished_ns.saturating_sub(started_ns));
        m.served(genomes, took, !done);
    }
    let result = ResultHeader {
        version: PROTOCOL_VERSION,
        status: status as u32,
        job_id: header.job_id,
        worker_id: id,
        started_ns,
        finished_ns,
    };
    (result, body)
}
