//! Hand-computed cases from SPEC §1 and §2, and the fast simulation held to
//! the reference bit for bit.

use super::*;
use crate::GuideParams;
use crate::{reference, score};
use proptest::prelude::*;

const G: f64 = 1.63 / 60.0;
const A: f64 = (350.0 / 60.0) / 100.0;

use crate::test_env as env;

fn state(x: f64, y: f64, vx: f64, vy: f64, rot: f64) -> State {
    State { x, y, vx, vy, rot }
}

fn one_tick(action: Action) -> State {
    let e = env(200.0, 100.0);
    let mut l = Lander::new(&e);
    assert_eq!(l.run(action, 1), 1);
    l.state()
}

#[test]
fn start_state_is_upside_down_at_rest_fifty_below_the_top() {
    let l = Lander::new(&env(123.0, 100.0));
    assert_eq!(l.state(), state(123.0, 250.0, 0.0, 0.0, PI));
}

#[test]
fn one_tick_of_each_action_from_the_start() {
    assert_eq!(
        one_tick(Action::Drift),
        state(200.0, 250.0 - G, 0.0, -G, PI)
    );
    assert_eq!(
        one_tick(Action::RotateLeft),
        state(200.0, 250.0 - G, 0.0, -G, PI - 0.05)
    );
    assert_eq!(
        one_tick(Action::RotateRight),
        state(200.0, 250.0 - G, 0.0, -G, PI + 0.05)
    );
    // Upside down, thrust pushes straight down: vy = -a - g.
    let t = one_tick(Action::Thrust);
    assert_eq!(t.vy, -A - G);
    assert_eq!(t.y, 250.0 + (-A - G));
    assert_eq!(t.vx, A * PI.sin()); // sin(π) in floating point is 1.2e-16
    assert!((t.vy - (-0.058_333_333_333 - 0.027_166_666_667)).abs() < 1e-9);
}

#[test]
fn rotate_left_wraps_below_minus_pi() {
    let e = env(200.0, 100.0);
    let mut l = Lander::with_state(&e, state(200.0, 250.0, 0.0, 0.0, -PI + 0.01), 0);
    l.run(Action::RotateLeft, 1);
    assert_eq!(l.state().rot, (-PI + 0.01 - 0.05) + TAU);
    assert!((l.state().rot - (PI - 0.04)).abs() < 1e-12);
}

#[test]
fn rotate_right_wraps_only_above_two_pi() {
    let e = env(200.0, 100.0);
    let mut l = Lander::with_state(&e, state(200.0, 250.0, 0.0, 0.0, 6.2), 0);
    l.run(Action::RotateRight, 1);
    assert_eq!(
        l.state().rot,
        6.25,
        "6.25 < 2π: no wrap, upright yet 'badly rotated'"
    );
    l.run(Action::RotateRight, 1);
    assert_eq!(l.state().rot, 6.25 + 0.05 - TAU);
    assert!((l.state().rot - 0.016_814_692_820_4).abs() < 1e-9);
}

#[test]
fn x_wraps_at_both_edges_with_no_ceiling() {
    let e = env(200.0, 100.0);
    let mut l = Lander::with_state(&e, state(399.9, 250.0, 0.2, 0.0, PI), 0);
    l.run(Action::Drift, 1);
    assert_eq!(l.state().x, 0.0);
    let mut l = Lander::with_state(&e, state(0.1, 250.0, -0.2, 0.0, PI), 0);
    l.run(Action::Drift, 1);
    assert_eq!(l.state().x, 400.0);
    let mut l = Lander::with_state(&e, state(10.0, 1e6, 0.0, 5.0, PI), 0);
    l.run(Action::Drift, 1);
    assert!(l.state().y > 1e6, "nothing stops a lander flying up");
}

#[test]
fn upright_touchdown_comes_when_the_centre_drops_below_67() {
    let e = env(200.0, 100.0);
    // After one drift tick from rest the centre is at y0 - g.
    for (after, down) in [(67.001, false), (67.0, false), (66.999, true)] {
        let mut l = Lander::with_state(&e, state(200.0, after + G, 0.0, 0.0, 0.0), 0);
        l.run(Action::Drift, 1);
        assert!((l.state().y - after).abs() < 1e-9);
        assert_eq!(l.touched_down(), down, "centre at {after}");
        assert_eq!(reference::touches_ground(&e, &l.state()), down);
    }
}

#[test]
fn upside_down_touchdown_uses_the_top_of_the_hull() {
    // Upside down the cabin top (py = 1) is lowest: 10 px below the centre.
    let e = env(200.0, 100.0);
    let mut l = Lander::with_state(&e, state(200.0, 65.0 + G + 0.001, 0.0, 0.0, PI), 0);
    l.run(Action::Drift, 1);
    assert!(!l.touched_down());
    l.run(Action::Drift, 1);
    assert!(l.touched_down());
}

