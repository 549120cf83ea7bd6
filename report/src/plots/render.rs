//! One drawing, two backends: [`render`] draws a [`Figure`] once on
//! plotters' SVG backend and once on its bitmap backend, and encodes the
//! bitmap as PNG. Also here: the embedded font, the frame every figure
//! shares (white ground, title, legend panel), the "no data" notice, and
//! data lines drawn so that both backends show them alike ([`polyline`]).
//!
//! Text in the PNG is rasterised with DejaVu Sans, embedded from
//! `report/assets/DejaVuSans.ttf` (license alongside it) and registered with
//! plotters once per process; the SVG names the `sans-serif` family and
//! leaves rendering to the viewer, but plotters measures its text with the
//! same font, so both outputs lay out alike.

use super::style::{FAMILY, LEGEND_WIDTH, MESSAGE_SIZE, REFERENCE, TITLE_SIZE};
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

const FONT: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");

/// Registers the embedded font as plotters' `sans-serif`, once.
fn font_ready() -> bool {
    static READY: OnceLock<bool> = OnceLock::new();
    *READY.get_or_init(|| register_font(FAMILY, FontStyle::Normal, FONT).is_ok())
}

/// Which output a drawing is for. Only data lines differ: see [`polyline`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Target {
    Svg,
    Png,
}

/// A figure that can draw itself on any plotters backend.
pub(super) trait Figure {
    /// Names the figure in errors.
    const NAME: &'static str;
    fn draw<DB: DrawingBackend>(&self, root: &Area<DB>, target: Target) -> DrawResult<(), DB>;
}

pub(super) fn render<F: Figure>(figure: &F) -> Result<Plot, PlotError> {
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
pub(super) type Area<DB> = DrawingArea<DB, Shift>;

/// White background and the title; returns the chart area and, to its
/// right, the legend panel.
pub(super) fn frame<DB: DrawingBackend>(
    root: &Area<DB>,
    title: &str,
) -> DrawResult<(Area<DB>, Area<DB>), DB> {
    root.fill(&WHITE)?;
    let body = root.titled(title, (FAMILY, TITLE_SIZE))?;
    let (w, _) = body.dim_in_pixel();
    Ok(body.split_horizontally(w.saturating_sub(LEGEND_WIDTH) as i32))
}

/// The "no data" notice, centred in the figure.
pub(super) fn no_data<DB: DrawingBackend>(root: &Area<DB>, why: &str) -> DrawResult<(), DB> {
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
pub(super) fn polyline<DB: DrawingBackend>(
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
