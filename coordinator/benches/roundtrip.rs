//! Round trip of one chunk of 1, 10 and 100 genomes to a real
//! `lander-worker` process over iceoryx2, beside the same chunk evaluated
//! in-process, so the transport's cost is the difference.
//!
//! `cargo build --workspace --release --bins && cargo bench --workspace --bench roundtrip`

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use lander_coordinator::config::RunConfig;
use lander_coordinator::evaluator::{Batch, Evaluator, InProcess};
use lander_coordinator::ga::random_population;
use lander_coordinator::pool::{IpcPool, PoolOptions};
use lander_model::stream::streams;
use lander_model::{Pass, StreamKey};
use std::time::Duration;

fn worker_pool() -> IpcPool {
    // target/release/deps/roundtrip-… → target/release/lander-worker
    let exe = std::env::current_exe().expect("the bench knows its path");
    let worker_exe = exe
        .parent()
        .and_then(|deps| deps.parent())
        .expect("benches live in target/<profile>/deps")
        .join("lander-worker");
    assert!(
        worker_exe.exists(),
        "{} is missing: run `cargo build --workspace --release --bins` first",
        worker_exe.display()
    );
    let opts = PoolOptions {
        run_id: format!("rtt{:08x}", rand::random::<u32>()),
        spawn: 1,
        worker_exe,
        chunks_per_worker: 1,
        deadline: Duration::from_secs(30),
        max_respawns: 0,
        pin: true,
        min_workers: 0,
        spin: std::time::Duration::ZERO,
        verify: 0.0,
        share: false,
        stand_in: false,
        stop: Default::default(),
    };
    let mut pool = IpcPool::start(opts, Default::default()).expect("pool starts");
    pool.wait_for_workers(1, Duration::from_secs(20))
        .expect("the worker announces itself");
    pool
}

fn roundtrip(c: &mut Criterion) {
    let mut cfg = RunConfig::default();
    let mut pool = worker_pool();
    let mut local = InProcess::new(1).expect("one thread");
    let mut group = c.benchmark_group("chunk");
    for size in [1usize, 10, 100] {
        cfg.ga.population = size;
        let key = StreamKey::new(1, 1, 0, 1);
        let genomes = random_population(&cfg.ga, &mut key.rng(streams::OPERATORS));
        group.throughput(Throughput::Elements(size as u64));
        let mut run = |name: &str, evaluator: &mut dyn Evaluator| {
            group.bench_function(format!("{name}/{size}"), |b| {
                b.iter_batched_ref(
                    || genomes.clone(),
                    |g| {
                        evaluator
                            .evaluate(Batch::new(
                                cfg.env(0),
                                Pass::Fly,
                                cfg.guided,
                                key,
                                cfg.ga.max_duration,
                                g,
                            ))
                            .expect("evaluation succeeds")
                    },
                    BatchSize::SmallInput,
                )
            });
        };
        run("iceoryx2", &mut pool);
        run("inproc", &mut local);
    }
    group.finish();
}

criterion_group!(benches, roundtrip);
criterion_main!(benches);
