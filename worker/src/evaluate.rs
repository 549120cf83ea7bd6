//! One genome under one method: what a worker does for each genome of a job.

use crate::guide::guide_in_place;
use crate::sim::{fly, Outcome};
use lander_protocol::stream::streams;
use lander_protocol::{Env, Gene, GuideParams, Method, StreamKey};

/// The result for one genome.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Evaluation {
    pub outcome: Outcome,
    /// Every tick simulated for this genome: the guided pass's look-aheads
    /// and the flight itself.
    pub simulated_ticks: u64,
}

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
            let (mut lander, looked_ahead) = guide_in_place(env, guide, genes, &mut rng);
            let n = lander.ticks;
            lander.drift_to_end();
            let outcome = lander.outcome(env, n);
            Evaluation {
                outcome,
                simulated_ticks: looked_ahead + u64::from(outcome.ticks - n),
            }
        }
    }
}
