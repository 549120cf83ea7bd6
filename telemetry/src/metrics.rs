//! Every metric lander exports, by name, in Prometheus's text format
//! (0.0.4). The coordinator's are in [`CoordinatorMetrics`], a worker's in
//! [`WorkerMetrics`]; each registry also holds the standard `process_*`
//! metrics of its process (CPU seconds, resident memory, open
//! descriptors), read from `/proc` at each scrape.
//!
//! Label sets are bounded: `trial` names only trials in flight (a
//! finished trial's series are removed), `cause` and `transport` take a
//! handful of fixed values.

use prometheus::core::Collector;
use prometheus::{
    exponential_buckets, Counter, Encoder, GaugeVec, Histogram, HistogramOpts, IntCounter,
    IntCounterVec, IntGaugeVec, Opts, Registry, TextEncoder,
};
use std::collections::HashMap;
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// The coordinator's metrics.
pub struct CoordinatorMetrics {
    registry: Registry,
    pub genomes_evaluated: IntCounter,
    pub generations: IntCounter,
    pub trials_finished: IntCounter,
    best: GaugeVec,
    mean: GaugeVec,
    /// Workers connected now, by transport.
    pub workers_connected: IntGaugeVec,
    pub chunks_dispatched: IntCounter,
    pub chunks_taken_back: IntCounter,
    /// Chunks the coordinator flew itself (`--coordinator-share`).
    pub chunks_flown_here: IntCounter,
    /// Chunks sent again because their worker died, left, missed its
    /// deadline or was refused; by that cause.
    pub chunks_redispatched: IntCounterVec,
    pub chunks_refused: IntCounter,
    /// Answers checked under --verify, by where the check was flown:
    /// `worker` (another worker) or `coordinator`.
    pub chunks_checked: IntCounterVec,
    /// Workers lost mid-run, by cause: exited, disconnected, left,
    /// deadline, refused. A zenoh worker's death shows as `left`: the
    /// coordinator sees its token go either way.
    pub workers_lost: IntCounterVec,
    pub worker_respawns: IntCounter,
    pub chunk_round_trip: Histogram,
    generation_wall: Histogram,
    /// When each trial in flight last finished a generation.
    last_generation: Mutex<HashMap<String, Instant>>,
}

/// A worker's metrics.
pub struct WorkerMetrics {
    registry: Registry,
    pub jobs: IntCounter,
    pub genomes_evaluated: IntCounter,
    pub rejected_frames: IntCounter,
    pub busy_seconds: Counter,
}

fn counter(registry: &Registry, name: &str, help: &str) -> IntCounter {
    add(registry, IntCounter::new(name, help))
}

fn counter_vec(registry: &Registry, name: &str, help: &str, label: &str) -> IntCounterVec {
    add(
        registry,
        IntCounterVec::new(Opts::new(name, help), &[label]),
    )
}

fn gauge_vec(registry: &Registry, name: &str, help: &str, label: &str) -> GaugeVec {
    add(registry, GaugeVec::new(Opts::new(name, help), &[label]))
}

/// A histogram of seconds from 100 µs to about 100 s, doubling.
fn seconds(registry: &Registry, name: &str, help: &str) -> Histogram {
    let buckets = exponential_buckets(1e-4, 2.0, 21).expect("fixed, valid buckets");
    add(
        registry,
        Histogram::with_opts(HistogramOpts::new(name, help).buckets(buckets)),
    )
}

/// Registers `metric`. The names and help texts are fixed strings of this
/// file and the registry is new, so a failure is a bug here.
fn add<M: Collector + Clone + 'static>(registry: &Registry, metric: prometheus::Result<M>) -> M {
    let metric = metric.expect("a valid metric name and help");
    registry
        .register(Box::new(metric.clone()))
        .expect("each metric registered once");
    metric
}

/// A registry holding this process's `process_*` metrics.
fn with_process() -> Registry {
    let registry = Registry::new();
    let process = prometheus::process_collector::ProcessCollector::for_self();
    registry
        .register(Box::new(process))
        .expect("registered once");
    registry
}

