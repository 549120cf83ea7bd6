//! Decoding one guided chunk's result (100 genomes of 50 genes), as the
//! coordinator does for every chunk of every generation while its workers
//! wait: the whole decode with its checks, postcard's part alone, and the
//! byte-by-byte search for a bad action that the checks used to make, in
//! the same run.
//!
//! `cargo bench --workspace --bench wire`

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use lander_model::{Evaluation, Outcome, Pass, State};
use lander_protocol::wire::ChunkResult;
use std::hint::black_box;

const GENOMES: usize = 100;
const LENGTH: usize = 50;

fn chunk() -> ChunkResult {
    let evaluations = (0..GENOMES)
        .map(|i| Evaluation {
            outcome: Outcome {
                state: State {
                    x: 100.0 + i as f64,
                    y: 0.5,
                    vx: -1.25,
                    vy: -7.5,
                    rot: 0.3,
                },
                ticks: 400 + i as u32,
                n: 380,
                touched_down: true,
                safe: i % 3 == 0,
                fitness: 1000.0 / (1.0 + i as f64),
            },
            simulated_ticks: 40_000 + i as u64,
        })
        .collect();
    ChunkResult {
        evaluations,
        actions: (0..GENOMES * LENGTH).map(|i| (i % 4) as u8).collect(),
    }
}

fn decode(c: &mut Criterion) {
    let result = chunk();
    let bytes = result.encode();
    let mut group = c.benchmark_group("a guided chunk of 100 genomes");
    group.throughput(Throughput::Elements(GENOMES as u64));
    group.bench_function("decode and check", |b| {
        b.iter(|| ChunkResult::decode(black_box(&bytes), Pass::Guide, GENOMES, LENGTH))
    });
    group.bench_function("postcard alone", |b| {
        b.iter(|| postcard::from_bytes::<ChunkResult>(black_box(&bytes)))
    });
    group.bench_function("the old action check alone", |b| {
        b.iter(|| black_box(&result.actions).iter().position(|&a| a > 3))
    });
    group.finish();
}

criterion_group!(benches, decode);
criterion_main!(benches);
