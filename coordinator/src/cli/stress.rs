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
}

pub fn stress(args: &StressArgs, work: &Workload, stop: &Stop) -> anyhow::Result<()> {
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
    let mut pool = IpcPool::start(opts, Box::new(|_| {}))?;
    pool.wait_for_workers(args.workers, Duration::from_secs(20))
        .context("waiting for the workers")?;
    let kind = ModeKind::Iceoryx2 {
        workers: args.workers,
    };
    let mut churned = Mode::new(kind, Box::new(pool));

    let stop = Arc::new(AtomicBool::new(false));
    let kills = Arc::new(AtomicU64::new(0));
    let killer = (args.kill_rate > 0.0).then(|| {
        let (stop, kills, rate) = (stop.clone(), kills.clone(), args.kill_rate);
        std::thread::spawn(move || kill_at_random(rate, &stop, &kills))
    });
    let flown = stress::fly(work, &mut reference, &mut churned);
    stop.store(true, Ordering::Relaxed);
    if let Some(k) = killer {
        let _ = k.join();
    }
    flown?;
    let kills = kills.load(Ordering::Relaxed);
    let report = StressReport::new(work, &reference, &churned, args.kill_rate, kills);
    drop(churned);
    if args.json {
        println!("{}", serde_json::to_string(&report)?);
    } else {
        println!(
            "{} GA under churn: {} genomes × {} generations, {} workers, {} killed ({:.1}/s asked)",
            report.method,
            report.population,
            report.generations,
            report.workers,
            report.kills,
            report.kill_rate
        );
        println!(
            "{:.0} genomes/s, {:.1} M ticks/s; evaluated {} of {} genomes; results match in-process: {}",
            report.genomes_per_s,
            report.ticks_per_s / 1e6,
            report.evaluated,
            report.expected,
            report.results_match
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
