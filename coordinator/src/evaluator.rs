//! Who flies a generation. [`Evaluator`] is the seam between the trial loop
//! and the transports; [`InProcess`] is the embedded default, a rayon pool.

use crate::ga::{Genome, Offspring};
use crate::stop::Stop;
use lander_model::learn::run_training;
use lander_model::stream::StreamRng;
use lander_model::TrainJob;
use lander_model::TrainResult;
use lander_model::{evaluate, Evaluation};
use lander_model::{Env, GuideParams, Pass, StreamKey};
use lander_protocol::iox::IpcError;
use rayon::prelude::*;
use std::sync::Arc;
use std::time::Duration;

mod pipeline;

use pipeline::Crew;

/// One generation's worth of work. Genome `i` uses the guided-pass stream
/// `(key, i)`, so the results do not depend on who flies which genome.
///
/// A trial's generation may not be bred yet: [`bred_genomes`](Batch::bred_genomes)
/// and [`evaluate_here`](Batch::evaluate_here) breed it first, and
/// `evaluate_as_bred`, on more than one thread, flies each genome as soon
/// as it is bred, while the next are bred (`pipeline`).
pub struct Batch<'a> {
    pub env: Env,
    pub pass: Pass,
    pub guide: GuideParams,
    pub key: StreamKey,
    /// The largest duration a gene may have.
    pub max_duration: u8,
    /// Rewritten in place by the guided pass; empty while `offspring` is
    /// still to breed it.
    genomes: &'a mut Vec<Genome>,
    offspring: Option<Offspring<'a, StreamRng>>,
}

impl<'a> Batch<'a> {
    /// A batch of `genomes` as they are.
    pub fn new(
        env: Env,
        pass: Pass,
        guide: GuideParams,
        key: StreamKey,
        max_duration: u8,
        genomes: &'a mut Vec<Genome>,
    ) -> Batch<'a> {
        Batch {
            env,
            pass,
            guide,
            key,
            max_duration,
            genomes,
            offspring: None,
        }
    }

    /// The same batch, its genomes bred by `offspring` (where `Some`) into
    /// the empty `genomes`.
    pub fn breeding(mut self, offspring: Option<Offspring<'a, StreamRng>>) -> Batch<'a> {
        assert!(
            offspring.is_none() || self.genomes.is_empty(),
            "a batch bred into genomes it already has"
        );
        self.offspring = offspring;
        self
    }

    /// How many genomes the batch flies, bred or not.
    pub fn len(&self) -> usize {
        match &self.offspring {
            Some(o) => o.population(),
            None => self.genomes.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The genomes, bred first if they are still to be bred.
    pub fn bred_genomes(&mut self) -> &mut [Genome] {
        self.bred_up_to(self.len())
    }

    /// Whether every genome is bred.
    pub fn is_bred(&self) -> bool {
        self.offspring.is_none()
    }

    /// The first `end` genomes (all there are, if fewer), breeding only as
    /// far as them if they are still to be bred: the rest are bred, in
    /// order, by later calls.
    pub fn bred_up_to(&mut self, end: usize) -> &mut [Genome] {
        if let Some(offspring) = &mut self.offspring {
            let more = end.saturating_sub(self.genomes.len());
            self.genomes.extend(offspring.by_ref().take(more));
            if self.genomes.len() >= offspring.population() {
                self.offspring = None;
            }
        }
        let end = end.min(self.genomes.len());
        &mut self.genomes[..end]
    }

    /// Evaluates every genome here, on the current rayon pool, breeding
    /// them first if they are still to be bred, and rewriting them as the
    /// guided pass leaves them.
    pub fn evaluate_here(mut self) -> Vec<Evaluation> {
        let fly = self.flier();
        self.bred_genomes()
            .par_iter_mut()
            .enumerate()
            .map(|(i, g)| fly(i, g))
            .collect()
    }

    /// Evaluates every genome on `pool`, each flown by `crew` as soon as
    /// it is bred, while this thread breeds the next (`pipeline`).
    /// A batch partly bred already (read with [`Batch::bred_up_to`]) is
    /// evaluated here: the crew numbers genomes from the first bred.
    fn evaluate_as_bred(mut self, crew: &Arc<Crew>, pool: &rayon::ThreadPool) -> Vec<Evaluation> {
        if !self.genomes.is_empty() {
            return self.evaluate_here();
        }
        let Some(offspring) = self.offspring.take() else {
            return self.evaluate_here();
        };
        let population = offspring.population();
        let flown = crew.fly_as_bred(pool, offspring, population, Arc::new(self.flier()));
        let mut evaluations = Vec::with_capacity(flown.len());
        for (genome, evaluation) in flown {
            self.genomes.push(genome);
            evaluations.push(evaluation);
        }
        evaluations
    }

    /// What flies genome `i` of the batch.
    fn flier(&self) -> impl Fn(usize, &mut Genome) -> Evaluation + Send + Sync + 'static {
        let (env, pass, guide, key) = (self.env, self.pass, self.guide, self.key);
        move |i: usize, g: &mut Genome| evaluate(&env, pass, &guide, key, i as u64, g)
    }
}

#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    #[error("cannot start {threads} evaluation threads: {reason}")]
    Threads { threads: usize, reason: String },
    #[error(transparent)]
    Ipc(#[from] IpcError),
    #[error("cannot start the worker {exe}: {reason} (build it with `cargo build --workspace --release --bins`)")]
    Spawn { exe: String, reason: String },
    #[error(
        "the worker {exe} speaks protocol version {got}, this lander {}: they come from \
         different builds (build both with `cargo build --release --workspace --bins`)",
        lander_protocol::wire::PROTOCOL_VERSION
    )]
    WorkerVersion { exe: String, got: u32 },
    #[error("every worker died and the {respawns} respawns allowed are used up")]
    NoWorkers { respawns: usize },
    #[error("only {got} of {wanted} workers announced themselves within {secs} s")]
    WorkersLate {
        wanted: usize,
        got: usize,
        secs: u64,
    },
    #[error("the genomes of a generation differ in length")]
    Ragged,
    #[error("the evaluator answered {answered} of the {taken} batches it took")]
    Miscounted { taken: usize, answered: usize },
    #[error("zenoh: {0}")]
    Net(String),
    #[error("stopped by SIGINT or SIGTERM")]
    Interrupted,
    #[error("a Q(λ) leg cannot start from its state: {0}")]
    Training(String),
    #[error(
        "qlearning.memory_bits = {memory_bits}: the trial's state travels to the workers \
         between legs ({why}), and at up to {bytes} bytes it does not fit a network frame \
         of {} bytes; use qlearning.memory_bits of {} or less, or train in-process \
         (without --workers or --connect)",
        lander_protocol::envelope::MAX_FRAME,
        lander_model::params::MAX_MEMORY_BITS - 1
    )]
    StateTooLarge {
        memory_bits: u32,
        bytes: usize,
        why: String,
    },
}

