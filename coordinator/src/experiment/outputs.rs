//! What a finished experiment leaves in its folder, all derived from the
//! trial records: `trials.csv`, `generations.jsonl`, `summary.json`,
//! `summary.md`, the plots as SVG and PNG, and `report.html`.

use super::file::Experiment;
use crate::recording::best_landing;
use lander_model::Method;
use lander_report::model::TrialRecord;
use lander_report::page::{report_html, Figure};
use lander_report::plots::{fitness_per_generation, generations_per_trial, learning_curve, Plot};
use lander_report::summary::Summary;
use serde::Serialize;
use std::io::Write;
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
#[error("{path}: {message}")]
pub struct OutputError {
    pub path: PathBuf,
    pub message: String,
}

fn fail(path: &Path) -> impl Fn(String) -> OutputError + '_ {
    move |message| OutputError {
        path: path.to_path_buf(),
        message,
    }
}

/// Writes `bytes` to `dir/name` through a temporary file and a rename.
pub fn write(dir: &Path, name: &str, bytes: &[u8]) -> Result<PathBuf, OutputError> {
    let path = dir.join(name);
    let tmp = dir.join(format!(".{name}.tmp"));
    std::fs::write(&tmp, bytes).map_err(|e| fail(&tmp)(e.to_string()))?;
    std::fs::rename(&tmp, &path).map_err(|e| fail(&path)(e.to_string()))?;
    Ok(path)
}

/// Writes a plot as `dir/stem.svg` and `dir/stem.png`.
pub fn write_plot(dir: &Path, stem: &str, plot: &Plot) -> Result<(), OutputError> {
    write(dir, &format!("{stem}.svg"), plot.svg.as_bytes())?;
    write(dir, &format!("{stem}.png"), &plot.png)?;
    Ok(())
}

/// One row of `trials.csv`; a column that does not apply to a method is
/// empty.
#[derive(Serialize)]
struct Row<'a> {
    method: &'a str,
    trial: u64,
    seed: u64,
    x0: f64,
    pad_x: f64,
    landed: bool,
    generations: Option<u64>,
    restarts: Option<u64>,
    /// Q-learning: the episode of the first safe landing.
    episodes: Option<u32>,
    /// Q-learning: the landing rate over the last 100 episodes.
    final_landing_rate: Option<f64>,
    wall_s: f64,
}

/// One line of `generations.jsonl`.
#[derive(Serialize)]
struct GenerationLine<'a> {
    method: &'a str,
    trial: u64,
    index: u64,
    restart: u64,
    best: f64,
    mean: f64,
}

/// The records in a stable order: by trial, then method as the file lists
/// them.
pub fn ordered(exp: &Experiment, mut records: Vec<TrialRecord>) -> Vec<TrialRecord> {
    let rank = |r: &TrialRecord| {
        let m = exp.methods.iter().position(|&m| m == r.method);
        (r.trial, m.unwrap_or(usize::MAX))
    };
    records.sort_by_key(rank);
    records
}

fn csv_text(records: &[TrialRecord]) -> Result<Vec<u8>, String> {
    let mut out = csv::Writer::from_writer(Vec::new());
    for r in records {
        out.serialize(Row {
            method: r.method.name(),
            trial: r.trial,
            seed: r.seed,
            x0: r.x0,
            pad_x: r.pad_x,
            landed: r.landed,
            generations: r.generations,
            restarts: r.restarts,
            episodes: r.episodes,
            final_landing_rate: r.learning.as_ref().map(|l| l.landing_rate_last_100),
            wall_s: r.wall_s,
        })
        .map_err(|e| e.to_string())?;
    }
    out.into_inner().map_err(|e| e.to_string())
}

fn jsonl_text(records: &[TrialRecord]) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    for r in records {
        for g in &r.fitness {
            let line = GenerationLine {
                method: r.method.name(),
                trial: r.trial,
                index: g.index,
                restart: g.restart,
                best: g.best,
                mean: g.mean,
            };
            serde_json::to_writer(&mut out, &line).map_err(|e| e.to_string())?;
            out.write_all(b"\n").map_err(|e| e.to_string())?;
        }
    }
    Ok(out)
}

/// The plots the methods run call for, with their file stems.
fn figures(
    exp: &Experiment,
    records: &[TrialRecord],
) -> Vec<(String, String, Result<Plot, String>)> {
    let has = |m: Method| records.iter().any(|r| r.method == m);
    let mut figures = Vec::new();
    if has(Method::Ga) || has(Method::Guided) {
        figures.push((
            "fig3-generations".to_string(),
            "Generations to a safe landing per trial (the paper's Figure 3)".to_string(),
            generations_per_trial(records).map_err(|e| e.to_string()),
        ));
        let t = exp.shown_trial();
        figures.push((
            format!("fig4-fitness-trial{t}"),
            format!("Best and mean fitness per generation in trial {t} (the paper's Figure 4)"),
            fitness_per_generation(records, t).map_err(|e| e.to_string()),
        ));
    }
    if has(Method::Qlearning) {
        figures.push((
            "qlearning-curve".to_string(),
            "The Q(λ) learning curve".to_string(),
            learning_curve(records).map_err(|e| e.to_string()),
        ));
    }
    figures
}

/// Writes every output file and returns the summary.
pub fn write_outputs(
    dir: &Path,
    exp: &Experiment,
    records: &[TrialRecord],
) -> Result<Summary, OutputError> {
    write(
        dir,
        "trials.csv",
        &csv_text(records).map_err(fail(&dir.join("trials.csv")))?,
    )?;
    let jsonl = jsonl_text(records).map_err(fail(&dir.join("generations.jsonl")))?;
    write(dir, "generations.jsonl", &jsonl)?;
    let summary = Summary::new(&exp.name, exp.seed, exp.trials, records);
    let json = serde_json::to_vec_pretty(&summary).map_err(|e| fail(dir)(e.to_string()))?;
    write(dir, "summary.json", &json)?;
    let markdown = summary.markdown();
    write(dir, "summary.md", markdown.as_bytes())?;
    let mut shown = Vec::new();
    for (stem, caption, plot) in figures(exp, records) {
        let plot = plot.map_err(fail(&dir.join(format!("{stem}.svg"))))?;
        write_plot(dir, &stem, &plot)?;
        shown.push(Figure {
            caption,
            svg: plot.svg,
        });
    }
    let recording = best_landing(exp, records);
    let html = report_html(&summary, &shown, recording.as_ref());
    write(dir, "report.html", html.as_bytes())?;
    Ok(summary)
}
