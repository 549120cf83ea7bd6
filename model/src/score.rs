//! The fitness of a finished flight (eq. 1, SPEC §2) and the reinforcement
//! function R that scores a state in mid-air (eq. 3, SPEC §4).

use crate::State;
use crate::{Env, GuideParams};

/// `1 / (|rot| + 1)`, shared by eq. 1 and eq. 3.
pub fn rot_fit(rot: f64) -> f64 {
    1.0 / (rot.abs() + 1.0)
}

/// True when distance to the pad, speed and rotation are all under their
/// thresholds. Only meaningful for a lander that has touched down.
pub fn is_safe(env: &Env, s: &State) -> bool {
    let sc = &env.scoring;
    (env.pad_x - s.x).abs() < sc.safe_distance
        && s.speed() < sc.safe_speed
        && s.rot.abs() < sc.safe_rotation
}

/// Eq. 1 with `n` decoded ticks flown, or `big_number` for a safe landing.
pub fn fitness(env: &Env, s: &State, n: u32, safe: bool) -> f64 {
    let sc = &env.scoring;
    if safe {
        return sc.big_number;
    }
    let dis_fit = env.world.width - (env.pad_x - s.x).abs();
    let air_time = f64::from(n) / (s.speed() + 1.0);
    sc.w1 * dis_fit + sc.w2 * rot_fit(s.rot) + sc.w3 * air_time
}

/// Eq. 3: how promising a state in flight is.
pub fn reinforcement(env: &Env, p: &GuideParams, s: &State) -> f64 {
    let w = &env.world;
    let sc = &env.scoring;
    let alt = s.y - w.ground_y;
    let dis_fit_x = w.width - (env.pad_x - s.x).abs();
    let dis_fit_y = w.height - alt.abs();
    let mut dis_fit = (dis_fit_x * dis_fit_x + dis_fit_y * dis_fit_y / p.w_y).sqrt();
    if alt < p.h1 {
        dis_fit *= p.r;
    }
    let speed = s.speed();
    let air_time = if alt < p.h2 {
        1.0 / (p.w_t * speed + 1.0)
    } else {
        1.0 / (speed + 1.0)
    };
    sc.w1 * dis_fit + sc.w2 * rot_fit(s.rot) + sc.w3 * air_time
}

/// Eq. 3 for two states at once: bit for bit
/// `[reinforcement(env, p, a), reinforcement(env, p, b)]`.
///
/// R's two square roots and three divisions queue for the CPU's one
/// divider, and the guided pass scores four branches per gene. In the two
/// lanes of an SSE2 vector (part of every x86-64) the two states take one
/// divider operation where they took two; the operations and their order
/// are eq. 3's, each rounded as IEEE 754 rounds it alone.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub fn reinforcement_pair(env: &Env, p: &GuideParams, a: &State, b: &State) -> [f64; 2] {
    use std::arch::x86_64::*;
    // SAFETY: SSE2 is part of every x86-64 CPU, so its intrinsics may be
    // called anywhere on this target; the one store writes the two f64s
    // of `out`, unaligned as it may be.
    unsafe {
        let (w, sc) = (&env.world, &env.scoring);
        let lanes = |f: fn(&State) -> f64| _mm_set_pd(f(b), f(a));
        let all = _mm_set1_pd;
        // `f64::abs` clears the sign bit, as this does.
        let abs = |x| _mm_andnot_pd(all(-0.0), x);
        let pick =
            |yes_mask, yes, no| _mm_or_pd(_mm_and_pd(yes_mask, yes), _mm_andnot_pd(yes_mask, no));
        let one = all(1.0);

        let alt = _mm_sub_pd(lanes(|s| s.y), all(w.ground_y));
        let dis_fit_x = _mm_sub_pd(
            all(w.width),
            abs(_mm_sub_pd(all(env.pad_x), lanes(|s| s.x))),
        );
        let dis_fit_y = _mm_sub_pd(all(w.height), abs(alt));
        let dis_fit = _mm_sqrt_pd(_mm_add_pd(
            _mm_mul_pd(dis_fit_x, dis_fit_x),
            _mm_div_pd(_mm_mul_pd(dis_fit_y, dis_fit_y), all(p.w_y)),
        ));
        // `_mm_cmplt_pd` is false on NaN, as `<` is.
        let low = _mm_cmplt_pd(alt, all(p.h1));
        let dis_fit = pick(low, _mm_mul_pd(dis_fit, all(p.r)), dis_fit);
        let (vx, vy) = (lanes(|s| s.vx), lanes(|s| s.vy));
        let speed = _mm_sqrt_pd(_mm_add_pd(_mm_mul_pd(vx, vx), _mm_mul_pd(vy, vy)));
        let near = _mm_cmplt_pd(alt, all(p.h2));
        let slowed = pick(
            near,
            _mm_add_pd(_mm_mul_pd(all(p.w_t), speed), one),
            _mm_add_pd(speed, one),
        );
        let air_time = _mm_div_pd(one, slowed);
        let rot_fit = _mm_div_pd(one, _mm_add_pd(abs(lanes(|s| s.rot)), one));
        let r = _mm_add_pd(
            _mm_add_pd(
                _mm_mul_pd(all(sc.w1), dis_fit),
                _mm_mul_pd(all(sc.w2), rot_fit),
            ),
            _mm_mul_pd(all(sc.w3), air_time),
        );
        let mut out = [0.0; 2];
        _mm_storeu_pd(out.as_mut_ptr(), r);
        out
    }
}

/// Eq. 3 for two states at once (see the x86-64 version).
#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
pub fn reinforcement_pair(env: &Env, p: &GuideParams, a: &State, b: &State) -> [f64; 2] {
    [reinforcement(env, p, a), reinforcement(env, p, b)]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_env;
    use proptest::prelude::*;

    fn arb_f64() -> impl Strategy<Value = f64> {
        prop_oneof![
            8 => -500.0f64..500.0,
            1 => any::<f64>(),
            1 => prop::sample::select(vec![0.0, -0.0, f64::INFINITY, f64::NEG_INFINITY, f64::NAN]),
        ]
    }

    fn arb_state() -> impl Strategy<Value = State> {
        (arb_f64(), arb_f64(), arb_f64(), arb_f64(), arb_f64())
            .prop_map(|(x, y, vx, vy, rot)| State { x, y, vx, vy, rot })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(5000))]

        /// Two states scored side by side equal each scored alone, bit for
        /// bit, on both sides of h1 and h2 and at the edges of f64.
        #[test]
        fn a_pair_scores_as_each_state_alone(
            a in arb_state(), b in arb_state(),
            h1 in 0.0f64..100.0, h2 in 0.0f64..100.0, w_t in 0.0f64..5.0,
            x0 in 0.0f64..400.0, pad_x in 50.0f64..350.0,
        ) {
            let env = test_env(x0, pad_x);
            let p = GuideParams { h1, h2, w_t, ..GuideParams::default() };
            let pair = reinforcement_pair(&env, &p, &a, &b);
            let alone = [reinforcement(&env, &p, &a), reinforcement(&env, &p, &b)];
            prop_assert_eq!(pair.map(f64::to_bits), alone.map(f64::to_bits));
        }
    }
}
