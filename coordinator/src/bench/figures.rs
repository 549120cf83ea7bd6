//! The figures `lander bench` derives from chunk timings: where a
//! generation's time went ([`Breakdown`]), each chunk's overhead beyond
//! compute ([`overheads`]) and nearest-rank percentiles ([`percentile`]).

use crate::pool::ChunkTiming;
use serde::Serialize;
use std::collections::HashMap;
use std::time::Duration;

/// Where one generation's wall time went over worker processes, in µs.
/// Each worker's time from the first request sent to the last answer read
/// is its start, compute, time between chunks, waiting and the tail; each
/// part here is its mean over the workers, so the parts add up to the wall
/// time. From the chunks' stamps: one host.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Breakdown {
    pub wall_us: f64,
    /// The coordinator alone: building the requests before the first is
    /// sent, and decoding and placing answers after the last is read.
    pub coordinator_us: f64,
    /// From the first request sent to the worker starting its first chunk:
    /// the rest of the hand-out and the worker's waking.
    pub start_us: f64,
    pub compute_us: f64,
    /// Between a worker's chunks: answering one and taking the next, or
    /// sleeping until a chunk taken back from another worker arrives (or
    /// computing one taken back from it just after it started, which no
    /// answer reports).
    pub between_us: f64,
    /// Done, while the last worker still computes: the imbalance.
    pub waiting_us: f64,
    /// From the last chunk finished to its answer read: telling and waking
    /// the coordinator, and its decoding of answers read before in the same
    /// wake.
    pub tail_us: f64,
}

impl Breakdown {
    /// The breakdown of a generation whose chunks went as `timings` and
    /// whose evaluation took `wall`; `None` for no chunks.
    pub fn of(timings: &[ChunkTiming], wall: Duration) -> Option<Breakdown> {
        // Every stamp from the first request sent, in whole nanoseconds:
        // stamps count from boot, and as f64 their differences would round.
        // Stamps come from another process, so nothing here may overflow.
        let first_sent = timings.iter().map(|t| t.sent_ns).min()?;
        let since = |ns: u64| ns.saturating_sub(first_sent);
        let last_read = since(timings.iter().map(|t| t.read_ns).max()?);
        let last_finished = since(timings.iter().map(|t| t.finished_ns).max()?);
        let mut workers: HashMap<u64, WorkerSpan> = HashMap::new();
        for t in timings {
            let w = workers.entry(t.worker).or_insert(WorkerSpan {
                started: u64::MAX,
                finished: 0,
                busy: 0,
            });
            w.started = w.started.min(since(t.started_ns));
            w.finished = w.finished.max(since(t.finished_ns));
            let busy = t.finished_ns.saturating_sub(t.started_ns);
            w.busy = w.busy.saturating_add(busy);
        }
        let mean_us = |part: &dyn Fn(&WorkerSpan) -> u64| {
            let total: f64 = workers.values().map(|w| part(w) as f64).sum();
            total / workers.len() as f64 / 1e3
        };
        let wall_us = wall.as_secs_f64() * 1e6;
        Some(Breakdown {
            wall_us,
            coordinator_us: wall_us - last_read as f64 / 1e3,
            start_us: mean_us(&|w| w.started),
            compute_us: mean_us(&|w| w.busy),
            between_us: mean_us(&|w| w.finished.saturating_sub(w.started).saturating_sub(w.busy)),
            waiting_us: mean_us(&|w| last_finished.saturating_sub(w.finished)),
            tail_us: last_read.saturating_sub(last_finished) as f64 / 1e3,
        })
    }

    /// The mean of `all`, part by part; `None` for none.
    pub fn mean(all: &[Breakdown]) -> Option<Breakdown> {
        let n = all.len() as f64;
        let part = |f: fn(&Breakdown) -> f64| all.iter().map(f).sum::<f64>() / n;
        (!all.is_empty()).then(|| Breakdown {
            wall_us: part(|b| b.wall_us),
            coordinator_us: part(|b| b.coordinator_us),
            start_us: part(|b| b.start_us),
            compute_us: part(|b| b.compute_us),
            between_us: part(|b| b.between_us),
            waiting_us: part(|b| b.waiting_us),
            tail_us: part(|b| b.tail_us),
        })
    }
}

/// One worker's part of a generation: its first start and last finish,
/// counted from the generation's first request, and its time computing in
/// between.
struct WorkerSpan {
    started: u64,
    finished: u64,
    busy: u64,
}

