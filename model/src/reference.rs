//! The straightforward simulation: every tick computes `sin` and `cos` and
//! transforms all 30 hull points, exactly as SPEC §1 reads.
//!
//! It is the baseline the benchmark beats and the oracle the tests hold
//! [`crate::sim`] to, bit for bit. Nothing else should call it.

use crate::score;
use crate::sim::HULL;
use crate::{Action, Env, Gene};
use crate::{Outcome, State};
use std::f64::consts::{PI, TAU};

/// Flies `genes` then drifts to touchdown, like [`crate::fly`].
pub fn fly(env: &Env, genes: &[Gene]) -> Outcome {
    let w = &env.world;
    let mut s = State {
        x: env.x0,
        y: w.height - w.start_drop,
        vx: 0.0,
        vy: 0.0,
        rot: PI,
    };
    let actions = genes
        .iter()
        .flat_map(|g| std::iter::repeat_n(g.action, usize::from(g.duration)));
    let decoded: u32 = genes.iter().map(|g| u32::from(g.duration)).sum();
    let mut ticks = 0;
    let mut down = false;
    for action in actions.chain(std::iter::repeat(Action::Drift)) {
        if ticks >= w.max_ticks {
            break;
        }
        tick(env, &mut s, action);
        ticks += 1;
        if touches_ground(env, &s) {
            down = true;
            break;
        }
    }
    let n = ticks.min(decoded);
    let safe = down && score::is_safe(env, &s);
    Outcome {
        state: s,
        ticks,
        n,
        touched_down: down,
        safe,
        fitness: score::fitness(env, &s, n, safe),
    }
}

/// One tick: action, gravity, move, wrap.
pub fn tick(env: &Env, s: &mut State, action: Action) {
    let w = &env.world;
    match action {
        Action::RotateLeft => {
            s.rot -= w.rotation_step;
            if s.rot < -PI {
                s.rot += TAU;
            }
        }
        Action::RotateRight => {
            s.rot += w.rotation_step;
            if s.rot > TAU {
                s.rot -= TAU;
            }
        }
        Action::Thrust => {
            let a = (w.thrust / w.ticks_per_second) / w.mass;
            s.vx += a * s.rot.sin();
            s.vy += a * s.rot.cos();
        }
        Action::Drift => {}
    }
    s.vy += -(w.gravity / w.ticks_per_second);
    s.x += s.vx;
    s.y += s.vy;
    if s.x > w.width {
        s.x = 0.0;
    }
    if s.x < 0.0 {
        s.x = w.width;
    }
}

/// The hull in world coordinates.
pub fn hull_points(env: &Env, s: &State) -> [(f64, f64); 30] {
    let k = env.world.hull_scale;
    let (sin, cos) = (s.rot.sin(), s.rot.cos());
    HULL.map(|(px, py)| {
        (
            s.x + k * (px * cos + py * sin),
            s.y + k * (-px * sin + py * cos),
        )
    })
}

/// True when any hull point is below the touchdown line.
pub fn touches_ground(env: &Env, s: &State) -> bool {
    hull_points(env, s)
        .iter()
        .any(|&(_, y)| y < env.world.ground_y)
}
