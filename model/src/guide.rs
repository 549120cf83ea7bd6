//! The guided evolve pass (SPEC §4): walk an individual's genes from the
//! start state and, gene by gene, switch to the action whose resulting
//! state scores best under R.

use crate::score::{is_safe, reinforcement_pair};
use crate::sim::{Flight, Physics};
use crate::{Action, Env, Gene, GuideParams};
use rand::Rng;

/// Improves `genes` in place. Only actions change, never durations or the
/// length. Returns the flight as it stands after the last gene flown, which
/// is exactly the state that flying the new genome would reach there, and
/// the number of ticks simulated to find it.
pub fn guide_in_place(
    env: &Env,
    params: &GuideParams,
    genes: &mut [Gene],
    rng: &mut impl Rng,
) -> (Flight, u64) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx512f") {
        // SAFETY: the CPU has the feature the function is compiled for; it
        // was just asked.
        return unsafe { guide_avx512(env, params, genes, rng) };
    }
    guide_with(Flight::branch, env, params, genes, rng)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn guide_avx512(
    env: &Env,
    params: &GuideParams,
    genes: &mut [Gene],
    rng: &mut impl Rng,
) -> (Flight, u64) {
    guide_with(Flight::branch, env, params, genes, rng)
}

/// [`guide_in_place`] with each gene's four branches flown one after
/// another ([`Flight::branch_one_by_one`]): the oracle of the property
/// tests and the baseline of the benches.
pub fn guide_in_place_one_by_one(
    env: &Env,
    params: &GuideParams,
    genes: &mut [Gene],
    rng: &mut impl Rng,
) -> (Flight, u64) {
    guide_with(Flight::branch_one_by_one, env, params, genes, rng)
}

type Brancher = fn(&Flight, &Physics, u32, &mut [Flight; 4]) -> u64;

#[inline(always)]
fn guide_with(
    branch: Brancher,
    env: &Env,
    params: &GuideParams,
    genes: &mut [Gene],
    rng: &mut impl Rng,
) -> (Flight, u64) {
    let p = Physics::new(env);
    let mut flight = Flight::start(env);
    let mut simulated = 0u64;
    let mut options = [flight; 4];
    for gene in genes.iter_mut() {
        simulated += branch(&flight, &p, u32::from(gene.duration), &mut options);
        let best = best_action(env, params, &options);
        let chosen = &options[usize::from(best.index())];
        let safe = chosen.touched_down() && is_safe(env, &chosen.state);
        if safe || (best != gene.action && rng.random::<f64>() >= params.epsilon) {
            gene.action = best;
        }
        flight = options[usize::from(gene.action.index())];
        if flight.ended(&p) {
            break;
        }
    }
    (flight, simulated)
}

/// The guided pass as a function: `guide(env, params, genome, rng) -> genome'`.
pub fn guide(env: &Env, params: &GuideParams, genes: &[Gene], rng: &mut impl Rng) -> Vec<Gene> {
    let mut out = genes.to_vec();
    guide_in_place(env, params, &mut out, rng);
    out
}

