//! `dispatch`, `hand_early` and `rebalance` alone, over links that only
//! record what they are sent (behind them, stand-in processes where a test
//! needs one pinned beside the coordinator).

use super::fake::{no_chunks, Nowhere, Recorder};
use crate::pool::progress::Progress;
use crate::pool::schedule::Early;
use crate::pool::{Pool, DEPTH};
use std::collections::VecDeque;

fn pool(links: Vec<Vec<usize>>) -> Pool<Nowhere> {
    let links = (0..)
        .zip(links)
        .map(|(id, chunks)| Recorder::holding(id, chunks));
    super::fake::pool(links.collect(), Default::default())
}

/// Which chunks each of `workers` links is sent, from `n` queued.
fn spread(workers: usize, n: usize) -> (Vec<Vec<usize>>, usize) {
    let mut pool = pool(vec![Vec::new(); workers]);
    let chunks = no_chunks(n);
    let mut todo: VecDeque<usize> = (0..n).collect();
    pool.dispatch(&chunks, &mut todo);
    let sent = pool.links.iter().map(|l| l.chunks.clone()).collect();
    (sent, todo.len())
}

#[test]
fn few_chunks_go_one_to_each_worker() {
    assert_eq!(spread(2, 2), (vec![vec![0], vec![1]], 0));
    assert_eq!(spread(3, 2), (vec![vec![0], vec![1], vec![]], 0));
}

#[test]
fn many_chunks_fill_every_queue_and_wait() {
    assert_eq!(DEPTH, 4, "the cases below assume four queued per worker");
    assert_eq!(spread(2, 12), (vec![vec![0, 2, 4, 6], vec![1, 3, 5, 7]], 4));
    assert_eq!(spread(0, 3), (vec![], 3));
}

/// What each link holds after one rebalancing, and what is queued.
fn rebalanced(links: Vec<Vec<usize>>, todo: &[usize]) -> (Vec<Vec<usize>>, Vec<usize>) {
    let mut pool = pool(links);
    let chunks = no_chunks(6);
    let mut progress = Progress::<()>::new(chunks.len());
    progress.todo = todo.iter().copied().collect();
    pool.rebalance(&chunks, &mut progress);
    let held = pool.links.iter().map(|l| l.chunks.clone()).collect();
    (held, progress.todo.into())
}

#[test]
fn an_idle_worker_takes_the_last_queued_chunk_of_the_busiest() {
    assert_eq!(
        rebalanced(vec![vec![], vec![1, 3], vec![0, 2, 4]], &[]),
        (vec![vec![4], vec![1, 3], vec![0, 2]], vec![])
    );
    assert_eq!(
        rebalanced(vec![vec![], vec![], vec![0, 2, 4]], &[]),
        (vec![vec![4], vec![2], vec![0]], vec![])
    );
}

#[test]
fn nothing_moves_while_chunks_wait_or_no_one_has_a_backlog() {
    let waiting = rebalanced(vec![vec![], vec![0, 1, 2]], &[3]);
    assert_eq!(waiting, (vec![vec![], vec![0, 1, 2]], vec![3]));
    let flying = rebalanced(vec![vec![], vec![0], vec![1]], &[]);
    assert_eq!(flying, (vec![vec![], vec![0], vec![1]], vec![]));
    let busy = rebalanced(vec![vec![5], vec![0, 1, 2]], &[]);
    assert_eq!(busy, (vec![vec![5], vec![0, 1, 2]], vec![]));
}

/// Hands out `n` chunks one by one, as a generation is bred, and returns
/// which each link was sent and how many went out early.
fn handed_early(pool: &mut Pool<Nowhere>, n: usize) -> (Vec<Vec<usize>>, usize) {
    let chunks = no_chunks(n);
    let mut early = Early::default();
    for cut in 1..=n {
        pool.hand_early(&chunks[..cut], &mut early);
    }
    let sent = pool.links.iter().map(|l| l.chunks.clone()).collect();
    (sent, early.sent.len())
}

#[test]
fn chunks_bred_one_by_one_go_round_robin_to_workers_with_room() {
    let mut pool = pool(vec![Vec::new(); 2]);
    // Ten chunks: eight fill both queues, two wait for the hand-out.
    assert_eq!(
        handed_early(&mut pool, 10),
        (vec![vec![0, 2, 4, 6], vec![1, 3, 5, 7]], 8)
    );
}

#[test]
fn chunks_bred_one_by_one_skip_the_worker_beside_the_coordinator() {
    let dir = tempfile::tempdir().unwrap();
    // A stand-in worker pinned to each CPU: the last shares its CPU with
    // the coordinator's thread.
    let mut pool = super::fake::on_every_cpu(dir.path(), false);
    let workers = pool.links.len();
    let others = workers - 1;
    let (sent, early) = handed_early(&mut pool, workers * DEPTH);
    assert_eq!(sent.last(), Some(&vec![]), "the coordinator's neighbour");
    assert!(
        sent[..others].iter().all(|s| s.len() == DEPTH),
        "every other worker fills its queue: {sent:?}"
    );
    assert_eq!(early, others * DEPTH, "the rest wait for the hand-out");
    assert_eq!(pool.children.stop_all(&[]), 0);
}
