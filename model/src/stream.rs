//! Keyed random streams.
//!
//! Every random draw in a run comes from a ChaCha8 generator whose key is
//! the tuple `(seed, trial, restart, generation)` and whose stream number
//! says what the draws are for. Results therefore never depend on which
//! process or thread made them, nor on the order in which work was done.

#[cfg(feature = "zero-copy")]
use iceoryx2::prelude::ZeroCopySend;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Where in a run a set of draws belongs. `generation` counts from 1 within
/// a restart; the environment's draws use generation 0.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(
    feature = "zero-copy",
    derive(ZeroCopySend),
    type_name("lander::StreamKey")
)]
pub struct StreamKey {
    pub seed: u64,
    pub trial: u64,
    pub restart: u64,
    pub generation: u64,
}

/// Stream numbers within one key.
pub mod streams {
    /// The coordinator's operators: the random first population, selection,
    /// crossover and mutation.
    pub const OPERATORS: u64 = 0;
    /// The trial's start column `x0` (key with restart 0, generation 0).
    pub const START: u64 = u64::MAX;
    /// A restart's pad position (key with generation 0).
    pub const PAD: u64 = u64::MAX - 1;
    /// A Q(λ) trial's exploration (key with restart 0, generation 0).
    pub const LEARN: u64 = u64::MAX - 2;

    /// The guided pass over the individual at `index` in the population.
    pub const fn guide(index: u64) -> u64 {
        1 + index
    }
}

impl StreamKey {
    pub fn new(seed: u64, trial: u64, restart: u64, generation: u64) -> StreamKey {
        StreamKey {
            seed,
            trial,
            restart,
            generation,
        }
    }

    /// The generator for `stream` under this key.
    pub fn rng(&self, stream: u64) -> ChaCha8Rng {
        let mut seed = [0u8; 32];
        let words = [self.seed, self.trial, self.restart, self.generation];
        for (chunk, word) in seed.chunks_exact_mut(8).zip(words) {
            chunk.copy_from_slice(&word.to_le_bytes());
        }
        let mut rng = ChaCha8Rng::from_seed(seed);
        rng.set_stream(stream);
        rng
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng;

    #[test]
    fn same_key_same_draws_different_key_different_draws() {
        let key = StreamKey::new(1, 2, 3, 4);
        let a: Vec<u64> = key.rng(7).random_iter().take(4).collect();
        let b: Vec<u64> = key.rng(7).random_iter().take(4).collect();
        assert_eq!(a, b);
        for other in [
            StreamKey::new(2, 2, 3, 4),
            StreamKey::new(1, 3, 3, 4),
            StreamKey::new(1, 2, 4, 4),
            StreamKey::new(1, 2, 3, 5),
        ] {
            let c: Vec<u64> = other.rng(7).random_iter().take(4).collect();
            assert_ne!(a, c, "{other:?}");
        }
        let d: Vec<u64> = key.rng(8).random_iter().take(4).collect();
        assert_ne!(a, d);
    }
}
