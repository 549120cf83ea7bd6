//! `lander run`: one trial, with a progress bar, written to a folder that
//! then holds that run's outputs and nothing of an earlier run's.

use super::transport::TransportArgs;
use super::watch::{trial_label, Watch};
use anyhow::{bail, Context};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use lander_coordinator::checkpoint::{self, CheckpointRef, Saved, SavedRef};
use lander_coordinator::config::RunConfig;
use lander_coordinator::evaluator::Backend;
use lander_coordinator::experiment::store::first_difference;
use lander_coordinator::folder_lock::FolderLock;
use lander_coordinator::run_files::{
    clear_run_outputs, refuse_others, write_json, BestRecord, Results, RunLog, RunSummary, BEST,
    GENERATIONS,
};
use lander_coordinator::stop::Stop;
use lander_coordinator::trial::{finish_trial, Generation, TrialRun};
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
    #[arg(long, value_parser = super::threads_parser())]
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
    /// Save the run to checkpoint.bin every N generations (qlearning: N
    /// episodes), and when stopped by SIGINT or SIGTERM; 0 saves only then
    /// [default: 500 generations, 100000 episodes].
    #[arg(long, value_name = "N")]
    checkpoint_every: Option<u64>,
    /// Go on with the run saved in DIR/checkpoint.bin, to the results an
    /// uninterrupted run would have had. Flags that change the
    /// configuration are refused unless they match the saved run's.
    #[arg(long, value_name = "DIR", conflicts_with = "out")]
    resume: Option<PathBuf>,
    /// Print one JSON summary object on stdout.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    transport: TransportArgs,
}

/// Generations between checkpoints unless told: one attempt at the
/// paper's cap. A checkpoint costs about a millisecond (its fsyncs), a
/// guided generation of 100 genomes about half of one on 2 cores, so this
/// costs about 0.5% of a run (docs/reliability.md).
const DEFAULT_CHECKPOINT_EVERY: u64 = 500;
/// Q(λ) episodes between checkpoints unless told. An episode takes about
/// 13 µs and a checkpoint of the agent's weights about 2.5 ms, so this
/// costs about 0.2% of a long trial (docs/reliability.md).
const DEFAULT_CHECKPOINT_EVERY_EPISODES: u64 = 100_000;

impl RunArgs {
    /// Generations, or Q(λ) episodes, between checkpoints.
    fn checkpoint_every(&self, method: Method) -> u64 {
        self.checkpoint_every.unwrap_or(match method {
            Method::Qlearning => DEFAULT_CHECKPOINT_EVERY_EPISODES,
            _ => DEFAULT_CHECKPOINT_EVERY,
        })
    }

    fn config(&self) -> anyhow::Result<RunConfig> {
        self.config_over(RunConfig::default())
    }

    /// The configuration: the --config file's, else `base`, with the flags
    /// given applied.
    fn config_over(&self, base: RunConfig) -> anyhow::Result<RunConfig> {
        let mut cfg = match &self.config {
            Some(path) => RunConfig::load(path)?,
            None => base,
        };
        cfg.method = self.method.unwrap_or(cfg.method);
        cfg.qlearning.episodes = self.episodes.unwrap_or(cfg.qlearning.episodes);
        cfg.seed = self.seed.unwrap_or(cfg.seed);
        cfg.trial = self.trial.unwrap_or(cfg.trial);
        cfg.threads = self.threads.unwrap_or(cfg.threads);
        cfg.ga.population = self.population.unwrap_or(cfg.ga.population);
        cfg.ga.max_generations = self.max_generations.unwrap_or(cfg.ga.max_generations);
        cfg.ga.max_restarts = self.max_restarts.unwrap_or(cfg.ga.max_restarts);
        self.check_method_flags(cfg.method)?;
        self.transport.check_threads(self.threads.is_some())?;
        cfg.validate()?;
        Ok(cfg)
    }

