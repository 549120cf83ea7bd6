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

/// The heatmap's colour for a share from 0 to 1: viridis, sampled at five
/// stops and interpolated linearly, from dark purple (0) to yellow (1). It
/// is perceptually uniform, so equal steps in share look like equal steps
/// in colour, and it reads the same to colour-blind readers and in grey.
/// Values outside [0, 1] are clamped; NaN is the middle grey of no data.
pub(super) fn sequential(share: f64) -> RGBColor {
    const STOPS: [(u8, u8, u8); 5] = [
        (68, 1, 84),
        (59, 82, 139),
        (33, 145, 140),
        (94, 201, 98),
        (253, 231, 37),
    ];
    if share.is_nan() {
        return REFERENCE;
    }
    let position = share.clamp(0.0, 1.0) * (STOPS.len() - 1) as f64;
    let below = (position.floor() as usize).min(STOPS.len() - 2);
    let fraction = position - below as f64;
    let (a, b) = (STOPS[below], STOPS[below + 1]);
    let mix =
        |x: u8, y: u8| (f64::from(x) + fraction * (f64::from(y) - f64::from(x))).round() as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// Black or white, whichever reads better on `background` (by its luma).
pub(super) fn ink_on(background: RGBColor) -> RGBColor {
    let luma = 0.299 * f64::from(background.0)
        + 0.587 * f64::from(background.1)
        + 0.114 * f64::from(background.2);
    if luma > 140.0 {
        RGBColor(0, 0, 0)
    } else {
        RGBColor(255, 255, 255)
    }
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

    #[test]
    fn the_sequential_scale_runs_from_purple_to_yellow() {
        assert_eq!(sequential(0.0), RGBColor(68, 1, 84));
        assert_eq!(sequential(0.5), RGBColor(33, 145, 140));
        assert_eq!(sequential(1.0), RGBColor(253, 231, 37));
        // Halfway between the first two stops.
        assert_eq!(sequential(0.125), RGBColor(64, 42, 112));
        assert_eq!(sequential(-1.0), sequential(0.0));
        assert_eq!(sequential(2.0), sequential(1.0));
        assert_eq!(sequential(f64::NAN), REFERENCE);
        // Brighter as the share grows, so the order reads without a legend.
        let luma = |c: RGBColor| 299 * u32::from(c.0) + 587 * u32::from(c.1) + 114 * u32::from(c.2);
        let steps: Vec<u32> = (0..=20)
            .map(|i| luma(sequential(f64::from(i) / 20.0)))
            .collect();
        assert!(steps.windows(2).all(|w| w[0] < w[1]), "{steps:?}");
        assert_eq!(ink_on(sequential(0.0)), RGBColor(255, 255, 255));
        assert_eq!(ink_on(sequential(1.0)), RGBColor(0, 0, 0));
    }
}
