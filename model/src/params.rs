//! The constants of the model (SPEC §1, §2 and §4), with the paper's
//! defaults. Each struct is plain data and deserialises from a TOML section
//! in which every key is optional and unknown keys are errors.

use crate::check::{
    at_most, check, finite, non_negative, positive, probability, within, ParamError,
};
#[cfg(feature = "zero-copy")]
use iceoryx2::prelude::ZeroCopySend;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// The world and the lander's physics (SPEC §1).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(
    feature = "zero-copy",
    derive(ZeroCopySend),
    type_name("lander::World")
)]
#[serde(default, deny_unknown_fields)]
pub struct World {
    /// Width `W` in pixels; x wraps at both edges.
    pub width: f64,
    /// Height `H` in pixels.
    pub height: f64,
    /// Gravity, per second per tick: `vy -= gravity / ticks_per_second` every tick.
    pub gravity: f64,
    /// Thrust force; acceleration per tick is `(thrust / ticks_per_second) / mass`.
    pub thrust: f64,
    pub mass: f64,
    pub ticks_per_second: f64,
    /// Radians turned by one rotate tick.
    pub rotation_step: f64,
    /// The lander starts at `y = height - start_drop`.
    pub start_drop: f64,
    /// The touchdown line: a flight ends when any hull point is below it.
    pub ground_y: f64,
    /// Model units to pixels for the hull.
    pub hull_scale: f64,
    /// `pad_x` is drawn from `[pad_margin, width - pad_margin)`.
    pub pad_margin: f64,
    /// A flight still airborne after this many ticks ends as a crash.
    pub max_ticks: u32,
}

impl Default for World {
    fn default() -> Self {
        World {
            width: 400.0,
            height: 300.0,
            gravity: 1.63,
            thrust: 350.0,
            mass: 100.0,
            ticks_per_second: 60.0,
            rotation_step: 0.05,
            start_drop: 50.0,
            ground_y: 55.0,
            hull_scale: 10.0,
            pad_margin: 50.0,
            max_ticks: 100_000,
        }
    }
}

impl World {
    /// Checks every field, naming the first out of range; the lander must start above the ground.
    pub fn check(&self) -> Result<(), ParamError> {
        let w = self;
        positive("world.width", w.width)?;
        positive("world.height", w.height)?;
        at_most("world.width", w.width, 1e6)?;
        at_most("world.height", w.height, 1e6)?;
        // Gravity pulls the lander down and thrust pushes it along its
        // nose: negative, a lander falls up off the screen and flies to
        // max_ticks, to a fitness that means nothing.
        non_negative("world.gravity", w.gravity)?;
        non_negative("world.thrust", w.thrust)?;
        positive("world.mass", w.mass)?;
        positive("world.ticks_per_second", w.ticks_per_second)?;
        // At most a full turn a tick, either way: `rot` then stays within
        // a few million radians over max_ticks, where beyond it turns to
        // infinities and NaN, written out as nulls.
        finite("world.rotation_step", w.rotation_step)?;
        check(
            "world.rotation_step",
            w.rotation_step.abs() <= std::f64::consts::TAU,
            format_args!(
                "must be from -2π to 2π radians, at most a full turn a tick (got {:?})",
                w.rotation_step
            ),
        )?;
        finite("world.start_drop", w.start_drop)?;
        finite("world.ground_y", w.ground_y)?;
        positive("world.hull_scale", w.hull_scale)?;
        non_negative("world.pad_margin", w.pad_margin)?;
        check(
            "world.pad_margin",
            2.0 * w.pad_margin < w.width,
            "must be less than half of world.width",
        )?;
        check(
            "world.max_ticks",
            (1..=1_000_000).contains(&w.max_ticks),
            "must be 1 to 1,000,000",
        )?;
        // Upside down (rot = π) the hull's top, its largest model y, is
        // lowest; a lander starting with it under the ground would touch
        // down on the first tick, to numbers that mean nothing.
        let top = crate::sim::HULL
            .iter()
            .map(|p| p.1)
            .fold(f64::NEG_INFINITY, f64::max);
        let least = w.ground_y + w.start_drop + w.hull_scale * top;
        check(
            "world.height",
            w.height > least,
            format_args!(
                "must be more than {least:?}, so that the lander, starting world.start_drop \
                 below the top, is above world.ground_y (got {:?})",
                w.height
            ),
        )?;
        // A velocity change per tick beyond the world's height flies off
        // any screen in one tick; bounded so, no speed or position over a
        // flight of max_ticks comes near f64's range (it would turn to
        // infinities and NaN, written out as nulls).
        for (field, per_tick, formula) in [
            (
                "world.thrust",
                w.thrust_per_tick(),
                "world.thrust / world.ticks_per_second / world.mass",
            ),
            (
                "world.gravity",
                w.gravity_per_tick(),
                "world.gravity / world.ticks_per_second",
            ),
        ] {
            check(
                field,
                per_tick.abs() <= w.height,
                format_args!(
                    "gives a velocity change per tick ({formula} = {per_tick:?}) beyond \
                     world.height ({:?})",
                    w.height
                ),
            )?;
        }
        Ok(())
    }

