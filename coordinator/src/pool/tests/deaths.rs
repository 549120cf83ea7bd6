//! A spawned worker that dies before it joins: told by the id the pool
//! gave it, and replaced. A worker whose link breaks as a chunk is sent to
//! it: told as a death, never as a refusal.

use super::fake::{no_chunks, options, pool, recorded, Nowhere, Recorder};
use crate::pool::{Pool, PoolOptions};
use std::time::Duration;

#[test]
fn a_worker_that_dies_before_it_joins_is_told_by_its_given_id_and_replaced() {
    let (dir, telemetry) = recorded();
    let exe = crate::pool::spawn::script(&dir.path().join("lander-worker"), "exit 3\n");
    let opts = PoolOptions {
        spawn: 1,
        worker_exe: exe,
        max_respawns: 1,
        ..options()
    };
    let mut pool = Pool::with_transport(Nowhere::default(), opts, telemetry).unwrap();
    // Nobody ever joins: each wait looks after the workers a while, until
    // both processes are reaped.
    let read = || lander_telemetry::events::read(dir.path()).unwrap_or_default();
    for _ in 0..200 {
        assert!(pool
            .wait_for_workers(1, Duration::from_millis(100))
            .is_err());
        if read().len() >= 3 {
            break;
        }
    }
    drop(pool);
    let events = read();
    let kinds: Vec<(&str, &str)> = events
        .iter()
        .map(|e| {
            let worker = e["worker"].as_str().unwrap_or("");
            (e["event"].as_str().unwrap(), worker)
        })
        .collect();
    assert_eq!(
        kinds,
        [
            ("worker_died", "0000000000000001"),
            ("worker_respawned", ""),
            ("worker_died", "0000000000000002"),
        ],
        "{events:?}"
    );
    assert!(events[0]["pid"].as_u64().is_some_and(|p| p > 0));
    assert_eq!(events[0]["why"], "exited");
}

#[test]
fn a_worker_gone_as_a_chunk_is_sent_is_told_as_a_death() {
    let (dir, telemetry) = recorded();
    let links = [(7, Some(1)), (8, None)]
        .into_iter()
        .map(|(id, sends_left)| Recorder {
            answer: Some(b"fine".to_vec()),
            sends_left,
            ..Recorder::holding(id, Vec::new())
        })
        .collect();
    let mut pool = pool(links, telemetry);
    let results = pool
        .run_chunks(&no_chunks(6), |i, _| Ok::<_, String>(i), |_, _| ())
        .unwrap();
    assert_eq!(results, [0, 1, 2, 3, 4, 5]);
    assert_eq!(pool.links.iter().map(|l| l.id).collect::<Vec<_>>(), [8]);
    drop(pool);
    let events = lander_telemetry::events::read(dir.path()).unwrap();
    let told: Vec<(&str, &str)> = events
        .iter()
        .filter(|e| e["worker"] == "0000000000000007")
        .map(|e| {
            (
                e["event"].as_str().unwrap(),
                e["why"].as_str().unwrap_or(""),
            )
        })
        .collect();
    assert_eq!(
        told.first(),
        Some(&("worker_died", "disconnected")),
        "{events:?}"
    );
    assert!(
        !told
            .iter()
            .any(|(event, why)| *event == "worker_refused" || *why == "refused"),
        "{events:?}"
    );
}
