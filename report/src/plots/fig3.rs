//! Figure 3: generations to a safe landing, trial by trial, one line per
//! GA method.

use super::axis::to_i64;
use super::legend::{legend, Entry, Swatch};
use super::render::{frame, no_data, polyline, render, Area, Figure, Plot, PlotError, Target};
use super::style::{colour, AXIS_DESC_SIZE, FAMILY, GRID, REFERENCE, TICK_SIZE};
use crate::model::{Method, TrialRecord};
use plotters::prelude::*;

/// Figure 3: generations each trial flew to its first safe landing, one
/// line per GA method (`ga` "general GA", `guided` "guided GA"), x = trial
/// number. A filled marker is a trial that landed; a hollow one is a trial
/// that never did, drawn at the generations it flew before giving up.
/// `qlearning` records are ignored. A record with no `generations` falls
/// back to its last fitness point's index and is left out if it has none.
/// Records are ordered by trial, then seed.
pub fn generations_per_trial(records: &[TrialRecord]) -> Result<Plot, PlotError> {
    let series = [Method::Ga, Method::Guided]
        .into_iter()
        .map(|method| {
            let mut rows: Vec<_> = records
                .iter()
                .filter(|r| r.method == method)
                .filter_map(|r| {
                    let generations = r
                        .generations
                        .or_else(|| r.fitness.last().map(|p| p.index))?;
                    Some((r.trial, r.seed, generations, r.landed))
                })
                .collect();
            rows.sort_by_key(|&(trial, seed, _, _)| (trial, seed));
            let points = rows
                .into_iter()
                .map(|(trial, _, generations, landed)| GenPoint {
                    trial: to_i64(trial),
                    generations: to_i64(generations),
                    landed,
                })
                .collect();
            (method, points)
        })
        .collect();
    render(&GenerationsFigure { series })
}

struct GenPoint {
    trial: i64,
    generations: i64,
    landed: bool,
}

struct GenerationsFigure {
    series: Vec<(Method, Vec<GenPoint>)>,
}

impl Figure for GenerationsFigure {
    const NAME: &'static str = "generations per trial";

    fn draw<DB: DrawingBackend>(&self, root: &Area<DB>, target: Target) -> DrawResult<(), DB> {
        let (area, legend_area) = frame(root, "Generations to a safe landing, per trial")?;
        let all = || self.series.iter().flat_map(|(_, p)| p);
        let (Some(t_min), Some(t_max), Some(g_max)) = (
            all().map(|p| p.trial).min(),
            all().map(|p| p.trial).max(),
            all().map(|p| p.generations).max(),
        ) else {
            return no_data(root, "no GA trial records");
        };
        let y_top = g_max.saturating_add(g_max / 10).saturating_add(1).max(1);
        let mut chart = ChartBuilder::on(&area)
            .margin(12)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d(
                t_min.saturating_sub(1)..t_max.saturating_add(1),
                0i64..y_top,
            )?;
        chart
            .configure_mesh()
            .x_desc("trial")
            .y_desc("generations to a safe landing")
            .axis_desc_style((FAMILY, AXIS_DESC_SIZE))
            .label_style((FAMILY, TICK_SIZE))
            .bold_line_style(GRID)
            .light_line_style(TRANSPARENT)
            .x_labels(12)
            .draw()?;

        let mut entries = Vec::new();
        let mut any_failed = false;
        for (method, points) in &self.series {
            let colour = colour(*method);
            if points.is_empty() {
                entries.push(Entry::new(
                    format!("{}: no data", method.label()),
                    Swatch::Note,
                ));
                continue;
            }
            polyline(
                root,
                target,
                points
                    .iter()
                    .map(|p| chart.backend_coord(&(p.trial, p.generations))),
                colour.stroke_width(2),
                None,
            )?;
            chart.draw_series(points.iter().map(|p| {
                let fill = if p.landed {
                    colour.filled()
                } else {
                    WHITE.filled()
                };
                let radius = if p.landed { 4 } else { 5 };
                EmptyElement::at((p.trial, p.generations))
                    + Circle::new((0, 0), radius, fill)
                    + Circle::new((0, 0), radius, colour.stroke_width(2))
            }))?;
            any_failed |= points.iter().any(|p| !p.landed);
            entries.push(Entry::new(method.label(), Swatch::LineMarker(colour)));
        }
        if any_failed {
            entries.push(Entry::new("did not land", Swatch::Hollow(REFERENCE)));
            entries.push(Entry::new("(at generations flown)", Swatch::Note));
        }
        legend(&legend_area, &entries)
    }
}
