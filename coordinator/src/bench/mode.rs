//! A mode under test in `lander bench`: what it is ([`ModeKind`]), the
//! evaluator behind it ([`Measured`]), what it has measured so far
//! ([`Tally`]) and its figures ([`ModeReport`]).

use super::figures::{overheads, percentile, Breakdown};
use super::Workload;
use crate::evaluator::{breeds_first, Batch, EvalError, Evaluator, InProcess};
use crate::ga::Genome;
use crate::pool::{ChunkTiming, IpcPool, ZenohPool};
use crate::trial::offspring;
use lander_model::Evaluation;
use lander_protocol::host::{process_cpu_time, thread_cpu_time, Pinned};
use rayon::prelude::*;
use serde::Serialize;
use std::hash::{DefaultHasher, Hash, Hasher};
use std::ops::Range;
use std::time::{Duration, Instant};

/// What a mode is: how it evaluates, and over how many threads or workers.
/// The ratios find the modes they compare by kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ModeKind {
    /// This process's own threads.
    InProcess { threads: usize },
    /// Worker processes on this host, over iceoryx2.
    Iceoryx2 { workers: usize },
    /// Worker processes over zenoh.
    Zenoh { workers: usize },
}

impl ModeKind {
    /// The name the report gives it: `inproc-2`, `iceoryx2-1`, `zenoh-2`.
    pub fn name(&self) -> String {
        match self {
            ModeKind::InProcess { threads } => format!("inproc-{threads}"),
            ModeKind::Iceoryx2 { workers } => format!("iceoryx2-{workers}"),
            ModeKind::Zenoh { workers } => format!("zenoh-{workers}"),
        }
    }

    /// The threads or workers it asks for.
    pub fn workers(&self) -> usize {
        match *self {
            ModeKind::InProcess { threads } => threads,
            ModeKind::Iceoryx2 { workers } | ModeKind::Zenoh { workers } => workers,
        }
    }

    /// The modes a transport named on `lander bench --transports` stands
    /// for, with `n` workers: `inproc` and `iceoryx2` are measured with one
    /// thread or worker and with `n`, for the scaling; `zenoh` with `n`
    /// only. `None` for a name that is no transport.
    pub fn for_transport(transport: &str, n: usize) -> Option<Vec<ModeKind>> {
        let one_and_n = |kind: fn(usize) -> ModeKind| {
            if n > 1 {
                vec![kind(1), kind(n)]
            } else {
                vec![kind(1)]
            }
        };
        match transport {
            "inproc" => Some(one_and_n(|threads| ModeKind::InProcess { threads })),
            "iceoryx2" => Some(one_and_n(|workers| ModeKind::Iceoryx2 { workers })),
            "zenoh" => Some(vec![ModeKind::Zenoh { workers: n }]),
            _ => None,
        }
    }
}

/// An evaluator under test: an [`Evaluator`] that says how many workers
/// serve it and, over worker processes, how each chunk went.
pub trait Measured: Evaluator {
    /// Workers serving it now; in-process threads count as workers.
    fn workers(&self) -> usize;

    /// Starts keeping the timing of every chunk, where there are chunks.
    fn record_timings(&mut self) {}

    /// The chunk timings kept since the last call; none in-process.
    fn take_timings(&mut self) -> Vec<ChunkTiming> {
        Vec::new()
    }

    /// The calling thread placed as a run places it while it flies
    /// ([`Pool::place_thread`](crate::pool::Pool::place_thread)), until
    /// the guard is dropped.
    fn place_thread(&self) -> Option<Pinned> {
        None
    }

    /// Runs `work` where a run's loop runs: on one of the evaluator's own
    /// threads where it has any ([`Evaluator::drive`]), here otherwise.
    fn drive_measured(&mut self, work: &mut (dyn FnMut(&mut dyn Measured) + Send));
}

impl Measured for InProcess {
    fn workers(&self) -> usize {
        self.thread_count()
    }