#[test]
fn fitness_worked_by_hand() {
    // dist 10, speed 5, rot 1, n 120: 390 + 400/2 + 4·120/6.
    let e = env(200.0, 100.0);
    let s = state(110.0, 60.0, 3.0, -4.0, 1.0);
    assert_eq!(score::fitness(&e, &s, 120, false), 390.0 + 200.0 + 80.0);
    assert_eq!(score::fitness(&e, &s, 120, true), 9_999_999.0);
}

#[test]
fn reinforcement_worked_by_hand() {
    let e = env(200.0, 100.0);
    let p = GuideParams::default();
    // alt 40: below h1 (×1.7), above h2 (airTime' = 1/(v+1)).
    let s = state(110.0, 95.0, 3.0, -4.0, 1.0);
    let expect = (390.0f64 * 390.0 + 260.0 * 260.0 / 3.0).sqrt() * 1.7 + 200.0 + 4.0 / 6.0;
    assert_eq!(score::reinforcement(&e, &p, &s), expect);
    assert!((expect - 911.082_272_726).abs() < 1e-6);
    // alt 20: below h2 too (airTime' = 1/(6v+1)).
    let s = state(110.0, 75.0, 3.0, -4.0, 1.0);
    assert!((score::reinforcement(&e, &p, &s) - 917.829_759_117).abs() < 1e-6);
    // alt 150: neither.
    let s = state(110.0, 205.0, 3.0, -4.0, 1.0);
    assert!((score::reinforcement(&e, &p, &s) - 600.166_353_775).abs() < 1e-6);
}

#[test]
fn each_safe_threshold_on_both_sides() {
    let e = env(200.0, 100.0);
    let ok = state(100.0, 60.0, 0.0, -0.3, 0.0);
    assert!(score::is_safe(&e, &ok));
    let cases = [
        (state(109.99, 60.0, 0.0, -0.3, 0.0), true),
        (state(110.0, 60.0, 0.0, -0.3, 0.0), false),
        (state(90.01, 60.0, 0.0, -0.3, 0.0), true),
        (state(100.0, 60.0, 0.3, -0.399, 0.0), true),
        (state(100.0, 60.0, 0.3, -0.4, 0.0), false),
        (state(100.0, 60.0, 0.0, -0.3, PI / 16.0 - 1e-9), true),
        (state(100.0, 60.0, 0.0, -0.3, PI / 16.0), false),
        (state(100.0, 60.0, 0.0, -0.3, -PI / 16.0 + 1e-9), true),
        (state(100.0, 60.0, 0.0, -0.3, TAU - 0.01), false),
    ];
    for (s, safe) in cases {
        assert_eq!(score::is_safe(&e, &s), safe, "{s:?}");
    }
}

#[test]
fn a_safe_landing_scores_big_number_and_a_crash_does_not() {
    // Dropped upright over the pad from just above touchdown: slow and safe.
    let e = env(100.0, 100.0);
    let l = Lander::with_state(&e, state(100.0, 68.0, 0.0, 0.0, 0.0), 0);
    let mut safe = l;
    safe.drift_to_end();
    let o = safe.outcome(&e, 0);
    assert!(o.touched_down && o.safe);
    assert_eq!(o.fitness, 9_999_999.0);
    // The same drop 20 px off the pad is a crash scored by eq. 1.
    let mut off = Lander::with_state(&e, state(120.0, 68.0, 0.0, 0.0, 0.0), 0);
    off.drift_to_end();
    let o = off.outcome(&e, 0);
    assert!(o.touched_down && !o.safe);
    assert!(o.fitness < 900.0);
}

#[test]
fn a_duration_zero_gene_is_a_no_op() {
    let e = env(200.0, 100.0);
    let plain = [
        Gene::new(Action::Thrust, 20),
        Gene::new(Action::RotateLeft, 10),
    ];
    let padded = [
        Gene::new(Action::RotateRight, 0),
        Gene::new(Action::Thrust, 20),
        Gene::new(Action::Thrust, 0),
        Gene::new(Action::RotateLeft, 10),
        Gene::new(Action::RotateLeft, 0),
    ];
    assert_eq!(fly(&e, &plain), fly(&e, &padded));
    assert_eq!(fly(&e, &padded).n, 30);
}

#[test]
fn the_tick_guard_ends_an_endless_flight_as_a_crash() {
    let mut e = env(200.0, 100.0);
    e.world.gravity = 0.0;
    let o = fly(&e, &[Gene::new(Action::RotateLeft, 1)]);
    assert_eq!(o.ticks, 100_000);
    assert!(!o.touched_down && !o.safe);
    assert_eq!(o, reference::fly(&e, &[Gene::new(Action::RotateLeft, 1)]));
}

