//! `lander bench`: the throughput stress test, modes side by side. Here
//! the flags are parsed, the evaluators built and the report printed; the
//! warm-up, the turns, the ratios and the agreement of the results are the
//! library's (`lander_coordinator::bench`).

use super::transport::{pool_options, CoordinatorShare};
use anyhow::Context;
use clap::Args;
use lander_coordinator::bench::{Measured, Mode, ModeKind, Plan, Report, Workload};
use lander_coordinator::config::RunConfig;
use lander_coordinator::evaluator::InProcess;
use lander_coordinator::pool::zenoh::Zenoh;
use lander_coordinator::pool::{IpcPool, Pool, PoolOptions};
use lander_coordinator::stop::Stop;
use lander_model::Method;
use lander_protocol::iox::MAX_WORKERS;
use lander_protocol::net::{coordinator_config, NetOptions};
use lander_protocol::spin::MAX_SPIN_US;
use lander_telemetry::Telemetry;
use std::path::PathBuf;
use std::time::Duration;

/// Chunks per worker unless `--chunks-per-worker` says otherwise: as many
/// as a worker queues at once, as `lander run` uses.
const DEFAULT_CHUNKS: u16 = lander_coordinator::pool::DEPTH as u16;

#[derive(Args, Debug)]
pub struct BenchArgs {
    /// A TOML run configuration for the model's parameters.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Workers (and threads) for the parallel modes.
    #[arg(long, default_value_t = 2)]
    workers: usize,
    /// Generations in the workload, which keeps each of them and may hold
    /// at most 4 GB [default: as many as the first trial flies, so that
    /// the workload is `lander run --seed S --trial T`'s; 60 with
    /// --stress].
    #[arg(long)]
    generations: Option<u64>,
    /// Genomes per generation [default: 100, or 10000 with --stress].
    #[arg(long)]
    population: Option<usize>,
    /// The GA whose evaluation is measured (Q(λ) trains, and is not a
    /// throughput of genomes).
    #[arg(long, default_value = "guided",
          value_parser = super::method_parser(&[Method::Ga, Method::Guided]))]
    method: Method,
    /// GA trials stepped together, as `lander experiment --in-flight` steps
    /// them: each step evaluates one generation of each as one batch. 1
    /// measures a single trial (`lander run`), whose generations are
    /// small; an experiment on 2 workers has 8 in flight by default.
    #[arg(long, value_name = "N", default_value_t = 1,
          value_parser = clap::value_parser!(u16).range(1..=1024))]
    in_flight: u16,
    /// Rounds; in each, every mode flies all the generations back to back,
    /// the modes' order rotating from round to round.
    #[arg(long, default_value_t = 5)]
    rounds: usize,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// The first trial flown for the workload: with the same seed, trial
    /// and generations, the bench breeds and evaluates exactly the
    /// generations that `lander run --seed S --trial T` does.
    #[arg(long, default_value_t = 1)]
    trial: u64,
    /// Transports to compare, comma-separated: inproc, iceoryx2, zenoh.
    #[arg(long, value_delimiter = ',', default_value = "inproc,iceoryx2")]
    transports: Vec<String>,
    /// zenoh mode: where the coordinator listens (loopback)
    /// [default: tcp/127.0.0.1:7448].
    #[arg(long, value_name = "ENDPOINT")]
    listen: Option<String>,
    /// Chunks each worker gets of a generation, for the worker-process
    /// modes (not --stress, which uses 16). More can balance the workers
    /// better, but each costs a little to send and answer, and a worker
    /// queues at most 4 at once [default: 4].
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u16).range(1..=256))]
    chunks_per_worker: Option<u16>,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    json: bool,
    /// Churn instead of comparison: small chunks over iceoryx2 workers that
    /// are killed and respawned at random, checked genome by genome against
    /// in-process evaluation.
    // The comparison's own settings do not apply to it, and are refused.
    #[arg(long, conflicts_with_all = ["transports", "rounds", "listen", "spin_us", "verify", "coordinator_share"])]
    stress: bool,
    /// Let the workers run on any CPU instead of one CPU each.
    #[arg(long)]
    no_pin: bool,
    /// Microseconds an evaluation thread or a spawned worker with a CPU of
    /// its own polls for its next work, and the coordinator standing in
    /// for the worker on its CPU for answers, before sleeping, as `lander
    /// run --spin-us` (0: never) [default: as `lander run`].
    #[arg(long, value_name = "MICROSECONDS", value_parser = clap::value_parser!(u64).range(0..=MAX_SPIN_US))]
    spin_us: Option<u64>,
    /// The worker-process modes check this share of answered chunks, 0 to
    /// 1, as `lander run --verify`, to measure what checking costs.
    #[arg(long, value_name = "RATE", default_value_t = 0.0)]
    verify: f64,
    /// Whether the coordinator of the worker-process modes flies queued
    /// chunks itself, as `lander run --coordinator-share` [default: auto].
    #[arg(long, value_enum, value_name = "WHEN")]
    coordinator_share: Option<CoordinatorShare>,
    /// With --stress: worker kills per second, on average [default: 2].
    #[arg(long, value_name = "PER_S")]
    kill_rate: Option<f64>,
    /// With --stress: fly the workload again and again for this long, and
    /// check that the coordinator's memory, open descriptors and iceoryx2
    /// files do not grow (a soak).
    #[arg(long, value_name = "SECONDS")]
    soak: Option<u64>,
    /// The worker-process modes (or --stress's churned pool) count into
    /// metrics served here, as `lander run --metrics`, to measure what
    /// metrics cost.
    #[command(flatten)]
    watch: super::watch::WatchArgs,
}

