//! `lander bench`: one fixed, seeded workload evaluated in several modes.
//! The modes take turns generation by generation, in an order that rotates,
//! so machine noise falls on all of them alike. Only time inside `evaluate`
//! counts; start-up does not.

use crate::config::RunConfig;
use crate::evaluator::{Batch, EvalError, Evaluator, InProcess};
use crate::ga::{random_population, Genome};
use crate::pool::{ChunkTiming, IpcPool, ZenohPool};
use crate::trial::env;
use lander_protocol::stream::streams;
use lander_protocol::{Evaluation, Method, StreamKey};
use lander_worker::cpu::thread_cpu_time;
use serde::Serialize;
use std::hash::{DefaultHasher, Hash, Hasher};
use std::time::{Duration, Instant};

/// The generations every mode evaluates: random populations keyed by the
/// configuration's seed, so every mode and every round sees the same work.
pub struct Workload {
    pub cfg: RunConfig,
    pub method: Method,
    pub generations: Vec<(StreamKey, Vec<Genome>)>,
}

impl Workload {
    pub fn new(cfg: &RunConfig, method: Method, generations: u64) -> Workload {
        let generations = (1..=generations)
            .map(|g| {
                let key = StreamKey::new(cfg.seed, cfg.trial, 0, g);
                (
                    key,
                    random_population(&cfg.ga, &mut key.rng(streams::OPERATORS)),
                )
            })
            .collect();
        Workload {
            cfg: cfg.clone(),
            method,
            generations,
        }
    }

    pub fn genomes(&self) -> usize {
        self.generations.iter().map(|(_, p)| p.len()).sum()
    }
}

/// A way of evaluating, under test.
pub struct Mode {
    pub name: String,
    pub evaluator: ModeEvaluator,
    pub tally: Tally,
    hasher: DefaultHasher,
}

pub enum ModeEvaluator {
    InProcess(InProcess),
    Iceoryx2(Box<IpcPool>),
    Zenoh(Box<ZenohPool>),
}

impl ModeEvaluator {
    fn as_evaluator(&mut self) -> &mut dyn Evaluator {
        match self {
            ModeEvaluator::InProcess(e) => e,
            ModeEvaluator::Iceoryx2(e) => e.as_mut(),
            ModeEvaluator::Zenoh(e) => e.as_mut(),
        }
    }

    /// Workers serving this mode; in-process threads count as workers.
    pub fn workers(&self) -> usize {
        match self {
            ModeEvaluator::InProcess(e) => e.threads(),
            ModeEvaluator::Iceoryx2(e) => e.workers(),
            ModeEvaluator::Zenoh(e) => e.workers(),
        }
    }
}

/// What a mode has done so far.
#[derive(Default)]
pub struct Tally {
    pub genomes: u64,
    pub ticks: u64,
    pub elapsed: Duration,
    pub coordinator_cpu: Duration,
    pub generations: u64,
    pub timings: Vec<ChunkTiming>,
    pub hash: Option<u64>,
    pub consistent: bool,
}

impl Mode {
    pub fn new(name: impl Into<String>, evaluator: ModeEvaluator) -> Mode {
        let mut evaluator = evaluator;
        match &mut evaluator {
            ModeEvaluator::Iceoryx2(pool) => pool.record_timings(),
            ModeEvaluator::Zenoh(pool) => pool.record_timings(),
            ModeEvaluator::InProcess(_) => {}
        }
        Mode {
            name: name.into(),
            evaluator,
            tally: Tally {
                consistent: true,
                ..Tally::default()
            },
            hasher: DefaultHasher::new(),
        }
    }

    /// Evaluates generation `g` of the workload.
    pub fn step(&mut self, work: &Workload, g: usize) -> Result<(), EvalError> {
        let (key, population) = &work.generations[g];
        let mut genomes = population.clone();
        let cpu = thread_cpu_time();
        let started = Instant::now();
        let evaluations = self.evaluator.as_evaluator().evaluate(Batch {
            env: env(&work.cfg, 0),
            method: work.method,
            guide: work.cfg.guided,
            key: *key,
            max_duration: work.cfg.ga.max_duration,
            genomes: &mut genomes,
        })?;
        self.tally.elapsed += started.elapsed();
        self.tally.coordinator_cpu += thread_cpu_time().saturating_sub(cpu);
        self.tally.generations += 1;
        self.tally.genomes += evaluations.len() as u64;
        self.tally.ticks += evaluations.iter().map(|e| e.simulated_ticks).sum::<u64>();
        hash_results(&mut self.hasher, &evaluations, &genomes);
        match &mut self.evaluator {
            ModeEvaluator::Iceoryx2(pool) => self.tally.timings.extend(pool.take_timings()),
            ModeEvaluator::Zenoh(pool) => self.tally.timings.extend(pool.take_timings()),
            ModeEvaluator::InProcess(_) => {}
        }
        Ok(())
    }

