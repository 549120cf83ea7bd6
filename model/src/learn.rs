//! The lander as a Q(λ) task (SPEC §5), and one whole training trial:
//! [`LearnRun`] steps it an episode at a time, and [`LearnState`] is where
//! it stands between episodes, which is all a checkpoint needs.
//!
//! Every `decision_ticks` ticks the agent picks an action from the tile-coded
//! features of `(x − pad_x, altitude, vx, vy, rot)`. The reward of a
//! decision is the change in R (eq. 3), plus a bonus for a safe landing or
//! a penalty for a crash when the flight ends.

use crate::qlearn::{QLambda, QParams, Task};
use crate::score::{is_safe, reinforcement};
use crate::sim::{Flight, Physics};
use crate::stream::{streams, StreamRng};
use crate::tiles::TileCoder;
use crate::{Env, EpisodeRecord, GuideParams, LearnParams, StreamKey, TrainResult, Training};
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;
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

/// A Q(λ) trial under way, stepped one episode at a time.
pub struct LearnRun {
    task: LanderTask,
    agent: QLambda,
    rng: StreamRng,
    learn: LearnParams,
    max_steps: u32,
    /// Episodes flown so far.
    flown: u32,
    first_safe: Option<u32>,
    /// Whether each of the last 100 episodes landed, oldest first.
    recent: VecDeque<bool>,
}

/// Everything a Q(λ) trial needs to go on exactly as it would have, saved
/// between episodes. Traces are cut as each episode starts, so none are
/// kept; the generator is kept as its position in its keyed stream.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LearnState {
    /// Episodes flown.
    pub episodes: u32,
    /// The learning stream's position, in 32-bit words.
    pub rng_word: u128,
    pub first_safe: Option<u32>,
    /// Whether each of the last (at most 100) episodes landed, oldest first.
    pub recent: Vec<bool>,
    /// The agent's weights that are not +0.0, by index.
    pub weights: Vec<(u32, f64)>,
}

impl LearnState {
    /// Whether a trial of `learn` can stand here: no more episodes flown
    /// than it has, at most 100 recent ones, its first landing among those
    /// flown, and every weight one of its agent's, finite. A state read
    /// from a checkpoint or a worker's answer passes this before it is
    /// trusted.
    pub fn check(&self, learn: &LearnParams) -> Result<(), String> {
        if self.episodes > learn.episodes {
            return Err(format!(
                "{} episodes flown of a trial of {}",
                self.episodes, learn.episodes
            ));
        }
        if self.recent.len() > 100 || self.recent.len() > self.episodes as usize {
            return Err(format!(
                "{} recent episodes after {} flown",
                self.recent.len(),
                self.episodes
            ));
        }
        if self.first_safe.is_some_and(|e| e == 0 || e > self.episodes) {
            return Err(format!(
                "a first landing in episode {:?} of {}",
                self.first_safe, self.episodes
            ));
        }
        let weights = 1u64.checked_shl(learn.memory_bits).unwrap_or(u64::MAX);
        for &(i, w) in &self.weights {
            if u64::from(i) >= weights {
                return Err(format!("weight {i} is past the agent's {weights} weights"));
            }
            if !w.is_finite() {
                return Err(format!("weight {i} is {w}"));
            }
        }
        Ok(())
    }
}

impl LearnRun {
    /// A fresh agent for `learn.episodes` episodes of `env`, its draws
    /// keyed by `key`.
    pub fn new(env: &Env, guide: &GuideParams, learn: &LearnParams, key: StreamKey) -> LearnRun {
        let params = QParams {
            alpha: learn.step_size / f64::from(learn.tilings),
            gamma: learn.gamma,
            lambda: learn.lambda,
            epsilon: learn.epsilon,
        };
        LearnRun {
            task: LanderTask::new(env, guide, learn),
            agent: QLambda::new(1 << learn.memory_bits, params),
            rng: key.rng(streams::LEARN),
            learn: *learn,
            max_steps: env.world.max_ticks.div_ceil(learn.decision_ticks.max(1)) + 1,
            flown: 0,
            first_safe: None,
            recent: VecDeque::with_capacity(100),
        }
    }

    /// The trial `new` would start, gone on from `state`. A state this
    /// configuration could not have reached is refused, saying why.
    pub fn resume(
        env: &Env,
        guide: &GuideParams,
        learn: &LearnParams,
        key: StreamKey,
        state: &LearnState,
    ) -> Result<LearnRun, String> {
        state.check(learn)?;
        let mut run = LearnRun::new(env, guide, learn, key);
        run.agent.set_weights(&state.weights)?;
        run.rng.set_word_pos(state.rng_word);
        run.flown = state.episodes;
        run.first_safe = state.first_safe;
        run.recent = state.recent.iter().copied().collect();
        Ok(run)
    }

