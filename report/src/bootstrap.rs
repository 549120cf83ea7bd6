//! Percentile bootstrap confidence intervals: how far a median or a share
//! computed from a handful of trials might move if the experiment were run
//! again. A sweep quotes one beside every median and every share of pairs
//! won, so that settings are compared by more than their point estimates.
//!
//! The resamples come from a seeded ChaCha8 stream, so an interval is a pure
//! function of the sample, the statistic, the resample count, the level and
//! the seed: the same inputs give the same interval on every machine and in
//! every build.

use crate::stats::{mean, median, quantile};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// A confidence interval: the statistic lies in `[low, high]` with the
/// interval's level of confidence.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Interval {
    pub low: f64,
    pub high: f64,
}

/// Resamples behind [`median_interval`] and [`share_interval`]. At 10,000
/// the Monte Carlo error of a 95% interval's ends is small beside their
/// sampling error for the sample sizes a sweep has (tens of trials), and a
/// setting's three intervals still take milliseconds.
pub const RESAMPLES: usize = 10_000;

/// The confidence level of [`median_interval`] and [`share_interval`].
pub const LEVEL: f64 = 0.95;

/// The bootstrap distribution of `statistic` over `xs`: `resamples` samples
/// of `xs.len()` values drawn from `xs` with replacement, each index by
/// `rng.random_range(0..n)` from `ChaCha8Rng::seed_from_u64(seed)`, and the
/// statistic of each, in the order drawn.
///
/// `None` if `xs` is empty or holds a NaN (no statistic of ours orders
/// one), if `resamples` is 0, or if the statistic has no value for some
/// resample: a distribution with holes would bias every quantile of it.
pub fn bootstrap_distribution(
    xs: &[f64],
    statistic: impl Fn(&[f64]) -> Option<f64>,
    resamples: usize,
    seed: u64,
) -> Option<Vec<f64>> {
    let n = xs.len();
    if n == 0 || resamples == 0 || xs.iter().any(|x| x.is_nan()) {
        return None;
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut resample = vec![0.0; n];
    let mut out = Vec::with_capacity(resamples);
    for _ in 0..resamples {
        for slot in &mut resample {
            *slot = *xs.get(rng.random_range(0..n))?;
        }
        out.push(statistic(&resample)?);
    }
    Some(out)
}

/// The percentile bootstrap interval of `statistic` over `xs` at `level`:
/// the `(1 − level)/2` and `1 − (1 − level)/2` type-7 quantiles
/// ([`quantile`]) of [`bootstrap_distribution`]. It assumes nothing about
/// the shape of the sample's distribution, which generation counts (skewed,
/// with a long tail of slow trials) do not have a convenient one of.
///
/// `None` where [`bootstrap_distribution`] is, if `level` is not strictly
/// between 0 and 1, or if a resample's statistic is NaN.
pub fn percentile_interval(
    xs: &[f64],
    statistic: impl Fn(&[f64]) -> Option<f64>,
    resamples: usize,
    level: f64,
    seed: u64,
) -> Option<Interval> {
    // Written so that a NaN level fails too.
    if !(level > 0.0 && level < 1.0) {
        return None;
    }
    let mut distribution = bootstrap_distribution(xs, statistic, resamples, seed)?;
    distribution.sort_by(f64::total_cmp);
    let tail = (1.0 - level) / 2.0;
    Some(Interval {
        low: quantile(&distribution, tail)?,
        high: quantile(&distribution, 1.0 - tail)?,
    })
}

/// The [`LEVEL`] interval of the median of `xs` ([`median`], so an even
/// count takes the mean of the middle two), over [`RESAMPLES`] resamples.
pub fn median_interval(xs: &[f64], seed: u64) -> Option<Interval> {
    percentile_interval(xs, median, RESAMPLES, LEVEL, seed)
}

/// The [`LEVEL`] interval of the share of `true` in `wins`, over
/// [`RESAMPLES`] resamples. `None` for no wins and no losses.
pub fn share_interval(wins: &[bool], seed: u64) -> Option<Interval> {
    let indicators: Vec<f64> = wins.iter().map(|&w| f64::from(u8::from(w))).collect();
    percentile_interval(&indicators, mean, RESAMPLES, LEVEL, seed)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn within(interval: Interval, x: f64) -> bool {
        interval.low <= x && x <= interval.high
    }

    #[test]
    fn nothing_to_resample_gives_no_interval() {
        assert_eq!(median_interval(&[], 1), None);
        assert_eq!(share_interval(&[], 1), None);
        assert_eq!(median_interval(&[1.0, f64::NAN], 1), None);
        assert_eq!(percentile_interval(&[1.0, 2.0], median, 0, 0.95, 1), None);
        for level in [0.0, 1.0, -0.5, 1.5, f64::NAN] {
            assert_eq!(
                percentile_interval(&[1.0, 2.0], median, 100, level, 1),
                None,
                "level {level}"
            );
        }
        // A statistic without a value for some resample spoils the whole.
        assert_eq!(
            percentile_interval(&[1.0, 2.0], |_| None, 100, 0.95, 1),
            None
        );
    }

    #[test]
    fn a_constant_sample_gives_a_point() {
        let xs = [7.5; 12];
        assert_eq!(
            median_interval(&xs, 3),
            Some(Interval {
                low: 7.5,
                high: 7.5
            })
        );
        assert_eq!(
            median_interval(&[42.0], 3),
            Some(Interval {
                low: 42.0,
                high: 42.0
            })
        );
        assert_eq!(
            share_interval(&[true; 9], 3),
            Some(Interval {
                low: 1.0,
                high: 1.0
            })
        );
        assert_eq!(
            share_interval(&[false; 4], 3),
            Some(Interval {
                low: 0.0,
                high: 0.0
            })
        );
    }

    #[test]
    fn two_values_give_three_medians() {
        // Resamples of [0, 1] are (0, 0), (0, 1), (1, 0), (1, 1), each with
        // probability ¼, with medians 0, ½, ½, 1. Of 10,000 draws about
        // 2,500 are 0 and 2,500 are 1, so the 2.5% and 97.5% quantiles
        // (order statistics near 250 and 9,750) are 0 and 1 exactly.
        let xs = [0.0, 1.0];
        let Some(distribution) = bootstrap_distribution(&xs, median, RESAMPLES, 11) else {
            panic!("a sample of two has a distribution");
        };
        assert_eq!(distribution.len(), RESAMPLES);
        assert!(distribution
            .iter()
            .all(|&m| m == 0.0 || m == 0.5 || m == 1.0));
        let share = |value: f64| {
            distribution.iter().filter(|&&m| m == value).count() as f64 / RESAMPLES as f64
        };
        // Binomial standard error at 10,000 draws is 0.005; 0.02 is four of them.
        assert!((share(0.5) - 0.5).abs() < 0.02, "{}", share(0.5));
        assert!((share(0.0) - 0.25).abs() < 0.02, "{}", share(0.0));
        assert_eq!(
            median_interval(&xs, 11),
            Some(Interval {
                low: 0.0,
                high: 1.0
            })
        );
    }

    #[test]
    fn the_seed_decides_the_draws() {
        let xs = [3.0, 1.0, 4.0, 1.0, 5.0, 9.0, 2.0, 6.0];
        let a = bootstrap_distribution(&xs, median, 200, 5);
        assert_eq!(a, bootstrap_distribution(&xs, median, 200, 5));
        assert_ne!(a, bootstrap_distribution(&xs, median, 200, 6));
        assert_eq!(median_interval(&xs, 5), median_interval(&xs, 5));
        // The interval for one sample and seed, pinned: it fixes the whole
        // chain (ChaCha8's stream from seed_from_u64, random_range's way of
        // drawing an index, the order of the draws, the quantile), so a
        // sweep's table comes out byte for byte the same from every build.
        // If a dependency update changes it, old sweeps no longer
        // reproduce: say so in the change rather than re-pin in silence.
        assert_eq!(
            median_interval(&xs, 5),
            Some(Interval {
                low: 1.0,
                high: 6.0
            })
        );
        // The mean takes many more values than the median, so its interval
        // and first draws pin the stream more tightly.
        assert_eq!(
            percentile_interval(&xs, mean, RESAMPLES, LEVEL, 5),
            Some(Interval {
                low: 2.125,
                high: 5.75
            })
        );
        assert_eq!(
            bootstrap_distribution(&xs, mean, 3, 5),
            Some(vec![3.0, 4.375, 2.875])
        );
    }

    /// `count` draws from the exponential distribution with rate 1 (median
    /// ln 2), by its inverse CDF −ln(1 − u) with u uniform in [0, 1).
    fn exponential(rng: &mut ChaCha8Rng, count: usize) -> Vec<f64> {
        (0..count)
            .map(|_| -(1.0 - rng.random::<f64>()).ln())
            .collect()
    }

    /// The share of `runs` samples of 40 whose 95% interval (1,000
    /// resamples) covers the truth. Each run has its own bootstrap seed, so
    /// that the runs are independent.
    fn coverage(runs: u64, mut covers: impl FnMut(u64) -> bool) -> f64 {
        (0..runs).filter(|&run| covers(run)).count() as f64 / runs as f64
    }

    #[test]
    fn the_median_interval_covers_the_true_median_about_95_percent_of_the_time() {
        let truth = std::f64::consts::LN_2;
        let mut data = ChaCha8Rng::seed_from_u64(2024);
        let covered = coverage(400, |run| {
            let xs = exponential(&mut data, 40);
            percentile_interval(&xs, median, 1_000, LEVEL, 1_000 + run)
                .is_some_and(|i| within(i, truth))
        });
        // At 400 runs a true 95% has a standard error of about 0.011: the
        // band is four of them either side, and the bootstrap of a median
        // at n = 40 is known to come out a little off 95%.
        assert!((0.90..=0.99).contains(&covered), "coverage {covered}");
    }

    #[test]
    fn the_share_interval_covers_the_true_share_about_95_percent_of_the_time() {
        let truth = 0.7;
        let mut data = ChaCha8Rng::seed_from_u64(7);
        let covered = coverage(400, |run| {
            let wins: Vec<f64> = (0..40)
                .map(|_| f64::from(u8::from(data.random::<f64>() < truth)))
                .collect();
            percentile_interval(&wins, mean, 1_000, LEVEL, 5_000 + run)
                .is_some_and(|i| within(i, truth))
        });
        assert!((0.90..=0.99).contains(&covered), "coverage {covered}");
    }

    #[test]
    fn an_interval_holds_the_point_estimate_of_a_skewed_sample() {
        let xs = [12.0, 15.0, 9.0, 40.0, 11.0, 13.0, 200.0, 14.0, 10.0];
        let Some(i) = median_interval(&xs, 9) else {
            panic!("a sample has an interval");
        };
        let Some(m) = median(&xs) else {
            panic!("a sample has a median");
        };
        assert!(i.low <= m && m <= i.high, "{i:?} around {m}");
        // Resampled medians are values of the sample (odd n).
        assert!(xs.contains(&i.low) && xs.contains(&i.high));
        assert!(i.low < i.high);
    }
}