#[test]
fn the_largest_rotation_steps_keep_every_number_finite() {
    let finite = |o: &Outcome| {
        let s = o.state;
        [s.x, s.y, s.vx, s.vy, s.rot, o.fitness]
            .iter()
            .all(|v| v.is_finite())
    };
    // 300,000 ticks rotating at a full turn a tick, either way round,
    // where the wrap that catches one way does not catch the other: the
    // state stays finite. Beyond the bound it does not.
    for step in [std::f64::consts::TAU, -std::f64::consts::TAU] {
        let mut e = env(200.0, 100.0);
        e.world.gravity = 0.0;
        e.world.rotation_step = step;
        e.world.max_ticks = 1_000_000;
        e.world.check().unwrap();
        for action in [Action::RotateLeft, Action::RotateRight] {
            let genome = vec![Gene::new(action, 30); 10_000];
            let o = fly(&e, &genome);
            assert!(o.n == 300_000 && finite(&o), "{step} {action:?}: {o:?}");
        }
        e.world.rotation_step = step * 1.0001;
        assert!(e.world.check().is_err());
        e.world.rotation_step = step.signum() * 1.7e308;
        let turning_back = match step > 0.0 {
            true => Action::RotateLeft,
            false => Action::RotateRight,
        };
        assert!(!finite(&fly(&e, &[Gene::new(turning_back, 30)])));
    }
}

#[test]
fn n_counts_decoded_ticks_only_until_touchdown() {
    let e = env(200.0, 100.0);
    // Full thrust upside down drives the lander into the ground within 30 ticks... of 50·30.
    let genome = vec![Gene::new(Action::Thrust, 30); 50];
    let o = fly(&e, &genome);
    assert!(o.touched_down);
    assert_eq!(o.n, o.ticks);
    assert!(o.ticks < 1500);
    // Short genome: n is the sum of durations, the rest is drift.
    let o = fly(&e, &[Gene::new(Action::Drift, 7)]);
    assert_eq!(o.n, 7);
    assert!(o.ticks > 7);
}

/// Flies `actions` one tick at a time from `start`, fast and reference side
/// by side, until touchdown.
fn ticks_match_the_reference(start: State, actions: &[u8]) -> Result<(), TestCaseError> {
    let e = env(200.0, 100.0);
    let mut fast = Lander::with_state(&e, start, 0);
    let mut slow = start;
    for &a in actions {
        let a = Action::from_index(a).unwrap();
        fast.run(a, 1);
        reference::tick(&e, &mut slow, a);
        prop_assert_eq!(fast.state(), slow);
        prop_assert_eq!(fast.touched_down(), reference::touches_ground(&e, &slow));
        if fast.touched_down() {
            break;
        }
    }
    Ok(())
}

fn arb_genome() -> impl Strategy<Value = Vec<Gene>> {
    proptest::collection::vec(
        (0u8..4, 0u8..=30).prop_map(|(a, d)| Gene::new(Action::from_index(a).unwrap(), d)),
        0..60,
    )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn fast_flight_is_bit_identical_to_the_reference(
        genome in arb_genome(),
        x0 in 0.0f64..400.0,
        pad_x in 50.0f64..350.0,
    ) {
        let e = env(x0, pad_x);
        prop_assert_eq!(fly(&e, &genome), reference::fly(&e, &genome));
    }

    #[test]
    fn fast_ticks_match_the_reference_from_any_state(
        x in 0.0f64..400.0, y in 40.0f64..120.0,
        vx in -3.0f64..3.0, vy in -3.0f64..3.0, rot in -PI..TAU,
        actions in proptest::collection::vec(0u8..4, 1..40),
    ) {
        ticks_match_the_reference(state(x, y, vx, vy, rot), &actions)?;
    }
}

proptest! {
    #[test]
    fn a_traced_flight_is_the_same_flight(genome in arb_genome(), x0 in 0.0f64..400.0) {
        let e = env(x0, 200.0);
        let mut last = None;
        let mut count = 0;
        let traced = fly_traced(&e, &genome, |tick, _, s| {
            count += 1;
            assert_eq!(tick, count);
            last = Some(*s);
        });
        let plain = fly(&e, &genome);
        prop_assert_eq!(traced, plain);
        prop_assert_eq!(count, plain.ticks);
        prop_assert_eq!(last, Some(plain.state));
    }
}

#[test]
fn hull_radius_is_the_farthest_hull_point() {
    let farthest = HULL
        .iter()
        .map(|&(px, py)| (px * px + py * py).sqrt())
        .fold(0.0, f64::max);
    assert_eq!(HULL_RADIUS, farthest);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(3000))]

    /// Spinning low over the ground is where the rotation bound works hardest.
    #[test]
    fn rotating_near_the_ground_matches_the_reference(
        x in 0.0f64..400.0, y in 55.0f64..80.0, vy in -0.5f64..0.5, rot in -PI..TAU,
        actions in proptest::collection::vec(0u8..2, 1..80),
    ) {
        ticks_match_the_reference(state(x, y, 0.0, vy, rot), &actions)?;
    }
}
