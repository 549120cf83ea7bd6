//! The report's figures, drawn from trial records: generations to a safe
//! landing per trial (the paper's Figure 3), best and mean fitness per
//! generation in one trial (Figure 4), and the Q(λ) baseline's learning
//! curve.
//!
//! Every figure comes back as a [`Plot`]: the same drawing as an SVG
//! document and as PNG bytes, 800×500 pixels. Nothing here touches the
//! file system; the caller decides where the bytes go.
//!
//! Colours follow the method everywhere (Okabe–Ito, safe for colour-blind
//! readers): general GA [`GA_COLOUR`] blue, guided GA [`GUIDED_COLOUR`]
//! vermillion, Q(λ) [`QLEARNING_COLOUR`] bluish green. Each legend sits in
//! a panel to the right of the chart so it never hides data.
//!
//! Empty input is not an error: a figure with nothing to show is still
//! drawn, with its title and a centred "no data: …" line saying what was
//! missing, so a report always has something to put in its place. A
//! [`PlotError`] means drawing or PNG encoding itself failed.
//!
//! Text in the PNG is rasterised with DejaVu Sans, embedded from
//! `report/assets/DejaVuSans.ttf` (license alongside it) and registered with
//! plotters once per process; the SVG names the `sans-serif` family and
//! leaves rendering to the viewer, but plotters measures its text with the
//! same font, so both outputs lay out alike.

use crate::model::TrialRecord;
use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::register_font;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::sync::OnceLock;
use thiserror::Error;

/// Width of every plot, in pixels.
pub const WIDTH: u32 = 800;
/// Height of every plot, in pixels.
pub const HEIGHT: u32 = 500;

/// The general GA (`ga`): Okabe–Ito blue.
pub const GA_COLOUR: RGBColor = RGBColor(0, 114, 178);
/// The guided GA (`guided`): Okabe–Ito vermillion.
pub const GUIDED_COLOUR: RGBColor = RGBColor(213, 94, 0);
/// Q(λ) (`qlearning`): Okabe–Ito bluish green.
pub const QLEARNING_COLOUR: RGBColor = RGBColor(0, 158, 115);

/// Episodes in the learning curve's moving average.
pub const SMOOTHING_WINDOW: usize = 100;

/// One figure, drawn twice: an SVG document and a PNG image, both
/// [`WIDTH`]×[`HEIGHT`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Plot {
    pub svg: String,
    pub png: Vec<u8>,
}

