//! The numbers the paper experiment's summary reports: the mean, median and
//! quartiles of a method's trials, and the Wilcoxon signed-rank test that
//! says whether two methods differ when run on the same trials (same seed,
//! start and pad, so the samples are paired).
//!
//! Every function is pure and total: empty or unusable input gives `None`,
//! never a panic, so a half-finished experiment can still be summarised.

use serde::{Deserialize, Serialize};

/// The arithmetic mean, `None` for an empty sample. A NaN in the sample makes
/// the mean NaN, as IEEE arithmetic does (unlike [`median`], which needs an
/// order and so refuses NaN).
pub fn mean(xs: &[f64]) -> Option<f64> {
    if xs.is_empty() {
        return None;
    }
    Some(xs.iter().sum::<f64>() / xs.len() as f64)
}

/// The median: the middle value, or the mean of the two middle values for an
/// even count (type-7 [`quantile`] at ½). `None` for an empty sample or one
/// holding a NaN, which has no place in an order.
pub fn median(xs: &[f64]) -> Option<f64> {
    quantile(&sorted_without_nan(xs)?, 0.5)
}

/// The lower quartile, median and upper quartile of a sample: the box of a
/// box plot and the spread the summary table quotes.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Quartiles {
    pub q1: f64,
    pub median: f64,
    pub q3: f64,
}

/// The quartiles of a sample by [`quantile`] (Hyndman–Fan type 7), so they
/// match R's `quantile` and numpy's `percentile` defaults and a reader can
/// reproduce them. `None` for an empty sample or one holding a NaN.
pub fn quartiles(xs: &[f64]) -> Option<Quartiles> {
    let sorted = sorted_without_nan(xs)?;
    Some(Quartiles {
        q1: quantile(&sorted, 0.25)?,
        median: quantile(&sorted, 0.5)?,
        q3: quantile(&sorted, 0.75)?,
    })
}

/// The `p`-quantile of an ascending sample, interpolating linearly between
/// order statistics: with `h = (n − 1)·p` and `x` indexed from 0, it is
/// `x[⌊h⌋] + (h − ⌊h⌋)·(x[⌊h⌋+1] − x[⌊h⌋])`. This is Hyndman and Fan's
/// (1996) type 7, the default of R's `quantile` and numpy's `percentile`; of
/// the common definitions it is the one readers are most likely to check our
/// numbers against.
///
/// `None` if the sample is empty, `p` is outside `[0, 1]`, the sample is
/// not ascending (a NaN counts as out of order: a quantile of unsorted data
/// would be silently wrong, and the check costs one pass), or the quantile
/// falls strictly between −∞ and +∞.
pub fn quantile(sorted: &[f64], p: f64) -> Option<f64> {
    if sorted.is_empty() || !(0.0..=1.0).contains(&p) || !sorted.is_sorted_by(|x, y| x <= y) {
        return None;
    }
    let position = p * (sorted.len() - 1) as f64;
    let below = position.floor() as usize;
    let fraction = position - below as f64;
    let low = *sorted.get(below)?;
    match sorted.get(below + 1) {
        // `high == low` also keeps two equal infinities from giving NaN.
        Some(&high) if fraction > 0.0 && high != low => between(low, high, fraction),
        _ => Some(low),
    }
}

/// The point `fraction` of the way from `low` to `high` (`low < high`).
/// From −∞ to a finite neighbour it is −∞, where `low + fraction·(high −
/// low)` would be −∞ + ∞; from −∞ to +∞ there is none.
fn between(low: f64, high: f64, fraction: f64) -> Option<f64> {
    if low == f64::NEG_INFINITY {
        return (high != f64::INFINITY).then_some(low);
    }
    Some(low + fraction * (high - low))
}

/// A copy of the sample in ascending order, `None` if it is empty or holds a
/// NaN.
fn sorted_without_nan(xs: &[f64]) -> Option<Vec<f64>> {
    if xs.is_empty() || xs.iter().any(|x| x.is_nan()) {
        return None;
    }
    let mut sorted = xs.to_vec();
    sorted.sort_by(f64::total_cmp);
    Some(sorted)
}

/// Up to this many non-zero differences [`wilcoxon_signed_rank`] computes the
/// exact p-value; beyond it, the normal approximation. 2^50 sign patterns
/// still count exactly in a `u64` (and in an `f64`, below 2^53), and by 50
/// pairs the normal approximation is good.
pub const WILCOXON_EXACT_MAX_PAIRS: usize = 50;