    /// Velocity change per thrust tick, `a = (350/60)/100` by default.
    pub fn thrust_per_tick(&self) -> f64 {
        (self.thrust / self.ticks_per_second) / self.mass
    }

    /// Downward velocity change per tick, `1.63/60` by default.
    pub fn gravity_per_tick(&self) -> f64 {
        self.gravity / self.ticks_per_second
    }

    pub fn start_y(&self) -> f64 {
        self.height - self.start_drop
    }
}

/// The fitness of eq. 1 and the safe-landing thresholds (SPEC §2).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(
    feature = "zero-copy",
    derive(ZeroCopySend),
    type_name("lander::Scoring")
)]
#[serde(default, deny_unknown_fields)]
pub struct Scoring {
    pub w1: f64,
    pub w2: f64,
    pub w3: f64,
    /// The fitness of a safe landing.
    pub big_number: f64,
    pub safe_distance: f64,
    pub safe_speed: f64,
    pub safe_rotation: f64,
}

impl Default for Scoring {
    fn default() -> Self {
        Scoring {
            w1: 1.0,
            w2: 400.0,
            w3: 4.0,
            big_number: 9_999_999.0,
            safe_distance: 10.0,
            safe_speed: 0.5,
            safe_rotation: PI / 16.0,
        }
    }
}

impl Scoring {
    /// Checks every field, naming the first out of range.
    pub fn check(&self) -> Result<(), ParamError> {
        let s = self;
        // Bounded so that fitness and R stay finite for any flight.
        within("scoring.w1", s.w1, 1e12)?;
        within("scoring.w2", s.w2, 1e12)?;
        within("scoring.w3", s.w3, 1e12)?;
        within("scoring.big_number", s.big_number, 1e15)?;
        non_negative("scoring.safe_distance", s.safe_distance)?;
        non_negative("scoring.safe_speed", s.safe_speed)?;
        non_negative("scoring.safe_rotation", s.safe_rotation)?;
        Ok(())
    }
}

/// The guided evolve pass: ε and the reinforcement function R of eq. 3
/// (SPEC §4).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(
    feature = "zero-copy",
    derive(ZeroCopySend),
    type_name("lander::GuideParams")
)]
#[serde(default, deny_unknown_fields)]
pub struct GuideParams {
    /// Probability of keeping a gene's action when R prefers another.
    pub epsilon: f64,
    pub w_y: f64,
    pub h1: f64,
    pub r: f64,
    pub h2: f64,
    pub w_t: f64,
}

impl Default for GuideParams {
    fn default() -> Self {
        GuideParams {
            epsilon: 0.1,
            w_y: 3.0,
            h1: 100.0,
            r: 1.7,
            h2: 30.0,
            w_t: 6.0,
        }
    }
}

impl GuideParams {
    /// Checks every field, naming the first out of range.
    pub fn check(&self) -> Result<(), ParamError> {
        let g = self;
        probability("guided.epsilon", g.epsilon)?;
        // Bounded, as the weights of scoring are, so that R stays finite
        // for any flight: an infinite R turns Q(λ)'s values into NaN.
        finite("guided.w_y", g.w_y)?;
        check(
            "guided.w_y",
            g.w_y >= 1e-12,
            format_args!("must be at least 1e-12 (got {:?})", g.w_y),
        )?;
        finite("guided.h1", g.h1)?;
        within("guided.r", g.r, 1e12)?;
        finite("guided.h2", g.h2)?;
        // Negative, `w_t·speed + 1` passes through zero.
        non_negative("guided.w_t", g.w_t)?;
        Ok(())
    }
}

/// The Q(λ) baseline (SPEC §5).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(
    feature = "zero-copy",
    derive(ZeroCopySend),
    type_name("lander::LearnParams")
)]
#[serde(default, deny_unknown_fields)]
pub struct LearnParams {
    /// Ticks each decision's action is held for.
    pub decision_ticks: u32,
    pub tilings: u32,
    /// The tile coder hashes into `2^memory_bits` weights.
    pub memory_bits: u32,
    /// Tile widths for `(x − pad_x, altitude, vx, vy, rot)`.
    pub tile_widths: [f64; 5],
    /// α times the number of tilings: each feature's step is
    /// `step_size / tilings`.
    pub step_size: f64,
    pub gamma: f64,
    pub lambda: f64,
    pub epsilon: f64,
    /// Added to the last reward of a safe landing.
    pub safe_bonus: f64,
    /// Subtracted from the last reward of a crash.
    pub crash_penalty: f64,
    pub episodes: u32,
}

