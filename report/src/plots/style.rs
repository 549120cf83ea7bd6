//! How the figures look: the colour of each method, the shades and greys
//! around the data, and the typeface sizes. A method's name on a figure is
//! its [`Method::label`]; its colour is [`colour`].

use crate::model::Method;
use plotters::style::RGBColor;

/// The general GA (`ga`): Okabe–Ito blue.
pub const GA_COLOUR: RGBColor = RGBColor(0, 114, 178);
/// The guided GA (`guided`): Okabe–Ito vermillion.
pub const GUIDED_COLOUR: RGBColor = RGBColor(213, 94, 0);
/// Q(λ) (`qlearning`): Okabe–Ito bluish green.
pub const QLEARNING_COLOUR: RGBColor = RGBColor(0, 158, 115);

/// The colour a method has on every plot.
pub fn colour(method: Method) -> RGBColor {
    match method {
        Method::Ga => GA_COLOUR,
        Method::Guided => GUIDED_COLOUR,
        Method::Qlearning => QLEARNING_COLOUR,
    }
}

/// `c` mixed 45% of the way to white: the lighter shade a mean is drawn in.
pub(super) fn tint(c: RGBColor) -> RGBColor {
    let mix = |v: u8| v + ((255 - v) as f64 * 0.45).round() as u8;
    RGBColor(mix(c.0), mix(c.1), mix(c.2))
}

/// The font family every text is set in: the embedded DejaVu Sans in the
/// PNG (see [`super::render`]), the viewer's sans-serif in the SVG.
pub(super) const FAMILY: &str = "sans-serif";
/// Width of the legend panel right of the chart, in pixels.
pub(super) const LEGEND_WIDTH: u32 = 190;
pub(super) const TITLE_SIZE: i32 = 22;
pub(super) const AXIS_DESC_SIZE: i32 = 16;
pub(super) const TICK_SIZE: i32 = 13;
pub(super) const LEGEND_SIZE: i32 = 14;
pub(super) const MESSAGE_SIZE: i32 = 18;
/// Opacity of the learning curve's unsmoothed line.
pub(super) const FAINT: f64 = 0.3;
/// The grid lines behind the data.
pub(super) const GRID: RGBColor = RGBColor(225, 225, 225);
/// Everything that is not data: the safe-landing line, notes, "no data".
pub(super) const REFERENCE: RGBColor = RGBColor(110, 110, 110);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_method_has_its_own_colour() {
        assert_eq!(colour(Method::Ga), GA_COLOUR);
        assert_eq!(colour(Method::Guided), GUIDED_COLOUR);
        assert_eq!(colour(Method::Qlearning), QLEARNING_COLOUR);
    }
}
