//! An experiment file: which methods, how many paired trials, the seed, and
//! the parameters every trial shares (the same sections as a run's TOML).

use crate::config::{toml_error, ConfigError, RunConfig};
use crate::ga::GaParams;
use lander_model::check::{check, ParamError};
use lander_model::Method;
use lander_model::{GuideParams, LearnParams, Scoring, World};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The most trials per method an experiment may ask for.
pub const MAX_TRIALS: u64 = 10_000;

/// What `lander experiment FILE.toml` runs. Trial `t` of every method flies
/// from the same `x0` to the same first pad, so the methods are paired.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Experiment {
    /// Names the default output folder, `results/<name>`.
    pub name: String,
    pub seed: u64,
    /// Trials per method, numbered from 1.
    pub trials: u64,
    /// Any of `ga`, `guided` and `qlearning`, each at most once.
    pub methods: Vec<Method>,
    /// The trial whose fitness per generation is plotted (the paper's
    /// Figure 4 shows its 13th); the last trial when it is beyond the count.
    pub figure_trial: u64,
    pub world: World,
    pub scoring: Scoring,
    pub guided: GuideParams,
    pub ga: GaParams,
    pub qlearning: LearnParams,
}

/// What [`is_folder_name`] allows, for error messages.
pub const FOLDER_NAME_RULE: &str =
    "must be 1 to 64 letters, digits, '-', '_' or '.', not starting with '.'";

/// Whether `name` can name a folder on any system without quoting: 1 to 64
/// letters, digits, `-`, `_` or `.`, not starting with `.`.
pub fn is_folder_name(name: &str) -> bool {
    !name.is_empty()
        && name.len() <= 64
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c))
        && !name.starts_with('.')
}

impl Default for Experiment {
    fn default() -> Self {
        let run = RunConfig::default();
        Experiment {
            name: "experiment".into(),
            seed: 1,
            trials: 25,
            methods: vec![Method::Ga, Method::Guided, Method::Qlearning],
            figure_trial: 13,
            world: run.world,
            scoring: run.scoring,
            guided: run.guided,
            ga: run.ga,
            qlearning: run.qlearning,
        }
    }
}

impl Experiment {
    /// Reads and validates a TOML file.
    pub fn load(path: &Path) -> Result<Experiment, ConfigError> {
        let shown = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|error| ConfigError::Read {
            path: shown.clone(),
            error,
        })?;
        let exp: Experiment = toml::from_str(&text).map_err(|e| ConfigError::Parse {
            path: shown.clone(),
            message: toml_error(&text, &e),
        })?;
        exp.validate().map_err(|e| ConfigError::Parse {
            path: shown,
            message: e.to_string(),
        })?;
        Ok(exp)
    }

    /// Checks every field, naming the first that is out of range.
    pub fn validate(&self) -> Result<(), ConfigError> {
        check("name", is_folder_name(&self.name), FOLDER_NAME_RULE)?;
        check(
            "trials",
            (1..=MAX_TRIALS).contains(&self.trials),
            "must be 1 to 10,000",
        )?;
        check(
            "methods",
            !self.methods.is_empty(),
            "must name at least one method",
        )?;
        for (i, m) in self.methods.iter().enumerate() {
            if self.methods[..i].contains(m) {
                return Err(ParamError {
                    field: "methods",
                    problem: format!("names {} twice", m.name()),
                }
                .into());
            }
        }
        check("figure_trial", self.figure_trial >= 1, "must be at least 1")?;
        self.config(Method::Guided, 1).validate()
    }

    /// The run configuration of one trial of one method.
    pub fn config(&self, method: Method, trial: u64) -> RunConfig {
        RunConfig {
            method,
            seed: self.seed,
            trial,
            threads: 0,
            world: self.world,
            scoring: self.scoring,
            guided: self.guided,
            ga: self.ga.clone(),
            qlearning: self.qlearning,
        }
    }

    /// Trials in all: `trials` of each method.
    pub fn trial_count(&self) -> u64 {
        self.methods.len() as u64 * self.trials
    }

    /// The trial Figure 4 shows.
    pub fn shown_trial(&self) -> u64 {
        self.figure_trial.min(self.trials)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Experiment, String> {
        let exp: Experiment = toml::from_str(text).map_err(|e| e.to_string())?;
        exp.validate().map_err(|e| e.to_string())?;
        Ok(exp)
    }

    #[test]
    fn the_shipped_paper_experiment_is_the_papers() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../experiments/paper.toml");
        let exp = Experiment::load(&path).expect("paper.toml loads");
        assert_eq!(exp.trials, 25);
        assert_eq!(
            exp.methods,
            vec![Method::Ga, Method::Guided, Method::Qlearning]
        );
        assert_eq!(exp.shown_trial(), 13);
        // The paper's parameters are the defaults.
        let defaults = Experiment::default();
        assert_eq!(exp.ga, defaults.ga);
        assert_eq!(exp.world, defaults.world);
        assert_eq!(exp.guided, defaults.guided);
        assert_eq!(exp.qlearning, defaults.qlearning);
    }

    #[test]
    fn overrides_reach_every_trial() {
        let exp = parse("trials = 3\nmethods = [\"guided\"]\n[ga]\npopulation = 20\n").unwrap();
        let cfg = exp.config(Method::Guided, 2);
        assert_eq!((cfg.trial, cfg.ga.population), (2, 20));
        assert_eq!(exp.shown_trial(), 3);
    }

    #[test]
    fn bad_fields_are_named() {
        for (text, field) in [
            ("trials = 0", "trials"),
            ("methods = []", "methods"),
            ("methods = [\"ga\", \"ga\"]", "methods"),
            ("name = \"../x\"", "name"),
            ("figure_trial = 0", "figure_trial"),
            ("[ga]\npopulation = 0", "ga.population"),
            ("trail = 3", "trail"),
            ("methods = [\"sarsa\"]", "sarsa"),
        ] {
            let err = parse(text).expect_err(text);
            assert!(err.contains(field), "{text}: {err}");
        }
    }
}
