//! One trial: generations of select, cross, mutate (and, for `guided`,
//! evolve), flown by an [`Evaluator`], restarting with a new pad after
//! `max_generations`, until a safe landing or `max_restarts` run out.

use crate::config::RunConfig;
use crate::evaluator::{Batch, EvalError, Evaluator};
use crate::ga::{random_population, GaParams, Genome, Offspring};
use lander_model::stream::{streams, StreamRng};
use lander_model::{Env, Pass, StreamKey};
use lander_model::{Evaluation, Outcome};
use serde::{Deserialize, Serialize};

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
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
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

/// An observer's own failure, such as a log it cannot write.
pub type ObserveError = Box<dyn std::error::Error + Send + Sync>;

/// Sees every generation as soon as it is scored; an error stops the trial.
pub type Observer<'a> = dyn FnMut(&Generation) -> Result<(), ObserveError> + 'a;

#[derive(Debug, thiserror::Error)]
pub enum TrialError {
    #[error("{0} is not a genetic algorithm; it trains with lander_model::learn::train")]
    NotEvolution(&'static str),
    #[error(transparent)]
    Eval(#[from] EvalError),
    #[error(transparent)]
    Observer(ObserveError),
    #[error("no trial is numbered past {0}")]
    TrialNumber(u64),
    #[error("the saved trial does not fit its configuration: {0}")]
    State(String),
}

/// Runs one trial.
pub fn run_trial(
    cfg: &RunConfig,
    evaluator: &mut dyn Evaluator,
    observe: &mut Observer<'_>,
) -> Result<TrialResult, TrialError> {
    let mut run = TrialRun::new(cfg)?;
    finish_trial(&mut run, evaluator, &mut |g, _| observe(g))
}

/// Runs `run` to its end. `observe` sees each generation, and the run as
/// it stands after it (to save it); on an error `run` stands before the
/// generation that failed, so that it can be saved and resumed.
pub fn finish_trial(
    run: &mut TrialRun,
    evaluator: &mut dyn Evaluator,
    observe: &mut dyn FnMut(&Generation, &TrialRun) -> Result<(), ObserveError>,
) -> Result<TrialResult, TrialError> {
    loop {
        if let Some(result) = run.result() {
            return Ok(result.clone());
        }
        let evaluations = evaluator.evaluate(run.batch())?;
        let generation = run.accept(&evaluations);
        observe(&generation, run).map_err(TrialError::Observer)?;
    }
}

/// Everything a trial under way needs to go on exactly as it would have:
/// saved between generations, its next generation still to fly.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrialState {
    pub restart: u64,
    /// The generation to fly next, within its restart, from 1.
    pub generation: u64,
    /// Generations flown so far, across restarts.
    pub index: u64,
    pub population: Vec<Genome>,
    pub best: Option<Best>,
}

/// A trial as a state machine, one generation per step: [`batch`] is the
/// generation to fly, [`accept`] takes its evaluations and moves on. This
/// lets one evaluator fly the generations of many trials at once.
///
/// [`batch`]: TrialRun::batch
/// [`accept`]: TrialRun::accept
pub struct TrialRun {
    cfg: RunConfig,
    pass: Pass,
    env: Env,
    restart: u64,
    /// The generation being flown, within its restart, from 1.
    generation: u64,
    /// Generations flown so far, across restarts.
    index: u64,
    /// The generation to fly; empty while it is still to be bred from
    /// `parents`, which lets an evaluator fly each genome as soon as it is
    /// bred (see [`Batch`]).
    population: Vec<Genome>,
    /// The generation flown last, as the guided pass left it, and its
    /// fitness: what an empty `population` is bred from.
    parents: Vec<Genome>,
    fitness: Vec<f64>,
    /// The generation before `parents`, kept for its memory only: the next
    /// breeding reuses it (`Offspring::reusing`).
    retired: Vec<Genome>,
    /// The best individual of the current attempt.
    best: Option<Best>,
    result: Option<TrialResult>,
}

impl TrialRun {
    pub fn new(cfg: &RunConfig) -> Result<TrialRun, TrialError> {
        let pass = cfg
            .method
            .pass()
            .ok_or(TrialError::NotEvolution(cfg.method.name()))?;
        let mut run = TrialRun {
            cfg: cfg.clone(),
            pass,
            env: cfg.env(0),
            restart: 0,
            generation: 1,
            index: 0,
            population: Vec::new(),
            parents: Vec::new(),
            fitness: Vec::new(),
            retired: Vec::new(),
            best: None,
            result: None,
        };
        run.begin_attempt(0);
        Ok(run)
    }

    fn key(&self, generation: u64) -> StreamKey {
        StreamKey::new(self.cfg.seed, self.cfg.trial, self.restart, generation)
    }

    fn begin_attempt(&mut self, restart: u64) {
        self.restart = restart;
        self.env = self.cfg.env(restart);
        self.generation = 1;
        self.best = None;
        let mut rng = self.key(1).rng(streams::OPERATORS);
        self.population = random_population(&self.cfg.ga, &mut rng);
    }