/// The action whose resulting state maximises R; the lowest index on a tie.
fn best_action(env: &Env, params: &GuideParams, options: &[Flight; 4]) -> Action {
    let [r0, r1] = reinforcement_pair(env, params, &options[0].state, &options[1].state);
    let [r2, r3] = reinforcement_pair(env, params, &options[2].state, &options[3].state);
    let mut best = Action::RotateLeft;
    let mut best_r = f64::NEG_INFINITY;
    for (action, r) in Action::ALL.into_iter().zip([r0, r1, r2, r3]) {
        if r > best_r {
            best = action;
            best_r = r;
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::evaluate::evaluate;
    use crate::score::reinforcement;
    use crate::sim::fly;
    use crate::{Pass, StreamKey};
    use proptest::prelude::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use crate::test_env as env;

    fn arb_genome() -> impl Strategy<Value = Vec<Gene>> {
        proptest::collection::vec(
            (0u8..4, 0u8..=30).prop_map(|(a, d)| Gene::new(Action::from_index(a).unwrap(), d)),
            1..60,
        )
    }

    /// Walks the guided genome independently of the pass and returns, per
    /// gene flown, the options' best action and whether it was a safe landing.
    fn oracle(env: &Env, p: &GuideParams, guided: &[Gene]) -> Vec<(Action, bool)> {
        let mut at = crate::sim::Lander::new(env);
        let mut seen = Vec::new();
        for gene in guided {
            let mut best = (f64::NEG_INFINITY, Action::Drift, false);
            for a in Action::ALL {
                let mut o = at;
                o.run(a, u32::from(gene.duration));
                let r = reinforcement(env, p, &o.state());
                if r > best.0 {
                    best = (r, a, o.touched_down() && is_safe(env, &o.state()));
                }
            }
            seen.push((best.1, best.2));
            at.run(gene.action, u32::from(gene.duration));
            if at.ended() {
                break;
            }
        }
        seen
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(500))]

        #[test]
        fn never_changes_durations_or_length(
            genome in arb_genome(), eps in 0.0f64..=1.0, seed in any::<u64>(),
            x0 in 0.0f64..400.0, pad_x in 50.0f64..350.0,
        ) {
            let e = env(x0, pad_x);
            let p = GuideParams { epsilon: eps, ..GuideParams::default() };
            let out = guide(&e, &p, &genome, &mut ChaCha8Rng::seed_from_u64(seed));
            prop_assert_eq!(out.len(), genome.len());
            for (a, b) in out.iter().zip(&genome) {
                prop_assert_eq!(a.duration, b.duration);
            }
        }

        #[test]
        fn with_epsilon_zero_every_gene_flown_takes_the_best_action(
            genome in arb_genome(), x0 in 0.0f64..400.0, pad_x in 50.0f64..350.0,
        ) {
            let e = env(x0, pad_x);
            let p = GuideParams { epsilon: 0.0, ..GuideParams::default() };
            let out = guide(&e, &p, &genome, &mut ChaCha8Rng::seed_from_u64(0));
            let flown = oracle(&e, &p, &out);
            for (i, (best, _)) in flown.iter().enumerate() {
                prop_assert_eq!(out[i].action, *best, "gene {}", i);
            }
            // Genes after touchdown are left as they were.
            prop_assert_eq!(&out[flown.len()..], &genome[flown.len()..]);
        }

        #[test]
        fn the_guided_flight_equals_flying_the_guided_genome(
            genome in arb_genome(), seed in any::<u64>(), index in 0u64..100,
            x0 in 0.0f64..400.0, pad_x in 50.0f64..350.0,
        ) {
            let e = env(x0, pad_x);
            let mut genes = genome.clone();
            let key = StreamKey::new(seed, 0, 0, 1);
            let ev = evaluate(&e, Pass::Guide, &GuideParams::default(), key, index, &mut genes);
            prop_assert_eq!(ev.outcome, fly(&e, &genes));
            let again = guide(&e, &GuideParams::default(), &genome, &mut key.short_rng(crate::stream::streams::guide(index)));
            prop_assert_eq!(again, genes);
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(1000))]

        /// The pass with branches flown together equals the one-by-one
        /// pass in every gene, tick count and bit of the flight.
        #[test]
        fn the_pass_equals_the_one_by_one_pass(
            genome in arb_genome(), eps in 0.0f64..=1.0, seed in any::<u64>(),
            x0 in 0.0f64..400.0, pad_x in 50.0f64..350.0,
        ) {
            let e = env(x0, pad_x);
            let p = GuideParams { epsilon: eps, ..GuideParams::default() };
            let (mut fast, mut slow) = (genome.clone(), genome);
            let a = guide_in_place(&e, &p, &mut fast, &mut ChaCha8Rng::seed_from_u64(seed));
            let b = guide_in_place_one_by_one(&e, &p, &mut slow, &mut ChaCha8Rng::seed_from_u64(seed));
            prop_assert_eq!(fast, slow);
            prop_assert_eq!((a.0.state, a.0.ticks, a.0.touched_down(), a.1),
                            (b.0.state, b.0.ticks, b.0.touched_down(), b.1));
        }
    }

    #[test]
    fn with_epsilon_one_it_switches_only_to_a_safe_landing() {
        // Generous thresholds make safe landings common enough to offer.
        let mut e = env(200.0, 200.0);
        e.scoring.safe_distance = 400.0;
        e.scoring.safe_speed = 3.0;
        e.scoring.safe_rotation = 10.0;
        let p = GuideParams {
            epsilon: 1.0,
            ..GuideParams::default()
        };
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut taken = 0;
        for _ in 0..300 {
            let genome: Vec<Gene> = (0..50)
                .map(|_| {
                    Gene::new(
                        Action::ALL[rng.random_range(0..4)],
                        rng.random_range(1..=30),
                    )
                })
                .collect();
            let out = guide(&e, &p, &genome, &mut rng);
            for (i, (best, safe)) in oracle(&e, &p, &out).into_iter().enumerate() {
                if safe {
                    assert_eq!(out[i].action, best, "a safe landing on offer is taken");
                    taken += usize::from(genome[i].action != best);
                } else {
                    assert_eq!(
                        out[i].action, genome[i].action,
                        "ε = 1 never switches otherwise"
                    );
                }
            }
        }
        assert!(
            taken > 0,
            "the generous world offered no safe landing to take"
        );
    }
}