/// The outcome of a two-sided Wilcoxon signed-rank test on paired samples.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Wilcoxon {
    /// Pairs with a non-zero difference: the pairs the test ranks.
    pub n: usize,
    /// Pairs with a zero difference, dropped before ranking.
    pub zeros: usize,
    /// Sum of the ranks of the positive differences `a − b`.
    pub w_plus: f64,
    /// Sum of the ranks of the negative differences `a − b`.
    pub w_minus: f64,
    /// `min(w_plus, w_minus)`, the statistic tables and scipy report.
    pub statistic: f64,
    /// Two-sided p-value: how often, if neither sample tends to be larger, a
    /// sign assignment at least as lopsided as this one would turn up.
    pub p_value: f64,
    /// Whether `p_value` is exact (`n ≤ WILCOXON_EXACT_MAX_PAIRS`) or the
    /// normal approximation.
    pub exact: bool,
}

/// The Wilcoxon signed-rank test of whether paired samples differ in
/// location: `a[i]` and `b[i]` are two methods' results on the same trial.
/// Unlike the paired t-test it does not assume normal differences, which
/// generation counts and fitness need not have.
///
/// The differences `d = a − b` that are zero are dropped (Wilcoxon's original
/// method, scipy's default `zero_method="wilcox"`), the rest are ranked by
/// `|d|` with ties given their average rank, and `W+`/`W−` sum the ranks of
/// the positive/negative differences.
///
/// For `n ≤ WILCOXON_EXACT_MAX_PAIRS` the p-value is exact: it counts, over
/// all 2^n ways of signing the observed ranks, those with `W+` at most and at
/// least the observed one, and gives `min(1, 2·min(P(W+ ≤ w), P(W+ ≥ w)))`.
/// That is the exact permutation distribution conditional on the ranks, so it
/// stays valid with tied ranks (where tables and scipy's `method="exact"`
/// are only approximate). For larger `n` it is the normal approximation with
/// the tie-corrected variance and a continuity correction, flagged
/// `exact: false`; it underflows to 0 only for z beyond about 38.
///
/// `None` if the samples differ in length, a difference is NaN, or no
/// difference is non-zero (nothing to test).
pub fn wilcoxon_signed_rank(a: &[f64], b: &[f64]) -> Option<Wilcoxon> {
    if a.len() != b.len() {
        return None;
    }
    let differences: Vec<f64> = a.iter().zip(b).map(|(x, y)| x - y).collect();
    if differences.iter().any(|d| d.is_nan()) {
        return None;
    }
    let nonzero: Vec<f64> = differences.iter().copied().filter(|&d| d != 0.0).collect();
    let n = nonzero.len();
    if n == 0 {
        return None;
    }
    let zeros = differences.len() - n;

    let magnitudes: Vec<f64> = nonzero.iter().map(|d| d.abs()).collect();
    let ranks = doubled_average_ranks(&magnitudes);
    let doubled_total: u64 = ranks.doubled.iter().sum();
    let doubled_w_plus: u64 = ranks
        .doubled
        .iter()
        .zip(&nonzero)
        .filter(|(_, &d)| d > 0.0)
        .map(|(&rank, _)| rank)
        .sum();
    let w_plus = doubled_w_plus as f64 / 2.0;
    let w_minus = (doubled_total - doubled_w_plus) as f64 / 2.0;

    let exact = n <= WILCOXON_EXACT_MAX_PAIRS;
    let p_value = if exact {
        exact_two_sided_p(&ranks.doubled, doubled_w_plus)
    } else {
        normal_two_sided_p(n, &ranks.tie_sizes, w_plus)
    };
    Some(Wilcoxon {
        n,
        zeros,
        w_plus,
        w_minus,
        statistic: w_plus.min(w_minus),
        p_value,
        exact,
    })
}

/// Ranks of a sample, doubled so that average ranks of ties stay integers
/// (an average of consecutive ranks is a whole or half number).
struct DoubledRanks {
    /// Twice each value's rank (1-based, ties averaged), in input order.
    doubled: Vec<u64>,
    /// The size of every group of equal values, singletons included.
    tie_sizes: Vec<usize>,
}