    fn drive_measured(&mut self, work: &mut (dyn FnMut(&mut dyn Measured) + Send)) {
        self.on_own_thread(|me| work(me))
    }
}

impl Measured for IpcPool {
    fn workers(&self) -> usize {
        IpcPool::workers(self)
    }

    fn record_timings(&mut self) {
        IpcPool::record_timings(self)
    }

    fn take_timings(&mut self) -> Vec<ChunkTiming> {
        IpcPool::take_timings(self)
    }

    fn place_thread(&self) -> Option<Pinned> {
        IpcPool::place_thread(self)
    }

    fn drive_measured(&mut self, work: &mut (dyn FnMut(&mut dyn Measured) + Send)) {
        work(self)
    }
}

impl Measured for ZenohPool {
    fn workers(&self) -> usize {
        ZenohPool::workers(self)
    }

    fn record_timings(&mut self) {
        ZenohPool::record_timings(self)
    }

    fn take_timings(&mut self) -> Vec<ChunkTiming> {
        ZenohPool::take_timings(self)
    }

    fn place_thread(&self) -> Option<Pinned> {
        ZenohPool::place_thread(self)
    }

    fn drive_measured(&mut self, work: &mut (dyn FnMut(&mut dyn Measured) + Send)) {
        work(self)
    }
}

/// A way of evaluating, under test.
pub struct Mode {
    pub kind: ModeKind,
    pub evaluator: Box<dyn Measured>,
    pub tally: Tally,
    hasher: DefaultHasher,
}

/// What a mode has done so far.
#[derive(Default)]
pub struct Tally {
    pub genomes: u64,
    pub ticks: u64,
    pub elapsed: Duration,
    pub coordinator_cpu: Duration,
    /// The whole process's CPU time inside `evaluate`: the coordinator's
    /// thread and the transport's.
    pub process_cpu: Duration,
    pub generations: u64,
    pub timings: Vec<ChunkTiming>,
    /// One per generation evaluated by worker processes.
    pub breakdowns: Vec<Breakdown>,
    pub hash: Option<u64>,
    pub consistent: bool,
}

impl Tally {
    fn new() -> Tally {
        Tally {
            consistent: true,
            ..Tally::default()
        }
    }
}

impl Mode {
    /// A mode of `kind` over `evaluator`, which starts keeping its chunk
    /// timings.
    pub fn new(kind: ModeKind, mut evaluator: Box<dyn Measured>) -> Mode {
        evaluator.record_timings();
        Mode::untimed(kind, evaluator)
    }

    /// A mode that keeps no chunk timings, for runs too long to keep one
    /// per chunk (a soak): its report has no round-trip figures.
    pub fn untimed(kind: ModeKind, evaluator: Box<dyn Measured>) -> Mode {
        Mode {
            kind,
            evaluator,
            tally: Tally::new(),
            hasher: DefaultHasher::new(),
        }
    }

    /// The name the report gives it.
    pub fn name(&self) -> String {
        self.kind.name()
    }

    /// The calling thread placed as a run places it while this mode flies
    /// ([`Measured::place_thread`]), until the guard is dropped.
    pub fn place_thread(&self) -> Option<Pinned> {
        self.evaluator.place_thread()
    }

    /// Evaluates the workload's steps `steps` back to back, breeding what a
    /// run breeds, where a run's loop runs them
    /// ([`Measured::drive_measured`]): in-process, on an evaluation
    /// thread, so that each generation reaches the threads as a run's
    /// does, not handed over from this thread.
    pub fn block(&mut self, work: &Workload, steps: Range<usize>) -> Result<(), EvalError> {
        let Mode {
            evaluator,
            tally,
            hasher,
            ..
        } = self;
        let mut result = Ok(());
        evaluator.drive_measured(&mut |evaluator| {
            for g in steps.clone() {
                if let Err(e) = step(evaluator, tally, hasher, work, g) {
                    result = Err(e);
                    return;
                }
            }
        });
        result
    }

