//! `lander bench --stress`: throughput under churn. Workers are killed at
//! random while small chunks fly; the results must equal an in-process
//! evaluation of the same workload, genome by genome.

use super::transport::pool_options;
use anyhow::Context;
use lander_coordinator::bench::{Mode, ModeEvaluator, Workload};
use lander_coordinator::evaluator::InProcess;
use lander_coordinator::pool::{kill_worker_child, worker_children, IpcPool};
use lander_coordinator::stop::Stop;
use rand::Rng;
use serde::Serialize;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;

/// The most kills a second: a worker needs some milliseconds to start, so
/// beyond this the workers would do little but die.
const MAX_KILL_RATE: f64 = 100.0;

pub struct StressArgs {
    pub workers: usize,
    pub kill_rate: f64,
    pub no_pin: bool,
    pub json: bool,
}

#[derive(Serialize)]
struct StressReport {
    method: &'static str,
    population: usize,
    generations: usize,
    workers: usize,
    kill_rate: f64,
    kills: u64,
    genomes_per_s: f64,
    ticks_per_s: f64,
    /// Genomes evaluated, and how many the workload holds.
    evaluated: u64,
    expected: u64,
    /// Every result equals the in-process one.
    results_match: bool,
}

pub fn stress(args: &StressArgs, work: &Workload, stop: &Stop) -> anyhow::Result<()> {
    anyhow::ensure!(
        (0.0..=MAX_KILL_RATE).contains(&args.kill_rate),
        "--kill-rate must be 0 to {MAX_KILL_RATE} kills per second (got {:?})",
        args.kill_rate
    );
    let mut reference = Mode::new("inproc", ModeEvaluator::InProcess(InProcess::new(0)?));
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
    let mut churned = Mode::new("iceoryx2", ModeEvaluator::Iceoryx2(Box::new(pool)));

    let stop = Arc::new(AtomicBool::new(false));
    let kills = Arc::new(AtomicU64::new(0));
    let killer = (args.kill_rate > 0.0).then(|| {
        let (stop, kills, rate) = (stop.clone(), kills.clone(), args.kill_rate);
        std::thread::spawn(move || kill_at_random(rate, &stop, &kills))
    });
    for g in 0..work.steps.len() {
        reference.step(work, g)?;
        churned.step(work, g)?;
    }
    stop.store(true, Ordering::Relaxed);
    if let Some(k) = killer {
        let _ = k.join();
    }
    reference.end_round();
    churned.end_round();

    let expected = work.genomes() as u64;
    let r = churned.report();
    let report = StressReport {
        method: work.method.method().name(),
        population: work.cfg.ga.population,
        generations: work.steps.len(),
        workers: args.workers,
        kill_rate: args.kill_rate,
        kills: kills.load(Ordering::Relaxed),
        genomes_per_s: r.genomes_per_s,
        ticks_per_s: r.ticks_per_s,
        evaluated: churned.tally.genomes,
        expected,
        results_match: reference.tally.hash == churned.tally.hash,
    };
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
        report.results_match && report.evaluated == expected,
        "work was lost or changed under churn"
    );
    Ok(())
}

/// SIGKILLs one of this process's `lander-worker` children at random
/// moments, `rate` times a second on average, until told to stop.
fn kill_at_random(rate: f64, stop: &AtomicBool, kills: &AtomicU64) {
    let mut rng = rand::rng();
    while !stop.load(Ordering::Relaxed) {
        // Exponential gaps make the kills a Poisson process.
        let gap = -rng.random::<f64>().max(1e-9).ln() / rate;
        let until = std::time::Instant::now() + Duration::from_secs_f64(gap.min(60.0));
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