    /// Refuses the flags the trial's method would not use: taken in
    /// silence, they would be recorded in its configuration all the same.
    fn check_method_flags(&self, method: Method) -> anyhow::Result<()> {
        let learns = method == Method::Qlearning;
        for (given, flag) in [
            (self.population.is_some(), "--population"),
            (self.max_generations.is_some(), "--max-generations"),
            (self.max_restarts.is_some(), "--max-restarts"),
        ] {
            anyhow::ensure!(
                !(learns && given),
                "{flag} applies only to the GA methods (ga, guided), not to qlearning"
            );
        }
        anyhow::ensure!(
            !(learns && self.threads.is_some()),
            "--threads does not apply to qlearning, which learns on one thread"
        );
        anyhow::ensure!(
            learns || self.episodes.is_none(),
            "--episodes applies only to --method qlearning"
        );
        Ok(())
    }
}

pub fn run(args: RunArgs, stop: &Stop) -> anyhow::Result<()> {
    let watch = args.transport.watch()?;
    let result = match &args.resume {
        Some(dir) => resume(&args, dir, &watch, stop),
        None => start(&args, &watch, stop),
    };
    watch.end(&result, stop.asked());
    result
}

/// A fresh run, in a folder readied for it.
fn start(args: &RunArgs, watch: &Watch, stop: &Stop) -> anyhow::Result<()> {
    let cfg = args.config()?;
    let out = args.out.clone().unwrap_or_else(|| {
        PathBuf::from("runs").join(format!(
            "{}-seed{}-trial{}",
            cfg.method.name(),
            cfg.seed,
            cfg.trial
        ))
    });
    // A folder in use is refused before any worker is started.
    super::out_folder(&out)?;
    let held = FolderLock::hold_if_there(&out)?;
    if cfg.method == Method::Qlearning {
        let pool = args.transport.pool(&watch.telemetry, stop)?;
        let every = args.checkpoint_every(cfg.method);
        super::learning::can_start(&cfg, pool.as_deref(), every)?;
        watch.keep(Some(prepare(&out, held)?));
        watch.begin(&out, "run")?;
        return counted(watch, &cfg, || {
            super::learning::learn(&cfg, &out, args.json, pool, every, stop)
        });
    }
    let bar = progress_bar(cfg.ga.max_generations);
    let evaluator = args
        .transport
        .evaluator(cfg.threads, &watch.telemetry, stop)?;
    watch.keep(Some(prepare(&out, held)?));
    watch.begin(&out, "run")?;
    let log = RunLog::create(&out, GENERATIONS)?;
    let run = TrialRun::new(&cfg)?;
    counted(watch, &cfg, || {
        evolve(args, &cfg, &out, run, log, evaluator, bar, watch)
    })
}

/// `lander run --resume DIR`: the saved run, checked against the flags,
/// its log cut back to the checkpoint, and on to the end.
fn resume(args: &RunArgs, dir: &Path, watch: &Watch, stop: &Stop) -> anyhow::Result<()> {
    // Held before the checkpoint is read: another command may be writing it.
    watch.keep(FolderLock::hold_if_there(dir)?);
    nothing_to_resume(dir)?;
    let saved = checkpoint::load(dir)?;
    // Threads aside: they change no result, and the flags may set them.
    RunConfig {
        threads: 0,
        ..saved.config.clone()
    }
    .validate()
    .with_context(|| dir.join(checkpoint::FILE).display().to_string())?;
    let cfg = args.config_over(saved.config.clone())?;
    if let Some(field) = differs(&saved.config, &cfg) {
        bail!(
            "{}: the saved run's {field} differs from this command's; \
             resume it without flags that change its configuration",
            dir.join(checkpoint::FILE).display()
        );
    }
    let state = match saved.state {
        Saved::Evolving(state) => state,
        Saved::Learning(state) => {
            let pool = args.transport.pool(&watch.telemetry, stop)?;
            let every = args.checkpoint_every(cfg.method);
            let trial = super::learning::resumable(&cfg, dir, state, pool, every)?;
            watch.begin(dir, "run --resume")?;
            return counted(watch, &cfg, || {
                super::learning::resume(&cfg, dir, args.json, trial, every, stop)
            });
        }
    };
    let index = state.index;
    let run = TrialRun::resume(&cfg, state)
        .with_context(|| dir.join(checkpoint::FILE).display().to_string())?;
    let bar = progress_bar(cfg.ga.max_generations);
    let evaluator = args
        .transport
        .evaluator(cfg.threads, &watch.telemetry, stop)?;
    let log = RunLog::resume(dir, GENERATIONS, index)?;
    watch.begin(dir, "run --resume")?;
    tracing::info!("resuming {} after generation {index}", dir.display());
    counted(watch, &cfg, || {
        evolve(args, &cfg, dir, run, log, evaluator, bar, watch)
    })
}