/// The text exposition of `registry`.
fn encode(registry: &Registry) -> Vec<u8> {
    let mut out = Vec::new();
    // Writing to a Vec cannot fail; the metric families are well formed.
    let _ = TextEncoder::new().encode(&registry.gather(), &mut out);
    out
}

impl CoordinatorMetrics {
    pub fn new() -> CoordinatorMetrics {
        let r = with_process();
        CoordinatorMetrics {
            genomes_evaluated: counter(
                &r,
                "lander_genomes_evaluated_total",
                "Genomes flown and scored.",
            ),
            generations: counter(
                &r,
                "lander_generations_total",
                "GA generations finished, over all trials.",
            ),
            trials_finished: counter(&r, "lander_trials_finished_total", "Trials finished."),
            best: gauge_vec(
                &r,
                "lander_trial_best_fitness",
                "Best fitness of the latest generation of each trial in flight.",
                "trial",
            ),
            mean: gauge_vec(
                &r,
                "lander_trial_mean_fitness",
                "Mean fitness of the latest generation of each trial in flight.",
                "trial",
            ),
            workers_connected: add(
                &r,
                IntGaugeVec::new(
                    Opts::new(
                        "lander_workers_connected",
                        "Worker processes connected now.",
                    ),
                    &["transport"],
                ),
            ),
            chunks_dispatched: counter(
                &r,
                "lander_chunks_dispatched_total",
                "Chunks sent to workers, re-sends included.",
            ),
            chunks_taken_back: counter(
                &r,
                "lander_chunks_taken_back_total",
                "Queued chunks moved from a busy worker to an idle one.",
            ),
            chunks_flown_here: counter(
                &r,
                "lander_chunks_flown_here_total",
                "Chunks the coordinator flew itself: a share of its own, or the share of the worker on its CPU.",
            ),
            chunks_redispatched: counter_vec(
                &r,
                "lander_chunks_redispatched_total",
                "Chunks put back to be flown again after their worker was lost, by cause.",
                "cause",
            ),
            chunks_refused: counter(
                &r,
                "lander_chunks_refused_total",
                "Answers refused: malformed, or wrong under --verify.",
            ),
            chunks_checked: counter_vec(
                &r,
                "lander_chunks_checked_total",
                "Answers checked under --verify, by where the check was flown.",
                "on",
            ),
            workers_lost: counter_vec(
                &r,
                "lander_workers_lost_total",
                "Workers lost mid-run, by cause.",
                "cause",
            ),
            worker_respawns: counter(
                &r,
                "lander_worker_respawns_total",
                "Spawned workers replaced after dying.",
            ),
            chunk_round_trip: seconds(
                &r,
                "lander_chunk_round_trip_seconds",
                "From a chunk's sending to its answer's arrival.",
            ),
            generation_wall: seconds(
                &r,
                "lander_generation_seconds",
                "Wall time of one generation of one trial, breeding included.",
            ),
            last_generation: Mutex::new(HashMap::new()),
            registry: r,
        }
    }

    /// Trial `trial` finished a generation with these scores.
    pub fn generation(&self, trial: &str, best: f64, mean: f64, evaluated: usize) {
        self.genomes_evaluated.inc_by(evaluated as u64);
        self.generations.inc();
        self.best.with_label_values(&[trial]).set(best);
        self.mean.with_label_values(&[trial]).set(mean);
        let now = Instant::now();
        let mut last = self
            .last_generation
            .lock()
            .unwrap_or_else(|p| p.into_inner());
        if let Some(then) = last.insert(trial.to_string(), now) {
            self.generation_wall.observe((now - then).as_secs_f64());
        }
    }

    /// Trial `trial` started: its first generation's time counts from now.
    pub fn trial_started(&self, trial: &str) {
        let mut last = self
            .last_generation
            .lock()
            .unwrap_or_else(|p| p.into_inner());
        last.insert(trial.to_string(), Instant::now());
    }