/// The largest learner a worker builds: `2^24` weights (128 MiB, and as
/// much again for traces), and the most episodes a trial may ask for.
pub const MAX_MEMORY_BITS: u32 = 24;
pub const MAX_EPISODES: u32 = 10_000_000;

impl LearnParams {
    /// Checks every field, naming the first out of range. The run
    /// configuration and a worker taking a training job both rely on it.
    pub fn check(&self) -> Result<(), ParamError> {
        check(
            "qlearning.decision_ticks",
            self.decision_ticks >= 1,
            "must be at least 1",
        )?;
        check(
            "qlearning.tilings",
            (1..=crate::tiles::MAX_TILINGS as u32).contains(&self.tilings),
            "must be 1 to 64",
        )?;
        check(
            "qlearning.memory_bits",
            (4..=MAX_MEMORY_BITS).contains(&self.memory_bits),
            "must be 4 to 24",
        )?;
        for w in self.tile_widths {
            positive("qlearning.tile_widths", w)?;
        }
        positive("qlearning.step_size", self.step_size)?;
        probability("qlearning.gamma", self.gamma)?;
        probability("qlearning.lambda", self.lambda)?;
        probability("qlearning.epsilon", self.epsilon)?;
        finite("qlearning.safe_bonus", self.safe_bonus)?;
        finite("qlearning.crash_penalty", self.crash_penalty)?;
        check(
            "qlearning.episodes",
            (1..=MAX_EPISODES).contains(&self.episodes),
            "must be 1 to 10,000,000",
        )
    }
}

impl Default for LearnParams {
    fn default() -> Self {
        LearnParams {
            decision_ticks: 5,
            tilings: 16,
            memory_bits: 18,
            tile_widths: [40.0, 30.0, 0.5, 0.5, 0.25],
            step_size: 0.1,
            gamma: 0.99,
            lambda: 0.9,
            epsilon: 0.05,
            safe_bonus: 1000.0,
            crash_penalty: 100.0,
            episodes: 5000,
        }
    }
}

/// One flight's environment: the world, the start column and the pad.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "zero-copy", derive(ZeroCopySend), type_name("lander::Env"))]
pub struct Env {
    pub world: World,
    pub scoring: Scoring,
    pub x0: f64,
    pub pad_x: f64,
}

/// What a run does: evolve with the general or the guided GA, or learn
/// with the Q(λ) baseline. Records, files and the command line all name a
/// method by [`Method::name`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    Ga,
    Guided,
    Qlearning,
}

impl Method {
    /// Every method, in the order tables and plots list them.
    pub const ALL: [Method; 3] = [Method::Ga, Method::Guided, Method::Qlearning];

    /// The name in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Method::Ga => "ga",
            Method::Guided => "guided",
            Method::Qlearning => "qlearning",
        }
    }

    /// The name on plots and in tables.
    pub fn label(self) -> &'static str {
        match self {
            Method::Ga => "general GA",
            Method::Guided => "guided GA",
            Method::Qlearning => "Q(λ)",
        }
    }

    /// How a GA method evaluates its genomes; `None` for Q(λ).
    pub fn pass(self) -> Option<Pass> {
        match self {
            Method::Ga => Some(Pass::Fly),
            Method::Guided => Some(Pass::Guide),
            Method::Qlearning => None,
        }
    }
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Method {
    type Err = ParamError;

    fn from_str(s: &str) -> Result<Method, ParamError> {
        Method::ALL
            .into_iter()
            .find(|m| m.name() == s)
            .ok_or_else(|| ParamError {
                field: "method",
                problem: format!("must be ga, guided or qlearning (got {s:?})"),
            })
    }
}

/// What a genome goes through when a GA method evaluates it: a job
/// carries its pass, and [`crate::evaluate()`] runs it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Pass {
    /// The general GA's: fly the genome as it is, and score the flight.
    Fly,
    /// The guided GA's: the evolve pass, then fly on and score.
    Guide,
}

impl Pass {
    /// The pass's number on the wire.
    pub fn code(self) -> u32 {
        match self {
            Pass::Fly => 0,
            Pass::Guide => 1,
        }
    }

    pub fn from_code(code: u32) -> Option<Pass> {
        [Pass::Fly, Pass::Guide]
            .into_iter()
            .find(|m| m.code() == code)
    }

    /// The GA method this pass is the evaluation of.
    pub fn method(self) -> Method {
        match self {
            Pass::Fly => Method::Ga,
            Pass::Guide => Method::Guided,
        }
    }
}
