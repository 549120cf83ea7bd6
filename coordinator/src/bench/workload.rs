//! The work `lander bench` measures: seeded random generations, the same
//! for every mode and every round.

use crate::config::RunConfig;
use crate::ga::{random_population, Genome};
use lander_model::stream::streams;
use lander_model::{Env, Pass, StreamKey};

/// The generations every mode evaluates: random populations keyed by the
/// configuration's seed, so every mode and every round sees the same work.
/// A step is one generation of each of `in_flight` trials, evaluated
/// together as `lander experiment` steps the trials it has in flight.
pub struct Workload {
    pub cfg: RunConfig,
    pub method: Pass,
    pub in_flight: usize,
    /// Per step, one population per trial in flight.
    pub steps: Vec<Vec<Population>>,
}

/// One trial's generation: where it flies and what.
pub struct Population {
    pub env: Env,
    pub key: StreamKey,
    pub genomes: Vec<Genome>,
}

impl Workload {
    /// `generations` steps of `in_flight` trials, numbered from the
    /// configuration's trial on.
    pub fn new(cfg: &RunConfig, method: Pass, generations: u64, in_flight: usize) -> Workload {
        let trials: Vec<RunConfig> = (0..in_flight as u64)
            .map(|t| RunConfig {
                trial: cfg.trial + t,
                ..cfg.clone()
            })
            .collect();
        let steps = (1..=generations)
            .map(|g| {
                trials
                    .iter()
                    .map(|trial| {
                        let key = StreamKey::new(trial.seed, trial.trial, 0, g);
                        Population {
                            env: trial.env(0),
                            key,
                            genomes: random_population(&trial.ga, &mut key.rng(streams::OPERATORS)),
                        }
                    })
                    .collect()
            })
            .collect();
        Workload {
            cfg: cfg.clone(),
            method,
            in_flight,
            steps,
        }
    }

    pub fn genomes(&self) -> usize {
        self.steps.iter().flatten().map(|p| p.genomes.len()).sum()
    }
}