    /// Trial `trial` finished: its series go, keeping the label set to the
    /// trials in flight.
    pub fn trial_finished(&self, trial: &str) {
        self.trials_finished.inc();
        let _ = self.best.remove_label_values(&[trial]);
        let _ = self.mean.remove_label_values(&[trial]);
        let mut last = self
            .last_generation
            .lock()
            .unwrap_or_else(|p| p.into_inner());
        last.remove(trial);
    }

    pub fn round_trip(&self, took: Duration) {
        self.chunk_round_trip.observe(took.as_secs_f64());
    }

    /// The text exposition of every metric.
    pub fn encode(&self) -> Vec<u8> {
        encode(&self.registry)
    }
}

impl Default for CoordinatorMetrics {
    fn default() -> Self {
        CoordinatorMetrics::new()
    }
}

impl WorkerMetrics {
    pub fn new() -> WorkerMetrics {
        let r = with_process();
        WorkerMetrics {
            jobs: counter(
                &r,
                "lander_worker_jobs_total",
                "Jobs answered, refusals included.",
            ),
            genomes_evaluated: counter(
                &r,
                "lander_worker_genomes_evaluated_total",
                "Genomes flown and scored.",
            ),
            rejected_frames: counter(
                &r,
                "lander_worker_rejected_frames_total",
                "Jobs refused: malformed or of another protocol version.",
            ),
            busy_seconds: add(
                &r,
                Counter::new(
                    "lander_worker_busy_seconds_total",
                    "Seconds spent answering jobs.",
                ),
            ),
            registry: r,
        }
    }

    /// One job answered, of `genomes` genomes, taking `took`.
    pub fn served(&self, genomes: u64, took: Duration, refused: bool) {
        self.jobs.inc();
        self.genomes_evaluated.inc_by(genomes);
        if refused {
            self.rejected_frames.inc();
        }
        self.busy_seconds.inc_by(took.as_secs_f64());
    }

    /// The text exposition of every metric.
    pub fn encode(&self) -> Vec<u8> {
        encode(&self.registry)
    }
}

impl Default for WorkerMetrics {
    fn default() -> Self {
        WorkerMetrics::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn text(bytes: Vec<u8>) -> String {
        String::from_utf8(bytes).unwrap()
    }

    #[test]
    fn a_finished_trial_leaves_no_series_behind() {
        let m = CoordinatorMetrics::new();
        m.trial_started("guided/1");
        m.generation("guided/1", -3.5, -9.25, 100);
        m.generation("guided/1", -2.0, -8.0, 100);
        let during = text(m.encode());
        assert!(
            during.contains("lander_trial_best_fitness{trial=\"guided/1\"} -2"),
            "{during}"
        );
        assert!(
            during.contains("lander_genomes_evaluated_total 200"),
            "{during}"
        );
        assert!(
            during.contains("lander_generation_seconds_count 2"),
            "{during}"
        );
        m.trial_finished("guided/1");
        let after = text(m.encode());
        assert!(!after.contains("trial=\"guided/1\""), "{after}");
        assert!(after.contains("lander_trials_finished_total 1"), "{after}");
    }

    #[test]
    fn a_worker_counts_jobs_genomes_refusals_and_busy_time() {
        let m = WorkerMetrics::new();
        m.served(40, Duration::from_millis(250), false);
        m.served(0, Duration::from_millis(250), true);
        let t = text(m.encode());
        assert!(t.contains("lander_worker_jobs_total 2"), "{t}");
        assert!(
            t.contains("lander_worker_genomes_evaluated_total 40"),
            "{t}"
        );
        assert!(t.contains("lander_worker_rejected_frames_total 1"), "{t}");
        assert!(t.contains("lander_worker_busy_seconds_total 0.5"), "{t}");
        assert!(t.contains("process_cpu_seconds_total"), "{t}");
    }
}