    /// The generation to fly next, with its breeding where it is still to
    /// be bred.
    pub fn batch(&mut self) -> Batch<'_> {
        let key = self.key(self.generation);
        let offspring = self.population.is_empty().then(|| {
            offspring(&self.cfg.ga, &self.parents, &self.fitness, key)
                .reusing(std::mem::take(&mut self.retired))
        });
        Batch::new(
            self.env,
            self.pass,
            self.cfg.guided,
            key,
            self.cfg.ga.max_duration,
            &mut self.population,
        )
        .breeding(offspring)
    }

    /// Breeds the next generation now, if it is still to be bred, rather
    /// than while it flies: for a caller that breeds many trials' next
    /// generations in parallel.
    pub fn breed(&mut self) {
        self.batch().bred_genomes();
    }

    /// Takes the evaluations of [`TrialRun::batch`], one per genome in
    /// order, and prepares the next generation, a restart, or the result.
    pub fn accept(&mut self, evaluations: &[Evaluation]) -> Generation {
        self.index += 1;
        let generation = record(self.index, self.restart, self.generation, evaluations);
        let landed = evaluations.iter().position(|e| e.outcome.safe);
        let top = landed.unwrap_or_else(|| fittest(evaluations));
        let improves = self
            .best
            .as_ref()
            .is_none_or(|b| evaluations[top].outcome.fitness > b.outcome.fitness);
        if improves || landed.is_some() {
            self.best = Some(Best {
                genome: self.population[top].clone(),
                outcome: evaluations[top].outcome,
                index: self.index,
            });
        }
        let last = self.generation >= self.cfg.ga.max_generations;
        if landed.is_some() || last {
            self.end_attempt();
        } else {
            // The next generation is bred from these as it flies: `batch`
            // hands the breeding to the evaluator.
            self.fitness.clear();
            self.fitness
                .extend(evaluations.iter().map(|e| e.outcome.fitness));
            std::mem::swap(&mut self.parents, &mut self.population);
            self.retired.clear();
            self.retired.append(&mut self.population);
            self.generation += 1;
        }
        generation
    }

    fn end_attempt(&mut self) {
        let Some(best) = self.best.take() else {
            return;
        };
        let landed = best.outcome.safe;
        if landed || self.restart >= self.cfg.ga.max_restarts {
            self.result = Some(TrialResult {
                x0: self.env.x0,
                pad_x: self.env.pad_x,
                landed,
                generations: self.index,
                restarts: self.restart,
                best,
            });
        } else {
            self.begin_attempt(self.restart + 1);
        }
    }

    /// The trial as it stands between generations; `None` once it has
    /// ended.
    pub fn state(&self) -> Option<TrialState> {
        if self.result.is_some() {
            return None;
        }
        Some(TrialState {
            restart: self.restart,
            generation: self.generation,
            index: self.index,
            population: self.bred(),
            best: self.best.clone(),
        })
    }

    /// The generation flown last, as the guided pass left it, and its
    /// fitness, while the next generation is still to be bred from them.
    pub fn parents(&self) -> Option<(&[Genome], &[f64])> {
        self.population
            .is_empty()
            .then_some((&self.parents[..], &self.fitness[..]))
    }

    /// The generation to fly next, bred here if it is still to be bred.
    fn bred(&self) -> Vec<Genome> {
        if !self.population.is_empty() {
            return self.population.clone();
        }
        let key = self.key(self.generation);
        offspring(&self.cfg.ga, &self.parents, &self.fitness, key).collect()
    }

    /// The trial `cfg` saved as `state`, to go on from there. A state that
    /// `cfg` could not have produced is refused, saying why.
    pub fn resume(cfg: &RunConfig, state: TrialState) -> Result<TrialRun, TrialError> {
        let mut run = TrialRun::new(cfg)?;
        let ga = &cfg.ga;
        let problem = if state.restart > ga.max_restarts {
            Some(format!(
                "restart {} is past max_restarts {}",
                state.restart, ga.max_restarts
            ))
        } else if !(1..=ga.max_generations).contains(&state.generation) {
            Some(format!(
                "generation {} is outside 1 to max_generations {}",
                state.generation, ga.max_generations
            ))
        } else if state.index < state.generation - 1 {
            Some(format!(
                "{} generations flown, fewer than this attempt's",
                state.index
            ))
        } else if state.population.len() != ga.population {
            Some(format!(
                "{} genomes, where the population is {}",
                state.population.len(),
                ga.population
            ))
        } else if state.population.iter().any(|g| g.len() != ga.genome_length) {
            Some(format!("a genome is not {} genes long", ga.genome_length))
        } else {
            None
        };
        if let Some(problem) = problem {
            return Err(TrialError::State(problem));
        }
        run.env = cfg.env(state.restart);
        run.restart = state.restart;
        run.generation = state.generation;
        run.index = state.index;
        run.population = state.population;
        run.best = state.best;
        Ok(run)
    }

    /// The trial's result, once it has one.
    pub fn result(&self) -> Option<&TrialResult> {
        self.result.as_ref()
    }

    pub fn config(&self) -> &RunConfig {
        &self.cfg
    }
}

/// The generation `key` breeds from `parents`, scored `fitness`.
pub(crate) fn offspring<'a>(
    ga: &'a GaParams,
    parents: &'a [Genome],
    fitness: &[f64],
    key: StreamKey,
) -> Offspring<'a, StreamRng> {
    Offspring::new(ga, parents, fitness, key.rng(streams::OPERATORS))
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