/// Says why a folder without a checkpoint has no run to resume, where its
/// files tell: another command's results, or a run that finished.
/// Otherwise reading the checkpoint says.
fn nothing_to_resume(dir: &Path) -> anyhow::Result<()> {
    if dir.join(checkpoint::FILE).exists() {
        return Ok(());
    }
    if let Err(theirs) = refuse_others(dir, Results::Run) {
        let command = match theirs.theirs {
            Results::Sweep => "sweep",
            _ => "experiment",
        };
        bail!(
            "{} holds {}'s results ({}), not a run's; `lander {command} FILE --resume --out {}` \
             finishes it",
            dir.display(),
            theirs.theirs.what(),
            theirs.file,
            dir.display()
        );
    }
    if let Some(file) = [BEST, "summary.json"].iter().find(|f| dir.join(f).exists()) {
        bail!(
            "{}: the run there finished (it wrote {file} and left no {}); there is nothing to \
             resume",
            dir.display(),
            checkpoint::FILE
        );
    }
    Ok(())
}

/// The first field where two configurations differ, thread counts aside
/// (they change no result).
fn differs(saved: &RunConfig, now: &RunConfig) -> Option<String> {
    let plain = |c: &RunConfig| {
        let mut c = c.clone();
        c.threads = 0;
        serde_json::to_value(c).unwrap_or_default()
    };
    first_difference(&plain(saved), &plain(now), "")
}

/// Runs `trial`, the run's one trial of any method, counted in the metrics
/// as started and, when it succeeds, finished.
fn counted(
    watch: &Watch,
    cfg: &RunConfig,
    trial: impl FnOnce() -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let metrics = watch.telemetry.metrics();
    let label = trial_label(None, cfg);
    if let Some(m) = metrics {
        m.trial_started(&label);
    }
    trial()?;
    if let Some(m) = metrics {
        m.trial_finished(&label);
    }
    Ok(())
}

