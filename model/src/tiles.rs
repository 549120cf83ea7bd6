//! A hashed tile coder (Sutton & Barto, §8.3.2): `T` offset grids over a
//! continuous state, each contributing the one tile the state falls in,
//! with the action hashed in so each (state, action) pair gets its own
//! binary features.

/// State dimensions the coder takes.
pub const DIMS: usize = 5;

/// The most tilings a coder has.
pub const MAX_TILINGS: usize = 64;

/// Tilings with their widths and offsets; hashes into `2^bits` weights.
///
/// Tiling by tiling is how the coder is defined ([`TileCoder::features`]),
/// but it is stored dimension by dimension, tilings side by side, so that
/// [`TileCoder::features_of_every_action`] works on all tilings at once in
/// vector lanes.
#[derive(Clone, Debug, PartialEq)]
pub struct TileCoder {
    widths: [f64; DIMS],
    /// `shifts[d][t]`: tiling `t`'s offset along dimension `d`, in tiles
    /// (see `cell`).
    shifts: [[f64; MAX_TILINGS]; DIMS],
    /// Each tiling's hash before its cell is mixed in: a constant, so it is
    /// found once here rather than once per state.
    seeds: [u64; MAX_TILINGS],
    tilings: usize,
    /// `2^bits − 1`: a hash's low bits are its remainder by `2^bits`, found
    /// without the division a remainder costs.
    mask: u64,
}

impl TileCoder {
    /// `tilings` grids over tiles of `widths`, hashed into `2^bits`
    /// features (`tilings` is at most [`MAX_TILINGS`], `bits` at most 63).
    pub fn new(widths: [f64; DIMS], tilings: usize, bits: u32) -> TileCoder {
        assert!(
            tilings <= MAX_TILINGS,
            "{tilings} tilings, at most {MAX_TILINGS}"
        );
        let shifts = std::array::from_fn(|d| {
            std::array::from_fn(|t| (t * (2 * d + 1)) as f64 / tilings as f64)
        });
        let seeds = std::array::from_fn(|t| mix(0x6c61_6e64_6572_2121 ^ t as u64));
        TileCoder {
            widths,
            shifts,
            seeds,
            tilings,
            mask: (1u64 << bits.min(63)) - 1,
        }
    }

    pub fn tilings(&self) -> usize {
        self.tilings
    }

    /// The grid cell of `point` in tiling `t`. Tiling `t` is shifted by
    /// `t · (2d + 1) / T` of a tile along dimension `d`: the asymmetric
    /// offsets Sutton & Barto recommend, so the tilings do not line up on
    /// the diagonal. The cell is a floor, so −0.5 tiles is cell −1, not 0.
    pub fn cell(&self, t: usize, point: &[f64; DIMS]) -> [i64; DIMS] {
        std::array::from_fn(|d| floor(point[d] / self.widths[d] + self.shifts[d][t]))
    }

    /// Writes the `tilings` active features of `(point, action)` into `out`.
    pub fn features(&self, point: &[f64; DIMS], action: u8, out: &mut [usize]) {
        for (t, slot) in out.iter_mut().enumerate().take(self.tilings) {
            *slot = self.index(t, &self.cell(t, point), action);
        }
    }

    /// Writes the active features of `(point, a)` for every action `a` in
    /// `0..actions`, action after action, `tilings` each: what
    /// [`TileCoder::features`] gives for each action in turn, bit for bit.
    ///
    /// Each tiling's cell is found and hashed once rather than once per
    /// action, the point is scaled to tiles once for all tilings, and the
    /// tilings go side by side, one dimension at a time: the same
    /// operations on the same values, in lanes where the CPU has them.
    pub fn features_of_every_action(&self, point: &[f64; DIMS], actions: u8, out: &mut [usize]) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx512dq")
            && std::arch::is_x86_feature_detected!("avx512vl")
        {
            // SAFETY: the CPU has every feature the function is compiled
            // for; it was just asked.
            return unsafe { self.every_action_avx512(point, actions, out) };
        }
        self.every_action(point, actions, out);
    }

    /// [`TileCoder::every_action`] compiled for AVX-512, whose packed
    /// 64-bit conversions and multiplies take a vector of tilings at once.
    /// Rust does not fuse or reorder floating-point operations, so the
    /// results are those of any other build.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl")]
    fn every_action_avx512(&self, point: &[f64; DIMS], actions: u8, out: &mut [usize]) {
        self.every_action(point, actions, out);
    }

    #[inline(always)]
    fn every_action(&self, point: &[f64; DIMS], actions: u8, out: &mut [usize]) {
        let n = self.tilings;
        let mut cells = self.seeds;
        let cells = &mut cells[..n];
        for ((&x, &width), shifts) in point.iter().zip(&self.widths).zip(&self.shifts) {
            let scaled = x / width;
            for (h, &shift) in cells.iter_mut().zip(&shifts[..n]) {
                *h = mix(*h ^ floor(scaled + shift) as u64);
            }
        }
        let each = out.chunks_exact_mut(n).take(usize::from(actions));
        for (a, slots) in each.enumerate() {
            for (slot, &cell) in slots.iter_mut().zip(cells.iter()) {
                *slot = self.with_action(cell, a as u8);
            }
        }
    }

    /// The feature of one cell of tiling `t` for `action`.
    pub fn index(&self, t: usize, cell: &[i64; DIMS], action: u8) -> usize {
        self.with_action(self.hash_cell(t, cell), action)
    }

    /// Tiling `t`'s seed with each of a cell's coordinates mixed in turn.
    fn hash_cell(&self, t: usize, cell: &[i64; DIMS]) -> u64 {
        cell.iter().fold(self.seeds[t], |h, &c| mix(h ^ c as u64))
    }

    #[inline(always)]
    fn with_action(&self, cell: u64, action: u8) -> usize {
        (mix(cell ^ u64::from(action)) & self.mask) as usize
    }
}