/// Why a figure could not be produced. `plot` names the figure.
#[derive(Debug, Error)]
pub enum PlotError {
    #[error("{plot} plot: the embedded DejaVu Sans font could not be registered")]
    Font { plot: &'static str },
    #[error("{plot} plot: drawing the {backend} failed: {reason}")]
    Draw {
        plot: &'static str,
        backend: &'static str,
        reason: String,
    },
    #[error("{plot} plot: encoding the PNG failed: {reason}")]
    Png { plot: &'static str, reason: String },
}

impl PlotError {
    /// The figure that failed.
    pub fn plot(&self) -> &'static str {
        match self {
            PlotError::Font { plot }
            | PlotError::Draw { plot, .. }
            | PlotError::Png { plot, .. } => plot,
        }
    }
}

/// The name a method has on plots: "general GA", "guided GA", "Q(λ)", or
/// the record's own name for anything else.
pub fn method_label(method: &str) -> &str {
    match Method::parse(method) {
        Some(m) => m.label(),
        None => method,
    }
}

/// The colour a method has on every plot, if it is one of the three.
pub fn method_colour(method: &str) -> Option<RGBColor> {
    Method::parse(method).map(Method::colour)
}

/// The y-scale of [`fitness_per_generation`]: `sign(v)·log10(1 + |v|)`.
/// Linear-ish near zero, logarithmic far from it, defined for every finite
/// value and increasing (strictly, up to rounding); a safe landing's
/// 9,999,999 maps to exactly 7.
pub fn symlog(v: f64) -> f64 {
    v.signum() * (1.0 + v.abs()).log10()
}

/// The inverse of [`symlog`].
pub fn symlog_inverse(t: f64) -> f64 {
    t.signum() * (10f64.powf(t.abs()) - 1.0)
}

/// Figure 3: generations each trial flew to its first safe landing, one
/// line per GA method (`ga` "general GA", `guided` "guided GA"), x = trial
/// number. A filled marker is a trial that landed; a hollow one is a trial
/// that never did, drawn at the generations it flew before giving up.
/// `qlearning` records (and any other method) are ignored. A record with
/// no `generations` falls back to its last fitness point's index and is
/// left out if it has none. Records are ordered by trial, then seed.
pub fn generations_per_trial(records: &[TrialRecord]) -> Result<Plot, PlotError> {
    let series = [Method::Ga, Method::Guided]
        .into_iter()
        .map(|method| {
            let mut rows: Vec<_> = records
                .iter()
                .filter(|r| Method::parse(&r.method) == Some(method))
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

/// Figure 4: best (solid) and mean (dashed) fitness per generation of
/// trial `trial`, for both GA methods, x = generation counted across
/// restarts. If a method has several records for the trial (several
/// seeds), the first in `records` is drawn.
///
/// The y-axis is [`symlog`], `sign(f)·log10(1 + |f|)`, labelled with the
/// untransformed fitness: a safe landing scores 9,999,999 while eq. 1
/// scores unsafe flights in the hundreds to thousands, and clipping would
/// hide the jump a landing makes in the mean. A dotted grey line marks the
/// safe-landing score when one of the trial's records landed. A method
/// with no records (or no fitness points) for the trial is listed in the
/// legend as "no data"; if neither has any, the figure says so.
pub fn fitness_per_generation(records: &[TrialRecord], trial: u64) -> Result<Plot, PlotError> {
    let series = [Method::Ga, Method::Guided]
        .into_iter()
        .map(|method| {
            let points = records
                .iter()
                .find(|r| r.trial == trial && Method::parse(&r.method) == Some(method))
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
        .filter(|r| r.trial == trial && Method::parse(&r.method).is_some_and(Method::is_ga))
        .filter_map(|r| r.best.as_ref())
        .find(|b| b.safe && b.fitness.is_finite())
        .map(|b| b.fitness);
    render(&FitnessFigure {
        trial,
        series,
        safe_score,
    })
}

/// The Q(λ) learning curve: for each episode, the mean return over the
/// trials that ran that episode (faint), and its trailing moving average
/// over [`SMOOTHING_WINDOW`] episodes (bold; shorter windows over the
/// first 99 episodes). Every record that carries `learning` with at least
/// one return counts, whatever its method; the rest are ignored. If none
/// does, the figure says "no data". Non-finite returns are skipped.
pub fn learning_curve(records: &[TrialRecord]) -> Result<Plot, PlotError> {
    let runs: Vec<&[f64]> = records
        .iter()
        .filter_map(|r| r.learning.as_ref())
        .map(|l| l.returns.as_slice())
        .filter(|r| !r.is_empty())
        .collect();
    let longest = runs.iter().map(|r| r.len()).max().unwrap_or(0);
    let mean: Vec<Option<f64>> = (0..longest)
        .map(|e| {
            let (sum, n) = runs
                .iter()
                .filter_map(|r| r.get(e).copied().filter(|v| v.is_finite()))
                .fold((0.0, 0u32), |(s, n), v| (s + v, n + 1));
            (n > 0).then(|| sum / f64::from(n))
        })
        .collect();
    let smoothed = moving_average(&mean, SMOOTHING_WINDOW);
    render(&LearningFigure {
        trials: runs.len(),
        mean,
        smoothed,
    })
}

// ---------------------------------------------------------------------------
// Methods.

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Method {
    Ga,
    Guided,
    QLearning,
}

impl Method {
    fn parse(s: &str) -> Option<Method> {
        match s {
            "ga" => Some(Method::Ga),
            "guided" => Some(Method::Guided),
            "qlearning" => Some(Method::QLearning),
            _ => None,
        }
    }

    fn label(self) -> &'static str {
        match self {
            Method::Ga => "general GA",
            Method::Guided => "guided GA",
            Method::QLearning => "Q(λ)",
        }
    }

    fn colour(self) -> RGBColor {
        match self {
            Method::Ga => GA_COLOUR,
            Method::Guided => GUIDED_COLOUR,
            Method::QLearning => QLEARNING_COLOUR,
        }
    }

    fn is_ga(self) -> bool {
        matches!(self, Method::Ga | Method::Guided)
    }
}

// ---------------------------------------------------------------------------
// Rendering: one drawing, two backends.

const FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");
const FAMILY: &str = "sans-serif";
const LEGEND_WIDTH: u32 = 190;
const TITLE_SIZE: i32 = 22;
const AXIS_DESC_SIZE: i32 = 16;
const TICK_SIZE: i32 = 13;
const LEGEND_SIZE: i32 = 14;
const MESSAGE_SIZE: i32 = 18;
/// Opacity of the learning curve's unsmoothed line.
const FAINT: f64 = 0.3;
const GRID: RGBColor = RGBColor(225, 225, 225);
const REFERENCE: RGBColor = RGBColor(110, 110, 110);

/// Registers the embedded font as plotters' `sans-serif`, once.
fn font_ready() -> bool {
    static READY: OnceLock<bool> = OnceLock::new();
    *READY.get_or_init(|| register_font(FAMILY, FontStyle::Normal, FONT).is_ok())
}

/// Which output a drawing is for. Only data lines differ: see [`polyline`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Target {
    Svg,
    Png,
}

/// A figure that can draw itself on any plotters backend.
trait Figure {
    /// Names the figure in errors.
    const NAME: &'static str;
    fn draw<DB: DrawingBackend>(&self, root: &Area<DB>, target: Target) -> DrawResult<(), DB>;
}

fn render<F: Figure>(figure: &F) -> Result<Plot, PlotError> {
    let plot = F::NAME;
    if !font_ready() {
        return Err(PlotError::Font { plot });
    }
    let draw_error = |backend: &'static str| {
        move |e: &dyn std::fmt::Display| PlotError::Draw {
            plot,
            backend,
            reason: e.to_string(),
        }
    };

    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (WIDTH, HEIGHT)).into_drawing_area();
        let fail = draw_error("SVG");
        figure.draw(&root, Target::Svg).map_err(|e| fail(&e))?;
        root.present().map_err(|e| fail(&e))?;
    }

    let mut pixels = vec![0u8; WIDTH as usize * HEIGHT as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, (WIDTH, HEIGHT)).into_drawing_area();
        let fail = draw_error("bitmap");
        figure.draw(&root, Target::Png).map_err(|e| fail(&e))?;
        root.present().map_err(|e| fail(&e))?;
    }
    let png = encode_png(&pixels, WIDTH, HEIGHT).map_err(|e| PlotError::Png {
        plot,
        reason: e.to_string(),
    })?;
    Ok(Plot { svg, png })
}

