//! The records an experiment keeps, one per finished trial, and the
//! [`Recording`] of a flight that a replay draws. They are stored as JSON
//! and read back on `--resume`, so every field is plain data.

use serde::{Deserialize, Serialize};

pub use lander_model::Method;

/// One generation of a GA trial: the best and mean fitness it scored.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitnessPoint {
    /// Generations flown in the trial so far, this one included (counted
    /// across restarts).
    pub index: u64,
    pub restart: u64,
    pub best: f64,
    pub mean: f64,
}

/// A Q(λ) trial's learning: the return of every episode.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Learning {
    pub episodes: u32,
    /// The episode of the first safe landing.
    pub first_safe: Option<u32>,
    pub landing_rate_last_100: f64,
    /// One return per episode, in order.
    pub returns: Vec<f64>,
}

/// The best lander a trial flew, enough to fly it again.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BestLander {
    /// `action:duration` pairs, as `lander fly --genome` takes them.
    pub genome: String,
    pub fitness: f64,
    pub safe: bool,
    /// The pad it flew to (a restart moves the pad).
    pub pad_x: f64,
}

/// One finished trial of one method.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrialRecord {
    /// Stored as its name: `ga`, `guided` or `qlearning`.
    pub method: Method,
    pub seed: u64,
    /// Numbered from 1; trials with the same number share `x0` and `pad_x`.
    pub trial: u64,
    pub x0: f64,
    pub pad_x: f64,
    pub landed: bool,
    /// GA methods: generations flown, counted across restarts.
    pub generations: Option<u64>,
    pub restarts: Option<u64>,
    /// Q-learning: the episode of the first landing.
    pub episodes: Option<u32>,
    pub wall_s: f64,
    /// GA methods: every generation's best and mean fitness.
    pub fitness: Vec<FitnessPoint>,
    pub best: Option<BestLander>,
    pub learning: Option<Learning>,
}

/// The world as a replay needs it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Scene {
    pub width: f64,
    pub height: f64,
    /// The touchdown line: the ground's surface.
    pub ground_y: f64,
    pub pad_x: f64,
    /// A landing within this distance of `pad_x` is on the pad.
    pub pad_half_width: f64,
    /// The hull's points in model units, and the model-to-pixel scale.
    pub hull: Vec<(f64, f64)>,
    pub hull_scale: f64,
}

/// The lander's pose after one tick, and what it was doing.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Frame {
    pub x: f64,
    pub y: f64,
    /// Radians; 0 is upright, and positive turns the nose to the right
    /// (SPEC §1: a model point's world x is `x + s·(px·cos + py·sin)`).
    pub rot: f64,
    /// True while the engine fires on this tick.
    pub thrust: bool,
}

/// A flight recorded frame by frame, to replay: where, and every tick of
/// it from the start state. (The simulation's own [`lander_model::Flight`]
/// is a flight in progress; this is what is left of one afterwards.)
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Recording {
    /// A caption, such as "guided GA, trial 13: landed safely".
    pub title: String,
    pub scene: Scene,
    /// The start state first, then one frame per tick to touchdown.
    pub frames: Vec<Frame>,
    pub safe: bool,
}