    /// Flies the next episode, learning as it goes; `None` once every
    /// episode is flown.
    pub fn step(&mut self) -> Option<EpisodeRecord> {
        if self.flown >= self.learn.episodes {
            return None;
        }
        self.flown += 1;
        let episode = self.flown;
        let stats = self
            .agent
            .episode(&mut self.task, &mut self.rng, self.max_steps);
        if self.task.landed && self.first_safe.is_none() {
            self.first_safe = Some(episode);
        }
        if self.recent.len() == 100 {
            self.recent.pop_front();
        }
        self.recent.push_back(self.task.landed);
        Some(EpisodeRecord {
            episode,
            reward: stats.reward,
            ticks: self.task.flight.ticks,
            decisions: stats.steps,
            safe: self.task.landed,
            epsilon: self.learn.epsilon,
        })
    }

    /// Where the trial stands.
    pub fn state(&self) -> LearnState {
        LearnState {
            episodes: self.flown,
            rng_word: self.rng.get_word_pos(),
            first_safe: self.first_safe,
            recent: self.recent.iter().copied().collect(),
            weights: self.agent.nonzero_weights(),
        }
    }

    /// The summary of the episodes flown so far.
    pub fn training(&self) -> Training {
        let landed = self.recent.iter().filter(|&&l| l).count();
        Training {
            episodes: self.flown,
            first_safe: self.first_safe,
            landing_rate_last_100: landed as f64 / self.recent.len().max(1) as f64,
        }
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
    let mut run = LearnRun::new(env, guide, learn, key);
    while let Some(record) = run.step() {
        if observe(&record).is_break() {
            break;
        }
    }
    run.training()
}

/// A Q(λ) trial, or a leg of one: everything [`run_training`] needs, so
/// that any thread or worker can run it. A leg starts where the trial
/// stands after an earlier one and ends after episode `until`; a trial
/// flown in legs is, episode for episode, the trial flown whole.
#[derive(Clone, Debug, PartialEq)]
pub struct TrainJob {
    pub env: Env,
    pub guide: GuideParams,
    pub learn: LearnParams,
    pub key: StreamKey,
    /// Where the leg starts; `None` at the trial's start.
    pub from: Option<LearnState>,
    /// The episode the leg ends after (at most the trial's last).
    pub until: u32,
}

impl TrainJob {
    /// The whole trial, from its start to its last episode.
    pub fn whole(env: Env, guide: GuideParams, learn: LearnParams, key: StreamKey) -> TrainJob {
        TrainJob {
            env,
            guide,
            learn,
            key,
            from: None,
            until: learn.episodes,
        }
    }

    /// The episodes flown before the leg starts.
    pub fn start(&self) -> u32 {
        self.from.as_ref().map_or(0, |s| s.episodes)
    }