/// Ranks `values` (which must hold no NaN) with ties given their average rank.
fn doubled_average_ranks(values: &[f64]) -> DoubledRanks {
    let mut order: Vec<usize> = (0..values.len()).collect();
    order.sort_by(|&i, &j| values[i].total_cmp(&values[j]));
    let mut doubled = vec![0; values.len()];
    let mut tie_sizes = Vec::new();
    let mut start = 0;
    while start < order.len() {
        let value = values[order[start]];
        let end = start
            + order[start..]
                .iter()
                .take_while(|&&i| values[i] == value)
                .count();
        // Sorted positions start..end hold ranks start+1..=end, averaging
        // (start + 1 + end) / 2.
        let group_rank = (start + 1 + end) as u64;
        for &i in &order[start..end] {
            doubled[i] = group_rank;
        }
        tie_sizes.push(end - start);
        start = end;
    }
    DoubledRanks { doubled, tie_sizes }
}

/// The exact two-sided p-value of an observed `W+` (doubled) given the
/// doubled ranks, by dynamic programming over sums: `ways[s]` counts the sign
/// assignments whose doubled `W+` is `s`. Counts never exceed 2^n, so for
/// n ≤ 50 they fit a `u64` exactly, and `2·min(...) ≤ 2^51` converts to `f64`
/// exactly; dividing by 2^n is exact too, so the p-value is the exact
/// fraction. Cost is O(n · n(n+1)), about 10^5 steps at n = 50.
fn exact_two_sided_p(doubled_ranks: &[u64], doubled_w_plus: u64) -> f64 {
    let doubled_total: u64 = doubled_ranks.iter().sum();
    let mut ways = vec![0u64; doubled_total as usize + 1];
    ways[0] = 1;
    let mut reachable = 0;
    for &rank in doubled_ranks {
        let rank = rank as usize;
        reachable += rank;
        for sum in (rank..=reachable).rev() {
            ways[sum] += ways[sum - rank];
        }
    }
    let observed = doubled_w_plus as usize;
    let at_most: u64 = ways[..=observed].iter().sum();
    let at_least: u64 = ways[observed..].iter().sum();
    let patterns = 2f64.powi(doubled_ranks.len() as i32);
    (2.0 * at_most.min(at_least) as f64 / patterns).min(1.0)
}

/// The two-sided p-value of `W+` by the normal approximation: mean
/// n(n+1)/4, variance n(n+1)(2n+1)/24 − Σ(t³ − t)/48 over tie groups of size
/// t, and the distance from the mean shrunk by ½ for continuity. As scipy's
/// `method="approx", correction=True`, except that a distance under ½ gives
/// z = 0 (p = 1) where scipy overshoots to the other side.
fn normal_two_sided_p(n: usize, tie_sizes: &[usize], w_plus: f64) -> f64 {
    let n = n as f64;
    let mean = n * (n + 1.0) / 4.0;
    let tie_correction: f64 = tie_sizes
        .iter()
        .map(|&size| {
            let t = size as f64;
            t * t * t - t
        })
        .sum();
    // Positive for n ≥ 1: even one tie group of all n leaves n(n+1)²/16.
    let variance = n * (n + 1.0) * (2.0 * n + 1.0) / 24.0 - tie_correction / 48.0;
    let z = ((w_plus - mean).abs() - 0.5).max(0.0) / variance.sqrt();
    // P(|Z| ≥ z) = erfc(z/√2).
    erfc(z / std::f64::consts::SQRT_2).min(1.0)
}

/// The complementary error function erfc(x) = 1 − erf(x), to about 1e-15
/// relative for x ≥ 0. Written here because std has none and one function
/// does not justify a dependency. Below 1.5 it is 1 − erf by a series; from
/// 1.5 a continued fraction keeps the small tail accurate.
fn erfc(x: f64) -> f64 {
    if x.is_nan() {
        f64::NAN
    } else if x < 0.0 {
        2.0 - erfc(-x)
    } else if x < 1.5 {
        1.0 - erf_series(x)
    } else {
        erfc_continued_fraction(x)
    }
}

/// erf(x) = (2/√π)·e^(−x²)·Σ_{k≥0} (2x²)^k·x / (1·3·…·(2k+1))
/// (Abramowitz & Stegun 7.1.6): every term is positive, so nothing cancels.
/// Under 30 terms for 0 ≤ x < 1.5.
fn erf_series(x: f64) -> f64 {
    let two_x_squared = 2.0 * x * x;
    let mut term = x;
    let mut sum = x;
    for k in 1..200 {
        term *= two_x_squared / f64::from(2 * k + 1);
        sum += term;
        if term <= sum * f64::EPSILON {
            break;
        }
    }
    2.0 / std::f64::consts::PI.sqrt() * (-x * x).exp() * sum
}

