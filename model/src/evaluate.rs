//! One genome under one method: what a worker does for each genome of a job.

use crate::guide::{guide_in_place, guide_in_place_one_by_one};
use crate::sim::{fly, Flight, Physics};
use crate::stream::{streams, ShortStreamRng};
use crate::{Env, Evaluation, Gene, GuideParams, Pass, StreamKey};

/// Evaluates `genes` in place. Under `Guided` the genes are first improved
/// by the evolve pass, whose draws come from the stream of
/// `(key, index)`; the flight then continues from where the pass left it.
pub fn evaluate(
    env: &Env,
    pass: Pass,
    guide: &GuideParams,
    key: StreamKey,
    index: u64,
    genes: &mut [Gene],
) -> Evaluation {
    match pass {
        Pass::Fly => {
            let outcome = fly(env, genes);
            Evaluation {
                outcome,
                simulated_ticks: u64::from(outcome.ticks),
            }
        }
        Pass::Guide => guided(guide_in_place, env, guide, key, index, genes),
    }
}

/// [`evaluate`] under [`Pass::Guide`], with the guided pass flying each
/// gene's four branches one after another: the baseline of the benches.
pub fn evaluate_guided_one_by_one(
    env: &Env,
    guide: &GuideParams,
    key: StreamKey,
    index: u64,
    genes: &mut [Gene],
) -> Evaluation {
    guided(guide_in_place_one_by_one, env, guide, key, index, genes)
}

type GuidePass = fn(&Env, &GuideParams, &mut [Gene], &mut ShortStreamRng) -> (Flight, u64);

#[inline(always)]
fn guided(
    pass: GuidePass,
    env: &Env,
    guide: &GuideParams,
    key: StreamKey,
    index: u64,
    genes: &mut [Gene],
) -> Evaluation {
    let mut rng = key.short_rng(streams::guide(index));
    let (mut flight, looked_ahead) = pass(env, guide, genes, &mut rng);
    let n = flight.ticks;
    flight.drift_to_end(&Physics::new(env));
    let outcome = flight.outcome(env, n);
    Evaluation {
        outcome,
        simulated_ticks: looked_ahead + u64::from(outcome.ticks - n),
    }
}