/// RGB8 pixels, row by row, as a PNG file.
fn encode_png(rgb: &[u8], width: u32, height: u32) -> Result<Vec<u8>, png::EncodingError> {
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_compression(png::Compression::Best);
    let mut writer = encoder.write_header()?;
    writer.write_image_data(rgb)?;
    writer.finish()?;
    Ok(out)
}

/// A region of a figure, in pixels.
type Area<DB> = DrawingArea<DB, Shift>;

/// White background and the title; returns the chart area and, to its
/// right, the legend panel.
fn frame<DB: DrawingBackend>(root: &Area<DB>, title: &str) -> DrawResult<(Area<DB>, Area<DB>), DB> {
    root.fill(&WHITE)?;
    let body = root.titled(title, (FAMILY, TITLE_SIZE))?;
    let (w, _) = body.dim_in_pixel();
    Ok(body.split_horizontally(w.saturating_sub(LEGEND_WIDTH) as i32))
}

/// The "no data" notice, centred in the figure.
fn no_data<DB: DrawingBackend>(root: &Area<DB>, why: &str) -> DrawResult<(), DB> {
    let (w, h) = root.dim_in_pixel();
    let style = (FAMILY, MESSAGE_SIZE)
        .into_font()
        .color(&REFERENCE)
        .pos(Pos::new(HPos::Center, VPos::Center));
    root.draw(&Text::new(
        format!("no data: {why}"),
        (w as i32 / 2, h as i32 / 2),
        style,
    ))
}

/// What a legend entry's sample looks like.
enum Swatch {
    /// A solid line with a filled point marker on it.
    LineMarker(RGBColor),
    /// A bold solid line.
    Line(RGBColor),
    /// A thin faint line.
    Faint(RGBColor),
    /// A dashed line.
    Dashed(RGBColor),
    /// A dotted line.
    Dotted(RGBColor),
    /// A hollow point marker.
    Hollow(RGBColor),
    /// No sample: the label is a note.
    Note,
}

struct Entry {
    label: String,
    swatch: Swatch,
}

impl Entry {
    fn new(label: impl Into<String>, swatch: Swatch) -> Entry {
        Entry {
            label: label.into(),
            swatch,
        }
    }
}

