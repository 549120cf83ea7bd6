//! A sweep's figures for a grid of one key: the share of pairs the guided
//! GA won ([`share_against`]) and the median generations of each GA
//! ([`generations_against`]) against the key's values, each estimate with
//! its bootstrap interval as a whisker. Also the grid helpers the heatmap
//! shares: which settings a grid holds, and the categorical axis.
//!
//! Every key's values sit at evenly spaced positions, labelled with the
//! values as written ([`value_text`]), rather than on a numeric axis: a
//! crossover named "uniform" or "buckland" has no place on a number line,
//! and a sweep's few numbers are usually picked on a rough log scale
//! (0, 0.01, 0.1, 0.5), which a linear axis would crowd into one corner.
//! Numbers are put in ascending order; other values keep the order the
//! sweep lists them in.

use super::axis::{plain, TickedAxis};
use super::legend::{legend, Entry, Swatch};
use super::render::{frame, no_data, polyline, render, Area, Figure, Plot, PlotError, Target};
use super::style::{colour, AXIS_DESC_SIZE, FAMILY, GRID, REFERENCE, TICK_SIZE};
use crate::bootstrap::Interval;
use crate::model::Method;
use crate::summary::num;
use crate::sweep::{
    value_text, GridInput, SettingRow, SweepSummary, PAPER_PAIRS_WON, PAPER_SHARE_WON,
};
use plotters::prelude::*;
use serde_json::Value;

/// The share of pairs the guided GA won under each setting of a one-key
/// grid, against the key's values: a marker at the share, a whisker over
/// its bootstrap interval, and a dashed line at the paper's 24 of 25
/// (0.96). A setting without pairs is left out. A grid without one key,
/// or without settings that have pairs, draws "no data" saying which.
pub fn share_against(grid: &GridInput, summary: &SweepSummary) -> Result<Plot, PlotError> {
    let axis = OneKey::of(grid, summary);
    let points = axis
        .rows
        .iter()
        .filter_map(|(position, row)| {
            let p = row.paired.as_ref()?;
            Some(Estimate {
                x: *position as f64,
                y: p.share_won,
                interval: p.share_won_interval,
            })
        })
        .collect();
    render(&AgainstFigure {
        title: format!("Share of pairs won by the guided GA, grid {}", grid.name),
        y_desc: "share of pairs the guided GA won".into(),
        why_empty: axis
            .problem
            .clone()
            .unwrap_or_else(|| format!("no paired trials in grid {}", grid.name)),
        axis,
        series: vec![(Method::Guided, points)],
        level: summary.level,
        reference: true,
    })
}

/// The median generations to a safe landing of each GA method under each
/// setting of a one-key grid, against the key's values, with whiskers over
/// the medians' bootstrap intervals. The two methods sit a little either
/// side of each position so that their whiskers do not overlap. A method
/// with no landed trial under a setting is left out there.
pub fn generations_against(grid: &GridInput, summary: &SweepSummary) -> Result<Plot, PlotError> {
    let axis = OneKey::of(grid, summary);
    let series = [(Method::Ga, -0.12), (Method::Guided, 0.12)]
        .into_iter()
        .map(|(method, offset)| {
            let points = axis
                .rows
                .iter()
                .filter_map(|(position, row)| {
                    let m = row.method(method)?;
                    Some(Estimate {
                        x: *position as f64 + offset,
                        y: m.generations?.median,
                        interval: m.median_interval,
                    })
                })
                .collect();
            (method, points)
        })
        .filter(|(method, _)| summary.methods().contains(method))
        .collect();
    render(&AgainstFigure {
        title: format!("Median generations to land, grid {}", grid.name),
        y_desc: "generations to a safe landing (median)".into(),
        why_empty: axis
            .problem
            .clone()
            .unwrap_or_else(|| format!("no landed GA trials in grid {}", grid.name)),
        axis,
        series,
        level: summary.level,
        reference: false,
    })
}

/// The settings of `grid` that set every one of its keys, in the sweep's
/// order.
pub(super) fn grid_rows<'a>(grid: &GridInput, summary: &'a SweepSummary) -> Vec<&'a SettingRow> {
    summary
        .settings
        .iter()
        .filter(|s| s.grid.as_deref() == Some(grid.name))
        .filter(|s| grid.keys.iter().all(|k| s.value(k).is_some()))
        .collect()
}

/// The distinct values `key` takes over `rows`, in axis order: ascending
/// if all are numbers, else as first met.
pub(super) fn categories(rows: &[&SettingRow], key: &str) -> Vec<Value> {
    let mut values: Vec<Value> = Vec::new();
    for value in rows.iter().filter_map(|r| r.value(key)) {
        if !values.contains(value) {
            values.push(value.clone());
        }
    }
    if values.iter().all(Value::is_number) {
        values.sort_by(|a, b| {
            let (a, b) = (a.as_f64().unwrap_or(0.0), b.as_f64().unwrap_or(0.0));
            a.total_cmp(&b)
        });
    }
    values
}

/// A categorical axis of `count` positions, 0 to `count − 1`, each with a
/// tick, and half a step of margin either side.
pub(super) fn category_axis(count: usize) -> TickedAxis {
    let last = count.saturating_sub(1) as f64;
    TickedAxis {
        inner: (-0.5..last + 0.5).into(),
        ticks: (0..count).map(|i| i as f64).collect(),
    }
}

/// The label of the category at tick `t`.
pub(super) fn category_label(labels: &[String], t: f64) -> String {
    let index = t.round();
    if index < 0.0 {
        return String::new();
    }
    labels.get(index as usize).cloned().unwrap_or_default()
}

