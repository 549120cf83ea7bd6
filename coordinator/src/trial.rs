//! One trial: generations of select, cross, mutate (and, for `guided`,
//! evolve), flown by an [`Evaluator`], restarting with a new pad after
//! `max_generations`, until a safe landing or `max_restarts` run out.

use crate::config::RunConfig;
use crate::evaluator::{Batch, EvalError, Evaluator};
use crate::ga::{next_generation, random_population, Genome};
use lander_protocol::stream::streams;
use lander_protocol::{Env, Method, StreamKey};
use lander_worker::{Evaluation, Outcome};
use rand::Rng;
use serde::Serialize;

/// One generation's record, a line of `generations.jsonl`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Generation {
    /// Generations flown in the trial so far, this one included.
    pub index: u64,
    pub restart: u64,
    /// The generation's number within its restart, from 1.
    pub generation: u64,
    pub best: f64,
    pub mean: f64,
    pub evaluated: usize,
    /// Ticks simulated: flights plus the guided pass's look-aheads.
    pub ticks: u64,
}

/// The best individual of the trial's last attempt.
#[derive(Clone, Debug, PartialEq)]
pub struct Best {
    pub genome: Genome,
    pub outcome: Outcome,
    pub index: u64,
}

#[derive(Clone, Debug, PartialEq)]
pub struct TrialResult {
    pub x0: f64,
    /// The pad of the last attempt.
    pub pad_x: f64,
    pub landed: bool,
    pub generations: u64,
    pub restarts: u64,
    pub best: Best,
}

/// The trial's start column, `U[0, W)` from `(seed, trial)`.
pub fn start_x(cfg: &RunConfig) -> f64 {
    let key = StreamKey::new(cfg.seed, cfg.trial, 0, 0);
    key.rng(streams::START).random::<f64>() * cfg.world.width
}

/// The pad of a restart, `U[margin, W − margin)` from `(seed, trial, restart)`.
pub fn pad_x(cfg: &RunConfig, restart: u64) -> f64 {
    let key = StreamKey::new(cfg.seed, cfg.trial, restart, 0);
    let m = cfg.world.pad_margin;
    m + key.rng(streams::PAD).random::<f64>() * (cfg.world.width - 2.0 * m)
}

/// The environment of one attempt.
pub fn env(cfg: &RunConfig, restart: u64) -> Env {
    Env {
        world: cfg.world,
        scoring: cfg.scoring,
        x0: start_x(cfg),
        pad_x: pad_x(cfg, restart),
    }
}

/// An observer's own failure, such as a log it cannot write.
pub type ObserveError = Box<dyn std::error::Error + Send + Sync>;

/// Sees every generation as soon as it is scored; an error stops the trial.
pub type Observer<'a> = dyn FnMut(&Generation) -> Result<(), ObserveError> + 'a;

#[derive(Debug, thiserror::Error)]
pub enum TrialError {
    #[error("{0} is not a genetic algorithm; it trains with lander_worker::learn::train")]
    NotEvolution(&'static str),
    #[error(transparent)]
    Eval(#[from] EvalError),
    #[error(transparent)]
    Observer(ObserveError),
}

/// Runs one trial.
pub fn run_trial(
    cfg: &RunConfig,
    evaluator: &mut dyn Evaluator,
    observe: &mut Observer<'_>,
) -> Result<TrialResult, TrialError> {
    let method = cfg
        .method
        .evolution()
        .ok_or(TrialError::NotEvolution(cfg.method.name()))?;
    let mut index = 0;
    let mut restart = 0;
    loop {
        let env = env(cfg, restart);
        let attempt = run_attempt(cfg, method, &env, restart, &mut index, evaluator, observe)?;
        let out_of_restarts = restart >= cfg.ga.max_restarts;
        if attempt.landed || out_of_restarts {
            return Ok(TrialResult {
                x0: env.x0,
                pad_x: env.pad_x,
                landed: attempt.landed,
                generations: index,
                restarts: restart,
                best: attempt.best,
            });
        }
        restart += 1;
    }
}

struct Attempt {
    landed: bool,
    best: Best,
}

fn run_attempt(
    cfg: &RunConfig,
    method: Method,
    env: &Env,
    restart: u64,
    index: &mut u64,
    evaluator: &mut dyn Evaluator,
    observe: &mut Observer<'_>,
) -> Result<Attempt, TrialError> {
    let key = |generation| StreamKey::new(cfg.seed, cfg.trial, restart, generation);
    let mut population = random_population(&cfg.ga, &mut key(1).rng(streams::OPERATORS));
    let mut best: Option<Best> = None;
    for generation in 1..=cfg.ga.max_generations.max(1) {
        let evaluations = evaluator.evaluate(Batch {
            env: *env,
            method,
            guide: cfg.guided,
            key: key(generation),
            max_duration: cfg.ga.max_duration,
            genomes: &mut population,
        })?;
        *index += 1;
        observe(&record(*index, restart, generation, &evaluations))
            .map_err(TrialError::Observer)?;
        let landed = evaluations.iter().position(|e| e.outcome.safe);
        let top = landed.unwrap_or_else(|| fittest(&evaluations));
        let improves = best
            .as_ref()
            .is_none_or(|b| evaluations[top].outcome.fitness > b.outcome.fitness);
        if improves || landed.is_some() {
            best = Some(Best {
                genome: population[top].clone(),
                outcome: evaluations[top].outcome,
                index: *index,
            });
        }
        if landed.is_some() {
            break;
        }
        if generation < cfg.ga.max_generations {
            let fitness: Vec<f64> = evaluations.iter().map(|e| e.outcome.fitness).collect();
            let mut rng = key(generation + 1).rng(streams::OPERATORS);
            population = next_generation(&cfg.ga, &population, &fitness, &mut rng);
        }
    }
    let best = best.expect("the loop runs at least once and the first generation sets best");
    Ok(Attempt {
        landed: best.outcome.safe,
        best,
    })
}

/// The first index of the highest fitness.
fn fittest(evaluations: &[Evaluation]) -> usize {
    let mut top = 0;
    for (i, e) in evaluations.iter().enumerate() {
        if e.outcome.fitness > evaluations[top].outcome.fitness {
            top = i;
        }
    }
    top
}

fn record(index: u64, restart: u64, generation: u64, evaluations: &[Evaluation]) -> Generation {
    let fitness = evaluations.iter().map(|e| e.outcome.fitness);
    Generation {
        index,
        restart,
        generation,
        best: fitness.clone().fold(f64::NEG_INFINITY, f64::max),
        mean: fitness.sum::<f64>() / evaluations.len() as f64,
        evaluated: evaluations.len(),
        ticks: evaluations.iter().map(|e| e.simulated_ticks).sum(),
    }
}
