//! The report's figures, drawn from trial records: generations to a safe
//! landing per trial (the paper's Figure 3), best and mean fitness per
//! generation in one trial (Figure 4), and the Q(λ) baseline's learning
//! curve; and a sweep's figures, drawn from its table
//! ([`SweepSummary`](crate::sweep::SweepSummary)) one grid at a time.
//!
//! Every figure comes back as a [`Plot`]: the same drawing as an SVG
//! document and as PNG bytes, 800×500 pixels. Nothing here touches the
//! file system; the caller decides where the bytes go.
//!
//! Colours follow the method everywhere (Okabe–Ito, safe for colour-blind
//! readers; see [`colour`]): general GA [`GA_COLOUR`] blue, guided GA
//! [`GUIDED_COLOUR`] vermillion, Q(λ) [`QLEARNING_COLOUR`] bluish green, and
//! each method is named by its [`Method::label`](crate::model::Method::label).
//! Each legend sits in a panel to the right of the chart so it never hides
//! data.
//!
//! Empty input is not an error: a figure with nothing to show is still
//! drawn, with its title and a centred "no data: …" line saying what was
//! missing, so a report always has something to put in its place. A
//! [`PlotError`] means drawing or PNG encoding itself failed.
//!
//! Text in the PNG is rasterised with DejaVu Sans, embedded from
//! `report/assets/DejaVuSans.ttf`; the SVG leaves it to the viewer's
//! `sans-serif` (see `render`).
//!
//! The parts, one file each:
//!
//! - `fig3`: [`generations_per_trial`], Figure 3.
//! - `fig4`: [`fitness_per_generation`], Figure 4.
//! - `learning`: [`learning_curve`], the Q(λ) learning curve.
//! - `sweep`: for a grid of one key, [`share_against`] (the share of pairs
//!   the guided GA won) and [`generations_against`] (each GA's median
//!   generations), with bootstrap intervals as whiskers; the categorical
//!   axis every sweep figure uses.
//! - `heatmap`: for a grid of two keys, [`heatmap`] of the share won.
//! - `render`: one drawing, two backends (SVG and PNG), the embedded font,
//!   the frame and the data lines every figure shares.
//! - `legend`: the legend panel.
//! - `axis`: the [`symlog`] scale, its ticks and the tick labels.
//! - `style`: colours, shades, the heatmap's sequential scale and text
//!   sizes.

mod axis;
mod fig3;
mod fig4;
mod heatmap;
mod learning;
mod legend;
mod render;
mod style;
mod sweep;
#[cfg(test)]
mod tests;

pub(crate) use axis::thousands;
pub use axis::{symlog, symlog_inverse};
pub use fig3::generations_per_trial;
pub use fig4::fitness_per_generation;
pub use heatmap::heatmap;
pub use learning::{learning_curve, SMOOTHING_WINDOW};
pub use render::{Plot, PlotError, HEIGHT, WIDTH};
pub use style::{colour, GA_COLOUR, GUIDED_COLOUR, QLEARNING_COLOUR};
pub use sweep::{generations_against, share_against};
