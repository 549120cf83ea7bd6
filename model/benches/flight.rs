//! Simulated ticks per second of `fly` against the straightforward
//! reference, the cost of one guided generation of 100 genomes (against the
//! same with each gene's branches flown one by one), Q(λ) decisions per
//! second, and a generation's breeding draws from a keyed stream (against
//! the same from rand_chacha's generator).
//!
//! `cargo bench --workspace --bench flight`

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use lander_model::evaluate::evaluate_guided_one_by_one;
use lander_model::learn::train;
use lander_model::stream::streams;
use lander_model::{evaluate, fly, reference};
use lander_model::{Action, Env, Gene, GuideParams, LearnParams, Pass, Scoring, StreamKey, World};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;
use std::ops::ControlFlow;

/// 100 random genomes of the paper's shape, each with its own ground.
fn workload() -> Vec<(Env, Vec<Gene>)> {
    let mut rng = ChaCha8Rng::seed_from_u64(42);
    (0..100)
        .map(|_| {
            let env = Env {
                world: World::default(),
                scoring: Scoring::default(),
                x0: rng.random_range(0.0..400.0),
                pad_x: rng.random_range(50.0..350.0),
            };
            let genes = (0..50)
                .map(|_| {
                    Gene::new(
                        Action::ALL[rng.random_range(0..4)],
                        rng.random_range(1..=30),
                    )
                })
                .collect();
            (env, genes)
        })
        .collect()
}

fn flights(c: &mut Criterion) {
    let work = workload();
    let ticks: u64 = work.iter().map(|(e, g)| u64::from(fly(e, g).ticks)).sum();
    for (e, g) in &work {
        assert_eq!(
            fly(e, g),
            reference::fly(e, g),
            "fast and reference flights differ"
        );
    }
    let mut group = c.benchmark_group("fly");
    group.throughput(Throughput::Elements(ticks));
    group.bench_function("fast", |b| {
        b.iter(|| {
            for (e, g) in &work {
                black_box(fly(black_box(e), black_box(g)));
            }
        })
    });
    group.bench_function("reference", |b| {
        b.iter(|| {
            for (e, g) in &work {
                black_box(reference::fly(black_box(e), black_box(g)));
            }
        })
    });
    group.finish();
}

fn guided_generation(c: &mut Criterion) {
    let work = workload();
    let params = GuideParams::default();
    let key = StreamKey::new(1, 1, 0, 1);
    let mut group = c.benchmark_group("generation");
    group.throughput(Throughput::Elements(work.len() as u64));
    for pass in [Pass::Guide, Pass::Fly] {
        group.bench_function(pass.method().name(), |b| {
            b.iter_batched_ref(
                || work.clone(),
                |batch| {
                    for (i, (e, g)) in batch.iter_mut().enumerate() {
                        black_box(evaluate(e, pass, &params, key, i as u64, g));
                    }
                },
                BatchSize::SmallInput,
            )
        });
    }
    // The guided generation with each gene's four branches flown one after
    // another: the baseline that flying them together is measured against.
    group.bench_function("guided one by one", |b| {
        b.iter_batched_ref(
            || work.clone(),
            |batch| {
                for (i, (e, g)) in batch.iter_mut().enumerate() {
                    black_box(evaluate_guided_one_by_one(e, &params, key, i as u64, g));
                }
            },
            BatchSize::SmallInput,
        )
    });
    group.finish();
}

fn qlearning(c: &mut Criterion) {
    let env = Env {
        world: World::default(),
        scoring: Scoring::default(),
        x0: 150.0,
        pad_x: 200.0,
    };
    let learn = LearnParams {
        episodes: 200,
        ..LearnParams::default()
    };
    let key = StreamKey::new(1, 1, 0, 0);
    let mut decisions = 0u64;
    train(&env, &GuideParams::default(), &learn, key, &mut |e| {
        decisions += u64::from(e.decisions);
        ControlFlow::Continue(())
    });
    let mut group = c.benchmark_group("qlearning");
    group.throughput(Throughput::Elements(decisions));
    group.sample_size(20);
    group.bench_function("200 episodes", |b| {
        b.iter(|| {
            train(&env, &GuideParams::default(), &learn, key, &mut |_| {
                ControlFlow::Continue(())
            })
        })
    });
    group.finish();
}

/// The draws of one generation's breeding, about 12,000 64-bit numbers
/// (two a gene for mutation, most of them), as f64s, from the operators'
/// stream: lander's `StreamRng` against rand_chacha's `ChaCha8Rng` over the
/// same words.
fn draws(c: &mut Criterion) {
    const DRAWS: usize = 12_000;
    let key = StreamKey::new(1, 16, 0, 7);
    let oracle = || {
        let mut rng = ChaCha8Rng::from_seed(key.bytes());
        rng.set_stream(streams::OPERATORS);
        rng
    };
    let (mut ours, mut theirs) = (key.rng(streams::OPERATORS), oracle());
    assert!(
        (0..DRAWS).all(|_| ours.random::<f64>() == theirs.random::<f64>()),
        "the two generators' draws differ"
    );
    let mut group = c.benchmark_group("draws");
    group.throughput(Throughput::Elements(DRAWS as u64));
    group.bench_function("stream_rng", |b| {
        b.iter(|| {
            let mut rng = key.rng(streams::OPERATORS);
            (0..DRAWS).map(|_| rng.random::<f64>()).sum::<f64>()
        })
    });
    group.bench_function("rand_chacha", |b| {
        b.iter(|| {
            let mut rng = oracle();
            (0..DRAWS).map(|_| rng.random::<f64>()).sum::<f64>()
        })
    });
    group.finish();
}

criterion_group!(benches, flights, guided_generation, qlearning, draws);
criterion_main!(benches);