/// Each chunk's round trip minus all its worker computed meanwhile: the
/// chunk itself, a chunk queued ahead of it, and the chunks after it that
/// the worker finished before the coordinator read the answer (an iceoryx2
/// worker wakes the coordinator once it has answered all it holds). What
/// is left is the hand-out, the wake-ups, the transport and the
/// coordinator's reading of the answer. Needs the worker's stamps on the
/// coordinator's clock: one host.
pub fn overheads(timings: &[ChunkTiming]) -> Vec<Duration> {
    let mut by_worker: HashMap<u64, Vec<&ChunkTiming>> = HashMap::new();
    for t in timings {
        by_worker.entry(t.worker).or_default().push(t);
    }
    for runs in by_worker.values_mut() {
        // A worker runs one job at a time, so its jobs sorted by start are
        // sorted by finish too.
        runs.sort_unstable_by_key(|r| r.started_ns);
    }
    timings
        .iter()
        .map(|chunk| {
            let runs = &by_worker[&chunk.worker];
            let first = runs.partition_point(|r| r.finished_ns <= chunk.sent_ns);
            let busy: u64 = runs[first..]
                .iter()
                .take_while(|r| r.started_ns < chunk.read_ns)
                .map(|r| {
                    let start = r.started_ns.max(chunk.sent_ns);
                    r.finished_ns.min(chunk.read_ns).saturating_sub(start)
                })
                .fold(0, u64::saturating_add);
            chunk
                .round_trip()
                .saturating_sub(Duration::from_nanos(busy))
        })
        .collect()
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

    fn timing(worker: u64, sent: u64, read: u64, started: u64, finished: u64) -> ChunkTiming {
        ChunkTiming {
            worker,
            sent_ns: sent,
            read_ns: read,
            started_ns: started,
            finished_ns: finished,
        }
    }

    /// Worker 1 holds three chunks sent at 0, 10 and 20, runs them over
    /// 50..150, 150..250 and 250..300, and wakes the coordinator, which
    /// reads all three at 340. Worker 2's chunk, sent at 30, runs over
    /// 60..260 and is read at 280. Every stamp is `boot` nanoseconds on.
    fn two_workers(boot: u64) -> [ChunkTiming; 4] {
        let at = |worker, sent, read, started, finished| {
            timing(
                worker,
                boot + sent,
                boot + read,
                boot + started,
                boot + finished,
            )
        };
        [
            at(1, 0, 340, 50, 150),
            at(1, 10, 340, 150, 250),
            at(1, 20, 340, 250, 300),
            at(2, 30, 280, 60, 260),
        ]
    }

    #[test]
    fn overhead_leaves_out_everything_the_worker_computed_meanwhile() {
        let ns = Duration::from_nanos;
        // Round trips 340, 330, 320 and 250, less 250, 250, 250 and 200:
        // worker 2's chunk takes nothing off worker 1's.
        assert_eq!(overheads(&two_workers(0)), [ns(90), ns(80), ns(70), ns(50)]);
    }

    #[test]
    fn a_chunk_sent_while_another_runs_counts_only_the_part_after_sending() {
        // Sent at 100 while the worker runs 0..150; runs itself 150..200.
        let t = [timing(1, 0, 210, 0, 150), timing(1, 100, 210, 150, 200)];
        let ns = Duration::from_nanos;
        assert_eq!(overheads(&t), [ns(210 - 200), ns(110 - 100)]);
    }

    #[test]
    fn a_generations_parts_add_up_to_its_wall_time() {
        // `two_workers`, evaluated in 400 ns: worker 1 starts 50 after the
        // first send, computes 250 with no gap, finishes last at 300; worker
        // 2 starts at 60, computes 200, finishes at 260 and waits 40. The
        // last answer is read 40 after the last finish. A host up for ten
        // years changes nothing.
        for boot in [0, 10 * 365 * 86_400 * 1_000_000_000] {
            let b = Breakdown::of(&two_workers(boot), Duration::from_nanos(400)).unwrap();
            assert_two_workers_breakdown(b);
        }
        assert_eq!(Breakdown::of(&[], Duration::from_nanos(400)), None);
    }

    fn assert_two_workers_breakdown(b: Breakdown) {
        let close = |got: f64, want_ns: f64| (got - want_ns / 1e3).abs() < 1e-9;
        assert!(close(b.wall_us, 400.0), "{b:?}");
        assert!(close(b.coordinator_us, 400.0 - 340.0), "{b:?}");
        assert!(close(b.start_us, (50.0 + 60.0) / 2.0), "{b:?}");
        assert!(close(b.compute_us, (250.0 + 200.0) / 2.0), "{b:?}");
        assert!(close(b.between_us, 0.0), "{b:?}");
        assert!(close(b.waiting_us, (0.0 + 40.0) / 2.0), "{b:?}");
        assert!(close(b.tail_us, 40.0), "{b:?}");
        let sum =
            b.coordinator_us + b.start_us + b.compute_us + b.between_us + b.waiting_us + b.tail_us;
        assert!(close(sum, 400.0), "{b:?}");
    }

    #[test]
    fn a_gap_between_chunks_is_counted_as_such() {
        // One worker: 10..20, then idle until 50, then 50..70; read at 80.
        let t = [timing(7, 0, 80, 10, 20), timing(7, 5, 80, 50, 70)];
        let b = Breakdown::of(&t, Duration::from_nanos(90)).unwrap();
        assert!((b.between_us - 0.030).abs() < 1e-9, "{b:?}");
        assert!((b.tail_us - 0.010).abs() < 1e-9, "{b:?}");
        assert!((b.coordinator_us - 0.010).abs() < 1e-9, "{b:?}");
    }

    #[test]
    fn nonsense_stamps_from_a_worker_give_nonsense_figures_but_no_panic() {
        let t = [
            timing(1, 10, 5, u64::MAX, 0),
            timing(1, 0, u64::MAX, 0, u64::MAX),
            timing(1, 0, u64::MAX, 1, u64::MAX),
            timing(2, u64::MAX, 0, 3, 2),
        ];
        assert_eq!(overheads(&t).len(), 4);
        assert!(Breakdown::of(&t, Duration::from_nanos(1)).is_some());
    }

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
