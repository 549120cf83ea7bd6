//! The Q(λ) baseline's learning curve: the mean return per episode over the
//! trials, and its moving average.

use super::axis::plain;
use super::legend::{legend, Entry, Swatch};
use super::render::{frame, no_data, polyline, render, Area, Figure, Plot, PlotError, Target};
use super::style::{AXIS_DESC_SIZE, FAINT, FAMILY, GRID, QLEARNING_COLOUR, TICK_SIZE};
use crate::model::TrialRecord;
use plotters::prelude::*;

/// Episodes in the learning curve's moving average.
pub const SMOOTHING_WINDOW: usize = 100;

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

    #[test]
    fn moving_average_is_trailing_and_skips_gaps() {
        let v = [Some(1.0), Some(3.0), None, Some(5.0), Some(7.0)];
        let m = moving_average(&v, 2);
        assert_eq!(
            m,
            vec![Some(1.0), Some(2.0), Some(3.0), Some(5.0), Some(6.0)]
        );
    }
}
