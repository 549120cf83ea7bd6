//! `lander run`: one trial, with a progress bar, written to a folder that
//! then holds that run's outputs and nothing of an earlier run's.

use super::transport::TransportArgs;
use anyhow::{bail, Context};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use lander_coordinator::config::RunConfig;
use lander_coordinator::run_files::{
    clear_run_outputs, write_json, BestRecord, GenerationLog, RunSummary,
};
use lander_coordinator::stop::Stop;
use lander_coordinator::trial::{run_trial, Generation};
use lander_model::Method;
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Args, Debug)]
pub struct RunArgs {
    /// A TOML run configuration; flags given here override it.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// `ga` (the general GA), `guided` (with the evolve pass) or
    /// `qlearning` (the Q(λ) baseline).
    #[arg(long, value_parser = super::method_parser(&Method::ALL))]
    method: Option<Method>,
    /// Q-learning episodes per trial (SPEC: 5000).
    #[arg(long)]
    episodes: Option<u32>,
    /// The run's seed; every random draw of the trial comes from it [default: 1].
    #[arg(long)]
    seed: Option<u64>,
    /// Trial number; `x0` and `pad_x` come from (seed, trial).
    #[arg(long)]
    trial: Option<u64>,
    /// Genomes per generation [default: 100].
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
    /// Output folder [default: runs/<method>-seed<seed>-trial<trial>]. An
    /// earlier run's outputs in it are replaced.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Print one JSON summary object on stdout.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    transport: TransportArgs,
}

impl RunArgs {
    fn config(&self) -> anyhow::Result<RunConfig> {
        let mut cfg = match &self.config {
            Some(path) => RunConfig::load(path)?,
            None => RunConfig::default(),
        };
        cfg.method = self.method.unwrap_or(cfg.method);
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

pub fn run(args: RunArgs, stop: &Stop) -> anyhow::Result<()> {
    let cfg = args.config()?;
    let out = args.out.clone().unwrap_or_else(|| {
        PathBuf::from("runs").join(format!(
            "{}-seed{}-trial{}",
            cfg.method.name(),
            cfg.seed,
            cfg.trial
        ))
    });
    if cfg.method == Method::Qlearning {
        let pool = args.transport.pool(&ProgressBar::hidden(), stop)?;
        prepare(&out)?;
        return super::learning::learn(&cfg, &out, args.json, pool, stop);
    }
    let bar = progress_bar(cfg.ga.max_generations);
    let mut evaluator = args.transport.evaluator(cfg.threads, &bar, stop)?;
    prepare(&out)?;
    let mut log = GenerationLog::create(&out)?;
    let started = Instant::now();
    // The trial runs on an evaluation thread, where there is one: see
    // `Evaluator::drive`.
    let mut outcome = None;
    evaluator.drive(&mut |evaluator| {
        outcome = Some(run_trial(&cfg, evaluator, &mut |g: &Generation| {
            show(&bar, g);
            log.write(g)?;
            Ok(())
        }));
    });
    let Some(outcome) = outcome else {
        anyhow::bail!("the evaluator never ran the trial");
    };
    let result = outcome.context("the trial stopped")?;
    let wall_s = started.elapsed().as_secs_f64();
    bar.finish_and_clear();
    drop(evaluator);

    let best_path = out.join("best.json");
    write_json(&best_path, &BestRecord::new(&cfg, &result))?;
    let summary = RunSummary::new(&cfg, &result, wall_s);
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

/// Readies `out` for this run, once the configuration and the workers are
/// known to be good, so a run that cannot start leaves an earlier run's
/// results alone. An experiment's folder is refused: its tables share
/// names with a run's files (`generations.jsonl`, `summary.json`).
fn prepare(out: &Path) -> anyhow::Result<()> {
    if out.join("experiment.json").exists() {
        bail!(
            "{} holds an experiment (experiment.json); give the run another --out",
            out.display()
        );
    }
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let removed = clear_run_outputs(out)?;
    if !removed.is_empty() {
        eprintln!(
            "note: removed an earlier run's {} from {}",
            removed.join(", "),
            out.display()
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
