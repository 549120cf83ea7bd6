//! A hashed tile coder (Sutton & Barto, §8.3.2): `T` offset grids over a
//! continuous state, each contributing the one tile the state falls in,
//! with the action hashed in so each (state, action) pair gets its own
//! binary features.

/// State dimensions the coder takes.
pub const DIMS: usize = 5;

/// Tilings with their widths and offsets; hashes into `size` weights.
#[derive(Clone, Debug, PartialEq)]
pub struct TileCoder {
    widths: [f64; DIMS],
    tilings: usize,
    size: usize,
}

impl TileCoder {
    /// `tilings` grids over tiles of `widths`, hashed into `size` features.
    pub fn new(widths: [f64; DIMS], tilings: usize, size: usize) -> TileCoder {
        TileCoder {
            widths,
            tilings,
            size,
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
        let mut cell = [0i64; DIMS];
        for d in 0..DIMS {
            let shift = (t * (2 * d + 1)) as f64 / self.tilings as f64;
            cell[d] = (point[d] / self.widths[d] + shift).floor() as i64;
        }
        cell
    }

    /// Writes the `tilings` active features of `(point, action)` into `out`.
    pub fn features(&self, point: &[f64; DIMS], action: u8, out: &mut [usize]) {
        for (t, slot) in out.iter_mut().enumerate().take(self.tilings) {
            *slot = self.index(t, &self.cell(t, point), action);
        }
    }

    /// The feature of one cell of tiling `t` for `action`.
    pub fn index(&self, t: usize, cell: &[i64; DIMS], action: u8) -> usize {
        let mut h = mix(0x6c61_6e64_6572_2121 ^ t as u64);
        for &c in cell {
            h = mix(h ^ c as u64);
        }
        h = mix(h ^ u64::from(action));
        (h % self.size as u64) as usize
    }
}

/// SplitMix64's finaliser: a fast, well-spread 64-bit mixer.
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
        TileCoder::new([40.0, 30.0, 0.5, 0.5, 0.25], 16, 1 << 18)
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