/// `x.floor() as i64`, without the call into libm that `floor` is on a
/// baseline x86-64 target (it was an eighth of a Q(λ) trial's time): the
/// truncation, one lower where it rounded a negative number up. Equal for
/// every `x`, NaN (0) and the saturated ends included.
#[inline(always)]
fn floor(x: f64) -> i64 {
    let truncated = x as i64;
    truncated.saturating_sub(i64::from(truncated as f64 > x))
}

/// SplitMix64's finaliser: a fast, well-spread 64-bit mixer.
#[inline(always)]
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn coder() -> TileCoder {
        TileCoder::new([40.0, 30.0, 0.5, 0.5, 0.25], 16, 18)
    }

    #[test]
    fn cells_by_hand_including_negative_coordinates() {
        let c = coder();
        // Tiling 0 has no shift: plain floor division by the widths.
        assert_eq!(
            c.cell(0, &[-41.0, 29.9, -0.1, 0.5, -0.26]),
            [-2, 0, -1, 1, -2]
        );
        assert_eq!(c.cell(0, &[-40.0, 0.0, 0.0, -0.0, 0.24]), [-1, 0, 0, 0, 0]);
        // Tiling 1 of 16 shifts dimension d by (2d + 1)/16 of a tile:
        // x: -41/40 + 1/16 = -0.9625 → -1; y: 29.9/30 + 3/16 = 1.18 → 1;
        // vx: -0.1/0.5 + 5/16 = 0.1125 → 0; vy: 1 + 7/16 → 1;
        // rot: -0.26/0.25 + 9/16 = -0.4775 → -1.
        assert_eq!(
            c.cell(1, &[-41.0, 29.9, -0.1, 0.5, -0.26]),
            [-1, 1, 0, 1, -1]
        );
        // Tiling 15 shifts x by 15/16: -41/40 + 0.9375 = -0.0875 → -1, not 0.
        assert_eq!(c.cell(15, &[-41.0, 0.0, 0.0, 0.0, 0.0])[0], -1);
    }

    #[test]
    fn the_fast_floor_is_floor() {
        let edges = [
            0.0,
            -0.0,
            0.5,
            -0.5,
            -1.0,
            -1.0 - f64::EPSILON,
            2.999_999_999,
            -2.000_000_000_1,
            1e18,
            -1e18,
            9.3e18,
            -9.3e18,
            f64::MAX,
            f64::MIN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        for x in edges {
            assert_eq!(floor(x), x.floor() as i64, "{x}");
        }
    }

    proptest::proptest! {
        #[test]
        fn the_fast_floor_is_floor_anywhere(x in proptest::num::f64::ANY) {
            proptest::prop_assert_eq!(floor(x), x.floor() as i64);
        }

        #[test]
        fn every_actions_features_at_once_are_each_actions_in_turn(
            point in proptest::array::uniform5(-1e4f64..1e4),
        ) {
            let c = coder();
            // As the CPU allows (in lanes where it has AVX-512), and the
            // portable build of the same code.
            let (mut all, mut portable) = ([0; 64], [0; 64]);
            c.features_of_every_action(&point, 4, &mut all);
            c.every_action(&point, 4, &mut portable);
            proptest::prop_assert_eq!(all, portable);
            for a in 0..4u8 {
                let mut one = [0; 16];
                c.features(&point, a, &mut one);
                let start = usize::from(a) * 16;
                proptest::prop_assert_eq!(&all[start..start + 16], &one[..]);
            }
        }

        #[test]
        fn any_number_of_tilings_codes_as_the_plain_coder(
            point in proptest::array::uniform5(-1e4f64..1e4),
            tilings in 1..=MAX_TILINGS,
        ) {
            let c = TileCoder::new([40.0, 30.0, 0.5, 0.5, 0.25], tilings, 18);
            let mut all = vec![0; 4 * tilings];
            c.features_of_every_action(&point, 4, &mut all);
            for (a, slots) in all.chunks(tilings).enumerate() {
                let mut one = vec![0; tilings];
                c.features(&point, a as u8, &mut one);
                proptest::prop_assert_eq!(slots, &one[..]);
            }
        }
    }

    #[test]
    fn features_are_in_range_and_depend_on_the_action() {
        let c = coder();
        let p = [12.0, 80.0, 0.3, -1.2, 3.0];
        let (mut a, mut b) = ([0; 16], [0; 16]);
        c.features(&p, 0, &mut a);
        c.features(&p, 1, &mut b);
        assert!(a.iter().chain(&b).all(|&i| i < 1 << 18));
        assert_eq!(a.iter().filter(|i| b.contains(i)).count(), 0);
    }

    #[test]
    fn nearby_points_share_most_tiles_and_distant_ones_none() {
        let c = coder();
        let shared = |p: [f64; 5], q: [f64; 5]| {
            let (mut a, mut b) = ([0; 16], [0; 16]);
            c.features(&p, 2, &mut a);
            c.features(&q, 2, &mut b);
            (0..16).filter(|&t| a[t] == b[t]).count()
        };
        let p = [10.0, 100.0, 0.2, -0.4, 1.0];
        assert_eq!(shared(p, p), 16);
        let near = [10.5, 100.3, 0.2, -0.4, 1.0];
        assert!(shared(p, near) >= 12, "{}", shared(p, near));
        let far = [-150.0, 10.0, 2.0, 3.0, -2.0];
        assert_eq!(shared(p, far), 0);
    }
}
