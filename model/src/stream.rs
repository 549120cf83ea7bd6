//! Keyed random streams.
//!
//! Every random draw in a run comes from a ChaCha8 generator whose key is
//! the tuple `(seed, trial, restart, generation)` and whose stream number
//! says what the draws are for. Results therefore never depend on which
//! process or thread made them, nor on the order in which work was done.
//!
//! The generator is [`StreamRng`]: the draws of rand_chacha's `ChaCha8Rng`,
//! made 16 blocks at a time by the chacha20 crate's keystream, in AVX-512
//! lanes where the CPU has them.

use chacha20::cipher::{Block, KeyIvInit, StreamCipherCore};
use chacha20::variants::Ietf;
use chacha20::{ChaChaCore, R8};
#[cfg(feature = "zero-copy")]
use iceoryx2::prelude::ZeroCopySend;
use rand::rand_core::block::{BlockRng, BlockRngCore};
use rand::RngCore;
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
    pub fn rng(&self, stream: u64) -> StreamRng {
        StreamRng::new(self.bytes(), stream)
    }

    /// The generator for `stream` under this key, for a stream drawn a few
    /// dozen times, such as a genome's guided pass: the same draws as
    /// [`StreamKey::rng`]'s, made 4 blocks at a time.
    pub fn short_rng(&self, stream: u64) -> ShortStreamRng {
        StreamRng::new(self.bytes(), stream)
    }

    /// The key as ChaCha8's 32 bytes: the four words, little-endian (what
    /// rand_chacha's `ChaCha8Rng::from_seed` takes for the same stream).
    pub fn bytes(&self) -> [u8; 32] {
        let mut key = [0u8; 32];
        let words = [self.seed, self.trial, self.restart, self.generation];
        for (chunk, word) in key.chunks_exact_mut(8).zip(words) {
            chunk.copy_from_slice(&word.to_le_bytes());
        }
        key
    }
}

/// Blocks of keystream a [`StreamRng`] makes at a time: as many as
/// chacha20's AVX-512 backend makes in one pass. A generation's breeding
/// draws about 95 KB.
const BLOCKS: usize = 16;
/// 32-bit words in a ChaCha block.
const BLOCK_WORDS: usize = 16;

/// A [`StreamRng`] that makes its keystream 4 blocks at a time, as
/// rand_chacha does, for a stream drawn a few dozen times: a genome's
/// guided pass draws a few dozen words from its own, and making 16 blocks
/// for them would cost it more than they save (about 80 ns a genome).
pub type ShortStreamRng = StreamRng<{ 4 * BLOCK_WORDS }>;

/// The generator of one keyed stream: ChaCha8 keyed with 32 bytes, its
/// 64-bit stream number as the nonce, its keystream's 32-bit words drawn
/// in order. Its draws are exactly those of rand_chacha's `ChaCha8Rng`
/// (`from_seed(key)`, then `set_stream(stream)`), which the tests hold it
/// to, word positions included; it makes its keystream about twice as
/// fast, where the CPU has AVX-512 (`.cargo/config.toml` builds chacha20
/// with that backend; without it, or on a CPU without AVX-512, it uses
/// AVX2 and is still faster).
///
/// `WORDS`, the words a refill makes, is a whole number of blocks, at
/// most [`BLOCKS`] of them.
pub struct StreamRng<const WORDS: usize = { BLOCKS * BLOCK_WORDS }>(BlockRng<Keystream<WORDS>>);

impl<const WORDS: usize> StreamRng<WORDS> {
    const REFILL: () = assert!(
        WORDS > 0 && WORDS.is_multiple_of(BLOCK_WORDS) && WORDS <= BLOCKS * BLOCK_WORDS,
        "a refill is 1 to 16 whole blocks"
    );

    /// The generator of `stream` under the 32 bytes `key`, at its start.
    pub fn new(key: [u8; 32], stream: u64) -> StreamRng<WORDS> {
        let () = Self::REFILL;
        StreamRng(BlockRng::new(Keystream::new(key, stream)))
    }

    /// Where the next draw starts, in 32-bit words from the stream's start
    /// (rand_chacha's `get_word_pos`): what a checkpoint keeps.
    pub fn get_word_pos(&self) -> u128 {
        let refilled = (WORDS / BLOCK_WORDS) as u64;
        let buffered_from = self.0.core.block.wrapping_sub(refilled);
        let index = self.0.index() as u64;
        let block = buffered_from.wrapping_add(index / BLOCK_WORDS as u64);
        u128::from(block) * BLOCK_WORDS as u128 + u128::from(index % BLOCK_WORDS as u64)
    }