/// Flies batches and returns one evaluation per genome, in order.
pub trait Evaluator {
    fn evaluate(&mut self, batch: Batch<'_>) -> Result<Vec<Evaluation>, EvalError> {
        let mut all = self.evaluate_many(vec![batch])?;
        Ok(all.pop().unwrap_or_default())
    }

    /// Flies several batches at once, such as the current generations of
    /// several trials, so that small generations still fill every core.
    /// A batch may not be bred yet: its genomes are read through
    /// [`Batch::bred_genomes`] or [`Batch::bred_up_to`] (or flown by
    /// [`Batch::evaluate_here`]), which breed them, so that the trial finds
    /// them in place.
    fn evaluate_many(&mut self, batches: Vec<Batch<'_>>)
        -> Result<Vec<Vec<Evaluation>>, EvalError>;

    /// [`Evaluator::evaluate_many`] over batches made as they are taken, in
    /// order: making one may take work (an experiment's trial first takes
    /// in its last generation), which an evaluator that hands batches out
    /// one by one does while its workers fly those before it. Returns one
    /// list of evaluations per batch taken. Takes them all first, unless
    /// the evaluator says otherwise.
    fn evaluate_each<'a>(
        &mut self,
        batches: &mut dyn Iterator<Item = Batch<'a>>,
    ) -> Result<Vec<Vec<Evaluation>>, EvalError> {
        self.evaluate_many(batches.collect())
    }

    /// This process's threads for other work between evaluations, such as
    /// breeding the next generations of the trials in flight: the
    /// evaluation threads themselves, where there are any, so that two sets
    /// of threads never contend for the cores. `None` where there are
    /// none: batches are then best handed over still to be bred, as a pool
    /// breeds each chunk as it hands it out, its workers flying meanwhile.
    fn threads(&self) -> Option<&rayon::ThreadPool> {
        None
    }

    /// Runs `work` with this evaluator on one of its own threads, where it
    /// has any. A loop of evaluations and breeding then runs where its
    /// work runs: handing each step to the threads and back costs two
    /// wake-ups, and on 2 cores a one-thread experiment spent up to a fifth
    /// of its wall time off the CPU waiting for them. An evaluator without threads of its own
    /// just calls `work`.
    fn drive(&mut self, work: &mut (dyn FnMut(&mut dyn Evaluator) + Send));

