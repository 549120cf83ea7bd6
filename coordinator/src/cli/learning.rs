//! `lander run --method qlearning`: one Q(λ) trial, written to a folder.
//! In-process it flies with a progress bar over episodes and a checkpoint
//! every `--checkpoint-every` episodes and when stopped. On workers it
//! flies in legs of `--checkpoint-every` episodes, each one job that
//! carries the trial's state to a worker and brings it back, checkpointed
//! between legs; a trial stopped mid-leg resumes from the leg's start.

use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};
use lander_coordinator::checkpoint::{self, CheckpointRef, SavedRef};
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

/// A Q(λ) trial from its start: in-process when `pool` is `None`, else
/// in legs on the pool; checkpointed every `every` episodes (0: in-process
/// only when stopped, on the pool at its start alone).
pub fn learn(
    cfg: &RunConfig,
    out: &Path,
    json: bool,
    pool: Option<Box<dyn Backend>>,
    every: u64,
    stop: &Stop,
) -> anyhow::Result<()> {
    let run = LearnRun::new(&cfg.env(0), &cfg.guided, &cfg.qlearning, key(cfg));
    let log = RunLog::create(out, EPISODES)?;
    let started = Instant::now();
    let (training, pool) = match pool {
        None => (in_process(cfg, out, run, log, every, stop)?, None),
        Some(pool) => {
            // The trial's start, so that `--resume` finds it after a kill
            // during the first leg.
            let start = run.state();
            // Its agent, every weight of it, is not needed on workers.
            drop(run);
            save(cfg, out, &start)?;
            let next = leg(cfg, Some(start), every);
            let (training, pool) = on_workers(cfg, out, next, log, pool, every)?;
            (training, Some(pool))
        }
    };
    finish(cfg, out, json, &training, started)?;
    over(pool);
    Ok(())
}

/// Tells the workers, if any, that the run is over, once its files are
/// whole: until then a failed write leaves the checkpoint to resume.
fn over(pool: Option<Box<dyn Backend>>) {
    if let Some(mut pool) = pool {
        pool.run_over();
    }
}

fn key(cfg: &RunConfig) -> StreamKey {
    StreamKey::new(cfg.seed, cfg.trial, 0, 0)
}

fn save(cfg: &RunConfig, out: &Path, state: &LearnState) -> anyhow::Result<()> {
    checkpoint::save(
        out,
        &CheckpointRef {
            config: cfg,
            state: SavedRef::Learning(state),
        },
    )?;
    Ok(())
}

/// A saved Q(λ) trial ready to go on: its run here, or its next leg and
/// the pool to fly it.
// Made once by a command, and moved twice: boxing the larger variant
// would save nothing.
#[allow(clippy::large_enum_variant)]
pub enum Resumable {
    Here(LearnRun),
    OnWorkers(TrainJob, Box<dyn Backend>),
}

/// The trial saved in `dir` at `state`, ready to go on in-process (`pool`
/// `None`) or on `pool`: refused, naming the checkpoint, if it does not
/// fit its configuration, or if `pool` could not train its next leg;
/// asked before the run's folder is touched.
pub fn resumable(
    cfg: &RunConfig,
    dir: &Path,
    state: LearnState,
    pool: Option<Box<dyn Backend>>,
    every: u64,
) -> anyhow::Result<Resumable> {
    let unfit = |e: String| {
        anyhow::anyhow!(
            "{}: the saved trial does not fit its configuration: {e}",
            dir.join(checkpoint::FILE).display()
        )
    };
    let Some(pool) = pool else {
        let run = LearnRun::resume(&cfg.env(0), &cfg.guided, &cfg.qlearning, key(cfg), &state);
        return run.map(Resumable::Here).map_err(unfit);
    };
    // Checked here: a worker would refuse it less clearly. The state goes
    // into the leg as it is, not copied: it may hold millions of weights.
    state.check(&cfg.qlearning).map_err(unfit)?;
    let next = leg(cfg, Some(state), every);
    pool.can_train(std::slice::from_ref(&next))?;
    Ok(Resumable::OnWorkers(next, pool))
}

