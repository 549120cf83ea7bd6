//! Runs an experiment's trials on one [`Backend`]: the GA trials stepped
//! together, a generation of each per round, so that every core stays busy
//! even with small populations; then the Q(λ) trials, one job each.

use super::file::Experiment;
use crate::config::RunConfig;
use crate::evaluator::{Backend, EvalError};
use crate::trial::{Generation, TrialError, TrialResult, TrialRun};
use lander_model::Method;
use lander_model::TrainJob;
use lander_model::{format_genome, Evaluation, StreamKey, TrainResult};
use lander_report::model::{BestLander, FitnessPoint, Learning, TrialRecord};
use rayon::prelude::*;
use std::time::Instant;

/// One trial of one method.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct TrialId {
    pub method: Method,
    pub trial: u64,
}

impl TrialId {
    /// The trial a record is of.
    pub fn of(record: &TrialRecord) -> TrialId {
        TrialId {
            method: record.method,
            trial: record.trial,
        }
    }
}

/// Every trial of the experiment: trial by trial, each method in the
/// file's order, so that an interrupted run has finished whole pairs.
pub fn tasks(exp: &Experiment) -> Vec<TrialId> {
    (1..=exp.trials)
        .flat_map(|trial| {
            exp.methods
                .iter()
                .map(move |&method| TrialId { method, trial })
        })
        .collect()
}

/// What the runner reports as it goes. A `finished` error stops the run.
pub trait Progress {
    fn started(&mut self, task: TrialId, cfg: &RunConfig);
    fn generation(&mut self, task: TrialId, generation: &Generation);
    fn finished(&mut self, record: TrialRecord) -> Result<(), ExperimentError>;
}

