//! `lander run`: one trial, with a progress bar, written to a folder.

use anyhow::Context;
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use lander_coordinator::config::{Approach, RunConfig};
use lander_coordinator::evaluator::{Evaluator, InProcess};
use lander_coordinator::pool::{IpcPool, PoolOptions};
use lander_coordinator::report::{write_json, BestRecord, GenerationLog, Summary};
use lander_coordinator::trial::{run_trial, Generation};
use lander_protocol::iox::MAX_WORKERS;
use std::path::PathBuf;
use std::time::{Duration, Instant};

#[derive(Args, Debug)]
pub struct RunArgs {
    /// A TOML run configuration; flags given here override it.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// `ga` (the general GA), `guided` (with the evolve pass) or
    /// `qlearning` (the Q(λ) baseline).
    #[arg(long, value_enum)]
    method: Option<MethodArg>,
    /// Q-learning episodes per trial (SPEC: 5000).
    #[arg(long)]
    episodes: Option<u32>,
    #[arg(long)]
    seed: Option<u64>,
    /// Trial number; `x0` and `pad_x` come from (seed, trial).
    #[arg(long)]
    trial: Option<u64>,
    #[arg(long)]
    population: Option<usize>,
    /// Evaluation threads; 0 means one per core.
    #[arg(long)]
    threads: Option<usize>,
    /// Generations per attempt before a restart with a new pad (paper: 500).
    #[arg(long)]
    max_generations: Option<u64>,
    /// Restarts before the trial ends unlanded; 0 is a single attempt [default: 9].
    #[arg(long)]
    max_restarts: Option<u64>,
    /// Output folder [default: runs/<method>-seed<seed>-trial<trial>].
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Print one JSON summary object on stdout.
    #[arg(long)]
    json: bool,
    /// Worker processes to spawn, evaluating over iceoryx2 shared memory;
    /// 0 evaluates in this process.
    #[arg(long, value_name = "N", default_value_t = 0)]
    workers: usize,
    /// Wait for workers started elsewhere with `lander-worker --run <id>`;
    /// they may join or leave at any time.
    #[arg(long)]
    attach: bool,
    /// The run id that names this run's iceoryx2 services [default: random].
    #[arg(long, value_name = "ID")]
    run_id: Option<String>,
    /// Seconds a worker may take over one chunk before it goes to another.
    #[arg(long, value_name = "SECS", default_value_t = 30.0)]
    deadline: f64,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum MethodArg {
    Ga,
    Guided,
    Qlearning,
}

impl From<MethodArg> for Approach {
    fn from(m: MethodArg) -> Approach {
        match m {
            MethodArg::Ga => Approach::Ga,
            MethodArg::Guided => Approach::Guided,
            MethodArg::Qlearning => Approach::Qlearning,
        }
    }
}

impl RunArgs {
    fn config(&self) -> anyhow::Result<RunConfig> {
        let mut cfg = match &self.config {
            Some(path) => RunConfig::load(path)?,
            None => RunConfig::default(),
        };
        cfg.method = self.method.map_or(cfg.method, Approach::from);
        cfg.qlearning.episodes = self.episodes.unwrap_or(cfg.qlearning.episodes);
        cfg.seed = self.seed.unwrap_or(cfg.seed);
        cfg.trial = self.trial.unwrap_or(cfg.trial);
        cfg.threads = self.threads.unwrap_or(cfg.threads);
        cfg.ga.population = self.population.unwrap_or(cfg.ga.population);
        cfg.ga.max_generations = self.max_generations.unwrap_or(cfg.ga.max_generations);
        cfg.ga.max_restarts = self.max_restarts.unwrap_or(cfg.ga.max_restarts);
        cfg.validate()?;
        Ok(cfg)
    }
}

impl RunArgs {
    /// The evaluator the flags ask for: in-process, spawned workers, or
    /// attached ones.
    fn evaluator(&self, cfg: &RunConfig, bar: &ProgressBar) -> anyhow::Result<Box<dyn Evaluator>> {
        Ok(match self.pool(bar)? {
            Some(pool) => Box::new(pool),
            None => Box::new(InProcess::new(cfg.threads)?),
        })
    }