    /// Closes a round: its results must hash the same as every other round's.
    pub fn end_round(&mut self) {
        let hash = std::mem::take(&mut self.hasher).finish();
        self.tally.consistent &= self.tally.hash.is_none_or(|h| h == hash);
        self.tally.hash = Some(hash);
    }

    /// Forgets everything measured so far, after a warm-up.
    pub fn reset(&mut self) {
        self.tally = Tally {
            consistent: true,
            ..Tally::default()
        };
        self.hasher = DefaultHasher::new();
    }
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
    pub name: String,
    pub workers: usize,
    pub genomes_per_s: f64,
    pub ticks_per_s: f64,
    pub rtt_p50_us: Option<f64>,
    pub rtt_p99_us: Option<f64>,
    pub rtt_max_us: Option<f64>,
    /// The p99 of round trip minus the worker's compute time, over chunks
    /// that did not queue behind another at their worker.
    pub overhead_p99_us: Option<f64>,
    pub coordinator_cpu_us_per_generation: f64,
    /// Share of the workers' time spent computing, for worker processes.
    pub worker_utilisation: Option<f64>,
    pub hash: String,
}

impl Mode {
    pub fn report(&self) -> ModeReport {
        let t = &self.tally;
        let secs = t.elapsed.as_secs_f64().max(f64::MIN_POSITIVE);
        let micros = |d: Duration| d.as_secs_f64() * 1e6;
        let mut rtt: Vec<Duration> = t.timings.iter().map(|c| c.round_trip).collect();
        let mut overhead: Vec<Duration> = t
            .timings
            .iter()
            .filter(|c| !c.queued)
            .map(|c| c.round_trip.saturating_sub(c.compute))
            .collect();
        let compute: Duration = t.timings.iter().map(|c| c.compute).sum();
        let workers = self.evaluator.workers();
        ModeReport {
            name: self.name.clone(),
            workers,
            genomes_per_s: t.genomes as f64 / secs,
            ticks_per_s: t.ticks as f64 / secs,
            rtt_p50_us: percentile(&mut rtt, 0.50).map(micros),
            rtt_p99_us: percentile(&mut rtt, 0.99).map(micros),
            rtt_max_us: percentile(&mut rtt, 1.0).map(micros),
            overhead_p99_us: percentile(&mut overhead, 0.99).map(micros),
            coordinator_cpu_us_per_generation: micros(t.coordinator_cpu)
                / t.generations.max(1) as f64,
            worker_utilisation: (!t.timings.is_empty())
                .then(|| compute.as_secs_f64() / (secs * workers.max(1) as f64)),
            hash: t.hash.map_or_else(String::new, |h| format!("{h:016x}")),
        }
    }
}

/// The `q` quantile by the nearest-rank method; `None` for no samples.
pub fn percentile(samples: &mut [Duration], q: f64) -> Option<Duration> {
    if samples.is_empty() {
        return None;
    }
    samples.sort_unstable();
    let rank = ((q * samples.len() as f64).ceil() as usize).clamp(1, samples.len());
    Some(samples[rank - 1])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_rank_percentiles() {
        let mut v: Vec<Duration> = (1..=100).rev().map(Duration::from_micros).collect();
        assert_eq!(percentile(&mut v, 0.5), Some(Duration::from_micros(50)));
        assert_eq!(percentile(&mut v, 0.99), Some(Duration::from_micros(99)));
        assert_eq!(percentile(&mut v, 1.0), Some(Duration::from_micros(100)));
        assert_eq!(percentile(&mut [], 0.5), None);
        let mut one = [Duration::from_micros(7)];
        assert_eq!(percentile(&mut one, 0.01), Some(Duration::from_micros(7)));
    }
}