/// The legend: one row per entry down the panel, sample then label.
fn legend<DB: DrawingBackend>(area: &Area<DB>, entries: &[Entry]) -> DrawResult<(), DB> {
    const X0: i32 = 6;
    const X1: i32 = 38;
    const ROW: i32 = 26;
    let text = (FAMILY, LEGEND_SIZE)
        .into_font()
        .color(&BLACK)
        .pos(Pos::new(HPos::Left, VPos::Center));
    let note = (FAMILY, LEGEND_SIZE)
        .into_font()
        .color(&REFERENCE)
        .pos(Pos::new(HPos::Left, VPos::Center));
    let mid = (X0 + X1) / 2;
    for (i, entry) in entries.iter().enumerate() {
        let y = 30 + ROW * i as i32;
        let line = |style: ShapeStyle| PathElement::new(vec![(X0, y), (X1, y)], style);
        match entry.swatch {
            Swatch::LineMarker(c) => {
                area.draw(&line(c.stroke_width(2)))?;
                area.draw(&Circle::new((mid, y), 4, c.filled()))?;
            }
            Swatch::Line(c) => area.draw(&line(c.stroke_width(3)))?,
            Swatch::Faint(c) => area.draw(&line(c.mix(FAINT).stroke_width(1)))?,
            Swatch::Dashed(c) => {
                for x in (X0..X1).step_by(10) {
                    let seg = vec![(x, y), ((x + 6).min(X1), y)];
                    area.draw(&PathElement::new(seg, c.stroke_width(2)))?;
                }
            }
            Swatch::Dotted(c) => {
                for x in (X0..=X1).step_by(5) {
                    area.draw(&Circle::new((x, y), 1, c.filled()))?;
                }
            }
            Swatch::Hollow(c) => {
                area.draw(&Circle::new((mid, y), 5, WHITE.filled()))?;
                area.draw(&Circle::new((mid, y), 5, c.stroke_width(2)))?;
            }
            Swatch::Note => {}
        }
        let (x, style) = match entry.swatch {
            Swatch::Note => (X0, note.clone()),
            _ => (X1 + 8, text.clone()),
        };
        area.draw(&Text::new(entry.label.clone(), (x, y), style))?;
    }
    Ok(())
}

/// A data line, given in backend pixels (from `ChartContext::backend_coord`),
/// drawn on the root area: solid, or dashed with `dash = (on, off)` pixel
/// lengths.
///
/// plotters draws a line wider than one pixel by turning the whole path
/// into one polygon, and on the bitmap backend the joins of a dense, noisy
/// path (hundreds of generations to a few pixels) grow long spikes. So for
/// the PNG each segment of a wide line is drawn on its own; the SVG keeps
/// one `<polyline>` per path and leaves joins to the viewer. Repeated
/// pixels are dropped first, which also keeps the SVG small.
fn polyline<DB: DrawingBackend>(
    root: &Area<DB>,
    target: Target,
    pixels: impl IntoIterator<Item = (i32, i32)>,
    style: ShapeStyle,
    dash: Option<(f64, f64)>,
) -> DrawResult<(), DB> {
    let mut path: Vec<(i32, i32)> = pixels.into_iter().collect();
    path.dedup();
    let pieces = match dash {
        Some((on, off)) => dashes(&path, on, off),
        None => vec![path],
    };
    for mut piece in pieces {
        piece.dedup();
        if piece.len() < 2 {
            continue;
        }
        if target == Target::Svg || style.stroke_width <= 1 {
            root.draw(&PathElement::new(piece, style))?;
        } else {
            for pair in piece.windows(2) {
                root.draw(&PathElement::new(pair.to_vec(), style))?;
            }
        }
    }
    Ok(())
}

/// Cuts a pixel path into dashes `on` pixels long with `off`-pixel gaps.
fn dashes(path: &[(i32, i32)], on: f64, off: f64) -> Vec<Vec<(i32, i32)>> {
    let (on, off) = (on.max(1.0), off.max(0.0));
    let mut out = Vec::new();
    let Some(&first) = path.first() else {
        return out;
    };
    let mut current = vec![first];
    let mut drawing = true;
    let mut left = on;
    for pair in path.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        let (dx, dy) = (f64::from(b.0 - a.0), f64::from(b.1 - a.1));
        let len = dx.hypot(dy);
        let mut done = 0.0;
        while len - done > left {
            done += left;
            let f = done / len;
            let p = (a.0 + (dx * f).round() as i32, a.1 + (dy * f).round() as i32);
            if drawing {
                current.push(p);
                out.push(std::mem::take(&mut current));
            } else {
                current = vec![p];
            }
            drawing = !drawing;
            left = if drawing { on } else { off };
        }
        left -= len - done;
        if drawing {
            current.push(b);
        }
    }
    if drawing && current.len() > 1 {
        out.push(current);
    }
    out
}

