//! The worker process's loop, over either transport: [`iceoryx`] for a
//! coordinator on this host, [`zenoh`] for one on any host. Both answer a
//! job the same way, with [`answer`].

pub mod iceoryx;
pub mod zenoh;

use lander_model::learn::run_training;
use lander_model::{evaluate, Pass};
use lander_protocol::host::host_clock_ns;
use lander_protocol::wire::{
    self, ChunkResult, EvalJob, Job, JobHeader, ResultHeader, Status, WireError, WireGene,
    PROTOCOL_VERSION,
};

pub use iceoryx::serve;

use std::sync::atomic::{AtomicU64, Ordering};

/// Jobs this process has answered, refusals included: one worker per
/// process, so one count.
static ANSWERED: AtomicU64 = AtomicU64::new(0);

/// Jobs answered so far.
pub fn answered() -> u64 {
    ANSWERED.load(Ordering::Relaxed)
}

/// Why a worker stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Exit {
    /// The coordinator said the run is over.
    RunFinished,
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
        Ok(Job::Evaluate(job)) => (Status::Done, run_job(job).encode()),
        Ok(Job::Train(job)) => (Status::Done, wire::encode(&run_training(&job))),
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
    let result = ResultHeader {
        version: PROTOCOL_VERSION,
        status: status as u32,
        job_id: header.job_id,
        worker_id: id,
        started_ns,
        finished_ns: host_clock_ns(),
    };
    (result, body)
}

/// Evaluates every genome of a checked job, writing back the actions the
/// guided pass chose.
fn run_job(job: EvalJob) -> ChunkResult {
    let mut genes = job.genes;
    let evaluations = genes
        .chunks_mut(job.genome_length)
        .enumerate()
        .map(|(i, g)| {
            let index = job.first_index + i as u64;
            evaluate(&job.env, job.pass, &job.guide, job.key, index, g)
        })
        .collect();
    let actions = match job.pass {
        Pass::Guide => genes.iter().map(|g| g.action.index()).collect(),
        Pass::Fly => Vec::new(),
    };
    ChunkResult {
        evaluations,
        actions,
    }
}