/// Worker kills per second under --stress, unless --kill-rate says.
const DEFAULT_KILL_RATE: f64 = 2.0;

fn args_for_stress(args: &BenchArgs, telemetry: &Telemetry) -> super::stress::StressArgs {
    super::stress::StressArgs {
        telemetry: telemetry.clone(),
        workers: args.workers,
        kill_rate: args.kill_rate.unwrap_or(DEFAULT_KILL_RATE),
        no_pin: args.no_pin,
        json: args.json,
        soak: args.soak.map(Duration::from_secs),
    }
}

fn pool_options_for(
    args: &BenchArgs,
    id: String,
    workers: usize,
    stop: &Stop,
) -> anyhow::Result<PoolOptions> {
    let mut opts = pool_options(id, workers, Duration::from_secs(60), !args.no_pin, stop)?;
    opts.chunks_per_worker = usize::from(args.chunks_per_worker.unwrap_or(DEFAULT_CHUNKS));
    if let Some(us) = args.spin_us {
        opts.spin = Duration::from_micros(us);
    }
    opts.verify = args.verify;
    let share = args.coordinator_share.unwrap_or(CoordinatorShare::Auto);
    opts.share = share.applies(workers);
    opts.stand_in = share.stands_in();
    Ok(opts)
}

/// zenoh mode's endpoint unless `--listen` says otherwise.
const DEFAULT_LISTEN: &str = "tcp/127.0.0.1:7448";

/// Refuses the flags of modes that `kinds` does not run: they would
/// change nothing, and the report would still name them.
fn check_mode_flags(args: &BenchArgs, kinds: &[ModeKind]) -> anyhow::Result<()> {
    anyhow::ensure!(
        (0.0..=1.0).contains(&args.verify),
        "--verify must be a share from 0 to 1 (got {})",
        args.verify
    );
    let pools = kinds
        .iter()
        .any(|k| !matches!(k, ModeKind::InProcess { .. }));
    for (given, flag) in [
        (args.verify != 0.0, "--verify"),
        (args.chunks_per_worker.is_some(), "--chunks-per-worker"),
        (args.coordinator_share.is_some(), "--coordinator-share"),
        (args.no_pin, "--no-pin"),
    ] {
        anyhow::ensure!(
            pools || !given,
            "{flag} applies only to the worker-process modes (--transports iceoryx2 or zenoh)"
        );
    }
    let zenoh = kinds.iter().any(|k| matches!(k, ModeKind::Zenoh { .. }));
    anyhow::ensure!(
        zenoh || args.listen.is_none(),
        "--listen applies only to --transports zenoh"
    );
    Ok(())
}

/// The modes `--transports` names, in its order, each transport checked
/// before any evaluator starts. A transport named twice is refused: its
/// modes would be measured twice and reported as two.
fn kinds(args: &BenchArgs) -> anyhow::Result<Vec<ModeKind>> {
    let mut kinds = Vec::new();
    for (i, transport) in args.transports.iter().enumerate() {
        anyhow::ensure!(
            !args.transports[..i].contains(transport),
            "--transports names {transport:?} twice"
        );
        match ModeKind::for_transport(transport, args.workers) {
            Some(k) => kinds.extend(k),
            None => anyhow::bail!(
                "--transports: unknown transport {transport:?} (known: inproc, iceoryx2, zenoh)"
            ),
        }
    }
    Ok(kinds)
}