/// `c` mixed 45% of the way to white: the lighter shade a mean is drawn in.
fn tint(c: RGBColor) -> RGBColor {
    let mix = |v: u8| v + ((255 - v) as f64 * 0.45).round() as u8;
    RGBColor(mix(c.0), mix(c.1), mix(c.2))
}

fn to_i64(v: u64) -> i64 {
    i64::try_from(v).unwrap_or(i64::MAX)
}

// ---------------------------------------------------------------------------
// Figure 3.

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
            let colour = method.colour();
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

// ---------------------------------------------------------------------------
// Figure 4.

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
            let colour = method.colour();
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

/// A linear f64 axis whose ticks are given: the symlog axis. (plotters'
/// own `with_key_points` wrapper loses the f64 label formatting that
/// `configure_mesh` needs.)
struct TickedAxis {
    inner: RangedCoordf64,
    ticks: Vec<f64>,
}

impl Ranged for TickedAxis {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        self.inner.map(value, limit)
    }

    fn key_points<H: KeyPointHint>(&self, hint: H) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            Vec::new()
        } else {
            self.ticks.clone()
        }
    }

    fn range(&self) -> std::ops::Range<f64> {
        self.inner.range()
    }
}

/// Tick positions (in symlog space) for `[lo, hi]`: 0 and ±powers of ten
/// when at least three fit, else ±1-2-5 steps, else plain linear steps.
fn symlog_ticks(lo: f64, hi: f64) -> Vec<f64> {
    let inside = |v: &f64| {
        let t = symlog(*v);
        t >= lo - 1e-9 && t <= hi + 1e-9
    };
    let signed = |mantissas: &[f64]| -> Vec<f64> {
        let mut v = vec![0.0];
        for k in 0..16 {
            for m in mantissas {
                let x = m * 10f64.powi(k);
                v.extend([x, -x]);
            }
        }
        v.retain(inside);
        v.sort_by(f64::total_cmp);
        v
    };
    for mantissas in [&[1.0][..], &[1.0, 2.0, 5.0][..]] {
        let ticks = signed(mantissas);
        if ticks.len() >= 3 {
            return ticks.into_iter().map(symlog).collect();
        }
    }
    let (a, b) = (symlog_inverse(lo), symlog_inverse(hi));
    let step = nice_step((b - a) / 5.0);
    let mut ticks = Vec::new();
    let mut k = (a / step).ceil();
    while k * step <= b && ticks.len() < 20 {
        ticks.push(symlog(k * step));
        k += 1.0;
    }
    ticks
}

/// 1, 2 or 5 times a power of ten, at least `raw`.
fn nice_step(raw: f64) -> f64 {
    if !(raw.is_finite() && raw > 0.0) {
        return 1.0;
    }
    let mag = 10f64.powf(raw.log10().floor());
    let f = raw / mag;
    let m = if f <= 1.0 {
        1.0
    } else if f <= 2.0 {
        2.0
    } else if f <= 5.0 {
        5.0
    } else {
        10.0
    };
    m * mag
}

/// A tick label: 1.5k, 10M, 250, 0.5.
fn human(v: f64) -> String {
    let a = v.abs();
    let (scaled, suffix) = if a >= 999_999.5 {
        (v / 1e6, "M")
    } else if a >= 999.5 {
        (v / 1e3, "k")
    } else {
        (v, "")
    };
    let mut s = format!("{scaled:.2}");
    if s.contains('.') {
        s = s.trim_end_matches('0').trim_end_matches('.').to_string();
    }
    if s == "-0" {
        s = "0".to_string();
    }
    s + suffix
}

/// A linear-axis tick label: "1,000", "-250", "0.5".
fn plain(v: f64) -> String {
    if (v - v.round()).abs() < 1e-9 * v.abs().max(1.0) {
        thousands(v)
    } else {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

/// 9999999 as "9,999,999" (rounded to an integer).
fn thousands(v: f64) -> String {
    let digits = format!("{:.0}", v.abs());
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i) % 3 == 0 {
            out.push(',');
        }
        out.push(c);
    }
    if v < 0.0 && digits != "0" {
        out.insert(0, '-');
    }
    out
}

// ---------------------------------------------------------------------------
// The learning curve.

struct LearningFigure {
    trials: usize,
    /// Per episode (from 1): mean return over the trials that ran it.
    mean: Vec<Option<f64>>,
    smoothed: Vec<Option<f64>>,
}

