//! The lander as a Q(λ) task (SPEC §5), and one whole training trial.
//!
//! Every `decision_ticks` ticks the agent picks an action from the tile-coded
//! features of `(x − pad_x, altitude, vx, vy, rot)`. The reward of a
//! decision is the change in R (eq. 3), plus a bonus for a safe landing or
//! a penalty for a crash when the flight ends.

use crate::qlearn::{QLambda, QParams, Task};
use crate::score::{is_safe, reinforcement};
use crate::sim::{Flight, Physics};
use crate::stream::streams;
use crate::tiles::TileCoder;
use crate::{Env, EpisodeRecord, GuideParams, LearnParams, StreamKey, TrainResult, Training};
use std::ops::ControlFlow;

pub struct LanderTask {
    env: Env,
    guide: GuideParams,
    learn: LearnParams,
    physics: Physics,
    coder: TileCoder,
    flight: Flight,
    /// Whether the episode ended in a safe landing.
    landed: bool,
}

impl LanderTask {
    pub fn new(env: &Env, guide: &GuideParams, learn: &LearnParams) -> LanderTask {
        LanderTask {
            env: *env,
            guide: *guide,
            learn: *learn,
            physics: Physics::new(env),
            coder: TileCoder::new(learn.tile_widths, learn.tilings as usize, learn.memory_bits),
            flight: Flight::start(env),
            landed: false,
        }
    }

    fn r(&self) -> f64 {
        reinforcement(&self.env, &self.guide, &self.flight.state)
    }
}

impl Task for LanderTask {
    const ACTIONS: usize = 4;

    fn active(&self) -> usize {
        self.coder.tilings()
    }

    fn reset(&mut self) {
        self.flight = Flight::start(&self.env);
        self.landed = false;
    }

    fn features(&self, out: &mut [usize]) {
        let s = &self.flight.state;
        let point = [
            s.x - self.env.pad_x,
            s.y - self.env.world.ground_y,
            s.vx,
            s.vy,
            s.rot,
        ];
        self.coder
            .features_of_every_action(&point, Self::ACTIONS as u8, out);
    }

    fn step(&mut self, action: u8) -> (f64, bool) {
        let before = self.r();
        let action = crate::Action::from_index(action).unwrap_or(crate::Action::Drift);
        self.flight
            .run(&self.physics, action, self.learn.decision_ticks);
        let reward = self.r() - before;
        if !self.flight.ended(&self.physics) {
            return (reward, false);
        }
        self.landed = self.flight.touched_down() && is_safe(&self.env, &self.flight.state);
        let end = if self.landed {
            self.learn.safe_bonus
        } else {
            -self.learn.crash_penalty
        };
        (reward + end, true)
    }
}

/// Trains a fresh agent for `learn.episodes` episodes of `env`, its draws
/// keyed by `key`. `observe` sees every episode as it ends, and may break
/// the training off after it; the summary then covers the episodes flown.
pub fn train(
    env: &Env,
    guide: &GuideParams,
    learn: &LearnParams,
    key: StreamKey,
    observe: &mut dyn FnMut(&EpisodeRecord) -> ControlFlow<()>,
) -> Training {
    let mut task = LanderTask::new(env, guide, learn);
    let params = QParams {
        alpha: learn.step_size / f64::from(learn.tilings),
        gamma: learn.gamma,
        lambda: learn.lambda,
        epsilon: learn.epsilon,
    };
    let mut agent = QLambda::new(1 << learn.memory_bits, params);
    let mut rng = key.rng(streams::LEARN);
    let max_steps = env.world.max_ticks.div_ceil(learn.decision_ticks.max(1)) + 1;
    let mut first_safe = None;
    let mut recent = std::collections::VecDeque::with_capacity(100);
    let mut flown = 0;
    for episode in 1..=learn.episodes {
        flown = episode;
        let stats = agent.episode(&mut task, &mut rng, max_steps);
        if task.landed && first_safe.is_none() {
            first_safe = Some(episode);
        }
        if recent.len() == 100 {
            recent.pop_front();
        }
        recent.push_back(task.landed);
        let seen = observe(&EpisodeRecord {
            episode,
            reward: stats.reward,
            ticks: task.flight.ticks,
            decisions: stats.steps,
            safe: task.landed,
            epsilon: learn.epsilon,
        });
        if seen.is_break() {
            break;
        }
    }
    let landed = recent.iter().filter(|&&l| l).count();
    Training {
        episodes: flown,
        first_safe,
        landing_rate_last_100: landed as f64 / recent.len().max(1) as f64,
    }
}

