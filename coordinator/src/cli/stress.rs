//! `lander bench --stress`: throughput under churn. Workers are killed at
//! random while small chunks fly; the results must equal an in-process
//! evaluation of the same workload, genome by genome. Here the pool is
//! built, the killer run and the report printed; the flying, the check and
//! the kills' schedule are the library's (`lander_coordinator::bench::stress`).

use super::transport::pool_options;
use anyhow::Context;
use lander_coordinator::bench::stress;
use lander_coordinator::bench::{kill_gap, Mode, ModeKind, StressReport, Workload, MAX_KILL_RATE};
use lander_coordinator::evaluator::InProcess;
use lander_coordinator::pool::{kill_worker_child, worker_children, IpcPool};
use lander_coordinator::stop::Stop;
use rand::Rng;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;

pub struct StressArgs {
    pub workers: usize,
    pub kill_rate: f64,
    pub no_pin: bool,
    pub json: bool,
    /// Fly the workload round after round for this long, watching the
    /// coordinator's resources.
    pub soak: Option<Duration>,
    /// The churned pool counts into it: metrics, where `--metrics` serves
    /// them.
    pub telemetry: lander_telemetry::Telemetry,
}

/// How much a soak lets the coordinator's resources grow from the end of
/// its first round to its end: memory by allocator noise, descriptors and
/// iceoryx2 files by what the workers being respawned at that moment hold.
const SOAK_RSS_GROWTH_KIB: u64 = 32 * 1024;
const SOAK_FD_GROWTH: usize = 16;
const SOAK_IOX_GROWTH_PER_WORKER: usize = 8;

/// The coordinator's resources at one moment of a soak.
#[derive(Clone, Copy, Debug, serde::Serialize)]
struct Resources {
    resident_kib: u64,
    open_descriptors: usize,
    iceoryx2_files: usize,
}

impl Resources {
    fn now() -> Resources {
        Resources {
            resident_kib: lander_protocol::host::resident_kib().unwrap_or(0),
            open_descriptors: lander_protocol::host::open_descriptors().unwrap_or(0),
            iceoryx2_files: lander_protocol::iox::resource_count(),
        }
    }
}

/// What a soak saw: rounds flown, and the resources after the first round
/// and at the end.
#[derive(Debug, serde::Serialize)]
struct Soak {
    seconds: f64,
    rounds: u64,
    start: Resources,
    end: Resources,
    bounds: Resources,
}

impl Soak {
    fn within_bounds(&self) -> bool {
        let grew = |a: usize, b: usize| b.saturating_sub(a);
        self.end
            .resident_kib
            .saturating_sub(self.start.resident_kib)
            <= self.bounds.resident_kib
            && grew(self.start.open_descriptors, self.end.open_descriptors)
                <= self.bounds.open_descriptors
            && grew(self.start.iceoryx2_files, self.end.iceoryx2_files)
                <= self.bounds.iceoryx2_files
    }
}