    /// The leg of this trial from `from` (its start, where `None`) to
    /// `end` of the episodes flown by then, and never past the trial's own
    /// end. The trial's own starting state is not copied: it may hold
    /// millions of weights.
    pub fn leg(&self, from: Option<LearnState>, end: impl FnOnce(u32) -> u32) -> TrainJob {
        let mut leg = TrainJob {
            from,
            ..TrainJob::whole(self.env, self.guide, self.learn, self.key)
        };
        leg.until = self.until.min(end(leg.start()));
        leg
    }
}

/// A trial's leg as a worker serves it: the leg's records, the summary so
/// far and, short of the trial's end, where it stands. A starting state
/// the trial could not have reached is refused, saying why.
pub fn run_training(job: &TrainJob) -> Result<TrainResult, String> {
    let mut run = match &job.from {
        None => LearnRun::new(&job.env, &job.guide, &job.learn, job.key),
        Some(state) => LearnRun::resume(&job.env, &job.guide, &job.learn, job.key, state)?,
    };
    if job.until < run.flown {
        return Err(format!(
            "a leg to episode {} from episode {}",
            job.until, run.flown
        ));
    }
    let mut episodes = Vec::with_capacity((job.until - run.flown) as usize);
    while run.flown < job.until {
        let Some(record) = run.step() else { break };
        episodes.push(record);
    }
    let state = (run.flown < job.learn.episodes).then(|| run.state());
    Ok(TrainResult {
        training: run.training(),
        episodes,
        state,
    })
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

    /// A short trial, of 40 episodes.
    fn short_trial() -> TrainJob {
        let learn = LearnParams {
            episodes: 40,
            ..LearnParams::default()
        };
        TrainJob::whole(
            test_env(150.0, 200.0),
            GuideParams::default(),
            learn,
            StreamKey::new(3, 2, 0, 0),
        )
    }

    #[test]
    fn a_trial_flown_in_legs_is_the_trial_flown_whole() {
        let whole_job = short_trial();
        let whole = run_training(&whole_job).unwrap();
        assert!(whole.is_plausible(&whole_job) && whole.state.is_none());
        let (mut from, mut episodes, mut training) = (None, Vec::new(), None);
        // An empty leg, and legs of every length, end to end.
        for until in [7, 7, 8, 25, 40] {
            let job = TrainJob {
                from: from.clone(),
                until,
                ..whole_job.clone()
            };
            let leg = run_training(&job).unwrap();
            assert!(leg.is_plausible(&job), "leg to {until}");
            // The same answer is no answer to a leg of another start.
            let other = TrainJob {
                from: None,
                ..job.clone()
            };
            assert!(until == 7 && from.is_none() || !leg.is_plausible(&other));
            episodes.extend(leg.episodes);
            from = leg.state;
            training = Some(leg.training);
        }
        assert_eq!(episodes, whole.episodes);
        assert_eq!(training, Some(whole.training));
        assert!(from.is_none(), "the last leg ends the trial");
        let backwards = TrainJob {
            from: run_training(&TrainJob {
                until: 9,
                ..whole_job.clone()
            })
            .unwrap()
            .state,
            until: 3,
            ..whole_job
        };
        assert!(run_training(&backwards).is_err());
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

    #[test]
    fn a_trial_resumed_from_its_state_goes_on_bit_for_bit() {
        let env = test_env(150.0, 200.0);
        let (guide, key) = (GuideParams::default(), StreamKey::new(3, 2, 0, 0));
        let learn = LearnParams {
            episodes: 60,
            ..LearnParams::default()
        };
        let mut whole = LearnRun::new(&env, &guide, &learn, key);
        let records: Vec<EpisodeRecord> = std::iter::from_fn(|| whole.step()).collect();
        for cut in [0, 1, 17, 59, 60] {
            let mut first = LearnRun::new(&env, &guide, &learn, key);
            for _ in 0..cut {
                first.step();
            }
            let state = first.state();
            assert!(!state.weights.is_empty() || cut == 0);
            let mut resumed = LearnRun::resume(&env, &guide, &learn, key, &state).unwrap();
            assert_eq!(resumed.state(), state, "cut {cut}");
            let rest: Vec<EpisodeRecord> = std::iter::from_fn(|| resumed.step()).collect();
            assert_eq!(rest, records[cut..], "cut {cut}");
            assert_eq!(resumed.training(), whole.training(), "cut {cut}");
            assert_eq!(resumed.state(), whole.state(), "cut {cut}");
        }
    }

    #[test]
    fn states_no_trial_could_reach_are_refused() {
        let env = test_env(150.0, 200.0);
        let (guide, key) = (GuideParams::default(), StreamKey::new(3, 2, 0, 0));
        let learn = LearnParams {
            episodes: 10,
            ..LearnParams::default()
        };
        let mut run = LearnRun::new(&env, &guide, &learn, key);
        run.step();
        let good = run.state();
        let bad = |change: &dyn Fn(&mut LearnState)| {
            let mut s = good.clone();
            change(&mut s);
            LearnRun::resume(&env, &guide, &learn, key, &s)
                .err()
                .unwrap()
        };
        assert!(bad(&|s| s.episodes = 11).contains("of a trial of 10"));
        assert!(bad(&|s| s.recent = vec![true; 2]).contains("2 recent episodes after 1"));
        assert!(bad(&|s| s.first_safe = Some(5)).contains("first landing"));
        assert!(bad(&|s| s.weights.push((1 << 30, 1.0))).contains("past the agent's"));
        assert!(bad(&|s| s.weights.push((3, f64::NAN))).contains("weight 3 is NaN"));
    }

    #[test]
    fn a_leg_starts_where_its_state_stands_and_ends_at_the_trials_end_at_most() {
        let trial = short_trial();
        let first = trial.leg(None, |start| start + 15);
        assert_eq!((first.start(), first.until), (0, 15));
        let state = run_training(&first).unwrap().state;
        let second = trial.leg(state.clone(), |start| start + 15);
        assert_eq!((second.start(), second.until), (15, 30));
        assert_eq!(second.from, state);
        // Cut at the trial's end, and of the trial otherwise.
        let last = trial.leg(state, |start| start + 100);
        assert_eq!(last.until, 40);
        assert_eq!(
            (last.env, last.learn, last.key),
            (trial.env, trial.learn, trial.key)
        );
    }
}