/// Flies `run` to its end, logging every generation and saving a
/// checkpoint every `--checkpoint-every` generations and when stopped;
/// then writes the best lander and the summary.
#[allow(clippy::too_many_arguments)]
fn evolve(
    args: &RunArgs,
    cfg: &RunConfig,
    out: &Path,
    mut run: TrialRun,
    mut log: RunLog,
    mut evaluator: Box<dyn Backend>,
    bar: ProgressBar,
    watch: &Watch,
) -> anyhow::Result<()> {
    let metrics = watch.telemetry.metrics();
    let label = trial_label(None, cfg);
    let every = args.checkpoint_every(cfg.method);
    let save = |run: &TrialRun, log: &mut RunLog| -> anyhow::Result<()> {
        let Some(state) = run.state() else {
            return Ok(());
        };
        log.sync()?;
        checkpoint::save(
            out,
            &CheckpointRef {
                config: cfg,
                state: SavedRef::Evolving(&state),
            },
        )?;
        Ok(())
    };
    let started = Instant::now();
    // The trial runs on an evaluation thread, where there is one: see
    // `Evaluator::drive`.
    let mut outcome = None;
    evaluator.drive(&mut |evaluator| {
        outcome = Some(finish_trial(&mut run, evaluator, &mut |g, run| {
            show(&bar, g);
            if let Some(m) = metrics {
                m.generation(&label, g.best, g.mean, g.evaluated);
            }
            log.write(g)?;
            if every > 0 && g.index % every == 0 {
                save(run, &mut log)?;
            }
            Ok(())
        }));
    });
    let Some(outcome) = outcome else {
        bail!("the evaluator never ran the trial");
    };
    let result = match outcome {
        Ok(result) => result,
        Err(e) => {
            // Between generations the run is whole: save it, whatever
            // stopped it.
            bar.finish_and_clear();
            drop(evaluator);
            let saved = save(&run, &mut log);
            let hint = match (&saved, run.state()) {
                (Ok(()), Some(state)) => format!(
                    "; saved after generation {}: `lander run --resume {}` goes on",
                    state.index,
                    out.display()
                ),
                // Stopped by the save itself (a full disk): said once.
                (Err(failed), _) if format!("{failed:#}") == e.to_string() => {
                    "; nor could it be saved".into()
                }
                (Err(failed), _) => format!("; saving checkpoint.bin failed too ({failed:#})"),
                _ => String::new(),
            };
            return Err(anyhow::Error::new(e).context(format!("the trial stopped{hint}")));
        }
    };
    let wall_s = started.elapsed().as_secs_f64();
    bar.finish_and_clear();
    log.finish()?;
    let best_path = out.join(BEST);
    write_json(&best_path, &BestRecord::new(cfg, &result))?;
    // The run is over; nothing is left to resume. Its workers are told so
    // only now: until then a failed write leaves the checkpoint to resume.
    checkpoint::remove(out)?;
    evaluator.run_over();
    drop(evaluator);
    let summary = RunSummary::new(cfg, &result, wall_s);
    if args.json {
        outln!("{}", serde_json::to_string(&summary)?)?;
    } else {
        outln!(
            "{} trial {} (seed {}): {} after {} generations, {} restarts, {:.1}s; best fitness {:.1}",
            summary.id.method,
            summary.id.trial,
            summary.id.seed,
            if summary.id.landed { "landed" } else { "did not land" },
            summary.generations,
            summary.restarts,
            wall_s,
            summary.best_fitness
        )?;
        outln!(
            "wrote {} and {}",
            out.join("generations.jsonl").display(),
            best_path.display()
        )?;
    }
    Ok(())
}

/// Readies `out` (a folder, if it is there: `out_folder`) for this run,
/// once the configuration and the workers are known to be good, so a run
/// that cannot start leaves an earlier run's results alone, and holds it
/// for the run ([`FolderLock`]; `held`, where it was there to hold
/// already). An experiment's or a sweep's folder is refused: their tables
/// share names with a run's files (`generations.jsonl`, `summary.json`).
fn prepare(out: &Path, held: Option<FolderLock>) -> anyhow::Result<FolderLock> {
    // Made (empty) and held before it is looked at, so that no other
    // command fills it between the look and the writes.
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let held = match held {
        Some(held) => held,
        None => FolderLock::hold(out)?,
    };
    refuse_others(out, Results::Run)?;
    if out.join(checkpoint::FILE).exists() {
        bail!(
            "{} holds an unfinished run (checkpoint.bin); `lander run --resume {}` finishes it, \
             or give this run another --out",
            out.display(),
            out.display()
        );
    }
    let removed = clear_run_outputs(out)?;
    if !removed.is_empty() {
        tracing::info!(
            "removed an earlier run's {} from {}",
            removed.join(", "),
            out.display()
        );
    }
    Ok(held)
}

fn progress_bar(max_generations: u64) -> ProgressBar {
    let bar = lander_telemetry::log::bars().add(ProgressBar::new(max_generations));
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