/// Trailing moving average over up to `window` values, skipping gaps.
fn moving_average(values: &[Option<f64>], window: usize) -> Vec<Option<f64>> {
    let window = window.max(1);
    let (mut sum, mut n) = (0.0, 0usize);
    let mut out = Vec::with_capacity(values.len());
    for (i, v) in values.iter().enumerate() {
        if let Some(v) = v {
            sum += v;
            n += 1;
        }
        if i >= window {
            if let Some(old) = values[i - window] {
                sum -= old;
                n -= 1;
            }
        }
        out.push((n > 0).then(|| sum / n as f64));
    }
    out
}

impl Figure for LearningFigure {
    const NAME: &'static str = "learning curve";

    fn draw<DB: DrawingBackend>(&self, root: &Area<DB>, target: Target) -> DrawResult<(), DB> {
        let (area, legend_area) = frame(root, "Q(λ) learning curve")?;
        let series = |v: &[Option<f64>]| -> Vec<(i64, f64)> {
            v.iter()
                .enumerate()
                .filter_map(|(i, v)| v.map(|v| (i as i64 + 1, v)))
                .collect()
        };
        let (mean, smoothed) = (series(&self.mean), series(&self.smoothed));
        let ys = || mean.iter().chain(&smoothed).map(|p| p.1);
        let (Some(lo), Some(hi)) = (ys().reduce(f64::min), ys().reduce(f64::max)) else {
            return no_data(root, "no Q-learning records with episode returns");
        };
        // A flat curve still gets a readable band around it.
        let pad = if hi > lo {
            (hi - lo) * 0.05
        } else {
            (0.05 * hi.abs()).max(0.5)
        };
        let episodes = self.mean.len() as i64;
        let mut chart = ChartBuilder::on(&area)
            .margin(12)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d(0i64..episodes + 1, (lo - pad)..(hi + pad))?;
        chart
            .configure_mesh()
            .x_desc("episode")
            .y_desc(format!(
                "return (mean over trials; {SMOOTHING_WINDOW}-episode moving average)"
            ))
            .axis_desc_style((FAMILY, AXIS_DESC_SIZE))
            .label_style((FAMILY, TICK_SIZE))
            .bold_line_style(GRID)
            .light_line_style(TRANSPARENT)
            .x_labels(10)
            .y_label_formatter(&|v| plain(*v))
            .draw()?;
        let colour = QLEARNING_COLOUR;
        let to_pixels = |line: &[(i64, f64)]| -> Vec<(i32, i32)> {
            line.iter().map(|p| chart.backend_coord(p)).collect()
        };
        polyline(
            root,
            target,
            to_pixels(&mean),
            colour.mix(FAINT).stroke_width(1),
            None,
        )?;
        polyline(
            root,
            target,
            to_pixels(&smoothed),
            colour.stroke_width(3),
            None,
        )?;
        if mean.len() == 1 {
            chart.draw_series(mean.iter().map(|&p| Circle::new(p, 3, colour.filled())))?;
        }
        let trials = match self.trials {
            1 => "1 trial".to_string(),
            n => format!("{n} trials"),
        };
        let entries = [
            Entry::new("mean return", Swatch::Faint(colour)),
            Entry::new(
                format!("moving avg, {SMOOTHING_WINDOW} ep."),
                Swatch::Line(colour),
            ),
            Entry::new(format!("Q(λ), {trials}"), Swatch::Note),
        ];
        legend(&legend_area, &entries)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{BestLander, FitnessPoint, Learning};
    use proptest::prelude::*;

    const PNG_SIGNATURE: [u8; 8] = [0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1a, b'\n'];

    fn record(method: &str, trial: u64, landed: bool, generations: u64) -> TrialRecord {
        let fitness = (1..=generations)
            .map(|g| {
                let last = g == generations && landed;
                FitnessPoint {
                    index: g,
                    restart: g / 50,
                    best: if last {
                        9_999_999.0
                    } else {
                        500.0 + 20.0 * g as f64
                    },
                    mean: if last {
                        100_300.0
                    } else {
                        200.0 + 8.0 * g as f64
                    },
                }
            })
            .collect();
        TrialRecord {
            method: method.to_string(),
            seed: 1,
            trial,
            x0: 100.0,
            pad_x: 200.0,
            landed,
            generations: Some(generations),
            restarts: Some(generations / 50),
            episodes: None,
            wall_s: 1.0,
            fitness,
            best: Some(BestLander {
                genome: "0:5".to_string(),
                fitness: if landed { 9_999_999.0 } else { 1234.0 },
                safe: landed,
                pad_x: 200.0,
            }),
            learning: None,
        }
    }

    fn learner(trial: u64, episodes: u32) -> TrialRecord {
        let returns = (0..episodes)
            .map(|e| -100.0 + f64::from(e) * 3.0 + f64::from(e % 7) * 10.0)
            .collect();
        TrialRecord {
            method: "qlearning".to_string(),
            seed: 1,
            trial,
            x0: 100.0,
            pad_x: 200.0,
            landed: true,
            generations: None,
            restarts: None,
            episodes: Some(episodes / 2),
            wall_s: 1.0,
            fitness: vec![],
            best: None,
            learning: Some(Learning {
                episodes,
                first_safe: Some(episodes / 2),
                landing_rate_last_100: 0.5,
                returns,
            }),
        }
    }

    fn sample() -> Vec<TrialRecord> {
        vec![
            record("ga", 1, true, 40),
            record("guided", 1, true, 12),
            record("ga", 2, false, 120),
            record("guided", 2, true, 30),
            record("ga", 3, true, 75),
            record("guided", 3, true, 9),
            learner(1, 300),
            learner(2, 250),
        ]
    }

    /// Width and height from the IHDR chunk, after checking the signature,
    /// and a full decode to be sure the image data is sound.
    fn png_size(png: &[u8]) -> (u32, u32) {
        assert_eq!(png[..8], PNG_SIGNATURE, "PNG signature");
        assert_eq!(&png[12..16], b"IHDR");
        let ihdr = (
            u32::from_be_bytes(png[16..20].try_into().unwrap()),
            u32::from_be_bytes(png[20..24].try_into().unwrap()),
        );
        let mut reader = png::Decoder::new(png).read_info().expect("PNG header");
        let mut buf = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buf).expect("PNG data");
        assert_eq!((info.width, info.height), ihdr);
        ihdr
    }

