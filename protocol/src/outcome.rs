//! What evaluating a genome produces: where the lander ended and how it
//! scored. Results cross process boundaries, so they live here.

use serde::{Deserialize, Serialize};

/// The lander's kinematic state.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct State {
    pub x: f64,
    pub y: f64,
    pub vx: f64,
    pub vy: f64,
    pub rot: f64,
}

impl State {
    pub fn speed(&self) -> f64 {
        (self.vx * self.vx + self.vy * self.vy).sqrt()
    }
}

/// How a flight ended.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Outcome {
    pub state: State,
    /// Ticks flown, including the drift after the genes ran out.
    pub ticks: u32,
    /// Decoded ticks flown: `min(ticks, Σ durations)`.
    pub n: u32,
    /// False when the flight hit the tick guard instead of the ground.
    pub touched_down: bool,
    pub safe: bool,
    pub fitness: f64,
}

/// The result for one genome.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Evaluation {
    pub outcome: Outcome,
    /// Every tick simulated for this genome: the guided pass's look-aheads
    /// and the flight itself.
    pub simulated_ticks: u64,
}

impl State {
    fn is_finite(&self) -> bool {
        [self.x, self.y, self.vx, self.vy, self.rot]
            .iter()
            .all(|v| v.is_finite())
    }
}

impl Evaluation {
    /// True when every number is one a real flight can produce: finite,
    /// with `n ≤ ticks` and safe only on touchdown. A receiver refuses
    /// anything else.
    pub fn is_plausible(&self) -> bool {
        let o = &self.outcome;
        o.state.is_finite()
            && o.fitness.is_finite()
            && o.n <= o.ticks
            && (o.touched_down || !o.safe)
            && self.simulated_ticks >= u64::from(o.ticks - o.n)
    }
}