/// erfc(x) = e^(−x²)/√π · 1/(x + ½/(x + 1/(x + (3/2)/(x + 2/(x + …)))))
/// (Abramowitz & Stegun 7.1.14), evaluated by Lentz's method. Under 100
/// terms for x ≥ 1.5.
fn erfc_continued_fraction(x: f64) -> f64 {
    const TINY: f64 = 1e-300;
    let mut fraction = x;
    let mut c = x;
    let mut d = 0.0;
    for k in 1..1000 {
        let a = f64::from(k) / 2.0;
        d = x + a * d;
        if d.abs() < TINY {
            d = TINY;
        }
        d = 1.0 / d;
        c = x + a / c;
        if c.abs() < TINY {
            c = TINY;
        }
        let delta = c * d;
        fraction *= delta;
        if (delta - 1.0).abs() <= f64::EPSILON {
            break;
        }
    }
    (-x * x).exp() / (fraction * std::f64::consts::PI.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn close(actual: f64, expected: f64, relative: f64) -> bool {
        (actual - expected).abs() <= relative * expected.abs()
    }

    #[test]
    fn mean_of_a_sample_and_of_nothing() {
        assert_eq!(mean(&[1.0, 2.0, 6.0]), Some(3.0));
        assert_eq!(mean(&[]), None);
    }

    #[test]
    fn empty_or_nan_samples_have_no_median_or_quartiles() {
        assert_eq!(median(&[]), None);
        assert_eq!(quartiles(&[]), None);
        assert_eq!(median(&[1.0, f64::NAN]), None);
        assert_eq!(quartiles(&[f64::NAN]), None);
    }

    #[test]
    fn one_value_is_every_quartile() {
        // numpy.percentile([7], [25, 50, 75]) = [7, 7, 7].
        let expected = Quartiles {
            q1: 7.0,
            median: 7.0,
            q3: 7.0,
        };
        assert_eq!(quartiles(&[7.0]), Some(expected));
        assert_eq!(median(&[7.0]), Some(7.0));
    }

    #[test]
    fn quartiles_of_an_odd_sample_interpolate_between_order_statistics() {
        // Sorted [1, 2, 3]: h = 2p, so q1 at h = 0.5 is 1.5, the median at
        // h = 1 is 2 and q3 at h = 1.5 is 2.5.
        // numpy.percentile([3, 1, 2], [25, 50, 75]) = [1.5, 2.0, 2.5].
        let expected = Quartiles {
            q1: 1.5,
            median: 2.0,
            q3: 2.5,
        };
        assert_eq!(quartiles(&[3.0, 1.0, 2.0]), Some(expected));
    }

    #[test]
    fn quartiles_of_an_even_sample() {
        // [1, 2, 3, 4]: h = 3p, q1 at h = 0.75 → 1.75, median at 1.5 → 2.5,
        // q3 at 2.25 → 3.25. numpy.percentile gives [1.75, 2.5, 3.25].
        let expected = Quartiles {
            q1: 1.75,
            median: 2.5,
            q3: 3.25,
        };
        assert_eq!(quartiles(&[1.0, 2.0, 3.0, 4.0]), Some(expected));
        // Unsorted [4, 1, 3, 2, 10, 8] sorts to [1, 2, 3, 4, 8, 10]; h = 5p:
        // q1 at 1.25 → 2 + 0.25·1 = 2.25, median at 2.5 → 3.5, q3 at 3.75 →
        // 4 + 0.75·4 = 7. numpy.percentile gives [2.25, 3.5, 7.0].
        let expected = Quartiles {
            q1: 2.25,
            median: 3.5,
            q3: 7.0,
        };
        assert_eq!(quartiles(&[4.0, 1.0, 3.0, 2.0, 10.0, 8.0]), Some(expected));
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0, 10.0, 8.0]), Some(3.5));
    }

    #[test]
    fn quartiles_of_the_textbook_eleven() {
        // The 11-value example on Wikipedia's "Quartile" page, type 7:
        // h = 10p, q1 at 2.5 → (15 + 36)/2 = 25.5, median 40, q3 at 7.5 →
        // (42 + 43)/2 = 42.5. numpy.percentile gives [25.5, 40.0, 42.5].
        let xs = [
            6.0, 7.0, 15.0, 36.0, 39.0, 40.0, 41.0, 42.0, 43.0, 47.0, 49.0,
        ];
        let expected = Quartiles {
            q1: 25.5,
            median: 40.0,
            q3: 42.5,
        };
        assert_eq!(quartiles(&xs), Some(expected));
    }

    #[test]
    fn quantile_at_other_probabilities() {
        // numpy.percentile([1, 2, 3, 4], 10) = 1.3 (h = 0.3);
        // numpy.quantile([10, 20, 30, 40, 50], 0.9) = 46 (h = 3.6).
        assert!(close(
            quantile(&[1.0, 2.0, 3.0, 4.0], 0.1).unwrap_or(f64::NAN),
            1.3,
            1e-15
        ));
        assert!(close(
            quantile(&[10.0, 20.0, 30.0, 40.0, 50.0], 0.9).unwrap_or(f64::NAN),
            46.0,
            1e-15
        ));
        assert_eq!(quantile(&[1.0, 2.0], 0.0), Some(1.0));
        assert_eq!(quantile(&[1.0, 2.0], 1.0), Some(2.0));
        assert_eq!(
            quantile(&[f64::INFINITY, f64::INFINITY], 0.5),
            Some(f64::INFINITY)
        );
        // An infinity and a finite neighbour: the infinity, at any fraction.
        assert_eq!(
            quantile(&[f64::NEG_INFINITY, 1.0], 0.25),
            Some(f64::NEG_INFINITY)
        );
        assert_eq!(quantile(&[1.0, f64::INFINITY], 0.5), Some(f64::INFINITY));
    }

    #[test]
    fn quantile_refuses_what_it_cannot_answer() {
        assert_eq!(quantile(&[], 0.5), None);
        assert_eq!(quantile(&[1.0, 2.0], -0.1), None);
        assert_eq!(quantile(&[1.0, 2.0], 1.1), None);
        assert_eq!(quantile(&[1.0, 2.0], f64::NAN), None);
        assert_eq!(quantile(&[2.0, 1.0], 0.5), None);
        assert_eq!(quantile(&[1.0, f64::NAN], 0.5), None);
        // Strictly between −∞ and +∞ is no number.
        assert_eq!(quantile(&[f64::NEG_INFINITY, f64::INFINITY], 0.5), None);
        assert_eq!(
            quantile(&[f64::NEG_INFINITY, f64::INFINITY], 0.0),
            Some(f64::NEG_INFINITY)
        );
    }

    #[test]
    fn wilcoxon_needs_equal_lengths_and_a_non_zero_difference() {
        assert_eq!(wilcoxon_signed_rank(&[1.0, 2.0], &[1.0]), None);
        assert_eq!(wilcoxon_signed_rank(&[], &[]), None);
        assert_eq!(wilcoxon_signed_rank(&[1.0, 2.0], &[1.0, 2.0]), None);
        assert_eq!(wilcoxon_signed_rank(&[f64::NAN], &[1.0]), None);
    }

    #[test]
    fn wilcoxon_three_pairs_enumerated_by_hand() {
        // d = [5−4, 3−5, 10−7] = [1, −2, 3], ranks 1, 2, 3: W+ = 4, W− = 2.
        // The 8 sign patterns give W+ = 0 {}, 1 {1}, 2 {2}, 3 {3}, 3 {1,2},
        // 4 {1,3}, 5 {2,3}, 6 {1,2,3}: P(W+ ≤ 4) = 6/8, P(W+ ≥ 4) = 3/8,
        // p = 2·3/8 = 0.75. scipy.stats.wilcoxon([5,3,10], [4,5,7],
        // method='exact') gives statistic 2.0, p = 0.75.
        let result = wilcoxon_signed_rank(&[5.0, 3.0, 10.0], &[4.0, 5.0, 7.0]);
        let expected = Wilcoxon {
            n: 3,
            zeros: 0,
            w_plus: 4.0,
            w_minus: 2.0,
            statistic: 2.0,
            p_value: 0.75,
            exact: true,
        };
        assert_eq!(result, Some(expected));
    }

    #[test]
    fn wilcoxon_four_pairs_with_a_tie_enumerated_by_hand() {
        // d = [1, −1, 2, 3] (and one zero pair, dropped): |d| ranks 1.5, 1.5,
        // 3, 4, so W+ = 1.5 + 3 + 4 = 8.5 and W− = 1.5. Of the 16 sign
        // patterns over {1.5, 1.5, 3, 4} (total 10), W+ ≥ 8.5 only for
        // {all} = 10 and the two {1.5, 3, 4} = 8.5: 3/16; W+ ≤ 8.5 for all but
        // {all}: 15/16. p = 2·3/16 = 0.375. scipy.stats.wilcoxon(
        // [1,-1,2,3,5], [0,0,0,0,5], method=scipy.stats.PermutationMethod())
        // gives statistic 1.5, p = 0.375.
        let result = wilcoxon_signed_rank(&[1.0, -1.0, 2.0, 3.0, 5.0], &[0.0, 0.0, 0.0, 0.0, 5.0]);
        let expected = Wilcoxon {
            n: 4,
            zeros: 1,
            w_plus: 8.5,
            w_minus: 1.5,
            statistic: 1.5,
            p_value: 0.375,
            exact: true,
        };
        assert_eq!(result, Some(expected));
    }

    /// The example of Wikipedia's "Wilcoxon signed-rank test" page (also in
    /// scipy's test suite): differences 15, −7, 5, 20, 0, −9, 17, −12, 5, −10.
    #[test]
    fn wilcoxon_wikipedia_example_with_its_zero_dropped() {
        let after = [
            125.0, 115.0, 130.0, 140.0, 140.0, 115.0, 140.0, 125.0, 140.0, 135.0,
        ];
        let before = [
            110.0, 122.0, 125.0, 120.0, 140.0, 124.0, 123.0, 137.0, 135.0, 145.0,
        ];
        let Some(result) = wilcoxon_signed_rank(&after, &before) else {
            panic!("the example has non-zero differences");
        };
        // Ranks of |d| = 5, 5, 7, 9, 10, 12, 15, 17, 20 are 1.5, 1.5, 3, …, 9;
        // W+ = 1.5 + 1.5 + 7 + 8 + 9 = 27, W− = 3 + 4 + 5 + 6 = 18, and
        // Wikipedia's signed-rank sum W = W+ − W− = 9 over N_r = 9 pairs.
        assert_eq!((result.n, result.zeros), (9, 1));
        assert_eq!(
            (result.w_plus, result.w_minus, result.statistic),
            (27.0, 18.0, 18.0)
        );
        assert_eq!(result.w_plus - result.w_minus, 9.0);
        // Brute force over the 2^9 sign patterns of the tied ranks: 162 have
        // W+ ≥ 27, so p = 2·162/512 = 0.6328125; scipy.stats.wilcoxon(after,
        // before, method=scipy.stats.PermutationMethod()) agrees. (scipy's
        // method='exact' says 0.65234375: it uses the tie-free distribution.)
        assert_eq!(result.p_value, 0.6328125);
        assert!(result.exact);
    }

    #[test]
    fn wilcoxon_ties_and_zeros_match_the_permutation_distribution() {
        // d = [2, 4, 0, 3, −1, 5, 3, 0, −1, 7, 3, 2, 0]: three zeros, ties in
        // |d| among the 1s, 2s and 3s. scipy.stats.wilcoxon(a, b,
        // method=scipy.stats.PermutationMethod()) enumerates all 2^10 sign
        // patterns: statistic 3.0, p = 0.0078125 (= 8/1024).
        let a = [
            3.0, 8.0, 5.0, 9.0, 2.0, 7.0, 7.0, 4.0, 6.0, 10.0, 5.0, 8.0, 6.0,
        ];
        let b = [
            1.0, 4.0, 5.0, 6.0, 3.0, 2.0, 4.0, 4.0, 7.0, 3.0, 2.0, 6.0, 6.0,
        ];
        let Some(result) = wilcoxon_signed_rank(&a, &b) else {
            panic!("non-zero differences");
        };
        assert_eq!((result.n, result.zeros, result.statistic), (10, 3, 3.0));
        assert_eq!(result.p_value, 0.0078125);
    }

    #[test]
    fn wilcoxon_without_ties_matches_the_exact_distribution() {
        // d = a − b has magnitudes 1..=20, W+ = 150, W− = 60.
        // scipy.stats.wilcoxon(a, b, method='exact') gives statistic 60.0,
        // p = 0.09730720520019531 (= 102034/2^20).
        let a = [
            103.0, 113.0, 112.0, 131.0, 106.0, 110.0, 130.0, 108.0, 109.0, 117.0, 116.0, 108.0,
            117.0, 126.0, 125.0, 86.0, 135.0, 124.0, 103.0, 133.0,
        ];
        let b = [
            100.0, 114.0, 105.0, 119.0, 110.0, 101.0, 115.0, 106.0, 120.0, 111.0, 102.0, 116.0,
            107.0, 121.0, 112.0, 103.0, 117.0, 108.0, 122.0, 113.0,
        ];
        let Some(result) = wilcoxon_signed_rank(&a, &b) else {
            panic!("non-zero differences");
        };
        assert_eq!((result.n, result.w_plus, result.w_minus), (20, 150.0, 60.0));
        assert_eq!(result.p_value, 102_034.0 / 1_048_576.0);
    }

    #[test]
    fn wilcoxon_all_positive_differences_give_two_over_two_to_the_n() {
        // Only the all-positive pattern reaches W+ = n(n+1)/2, so
        // p = 2·1/2^n. scipy.stats.wilcoxon([1,…,6], method='exact') gives
        // p = 0.03125 = 2/64.
        let six: Vec<f64> = (1..=6).map(f64::from).collect();
        let Some(result) = wilcoxon_signed_rank(&six, &[0.0; 6]) else {
            panic!("non-zero differences");
        };
        assert_eq!(
            (result.w_plus, result.w_minus, result.statistic),
            (21.0, 0.0, 0.0)
        );
        assert_eq!(result.p_value, 0.03125);
        // At the largest exact size the counts reach 2^50 without overflow.
        let fifty: Vec<f64> = (1..=50).map(f64::from).collect();
        let Some(result) = wilcoxon_signed_rank(&fifty, &[0.0; 50]) else {
            panic!("non-zero differences");
        };
        assert!(result.exact);
        assert_eq!(result.p_value, 2.0f64.powi(-49));
    }

    #[test]
    fn wilcoxon_large_sample_with_ties_uses_the_normal_approximation() {
        // a = [(7i) % 13], b = [(5i) % 11] for i in 0..90: 6 zeros, 84 pairs
        // with many ties; W+ = 2213, W− = 1357. scipy.stats.wilcoxon(a, b,
        // method='approx', correction=True) gives statistic 1357.0,
        // p = 0.05617025845251361.
        let a: Vec<f64> = (0..90u32).map(|i| f64::from((i * 7) % 13)).collect();
        let b: Vec<f64> = (0..90u32).map(|i| f64::from((i * 5) % 11)).collect();
        let Some(result) = wilcoxon_signed_rank(&a, &b) else {
            panic!("non-zero differences");
        };
        assert_eq!((result.n, result.zeros), (84, 6));
        assert_eq!(
            (result.w_plus, result.w_minus, result.statistic),
            (2213.0, 1357.0, 1357.0)
        );
        assert!(!result.exact);
        assert!(
            close(result.p_value, 0.05617025845251361, 1e-12),
            "{}",
            result.p_value
        );
    }

    #[test]
    fn wilcoxon_large_sample_without_ties_uses_the_normal_approximation() {
        // d[i] = ±(i + 1) for i in 0..60, positive when (i² + 3i) % 7 < 4.
        // scipy.stats.wilcoxon(d, method='approx', correction=True) gives
        // statistic 776.0 (= W+), p = 0.30792673785777747.
        let d: Vec<f64> = (0..60u32)
            .map(|i| {
                let magnitude = f64::from(i + 1);
                if (i * i + 3 * i) % 7 < 4 {
                    magnitude
                } else {
                    -magnitude
                }
            })
            .collect();
        let Some(result) = wilcoxon_signed_rank(&d, &[0.0; 60]) else {
            panic!("non-zero differences");
        };
        assert_eq!(
            (result.n, result.w_plus, result.statistic),
            (60, 776.0, 776.0)
        );
        assert!(!result.exact);
        assert!(
            close(result.p_value, 0.30792673785777747, 1e-12),
            "{}",
            result.p_value
        );
    }

    #[test]
    fn normal_approximation_on_the_wikipedia_example() {
        // Tie groups of |d| = 5, 5, 7, 9, 10, 12, 15, 17, 20: one pair, seven
        // singletons. scipy.stats.wilcoxon(after, before, method='approx',
        // correction=True) gives p = 0.6352893188352069.
        let p = normal_two_sided_p(9, &[2, 1, 1, 1, 1, 1, 1, 1], 27.0);
        assert!(close(p, 0.6352893188352069, 1e-12), "{p}");
        // W+ at the mean gives p = 1, never more.
        assert_eq!(normal_two_sided_p(9, &[1; 9], 22.5), 1.0);
    }

    #[test]
    fn erfc_matches_scipy() {
        // scipy.special.erfc at each x.
        let reference = [
            (0.0, 1.0),
            (0.1, 0.8875370839817152),
            (0.5, 0.4795001221869535),
            (1.0, 0.15729920705028516),
            (1.5, 0.03389485352468927),
            (2.0, 0.004677734981047266),
            (2.5, 0.00040695201744495886),
            (3.0, 2.2090496998585445e-05),
            (4.0, 1.541725790028002e-08),
            (6.0, 2.1519736712498913e-17),
            (10.0, 2.0884875837625446e-45),
        ];
        for (x, expected) in reference {
            assert!(close(erfc(x), expected, 1e-14), "erfc({x}) = {}", erfc(x));
        }
        assert!(close(erfc(-1.0), 2.0 - 0.15729920705028516, 1e-15));
        // e^(−1600) underflows: the p-value's floor (see `wilcoxon_signed_rank`).
        assert_eq!(erfc(40.0), 0.0);
    }

    /// The exact p-value by definition: rank by counting, then try all 2^n
    /// sign patterns. Independent of the ranking and the dynamic programme.
    fn brute_force_p(differences: &[f64]) -> f64 {
        let nonzero: Vec<f64> = differences.iter().copied().filter(|&d| d != 0.0).collect();
        let ranks: Vec<f64> = nonzero
            .iter()
            .map(|d| {
                let below = nonzero.iter().filter(|e| e.abs() < d.abs()).count() as f64;
                let equal = nonzero.iter().filter(|e| e.abs() == d.abs()).count() as f64;
                below + (equal + 1.0) / 2.0
            })
            .collect();
        let observed: f64 = ranks
            .iter()
            .zip(&nonzero)
            .filter(|(_, &d)| d > 0.0)
            .map(|(r, _)| r)
            .sum();
        let (mut at_most, mut at_least) = (0u32, 0u32);
        for pattern in 0u32..1 << ranks.len() {
            let w: f64 = ranks
                .iter()
                .enumerate()
                .filter(|(i, _)| pattern >> i & 1 == 1)
                .map(|(_, r)| r)
                .sum();
            at_most += u32::from(w <= observed);
            at_least += u32::from(w >= observed);
        }
        (2.0 * f64::from(at_most.min(at_least)) / f64::from(1u32 << ranks.len())).min(1.0)
    }

    /// Paired samples of small integers, so zeros and ties are common, from 1
    /// to 80 pairs so both the exact and the approximate branch run.
    fn paired_samples() -> impl Strategy<Value = (Vec<f64>, Vec<f64>)> {
        (1usize..=80).prop_flat_map(|len| {
            let values = prop::collection::vec((-6i32..=6).prop_map(f64::from), len);
            (values.clone(), values)
        })
    }

    proptest! {
        #[test]
        fn wilcoxon_is_consistent((a, b) in paired_samples()) {
            let Some(forward) = wilcoxon_signed_rank(&a, &b) else {
                prop_assert!(a == b);
                return Ok(());
            };
            prop_assert!(forward.p_value > 0.0 && forward.p_value <= 1.0, "{}", forward.p_value);
            let n = forward.n as f64;
            prop_assert_eq!(forward.w_plus + forward.w_minus, n * (n + 1.0) / 2.0);
            prop_assert_eq!(forward.n + forward.zeros, a.len());
            prop_assert_eq!(forward.statistic, forward.w_plus.min(forward.w_minus));
            prop_assert_eq!(forward.exact, forward.n <= WILCOXON_EXACT_MAX_PAIRS);

            let backward = wilcoxon_signed_rank(&b, &a);
            prop_assert_eq!(
                backward,
                Some(Wilcoxon { w_plus: forward.w_minus, w_minus: forward.w_plus, ..forward })
            );
        }

        #[test]
        fn exact_p_matches_brute_force(
            differences in prop::collection::vec((-5i32..=5).prop_map(f64::from), 1..=12)
        ) {
            let zeros = vec![0.0; differences.len()];
            if let Some(result) = wilcoxon_signed_rank(&differences, &zeros) {
                let expected = brute_force_p(&differences);
                prop_assert!(
                    close(result.p_value, expected, 1e-15),
                    "{} vs {}",
                    result.p_value,
                    expected
                );
            }
        }

        #[test]
        fn quartiles_are_ordered_and_the_median_is_the_middle(
            xs in prop::collection::vec(-1e6f64..1e6, 1..40)
        ) {
            let Some(q) = quartiles(&xs) else {
                return Err(TestCaseError::fail("a non-empty sample has quartiles"));
            };
            let mut sorted = xs.clone();
            sorted.sort_by(f64::total_cmp);
            let middle = sorted.len() / 2;
            let expected_median = if sorted.len() % 2 == 1 {
                sorted[middle]
            } else {
                (sorted[middle - 1] + sorted[middle]) / 2.0
            };
            let tolerance = 1e-9 * expected_median.abs().max(1.0);
            prop_assert!((q.median - expected_median).abs() <= tolerance);
            prop_assert!(sorted[0] <= q.q1 && q.q1 <= q.median && q.median <= q.q3);
            prop_assert!(q.q3 <= sorted[sorted.len() - 1]);
        }
    }
}