    fn check(plot: &Plot, texts: &[&str]) {
        let svg = plot.svg.trim_start();
        assert!(
            svg.starts_with("<svg"),
            "SVG starts with: {}",
            &svg[..40.min(svg.len())]
        );
        assert!(svg.trim_end().ends_with("</svg>"));
        for text in texts {
            assert!(plot.svg.contains(text), "SVG lacks {text:?}");
        }
        assert_eq!(png_size(&plot.png), (WIDTH, HEIGHT));
    }

    #[test]
    fn plots_generations_per_trial() {
        let plot = generations_per_trial(&sample()).unwrap();
        check(
            &plot,
            &[
                "Generations to a safe landing",
                "general GA",
                "guided GA",
                "did not land",
                "trial",
            ],
        );
    }

    #[test]
    fn plots_fitness_per_generation() {
        let plot = fitness_per_generation(&sample(), 2).unwrap();
        check(
            &plot,
            &[
                "trial 2",
                "general GA best",
                "general GA mean",
                "guided GA best",
                "guided GA mean",
                "safe landing",
                "(fitness 9,999,999)",
                "symlog",
                "10M",
            ],
        );
    }

    #[test]
    fn fitness_handles_a_method_without_records() {
        let records: Vec<_> = sample()
            .into_iter()
            .filter(|r| r.method != "guided")
            .collect();
        let plot = fitness_per_generation(&records, 1).unwrap();
        check(&plot, &["general GA best", "guided GA: no data"]);
    }

    #[test]
    fn plots_learning_curve() {
        let plot = learning_curve(&sample()).unwrap();
        check(
            &plot,
            &[
                "Q(λ) learning curve",
                "mean return",
                "moving avg, 100 ep.",
                "2 trials",
            ],
        );
    }

    #[test]
    fn empty_inputs_draw_no_data() {
        let none: Vec<TrialRecord> = vec![];
        let plot = generations_per_trial(&none).unwrap();
        check(&plot, &["no data: no GA trial records"]);
        let plot = fitness_per_generation(&none, 1).unwrap();
        check(&plot, &["no data: no GA records for trial 1"]);
        let plot = fitness_per_generation(&sample(), 99).unwrap();
        check(&plot, &["no data: no GA records for trial 99"]);
        let plot = learning_curve(&none).unwrap();
        check(&plot, &["no data: no Q-learning records"]);
        // Records of the wrong kind count as none.
        let learners = vec![learner(1, 10)];
        check(&generations_per_trial(&learners).unwrap(), &["no data"]);
        let mut empty = learner(1, 0);
        empty.learning.as_mut().unwrap().returns.clear();
        let ga_only = vec![record("ga", 1, true, 3), empty];
        check(&learning_curve(&ga_only).unwrap(), &["no data"]);
    }

