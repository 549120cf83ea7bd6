//! The legend panel right of every chart: one [`Entry`] per row, a
//! [`Swatch`] of the line or marker it stands for, then its label. It has
//! its own panel, so it never hides data.

use super::render::Area;
use super::style::{FAINT, FAMILY, LEGEND_SIZE, REFERENCE};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// What a legend entry's sample looks like.
pub(super) enum Swatch {
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
    /// A filled point marker on a vertical whisker: an estimate and its
    /// interval.
    Interval(RGBColor),
    /// A hollow point marker.
    Hollow(RGBColor),
    /// No sample: the label is a note.
    Note,
}

/// One row of a legend.
pub(super) struct Entry {
    label: String,
    swatch: Swatch,
}

impl Entry {
    pub(super) fn new(label: impl Into<String>, swatch: Swatch) -> Entry {
        Entry {
            label: label.into(),
            swatch,
        }
    }
}

/// The legend: one row per entry down the panel, sample then label.
pub(super) fn legend<DB: DrawingBackend>(area: &Area<DB>, entries: &[Entry]) -> DrawResult<(), DB> {
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
            Swatch::Interval(c) => {
                let whisker = vec![(mid, y - 9), (mid, y + 9)];
                area.draw(&PathElement::new(whisker, c.stroke_width(2)))?;
                area.draw(&Circle::new((mid, y), 4, c.filled()))?;
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
