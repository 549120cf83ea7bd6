//! A sweep's figure for a grid of two keys: a heatmap of the share of
//! pairs the guided GA won, one cell per setting, the first key across and
//! the second up, both on categorical axes as in `sweep`. Each cell is
//! coloured on a sequential scale (viridis, [`sequential`]) and carries its
//! share and bootstrap interval in figures, so nothing rests on judging a
//! colour; the legend panel holds the colour bar with the paper's share
//! marked on it.

use super::legend::{legend, Entry, Swatch};
use super::render::{frame, no_data, polyline, render, Area, Figure, Plot, PlotError, Target};
use super::style::{
    ink_on, sequential, AXIS_DESC_SIZE, FAMILY, GRID, LEGEND_SIZE, REFERENCE, TICK_SIZE,
};
use super::sweep::{categories, category_axis, category_label, grid_rows};
use crate::bootstrap::Interval;
use crate::summary::num;
use crate::sweep::{value_text, GridInput, SweepSummary, PAPER_PAIRS_WON, PAPER_SHARE_WON};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// The share of pairs the guided GA won under each setting of a two-key
/// grid, as a heatmap: the first key's values across, the second's up,
/// each cell coloured by the share and labelled with it and its interval.
/// A setting without pairs is a grey cell marked "–"; a combination no
/// setting covers stays white. A grid without two keys, or without
/// settings, draws "no data" saying which.
pub fn heatmap(grid: &GridInput, summary: &SweepSummary) -> Result<Plot, PlotError> {
    let title = format!("Share of pairs won by the guided GA, grid {}", grid.name);
    let [across, up] = grid.keys.as_slice() else {
        return render(&HeatmapFigure {
            title,
            problem: Some(format!(
                "grid {} has {} keys; this plot needs 2",
                grid.name,
                grid.keys.len()
            )),
            ..HeatmapFigure::default()
        });
    };
    let rows = grid_rows(grid, summary);
    let (xs, ys) = (categories(&rows, across), categories(&rows, up));
    let mut cells: Vec<Cell> = Vec::new();
    for row in &rows {
        let position = |values: &[serde_json::Value], key: &str| {
            values.iter().position(|v| Some(v) == row.value(key))
        };
        let (Some(x), Some(y)) = (position(&xs, across), position(&ys, up)) else {
            continue;
        };
        // Two settings of one grid with the same values would share a
        // cell; the first keeps it.
        if cells.iter().any(|c| (c.x, c.y) == (x, y)) {
            continue;
        }
        let paired = row.paired.as_ref();
        cells.push(Cell {
            x,
            y,
            share: paired.map(|p| p.share_won),
            interval: paired.and_then(|p| p.share_won_interval),
        });
    }
    render(&HeatmapFigure {
        problem: cells
            .is_empty()
            .then(|| format!("no settings in grid {}", grid.name)),
        title,
        keys: (across.clone(), up.clone()),
        x_labels: xs.iter().map(value_text).collect(),
        y_labels: ys.iter().map(value_text).collect(),
        cells,
        level: summary.level,
    })
}

/// One setting's cell: its position on both axes and its share.
struct Cell {
    x: usize,
    y: usize,
    share: Option<f64>,
    interval: Option<Interval>,
}

#[derive(Default)]
struct HeatmapFigure {
    title: String,
    /// Why there is nothing to draw, if there is not.
    problem: Option<String>,
    keys: (String, String),
    x_labels: Vec<String>,
    y_labels: Vec<String>,
    cells: Vec<Cell>,
    level: f64,
}

/// The cells' text sizes: the share, and its interval below it.
const SHARE_SIZE: i32 = 15;
const INTERVAL_SIZE: i32 = 12;

impl Figure for HeatmapFigure {
    const NAME: &'static str = "sweep heatmap";