    /// Closes a round: its results must hash the same as every other round's.
    pub fn end_round(&mut self) {
        let hash = std::mem::take(&mut self.hasher).finish();
        self.tally.consistent &= self.tally.hash.is_none_or(|h| h == hash);
        self.tally.hash = Some(hash);
    }

    /// Forgets everything measured so far, after a warm-up.
    pub fn reset(&mut self) {
        self.tally = Tally::new();
        self.hasher = DefaultHasher::new();
    }
}

/// Evaluates step `g` of the workload with `evaluator`, breeding what a
/// run breeds, into `tally` and `hasher`.
fn step(
    evaluator: &mut dyn Measured,
    tally: &mut Tally,
    hasher: &mut DefaultHasher,
    work: &Workload,
    g: usize,
) -> Result<(), EvalError> {
    let ga = &work.cfg.ga;
    let mut genomes: Vec<Vec<Genome>> = work.steps[g]
        .iter()
        .map(|p| match p.bred_from {
            Some(_) => Vec::with_capacity(p.genomes.len()),
            None => p.genomes.clone(),
        })
        .collect();
    let mut batches: Vec<Batch<'_>> = work.steps[g]
        .iter()
        .zip(&mut genomes)
        .map(|(p, genomes)| {
            let offspring = p
                .bred_from
                .as_ref()
                .map(|from| offspring(ga, &from.genomes, &from.fitness, p.key));
            Batch::new(
                p.env,
                work.pass,
                work.cfg.guided,
                p.key,
                ga.max_duration,
                genomes,
            )
            .breeding(offspring)
        })
        .collect();
    let (cpu, process_cpu) = (thread_cpu_time(), process_cpu_time());
    let started = Instant::now();
    // As `lander experiment` steps its trials: in-process, bred all at
    // once on the evaluation threads, then flown together; over a pool,
    // each bred as it is handed out. A single trial in flight is bred as
    // `lander run` breeds it, by the evaluator.
    if let Some(threads) = breeds_first(evaluator, batches.len()) {
        threads.install(|| {
            batches.par_iter_mut().for_each(|b| {
                b.bred_genomes();
            })
        });
    }
    let evaluations = evaluator.evaluate_many(batches)?;
    let wall = started.elapsed();
    tally.elapsed += wall;
    tally.coordinator_cpu += thread_cpu_time().saturating_sub(cpu);
    tally.process_cpu += process_cpu_time().saturating_sub(process_cpu);
    tally.generations += 1;
    for (evaluations, genomes) in evaluations.iter().zip(&genomes) {
        tally.genomes += evaluations.len() as u64;
        tally.ticks += evaluations.iter().map(|e| e.simulated_ticks).sum::<u64>();
        hash_results(hasher, evaluations, genomes);
    }
    let timings = evaluator.take_timings();
    tally.breakdowns.extend(Breakdown::of(&timings, wall));
    tally.timings.extend(timings);
    Ok(())
}

fn hash_results(h: &mut impl Hasher, evaluations: &[Evaluation], genomes: &[Genome]) {
    for e in evaluations {
        let o = &e.outcome;
        for v in [
            o.fitness,
            o.state.x,
            o.state.y,
            o.state.vx,
            o.state.vy,
            o.state.rot,
        ] {
            v.to_bits().hash(h);
        }
        (o.ticks, o.n, o.safe, o.touched_down, e.simulated_ticks).hash(h);
    }
    genomes.hash(h);
}

/// One mode's figures, as `lander bench --json` prints them.
#[derive(Debug, Serialize)]
pub struct ModeReport {
    /// What the mode is; its `name` says it in the JSON.
    #[serde(skip)]
    pub kind: ModeKind,
    pub name: String,
    pub workers: usize,
    /// Genomes evaluated, in every round.
    pub genomes: u64,
    pub genomes_per_s: f64,
    pub ticks_per_s: f64,
    pub rtt_p50_us: Option<f64>,
    pub rtt_p99_us: Option<f64>,
    pub rtt_max_us: Option<f64>,
    /// The p99 of round trip minus compute: see [`overheads`].
    pub overhead_p99_us: Option<f64>,
    pub coordinator_cpu_us_per_generation: f64,
    /// For worker processes: the coordinator process's CPU time (all its
    /// threads, the transport's included) per chunk answered, what bounds
    /// how many workers one coordinator feeds.
    pub coordinator_cpu_us_per_chunk: Option<f64>,
    /// Share of the workers' time spent computing, for worker processes.
    pub worker_utilisation: Option<f64>,
    /// Where a generation's time went, on average, for worker processes.
    pub generation: Option<Breakdown>,
    pub hash: String,
}

