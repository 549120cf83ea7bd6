//! Planning a sweep: shared trials run once and give every setting the
//! record it would have had alone.

use super::*;
use crate::evaluator::InProcess;
use crate::experiment::{experiment_tasks, run, ExperimentError, Progress};
use crate::trial::Generation;

const SMALL: &str = "name = \"s\"\ntrials = 2\nmethods = [\"ga\", \"guided\"]\n\
    [ga]\npopulation = 12\ngenome_length = 10\nmax_generations = 4\nmax_restarts = 1\n\
    [grids.eps]\n\"guided.epsilon\" = [0.0, 0.5]\n";

/// Collects records by key.
struct Collect<K>(Vec<(K, TrialRecord)>);

impl<K: Copy> Progress<K> for Collect<K> {
    fn started(&mut self, _: K, _: &RunConfig) {}
    fn generation(&mut self, _: K, _: &Generation) {}
    fn finished(&mut self, key: K, record: TrialRecord) -> Result<(), ExperimentError> {
        self.0.push((key, record));
        Ok(())
    }
}

fn without_wall_time(mut r: TrialRecord) -> TrialRecord {
    r.wall_s = 0.0;
    r
}

#[test]
fn the_general_ga_runs_once_for_settings_that_differ_only_in_guidance() {
    let sweep = Sweep::parse(SMALL, false).unwrap();
    let plan = Plan::new(&sweep, &[]);
    // 2 settings × 2 trials × 2 methods, of which the GA's are shared.
    assert_eq!(plan.trials(), 8);
    assert_eq!(plan.tasks.len(), 6);
    for (task, group) in plan.tasks.iter().zip(&plan.groups) {
        let shared = task.cfg.method == Method::Ga;
        assert_eq!(group.len(), if shared { 2 } else { 1 }, "{group:?}");
    }
}

#[test]
fn a_shared_trial_gives_each_setting_its_own_record() {
    let sweep = Sweep::parse(SMALL, false).unwrap();
    let plan = Plan::new(&sweep, &[]);
    let mut backend = InProcess::new(2).unwrap();
    let mut planned = Collect(Vec::new());
    run(&plan.tasks, &mut backend, 3, &mut planned).unwrap();
    for (s, setting) in sweep.settings.iter().enumerate() {
        let exp = &setting.experiment;
        let mut alone = Collect(Vec::new());
        let tasks = experiment_tasks(exp, &trials(exp));
        run(&tasks, &mut backend, 1, &mut alone).unwrap();
        assert_eq!(alone.0.len(), 4);
        for (id, record) in alone.0 {
            let (g, shared) = planned
                .0
                .iter()
                .find(|(g, _)| {
                    plan.groups[*g].contains(&SweepTrial {
                        setting: s,
                        trial: id,
                    })
                })
                .expect("every trial is planned");
            assert_eq!(
                without_wall_time(shared.clone()),
                without_wall_time(record),
                "setting {s}, {id:?}, task {g}"
            );
        }
    }
}

#[test]
fn finished_trials_are_not_planned_again() {
    let sweep = Sweep::parse(SMALL, false).unwrap();
    let plan = Plan::new(&sweep, &[]);
    let mut backend = InProcess::new(1).unwrap();
    let mut done = Collect(Vec::new());
    run(&plan.tasks[..2], &mut backend, 2, &mut done).unwrap();
    let mut finished = vec![Vec::new(); sweep.settings.len()];
    for (g, record) in done.0 {
        for m in &plan.groups[g] {
            finished[m.setting].push(record.clone());
        }
    }
    let rest = Plan::new(&sweep, &finished);
    assert_eq!(
        rest.trials(),
        plan.trials() - plan.groups[..2].iter().map(Vec::len).sum::<usize>()
    );
    for group in &rest.groups {
        for m in group {
            assert!(!finished[m.setting]
                .iter()
                .any(|r| TrialId::of(r) == m.trial));
        }
    }
}