/// Starts the evaluator of a mode of `kind`, its workers announced.
fn evaluator(
    args: &BenchArgs,
    kind: ModeKind,
    telemetry: &Telemetry,
    stop: &Stop,
) -> anyhow::Result<Box<dyn Measured>> {
    Ok(match kind {
        ModeKind::InProcess { threads } => {
            let mut inproc = InProcess::new(threads)?.stopping_on(stop.clone());
            if let Some(us) = args.spin_us {
                inproc = inproc.spinning(Duration::from_micros(us));
            }
            Box::new(inproc)
        }
        ModeKind::Iceoryx2 { workers } => {
            let id = format!("bench{:08x}", rand::random::<u32>());
            let opts = pool_options_for(args, id, workers, stop)?;
            let mut pool = IpcPool::start(opts, telemetry.clone())?;
            pool.wait_for_workers(workers, Duration::from_secs(20))
                .context("waiting for the benchmark's workers")?;
            Box::new(pool)
        }
        ModeKind::Zenoh { workers } => {
            let id = format!("bench{:08x}", rand::random::<u32>());
            let opts = pool_options_for(args, id, workers, stop)?;
            let options = NetOptions {
                listen: vec![args.listen.as_deref().unwrap_or(DEFAULT_LISTEN).to_string()],
                ..NetOptions::default()
            };
            let config = coordinator_config(&options)?;
            super::transport::refuse_any_port(&config, true)?;
            let transport = Zenoh::open(&opts.run_id, config)?;
            let mut pool = Pool::with_transport(transport, opts, telemetry.clone())?;
            pool.wait_for_workers(workers, Duration::from_secs(20))
                .context("waiting for the benchmark's zenoh workers")?;
            Box::new(pool)
        }
    })
}

pub fn bench(args: BenchArgs, stop: &Stop) -> anyhow::Result<()> {
    anyhow::ensure!(
        (1..=MAX_WORKERS).contains(&args.workers),
        "--workers must be 1 to {MAX_WORKERS} (got {})",
        args.workers
    );
    anyhow::ensure!(args.rounds >= 1, "--rounds must be at least 1");
    let mut cfg = match &args.config {
        Some(path) => RunConfig::load(path)?,
        None => RunConfig::default(),
    };
    cfg.method = args.method;
    let Some(pass) = args.method.pass() else {
        anyhow::bail!("--method must be ga or guided");
    };
    cfg.seed = args.seed;
    cfg.trial = args.trial;
    let (population, generations) = if args.stress {
        (10_000, Some(60))
    } else {
        (100, None)
    };
    cfg.ga.population = args.population.unwrap_or(population);
    cfg.validate()?;
    let generations = args.generations.or(generations);
    anyhow::ensure!(generations != Some(0), "--generations must be at least 1");
    // Checked here rather than by clap's `requires`, which a flag's
    // default (`--stress` off) satisfies.
    for (given, flag) in [
        (args.kill_rate.is_some(), "--kill-rate"),
        (args.soak.is_some(), "--soak"),
    ] {
        anyhow::ensure!(args.stress || !given, "{flag} applies only to --stress");
    }
    if args.stress {
        anyhow::ensure!(
            args.chunks_per_worker.is_none(),
            "--chunks-per-worker does not apply to --stress, which uses small chunks of its own"
        );
        anyhow::ensure!(
            args.in_flight == 1,
            "--in-flight does not apply to --stress, which flies one large population"
        );
    }
    // The modes, checked before the workload is bred (`--stress` has its own).
    let kinds = if args.stress {
        Vec::new()
    } else {
        let kinds = kinds(&args)?;
        anyhow::ensure!(!kinds.is_empty(), "--transports named no transport");
        check_mode_flags(&args, &kinds)?;
        kinds
    };
    anyhow::ensure!(
        cfg.trial
            .checked_add(u64::from(args.in_flight) - 1)
            .is_some(),
        "--in-flight {} trials from trial {} would number past the largest trial",
        args.in_flight,
        cfg.trial
    );
    let work = Workload::new(&cfg, pass, generations, usize::from(args.in_flight), stop)?;
    let watch = args
        .watch
        .start(format!("bench{:08x}", rand::random::<u32>()))?;
    if args.stress {
        return super::stress::stress(&args_for_stress(&args, &watch.telemetry), &work, stop);
    }
    let mut modes = Vec::new();
    for kind in kinds {
        modes.push(Mode::new(
            kind,
            evaluator(&args, kind, &watch.telemetry, stop)?,
        ));
    }
    let plan = Plan {
        rounds: args.rounds,
        workers: args.workers,
        chunks_per_worker: args.chunks_per_worker.unwrap_or(DEFAULT_CHUNKS),
    };
    let report = lander_coordinator::bench::run(&work, &mut modes, &plan)?;
    // The workers go before the report is printed, told the run is over.
    for mode in &mut modes {
        mode.evaluator.run_over();
    }
    drop(modes);
    if args.json {
        outln!("{}", serde_json::to_string(&report)?)?;
    } else {
        print_table(&report)?;
    }
    anyhow::ensure!(
        report.hashes_agree,
        "the modes' results differ: a determinism bug"
    );
    Ok(())
}

