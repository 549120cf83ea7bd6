//! `lander run --method qlearning`: one Q(λ) trial, in-process with a
//! progress bar over episodes and a checkpoint every `--checkpoint-every`
//! episodes and when stopped, or as one `Train` job on a worker, written to
//! a folder. The worker holds the agent, so a trial on a worker is
//! checkpointed only at its start: resumed, it is flown again whole.

use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};
use lander_coordinator::checkpoint::{self, Checkpoint, Saved};
use lander_coordinator::config::RunConfig;
use lander_coordinator::evaluator::{Backend, EvalError};
use lander_coordinator::run_files::{write_json, RunLog, EPISODES};
use lander_coordinator::stop::Stop;
use lander_model::learn::{LearnRun, LearnState};
use lander_model::{StreamKey, TrainJob, Training};
use serde::Serialize;
use std::path::Path;
use std::time::Instant;

/// The summary of a Q-learning trial.
#[derive(Serialize)]
struct LearnSummary {
    method: &'static str,
    seed: u64,
    trial: u64,
    x0: f64,
    pad_x: f64,
    landed: bool,
    episodes: u32,
    /// The episode of the first safe landing, or null.
    first_safe_episode: Option<u32>,
    landing_rate_last_100: f64,
    wall_s: f64,
}

/// A Q(λ) trial from its start: in-process when `pool` is `None`,
/// checkpointed every `every` episodes (0: only when stopped), else as
/// one job on the pool.
pub fn learn(
    cfg: &RunConfig,
    out: &Path,
    json: bool,
    pool: Option<Box<dyn Backend>>,
    every: u64,
    stop: &Stop,
) -> anyhow::Result<()> {
    let key = StreamKey::new(cfg.seed, cfg.trial, 0, 0);
    let env = cfg.env(0);
    let started = Instant::now();
    let training = match pool {
        None => {
            let run = LearnRun::new(&env, &cfg.guided, &cfg.qlearning, key);
            let log = RunLog::create(out, EPISODES)?;
            in_process(cfg, out, run, log, every, stop)?
        }
        Some(pool) => {
            // The trial's start, so that `--resume` finds it after a kill.
            let start = LearnRun::new(&env, &cfg.guided, &cfg.qlearning, key).state();
            save(cfg, out, &start)?;
            on_a_worker(cfg, out, pool)?
        }
    };
    finish(cfg, out, json, &training, started)
}

fn save(cfg: &RunConfig, out: &Path, state: &LearnState) -> anyhow::Result<()> {
    checkpoint::save(
        out,
        &Checkpoint {
            config: cfg.clone(),
            state: Saved::Learning(state.clone()),
        },
    )?;
    Ok(())
}

/// `lander run --resume DIR` of a Q(λ) trial saved at `state`: its log cut
/// back to the checkpoint, and on in-process to the end; or whole on
/// `pool`, which the caller gives only for a trial saved at its start.
pub fn resume(
    cfg: &RunConfig,
    dir: &Path,
    json: bool,
    state: &LearnState,
    pool: Option<Box<dyn Backend>>,
    every: u64,
    stop: &Stop,
) -> anyhow::Result<()> {
    if let Some(pool) = pool {
        let started = Instant::now();
        let training = on_a_worker(cfg, dir, pool)?;
        return finish(cfg, dir, json, &training, started);
    }
    let key = StreamKey::new(cfg.seed, cfg.trial, 0, 0);
    let run =
        LearnRun::resume(&cfg.env(0), &cfg.guided, &cfg.qlearning, key, state).map_err(|e| {
            anyhow::anyhow!(
                "{}: the saved trial does not fit its configuration: {e}",
                dir.join(checkpoint::FILE).display()
            )
        })?;
    // A trial saved at its start (on a worker) may have no log yet.
    let log = match state.episodes {
        0 => RunLog::create(dir, EPISODES)?,
        n => RunLog::resume(dir, EPISODES, u64::from(n))?,
    };
    tracing::info!(
        "resuming {} after episode {}",
        dir.display(),
        state.episodes
    );
    let started = Instant::now();
    let training = in_process(cfg, dir, run, log, every, stop)?;
    finish(cfg, dir, json, &training, started)
}

