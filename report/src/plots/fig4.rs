//! Figure 4: best and mean fitness per generation in one trial, for both
//! GA methods, on a symlog y-axis.

use super::axis::{human, symlog, symlog_inverse, symlog_ticks, thousands, to_i64, TickedAxis};
use super::legend::{legend, Entry, Swatch};
use super::render::{frame, no_data, polyline, render, Area, Figure, Plot, PlotError, Target};
use super::style::{colour, tint, AXIS_DESC_SIZE, FAMILY, GRID, REFERENCE, TICK_SIZE};
use crate::model::{Method, TrialRecord};
use plotters::prelude::*;

/// Figure 4: best (solid) and mean (dashed) fitness per generation of
/// trial `trial`, for both GA methods, x = generation counted across
/// restarts. If a method has several records for the trial (several
/// seeds), the first in `records` is drawn.
///
/// The y-axis is [`symlog`](super::symlog), `sign(f)·log10(1 + |f|)`,
/// labelled with the untransformed fitness: a safe landing scores
/// 9,999,999 while eq. 1 scores unsafe flights in the hundreds to
/// thousands, and clipping would hide the jump a landing makes in the mean. A dotted grey line marks the
/// safe-landing score when one of the trial's records landed. A method
/// with no records (or no fitness points) for the trial is listed in the
/// legend as "no data"; if neither has any, the figure says so.
pub fn fitness_per_generation(records: &[TrialRecord], trial: u64) -> Result<Plot, PlotError> {
    let series = [Method::Ga, Method::Guided]
        .into_iter()
        .map(|method| {
            let points = records
                .iter()
                .find(|r| r.trial == trial && r.method == method)
                .map(|r| {
                    r.fitness
                        .iter()
                        .map(|p| (to_i64(p.index), p.best, p.mean))
                        .collect::<Vec<_>>()
                })
                .unwrap_or_default();
            (method, points)
        })
        .collect();
    let safe_score = records
        .iter()
        .filter(|r| r.trial == trial && matches!(r.method, Method::Ga | Method::Guided))
        .filter_map(|r| r.best.as_ref())
        .find(|b| b.safe && b.fitness.is_finite())
        .map(|b| b.fitness);
    render(&FitnessFigure {
        trial,
        series,
        safe_score,
    })
}

/// One generation on Figure 4: (generation, best, mean).
type Generation = (i64, f64, f64);

struct FitnessFigure {
    trial: u64,
    series: Vec<(Method, Vec<Generation>)>,
    safe_score: Option<f64>,
}

impl Figure for FitnessFigure {
    const NAME: &'static str = "fitness per generation";

    fn draw<DB: DrawingBackend>(&self, root: &Area<DB>, target: Target) -> DrawResult<(), DB> {
        let title = format!("Best and mean fitness per generation, trial {}", self.trial);
        let (area, legend_area) = frame(root, &title)?;
        let points = || self.series.iter().flat_map(|(_, p)| p);
        let values = || {
            points()
                .flat_map(|&(_, best, mean)| [best, mean])
                .chain(self.safe_score)
                .filter(|v| v.is_finite())
                .map(symlog)
        };
        let (Some(x_max), Some(lo), Some(hi)) = (
            points().map(|p| p.0).max(),
            values().reduce(f64::min),
            values().reduce(f64::max),
        ) else {
            return no_data(root, &format!("no GA records for trial {}", self.trial));
        };
        let x_min = points().map(|p| p.0).min().unwrap_or(0).min(1);
        let pad = ((hi - lo) * 0.05).max(0.1);
        let (lo, hi) = (lo - pad, hi + pad);
        let mut chart = ChartBuilder::on(&area)
            .margin(12)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d(
                x_min.saturating_sub(1)..x_max.saturating_add(1),
                TickedAxis {
                    inner: (lo..hi).into(),
                    ticks: symlog_ticks(lo, hi),
                },
            )?;
        chart
            .configure_mesh()
            .x_desc("generation (counted across restarts)")
            .y_desc("fitness (symlog: sign·log10(1+|f|))")
            .axis_desc_style((FAMILY, AXIS_DESC_SIZE))
            .label_style((FAMILY, TICK_SIZE))
            .bold_line_style(GRID)
            .light_line_style(TRANSPARENT)
            .x_labels(10)
            .y_label_formatter(&|t| human(symlog_inverse(*t)))
            .draw()?;

        let mut entries = Vec::new();
        if let Some(score) = self.safe_score {
            let y = symlog(score);
            let ends = [(x_min.saturating_sub(1), y), (x_max.saturating_add(1), y)];
            polyline(
                root,
                target,
                ends.iter().map(|p| chart.backend_coord(p)),
                REFERENCE.stroke_width(2),
                Some((2.0, 4.0)),
            )?;
            entries.push(Entry::new("safe landing", Swatch::Dotted(REFERENCE)));
            entries.push(Entry::new(
                format!("(fitness {})", thousands(score)),
                Swatch::Note,
            ));
        }
        for (method, points) in &self.series {
            let colour = colour(*method);
            let best: Vec<(i64, f64)> = points
                .iter()
                .filter(|p| p.1.is_finite())
                .map(|p| (p.0, symlog(p.1)))
                .collect();
            let mean: Vec<(i64, f64)> = points
                .iter()
                .filter(|p| p.2.is_finite())
                .map(|p| (p.0, symlog(p.2)))
                .collect();
            if best.is_empty() && mean.is_empty() {
                entries.push(Entry::new(
                    format!("{}: no data", method.label()),
                    Swatch::Note,
                ));
                continue;
            }
            let to_pixels = |line: &[(i64, f64)]| -> Vec<(i32, i32)> {
                line.iter().map(|p| chart.backend_coord(p)).collect()
            };
            polyline(
                root,
                target,
                to_pixels(&mean),
                tint(colour).stroke_width(2),
                Some((7.0, 4.0)),
            )?;
            polyline(root, target, to_pixels(&best), colour.stroke_width(2), None)?;
            if points.len() == 1 {
                // A lone generation draws no line: mark it instead.
                chart.draw_series(
                    best.iter()
                        .chain(&mean)
                        .map(|&p| Circle::new(p, 3, colour.filled())),
                )?;
            }
            entries.push(Entry::new(
                format!("{} best", method.label()),
                Swatch::Line(colour),
            ));
            entries.push(Entry::new(
                format!("{} mean", method.label()),
                Swatch::Dashed(tint(colour)),
            ));
        }
        legend(&legend_area, &entries)
    }
}
