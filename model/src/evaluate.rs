//! One genome under one method: what a worker does for each genome of a job.

use crate::guide::{guide_in_place, guide_in_place_one_by_one, guide_lanes, Walk};
use crate::sim::{fly, Flight, Physics};
use crate::stream::streams;
use crate::{Env, Evaluation, Gene, GuideParams, Pass, StreamKey};
use rand_chacha::ChaCha8Rng;

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

type GuidePass = fn(&Env, &GuideParams, &mut [Gene], &mut ChaCha8Rng) -> (Flight, u64);

#[inline(always)]
fn guided(
    pass: GuidePass,
    env: &Env,
    guide: &GuideParams,
    key: StreamKey,
    index: u64,
    genes: &mut [Gene],
) -> Evaluation {
    let mut rng = key.rng(streams::guide(index));
    let (flight, looked_ahead) = pass(env, guide, genes, &mut rng);
    finish(env, flight, looked_ahead)
}

/// Evaluates every genome `genomes` yields in place, as [`evaluate`]
/// evaluates each: `(env, index, genes)` under the stream of
/// `(key, index)`, and shows `done` each one's index, genes and
/// evaluation as it is evaluated. The guided pass walks the genomes
/// several at a time ([`guide_lanes`]), which gives the same results
/// faster, and in another order: a genome is taken from `genomes` when
/// there is room for it, and shown to `done` when its walk ends.
pub fn evaluate_each<G: AsMut<[Gene]>>(
    pass: Pass,
    guide: &GuideParams,
    key: StreamKey,
    genomes: impl IntoIterator<Item = (Env, u64, G)>,
    done: &mut dyn FnMut(u64, G, Evaluation),
) {
    match pass {
        Pass::Fly => {
            for (env, index, mut genes) in genomes {
                let evaluation = evaluate(&env, pass, guide, key, index, genes.as_mut());
                done(index, genes, evaluation);
            }
        }
        Pass::Guide => {
            let walks = genomes.into_iter().map(|(env, index, genes)| Walk {
                env,
                index,
                genes,
                rng: key.rng(streams::guide(index)),
            });
            guide_lanes(guide, walks, &mut |walk, flight, looked_ahead| {
                done(
                    walk.index,
                    walk.genes,
                    finish(&walk.env, flight, looked_ahead),
                );
            });
        }
    }
}

/// [`evaluate_each`] over genomes indexed in order from `first`, their
/// evaluations returned in that order.
pub fn evaluate_many<'g>(
    pass: Pass,
    guide: &GuideParams,
    key: StreamKey,
    first: u64,
    genomes: impl IntoIterator<Item = (Env, &'g mut [Gene])>,
) -> Vec<Evaluation> {
    let mut evaluations = Vec::new();
    let indexed = genomes
        .into_iter()
        .zip(first..)
        .map(|((env, genes), index)| {
            evaluations.push(None);
            (env, index, genes)
        });
    let mut done = Vec::new();
    evaluate_each(pass, guide, key, indexed, &mut |index, _, evaluation| {
        done.push((index, evaluation));
    });
    for (index, evaluation) in done {
        evaluations[(index - first) as usize] = Some(evaluation);
    }
    evaluations.into_iter().flatten().collect()
}

/// The evaluation of a genome the guided pass left at `flight`, after
/// `looked_ahead` ticks of branches: the flight drifts on to its end.
fn finish(env: &Env, mut flight: Flight, looked_ahead: u64) -> Evaluation {
    let n = flight.ticks;
    flight.drift_to_end(&Physics::new(env));
    let outcome = flight.outcome(env, n);
    Evaluation {
        outcome,
        simulated_ticks: looked_ahead + u64::from(outcome.ticks - n),
    }
}
