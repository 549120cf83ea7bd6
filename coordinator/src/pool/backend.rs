//! The pool as a [`Backend`](crate::evaluator::Backend): the [`Evaluator`]
//! and [`Trainer`] impls, which turn batches of genomes and Q(λ) trials
//! into chunks, and the answers back into evaluations (writing the guided
//! pass's actions into the genomes) and training results; and whether a
//! step's batches are bred as they are handed out or first (`Pace`).

use super::schedule::{chunk_ranges, Chunk, Early};
use super::verify::{self, Check};
use super::{Pool, Transport, DEPTH, SHARED_STEP_DEPTH};
use crate::evaluator::{Batch, Busy, EvalError, Evaluator, Trainer};
use lander_model::learn::{run_training, LearnState};
use lander_model::{Action, Evaluation, TrainJob, TrainResult};
use lander_protocol::host::thread_cpu_time;
use lander_protocol::wire::{
    decode_training, most_episodes_beside_state, most_genomes_per_chunk, most_state_bytes,
    pack_state, state_bytes, state_fits, ChunkResult, JobHeader, WireGene, KIND_EVALUATE,
    KIND_TRAIN, PROTOCOL_VERSION,
};
use rayon::prelude::*;
use std::ops::Range;
use std::time::Duration;

impl<T: Transport> Trainer for Pool<T> {
    /// Refuses a trial whose state would travel with a leg and may not
    /// fit a network frame ([`Pool::episodes_per_leg`]).
    fn can_train(&self, jobs: &[TrainJob]) -> Result<(), EvalError> {
        jobs.iter()
            .try_for_each(|t| self.episodes_per_leg(t).map(drop))
    }

    /// Each trial in legs of at most `episodes_per_chunk` episodes
    /// (`MOST_EPISODES_PER_CHUNK`), every trial's next leg going out
    /// together, each from the state the last left: a trial of millions
    /// of episodes would otherwise answer in a frame no network carries.
    /// A trial of fewer goes out whole. Legs are the trial bit for bit.
    fn train(
        &mut self,
        trials: &[TrainJob],
        done: &mut dyn FnMut(usize, &TrainResult),
    ) -> Result<Vec<TrainResult>, EvalError> {
        let per_leg: Vec<u32> = trials
            .iter()
            .map(|t| self.episodes_per_leg(t))
            .collect::<Result<_, _>>()?;
        // Each trial's records so far, and the leg it flies next.
        let mut so_far: Vec<Option<TrainResult>> = vec![None; trials.len()];
        let mut next: Vec<Option<TrainJob>> = trials
            .iter()
            .zip(&per_leg)
            .map(|(t, &n)| Some(leg(t, t.from.clone(), n)))
            .collect();
        loop {
            let open: Vec<usize> = (0..trials.len()).filter(|&i| next[i].is_some()).collect();
            if open.is_empty() {
                return Ok(so_far.into_iter().flatten().collect());
            }
            let legs: Vec<TrainJob> = open.iter().filter_map(|&i| next[i].take()).collect();
            let answers = self.train_legs(&legs, &mut |k, r| {
                let i = open[k];
                if legs[k].until == trials[i].until {
                    match &so_far[i] {
                        None => done(i, r),
                        Some(before) => done(i, &joined(before.clone(), r.clone())),
                    }
                }
            })?;
            for ((k, &i), answer) in open.iter().enumerate().zip(answers) {
                let whole = match so_far[i].take() {
                    None => answer,
                    Some(before) => joined(before, answer),
                };
                if legs[k].until < trials[i].until {
                    next[i] = Some(leg(&trials[i], whole.state.clone(), per_leg[i]));
                }
                so_far[i] = Some(whole);
            }
        }
    }
}

/// The leg of `trial` from `from` (its start, where `None`): at most
/// `per_chunk` episodes, and none past the trial's own end.
fn leg(trial: &TrainJob, from: Option<LearnState>, per_chunk: u32) -> TrainJob {
    trial.leg(from, |start| start.saturating_add(per_chunk))
}

/// A trial's records up to the end of `after`, the leg that followed
/// `before`: the summary and state are the later leg's, which count every
/// episode flown so far.
fn joined(mut before: TrainResult, after: TrainResult) -> TrainResult {
    before.episodes.extend(after.episodes);
    TrainResult {
        training: after.training,
        episodes: before.episodes,
        state: after.state,
    }
}

