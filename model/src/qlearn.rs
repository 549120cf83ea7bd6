//! Watkins's Q(λ), linear over binary features, with ε-greedy actions and
//! accumulating traces (Sutton & Barto 1998, Figure 8.8). A trace is cut
//! when an exploratory, non-greedy action is taken, and decays by γλ after
//! a greedy one.
//!
//! The agent knows nothing of landers: it learns any [`Task`] that names
//! its active features. Traces are kept sparse, so a step costs in
//! proportion to the features touched recently, not to the weight count.

use rand::Rng;

/// An episodic problem with actions `0..ACTIONS` and binary features.
pub trait Task {
    const ACTIONS: usize;
    /// Features active for `(current state, action)`, always this many.
    fn active(&self) -> usize;
    /// Starts an episode.
    fn reset(&mut self);
    /// Writes the features of `(current state, a)` for every action `a`,
    /// action after action, `active()` each.
    fn features(&self, out: &mut [usize]);
    /// Takes `action`: the reward, and whether the episode is over.
    fn step(&mut self, action: u8) -> (f64, bool);
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QParams {
    /// Step size per feature.
    pub alpha: f64,
    pub gamma: f64,
    pub lambda: f64,
    pub epsilon: f64,
}

/// Traces smaller than this are dropped: they would change a weight by
/// less than a millionth of a step.
const TRACE_FLOOR: f64 = 1e-6;

/// What to do with the traces after choosing the next action.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TraceRule {
    Decay,
    Cut,
}

/// Watkins's rule: the traces survive only a greedy choice, one whose
/// value is the largest of `qs`.
pub fn trace_rule(qs: &[f64], chosen: u8) -> TraceRule {
    if qs[usize::from(chosen)] >= max(qs) {
        TraceRule::Decay
    } else {
        TraceRule::Cut
    }
}

fn max(qs: &[f64]) -> f64 {
    qs.iter().copied().fold(f64::NEG_INFINITY, f64::max)
}

/// One episode's account.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EpisodeStats {
    pub reward: f64,
    pub steps: u32,
}

pub struct QLambda {
    pub params: QParams,
    weights: Vec<f64>,
    /// The non-zero traces, `(feature, trace)`, in the order they became
    /// non-zero: learning and decaying read them as one run of memory, and
    /// only the weights at random.
    traced: Vec<(usize, f64)>,
    /// Where each feature's trace is in `traced`, or [`UNTRACED`].
    slot: Vec<u32>,
}

/// The `slot` of a feature whose trace is zero.
const UNTRACED: u32 = u32::MAX;

impl QLambda {
    pub fn new(size: usize, params: QParams) -> QLambda {
        QLambda {
            params,
            weights: vec![0.0; size],
            traced: Vec::new(),
            slot: vec![UNTRACED; size],
        }
    }

    pub fn q(&self, features: &[usize]) -> f64 {
        features.iter().map(|&i| self.weights[i]).sum()
    }

    pub fn weight(&self, i: usize) -> f64 {
        self.weights[i]
    }

    /// Every weight that is not +0.0, as `(index, weight)` in index order:
    /// what a checkpoint keeps of the agent between episodes, where every
    /// trace is cut anyway. (-0.0 is kept, so that the weights come back
    /// bit for bit.)
    pub fn nonzero_weights(&self) -> Vec<(u32, f64)> {
        self.weights
            .iter()
            .enumerate()
            .filter(|(_, w)| w.to_bits() != 0)
            .map(|(i, &w)| (i as u32, w))
            .collect()
    }

    /// Sets the weights from [`QLambda::nonzero_weights`]' list; the rest
    /// are zero. Refuses an index past the weights or a weight that is not
    /// finite, saying which.
    pub fn set_weights(&mut self, weights: &[(u32, f64)]) -> Result<(), String> {
        self.weights.iter_mut().for_each(|w| *w = 0.0);
        for &(i, w) in weights {
            let Some(slot) = self.weights.get_mut(i as usize) else {
                return Err(format!(
                    "weight {i} is past the agent's {} weights",
                    self.weights.len()
                ));
            };
            if !w.is_finite() {
                return Err(format!("weight {i} is {w}"));
            }
            *slot = w;
        }
        Ok(())
    }