    /// Goes to word `word` of the stream (rand_chacha's `set_word_pos`,
    /// which keeps the position's low 68 bits).
    pub fn set_word_pos(&mut self, word: u128) {
        self.0.core.block = (word / BLOCK_WORDS as u128) as u64;
        self.0
            .generate_and_set((word % BLOCK_WORDS as u128) as usize);
    }
}

impl<const WORDS: usize> RngCore for StreamRng<WORDS> {
    #[inline]
    fn next_u32(&mut self) -> u32 {
        self.0.next_u32()
    }

    #[inline]
    fn next_u64(&mut self) -> u64 {
        self.0.next_u64()
    }

    #[inline]
    fn fill_bytes(&mut self, dest: &mut [u8]) {
        self.0.fill_bytes(dest)
    }
}

/// The keystream of one stream, `WORDS` words at a time, from block
/// `block`. chacha20's ChaCha8 is the IETF one: a 32-bit block counter and
/// a 96-bit nonce, where rand_chacha's counts blocks in 64 bits beside a
/// 64-bit stream. The nonce's first word stands in for the counter's high
/// word, so the two keystreams are the same; the core is keyed again each
/// time the low word wraps, after 2^32 blocks.
struct Keystream<const WORDS: usize> {
    key: [u8; 32],
    stream: u64,
    /// The block the next refill starts at.
    block: u64,
    core: ChaChaCore<R8, Ietf>,
    /// The high word of the counter `core` was keyed for.
    high: u32,
}

impl<const WORDS: usize> Keystream<WORDS> {
    /// The keystream of `stream` under `key`, from its first block.
    fn new(key: [u8; 32], stream: u64) -> Keystream<WORDS> {
        Keystream {
            key,
            stream,
            block: 0,
            core: core(&key, stream, 0),
            high: 0,
        }
    }
}

/// ChaCha8 keyed for the blocks of `stream` whose number's high word is
/// `high`.
fn core(key: &[u8; 32], stream: u64, high: u32) -> ChaChaCore<R8, Ietf> {
    let mut nonce = [0u8; 12];
    nonce[..4].copy_from_slice(&high.to_le_bytes());
    nonce[4..].copy_from_slice(&stream.to_le_bytes());
    ChaChaCore::new(key.into(), &nonce.into())
}

/// A refill's words, as [`BlockRng`] holds them.
struct Words<const WORDS: usize>([u32; WORDS]);

impl<const WORDS: usize> Default for Words<WORDS> {
    fn default() -> Words<WORDS> {
        Words([0; WORDS])
    }
}

impl<const WORDS: usize> AsRef<[u32]> for Words<WORDS> {
    fn as_ref(&self) -> &[u32] {
        &self.0
    }
}

impl<const WORDS: usize> AsMut<[u32]> for Words<WORDS> {
    fn as_mut(&mut self) -> &mut [u32] {
        &mut self.0
    }
}

impl<const WORDS: usize> BlockRngCore for Keystream<WORDS> {
    type Item = u32;
    type Results = Words<WORDS>;