    /// The worker pool the flags ask for, or `None` for in-process work.
    fn pool(&self, bar: &ProgressBar) -> anyhow::Result<Option<IpcPool>> {
        anyhow::ensure!(
            self.workers <= MAX_WORKERS,
            "--workers must be at most {MAX_WORKERS} (got {})",
            self.workers
        );
        anyhow::ensure!(
            self.deadline.is_finite() && self.deadline > 0.0,
            "--deadline must be a positive number of seconds (got {})",
            self.deadline
        );
        if self.workers == 0 && !self.attach {
            anyhow::ensure!(
                self.run_id.is_none(),
                "--run-id needs --workers or --attach"
            );
            return Ok(None);
        }
        anyhow::ensure!(
            !(self.attach && self.workers > 0),
            "--attach and --workers N exclude each other: attach waits for workers started elsewhere"
        );
        let run_id = match &self.run_id {
            Some(id) => check_run_id(id)?,
            None => format!("{:08x}", rand::random::<u32>()),
        };
        let opts = pool_options(run_id, self.workers, Duration::from_secs_f64(self.deadline))?;
        let bar = bar.clone();
        let say = Box::new(move |msg: &str| bar.suspend(|| eprintln!("lander: {msg}")));
        if self.attach {
            say(&format!("run id {}", opts.run_id));
        }
        Ok(Some(IpcPool::start(opts, say)?))
    }
}

/// A pool that spawns `workers` copies of the `lander-worker` beside this
/// executable (0: workers attach themselves).
pub fn pool_options(
    run_id: String,
    workers: usize,
    deadline: Duration,
) -> anyhow::Result<PoolOptions> {
    let worker_exe = std::env::current_exe()
        .context("finding this executable")?
        .with_file_name("lander-worker");
    Ok(PoolOptions {
        run_id,
        spawn: workers,
        worker_exe,
        chunks_per_worker: 4,
        deadline,
        max_respawns: 3 * workers.max(1),
    })
}

fn check_run_id(id: &str) -> anyhow::Result<String> {
    let ok = !id.is_empty()
        && id.len() <= 64
        && id
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_');
    anyhow::ensure!(
        ok,
        "--run-id must be 1 to 64 letters, digits, '-' or '_' (got {id:?})"
    );
    Ok(id.to_string())
}

pub fn run(args: RunArgs) -> anyhow::Result<()> {
    let cfg = args.config()?;
    let out = args.out.clone().unwrap_or_else(|| {
        PathBuf::from("runs").join(format!(
            "{}-seed{}-trial{}",
            cfg.method.name(),
            cfg.seed,
            cfg.trial
        ))
    });
    if cfg.method == Approach::Qlearning {
        let pool = args.pool(&ProgressBar::hidden())?;
        return super::learning::learn(&cfg, &out, args.json, pool);
    }
    let bar = progress_bar(cfg.ga.max_generations);
    let mut evaluator = args.evaluator(&cfg, &bar)?;
    let mut log = GenerationLog::create(&out)?;
    let started = Instant::now();
    let result = run_trial(&cfg, evaluator.as_mut(), &mut |g: &Generation| {
        show(&bar, g);
        log.write(g)?;
        Ok(())
    })
    .context("the trial stopped")?;
    let wall_s = started.elapsed().as_secs_f64();
    bar.finish_and_clear();
    drop(evaluator);

    let best_path = out.join("best.json");
    write_json(&best_path, &BestRecord::new(&cfg, &result))?;
    let summary = Summary::new(&cfg, &result, wall_s);
    if args.json {
        println!("{}", serde_json::to_string(&summary)?);
    } else {
        println!(
            "{} trial {} (seed {}): {} after {} generations, {} restarts, {:.1}s; best fitness {:.1}",
            summary.id.method,
            summary.id.trial,
            summary.id.seed,
            if summary.id.landed { "landed" } else { "did not land" },
            summary.generations,
            summary.restarts,
            wall_s,
            summary.best_fitness
        );
        println!(
            "wrote {} and {}",
            out.join("generations.jsonl").display(),
            best_path.display()
        );
    }
    Ok(())
}

fn progress_bar(max_generations: u64) -> ProgressBar {
    let bar = ProgressBar::new(max_generations);
    let style = ProgressStyle::with_template(
        "{prefix} [{bar:30}] gen {pos}/{len} {msg} ({per_sec}, {elapsed})",
    )
    .unwrap_or_else(|_| ProgressStyle::default_bar())
    .progress_chars("=> ");
    bar.set_style(style);
    bar
}

fn show(bar: &ProgressBar, g: &Generation) {
    if g.generation == 1 {
        bar.reset();
        bar.set_prefix(format!("restart {}", g.restart));
    }
    bar.set_position(g.generation);
    bar.set_message(format!("best {:.1} mean {:.1}", g.best, g.mean));
}
