//! A deterministic stand-in for an evaluator, for the bench's unit tests:
//! answers that depend only on the work (or are wrong on purpose), chunk
//! timings made by hand, and a log of who flew which generation.

use super::{Measured, Workload};
use crate::config::RunConfig;
use crate::evaluator::{Batch, EvalError, Evaluator};
use crate::pool::ChunkTiming;
use crate::stop::Stop;
use lander_model::{Evaluation, Outcome, Pass, State};
use std::cell::RefCell;
use std::rc::Rc;

/// Who was called, and for which generation, in call order.
pub type Log = Rc<RefCell<Vec<(&'static str, u64)>>>;

/// `generations` steps of `in_flight` trials of `population` genomes.
pub fn workload(generations: u64, population: usize, in_flight: usize) -> Workload {
    let mut cfg = RunConfig::default();
    cfg.ga.population = population;
    cfg.ga.elites = cfg.ga.elites.min(population);
    Workload::new(
        &cfg,
        Pass::Guide,
        Some(generations),
        in_flight,
        &Stop::new(),
    )
    .expect("a GA workload")
}

pub struct Fake {
    label: &'static str,
    workers: usize,
    log: Log,
    calls: usize,
    /// Over "worker processes": one chunk per worker a call, each computing
    /// this long. `None` in-process: no chunks.
    compute_ns: Option<u64>,
    /// The first call's compute instead, where there are chunks.
    pub warm_up_compute_ns: Option<u64>,
    /// Calls, counted from 0, whose every fitness is one off.
    pub wrong_on: Vec<usize>,
    /// Loses the last genome of every batch.
    pub drop_last: bool,
}

impl Fake {
    pub fn new(label: &'static str, workers: usize, log: &Log) -> Fake {
        Fake {
            label,
            workers,
            log: log.clone(),
            calls: 0,
            compute_ns: None,
            warm_up_compute_ns: None,
            wrong_on: Vec::new(),
            drop_last: false,
        }
    }

    /// Answers in chunks: one per worker a call, each sent at the call's
    /// start, computing from 10 ns on for `compute_ns`, and read 10 ns
    /// after.
    pub fn with_chunks(mut self, compute_ns: u64) -> Fake {
        self.compute_ns = Some(compute_ns);
        self
    }
}

impl Evaluator for Fake {
    fn drive(&mut self, work: &mut (dyn FnMut(&mut dyn Evaluator) + Send)) {
        work(self)
    }

    fn evaluate_many(
        &mut self,
        batches: Vec<Batch<'_>>,
    ) -> Result<Vec<Vec<Evaluation>>, EvalError> {
        let generation = batches.first().map_or(0, |b| b.key.generation);
        self.log.borrow_mut().push((self.label, generation));
        let off = if self.wrong_on.contains(&self.calls) {
            1.0
        } else {
            0.0
        };
        self.calls += 1;
        Ok(batches
            .iter()
            .map(|b| {
                let mut answers: Vec<Evaluation> = (0..b.len())
                    .map(|i| {
                        let fitness =
                            (b.key.trial * 1000 + b.key.generation * 100) as f64 + i as f64 + off;
                        evaluation(fitness)
                    })
                    .collect();
                if self.drop_last {
                    answers.pop();
                }
                answers
            })
            .collect())
    }
}

impl Measured for Fake {
    fn workers(&self) -> usize {
        self.workers
    }

    fn drive_measured(&mut self, work: &mut (dyn FnMut(&mut dyn Measured) + Send)) {
        work(self)
    }

    fn take_timings(&mut self) -> Vec<ChunkTiming> {
        let Some(mut compute) = self.compute_ns else {
            return Vec::new();
        };
        if self.calls == 1 {
            compute = self.warm_up_compute_ns.unwrap_or(compute);
        }
        // Each call 10 s after the one before, so calls never overlap.
        let at = (self.calls as u64 - 1) * 10_000_000_000;
        (0..self.workers as u64)
            .map(|worker| ChunkTiming {
                worker,
                sent_ns: at,
                read_ns: at + 20 + compute,
                started_ns: at + 10,
                finished_ns: at + 10 + compute,
            })
            .collect()
    }
}

fn evaluation(fitness: f64) -> Evaluation {
    Evaluation {
        outcome: Outcome {
            state: State {
                x: 0.0,
                y: 0.0,
                vx: 0.0,
                vy: 0.0,
                rot: 0.0,
            },
            ticks: 10,
            n: 10,
            touched_down: true,
            safe: true,
            fitness,
        },
        simulated_ticks: 10,
    }
}