    /// The non-zero traces.
    pub fn traces(&self) -> impl Iterator<Item = (usize, f64)> + '_ {
        self.traced.iter().copied()
    }

    /// Accumulating traces: each active feature's trace grows by one.
    pub fn accumulate(&mut self, features: &[usize]) {
        for &i in features {
            match self.slot[i] {
                UNTRACED => {
                    self.slot[i] = self.traced.len() as u32;
                    self.traced.push((i, 1.0));
                }
                at => self.traced[at as usize].1 += 1.0,
            }
        }
    }

    /// Applies `rule` to every trace.
    pub fn apply(&mut self, rule: TraceRule) {
        match rule {
            TraceRule::Cut => {
                for &(i, _) in &self.traced {
                    self.slot[i] = UNTRACED;
                }
                self.traced.clear();
            }
            TraceRule::Decay => {
                let k = self.params.gamma * self.params.lambda;
                self.traced.iter_mut().for_each(|(_, e)| *e *= k);
                self.drop_faint();
            }
        }
    }

    /// Drops the traces below [`TRACE_FLOOR`].
    fn drop_faint(&mut self) {
        let slot = &mut self.slot;
        let (mut at, mut kept) = (0, 0);
        self.traced.retain_mut(|(i, e)| {
            at += 1;
            if *e < TRACE_FLOOR {
                slot[*i] = UNTRACED;
                return false;
            }
            // A kept trace moves up past those dropped before it.
            if kept + 1 != at {
                slot[*i] = kept;
            }
            kept += 1;
            true
        });
    }

    fn learn(&mut self, delta: f64) {
        let step = self.params.alpha * delta;
        for &(i, e) in &self.traced {
            self.weights[i] += step * e;
        }
    }

    /// [`QLambda::learn`], and every trace decayed by γλ in the same pass
    /// over them, ahead of knowing whether the next action keeps them (the
    /// decay reads nothing the choice writes, nor the other way round).
    /// Returns whether a trace fell below [`TRACE_FLOOR`].
    fn learn_and_decay(&mut self, delta: f64) -> bool {
        let step = self.params.alpha * delta;
        let k = self.params.gamma * self.params.lambda;
        let mut faint = false;
        for (i, e) in &mut self.traced {
            self.weights[*i] += step * *e;
            *e *= k;
            faint |= *e < TRACE_FLOOR;
        }
        faint
    }

    /// Every action's value into `out`, from `features`: each action's
    /// active features in turn.
    fn values(&self, features: &[usize], out: &mut [f64]) {
        let n = features.len() / out.len();
        for (q, f) in out.iter_mut().zip(features.chunks(n)) {
            *q = self.q(f);
        }
    }

    /// ε-greedy, with ties among the best broken at random: with all
    /// weights at zero, a fixed tie-break would never explore. Values that
    /// are not numbers never win; when no value is a number (the weights
    /// overflowed, with a step size too large for the rewards) every
    /// action ties.
    fn choose(&self, qs: &[f64], rng: &mut impl Rng) -> u8 {
        if rng.random::<f64>() < self.params.epsilon {
            return rng.random_range(0..qs.len() as u8);
        }
        let best = max(qs);
        let ties = qs.iter().filter(|&&q| q == best).count();
        if ties == 0 {
            return rng.random_range(0..qs.len() as u8);
        }
        let pick = rng.random_range(0..ties);
        let mut tied = qs.iter().enumerate().filter(|&(_, &q)| q == best);
        tied.nth(pick).map_or(0, |(a, _)| a as u8)
    }

    /// Runs one episode of `task`, learning as it goes, for at most
    /// `max_steps` decisions.
    pub fn episode<T: Task>(
        &mut self,
        task: &mut T,
        rng: &mut impl Rng,
        max_steps: u32,
    ) -> EpisodeStats {
        task.reset();
        self.apply(TraceRule::Cut);
        let n = task.active();
        // The features of every action in the current state, computed once
        // per state: the values are read from them before and after learning.
        let mut state = vec![0usize; T::ACTIONS * n];
        let mut taken = vec![0usize; n];
        let (mut before, mut after) = (vec![0.0; T::ACTIONS], vec![0.0; T::ACTIONS]);
        task.features(&mut state);
        self.values(&state, &mut after);
        let mut action = self.choose(&after, rng);
        let mut stats = EpisodeStats {
            reward: 0.0,
            steps: 0,
        };
        while stats.steps < max_steps {
            let a = usize::from(action);
            taken.copy_from_slice(&state[a * n..(a + 1) * n]);
            self.accumulate(&taken);
            let q_sa = self.q(&taken);
            let (reward, done) = task.step(action);
            stats.reward += reward;
            stats.steps += 1;
            if done {
                self.learn(reward - q_sa);
                break;
            }
            task.features(&mut state);
            self.values(&state, &mut before);
            let faint = self.learn_and_decay(reward + self.params.gamma * max(&before) - q_sa);
            // Sutton & Barto's Figure 8.8 picks the next action from the
            // values after this update.
            self.values(&state, &mut after);
            let next = self.choose(&after, rng);
            match trace_rule(&after, next) {
                TraceRule::Cut => self.apply(TraceRule::Cut),
                TraceRule::Decay if faint => self.drop_faint(),
                TraceRule::Decay => {}
            }
            action = next;
        }
        stats
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    /// A corridor of `N` cells: start at 0, +1 for reaching the last cell.
    /// Tabular, so each (cell, action) is one feature.
    struct Corridor {
        at: usize,
    }

    const N: usize = 6;

    impl Task for Corridor {
        const ACTIONS: usize = 2;
        fn active(&self) -> usize {
            1
        }
        fn reset(&mut self) {
            self.at = 0;
        }
        fn features(&self, out: &mut [usize]) {
            out[0] = self.at * 2;
            out[1] = self.at * 2 + 1;
        }
        fn step(&mut self, action: u8) -> (f64, bool) {
            self.at = if action == 1 {
                self.at + 1
            } else {
                self.at.saturating_sub(1)
            };
            if self.at == N - 1 {
                (1.0, true)
            } else {
                (0.0, false)
            }
        }
    }

    fn params() -> QParams {
        QParams {
            alpha: 0.5,
            gamma: 0.9,
            lambda: 0.8,
            epsilon: 0.1,
        }
    }

    /// [`QLambda::episode`] with learning and decaying as two passes over
    /// the traces, the decay once the next action is chosen: the oracle
    /// of the episode's single pass. Returns how many traces faded below
    /// the floor.
    fn episode_in_two_passes(
        agent: &mut QLambda,
        task: &mut Corridor,
        rng: &mut impl Rng,
        max_steps: u32,
    ) -> usize {
        let mut faded = 0;
        task.reset();
        agent.apply(TraceRule::Cut);
        let (mut state, mut taken) = (vec![0usize; 2], vec![0usize; 1]);
        let (mut before, mut after) = (vec![0.0; 2], vec![0.0; 2]);
        task.features(&mut state);
        agent.values(&state, &mut after);
        let mut action = agent.choose(&after, rng);
        for _ in 0..max_steps {
            let a = usize::from(action);
            taken.copy_from_slice(&state[a..a + 1]);
            agent.accumulate(&taken);
            let q_sa = agent.q(&taken);
            let (reward, done) = task.step(action);
            if done {
                agent.learn(reward - q_sa);
                return faded;
            }
            task.features(&mut state);
            agent.values(&state, &mut before);
            agent.learn(reward + agent.params.gamma * max(&before) - q_sa);
            agent.values(&state, &mut after);
            let next = agent.choose(&after, rng);
            let (rule, traced) = (trace_rule(&after, next), agent.traced.len());
            agent.apply(rule);
            if rule == TraceRule::Decay {
                faded += traced - agent.traced.len();
            }
            action = next;
        }
        faded
    }

    /// Values that are not numbers never win, and when none is a number
    /// every action may be chosen: the learner flies on (it panicked,
    /// finding no best to break a tie among).
    #[test]
    fn choosing_among_values_that_are_not_numbers() {
        let agent = QLambda::new(
            4,
            QParams {
                epsilon: 0.0,
                ..params()
            },
        );
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for _ in 0..100 {
            assert_eq!(agent.choose(&[f64::NAN, 2.0, f64::NAN, 1.0], &mut rng), 1);
        }
        let mut seen = [false; 4];
        for _ in 0..200 {
            seen[usize::from(agent.choose(&[f64::NAN; 4], &mut rng))] = true;
        }
        assert_eq!(seen, [true; 4]);
    }

    /// Learning and decaying in one pass learns what two passes learn, bit
    /// for bit, traces falling below the floor and cut included (a long
    /// corridor, λ small enough that old traces fade out).
    #[test]
    fn one_pass_over_the_traces_learns_as_two() {
        let params = QParams {
            lambda: 0.01,
            epsilon: 0.3,
            ..params()
        };
        let (mut one, mut two) = (QLambda::new(2 * N, params), QLambda::new(2 * N, params));
        let (mut r1, mut r2) = (ChaCha8Rng::seed_from_u64(5), ChaCha8Rng::seed_from_u64(5));
        let mut task = Corridor { at: 0 };
        let mut faded = 0;
        for _ in 0..300 {
            one.episode(&mut task, &mut r1, 40);
            faded += episode_in_two_passes(&mut two, &mut task, &mut r2, 40);
            let bits = |a: &QLambda| a.weights.iter().map(|w| w.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&one), bits(&two));
            assert_eq!(one.traced, two.traced);
            assert_eq!(one.slot, two.slot);
        }
        assert!(faded > 0, "some traces faded below the floor");
    }

    #[test]
    fn learns_the_optimal_policy_and_values_of_a_corridor() {
        let mut agent = QLambda::new(2 * N, params());
        let mut task = Corridor { at: 0 };
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for _ in 0..500 {
            agent.episode(&mut task, &mut rng, 1000);
        }
        for cell in 0..N - 1 {
            let (left, right) = (agent.weight(cell * 2), agent.weight(cell * 2 + 1));
            assert!(
                right > left,
                "cell {cell}: right {right} should beat left {left}"
            );
            // The optimal value of going right from `cell` is γ^(steps left − 1).
            let optimal = 0.9f64.powi((N - 2 - cell) as i32);
            assert!(
                (right - optimal).abs() < 0.05,
                "cell {cell}: {right} vs {optimal}"
            );
        }
        // Greedy from the start walks straight to the goal.
        agent.params.epsilon = 0.0;
        let stats = agent.episode(&mut task, &mut rng, 1000);
        assert_eq!(stats.steps as usize, N - 1);
    }

    #[test]
    fn traces_decay_by_gamma_lambda_after_greedy_and_are_cut_after_exploring() {
        let mut agent = QLambda::new(16, params());
        agent.accumulate(&[3, 5]);
        agent.accumulate(&[5]);
        let before: Vec<(usize, f64)> = agent.traces().collect();
        assert_eq!(before, vec![(3, 1.0), (5, 2.0)]);
        agent.apply(trace_rule(&[0.0, 1.0], 1));
        let k = 0.9 * 0.8;
        assert_eq!(
            agent.traces().collect::<Vec<_>>(),
            vec![(3, k), (5, 2.0 * k)]
        );
        agent.apply(trace_rule(&[0.0, 1.0], 0));
        assert_eq!(agent.traces().count(), 0);
        agent.accumulate(&[7]);
        assert_eq!(agent.traces().collect::<Vec<_>>(), vec![(7, 1.0)]);
    }

    #[test]
    fn an_exploratory_action_that_is_also_greedy_keeps_the_traces() {
        let qs = [0.5, 0.2, 0.9, 0.9];
        assert_eq!(trace_rule(&qs, 2), TraceRule::Decay);
        assert_eq!(
            trace_rule(&qs, 3),
            TraceRule::Decay,
            "tied for best is greedy"
        );
        assert_eq!(trace_rule(&qs, 0), TraceRule::Cut);
    }

    #[test]
    fn the_same_seed_learns_the_same_weights() {
        let run = |seed| {
            let mut agent = QLambda::new(2 * N, params());
            let mut task = Corridor { at: 0 };
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let steps: Vec<u32> = (0..50)
                .map(|_| agent.episode(&mut task, &mut rng, 1000).steps)
                .collect();
            (
                steps,
                (0..2 * N)
                    .map(|i| agent.weight(i).to_bits())
                    .collect::<Vec<_>>(),
            )
        };
        assert_eq!(run(9), run(9));
        assert_ne!(run(9), run(10));
    }
}
