//! One genome under one method: what a worker does for each genome of a job.

use crate::guide::guide_in_place;
use crate::sim::{fly, Physics};
use crate::stream::streams;
use crate::{Env, Evaluation, Gene, GuideParams, Pass, StreamKey};

/// Evaluates `genes` in place. Under `Guided` the genes are first improved
/// by the evolve pass, whose draws come from the stream of
/// `(key, index)`; the flight then continues from where the pass left it.
pub fn evaluate(
    env: &Env,
    method: Pass,
    guide: &GuideParams,
    key: StreamKey,
    index: u64,
    genes: &mut [Gene],
) -> Evaluation {
    match method {
        Pass::Fly => {
            let outcome = fly(env, genes);
            Evaluation {
                outcome,
                simulated_ticks: u64::from(outcome.ticks),
            }
        }
        Pass::Guide => {
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