/// `lander run --resume DIR` of a Q(λ) trial ([`resumable`]): its log cut
/// back to the checkpoint, and on to the end, in-process or in legs on a
/// pool.
pub fn resume(
    cfg: &RunConfig,
    dir: &Path,
    json: bool,
    trial: Resumable,
    every: u64,
    stop: &Stop,
) -> anyhow::Result<()> {
    let episodes = match &trial {
        Resumable::Here(run) => run.training().episodes,
        Resumable::OnWorkers(next, _) => next.start(),
    };
    // A trial saved at its start (on workers) may have no log yet.
    let log = match episodes {
        0 => RunLog::create(dir, EPISODES)?,
        n => RunLog::resume(dir, EPISODES, u64::from(n))?,
    };
    tracing::info!("resuming {} after episode {episodes}", dir.display());
    let started = Instant::now();
    let (training, pool) = match trial {
        Resumable::Here(run) => (in_process(cfg, dir, run, log, every, stop)?, None),
        Resumable::OnWorkers(next, pool) => {
            let (training, pool) = on_workers(cfg, dir, next, log, pool, every)?;
            (training, Some(pool))
        }
    };
    finish(cfg, dir, json, &training, started)?;
    over(pool);
    Ok(())
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

/// The trial's episodes from leg `next` on, in legs on the pool that end
/// at multiples of `every` (one leg to the end for 0): each leg's episodes
/// are logged and the trial's state saved when the leg returns. Gives the
/// pool back with the trial, for [`over`].
fn on_workers(
    cfg: &RunConfig,
    out: &Path,
    next: TrainJob,
    mut log: RunLog,
    mut pool: Box<dyn Backend>,
    every: u64,
) -> anyhow::Result<(Training, Box<dyn Backend>)> {
    let bar = bar(cfg);
    let mut job = next;
    loop {
        let start = job.start();
        bar.set_position(u64::from(start));
        // Refused before it starts, a leg leaves nothing to resume.
        pool.can_train(std::slice::from_ref(&job))?;
        let result = pool
            .train(std::slice::from_ref(&job), &mut |_, _| ())
            .with_context(|| {
                format!(
                    "the trial stopped; `lander run --resume {}` goes on after episode {start}",
                    out.display()
                )
            })?
            .pop()
            .context("the pool returned no result for the trial")?;
        for e in &result.episodes {
            log.write(e)?;
        }
        log.sync()?;
        match result.state {
            Some(state) => {
                save(cfg, out, &state)?;
                job = leg(cfg, Some(state), every);
            }
            None => {
                bar.finish_and_clear();
                return Ok((result.training, pool));
            }
        }
    }
}

/// Refuses a trial whose first leg `pool` could not train, such as one
/// whose state cannot travel: asked before the run's folder is touched,
/// so that a refused run leaves nothing behind to resume or to clear.
pub fn can_start(cfg: &RunConfig, pool: Option<&dyn Backend>, every: u64) -> anyhow::Result<()> {
    if let Some(pool) = pool {
        pool.can_train(std::slice::from_ref(&leg(cfg, None, every)))?;
    }
    Ok(())
}

/// The trial's leg from `from` (its start, where `None`), as it goes to
/// the pool: to the next checkpoint ([`leg_end`]).
fn leg(cfg: &RunConfig, from: Option<LearnState>, every: u64) -> TrainJob {
    let episodes = cfg.qlearning.episodes;
    TrainJob::whole(cfg.env(0), cfg.guided, cfg.qlearning, key(cfg))
        .leg(from, |start| leg_end(start, every, episodes))
}

/// Where a leg from episode `start` ends: at the next multiple of `every`
/// (at the trial's end for 0), and never past the trial's `episodes`.
fn leg_end(start: u32, every: u64, episodes: u32) -> u32 {
    if every == 0 {
        return episodes;
    }
    let next = (u64::from(start) / every + 1) * every;
    next.min(u64::from(episodes)) as u32
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
        outln!("{}", serde_json::to_string(&summary)?)?;
    } else {
        let first = summary
            .first_safe_episode
            .map_or("never landed".to_string(), |e| {
                format!("first landed in episode {e}")
            });
        outln!(
            "qlearning trial {} (seed {}): {} episodes, {first}; landing rate over the last 100: {:.2}; {:.1}s",
            summary.trial, summary.seed, summary.episodes, summary.landing_rate_last_100, summary.wall_s
        )?;
        outln!(
            "wrote {} and {}",
            out.join(EPISODES).display(),
            summary_path.display()
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn legs_end_at_the_checkpoints_and_the_trial() {
        use super::leg_end;
        assert_eq!(leg_end(0, 2000, 5000), 2000);
        assert_eq!(leg_end(2000, 2000, 5000), 4000);
        assert_eq!(leg_end(4000, 2000, 5000), 5000);
        // From a checkpoint taken when stopped, to the next multiple.
        assert_eq!(leg_end(2137, 2000, 60_000), 4000);
        assert_eq!(leg_end(0, 0, 5000), 5000);
        assert_eq!(leg_end(0, 100_000, 5000), 5000);
    }
}
