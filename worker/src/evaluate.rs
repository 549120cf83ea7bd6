//! One genome under one method: what a worker does for each genome of a job.

use crate::guide::guide_in_place;
use crate::sim::{fly, Physics};
use lander_protocol::stream::streams;
use lander_protocol::wire::{ChunkResult, EvalJob};
use lander_protocol::{Env, Evaluation, Gene, GuideParams, Method, StreamKey};

/// Evaluates `genes` in place. Under `Guided` the genes are first improved
/// by the evolve pass, whose draws come from the stream of
/// `(key, index)`; the flight then continues from where the pass left it.
pub fn evaluate(
    env: &Env,
    method: Method,
    guide: &GuideParams,
    key: StreamKey,
    index: u64,
    genes: &mut [Gene],
) -> Evaluation {
    match method {
        Method::Ga => {
            let outcome = fly(env, genes);
            Evaluation {
                outcome,
                simulated_ticks: u64::from(outcome.ticks),
            }
        }
        Method::Guided => {
            let mut rng = key.rng(streams::guide(index));
            let (mut flight, looked_ahead) = guide_in_place(env, guide, genes, &mut rng);
            let n = flight.ticks;
            flight.drift_to_end(&Physics::new(env));
            let outcome = flight.outcome(env, n);
            Evaluation {
                outcome,
                simulated_ticks: looked_ahead + u64::from(outcome.ticks - n),
            }
        }
    }
}

/// Evaluates every genome of a checked job, as a worker does.
pub fn run_job(job: EvalJob) -> ChunkResult {
    let mut genes = job.genes;
    let evaluations = genes
        .chunks_mut(job.genome_length)
        .enumerate()
        .map(|(i, g)| {
            let index = job.first_index + i as u64;
            evaluate(&job.env, job.method, &job.guide, job.key, index, g)
        })
        .collect();
    let actions = match job.method {
        Method::Guided => genes.iter().map(|g| g.action.index()).collect(),
        Method::Ga => Vec::new(),
    };
    ChunkResult {
        evaluations,
        actions,
    }
}
