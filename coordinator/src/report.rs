//! What a run writes: `generations.jsonl` as it goes, then `best.json`, and
//! the one-object JSON summary printed by `lander run --json`; and the list
//! of every file a run owns in its folder, so a new run can clear them.

use crate::config::RunConfig;
use crate::trial::{Generation, TrialResult};
use lander_protocol::format_genome;
use lander_worker::Outcome;
use serde::Serialize;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Which trial a record is about, and whether it landed: the fields every
/// record of a trial starts with.
#[derive(Debug, Serialize)]
pub struct TrialId {
    pub method: &'static str,
    pub seed: u64,
    pub trial: u64,
    pub x0: f64,
    pub pad_x: f64,
    pub landed: bool,
}

impl TrialId {
    pub fn new(cfg: &RunConfig, result: &TrialResult) -> TrialId {
        TrialId {
            method: cfg.method.name(),
            seed: cfg.seed,
            trial: cfg.trial,
            x0: result.x0,
            pad_x: result.pad_x,
            landed: result.landed,
        }
    }
}

/// The summary of one trial; the field order is the documented one.
#[derive(Debug, Serialize)]
pub struct Summary {
    #[serde(flatten)]
    pub id: TrialId,
    pub generations: u64,
    pub restarts: u64,
    pub best_fitness: f64,
    pub best_genome: String,
    pub wall_s: f64,
}

impl Summary {
    pub fn new(cfg: &RunConfig, result: &TrialResult, wall_s: f64) -> Summary {
        Summary {
            id: TrialId::new(cfg, result),
            generations: result.generations,
            restarts: result.restarts,
            best_fitness: result.best.outcome.fitness,
            best_genome: format_genome(&result.best.genome),
            wall_s,
        }
    }
}

/// `best.json`: the best individual of the last attempt, its flight, and
/// the configuration the trial ran with.
#[derive(Debug, Serialize)]
pub struct BestRecord<'a> {
    #[serde(flatten)]
    pub id: TrialId,
    /// The generation, counted across restarts, that flew it.
    pub generation: u64,
    pub restart: u64,
    pub genome: String,
    pub outcome: &'a Outcome,
    /// The whole configuration, not just the world: `lander replay --run`
    /// must fly the genome under the same world and scoring, and parse it
    /// with the same `ga.max_duration`, without the user passing --config
    /// again.
    pub config: &'a RunConfig,
}

impl<'a> BestRecord<'a> {
    pub fn new(cfg: &'a RunConfig, result: &'a TrialResult) -> BestRecord<'a> {
        BestRecord {
            id: TrialId::new(cfg, result),
            generation: result.best.index,
            restart: result.restarts,
            genome: format_genome(&result.best.genome),
            outcome: &result.best.outcome,
            config: cfg,
        }
    }
}

/// Every file `lander run` writes into its folder, for any method: the
/// GA's log and best lander, Q(λ)'s episodes and summary.
pub const RUN_OUTPUTS: [&str; 4] = [
    "generations.jsonl",
    "best.json",
    "episodes.jsonl",
    "summary.json",
];

/// Removes the [`RUN_OUTPUTS`] an earlier run left in `dir` and returns
/// their names. A run rewrites only some of them, and an interrupted run
/// none, so without this a folder could pair one run's log with another
/// run's best lander, and a replay would draw the stale one.
pub fn clear_run_outputs(dir: &Path) -> Result<Vec<&'static str>, WriteError> {
    let mut removed = Vec::new();
    for name in RUN_OUTPUTS {
        let path = dir.join(name);
        match std::fs::remove_file(&path) {
            Ok(()) => removed.push(name),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(at(&path)(e)),
        }
    }
    Ok(removed)
}

#[derive(Debug, thiserror::Error)]
#[error("{path}: {source}")]
pub struct WriteError {
    pub path: PathBuf,
    pub source: std::io::Error,
}

fn at(path: &Path) -> impl Fn(std::io::Error) -> WriteError + '_ {
    move |source| WriteError {
        path: path.to_path_buf(),
        source,
    }
}

/// Appends one JSON line per generation, flushed as each arrives so an
/// interrupted run keeps what it flew.
pub struct GenerationLog {
    path: PathBuf,
    out: BufWriter<File>,
}

impl GenerationLog {
    pub fn create(dir: &Path) -> Result<GenerationLog, WriteError> {
        std::fs::create_dir_all(dir).map_err(at(dir))?;
        let path = dir.join("generations.jsonl");
        let file = File::create(&path).map_err(at(&path))?;
        Ok(GenerationLog {
            out: BufWriter::new(file),
            path,
        })
    }

    pub fn write(&mut self, g: &Generation) -> Result<(), WriteError> {
        serde_json::to_writer(&mut self.out, g).map_err(|e| at(&self.path)(e.into()))?;
        self.out.write_all(b"\n").map_err(at(&self.path))?;
        self.out.flush().map_err(at(&self.path))
    }
}

/// Writes `value` as pretty JSON to `path`, via a temporary file and a
/// rename so a reader never sees half a file.
pub fn write_json(path: &Path, value: &impl Serialize) -> Result<(), WriteError> {
    let tmp = path.with_extension("json.tmp");
    let mut text = serde_json::to_string_pretty(value).map_err(|e| at(path)(e.into()))?;
    text.push('\n');
    std::fs::write(&tmp, text).map_err(at(&tmp))?;
    std::fs::rename(&tmp, path).map_err(at(path))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clearing_removes_only_a_runs_own_files() {
        let dir = std::env::temp_dir().join(format!("lander-clear-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for name in ["best.json", "summary.json", "notes.txt"] {
            std::fs::write(dir.join(name), "x").unwrap();
        }
        let removed = clear_run_outputs(&dir).unwrap();
        assert_eq!(removed, ["best.json", "summary.json"]);
        assert!(!dir.join("best.json").exists());
        assert!(dir.join("notes.txt").exists(), "not a run's file");
        assert!(clear_run_outputs(&dir).unwrap().is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
