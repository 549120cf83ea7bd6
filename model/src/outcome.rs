//! What evaluating a genome produces (where the lander ended and how it
//! scored) and what a Q(λ) trial produces. Results cross process
//! boundaries, so they live here.

use crate::learn::{LearnState, TrainJob};
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

/// One episode, a line of `episodes.jsonl`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EpisodeRecord {
    /// Numbered from 1.
    pub episode: u32,
    #[serde(rename = "return")]
    pub reward: f64,
    pub ticks: u32,
    /// Actions chosen: one per `decision_ticks` ticks, the last maybe short.
    pub decisions: u32,
    pub safe: bool,
    pub epsilon: f64,
}

/// A trial's outcome: the episode of the first safe landing, if any, and
/// the landing rate over the last 100 episodes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Training {
    pub episodes: u32,
    pub first_safe: Option<u32>,
    pub landing_rate_last_100: f64,
}

/// A Q(λ) trial's results, or a leg's of it (`TrainJob`), as a worker
/// returns them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrainResult {
    /// The summary of every episode flown so far, the earlier legs' too.
    pub training: Training,
    /// The leg's episodes.
    pub episodes: Vec<EpisodeRecord>,
    /// Where the trial stands after a leg that ends before the trial does.
    pub state: Option<LearnState>,
}

impl TrainResult {
    /// True when the records are a possible answer to `job`: its leg's
    /// episodes numbered in order, finite, agreeing with the summary, and
    /// with the trial's state after a leg short of its end, one the next
    /// leg can start from (`LearnState::check`).
    pub fn is_plausible(&self, job: &TrainJob) -> bool {
        let (start, first_before) = job
            .from
            .as_ref()
            .map_or((0, None), |s| (s.episodes, s.first_safe));
        let until = job.until.min(job.learn.episodes);
        let numbered = self
            .episodes
            .iter()
            .zip(start + 1..)
            .all(|(e, n)| e.episode == n);
        let finite = self
            .episodes
            .iter()
            .all(|e| e.reward.is_finite() && e.epsilon.is_finite());
        let first = first_before.or(self.episodes.iter().find(|e| e.safe).map(|e| e.episode));
        let rate = self.training.landing_rate_last_100;
        let state = match &self.state {
            None => until == job.learn.episodes,
            Some(s) => {
                until < job.learn.episodes
                    && s.episodes == until
                    && s.first_safe == self.training.first_safe
                    && s.check(&job.learn).is_ok()
            }
        };
        start <= until
            && self.episodes.len() == (until - start) as usize
            && self.training.episodes == until
            && numbered
            && finite
            && first == self.training.first_safe
            && (0.0..=1.0).contains(&rate)
            && state
    }
}
