//! A spawned worker that dies before it joins: told by the id the pool
//! gave it, and replaced.

use super::fake::{options, recorded, Nowhere};
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
    let mut pool = Pool::with_transport(Nowhere, opts, telemetry).unwrap();
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
