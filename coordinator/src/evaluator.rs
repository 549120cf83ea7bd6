//! Who flies a generation. [`Evaluator`] is the seam between the trial loop
//! and the transports; [`InProcess`] is the embedded default, a rayon pool.

use crate::ga::Genome;
use lander_protocol::iox::IpcError;
use lander_protocol::{Env, GuideParams, Method, StreamKey};
use lander_worker::{evaluate, Evaluation};
use rayon::prelude::*;

/// One generation's worth of work. Genome `i` uses the guided-pass stream
/// `(key, i)`, so the results do not depend on who flies which genome.
pub struct Batch<'a> {
    pub env: Env,
    pub method: Method,
    pub guide: GuideParams,
    pub key: StreamKey,
    /// The largest duration a gene may have.
    pub max_duration: u8,
    /// Rewritten in place by the guided pass.
    pub genomes: &'a mut [Genome],
}

#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    #[error("cannot start {threads} evaluation threads: {reason}")]
    Threads { threads: usize, reason: String },
    #[error(transparent)]
    Ipc(#[from] IpcError),
    #[error("cannot start the worker {exe}: {reason} (build it with `cargo build --release -p lander-worker`)")]
    Spawn { exe: String, reason: String },
    #[error("every worker died and the {respawns} respawns allowed are used up")]
    NoWorkers { respawns: usize },
    #[error("only {got} of {wanted} workers announced themselves within {secs} s")]
    WorkersLate {
        wanted: usize,
        got: usize,
        secs: u64,
    },
    #[error("the genomes of a generation differ in length")]
    Ragged,
}

/// Flies a batch and returns one evaluation per genome, in order.
pub trait Evaluator {
    fn evaluate(&mut self, batch: Batch<'_>) -> Result<Vec<Evaluation>, EvalError>;
}

/// Evaluation on this process's own threads.
pub struct InProcess {
    pool: rayon::ThreadPool,
}

impl InProcess {
    /// A pool of `threads` threads; 0 means one per core.
    pub fn new(threads: usize) -> Result<InProcess, EvalError> {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .thread_name(|i| format!("lander-eval-{i}"))
            .build()
            .map_err(|e| EvalError::Threads {
                threads,
                reason: e.to_string(),
            })?;
        Ok(InProcess { pool })
    }

    pub fn threads(&self) -> usize {
        self.pool.current_num_threads()
    }
}

impl Evaluator for InProcess {
    fn evaluate(&mut self, batch: Batch<'_>) -> Result<Vec<Evaluation>, EvalError> {
        let Batch {
            env,
            method,
            guide,
            key,
            genomes,
            ..
        } = batch;
        Ok(self.pool.install(|| {
            genomes
                .par_iter_mut()
                .enumerate()
                .map(|(i, g)| evaluate(&env, method, &guide, key, i as u64, g))
                .collect()
        }))
    }
}