    // Kept out of the draws' inlined fast path, as rand_chacha keeps its own:
    // inlined, it makes the draw too large to inline where it is made.
    #[inline(never)]
    fn generate(&mut self, results: &mut Words<WORDS>) {
        let wanted = WORDS / BLOCK_WORDS;
        // The keystream written straight into the words, as their bytes:
        // no buffer of blocks to zero when a stream is made, nor to copy
        // from at each refill.
        let bytes: &mut [u8] = bytemuck::cast_slice_mut(&mut results.0[..]);
        let (blocks, _) = Block::<ChaChaCore<R8, Ietf>>::slice_as_chunks_mut(bytes);
        let mut made = 0;
        while made < wanted {
            let block = self.block.wrapping_add(made as u64);
            let high = (block >> 32) as u32;
            if high != self.high {
                self.core = core(&self.key, self.stream, high);
                self.high = high;
            }
            self.core.set_block_pos(block as u32);
            // Up to where the counter's low word wraps.
            let to_wrap = (1u64 << 32) - u64::from(block as u32);
            let n = (wanted - made).min(usize::try_from(to_wrap).unwrap_or(wanted));
            self.core
                .write_keystream_blocks(&mut blocks[made..made + n]);
            made += n;
        }
        self.block = self.block.wrapping_add(wanted as u64);
        // The keystream's words are little-endian: nothing to do on x86.
        for word in &mut results.0 {
            *word = u32::from_le(*word);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::{any, prop, prop_assert_eq, prop_oneof, proptest, Just, Strategy};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// rand_chacha's generator for `stream` under `key`: the oracle.
    fn oracle(key: [u8; 32], stream: u64) -> ChaCha8Rng {
        let mut rng = ChaCha8Rng::from_seed(key);
        rng.set_stream(stream);
        rng
    }

    /// One way of drawing, done to both generators alike.
    #[derive(Clone, Debug)]
    enum Draw {
        U32,
        U64,
        Bytes(usize),
        /// Go to a word position near a refill's edge or the counter's
        /// low word wrapping.
        Seek(u128),
    }

    fn draws() -> impl Strategy<Value = Vec<Draw>> {
        let near = prop_oneof![
            0u128..2_000,
            // Around where the counter's low word wraps (2^32 blocks).
            ((1u128 << 36) - 600)..((1u128 << 36) + 600),
            // Around the end of the 64-bit counter.
            ((1u128 << 68) - 600)..(1u128 << 68),
        ];
        let draw = prop_oneof![
            4 => Just(Draw::U32),
            4 => Just(Draw::U64),
            2 => (0usize..700).prop_map(Draw::Bytes),
            1 => near.prop_map(Draw::Seek),
        ];
        prop::collection::vec(draw, 1..400)
    }

    /// Does `draws` to a `StreamRng` of `WORDS`-word refills and to
    /// rand_chacha's generator alike, checking that they agree.
    fn agree<const WORDS: usize>(
        key: [u8; 32],
        stream: u64,
        draws: &[Draw],
    ) -> Result<(), proptest::test_runner::TestCaseError> {
        let (mut ours, mut theirs) = (StreamRng::<WORDS>::new(key, stream), oracle(key, stream));
        for draw in draws {
            match *draw {
                Draw::U32 => prop_assert_eq!(ours.next_u32(), theirs.next_u32()),
                Draw::U64 => prop_assert_eq!(ours.next_u64(), theirs.next_u64()),
                Draw::Bytes(n) => {
                    let (mut a, mut b) = (vec![0u8; n], vec![0u8; n]);
                    ours.fill_bytes(&mut a);
                    theirs.fill_bytes(&mut b);
                    prop_assert_eq!(a, b);
                }
                Draw::Seek(word) => {
                    ours.set_word_pos(word);
                    theirs.set_word_pos(word);
                }
            }
            prop_assert_eq!(ours.get_word_pos(), theirs.get_word_pos());
        }
        Ok(())
    }

    proptest! {
        /// Any mix of draws, byte fills and seeks gives what rand_chacha's
        /// `ChaCha8Rng` gives, at the same word positions, with refills of
        /// 16 blocks ([`StreamRng`]), 4 ([`ShortStreamRng`]) or 1.
        #[test]
        fn draws_are_rand_chachas(key in any::<[u8; 32]>(), stream in any::<u64>(), draws in draws()) {
            agree::<{ BLOCKS * BLOCK_WORDS }>(key, stream, &draws)?;
            agree::<{ 4 * BLOCK_WORDS }>(key, stream, &draws)?;
            agree::<BLOCK_WORDS>(key, stream, &draws)?;
        }
    }

    #[test]
    fn a_streams_keystream_crosses_the_counters_low_word_as_rand_chachas_does() {
        let key = StreamKey::new(1, 16, 0, 3).bytes();
        // Twenty words before block 2^32, which a refill straddles.
        let word = (1u128 << 36) - 20;
        let mut theirs = oracle(key, 9);
        theirs.set_word_pos(word);
        let want: Vec<u32> = (0..600).map(|_| theirs.next_u32()).collect();
        let mut long = StreamKey::new(1, 16, 0, 3).rng(9);
        long.set_word_pos(word);
        let mut short = StreamKey::new(1, 16, 0, 3).short_rng(9);
        short.set_word_pos(word);
        assert_eq!((0..600).map(|_| long.next_u32()).collect::<Vec<_>>(), want);
        assert_eq!((0..600).map(|_| short.next_u32()).collect::<Vec<_>>(), want);
        assert_eq!(long.get_word_pos(), word + 600);
        assert_eq!(short.get_word_pos(), word + 600);
    }

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
