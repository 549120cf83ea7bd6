//! `lander bench --stress`'s logic: a workload flown by a reference mode
//! and by a mode whose workers are killed meanwhile, the check that every
//! genome came back exactly once and unchanged ([`StressReport`]), and the
//! kills' random schedule ([`kill_gap`]).

use super::mode::Mode;
use super::Workload;
use crate::evaluator::EvalError;
use serde::Serialize;
use std::time::Duration;

/// The most kills a second: a worker needs some milliseconds to start, so
/// beyond this the workers would do little but die.
pub const MAX_KILL_RATE: f64 = 100.0;

/// The longest wait between two kills, however low the rate.
const MAX_GAP_S: f64 = 60.0;

/// What churn did, as `lander bench --stress --json` prints it.
#[derive(Debug, Serialize)]
pub struct StressReport {
    pub method: &'static str,
    pub population: usize,
    pub generations: usize,
    pub workers: usize,
    pub kill_rate: f64,
    pub kills: u64,
    pub genomes_per_s: f64,
    pub ticks_per_s: f64,
    /// Genomes evaluated, and how many the workload holds.
    pub evaluated: u64,
    pub expected: u64,
    /// Every result equals the in-process one.
    pub results_match: bool,
}

/// Flies every generation of `work` through `reference` and then
/// `churned`, as one round each.
pub fn fly(work: &Workload, reference: &mut Mode, churned: &mut Mode) -> Result<(), EvalError> {
    for g in 0..work.steps.len() {
        reference.block(work, g..g + 1)?;
        churned.block(work, g..g + 1)?;
    }
    reference.end_round();
    churned.end_round();
    Ok(())
}

impl StressReport {
    /// The figures of `churned` against `reference` once both have flown
    /// `work` (see [`fly`]), while `kills` workers were killed at
    /// `kill_rate` a second asked.
    pub fn new(
        work: &Workload,
        reference: &Mode,
        churned: &Mode,
        kill_rate: f64,
        kills: u64,
    ) -> StressReport {
        let r = churned.report();
        StressReport {
            method: work.pass.method().name(),
            population: work.cfg.ga.population,
            generations: work.steps.len(),
            workers: churned.kind.workers(),
            kill_rate,
            kills,
            genomes_per_s: r.genomes_per_s,
            ticks_per_s: r.ticks_per_s,
            evaluated: churned.tally.genomes,
            expected: work.genomes() as u64,
            results_match: reference.tally.hash == churned.tally.hash,
        }
    }

    /// Nothing lost or changed: as many genomes evaluated as the workload
    /// holds, and every result the reference's.
    pub fn lost_nothing(&self) -> bool {
        self.results_match && self.evaluated == self.expected
    }
}

/// The wait before the next kill, for `rate` kills a second on average,
/// from `u` drawn uniformly from [0, 1): exponential gaps make the kills a
/// Poisson process. At most a minute, so that a low rate still looks at
/// whether to stop.
pub fn kill_gap(u: f64, rate: f64) -> Duration {
    let gap = -u.max(1e-9).ln() / rate;
    Duration::from_secs_f64(gap.min(MAX_GAP_S))
}

#[cfg(test)]
mod tests {
    use super::super::fake::{workload, Fake, Log};
    use super::super::ModeKind;
    use super::*;

    fn modes(churned: Fake, log: &Log) -> (Mode, Mode) {
        let reference = Mode::new(
            ModeKind::InProcess { threads: 1 },
            Box::new(Fake::new("reference", 1, log)),
        );
        let churned = Mode::new(ModeKind::Iceoryx2 { workers: 3 }, Box::new(churned));
        (reference, churned)
    }

    #[test]
    fn a_churned_mode_that_answers_everything_alike_lost_nothing() {
        let log = Log::default();
        let (mut reference, mut churned) = modes(Fake::new("churned", 2, &log), &log);
        let work = workload(4, 5, 1);
        fly(&work, &mut reference, &mut churned).unwrap();
        // Reference then churned, generation by generation, no warm-up.
        let order: Vec<_> = log.borrow().clone();
        assert_eq!(
            order,
            [1, 2, 3, 4]
                .into_iter()
                .flat_map(|g| [("reference", g), ("churned", g)])
                .collect::<Vec<_>>()
        );
        let r = StressReport::new(&work, &reference, &churned, 2.5, 7);
        assert_eq!((r.method, r.population, r.generations), ("guided", 5, 4));
        // The workers asked for, not those alive after the kills.
        assert_eq!((r.workers, r.kill_rate, r.kills), (3, 2.5, 7));
        assert_eq!((r.evaluated, r.expected), (20, 20));
        assert!(r.results_match && r.lost_nothing());
        assert!(r.genomes_per_s > 0.0);
        assert!((r.ticks_per_s / r.genomes_per_s - 10.0).abs() < 1e-9);
    }

    #[test]
    fn a_lost_genome_is_caught() {
        let log = Log::default();
        let mut lossy = Fake::new("churned", 2, &log);
        lossy.drop_last = true;
        let (mut reference, mut churned) = modes(lossy, &log);
        let work = workload(3, 4, 1);
        fly(&work, &mut reference, &mut churned).unwrap();
        let r = StressReport::new(&work, &reference, &churned, 2.0, 0);
        assert_eq!((r.evaluated, r.expected), (9, 12));
        assert!(!r.results_match);
        assert!(!r.lost_nothing());
    }

    #[test]
    fn a_changed_result_is_caught_though_none_is_lost() {
        let log = Log::default();
        let mut wrong = Fake::new("churned", 2, &log);
        wrong.wrong_on = vec![2];
        let (mut reference, mut churned) = modes(wrong, &log);
        let work = workload(3, 4, 2);
        fly(&work, &mut reference, &mut churned).unwrap();
        let r = StressReport::new(&work, &reference, &churned, 2.0, 1);
        assert_eq!((r.evaluated, r.expected), (24, 24));
        assert!(!r.results_match);
        assert!(!r.lost_nothing());
    }

    #[test]
    fn kill_gaps_are_exponential_and_at_most_a_minute() {
        let s = |d: Duration| d.as_secs_f64();
        let close = |a: f64, b: f64| (a - b).abs() < 1e-6;
        // −ln(e^−1) / 2 = 0.5 s; −ln(½) / 4 = ln 2 / 4.
        assert!(close(s(kill_gap((-1.0f64).exp(), 2.0)), 0.5));
        assert!(close(s(kill_gap(0.5, 4.0)), 2f64.ln() / 4.0));
        // 0 draws as 1e-9: −ln(1e-9) = 20.72 s at one kill a second.
        assert!(close(s(kill_gap(0.0, 1.0)), 9.0 * 10f64.ln()));
        // Rare kills wait at most a minute: −ln(0.001) / 0.1 = 69 s.
        assert_eq!(kill_gap(0.001, 0.1), Duration::from_secs(60));
        assert!(close(s(kill_gap(0.5, MAX_KILL_RATE)), 2f64.ln() / 100.0));
    }
}
