//! Runs trials on one [`Backend`]: the GA trials stepped together, a
//! generation of each per round, so that every core stays busy even with
//! small populations (without the evaluator's own threads, as on a pool,
//! each trial taking in its last generation as the evaluator asks for its
//! next: `step_each`); then the Q(λ) trials, one job each. A task is a
//! trial's configuration under a key of the caller's (an experiment's
//! [`TrialId`], or a sweep's setting and trial), so one workload can hold
//! many experiments.

use super::file::Experiment;
use crate::config::RunConfig;
use crate::evaluator::{breeds_first, Backend, EvalError, Evaluator};
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
pub fn trials(exp: &Experiment) -> Vec<TrialId> {
    (1..=exp.trials)
        .flat_map(|trial| {
            exp.methods
                .iter()
                .map(move |&method| TrialId { method, trial })
        })
        .collect()
}

/// One trial to run: its configuration, under the caller's key.
#[derive(Clone, Debug)]
pub struct Task<K> {
    pub key: K,
    pub cfg: RunConfig,
}

/// The tasks of one experiment's trials.
pub fn experiment_tasks(exp: &Experiment, ids: &[TrialId]) -> Vec<Task<TrialId>> {
    ids.iter()
        .map(|&key| Task {
            key,
            cfg: exp.config(key.method, key.trial),
        })
        .collect()
}

/// What the runner reports as it goes. A `finished` error stops the run.
pub trait Progress<K> {
    fn started(&mut self, key: K, cfg: &RunConfig);
    fn generation(&mut self, key: K, generation: &Generation);
    /// A trial's record, once it is finished; again, with the record that
    /// replaces the first, for a Q(λ) trial whose result was given up
    /// since (the worker that gave it was refused for another answer, and
    /// the trial flown again). [`keep`] keeps records so.
    fn finished(&mut self, key: K, record: TrialRecord) -> Result<(), ExperimentError>;
}

