//! What the metrics cost where they are counted: the work the pool adds
//! to each chunk (one dispatch, one round trip), and what a finished
//! generation adds (the trial's scores and its wall time). Compared in
//! docs/observability.md with the coordinator's own time per chunk and
//! per generation.

use criterion::{criterion_group, criterion_main, Criterion};
use lander_telemetry::CoordinatorMetrics;
use std::hint::black_box;
use std::time::Duration;

fn per_chunk(c: &mut Criterion) {
    let m = CoordinatorMetrics::new();
    c.bench_function("metrics/per_chunk", |b| {
        b.iter(|| {
            m.chunks_dispatched.inc();
            m.round_trip(black_box(Duration::from_micros(700)));
        })
    });
}

fn per_generation(c: &mut Criterion) {
    let m = CoordinatorMetrics::new();
    m.trial_started("guided/1");
    c.bench_function("metrics/per_generation", |b| {
        b.iter(|| m.generation(black_box("guided/1"), -3.5, -9.25, 100))
    });
}

fn scrape(c: &mut Criterion) {
    let m = CoordinatorMetrics::new();
    for t in 0..8 {
        m.generation(&format!("guided/{t}"), -3.5, -9.25, 100);
    }
    c.bench_function("metrics/scrape", |b| b.iter(|| black_box(m.encode())));
}

criterion_group!(benches, per_chunk, per_generation, scrape);
criterion_main!(benches);