impl Mode {
    pub fn report(&self) -> ModeReport {
        let t = &self.tally;
        let secs = t.elapsed.as_secs_f64().max(f64::MIN_POSITIVE);
        let micros = |d: Duration| d.as_secs_f64() * 1e6;
        let mut rtt: Vec<Duration> = t.timings.iter().map(ChunkTiming::round_trip).collect();
        let mut overhead = overheads(&t.timings);
        let compute: Duration = t.timings.iter().map(ChunkTiming::compute).sum();
        let workers = self.evaluator.workers();
        ModeReport {
            kind: self.kind,
            name: self.name(),
            workers,
            genomes: t.genomes,
            genomes_per_s: t.genomes as f64 / secs,
            ticks_per_s: t.ticks as f64 / secs,
            rtt_p50_us: percentile(&mut rtt, 0.50).map(micros),
            rtt_p99_us: percentile(&mut rtt, 0.99).map(micros),
            rtt_max_us: percentile(&mut rtt, 1.0).map(micros),
            overhead_p99_us: percentile(&mut overhead, 0.99).map(micros),
            coordinator_cpu_us_per_generation: micros(t.coordinator_cpu)
                / t.generations.max(1) as f64,
            coordinator_cpu_us_per_chunk: (!t.timings.is_empty())
                .then(|| micros(t.process_cpu) / t.timings.len() as f64),
            worker_utilisation: (!t.timings.is_empty())
                .then(|| compute.as_secs_f64() / (secs * workers.max(1) as f64)),
            generation: Breakdown::mean(&t.breakdowns),
            hash: t.hash.map_or_else(String::new, |h| format!("{h:016x}")),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_are_named_as_the_report_always_named_them() {
        assert_eq!(ModeKind::InProcess { threads: 1 }.name(), "inproc-1");
        assert_eq!(ModeKind::InProcess { threads: 8 }.name(), "inproc-8");
        assert_eq!(ModeKind::Iceoryx2 { workers: 2 }.name(), "iceoryx2-2");
        assert_eq!(ModeKind::Zenoh { workers: 3 }.name(), "zenoh-3");
        assert_eq!(ModeKind::Zenoh { workers: 3 }.workers(), 3);
        assert_eq!(ModeKind::InProcess { threads: 5 }.workers(), 5);
    }

    #[test]
    fn a_transport_stands_for_one_worker_and_n_except_zenoh() {
        use ModeKind::*;
        let kinds = |t, n| ModeKind::for_transport(t, n);
        assert_eq!(
            kinds("inproc", 4),
            Some(vec![InProcess { threads: 1 }, InProcess { threads: 4 }])
        );
        assert_eq!(kinds("inproc", 1), Some(vec![InProcess { threads: 1 }]));
        assert_eq!(
            kinds("iceoryx2", 2),
            Some(vec![Iceoryx2 { workers: 1 }, Iceoryx2 { workers: 2 }])
        );
        assert_eq!(kinds("iceoryx2", 1), Some(vec![Iceoryx2 { workers: 1 }]));
        assert_eq!(kinds("zenoh", 2), Some(vec![Zenoh { workers: 2 }]));
        assert_eq!(kinds("zenoh", 1), Some(vec![Zenoh { workers: 1 }]));
        assert_eq!(kinds("carrier-pigeon", 2), None);
        assert_eq!(kinds("Inproc", 2), None);
    }
}