#[derive(Debug, thiserror::Error)]
pub enum ExperimentError {
    #[error(transparent)]
    Trial(#[from] TrialError),
    #[error(transparent)]
    Eval(#[from] EvalError),
    #[error("{0}")]
    Store(String),
}

/// Runs `tasks` with at most `in_flight` GA trials at once. Every trial's
/// results depend only on the experiment and its number, never on
/// `in_flight`, the backend or the order of finishing.
pub fn run(
    exp: &Experiment,
    tasks: &[TrialId],
    backend: &mut dyn Backend,
    in_flight: usize,
    progress: &mut dyn Progress,
) -> Result<(), ExperimentError> {
    let (learning, evolving): (Vec<TrialId>, Vec<TrialId>) =
        tasks.iter().partition(|t| t.method == Method::Qlearning);
    evolve(exp, &evolving, backend, in_flight.max(1), progress)?;
    learn(exp, &learning, backend, progress)
}

struct Running {
    task: TrialId,
    run: TrialRun,
    log: Vec<Generation>,
    started: Instant,
}

fn evolve(
    exp: &Experiment,
    tasks: &[TrialId],
    backend: &mut dyn Backend,
    in_flight: usize,
    progress: &mut dyn Progress,
) -> Result<(), ExperimentError> {
    let mut queue = tasks.iter();
    let mut running: Vec<Running> = Vec::new();
    loop {
        while running.len() < in_flight {
            let Some(&task) = queue.next() else { break };
            let cfg = exp.config(task.method, task.trial);
            progress.started(task, &cfg);
            running.push(Running {
                task,
                run: TrialRun::new(&cfg)?,
                log: Vec::new(),
                started: Instant::now(),
            });
        }
        if running.is_empty() {
            return Ok(());
        }
        let batches = running.iter_mut().map(|r| r.run.batch()).collect();
        let evaluations = backend.evaluate_many(batches)?;
        let generations = match backend.threads() {
            Some(pool) => pool.install(|| breed(&mut running, &evaluations)),
            None => breed(&mut running, &evaluations),
        };
        for (r, generation) in running.iter_mut().zip(generations) {
            progress.generation(r.task, &generation);
            r.log.push(generation);
        }
        let mut i = 0;
        while i < running.len() {
            if let Some(result) = running[i].run.result() {
                let r = &running[i];
                let record = evolution_record(r.run.config(), result, &r.log, r.started);
                running.remove(i);
                progress.finished(record)?;
            } else {
                i += 1;
            }
        }
    }
}

/// Scores each running trial's generation and breeds its next. Each trial
/// draws from its own keyed stream, so doing them in parallel changes
/// nothing but the time: serial, breeding took a sixth of an in-process
/// experiment's GA time on 2 cores.
fn breed(running: &mut [Running], evaluations: &[Vec<Evaluation>]) -> Vec<Generation> {
    running
        .par_iter_mut()
        .zip(evaluations)
        .map(|(r, evaluations)| r.run.accept(evaluations))
        .collect()
}

fn learn(
    exp: &Experiment,
    tasks: &[TrialId],
    backend: &mut dyn Backend,
    progress: &mut dyn Progress,
) -> Result<(), ExperimentError> {
    if tasks.is_empty() {
        return Ok(());
    }
    let configs: Vec<RunConfig> = tasks
        .iter()
        .map(|t| exp.config(t.method, t.trial))
        .collect();
    let jobs: Vec<TrainJob> = configs
        .iter()
        .map(|cfg| TrainJob {
            env: cfg.env(0),
            guide: cfg.guided,
            learn: cfg.qlearning,
            key: StreamKey::new(cfg.seed, cfg.trial, 0, 0),
        })
        .collect();
    for (task, cfg) in tasks.iter().zip(&configs) {
        progress.started(*task, cfg);
    }
    let started = Instant::now();
    // A store failure is reported once training stops; training a few
    // more trials in the meantime loses nothing.
    let mut failure = None;
    backend.train(&jobs, &mut |i, result| {
        if failure.is_some() {
            return;
        }
        let record = learning_record(&configs[i], &jobs[i], result, started);
        if let Err(e) = progress.finished(record) {
            failure = Some(e);
        }
    })?;
    failure.map_or(Ok(()), Err)
}

/// The record of a finished GA trial.
pub fn evolution_record(
    cfg: &RunConfig,
    result: &TrialResult,
    log: &[Generation],
    started: Instant,
) -> TrialRecord {
    TrialRecord {
        method: cfg.method,
        seed: cfg.seed,
        trial: cfg.trial,
        x0: result.x0,
        pad_x: cfg.env(0).pad_x,
        landed: result.landed,
        generations: Some(result.generations),
        restarts: Some(result.restarts),
        episodes: None,
        wall_s: started.elapsed().as_secs_f64(),
        fitness: log
            .iter()
            .map(|g| FitnessPoint {
                index: g.index,
                restart: g.restart,
                best: g.best,
                mean: g.mean,
            })
            .collect(),
        best: Some(BestLander {
            genome: format_genome(&result.best.genome),
            fitness: result.best.outcome.fitness,
            safe: result.best.outcome.safe,
            pad_x: result.pad_x,
        }),
        learning: None,
    }
}

/// The record of a finished Q(λ) trial. Trials train in parallel, so its
/// wall time is the time since training began.
pub fn learning_record(
    cfg: &RunConfig,
    job: &TrainJob,
    result: &TrainResult,
    started: Instant,
) -> TrialRecord {
    let t = &result.training;
    TrialRecord {
        method: cfg.method,
        seed: cfg.seed,
        trial: cfg.trial,
        x0: job.env.x0,
        pad_x: job.env.pad_x,
        landed: t.first_safe.is_some(),
        generations: None,
        restarts: None,
        episodes: t.first_safe,
        wall_s: started.elapsed().as_secs_f64(),
        fitness: Vec::new(),
        best: None,
        learning: Some(Learning {
            episodes: t.episodes,
            first_safe: t.first_safe,
            landing_rate_last_100: t.landing_rate_last_100,
            returns: result.episodes.iter().map(|e| e.reward).collect(),
        }),
    }
}
