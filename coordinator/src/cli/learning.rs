//! `lander run --method qlearning`: one Q(λ) trial, in-process with a
//! progress bar over episodes, or as one `Train` job on a worker, written
//! to a folder.

use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};
use lander_coordinator::config::RunConfig;
use lander_coordinator::evaluator::{Backend, EvalError};
use lander_coordinator::run_files::write_json;
use lander_coordinator::stop::Stop;
use lander_model::learn::train;
use lander_model::EpisodeRecord;
use lander_model::StreamKey;
use lander_model::TrainJob;
use serde::Serialize;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::ops::ControlFlow;
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

pub fn learn(
    cfg: &RunConfig,
    out: &Path,
    json: bool,
    pool: Option<Box<dyn Backend>>,
    stop: &Stop,
) -> anyhow::Result<()> {
    let env = cfg.env(0);
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let log_path = out.join("episodes.jsonl");
    let mut log = BufWriter::new(
        File::create(&log_path).with_context(|| format!("creating {}", log_path.display()))?,
    );
    let bar =
        lander_telemetry::log::bars().add(ProgressBar::new(u64::from(cfg.qlearning.episodes)));
    bar.set_style(
        ProgressStyle::with_template("qlearning [{bar:30}] episode {pos}/{len} {msg} ({per_sec})")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    let started = Instant::now();
    let key = StreamKey::new(cfg.seed, cfg.trial, 0, 0);
    let mut landings = 0u32;
    let mut failure = None;
    let mut record = |e: &EpisodeRecord| {
        landings += u32::from(e.safe);
        bar.set_position(u64::from(e.episode));
        bar.set_message(format!("landings {landings}"));
        let line = serde_json::to_string(e).map(|l| l + "\n");
        if let Err(err) = line
            .map_err(std::io::Error::from)
            .and_then(|l| log.write_all(l.as_bytes()))
        {
            failure.get_or_insert(err);
        }
    };
    let training = match pool {
        None => {
            // In-process, the trial looks at `stop` after every episode, as
            // a pool does between its sleeps.
            let mut until_stopped = |e: &EpisodeRecord| {
                record(e);
                if stop.asked() {
                    ControlFlow::Break(())
                } else {
                    ControlFlow::Continue(())
                }
            };
            let training = train(&env, &cfg.guided, &cfg.qlearning, key, &mut until_stopped);
            if training.episodes < cfg.qlearning.episodes {
                return Err(EvalError::Interrupted.into());
            }
            training
        }
        Some(mut pool) => {
            let job = TrainJob {
                env,
                guide: cfg.guided,
                learn: cfg.qlearning,
                key,
            };
            let result = pool
                .train(&[job], &mut |_, _| ())?
                .pop()
                .context("the pool returned no result for the trial")?;
            result.episodes.iter().for_each(&mut record);
            result.training
        }
    };
    bar.finish_and_clear();
    if let Some(err) = failure {
        return Err(err).with_context(|| format!("writing {}", log_path.display()));
    }
    log.flush()
        .with_context(|| format!("writing {}", log_path.display()))?;
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
            log_path.display(),
            summary_path.display()
        );
    }
    Ok(())
}
