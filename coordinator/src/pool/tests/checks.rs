//! `run_checked` (`--verify`) over links that answer at once: a checked
//! answer is held while another worker flies its chunk again, taken where
//! the two agree, and judged by the chunk flown here where they do not.

use super::fake::{self, answering, assert_refused_alone, pool, recorded, Nowhere};
use crate::pool::verify::Check;
use crate::pool::Pool;
use lander_telemetry::Telemetry;

const CHUNKS: usize = 6;

/// Links answering every chunk `c` with `10c + lie`.
fn workers(lies: &[(u64, u8)], telemetry: Telemetry) -> Pool<Nowhere> {
    pool(answering(lies), telemetry)
}

/// Runs `CHUNKS` chunks with every answer checked; returns the results
/// and how many chunks were flown here.
fn run_all_checked(pool: &mut Pool<Nowhere>) -> (Vec<usize>, usize) {
    let (results, here) = fake::run_all_checked(pool, CHUNKS, false);
    (results, here.len())
}

#[test]
fn a_checked_answer_is_flown_again_on_another_worker_and_taken_where_they_agree() {
    let (_dir, telemetry) = recorded();
    let mut pool = workers(&[(7, 0), (8, 0)], telemetry.clone());
    let (results, here) = run_all_checked(&mut pool);
    assert_eq!(results, [0, 10, 20, 30, 40, 50]);
    // Their first answers, checked by each other, are checked here too:
    // two workers that agree before either was vetted may share a build.
    assert_eq!(
        here, 1,
        "two vetted workers that agree need nothing flown here"
    );
    // Each chunk flown by one worker, and its check (sent as CHUNKS + c)
    // by the other.
    for c in 0..CHUNKS {
        let by = |i: usize| pool.links.iter().filter(|l| l.sent.contains(&i)).count();
        assert_eq!((by(c), by(CHUNKS + c)), (1, 1), "chunk {c}");
        let same = pool
            .links
            .iter()
            .any(|l| l.sent.contains(&c) && l.sent.contains(&(CHUNKS + c)));
        assert!(!same, "chunk {c} was checked by the worker that flew it");
    }
    let metrics = String::from_utf8(telemetry.metrics().unwrap().encode()).unwrap();
    assert!(
        metrics.contains("lander_chunks_checked_total{on=\"worker\"} 6"),
        "{metrics}"
    );
}

#[test]
fn where_two_workers_disagree_the_chunk_flown_here_decides() {
    let (dir, telemetry) = recorded();
    let mut pool = workers(&[(7, 1), (8, 0)], telemetry);
    let (results, here) = run_all_checked(&mut pool);
    assert_eq!(
        results,
        [0, 10, 20, 30, 40, 50],
        "the liar's answers are not taken"
    );
    assert!(here >= 1);
    let why = "differs from this host's (--verify";
    assert_refused_alone(&pool, dir.path(), 7, why, &[8]);
}

#[test]
fn with_one_worker_every_check_is_flown_here() {
    let mut pool = workers(&[(8, 0)], Default::default());
    let (results, here) = run_all_checked(&mut pool);
    assert_eq!(results, [0, 10, 20, 30, 40, 50]);
    assert_eq!(here, CHUNKS);
    assert!(
        pool.links[0].sent.iter().all(|&i| i < CHUNKS),
        "no check sent"
    );
}

/// Worker 8 alone is left, the two others refused.
fn assert_two_refused_and_8_left(pool: &Pool<Nowhere>, dir: &std::path::Path) {
    let ids: Vec<u64> = pool.links.iter().map(|l| l.id).collect();
    assert_eq!(ids, [8]);
    let events = lander_telemetry::events::read(dir).unwrap();
    let refused = events
        .iter()
        .filter(|e| e["event"] == "worker_refused")
        .count();
    assert_eq!(refused, 2, "{events:?}");
}

#[test]
fn two_wrong_workers_that_disagree_are_both_refused() {
    let (dir, telemetry) = recorded();
    let mut pool = workers(&[(7, 1), (9, 2), (8, 0)], telemetry);
    let (results, _) = run_all_checked(&mut pool);
    assert_eq!(results, [0, 10, 20, 30, 40, 50]);
    assert_two_refused_and_8_left(&pool, dir.path());
}

/// Two workers of one wrong build, each checking the other's first
/// answer before either has had one taken, beside a slow honest one; only
/// first answers are checked.
#[test]
fn two_workers_of_one_wrong_build_that_agree_are_both_refused() {
    let (dir, telemetry) = recorded();
    let mut links = answering(&[(7, 1), (9, 1), (8, 0)]);
    links[2].looks_per_answer = 8;
    let mut pool = pool(links, telemetry);
    let check = Check {
        due: &|_, first| first,
        here: &|c| Ok(10 * c),
        differs: &|c, a: &usize, b: &usize| (a != b).then(|| format!("its answer to chunk {c}")),
        shares: false,
    };
    let decode = |c: usize, body: &[u8]| Ok(10 * c + usize::from(body[0]));
    let results = pool
        .run_checked(&fake::no_chunks(12), decode, &check, |_, _| {})
        .unwrap();
    assert_eq!(results, (0..12).map(|c| 10 * c).collect::<Vec<_>>());
    assert_two_refused_and_8_left(&pool, dir.path());
}