    #[test]
    fn odd_values_do_not_panic() {
        let mut r = record("ga", 1, false, 1);
        r.fitness[0].best = f64::NAN;
        r.fitness[0].mean = f64::INFINITY;
        r.generations = None;
        check(
            &fitness_per_generation(&[r.clone()], 1).unwrap(),
            &["no data"],
        );
        check(&generations_per_trial(&[r]).unwrap(), &["general GA"]);
        let one = record("guided", 5, true, 1);
        check(
            &fitness_per_generation(std::slice::from_ref(&one), 5).unwrap(),
            &["guided GA best"],
        );
        check(&generations_per_trial(&[one]).unwrap(), &["guided GA"]);
        let mut flat = learner(1, 1);
        flat.learning.as_mut().unwrap().returns = vec![5.0];
        check(&learning_curve(&[flat]).unwrap(), &["1 trial"]);
    }

    #[test]
    fn dashes_alternate_along_the_path() {
        let d = dashes(&[(0, 0), (50, 0), (50, 50)], 6.0, 4.0);
        assert_eq!(d.len(), 10);
        assert_eq!(d[0], vec![(0, 0), (6, 0)]);
        // The fifth dash turns the corner.
        assert_eq!(d[4], vec![(40, 0), (46, 0)]);
        assert_eq!(d[5], vec![(50, 0), (50, 6)]);
        assert!(dashes(&[], 6.0, 4.0).is_empty());
        assert!(dashes(&[(3, 3)], 6.0, 4.0).is_empty());
    }

    #[test]
    fn moving_average_is_trailing_and_skips_gaps() {
        let v = [Some(1.0), Some(3.0), None, Some(5.0), Some(7.0)];
        let m = moving_average(&v, 2);
        assert_eq!(
            m,
            vec![Some(1.0), Some(2.0), Some(3.0), Some(5.0), Some(6.0)]
        );
    }

    #[test]
    fn tick_labels_read_well() {
        assert_eq!(human(9_999_999.0), "10M");
        assert_eq!(human(1500.0), "1.5k");
        assert_eq!(human(-250.0), "-250");
        assert_eq!(human(-0.0), "0");
        assert_eq!(thousands(9_999_999.0), "9,999,999");
        assert_eq!(thousands(-1234.0), "-1,234");
        assert_eq!(thousands(12.0), "12");
        assert_eq!(plain(1000.0), "1,000");
        assert_eq!(plain(-0.25), "-0.25");
        assert_eq!(tint(RGBColor(0, 100, 255)), RGBColor(115, 170, 255));
        assert_eq!(symlog(9_999_999.0), 7.0);
        let ticks = symlog_ticks(symlog(300.0), symlog(9_999_999.0) + 0.1);
        let labels: Vec<_> = ticks.iter().map(|t| human(symlog_inverse(*t))).collect();
        assert_eq!(labels, ["1k", "10k", "100k", "1M", "10M"]);
        // A narrow range still gets ticks.
        assert!(symlog_ticks(symlog(1200.0), symlog(1300.0)).len() >= 2);
    }

    proptest! {
        #[test]
        fn symlog_is_monotonic(a in -1e9f64..1e9, b in -1e9f64..1e9) {
            let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
            prop_assert!(symlog(lo) <= symlog(hi));
            // Values apart by more than rounding map apart.
            if hi - lo > 1e-6 * hi.abs().max(1.0) {
                prop_assert!(symlog(lo) < symlog(hi));
            }
        }

        #[test]
        fn symlog_inverts(v in -1e9f64..1e9) {
            let back = symlog_inverse(symlog(v));
            prop_assert!((back - v).abs() <= 1e-9 * v.abs().max(1.0));
        }

        #[test]
        fn ticks_stay_in_range(a in -1e8f64..1e8, span in 0.05f64..10.0) {
            let lo = symlog(a);
            let hi = lo + span;
            let ticks = symlog_ticks(lo, hi);
            prop_assert!(!ticks.is_empty());
            prop_assert!(ticks.iter().all(|t| *t >= lo - 1e-9 && *t <= hi + 1e-9));
            prop_assert!(ticks.windows(2).all(|w| w[0] < w[1]));
        }
    }
}