impl<T: Transport> Pool<T> {
    /// The most episodes a leg of `trial` flies: `episodes_per_chunk`, or
    /// fewer where a leg's answer carries the trial's state on, so that
    /// its records and that state fit a network frame together
    /// (`most_episodes_beside_state`). A state that may not fit at all,
    /// going out or coming back, is an error, found before any leg goes
    /// out.
    fn episodes_per_leg(&self, trial: &TrainJob) -> Result<u32, EvalError> {
        let per_chunk = self.episodes_per_chunk.max(1);
        let learn = &trial.learn;
        let too_large = |bytes, why| EvalError::StateTooLarge {
            memory_bits: learn.memory_bits,
            bytes,
            why,
        };
        let start = trial.start();
        if let Some(from) = &trial.from {
            let bytes = state_bytes(from.weights.len());
            if !state_fits(bytes) {
                let why = format!("it starts from a state of {} weights", from.weights.len());
                return Err(too_large(bytes, why));
            }
        }
        let why = if trial.until < learn.episodes {
            format!(
                "a leg ends at episode {} of {}",
                trial.until, learn.episodes
            )
        } else if trial.until.saturating_sub(start) > per_chunk {
            let left = trial.until - start;
            format!("its {left} episodes go out in legs of at most {per_chunk}")
        } else {
            return Ok(per_chunk);
        };
        match most_episodes_beside_state(learn.memory_bits) {
            Some(most) => Ok(per_chunk.min(most)),
            None => Err(too_large(most_state_bytes(learn.memory_bits), why)),
        }
    }

    /// One chunk per leg, with no deadline: a dead trainer is still found
    /// by its exit or its node's death. A leg's starting state travels in
    /// the genes' place (`pack_state`).
    fn train_legs(
        &mut self,
        trials: &[TrainJob],
        done: &mut dyn FnMut(usize, &TrainResult),
    ) -> Result<Vec<TrainResult>, EvalError> {
        let chunks: Vec<Chunk> = trials
            .iter()
            .map(|t| {
                let (genes, state_len) = pack_state(t.from.as_ref());
                Chunk {
                    header: JobHeader {
                        version: PROTOCOL_VERSION,
                        kind: KIND_TRAIN,
                        key: t.key,
                        env: t.env,
                        guide: t.guide,
                        learn: t.learn,
                        until: t.until,
                        state_len,
                        ..JobHeader::default()
                    },
                    genes,
                    timed: false,
                }
            })
            .collect();
        // With a share of its own, the coordinator trains queued trials
        // too, between answers.
        let here = |i: usize| run_training(&trials[i]);
        self.run_checked(
            &chunks,
            |i, body| decode_training(body, &trials[i]).map_err(|e| e.to_string()),
            &Check::sharing(&here),
            done,
        )
    }
}

impl<T: Transport> Evaluator for Pool<T> {
    /// `work` runs on this thread, placed beside a worker where there is
    /// a worker on every CPU ([`Pool::place_thread`]).
    fn drive(&mut self, work: &mut (dyn FnMut(&mut dyn Evaluator) + Send)) {
        let _placed = self.place_thread();
        work(self)
    }

    fn worker_busy(&self) -> Option<Busy> {
        Some(self.busy)
    }

    fn run_over(&mut self) {
        self.ending = lander_protocol::Farewell::RunOver;
    }

    fn evaluate_many(
        &mut self,
        batches: Vec<Batch<'_>>,
    ) -> Result<Vec<Vec<Evaluation>>, EvalError> {
        self.evaluate_each(&mut batches.into_iter())
    }

    /// Takes each batch as it comes to hand it out, so that the work of
    /// making the next (an experiment's trial taking in its last
    /// generation) is done while the workers fly the chunks before it.
    fn evaluate_each<'a>(
        &mut self,
        next: &mut dyn Iterator<Item = Batch<'a>>,
    ) -> Result<Vec<Vec<Evaluation>>, EvalError> {
        // As many batches as may come.
        let (least, most) = next.size_hint();
        let coming = most.unwrap_or(least).max(1);
        self.depth = self.depth_for(coming);
        let evaluations = self.evaluate_step(next, coming);
        self.depth = DEPTH;
        evaluations
    }
}

