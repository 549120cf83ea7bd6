//! What a finished sweep leaves in its folder: every setting's experiment
//! outputs (as `lander experiment` writes them), and, comparing the
//! settings, `sweep.csv`, `sweep.md`, `sweep.json`'s companion
//! `summary.json`, a plot or two per grid and `report.html`.

use super::file::{plain, Sweep};
use super::store::SweepStore;
use crate::experiment::outputs::{ordered, write, write_outputs, write_plot, OutputError};
use lander_report::model::TrialRecord;
use lander_report::page::Figure;
use lander_report::plots::{generations_against, heatmap, share_against, Plot, PlotError};
use lander_report::summary::Summary;
use lander_report::sweep::{sweep_summary, GridInput, SettingInput, SweepSummary};
use lander_report::sweep_page::sweep_html;

/// Writes every setting's outputs and the sweep's, and returns the sweep's
/// table. `records[s]` are setting `s`'s records.
pub fn write_sweep_outputs(
    store: &SweepStore,
    sweep: &Sweep,
    records: Vec<Vec<TrialRecord>>,
) -> Result<SweepSummary, OutputError> {
    let dir = store.dir();
    let mut summaries: Vec<(Summary, Vec<TrialRecord>)> = Vec::new();
    for ((setting, records), setting_store) in
        sweep.settings.iter().zip(records).zip(&store.settings)
    {
        let records = ordered(&setting.experiment, records);
        let summary = write_outputs(setting_store.dir(), &setting.experiment, &records)?;
        summaries.push((summary, records));
    }
    let folders: Vec<String> = sweep
        .settings
        .iter()
        .map(|s| format!("settings/{}", s.folder))
        .collect();
    let inputs: Vec<SettingInput> = sweep
        .settings
        .iter()
        .zip(&summaries)
        .zip(&folders)
        .map(|((s, (summary, records)), folder)| SettingInput {
            name: &s.name,
            folder,
            grid: s.grid.as_deref(),
            values: s
                .values
                .iter()
                .map(|(k, v)| (k.clone(), json_of(v)))
                .collect(),
            summary,
            records,
        })
        .collect();
    let base = &sweep.base;
    let table = sweep_summary(&base.name, base.seed, base.trials, &inputs);
    let csv = table.csv().map_err(|e| OutputError {
        path: dir.join("sweep.csv"),
        message: e.to_string(),
    })?;
    write(dir, "sweep.csv", &csv)?;
    write(dir, "sweep.md", table.markdown().as_bytes())?;
    let json = serde_json::to_vec_pretty(&table).map_err(|e| OutputError {
        path: dir.join("summary.json"),
        message: e.to_string(),
    })?;
    write(dir, "summary.json", &json)?;
    let mut figures = Vec::new();
    for grid in &sweep.grids {
        let input = GridInput {
            name: &grid.name,
            keys: grid.keys.clone(),
        };
        for (what, plot) in grid_plots(&input, &table) {
            let stem = format!("grid-{}-{what}", grid.name);
            let plot = plot.map_err(|e| OutputError {
                path: dir.join(format!("{stem}.svg")),
                message: e.to_string(),
            })?;
            write_plot(dir, &stem, &plot)?;
            figures.push(Figure {
                caption: caption(&grid.name, &grid.keys, what),
                svg: plot.svg,
            });
        }
    }
    write(dir, "report.html", sweep_html(&table, &figures).as_bytes())?;
    Ok(table)
}

/// A grid of one key gets the share of pairs won and the generations
/// against it; a grid of two, a heatmap; larger grids only the table.
fn grid_plots(
    grid: &GridInput,
    table: &SweepSummary,
) -> Vec<(&'static str, Result<Plot, PlotError>)> {
    match grid.keys.len() {
        1 => vec![
            ("share-won", share_against(grid, table)),
            ("generations", generations_against(grid, table)),
        ],
        2 => vec![("share-won", heatmap(grid, table))],
        _ => Vec::new(),
    }
}

fn caption(grid: &str, keys: &[String], what: &str) -> String {
    let against = keys.join(" and ");
    match what {
        "generations" => format!(
            "Grid {grid}: median generations to a safe landing against {against}, with 95% bootstrap intervals"
        ),
        _ => format!(
            "Grid {grid}: share of pairs in which the guided GA needed fewer generations, against {against}, with 95% bootstrap intervals"
        ),
    }
}

/// A TOML value as JSON: numbers stay numbers, so plots can place them.
fn json_of(v: &toml::Value) -> serde_json::Value {
    serde_json::to_value(v).unwrap_or_else(|_| serde_json::Value::String(plain(v)))
}