fn print_table(r: &Report) -> anyhow::Result<()> {
    let method = if r.method == "ga" {
        "general"
    } else {
        r.method
    };
    let trials = match r.in_flight {
        1 => String::new(),
        n => format!(" × {n} trials in flight"),
    };
    outln!(
        "{method} GA, {} genomes{trials} × {} generations × {} rounds, {} workers, {} chunks per worker",
        r.population, r.generations, r.rounds, r.workers, r.chunks_per_worker
    )?;
    outln!(
        "{:<12} {:>12} {:>10} {:>9} {:>9} {:>9} {:>12} {:>13} {:>15} {:>6}",
        "mode",
        "genomes/s",
        "Mticks/s",
        "rtt p50",
        "rtt p99",
        "rtt max",
        "overhead p99",
        "coord CPU/gen",
        "coord CPU/chunk",
        "util"
    )?;
    let us = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.0} µs"));
    for m in &r.modes {
        outln!(
            "{:<12} {:>12.0} {:>10.1} {:>9} {:>9} {:>9} {:>12} {:>10.0} µs {:>15} {:>6}",
            m.name,
            m.genomes_per_s,
            m.ticks_per_s / 1e6,
            us(m.rtt_p50_us),
            us(m.rtt_p99_us),
            us(m.rtt_max_us),
            us(m.overhead_p99_us),
            m.coordinator_cpu_us_per_generation,
            m.coordinator_cpu_us_per_chunk
                .map_or("-".into(), |c| format!("{c:.1} µs")),
            m.worker_utilisation
                .map_or("-".into(), |u| format!("{:.0}%", u * 100.0)),
        )?;
    }
    print_breakdowns(r)?;
    let pct = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.2}×"));
    outln!(
        "scaling (iceoryx2-{n} / iceoryx2-1): {} (compute alone: {})   ipc efficiency (iceoryx2-{n} / inproc-{n}): {}   \
         zenoh efficiency (zenoh-{n} / inproc-{n}): {}   results agree: {}",
        pct(r.ratios.scaling),
        pct(r.ratios.compute_scaling),
        pct(r.ratios.ipc_efficiency),
        pct(r.ratios.zenoh_efficiency),
        r.hashes_agree,
        n = r.workers
    )
}

/// Where a generation's time went, for the modes over worker processes.
fn print_breakdowns(r: &Report) -> anyhow::Result<()> {
    let rows: Vec<_> = r
        .modes
        .iter()
        .filter_map(|m| Some((&m.name, m.generation?)))
        .collect();
    if rows.is_empty() {
        return Ok(());
    }
    outln!(
        "a generation, mean µs (each part the mean over workers; with the coordinator's, they add up to the wall time):"
    )?;
    outln!(
        "{:<12} {:>8} {:>11} {:>8} {:>8} {:>8} {:>8} {:>8}",
        "mode",
        "wall",
        "coordinator",
        "start",
        "compute",
        "between",
        "waiting",
        "tail"
    )?;
    for (name, b) in rows {
        outln!(
            "{:<12} {:>8.0} {:>11.0} {:>8.0} {:>8.0} {:>8.0} {:>8.0} {:>8.0}",
            name,
            b.wall_us,
            b.coordinator_us,
            b.start_us,
            b.compute_us,
            b.between_us,
            b.waiting_us,
            b.tail_us
        )?;
    }
    Ok(())
}