/// Keeps `record` among `records`: in place of the record of the same
/// trial, where [`Progress::finished`] hears a trial again, or else added.
/// Returns whether it was added.
pub fn keep(records: &mut Vec<TrialRecord>, record: TrialRecord) -> bool {
    let id = TrialId::of(&record);
    match records.iter_mut().find(|r| TrialId::of(r) == id) {
        Some(earlier) => {
            *earlier = record;
            false
        }
        None => {
            records.push(record);
            true
        }
    }
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

/// The most genes the GA trials in flight may hold together (four of the
/// largest generations a trial may have, about 2 GB): beyond it a trial
/// waits for a running one to finish, so that many trials of large
/// generations do not take more memory than the host has. One trial always
/// runs.
pub const MAX_GENES_IN_FLIGHT: usize = 4 * crate::ga::MAX_GENES;

/// Runs `tasks` with at most `in_flight` GA trials at once (fewer where
/// their generations would hold more than [`MAX_GENES_IN_FLIGHT`] genes).
/// Every trial's results depend only on its configuration, never on
/// `in_flight`, the backend, the other tasks or the order of finishing.
pub fn run<K: Copy + Send + Sync>(
    tasks: &[Task<K>],
    backend: &mut dyn Backend,
    in_flight: usize,
    progress: &mut (dyn Progress<K> + Send),
) -> Result<(), ExperimentError> {
    can_run(tasks, backend)?;
    let (learning, evolving): (Vec<&Task<K>>, Vec<&Task<K>>) = tasks
        .iter()
        .partition(|t| t.cfg.method == Method::Qlearning);
    let mut evolved = Ok(());
    let started = Instant::now();
    backend.drive(&mut |evaluator| {
        let most = InFlight {
            trials: in_flight.max(1),
            genes: MAX_GENES_IN_FLIGHT,
        };
        evolved = evolve(&evolving, evaluator, most, progress);
    });
    evolved?;
    let evolved_at = Instant::now();
    learn(&learning, backend, progress)?;
    tracing::debug!(
        ga_trials = evolving.len(),
        ga_s = (evolved_at - started).as_secs_f64(),
        qlearning_trials = learning.len(),
        qlearning_s = evolved_at.elapsed().as_secs_f64(),
        "trials run"
    );
    Ok(())
}

struct Running<K> {
    key: K,
    run: TrialRun,
    log: Vec<Generation>,
    started: Instant,
    /// Its last generation's evaluations, while the trial has not yet
    /// taken them in (`step_each`).
    flown: Option<Vec<Evaluation>>,
}

impl<K: Copy> Running<K> {
    /// Takes in the trial's last generation, if it has not yet.
    fn take_in(&mut self, progress: &mut dyn Progress<K>) {
        if let Some(evaluations) = self.flown.take() {
            let generation = self.run.accept(&evaluations);
            self.record(generation, progress);
        }
    }

    /// Reports and logs a generation the trial has taken in.
    fn record(&mut self, generation: Generation, progress: &mut dyn Progress<K>) {
        progress.generation(self.key, &generation);
        self.log.push(generation);
    }
}

/// The most GA trials in flight, and the most genes their generations hold.
#[derive(Clone, Copy, Debug)]
struct InFlight {
    trials: usize,
    genes: usize,
}

fn evolve<K: Copy + Send>(
    tasks: &[&Task<K>],
    backend: &mut dyn Evaluator,
    most: InFlight,
    progress: &mut dyn Progress<K>,
) -> Result<(), ExperimentError> {
    let mut queue = tasks.iter().peekable();
    let mut running: Vec<Running<K>> = Vec::new();
    // Where the evaluator has threads of its own, a step's trials are
    // bred on them, together; elsewhere each is made as it is handed out.
    let together = backend.threads().is_some();
    loop {
        let mut held: usize = running.iter().map(|r| r.run.config().ga.genes()).sum();
        while running.len() < most.trials {
            let room = |t: &&&Task<K>| held == 0 || held + t.cfg.ga.genes() <= most.genes;
            let Some(task) = queue.next_if(room) else {
                break;
            };
            held += task.cfg.ga.genes();
            progress.started(task.key, &task.cfg);
            running.push(Running {
                key: task.key,
                run: TrialRun::new(&task.cfg)?,
                log: Vec::new(),
                started: Instant::now(),
                flown: None,
            });
        }
        if running.is_empty() {
            return Ok(());
        }
        let stepped = if together {
            step_together(&mut running, backend, progress)
        } else {
            step_each(&mut running, backend, progress)
        };
        if stepped.is_err() {
            // The trials whose last generation has flown are recorded
            // before the error ends the run, as they are stepped together:
            // a resumed run need not fly them again.
            for r in &mut running {
                r.take_in(progress);
            }
        }
        let mut i = 0;
        while i < running.len() {
            if let Some(result) = running[i].run.result() {
                let r = &running[i];
                let record = evolution_record(r.run.config(), result, &r.log, r.started);
                let key = r.key;
                running.remove(i);
                progress.finished(key, record)?;
            } else {
                i += 1;
            }
        }
        stepped?;
    }
}

/// Flies a generation of every running trial, then takes each in and, on
/// the evaluator's threads where there are several trials, breeds the
/// next.
fn step_together<K: Copy + Send>(
    running: &mut [Running<K>],
    backend: &mut dyn Evaluator,
    progress: &mut dyn Progress<K>,
) -> Result<(), ExperimentError> {
    let batches = running.iter_mut().map(|r| r.run.batch()).collect();
    let evaluations = backend.evaluate_many(batches)?;
    let generations = match breeds_first(backend, running.len()) {
        Some(threads) => threads.install(|| accept_and_breed(running, &evaluations)),
        // A single trial's next generation is bred as it flies.
        None => running
            .iter_mut()
            .zip(&evaluations)
            .map(|(r, evaluations)| r.run.accept(evaluations))
            .collect(),
    };
    for (r, generation) in running.iter_mut().zip(generations) {
        r.record(generation, progress);
    }
    Ok(())
}

/// Flies a generation of every running trial that goes on, each trial
/// taking in its last generation only as the evaluator asks for its next,
/// for an evaluator without threads of its own (a pool asks as it hands
/// the step out, breeding each trial's generation chunk by chunk, so that
/// its workers fly the first trials' while the rest are taken in). A
/// trial that ends there flies no more, and leaves after the step: one
/// step later than stepped together, its slot idle for that step. The
/// others keep their evaluations for the next step.
fn step_each<K: Copy>(
    running: &mut [Running<K>],
    backend: &mut dyn Evaluator,
    progress: &mut dyn Progress<K>,
) -> Result<(), ExperimentError> {
    // The running trials flown in this step, in the order taken.
    let mut flying = Vec::new();
    // Taking a batch takes its trial in first: the iterator is lazy, and
    // its borrows end with it, before the evaluations are stored.
    let mut batches = running.iter_mut().enumerate().filter_map(|(i, r)| {
        r.take_in(progress);
        if r.run.result().is_some() {
            return None;
        }
        flying.push(i);
        Some(r.run.batch())
    });
    let evaluations = backend.evaluate_each(&mut batches)?;
    drop(batches);
    if evaluations.len() != flying.len() {
        return Err(EvalError::Miscounted {
            taken: flying.len(),
            answered: evaluations.len(),
        }
        .into());
    }
    for (i, evaluations) in flying.into_iter().zip(evaluations) {
        running[i].flown = Some(evaluations);
    }
    Ok(())
}

/// Scores each running trial's generation and breeds its next, on the
/// evaluation threads. Each trial draws from its own keyed stream, so
/// doing them in parallel changes nothing but the time: serial, breeding
/// took a sixth of an in-process experiment's GA time on 2 cores, and
/// bred as they fly, 2% more than this.
fn accept_and_breed<K: Send>(
    running: &mut [Running<K>],
    evaluations: &[Vec<Evaluation>],
) -> Vec<Generation> {
    running
        .par_iter_mut()
        .zip(evaluations)
        .map(|(r, evaluations)| {
            let generation = r.run.accept(evaluations);
            r.run.breed();
            generation
        })
        .collect()
}

fn learn<K: Copy>(
    tasks: &[&Task<K>],
    backend: &mut dyn Backend,
    progress: &mut dyn Progress<K>,
) -> Result<(), ExperimentError> {
    if tasks.is_empty() {
        return Ok(());
    }
    let jobs = train_jobs(tasks);
    for task in tasks {
        progress.started(task.key, &task.cfg);
    }
    let started = Instant::now();
    // A store failure is reported once training stops; training a few
    // more trials in the meantime loses nothing.
    let mut failure = None;
    backend.train(&jobs, &mut |i, result| {
        if failure.is_some() {
            return;
        }
        let record = learning_record(&tasks[i].cfg, &jobs[i], result, started);
        if let Err(e) = progress.finished(tasks[i].key, record) {
            failure = Some(e);
        }
    })?;
    failure.map_or(Ok(()), Err)
}

/// Whether `backend` can run `tasks`: [`run`] asks before anything runs,
/// and a caller may ask before it starts, to tell a refusal from a stop.
pub fn can_run<K>(tasks: &[Task<K>], backend: &dyn Backend) -> Result<(), EvalError> {
    let learning: Vec<&Task<K>> = tasks
        .iter()
        .filter(|t| t.cfg.method == Method::Qlearning)
        .collect();
    backend.can_train(&train_jobs(&learning))
}

/// Each Q(λ) task's trial, whole.
fn train_jobs<K>(tasks: &[&Task<K>]) -> Vec<TrainJob> {
    tasks
        .iter()
        .map(|Task { cfg, .. }| {
            TrainJob::whole(
                cfg.env(0),
                cfg.guided,
                cfg.qlearning,
                StreamKey::new(cfg.seed, cfg.trial, 0, 0),
            )
        })
        .collect()
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::evaluator::{Batch, InProcess};

    const SMALL: &str = "name = \"s\"\ntrials = 3\nmethods = [\"ga\", \"guided\"]\n\
        [ga]\npopulation = 12\ngenome_length = 10\nmax_generations = 4\nmax_restarts = 1\n";

    /// The records by key, and the most trials running at once.
    #[derive(Default)]
    struct Watch {
        running: usize,
        most: usize,
        records: Vec<(TrialId, TrialRecord)>,
    }

    impl Progress<TrialId> for Watch {
        fn started(&mut self, _: TrialId, _: &RunConfig) {
            self.running += 1;
            self.most = self.most.max(self.running);
        }
        fn generation(&mut self, _: TrialId, _: &Generation) {}
        fn finished(
            &mut self,
            key: TrialId,
            mut record: TrialRecord,
        ) -> Result<(), ExperimentError> {
            self.running -= 1;
            record.wall_s = 0.0;
            self.records.push((key, record));
            Ok(())
        }
    }

    /// An evaluator with no threads of its own that flies each batch as
    /// soon as it takes it, as a pool hands a step out: each trial takes
    /// in its last generation only once the trials before it have flown.
    struct OneByOne(InProcess);

    impl Evaluator for OneByOne {
        fn drive(&mut self, work: &mut (dyn FnMut(&mut dyn Evaluator) + Send)) {
            work(self)
        }

        fn evaluate_many(
            &mut self,
            batches: Vec<Batch<'_>>,
        ) -> Result<Vec<Vec<Evaluation>>, EvalError> {
            self.0.evaluate_many(batches)
        }

        fn evaluate_each<'a>(
            &mut self,
            batches: &mut dyn Iterator<Item = Batch<'a>>,
        ) -> Result<Vec<Vec<Evaluation>>, EvalError> {
            batches.map(|b| self.0.evaluate(b)).collect()
        }
    }

    fn evolved(genes: usize) -> Watch {
        evolved_on(&mut InProcess::new(2).unwrap(), genes)
    }

    fn evolved_on(backend: &mut dyn Evaluator, genes: usize) -> Watch {
        let exp: Experiment = toml::from_str(SMALL).unwrap();
        exp.validate().unwrap();
        let tasks = experiment_tasks(&exp, &trials(&exp));
        let tasks: Vec<&Task<TrialId>> = tasks.iter().collect();
        let mut watch = Watch::default();
        let most = InFlight { trials: 8, genes };
        evolve(&tasks, backend, most, &mut watch).unwrap();
        watch
            .records
            .sort_by_key(|(id, _)| (id.trial, id.method.name()));
        watch
    }

    #[test]
    fn trials_wait_while_those_in_flight_hold_the_most_genes() {
        // 120 genes a generation: 6 trials fit in 8 × 120, two in 250,
        // and one trial larger than the bound still runs alone.
        let free = evolved(MAX_GENES_IN_FLIGHT);
        assert_eq!((free.most, free.records.len()), (6, 6));
        for (genes, most) in [(250, 2), (120, 1), (50, 1)] {
            let bound = evolved(genes);
            assert_eq!(bound.most, most, "{genes} genes");
            assert!(
                bound.records == free.records,
                "{genes} genes: other results"
            );
        }
    }

    #[test]
    fn trials_made_as_the_evaluator_takes_them_end_as_when_stepped_together() {
        let together = evolved(MAX_GENES_IN_FLIGHT);
        for genes in [MAX_GENES_IN_FLIGHT, 250, 50] {
            let each = evolved_on(&mut OneByOne(InProcess::new(1).unwrap()), genes);
            assert_eq!(each.records.len(), 6, "{genes} genes");
            assert!(
                each.records == together.records,
                "{genes} genes: other results"
            );
        }
    }

    #[test]
    fn a_record_heard_again_replaces_the_first() {
        let record = |trial, wall_s| TrialRecord {
            method: Method::Qlearning,
            seed: 1,
            trial,
            x0: 0.0,
            pad_x: 0.0,
            landed: false,
            generations: None,
            restarts: None,
            episodes: None,
            wall_s,
            fitness: Vec::new(),
            best: None,
            learning: None,
        };
        let mut records = Vec::new();
        assert!(keep(&mut records, record(1, 1.0)));
        assert!(keep(&mut records, record(2, 2.0)));
        assert!(!keep(&mut records, record(1, 3.0)));
        let kept: Vec<(u64, f64)> = records.iter().map(|r| (r.trial, r.wall_s)).collect();
        assert_eq!(kept, [(1, 3.0), (2, 2.0)]);
    }
}
