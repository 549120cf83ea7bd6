//! What a run writes: `generations.jsonl` as it goes, then `best.json`, and
//! the one-object JSON summary printed by `lander run --json`.

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

/// `best.json`: the best individual of the last attempt and its flight.
#[derive(Debug, Serialize)]
pub struct BestRecord<'a> {
    #[serde(flatten)]
    pub id: TrialId,
    /// The generation, counted across restarts, that flew it.
    pub generation: u64,
    pub restart: u64,
    pub genome: String,
    pub outcome: &'a Outcome,
}

impl<'a> BestRecord<'a> {
    pub fn new(cfg: &RunConfig, result: &'a TrialResult) -> BestRecord<'a> {
        BestRecord {
            id: TrialId::new(cfg, result),
            generation: result.best.index,
            restart: result.restarts,
            genome: format_genome(&result.best.genome),
            outcome: &result.best.outcome,
        }
    }
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