pub fn stress(args: &StressArgs, work: &Workload, stop_asked: &Stop) -> anyhow::Result<()> {
    let stop = stop_asked;
    anyhow::ensure!(
        (0.0..=MAX_KILL_RATE).contains(&args.kill_rate),
        "--kill-rate must be 0 to {MAX_KILL_RATE} kills per second (got {:?})",
        args.kill_rate
    );
    // One thread per core: the reference need only be right.
    let inproc = InProcess::new(0)?.stopping_on(stop.clone());
    let threads = inproc.thread_count();
    let mut reference = Mode::new(ModeKind::InProcess { threads }, Box::new(inproc));
    let mut opts = pool_options(
        format!("stress{:08x}", rand::random::<u32>()),
        args.workers,
        Duration::from_secs(60),
        !args.no_pin,
        stop,
    )?;
    opts.chunks_per_worker = 16;
    opts.max_respawns = usize::MAX;
    // Every chunk goes through the workers being killed.
    opts.share = false;
    opts.stand_in = false;
    let mut pool = IpcPool::start(opts, args.telemetry.clone())?;
    pool.wait_for_workers(args.workers, Duration::from_secs(20))
        .context("waiting for the workers")?;
    let kind = ModeKind::Iceoryx2 {
        workers: args.workers,
    };
    // A soak flies millions of chunks: keeping each one's timing, as the
    // comparison's figures need, grew the coordinator by 80 MB in ten
    // minutes. The churn report uses none of them.
    let mut churned = Mode::untimed(kind, Box::new(pool));

    let stop = Arc::new(AtomicBool::new(false));
    let kills = Arc::new(AtomicU64::new(0));
    let killer = (args.kill_rate > 0.0).then(|| {
        let (stop, kills, rate) = (stop.clone(), kills.clone(), args.kill_rate);
        std::thread::spawn(move || kill_at_random(rate, &stop, &kills))
    });
    let began = std::time::Instant::now();
    let mut flown = stress::fly(work, &mut reference, &mut churned);
    let mut rounds = 1;
    let start = Resources::now();
    if let Some(soak) = args.soak {
        while flown.is_ok() && began.elapsed() < soak && !stop_asked.asked() {
            flown = stress::fly(work, &mut reference, &mut churned);
            rounds += 1;
        }
    }
    let end = Resources::now();
    stop.store(true, Ordering::Relaxed);
    if let Some(k) = killer {
        let _ = k.join();
    }
    flown?;
    let kills = kills.load(Ordering::Relaxed);
    let mut report = StressReport::new(work, &reference, &churned, args.kill_rate, kills);
    report.expected *= rounds;
    let soak = args.soak.map(|_| Soak {
        seconds: began.elapsed().as_secs_f64(),
        rounds,
        start,
        end,
        bounds: Resources {
            resident_kib: SOAK_RSS_GROWTH_KIB,
            open_descriptors: SOAK_FD_GROWTH,
            iceoryx2_files: SOAK_IOX_GROWTH_PER_WORKER * args.workers,
        },
    });
    churned.evaluator.run_over();
    drop(churned);
    if args.json {
        let mut value = serde_json::to_value(&report)?;
        if let (Some(soak), Some(map)) = (&soak, value.as_object_mut()) {
            map.insert("soak".into(), serde_json::to_value(soak)?);
        }
        outln!("{}", serde_json::to_string(&value)?)?;
    } else {
        outln!(
            "{} GA under churn: {} genomes × {} generations, {} workers, {} killed ({:.1}/s asked)",
            report.method,
            report.population,
            report.generations,
            report.workers,
            report.kills,
            report.kill_rate
        )?;
        outln!(
            "{:.0} genomes/s, {:.1} M ticks/s; evaluated {} of {} genomes; results match in-process: {}",
            report.genomes_per_s,
            report.ticks_per_s / 1e6,
            report.evaluated,
            report.expected,
            report.results_match
        )?;
    }
    if let Some(soak) = &soak {
        if !args.json {
            let show = |r: &Resources| {
                format!(
                    "{} KiB resident, {} descriptors, {} iceoryx2 files",
                    r.resident_kib, r.open_descriptors, r.iceoryx2_files
                )
            };
            outln!(
                "soak: {} rounds in {:.0} s; after the first: {}; at the end: {}",
                soak.rounds,
                soak.seconds,
                show(&soak.start),
                show(&soak.end)
            )?;
        }
        anyhow::ensure!(
            soak.within_bounds(),
            "the coordinator's resources grew past the soak's bounds ({} KiB, {} descriptors, {} iceoryx2 files)",
            soak.bounds.resident_kib,
            soak.bounds.open_descriptors,
            soak.bounds.iceoryx2_files
        );
    }
    anyhow::ensure!(
        report.lost_nothing(),
        "work was lost or changed under churn"
    );
    Ok(())
}

/// SIGKILLs one of this process's `lander-worker` children at random
/// moments, `rate` times a second on average, until told to stop.
fn kill_at_random(rate: f64, stop: &AtomicBool, kills: &AtomicU64) {
    let mut rng = rand::rng();
    while !stop.load(Ordering::Relaxed) {
        let until = std::time::Instant::now() + kill_gap(rng.random::<f64>(), rate);
        while std::time::Instant::now() < until {
            if stop.load(Ordering::Relaxed) {
                return;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        let workers = worker_children(std::process::id());
        if workers.is_empty() {
            continue;
        }
        let pid = workers[rng.random_range(0..workers.len())];
        if kill_worker_child(std::process::id(), pid) {
            kills.fetch_add(1, Ordering::Relaxed);
        }
    }
}
