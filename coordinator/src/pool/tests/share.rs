//! `PoolOptions::share`: the coordinator flies queued chunks itself
//! between answers (evaluations and Q(λ) trials alike), and takes one back
//! from a worker's backlog once nothing waits, rather than sleeping.

use super::fake::{answering, assert_refused_alone, no_chunks, recorded, Nowhere, Recorder};
use crate::pool::verify::Check;
use crate::pool::{Pool, PoolOptions};
use lander_protocol::wire::KIND_TRAIN;
use lander_telemetry::Telemetry;
use std::cell::RefCell;

const CHUNKS: usize = 12;

/// A pool of one worker answering every chunk at the next look.
fn one_worker(share: bool) -> Pool<Nowhere> {
    let opts = PoolOptions {
        share,
        ..super::fake::options()
    };
    let mut pool = Pool::with_transport(Nowhere::default(), opts, Default::default()).unwrap();
    pool.links = vec![Recorder {
        answer: Some(vec![1]),
        ..Recorder::holding(7, Vec::new())
    }];
    pool
}

/// Runs `chunks`: a worker's answer to chunk `c` reads `10c + 1`, the
/// coordinator's `10c`. Returns the results and the chunks flown here, in
/// the order flown.
fn run(pool: &mut Pool<Nowhere>, chunks: &[crate::pool::Chunk]) -> (Vec<usize>, Vec<usize>) {
    let here = RefCell::new(Vec::new());
    let check = Check {
        due: &|_, _| false,
        here: &|c| {
            here.borrow_mut().push(c);
            Ok(10 * c)
        },
        differs: &|_, _, _| None,
        shares: true,
    };
    let decode = |c: usize, body: &[u8]| Ok(10 * c + usize::from(body[0]));
    let results = pool.run_checked(chunks, decode, &check, |_, _| {}).unwrap();
    assert!(
        pool.links.iter().all(|l| l.chunks.is_empty()),
        "a generation leaves nothing in flight"
    );
    (results, here.into_inner())
}

#[test]
fn the_coordinator_flies_what_waits_and_a_backlog_taken_back() {
    let mut pool = one_worker(true);
    let (results, here) = run(&mut pool, &no_chunks(CHUNKS));
    assert!(!here.is_empty(), "nothing flown here");
    assert_eq!(pool.flown_here(), here.len() as u64);
    // Each chunk's result is the worker's or the coordinator's, once.
    for (c, &r) in results.iter().enumerate() {
        let by_here = here.contains(&c);
        assert_eq!(r, 10 * c + usize::from(!by_here), "chunk {c}");
    }
    let mut flown: Vec<usize> = here.clone();
    flown.extend(pool.links[0].sent.iter().filter(|c| !here.contains(c)));
    flown.sort_unstable();
    assert_eq!(flown, (0..CHUNKS).collect::<Vec<_>>(), "every chunk once");
    // With nothing left queued, the last chunk of the worker's backlog
    // was taken back and flown here.
    let sent_then_here: Vec<&usize> = here
        .iter()
        .filter(|c| pool.links[0].sent.contains(c))
        .collect();
    assert!(
        !sent_then_here.is_empty(),
        "no backlog taken back: {here:?}"
    );
    assert_eq!(pool.taken_back(), sent_then_here.len() as u64);
}

#[test]
fn without_a_share_every_chunk_goes_to_the_workers() {
    let mut pool = one_worker(false);
    let (results, here) = run(&mut pool, &no_chunks(CHUNKS));
    assert!(here.is_empty());
    assert_eq!(pool.flown_here(), 0);
    let expected: Vec<usize> = (0..CHUNKS).map(|c| 10 * c + 1).collect();
    assert_eq!(results, expected);
}

/// Whatever the job (`Pool::train` shares its Q(λ) trials through
/// `Check::sharing`; `tests/tests/experiment.rs` trains one here).
#[test]
fn queued_training_jobs_are_shared_too() {
    let mut pool = one_worker(true);
    let mut chunks = no_chunks(CHUNKS);
    for chunk in &mut chunks {
        chunk.header.kind = KIND_TRAIN;
        chunk.timed = false;
    }
    let (results, here) = run(&mut pool, &chunks);
    assert!(!here.is_empty(), "no Q(λ) trial trained here");
    for (c, &r) in results.iter().enumerate() {
        assert_eq!(r, 10 * c + usize::from(!here.contains(&c)), "chunk {c}");
    }
}

#[test]
fn chunks_the_coordinator_cannot_fly_are_left_to_the_workers() {
    let mut pool = one_worker(true);
    let decode = |c: usize, body: &[u8]| Ok(10 * c + usize::from(body[0]));
    let results = pool
        .run_chunks(&no_chunks(CHUNKS), decode, |_, _| {})
        .unwrap();
    assert_eq!(pool.flown_here(), 0);
    let expected: Vec<usize> = (0..CHUNKS).map(|c| 10 * c + 1).collect();
    assert_eq!(results, expected);
}

/// Runs `CHUNKS` chunks, every answer checked, with the coordinator's
/// share; returns the results and the chunks flown here.
fn run_checked_sharing(pool: &mut Pool<Nowhere>) -> (Vec<usize>, Vec<usize>) {
    super::fake::run_all_checked(pool, CHUNKS, true)
}

fn checked_workers(lies: &[(u64, u8)], telemetry: Telemetry) -> Pool<Nowhere> {
    let opts = PoolOptions {
        share: true,
        ..super::fake::options()
    };
    let mut pool = Pool::with_transport(Nowhere::default(), opts, telemetry).unwrap();
    pool.links = answering(lies);
    pool
}

/// With `--verify`, the backlog taken back may be a check (of another
/// worker's held answer): it is decided here, as a check with no other
/// worker to go to is, rather than sent out once more.
#[test]
fn a_check_taken_back_for_the_share_is_decided_here() {
    let mut pool = checked_workers(&[(7, 0), (8, 0)], Telemetry::default());
    let (results, here) = run_checked_sharing(&mut pool);
    assert_eq!(results, (0..CHUNKS).map(|c| 10 * c).collect::<Vec<_>>());
    let sent = |i: usize| {
        pool.links
            .iter()
            .map(|l| l.sent.iter().filter(|&&s| s == i).count())
            .sum::<usize>()
    };
    // A chunk flown by a worker, its check sent and then decided here.
    let decided_here = (0..CHUNKS)
        .filter(|&c| sent(c) == 1 && sent(CHUNKS + c) == 1 && here.contains(&c))
        .count();
    assert!(
        decided_here > 0,
        "no check taken back and decided here: here {here:?}, sent {:?}",
        pool.links.iter().map(|l| &l.sent).collect::<Vec<_>>()
    );
    for c in 0..CHUNKS {
        assert!(
            sent(CHUNKS + c) <= 1,
            "the check of chunk {c} went out twice"
        );
    }
}

/// With the share deciding checks, a liar is refused alone, as without,
/// and what it answered is flown again.
#[test]
fn with_the_share_a_liar_is_still_refused_alone() {
    let (dir, telemetry) = recorded();
    let mut pool = checked_workers(&[(7, 1), (8, 0)], telemetry);
    let (results, _) = run_checked_sharing(&mut pool);
    assert_eq!(results, (0..CHUNKS).map(|c| 10 * c).collect::<Vec<_>>());
    assert_refused_alone(&pool, dir.path(), 7, "differs", &[8]);
}
