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