/// A one-key grid laid out on the categorical axis: each setting with its
/// position, the positions' labels, and why there is nothing to draw.
struct OneKey<'a> {
    key: String,
    labels: Vec<String>,
    rows: Vec<(usize, &'a SettingRow)>,
    problem: Option<String>,
}

impl<'a> OneKey<'a> {
    fn of(grid: &GridInput, summary: &'a SweepSummary) -> OneKey<'a> {
        let [key] = grid.keys.as_slice() else {
            return OneKey {
                key: grid.keys.join(", "),
                labels: Vec::new(),
                rows: Vec::new(),
                problem: Some(format!(
                    "grid {} has {} keys; this plot needs 1",
                    grid.name,
                    grid.keys.len()
                )),
            };
        };
        let rows = grid_rows(grid, summary);
        let values = categories(&rows, key);
        let rows = rows
            .into_iter()
            .filter_map(|r| Some((values.iter().position(|v| Some(v) == r.value(key))?, r)))
            .collect::<Vec<_>>();
        OneKey {
            key: key.clone(),
            labels: values.iter().map(value_text).collect(),
            problem: rows
                .is_empty()
                .then(|| format!("no settings in grid {}", grid.name)),
            rows,
        }
    }
}

/// An estimate at an x position, with its interval if it has one.
struct Estimate {
    x: f64,
    y: f64,
    interval: Option<Interval>,
}

/// An estimate per setting against a one-key grid's values.
struct AgainstFigure<'a> {
    title: String,
    y_desc: String,
    why_empty: String,
    axis: OneKey<'a>,
    /// The estimates of each method, drawn in its colour.
    series: Vec<(Method, Vec<Estimate>)>,
    level: f64,
    /// Whether to draw the paper's share as a reference line.
    reference: bool,
}

impl Figure for AgainstFigure<'_> {
    const NAME: &'static str = "sweep against a key";

    fn draw<DB: DrawingBackend>(&self, root: &Area<DB>, target: Target) -> DrawResult<(), DB> {
        let (area, legend_area) = frame(root, &self.title)?;
        let estimates = || self.series.iter().flat_map(|(_, e)| e);
        if estimates().next().is_none() {
            return no_data(root, &self.why_empty);
        }
        let tops = estimates().flat_map(|e| [Some(e.y), e.interval.map(|i| i.high)]);
        let top = tops.flatten().filter(|v| v.is_finite()).fold(0.0, f64::max);
        let (low, high) = if self.reference {
            (-0.03, 1.05)
        } else {
            (0.0, (top * 1.1).max(1.0))
        };
        let mut chart = ChartBuilder::on(&area)
            .margin(12)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d(category_axis(self.axis.labels.len()), low..high)?;
        chart
            .configure_mesh()
            .x_desc(self.axis.key.as_str())
            .y_desc(self.y_desc.as_str())
            .axis_desc_style((FAMILY, AXIS_DESC_SIZE))
            .label_style((FAMILY, TICK_SIZE))
            .bold_line_style(GRID)
            .light_line_style(TRANSPARENT)
            .x_label_formatter(&|t| category_label(&self.axis.labels, *t))
            .y_label_formatter(&|v| plain(*v))
            .draw()?;

        let mut entries = Vec::new();
        if self.reference {
            let ends = [
                (-0.5, PAPER_SHARE_WON),
                (self.axis.labels.len() as f64 - 0.5, PAPER_SHARE_WON),
            ];
            polyline(
                root,
                target,
                ends.iter().map(|p| chart.backend_coord(p)),
                REFERENCE.stroke_width(2),
                Some((7.0, 4.0)),
            )?;
        }
        for (method, points) in &self.series {
            let colour = colour(*method);
            for e in points {
                if let Some(i) = e.interval {
                    whisker(
                        root,
                        target,
                        chart.backend_coord(&(e.x, i.low)),
                        chart.backend_coord(&(e.x, i.high)),
                        colour,
                    )?;
                }
                root.draw(&Circle::new(
                    chart.backend_coord(&(e.x, e.y)),
                    5,
                    colour.filled(),
                ))?;
            }
            if !points.is_empty() {
                entries.push(Entry::new(method.label(), Swatch::Interval(colour)));
            }
        }
        let level = format!("{:.0}%", 100.0 * self.level);
        if self.reference {
            entries.push(Entry::new(format!("share won, {level} CI"), Swatch::Note));
            let (won, of) = PAPER_PAIRS_WON;
            entries.push(Entry::new(
                format!("paper: {won} of {of}"),
                Swatch::Dashed(REFERENCE),
            ));
            entries.push(Entry::new(
                format!("(share {})", num(PAPER_SHARE_WON)),
                Swatch::Note,
            ));
        } else {
            entries.push(Entry::new(format!("median, {level} CI"), Swatch::Note));
            entries.push(Entry::new("(trials that landed)", Swatch::Note));
        }
        legend(&legend_area, &entries)
    }
}

/// A vertical whisker between two pixels, capped at both ends.
fn whisker<DB: DrawingBackend>(
    root: &Area<DB>,
    target: Target,
    low: (i32, i32),
    high: (i32, i32),
    colour: RGBColor,
) -> DrawResult<(), DB> {
    const CAP: i32 = 5;
    let style = colour.stroke_width(2);
    polyline(root, target, [low, high], style, None)?;
    for (x, y) in [low, high] {
        polyline(root, target, [(x - CAP, y), (x + CAP, y)], style, None)?;
    }
    Ok(())
}
