//! The pool's rebalancing, with real worker processes. While one worker is
//! stopped (SIGSTOP), the other answers its own chunks and then takes the
//! stopped one's queued chunks, one at a time; when the stopped worker
//! resumes it skips what was taken. No chunk is lost or counted twice, the
//! results equal in-process evaluation, and the runs after it go on
//! without losing a chunk to a worker's over-full queue.
//!
//! It opens a pool in this process, so it points this process's iceoryx2
//! use at its own resources, and lives in a test file of its own.

use lander_coordinator::config::RunConfig;
use lander_coordinator::evaluator::{Batch, Evaluator, InProcess};
use lander_coordinator::ga::random_population;
use lander_coordinator::pool::{worker_children, IpcPool, PoolOptions, DEPTH};
use lander_model::stream::streams;
use lander_model::{Pass, StreamKey};
use lander_telemetry::Telemetry;
use lander_tests::{binary, json_lines, signal, Iox};
use std::time::Duration;

/// Evaluates generation `generation` of a seeded workload on `pool` and
/// in-process, and checks the two agree.
fn agree(pool: &mut IpcPool, cfg: &RunConfig, generation: u64) {
    let key = StreamKey::new(cfg.seed, 1, 0, generation);
    let genomes = random_population(&cfg.ga, &mut key.rng(streams::OPERATORS));
    let mut reference = InProcess::new(1).unwrap();
    let mut results = Vec::new();
    for evaluator in [pool as &mut dyn Evaluator, &mut reference] {
        let mut guided = genomes.clone();
        let evaluations = evaluator
            .evaluate(Batch::new(
                cfg.env(0),
                Pass::Guide,
                cfg.guided,
                key,
                cfg.ga.max_duration,
                &mut guided,
            ))
            .unwrap();
        results.push((evaluations, guided));
    }
    assert!(
        results[0] == results[1],
        "generation {generation}: the pool's results differ from in-process"
    );
}

#[test]
fn an_idle_worker_takes_a_stopped_workers_queued_chunks_and_nothing_is_lost() {
    let iox = Iox::new("rebalance");
    iox.enter();
    let cfg = RunConfig::default();
    let dir = tempfile::tempdir().unwrap();
    let telemetry = Telemetry::new("rebalance", None);
    telemetry.record_to(dir.path()).unwrap();
    let opts = PoolOptions {
        run_id: format!("rebalance{}", std::process::id()),
        spawn: 2,
        worker_exe: binary("lander-worker"),
        chunks_per_worker: DEPTH,
        deadline: Duration::from_secs(60),
        max_respawns: 0,
        pin: false,
        min_workers: 0,
        spin: std::time::Duration::ZERO,
        verify: 0.0,
        share: false,
        stand_in: false,
        stop: Default::default(),
    };
    let mut pool = IpcPool::start(opts, telemetry).unwrap();
    pool.wait_for_workers(2, Duration::from_secs(30)).unwrap();
    agree(&mut pool, &cfg, 1);
    let before = pool.taken_back();

    let workers = worker_children(std::process::id());
    assert_eq!(workers.len(), 2, "{workers:?}");
    let stopped = workers[0];
    signal(stopped, "STOP");
    let resume = std::thread::spawn(move || {
        std::thread::sleep(Duration::from_secs(2));
        signal(stopped, "CONT");
    });
    agree(&mut pool, &cfg, 2);
    resume.join().unwrap();
    // Of the stopped worker's four chunks, the first waits for it and up
    // to three go one by one to the worker that is running. Fewer when
    // generation 1 took back some of its chunks: the pool counts those as
    // still queued at the worker until the worker answers a later job
    // (it cannot see the worker skip them), and never lets the queue
    // overflow (`MAX_QUEUED`).
    let taken = pool.taken_back() - before;
    assert!(
        (1..DEPTH as u64).contains(&taken),
        "{taken} chunks taken back from the stopped worker"
    );

    for generation in 3..=40 {
        agree(&mut pool, &cfg, generation);
    }
    assert_eq!(pool.workers(), 2);
    let events = json_lines(&dir.path().join("events.jsonl"));
    let kinds: Vec<&str> = events
        .iter()
        .map(|e| e["event"].as_str().unwrap())
        .collect();
    assert_eq!(
        kinds,
        ["worker_joined", "worker_joined"],
        "the pool reported trouble: {events:?}"
    );
}
