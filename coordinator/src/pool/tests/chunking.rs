//! `chunk_ranges`: how a generation is cut into chunks, largest first.

use crate::pool::backend::parts;
use crate::pool::schedule::chunk_ranges;
use lander_protocol::wire::most_genomes_per_chunk;

#[test]
fn chunks_cover_everything_once_in_order() {
    for (n, parts, workers) in [
        (100, 8, 2),
        (100, 1, 1),
        (7, 20, 2),
        (1, 4, 1),
        (0, 3, 2),
        (10_000, 12, 3),
        (100, 3, 8),
    ] {
        let c = chunk_ranges(n, parts, workers);
        let flat: Vec<usize> = c.iter().flat_map(|r| r.clone()).collect();
        assert_eq!(flat, (0..n).collect::<Vec<_>>(), "n={n} parts={parts}");
        assert!(c.len() <= parts.max(1));
    }
}

#[test]
fn each_round_of_chunks_is_smaller_than_the_last() {
    // Two workers, four chunks each: weights 4, 4, 3, 3, 2, 2, 1, 1 of 20.
    let sizes: Vec<usize> = chunk_ranges(100, 8, 2).iter().map(|r| r.len()).collect();
    assert_eq!(sizes, [20, 20, 15, 15, 10, 10, 5, 5]);
    // Each worker's share is still even: 20 + 15 + 10 + 5 = 50.
    let one: Vec<usize> = chunk_ranges(100, 4, 1).iter().map(|r| r.len()).collect();
    assert_eq!(one, [40, 30, 20, 10]);
}

#[test]
fn no_chunk_outgrows_a_network_frame() {
    // A generation of 10^8 genes (the most a run may have) in genomes of
    // one, 50 or 1,000 genes, cut for one worker or eight.
    for length in [1, 50, 1_000] {
        let n = 100_000_000 / length;
        let most = most_genomes_per_chunk(length);
        for (per_batch, workers) in [(1, 1), (4, 1), (32, 8)] {
            let chunks = chunk_ranges(n, parts(n, length, per_batch), workers);
            let largest = chunks.iter().map(|r| r.len()).max().unwrap();
            assert!(
                largest <= most,
                "{length} genes, {per_batch}: {largest} > {most}"
            );
        }
    }
    // A generation of the paper's is cut as asked.
    assert_eq!(parts(100, 50, 8), 8);
}