impl<T: Transport> Pool<T> {
    /// [`Pool::evaluate_each`]'s step of up to `coming` batches, at the
    /// depth it set.
    fn evaluate_step<'a>(
        &mut self,
        next: &mut dyn Iterator<Item = Batch<'a>>,
        coming: usize,
    ) -> Result<Vec<Vec<Evaluation>>, EvalError> {
        // Before any chunk goes out early, as before the hand-out.
        self.await_first_workers()?;
        // A coordinator that flies a share counts as one more worker.
        let workers = self.links.len().max(self.opts.spawn).max(1) + usize::from(self.opts.share);
        // About `chunks_per_worker` chunks per worker in all, however many
        // batches share them.
        let per_batch = (workers * self.opts.chunks_per_worker).div_ceil(coming);
        // Flying counts the coordinator's own chunks too: in place of the
        // worker on its CPU it flies that worker's share.
        let busy = self.busy.flying();
        let mut breeding = Duration::ZERO;
        let mut batches: Vec<Batch<'a>> = Vec::with_capacity(coming);
        // Whether a batch of the step was still to be bred.
        let mut unbred = false;
        if coming > 1 && !self.pace.keeps_up(self.at_once(workers)) {
            // Every batch made now, the making counted as breeding is
            // where they are made as they are handed out.
            let making = thread_cpu_time();
            batches.extend(&mut *next);
            breeding = thread_cpu_time().saturating_sub(making);
            unbred = batches.iter().any(|b| !b.is_bred());
            if batches.len() > 1 && unbred {
                breeding += breed_in_parallel(&mut batches);
            }
        }
        let cutting = thread_cpu_time();
        let mut chunks = Vec::new();
        // For each chunk: its batch, the genomes it covers, their length.
        let mut spans = Vec::new();
        // Chunks handed out while the rest of their generation was bred.
        let mut early = Early::default();
        for b in 0.. {
            if b == batches.len() {
                let Some(batch) = next.next() else { break };
                batches.push(batch);
            }
            let batch = &mut batches[b];
            // A generation not bred yet is bred here, chunk by chunk, each
            // chunk going out as soon as it is bred: a worker flies it
            // while the coordinator breeds the next.
            let bred_here = !batch.is_bred();
            unbred |= bred_here;
            let length = batch.bred_up_to(1).first().map_or(0, Vec::len);
            for range in chunk_ranges(batch.len(), parts(batch.len(), length, per_batch), workers) {
                let genomes = &batch.bred_up_to(range.end)[range.clone()];
                if genomes.iter().any(|g| g.len() != length) {
                    // Chunks sent already are not waited for.
                    self.abandon_in_flight();
                    return Err(EvalError::Ragged);
                }
                chunks.push(chunk_of(batch, range.clone(), length));
                spans.push((b, range, length, batch.pass));
                if bred_here {
                    self.hand_early(&chunks, &mut early);
                }
            }
        }
        breeding += thread_cpu_time().saturating_sub(cutting);
        // The guided actions go back into the genomes as each answer
        // arrives, while other workers still fly: at a generation's end
        // only the last answers' are left to write.
        let rate = self.opts.verify;
        let check = Check {
            due: &|i, first| verify::due(&chunks[i].header, rate, first),
            here: &|i| verify::fly_here(&chunks[i]),
            differs: &|i, truth, answer| verify::differs(&chunks[i], truth, answer),
            shares: true,
        };
        self.stands_in = self.may_stand_in();
        let results = self.run_checked_after(
            &chunks,
            &early.sent,
            |i, body| {
                let (_, range, length, pass) = &spans[i];
                ChunkResult::decode(body, *pass, range.len(), *length).map_err(|e| e.to_string())
            },
            &check,
            |i, result| {
                let (b, range, _, _) = &spans[i];
                write_back(
                    &mut batches[*b].bred_genomes()[range.clone()],
                    &result.actions,
                );
            },
        );
        self.stands_in = false;
        if results.is_err() {
            // Nothing of this step is waited for any more.
            self.abandon_in_flight();
            // The genomes go back as they were bred, their actions as the
            // chunks carried them out: a trial saved now (stopped, or out
            // of workers) flies them again on resuming, and a guided pass
            // over genomes it has rewritten once draws otherwise.
            for ((b, range, _, _), chunk) in spans.iter().zip(&chunks) {
                let bred: Vec<u8> = chunk.genes.iter().map(|g| g.action).collect();
                write_back(&mut batches[*b].bred_genomes()[range.clone()], &bred);
            }
        }
        let results = results?;
        if unbred && batches.len() > 1 {
            self.pace = Pace {
                breeding,
                flying: self.busy.flying().saturating_sub(busy),
            };
        }
        let mut evaluations: Vec<Vec<Evaluation>> = batches
            .iter()
            .map(|b| Vec::with_capacity(b.len()))
            .collect();
        for ((b, _, _, _), result) in spans.iter().zip(results) {
            evaluations[*b].extend(result.evaluations);
        }
        Ok(evaluations)
    }

    /// How many chunks a worker may hold in a step of `batches` batches:
    /// [`SHARED_STEP_DEPTH`] where it is a single batch and the coordinator
    /// flies a share (its own, or that of the worker beside it while
    /// another flies the rest: `Pool::stands_in_for`), else [`DEPTH`].
    fn depth_for(&self, batches: usize) -> usize {
        let shares = self.opts.share
            || (self.may_stand_in() && self.opts.spawn > 1 && self.children.beside().is_some());
        if batches == 1 && shares {
            SHARED_STEP_DEPTH
        } else {
            DEPTH
        }
    }

    /// Whether the coordinator flies the share of the worker on its CPU
    /// itself in an evaluation step (`Pool::stands_in`), sparing the
    /// hand-over and the wake-ups: that worker could start only once the
    /// coordinator had bred the step and slept. With --verify every worker
    /// keeps its share, so that another can check its answers.
    fn may_stand_in(&self) -> bool {
        self.opts.stand_in && self.opts.verify == 0.0
    }

    /// How many of `workers` fly at once: workers spawned here no more
    /// than there are CPUs to run them.
    fn at_once(&self, workers: usize) -> usize {
        if self.opts.spawn > 0 {
            workers.min(self.cpus)
        } else {
            workers
        }
    }
}