    fn draw<DB: DrawingBackend>(&self, root: &Area<DB>, target: Target) -> DrawResult<(), DB> {
        let (area, legend_area) = frame(root, &self.title)?;
        if let Some(problem) = &self.problem {
            return no_data(root, problem);
        }
        let mut chart = ChartBuilder::on(&area)
            .margin(12)
            .x_label_area_size(45)
            .y_label_area_size(90)
            .build_cartesian_2d(
                category_axis(self.x_labels.len()),
                category_axis(self.y_labels.len()),
            )?;
        chart
            .configure_mesh()
            .x_desc(self.keys.0.as_str())
            .y_desc(self.keys.1.as_str())
            .axis_desc_style((FAMILY, AXIS_DESC_SIZE))
            .label_style((FAMILY, TICK_SIZE))
            .bold_line_style(TRANSPARENT)
            .light_line_style(TRANSPARENT)
            .x_label_formatter(&|t| category_label(&self.x_labels, *t))
            .y_label_formatter(&|t| category_label(&self.y_labels, *t))
            .draw()?;

        let centred = |size: i32, colour: RGBColor| {
            (FAMILY, size)
                .into_font()
                .color(&colour)
                .pos(Pos::new(HPos::Center, VPos::Center))
        };
        for cell in &self.cells {
            let (x, y) = (cell.x as f64, cell.y as f64);
            let fill = cell.share.map_or(GRID, sequential);
            let corners = [(x - 0.5, y - 0.5), (x + 0.5, y + 0.5)];
            chart.draw_series([
                Rectangle::new(corners, fill.filled()),
                Rectangle::new(corners, WHITE.stroke_width(2)),
            ])?;
            let (px, py) = chart.backend_coord(&(x, y));
            let ink = ink_on(fill);
            let Some(share) = cell.share else {
                root.draw(&Text::new("–", (px, py), centred(SHARE_SIZE, REFERENCE)))?;
                continue;
            };
            let shift = if cell.interval.is_some() { 8 } else { 0 };
            root.draw(&Text::new(
                num(share),
                (px, py - shift),
                centred(SHARE_SIZE, ink),
            ))?;
            if let Some(i) = cell.interval {
                root.draw(&Text::new(
                    format!("{}–{}", num(i.low), num(i.high)),
                    (px, py + shift),
                    centred(INTERVAL_SIZE, ink),
                ))?;
            }
        }
        colour_bar(&legend_area, target, self.level)
    }
}

/// The legend panel: a vertical colour bar from share 0 (bottom) to 1
/// (top) with ticks every quarter, the paper's share dashed across it, and
/// notes on what the cells hold.
fn colour_bar<DB: DrawingBackend>(
    area: &Area<DB>,
    target: Target,
    level: f64,
) -> DrawResult<(), DB> {
    const LEFT: i32 = 30;
    const RIGHT: i32 = 54;
    const TOP: i32 = 44;
    const BOTTOM: i32 = 284;
    const BANDS: i32 = 60;
    let y_of = |share: f64| BOTTOM - ((BOTTOM - TOP) as f64 * share).round() as i32;
    let text = |anchor: HPos| {
        (FAMILY, LEGEND_SIZE)
            .into_font()
            .color(&BLACK)
            .pos(Pos::new(anchor, VPos::Center))
    };
    area.draw(&Text::new(
        "share won",
        (LEFT - 16, TOP - 22),
        text(HPos::Left),
    ))?;
    for band in 0..BANDS {
        let (from, to) = (
            f64::from(band) / f64::from(BANDS),
            f64::from(band + 1) / f64::from(BANDS),
        );
        let middle = (from + to) / 2.0;
        area.draw(&Rectangle::new(
            [(LEFT, y_of(to)), (RIGHT, y_of(from))],
            sequential(middle).filled(),
        ))?;
    }
    area.draw(&Rectangle::new(
        [(LEFT, TOP), (RIGHT, BOTTOM)],
        REFERENCE.stroke_width(1),
    ))?;
    for tick in [0.0, 0.25, 0.5, 0.75, 1.0] {
        let y = y_of(tick);
        area.draw(&PathElement::new(
            vec![(RIGHT, y), (RIGHT + 4, y)],
            BLACK.stroke_width(1),
        ))?;
        area.draw(&Text::new(num(tick), (RIGHT + 8, y), text(HPos::Left)))?;
    }
    let paper = y_of(PAPER_SHARE_WON);
    polyline(
        area,
        target,
        [(LEFT - 14, paper), (RIGHT, paper)],
        BLACK.stroke_width(2),
        Some((4.0, 3.0)),
    )?;
    let (won, of) = PAPER_PAIRS_WON;
    let notes = [
        Entry::new(format!("paper: {won} of {of}"), Swatch::Dashed(BLACK)),
        Entry::new(format!("(share {})", num(PAPER_SHARE_WON)), Swatch::Note),
        Entry::new(
            format!("cells: share, {:.0}% CI", 100.0 * level),
            Swatch::Note,
        ),
        Entry::new("–: no pairs", Swatch::Note),
    ];
    let (_, below) = area.split_vertically(BOTTOM + 10);
    legend(&below, &notes)
}