/// Flies `run`'s remaining episodes here, logging each and saving a
/// checkpoint every `every` episodes and when stopped.
fn in_process(
    cfg: &RunConfig,
    out: &Path,
    mut run: LearnRun,
    mut log: RunLog,
    every: u64,
    stop: &Stop,
) -> anyhow::Result<Training> {
    let bar = bar(cfg);
    let save = |run: &LearnRun, log: &mut RunLog| -> anyhow::Result<()> {
        log.sync()?;
        save(cfg, out, &run.state())
    };
    bar.set_position(u64::from(run.training().episodes));
    while let Some(e) = run.step() {
        log.write(&e)?;
        bar.set_position(u64::from(e.episode));
        if e.safe || e.episode % 100 == 0 {
            let rate = run.training().landing_rate_last_100;
            bar.set_message(format!("landing rate over the last 100 {rate:.2}"));
        }
        if every > 0 && u64::from(e.episode) % every == 0 {
            save(&run, &mut log)?;
        }
        // The trial looks at `stop` after every episode, as a pool does
        // between its sleeps; between episodes the trial is whole.
        if stop.asked() && run.training().episodes < cfg.qlearning.episodes {
            bar.finish_and_clear();
            let hint = match save(&run, &mut log) {
                Ok(()) => format!(
                    "; saved after episode {}: `lander run --resume {}` goes on",
                    e.episode,
                    out.display()
                ),
                Err(e) => format!("; saving checkpoint.bin failed: {e:#}"),
            };
            return Err(anyhow::Error::new(EvalError::Interrupted)
                .context(format!("the trial stopped{hint}")));
        }
    }
    bar.finish_and_clear();
    log.sync()?;
    Ok(run.training())
}

/// The whole trial as one job on a worker; its episodes are logged when
/// it returns.
fn on_a_worker(
    cfg: &RunConfig,
    out: &Path,
    mut pool: Box<dyn Backend>,
) -> anyhow::Result<Training> {
    let job = TrainJob {
        env: cfg.env(0),
        guide: cfg.guided,
        learn: cfg.qlearning,
        key: StreamKey::new(cfg.seed, cfg.trial, 0, 0),
    };
    let bar = bar(cfg);
    let result = pool
        .train(&[job], &mut |_, _| ())
        .with_context(|| {
            format!(
                "the trial stopped; `lander run --resume {}` flies it again from its start",
                out.display()
            )
        })?
        .pop()
        .context("the pool returned no result for the trial")?;
    bar.finish_and_clear();
    let mut log = RunLog::create(out, EPISODES)?;
    for e in &result.episodes {
        log.write(e)?;
    }
    log.sync()?;
    Ok(result.training)
}

fn bar(cfg: &RunConfig) -> ProgressBar {
    let bar =
        lander_telemetry::log::bars().add(ProgressBar::new(u64::from(cfg.qlearning.episodes)));
    bar.set_style(
        ProgressStyle::with_template("qlearning [{bar:30}] episode {pos}/{len} {msg} ({per_sec})")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar
}

/// Writes the summary, removes the checkpoint of the finished run, and
/// reports.
fn finish(
    cfg: &RunConfig,
    out: &Path,
    json: bool,
    training: &Training,
    started: Instant,
) -> anyhow::Result<()> {
    let env = cfg.env(0);
    let summary = LearnSummary {
        method: cfg.method.name(),
        seed: cfg.seed,
        trial: cfg.trial,
        x0: env.x0,
        pad_x: env.pad_x,
        landed: training.first_safe.is_some(),
        episodes: training.episodes,
        first_safe_episode: training.first_safe,
        landing_rate_last_100: training.landing_rate_last_100,
        wall_s: started.elapsed().as_secs_f64(),
    };
    let summary_path = out.join("summary.json");
    write_json(&summary_path, &summary)?;
    // The run is over; nothing is left to resume.
    checkpoint::remove(out)?;
    if json {
        println!("{}", serde_json::to_string(&summary)?);
    } else {
        let first = summary
            .first_safe_episode
            .map_or("never landed".to_string(), |e| {
                format!("first landed in episode {e}")
            });
        println!(
            "qlearning trial {} (seed {}): {} episodes, {first}; landing rate over the last 100: {:.2}; {:.1}s",
            summary.trial, summary.seed, summary.episodes, summary.landing_rate_last_100, summary.wall_s
        );
        println!(
            "wrote {} and {}",
            out.join(EPISODES).display(),
            summary_path.display()
        );
    }
    Ok(())
}