/// Breeds every batch first, in parallel on rayon's pool, while the
/// workers wait (one thread would not keep them busy); returns the CPU
/// time it took, summed over the threads.
fn breed_in_parallel(batches: &mut [Batch<'_>]) -> Duration {
    batches
        .par_iter_mut()
        .map(|b| {
            let cpu = thread_cpu_time();
            b.bred_genomes();
            thread_cpu_time().saturating_sub(cpu)
        })
        .sum()
}

/// What a step of several batches still to be bred cost: the
/// coordinator's CPU time making them (an experiment's trials taking in
/// their last generation), breeding them and cutting their chunks, and
/// the time flying them: the workers', and the coordinator's on the
/// chunks it flew itself.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Pace {
    pub breeding: Duration,
    pub flying: Duration,
}

impl Pace {
    /// Whether the coordinator, breeding the batches one after another and
    /// handing each chunk out as soon as it is bred, keeps `workers`
    /// workers busy. Bred so, a step takes at least the breeding; spread
    /// over the workers, the step's work takes (breeding + flying) /
    /// workers. So it keeps up while breeding × (workers − 1) ≤ flying;
    /// otherwise a step's batches are better bred first, in parallel,
    /// while the workers wait. Before any step, it keeps up.
    pub(super) fn keeps_up(&self, workers: usize) -> bool {
        let others = u32::try_from(workers.saturating_sub(1)).unwrap_or(u32::MAX);
        self.breeding.saturating_mul(others) <= self.flying
    }
}

/// How many chunks to cut `n` genomes of `length` genes into: about
/// `per_batch`, more where a chunk would outgrow a network frame. Cut
/// largest first, the largest chunk holds less than twice an even share.
pub(super) fn parts(n: usize, length: usize, per_batch: usize) -> usize {
    per_batch.max(2 * n.div_ceil(most_genomes_per_chunk(length)))
}

/// The chunk that flies `range` of a batch's genomes.
fn chunk_of(batch: &mut Batch<'_>, range: Range<usize>, length: usize) -> Chunk {
    let header = JobHeader {
        version: PROTOCOL_VERSION,
        kind: KIND_EVALUATE,
        pass: batch.pass.code(),
        key: batch.key,
        first_index: range.start as u64,
        genomes: range.len() as u32,
        genome_length: length as u32,
        max_duration: u32::from(batch.max_duration),
        env: batch.env,
        guide: batch.guide,
        ..JobHeader::default()
    };
    Chunk {
        header,
        genes: wire_genes(&batch.bred_up_to(range.end)[range], length),
        timed: true,
    }
}

/// The genes of `genomes`, each `length` long, end to end. Genome by genome
/// rather than through one flattening iterator: this runs for every genome
/// of every generation, and the flattening version profiled at 14% of the
/// coordinator's time in one.
fn wire_genes(genomes: &[crate::ga::Genome], length: usize) -> Vec<WireGene> {
    let mut genes = Vec::with_capacity(genomes.len() * length);
    for genome in genomes {
        genes.extend(genome.iter().map(|&g| WireGene::from(g)));
    }
    genes
}

/// Writes the guided pass's actions into the genomes it rewrote. A chunk
/// of the general GA brings no actions, and leaves its genomes alone.
fn write_back(genomes: &mut [crate::ga::Genome], actions: &[u8]) {
    let length = genomes.first().map_or(0, Vec::len).max(1);
    for (genome, actions) in genomes.iter_mut().zip(actions.chunks(length)) {
        for (gene, &a) in genome.iter_mut().zip(actions) {
            // Checked on decoding: every action is 0..=3.
            gene.action = Action::from_index(a).unwrap_or(gene.action);
        }
    }
}
