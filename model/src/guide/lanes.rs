//! The guided pass over several genomes at once, one genome a lane.
//!
//! One genome's pass is a single chain of dependent steps: each tick's
//! velocity waits for the last, each gene's branches start where the gene
//! before ended, and R and the choice wait for the branches. The CPU's
//! execution units sit mostly idle waiting on that chain. Genomes are
//! independent of each other, so [`guide_lanes`] walks [`LANES`] of them
//! side by side, their states kept as arrays with one element a lane: every
//! tick adds the same numbers for every lane at once, in vector registers
//! where the CPU has them, and R is scored for every lane's four branches
//! together.
//!
//! Each lane computes exactly what [`super::guide_in_place`] computes for
//! its genome: the same operations on the same numbers in the same order.
//! A lane whose gene is shorter than another's stops ticking (a masked
//! update, not a branch); a wrap is a select that yields what the scalar
//! flight's branch yields; a lane near the ground has its hulls tested one
//! at a time, in [`Flight::branch`]'s order. The choice between branches
//! and its draw from the genome's own stream stay per lane. When a lane's
//! walk ends, it takes the next genome.

use crate::sim::Flight;
use crate::{Env, Gene, GuideParams};
use rand_chacha::ChaCha8Rng;

#[cfg(target_arch = "x86_64")]
mod group;
#[cfg(target_arch = "x86_64")]
mod vector;

/// Genomes walked side by side: one 512-bit vector of `f64`s.
pub const LANES: usize = 8;

/// One genome for [`guide_lanes`]: where it flies, its index in its
/// generation (which [`guide_lanes`] hands back, untouched), its genes
/// (whose actions the pass rewrites) and the stream of its draws.
pub struct Walk<G> {
    pub env: Env,
    pub index: u64,
    pub genes: G,
    pub rng: ChaCha8Rng,
}

/// What [`guide_lanes`] shows each walk as it ends: the walk, its flight
/// as the pass left it, and the ticks simulated.
pub type Done<'d, G> = dyn FnMut(Walk<G>, Flight, u64) + 'd;

/// Walks every genome `walks` yields through the guided pass, as
/// [`super::guide_in_place`] walks each, and shows `done` each walk with
/// its flight and the ticks simulated as it ends: not in `walks`' order.
/// A walk is taken from `walks` only when a lane is free for it. On a CPU
/// without AVX-512 each genome is walked alone.
pub fn guide_lanes<G: AsMut<[Gene]>>(
    params: &GuideParams,
    walks: impl Iterator<Item = Walk<G>>,
    done: &mut Done<'_, G>,
) {
    #[cfg(target_arch = "x86_64")]
    if in_lanes() {
        // SAFETY: the CPU has the feature the function is compiled for;
        // it was just asked.
        return unsafe { lanes_avx512(params, walks, done) };
    }
    for mut walk in walks {
        let (flight, simulated) =
            super::guide_in_place(&walk.env, params, walk.genes.as_mut(), &mut walk.rng);
        done(walk, flight, simulated);
    }
}

/// Whether [`guide_lanes`] walks genomes in lanes on this CPU.
pub fn in_lanes() -> bool {
    #[cfg(target_arch = "x86_64")]
    return std::arch::is_x86_feature_detected!("avx512f");
    #[cfg(not(target_arch = "x86_64"))]
    return false;
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn lanes_avx512<G: AsMut<[Gene]>>(
    params: &GuideParams,
    walks: impl Iterator<Item = Walk<G>>,
    done: &mut Done<'_, G>,
) {
    group::Group::walk_all(params, walks, done)
}