    /// The time worker processes have spent on jobs so far, summed over
    /// the workers (a chunk answered twice counts twice), and the time the
    /// coordinator spent flying chunks itself beside them; `None` without
    /// worker processes.
    fn worker_busy(&self) -> Option<Busy> {
        None
    }

    /// Says the command's work is done: as the evaluator goes, its
    /// workers are told that the run is over. Unless told this, they are
    /// told that it stopped, which a `--resume` may carry on, and a worker
    /// started with `--rejoin` waits for that.
    fn run_over(&mut self) {}
}

/// Time spent on jobs beside worker processes ([`Evaluator::worker_busy`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Busy {
    /// The workers' own time on the jobs they answered.
    pub workers: std::time::Duration,
    /// The coordinator's, on the chunks it flew itself: a share of its
    /// own, or that of the worker on its CPU.
    pub here: std::time::Duration,
}

impl Busy {
    /// All the time spent flying, here and on the workers.
    pub fn flying(&self) -> std::time::Duration {
        self.workers + self.here
    }
}

/// The threads on which a step of `batches` generations is best bred
/// before it flies, all of them at once, a trial per thread: the
/// evaluator's own ([`Evaluator::threads`]), where the step holds more than
/// one. `None` where the evaluator breeds better itself: a single trial's
/// generation in-process is flown as it is bred, the other threads flying
/// each genome as the first breeds the next (`pipeline`), and a pool
/// breeds each batch as it hands it out.
pub fn breeds_first(evaluator: &dyn Evaluator, batches: usize) -> Option<&rayon::ThreadPool> {
    evaluator.threads().filter(|_| batches > 1)
}

/// Runs Q(λ) trials, one per job; a learner is sequential within a trial,
/// so trials are the unit of parallelism.
pub trait Trainer {
    /// Whether this trainer can run `jobs`, asked before anything runs:
    /// an experiment trains after its GA trials, and finding out then
    /// would waste them.
    fn can_train(&self, _jobs: &[TrainJob]) -> Result<(), EvalError> {
        Ok(())
    }

    /// Returns the results in job order, showing `done` each one as it
    /// arrives, and again, in its place, one that arrives again for a job
    /// whose first answer was given up (a pool refuses a worker for one
    /// answer and believes none it gave).
    fn train(
        &mut self,
        jobs: &[TrainJob],
        done: &mut dyn FnMut(usize, &TrainResult),
    ) -> Result<Vec<TrainResult>, EvalError>;
}

/// Both kinds of work, as an experiment needs them from one set of workers.
pub trait Backend: Evaluator + Trainer {}
impl<T: Evaluator + Trainer> Backend for T {}

/// How long an evaluation thread polls for the next generation, or a
/// spawned worker with a CPU of its own for its next chunk, before it
/// sleeps, unless told otherwise (`--spin-us`): a trial's generations
/// follow each other within microseconds, and a millisecond outlasts every
/// gap of a run but its checkpoints (docs/performance.md measures it).
pub const DEFAULT_SPIN_US: u64 = 1_000;
pub const DEFAULT_SPIN: Duration = Duration::from_micros(DEFAULT_SPIN_US);

/// `spin` where each of `threads` threads has a CPU of its own, and
/// nothing where they would share one: a spinning thread would take its
/// CPU from the thread it waits for.
fn own_cpus_spin(threads: usize, spin: Duration) -> Duration {
    // The CPUs this process may run on, fewer where a cgroup's quota caps
    // them.
    let allowed = lander_protocol::host::allowed_cpus().len();
    let cpus = std::thread::available_parallelism().map_or(allowed, |n| allowed.min(n.get()));
    if threads <= cpus {
        spin
    } else {
        Duration::ZERO
    }
}

/// The most in-process evaluation threads a run may ask for.
pub const MAX_THREADS: usize = 1024;

/// Evaluation on this process's own threads.
pub struct InProcess {
    /// Shared with [`drive`](Evaluator::drive)'s call, which lends `self`
    /// to one of the pool's threads.
    pool: Arc<rayon::ThreadPool>,
    /// The pool's threads as they fly a single trial's generation while
    /// it is bred.
    crew: Arc<Crew>,
    stop: Stop,
}

