//! `--verify RATE`: a reproducible sample of answered evaluation chunks is
//! flown again in-process and compared bit for bit. Evaluation is
//! deterministic, so one differing number shows a worker wrong (bad memory,
//! another build that still speaks the protocol, a bug); the pool then
//! drops it for good and flies again every chunk it answered in the
//! generation (`Pool::run_chunks`).
//!
//! The sample depends only on the chunk's stream key and first genome,
//! never on timing or on who answered, so the same run samples the same
//! chunks every time. Besides the sample, each worker's first answer is
//! checked: a worker wrong on every answer is then caught before any of
//! its answers is taken.

use super::schedule::Chunk;
use lander_protocol::wire::{ChunkResult, EvalJob, JobHeader, KIND_EVALUATE};

/// Whether the answer to the chunk under `header` is checked: with `rate`
/// above 0, when the chunk is in the sample or the answer is its worker's
/// `first`.
pub(super) fn due(header: &JobHeader, rate: f64, first: bool) -> bool {
    header.kind == KIND_EVALUATE && rate > 0.0 && (first || sampled(header, rate))
}

/// Whether the chunk under `header` is one of the `rate` share checked.
pub(super) fn sampled(header: &JobHeader, rate: f64) -> bool {
    if header.kind != KIND_EVALUATE || rate <= 0.0 {
        return false;
    }
    let k = header.key;
    let mut x: u64 = 0x5eed_0f7e_51f1_ed00;
    for part in [k.seed, k.trial, k.restart, k.generation, header.first_index] {
        x = splitmix(x ^ part);
    }
    // The top 53 bits as a uniform number in [0, 1).
    ((x >> 11) as f64 / (1u64 << 53) as f64) < rate
}

/// SplitMix64's step: every input bit moves about half the output's.
fn splitmix(x: u64) -> u64 {
    let x = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
    let x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    let x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^ (x >> 31)
}

/// Flies `chunk` here and compares the worker's `answer` with it.
pub(super) fn check(chunk: &Chunk, answer: &ChunkResult) -> Result<(), String> {
    let job = EvalJob::from_wire(&chunk.header, &chunk.genes)
        .map_err(|e| format!("its chunk cannot be flown here: {e}"))?;
    let here = job.run();
    if here.evaluations.len() != answer.evaluations.len() {
        return Err("its answer has the wrong number of evaluations (--verify)".into());
    }
    let wrong = here
        .evaluations
        .iter()
        .zip(&answer.evaluations)
        .position(|(a, b)| a != b);
    if let Some(i) = wrong {
        return Err(format!(
            "its evaluation of genome {} differs from this host's (--verify)",
            chunk.header.first_index + i as u64
        ));
    }
    if here.actions != answer.actions {
        return Err("its guided actions differ from this host's (--verify)".into());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use lander_model::StreamKey;

    fn header(generation: u64, first_index: u64) -> JobHeader {
        JobHeader {
            kind: KIND_EVALUATE,
            key: StreamKey::new(1, 2, 0, generation),
            first_index,
            ..JobHeader::default()
        }
    }

    #[test]
    fn the_sample_is_reproducible_and_near_its_rate() {
        for rate in [0.01, 0.05, 0.2] {
            let picked = (0..20_000)
                .filter(|&i| sampled(&header(i / 10, (i % 10) * 10), rate))
                .count();
            let share = picked as f64 / 20_000.0;
            assert!((share - rate).abs() < rate * 0.2 + 0.002, "{rate}: {share}");
        }
        let h = header(7, 30);
        assert_eq!(sampled(&h, 0.5), sampled(&h, 0.5));
        assert!(!sampled(&h, 0.0));
        assert!(sampled(&h, 1.0));
    }

    #[test]
    fn a_workers_first_answer_is_checked_at_any_rate_above_zero() {
        let unsampled = (0..1000)
            .map(|i| header(i, 0))
            .find(|h| !sampled(h, 0.01))
            .unwrap();
        assert!(!due(&unsampled, 0.01, false));
        assert!(due(&unsampled, 0.01, true));
        assert!(!due(&unsampled, 0.0, true), "rate 0 checks nothing");
        let training = JobHeader {
            kind: lander_protocol::wire::KIND_TRAIN,
            ..unsampled
        };
        assert!(!due(&training, 1.0, true), "training jobs are not checked");
    }
}
