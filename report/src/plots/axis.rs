//! Axes and their labels: the symlog scale of Figure 4 with its ticks, and
//! the tick and legend numbers of Figure 4 and the learning curve ("1.5k",
//! "10M", "9,999,999", "-0.25").

use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint};
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

/// The y-scale of [`fitness_per_generation`](super::fitness_per_generation):
/// `sign(v)·log10(1 + |v|)`. Linear-ish near zero, logarithmic far from it,
/// defined for every finite value and increasing (strictly, up to
/// rounding); a safe landing's 9,999,999 maps to exactly 7.
pub fn symlog(v: f64) -> f64 {
    v.signum() * (1.0 + v.abs()).log10()
}

/// The inverse of [`symlog`].
pub fn symlog_inverse(t: f64) -> f64 {
    t.signum() * (10f64.powf(t.abs()) - 1.0)
}

/// A linear f64 axis whose ticks are given: the symlog axis. (plotters'
/// own `with_key_points` wrapper loses the f64 label formatting that
/// `configure_mesh` needs.)
pub(super) struct TickedAxis {
    pub(super) inner: RangedCoordf64,
    pub(super) ticks: Vec<f64>,
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
pub(super) fn symlog_ticks(lo: f64, hi: f64) -> Vec<f64> {
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
pub(super) fn human(v: f64) -> String {
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
pub(super) fn plain(v: f64) -> String {
    if (v - v.round()).abs() < 1e-9 * v.abs().max(1.0) {
        thousands(v)
    } else {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

/// 9999999 as "9,999,999" (rounded to an integer).
pub(crate) fn thousands(v: f64) -> String {
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

/// A count as a plotters coordinate, saturating.
pub(super) fn to_i64(v: u64) -> i64 {
    i64::try_from(v).unwrap_or(i64::MAX)
}

#[cfg(test)]
mod tests {
    use super::super::style::tint;
    use super::*;
    use proptest::prelude::*;

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