impl InProcess {
    /// A pool of `threads` threads; 0 means one per core.
    pub fn new(threads: usize) -> Result<InProcess, EvalError> {
        if threads > MAX_THREADS {
            // Thousands of threads would start, and then crawl.
            return Err(EvalError::Threads {
                threads,
                reason: format!("threads must be 0 (one per core) to {MAX_THREADS}"),
            });
        }
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .thread_name(|i| format!("lander-eval-{i}"))
            .build()
            .map_err(|e| EvalError::Threads {
                threads,
                reason: e.to_string(),
            })?;
        let threads = pool.current_num_threads();
        Ok(InProcess {
            crew: Arc::new(Crew::new(threads, own_cpus_spin(threads, DEFAULT_SPIN))),
            pool: Arc::new(pool),
            stop: Stop::new(),
        })
    }

    /// The same pool, its threads polling for the next generation for at
    /// most `spin` before they sleep, where each has a CPU of its own;
    /// zero never spins.
    pub fn spinning(mut self, spin: Duration) -> InProcess {
        let threads = self.thread_count();
        self.crew = Arc::new(Crew::new(threads, own_cpus_spin(threads, spin)));
        self
    }

    /// Stops at the next generation or trial once `stop` is asked.
    pub fn stopping_on(mut self, stop: Stop) -> InProcess {
        self.stop = stop;
        self
    }

    pub fn thread_count(&self) -> usize {
        self.pool.current_num_threads()
    }

    /// Runs `work` with this evaluator on one of its own threads, where
    /// every `install` in it runs in place ([`Evaluator::drive`]).
    pub fn on_own_thread<R: Send>(&mut self, work: impl FnOnce(&mut InProcess) -> R + Send) -> R {
        let pool = Arc::clone(&self.pool);
        let result = pool.install(|| work(self));
        // Nothing more of this work is coming for the helpers to poll for.
        self.crew.dismiss();
        result
    }
}

impl Evaluator for InProcess {
    fn threads(&self) -> Option<&rayon::ThreadPool> {
        Some(&self.pool)
    }

    /// `work` runs on a thread of the pool, so that every `install` in it
    /// (evaluating, breeding) runs in place.
    fn drive(&mut self, work: &mut (dyn FnMut(&mut dyn Evaluator) + Send)) {
        self.on_own_thread(|me| work(me));
    }

    fn evaluate_many(
        &mut self,
        batches: Vec<Batch<'_>>,
    ) -> Result<Vec<Vec<Evaluation>>, EvalError> {
        if self.stop.asked() {
            return Err(EvalError::Interrupted);
        }
        let (pool, crew) = (&self.pool, &self.crew);
        Ok(pool.install(|| match <[Batch; 1]>::try_from(batches) {
            // A single trial's generation still to be bred, on more than
            // one thread: flown as it is bred.
            Ok([batch]) if !batch.is_bred() && pool.current_num_threads() > 1 => {
                vec![batch.evaluate_as_bred(crew, pool)]
            }
            Ok([batch]) => {
                crew.dismiss();
                vec![batch.evaluate_here()]
            }
            Err(batches) => {
                crew.dismiss();
                batches.into_par_iter().map(Batch::evaluate_here).collect()
            }
        }))
    }
}

impl Trainer for InProcess {
    fn train(
        &mut self,
        jobs: &[TrainJob],
        done: &mut dyn FnMut(usize, &TrainResult),
    ) -> Result<Vec<TrainResult>, EvalError> {
        // Training is work of another kind: polling helpers make way.
        self.crew.dismiss();
        let (tx, rx) = std::sync::mpsc::channel();
        let (pool, stop) = (&self.pool, &self.stop);
        let mut results: Vec<Option<TrainResult>> = jobs.iter().map(|_| None).collect();
        let mut failure = None;
        std::thread::scope(|s| {
            s.spawn(move || {
                pool.install(|| {
                    jobs.par_iter()
                        .enumerate()
                        .for_each_with(tx, |tx, (i, job)| {
                            // Trials under way finish; no new one starts.
                            if stop.asked() {
                                return;
                            }
                            // The receiver outlives the loop; a failed send
                            // would only mean it stopped listening.
                            let _ = tx.send((i, run_training(job)));
                        })
                })
            });
            for (i, result) in rx {
                match result {
                    Ok(result) => {
                        done(i, &result);
                        results[i] = Some(result);
                    }
                    Err(e) => failure = Some(e),
                }
            }
        });
        if let Some(e) = failure {
            return Err(EvalError::Training(e));
        }
        if self.stop.asked() {
            return Err(EvalError::Interrupted);
        }
        Ok(results.into_iter().flatten().collect())
    }
}
