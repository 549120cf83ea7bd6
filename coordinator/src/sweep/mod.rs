//! `lander sweep`: one experiment under many settings, all their trials run
//! as one workload on one backend, stored setting by setting so that an
//! interrupted sweep can resume, and compared in one table, plots and a
//! report.
//!
//! - [`file`](mod@file): the sweep file, its grids and listed settings, all checked
//!   before anything runs;
//! - [`store`]: the sweep folder, an experiment folder per setting;
//! - [`outputs`]: `sweep.csv`, `sweep.md`, the plots and `report.html`.
//!
//! Trial `t` of a setting is a pure function of the sweep file, the setting
//! and `t` ([`crate::experiment::runner`] never lets one trial see
//! another), so the results are the same on any backend, with any number of
//! workers, in any order and across resumes.

pub mod file;
pub mod outputs;
pub mod store;

pub use file::{Setting, Sweep};
pub use store::{SweepStore, SweepStoreError};

use crate::config::RunConfig;
use crate::experiment::{trials, Task, TrialId};
use lander_model::{GuideParams, LearnParams, Method};
use lander_report::model::TrialRecord;
use std::collections::{HashMap, HashSet};

/// One trial of one setting.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SweepTrial {
    /// The setting's position in [`Sweep::settings`].
    pub setting: usize,
    pub trial: TrialId,
}

/// The trials still to run. Settings often share trials: a grid over ε
/// changes nothing for the general GA, which never runs the guided pass.
/// Such trials run once, as one task, and their record goes to every
/// setting in the task's group.
pub struct Plan {
    /// Keyed by their position in `groups`, setting by setting, so that
    /// settings finish one after another.
    pub tasks: Vec<Task<usize>>,
    /// The unfinished trials each task stands for.
    pub groups: Vec<Vec<SweepTrial>>,
}

impl Plan {
    /// Plans the trials not yet finished; `finished[s]` holds setting `s`'s
    /// finished records.
    pub fn new(sweep: &Sweep, finished: &[Vec<TrialRecord>]) -> Plan {
        let mut plan = Plan {
            tasks: Vec::new(),
            groups: Vec::new(),
        };
        let mut by_config: HashMap<String, usize> = HashMap::new();
        for (s, setting) in sweep.settings.iter().enumerate() {
            let done: HashSet<TrialId> = finished
                .get(s)
                .map(|r| r.iter().map(TrialId::of).collect())
                .unwrap_or_default();
            for trial in trials(&setting.experiment) {
                if done.contains(&trial) {
                    continue;
                }
                let member = SweepTrial { setting: s, trial };
                let cfg = setting.experiment.config(trial.method, trial.trial);
                // serde_json of a RunConfig cannot fail: plain numbers,
                // strings and enums.
                let same = serde_json::to_string(&effective(&cfg)).unwrap_or_default();
                match by_config.get(&same) {
                    Some(&g) => plan.groups[g].push(member),
                    None => {
                        by_config.insert(same, plan.tasks.len());
                        plan.tasks.push(Task {
                            key: plan.tasks.len(),
                            cfg,
                        });
                        plan.groups.push(vec![member]);
                    }
                }
            }
        }
        plan
    }

    /// How many trials the plan finishes, counting each member.
    pub fn trials(&self) -> usize {
        self.groups.iter().map(Vec::len).sum()
    }
}

/// The part of a trial's configuration its results depend on: the general
/// GA never runs the guided pass or learns, the guided GA never learns, and
/// Q(λ) breeds no population.
pub fn effective(cfg: &RunConfig) -> RunConfig {
    let mut cfg = cfg.clone();
    match cfg.method {
        Method::Ga => {
            cfg.guided = GuideParams::default();
            cfg.qlearning = LearnParams::default();
        }
        Method::Guided => cfg.qlearning = LearnParams::default(),
        Method::Qlearning => cfg.ga = Default::default(),
    }
    cfg
}

#[cfg(test)]
mod tests;