/// A whole Q(λ) trial: everything [`run_training`] needs, so that any
/// thread or worker can run it.
#[derive(Clone, Debug, PartialEq)]
pub struct TrainJob {
    pub env: Env,
    pub guide: GuideParams,
    pub learn: LearnParams,
    pub key: StreamKey,
}

/// A whole training trial as a worker serves it: the records and summary.
pub fn run_training(job: &TrainJob) -> TrainResult {
    let mut episodes = Vec::new();
    let training = train(&job.env, &job.guide, &job.learn, job.key, &mut |e| {
        episodes.push(e.clone());
        ControlFlow::Continue(())
    });
    TrainResult { training, episodes }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_env;

    #[test]
    fn rewards_are_the_change_in_r_plus_the_ending() {
        let env = test_env(200.0, 200.0);
        let learn = LearnParams::default();
        let mut task = LanderTask::new(&env, &GuideParams::default(), &learn);
        task.reset();
        let before = task.r();
        let (reward, done) = task.step(3);
        assert!(!done);
        assert_eq!(task.flight.ticks, 5);
        assert_eq!(reward, task.r() - before);
        // Drifting on, the lander falls upside down and crashes.
        let mut last = (0.0, false);
        while !last.1 {
            let before = task.r();
            last = task.step(3);
            if last.1 {
                assert!(!task.landed);
                assert_eq!(last.0, task.r() - before - 100.0);
            }
        }
    }

    #[test]
    fn training_broken_off_sums_up_the_episodes_flown() {
        let env = test_env(150.0, 200.0);
        let learn = LearnParams {
            episodes: 30,
            ..LearnParams::default()
        };
        let mut seen = Vec::new();
        let t = train(
            &env,
            &GuideParams::default(),
            &learn,
            StreamKey::new(1, 1, 0, 0),
            &mut |e| {
                seen.push(e.clone());
                if e.episode == 7 {
                    ControlFlow::Break(())
                } else {
                    ControlFlow::Continue(())
                }
            },
        );
        assert_eq!(t.episodes, 7);
        assert_eq!(
            t.first_safe,
            seen.iter().find(|e| e.safe).map(|e| e.episode)
        );
        assert_eq!(
            seen.iter().map(|e| e.episode).collect::<Vec<_>>(),
            (1..=7).collect::<Vec<_>>()
        );
        // The episodes it did fly are those of the whole trial.
        let mut whole = Vec::new();
        train(
            &env,
            &GuideParams::default(),
            &learn,
            StreamKey::new(1, 1, 0, 0),
            &mut |e| {
                whole.push(e.clone());
                ControlFlow::Continue(())
            },
        );
        assert_eq!(&whole[..7], &seen[..]);
    }

    #[test]
    fn training_is_deterministic_and_reports_every_episode() {
        let env = test_env(150.0, 200.0);
        let learn = LearnParams {
            episodes: 30,
            ..LearnParams::default()
        };
        let run = || {
            let mut seen = Vec::new();
            let t = train(
                &env,
                &GuideParams::default(),
                &learn,
                StreamKey::new(1, 1, 0, 0),
                &mut |e| {
                    seen.push(e.clone());
                    ControlFlow::Continue(())
                },
            );
            (t, seen)
        };
        let (a, seen) = run();
        assert_eq!(run(), (a.clone(), seen.clone()));
        assert_eq!(seen.len(), 30);
        assert_eq!(a.episodes, 30);
        assert_eq!(
            seen.iter().map(|e| e.episode).collect::<Vec<_>>(),
            (1..=30).collect::<Vec<_>>()
        );
        assert!((0.0..=1.0).contains(&a.landing_rate_last_100));
        assert!(seen.iter().all(|e| e.ticks > 0 && e.reward.is_finite()));
    }
}
