//! The evaluator pool: hands chunks of a generation to worker processes over
//! iceoryx2 and survives their failures.
//!
//! Each generation is split into chunks, several per worker, and the next
//! chunk goes to whichever worker is idle. The pool sleeps on its `wake`
//! event between results, never spinning. A chunk whose worker dies (its
//! process exits, its node is found dead, or its server disconnects) or
//! misses its deadline goes back in the queue; a late duplicate is dropped
//! by job id. Results are placed by chunk, so they are identical however the
//! work was spread.

mod link;
mod spawn;

use crate::evaluator::{Batch, EvalError, Evaluator};
use iceoryx2::port::listener::{Listener, ListenerWaitError};
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use lander_protocol::iox::{self, RunNames};
use lander_protocol::wire::{
    decode_training, ChunkResult, JobHeader, TrainJob, WireGene, WorkerAnnounce, KIND_EVALUATE,
    KIND_TRAIN, PROTOCOL_VERSION,
};
use lander_protocol::{Action, Evaluation, TrainResult};
pub use link::ChunkTiming;
use link::Link;
pub use spawn::worker_children;
use spawn::Children;
use std::collections::{HashSet, VecDeque};
use std::ops::Range;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// How long the pool sleeps at most before looking after its workers.
const SLICE: Duration = Duration::from_millis(25);
/// How often dead nodes are looked for.
const REAP_EVERY: Duration = Duration::from_millis(100);

/// How a pool finds its workers.
#[derive(Clone, Debug)]
pub struct PoolOptions {
    /// The run id that names every service.
    pub run_id: String,
    /// Workers to spawn and keep alive; 0 means workers attach themselves.
    pub spawn: usize,
    /// The `lander-worker` executable for spawned workers.
    pub worker_exe: PathBuf,
    /// Chunks per worker in each generation.
    pub chunks_per_worker: usize,
    /// A chunk not answered within this goes to another worker.
    pub deadline: Duration,
    /// Spawned workers replaced after dying, at most.
    pub max_respawns: usize,
}

/// Messages for the user, such as "waiting for workers".
pub type Say = Box<dyn Fn(&str) + Send>;

pub struct IpcPool {
    opts: PoolOptions,
    names: RunNames,
    node: Node<ipc::Service>,
    register: Subscriber<ipc::Service, WorkerAnnounce, ()>,
    wake: Listener<ipc::Service>,
    links: Vec<Link>,
    /// Workers dropped once are not taken back: a worker that restarts
    /// comes back under a new id.
    dropped: HashSet<u64>,
    children: Children,
    next_job: u64,
    last_reap: Instant,
    told_waiting: bool,
    /// Kept only when asked for, so long runs do not accumulate them.
    timings: Option<Vec<ChunkTiming>>,
    say: Say,
}

impl IpcPool {
    /// Opens the run's services and, when asked to, spawns its workers.
    pub fn start(opts: PoolOptions, say: Say) -> Result<IpcPool, EvalError> {
        iox::quiet_logs();
        let config = iox::config()?;
        let names = RunNames::new(&opts.run_id);
        // Ctrl-C should stop the coordinator at once; a later run reaps what
        // it leaves behind, as this one does now.
        let node = iox::node(
            &format!("lander-coordinator-{}", opts.run_id),
            &config,
            SignalHandlingMode::Disabled,
        )?;
        node.try_cleanup_dead_nodes();
        let register = iox::register_service(&node, &names.register())?
            .subscriber_builder()
            .create()
            .map_err(iox::fail("subscribing to registrations"))?;
        let wake = iox::event_service(&node, &names.wake())?
            .listener_builder()
            .create()
            .map_err(iox::fail("listening for workers"))?;
        let mut pool = IpcPool {
            names,
            node,
            register,
            wake,
            links: Vec::new(),
            dropped: HashSet::new(),
            children: Children::new(
                opts.worker_exe.clone(),
                opts.run_id.clone(),
                opts.max_respawns,
            ),
            next_job: 0,
            last_reap: Instant::now(),
            told_waiting: false,
            timings: None,
            say,
            opts,
        };
        for _ in 0..pool.opts.spawn {
            pool.children.spawn()?;
        }
        Ok(pool)
    }

    /// Workers connected now.
    pub fn workers(&self) -> usize {
        self.links.len()
    }

    /// Waits until `n` workers have announced themselves.
    pub fn wait_for_workers(&mut self, n: usize, patience: Duration) -> Result<(), EvalError> {
        let end = Instant::now() + patience;
        let mut todo = VecDeque::new();
        while self.links.len() < n {
            if Instant::now() >= end {
                return Err(EvalError::WorkersLate {
                    wanted: n,
                    got: self.links.len(),
                    secs: patience.as_secs(),
                });
            }
            self.accept()?;
            self.reap(&mut todo)?;
            self.sleep()?;
        }
        Ok(())
    }

    /// Starts keeping the timing of every chunk answered.
    pub fn record_timings(&mut self) {
        self.timings.get_or_insert_with(Vec::new);
    }

    /// The timings kept since the last call.
    pub fn take_timings(&mut self) -> Vec<ChunkTiming> {
        self.timings
            .as_mut()
            .map(std::mem::take)
            .unwrap_or_default()
    }

    /// Connects to workers that announced themselves since the last look.
    fn accept(&mut self) -> Result<(), EvalError> {
        while let Some(sample) = self
            .register
            .receive()
            .map_err(iox::fail("reading registrations"))?
        {
            let w = *sample;
            if self.dropped.contains(&w.worker_id) || self.links.iter().any(|l| l.id == w.worker_id)
            {
                continue;
            }
            if w.version != PROTOCOL_VERSION {
                (self.say)(&format!(
                    "refusing worker {:016x} (pid {}): it speaks protocol version {}, this coordinator {}",
                    w.worker_id, w.pid, w.version, PROTOCOL_VERSION
                ));
                // It re-announces until served; say so once.
                self.dropped.insert(w.worker_id);
                continue;
            }
            match Link::open(&self.node, &self.names, w) {
                Ok(link) => self.links.push(link),
                Err(e) => (self.say)(&format!("cannot reach worker {:016x}: {e}", w.worker_id)),
            }
        }
        Ok(())
    }

    /// Drops links whose process exited or whose node died, and replaces
    /// spawned workers that are gone. Their chunks go back in `todo`.
    fn reap(&mut self, todo: &mut VecDeque<usize>) -> Result<(), EvalError> {
        for pid in self.children.exited() {
            let replaced = self.children.respawn()?;
            (self.say)(&format!(
                "worker process {pid} exited; {}",
                if replaced {
                    "starting another"
                } else {
                    "no respawns left"
                }
            ));
            self.drop_links(todo, |l| l.pid == pid, "exited");
        }
        if self.last_reap.elapsed() >= REAP_EVERY {
            self.node.try_cleanup_dead_nodes();
            self.last_reap = Instant::now();
        }
        let now = Instant::now();
        self.drop_links(todo, |l| l.overdue(now), "missed its deadline");
        Ok(())
    }

    /// Forgets the links `gone` picks, putting their chunks back first.
    fn drop_links(&mut self, todo: &mut VecDeque<usize>, gone: impl Fn(&Link) -> bool, why: &str) {
        let mut dropped = Vec::new();
        self.links.retain_mut(|link| {
            if !gone(link) {
                return true;
            }
            let chunks = link.abandon();
            for &chunk in chunks.iter().rev() {
                todo.push_front(chunk);
            }
            // A worker we stop trusting is told to leave and, if we
            // spawned it, killed (the next reap replaces it).
            link.shut_down();
            dropped.push((link.id, link.pid, !chunks.is_empty()));
            false
        });
        for (id, pid, requeued) in dropped {
            self.children.kill(pid);
            self.dropped.insert(id);
            let then = if requeued {
                "; its chunks go to other workers"
            } else {
                ""
            };
            (self.say)(&format!("worker {id:016x} {why}{then}"));
        }
    }

    /// Sleeps until a worker says something or the next deadline is due.
    fn sleep(&mut self) -> Result<(), EvalError> {
        let until_deadline = self
            .links
            .iter()
            .filter_map(Link::deadline)
            .min()
            .map(|d| d.saturating_duration_since(Instant::now()));
        let slice = until_deadline.map_or(SLICE, |d| d.min(SLICE));
        match self.wake.timed_wait(|_| {}, slice) {
            // A signal, such as SIGCHLD from a worker that died, only ends
            // the sleep early; the caller looks around anyway.
            Ok(_) | Err(ListenerWaitError::InterruptSignal) => Ok(()),
            Err(e) => Err(iox::fail("waiting for workers")(e).into()),
        }
    }

    fn tell_waiting(&mut self) {
        if self.links.is_empty() && self.opts.spawn == 0 && !self.told_waiting {
            (self.say)(&format!(
                "waiting for workers: start them with `lander-worker --run {}`",
                self.opts.run_id
            ));
            self.told_waiting = true;
        }
    }
}

/// Splits `n` genomes into about `parts` contiguous chunks.
fn chunks(n: usize, parts: usize) -> Vec<Range<usize>> {
    let parts = parts.clamp(1, n.max(1));
    let size = n.div_ceil(parts);
    (0..n)
        .step_by(size.max(1))
        .map(|s| s..(s + size).min(n))
        .collect()
}

/// One job for the pool: its header (the job id is filled in when sent),
/// its genes, and whether the pool's deadline applies to it.
pub struct Job {
    pub header: JobHeader,
    pub genes: Vec<WireGene>,
    /// A whole Q(λ) trial may rightly take minutes, so only evaluation
    /// chunks have deadlines; a dead trainer is still found by its exit or
    /// its node's death.
    pub timed: bool,
}

impl IpcPool {
    /// Runs every job on the workers and returns the answers in job order.
    /// `decode` checks and decodes the answer to job `i`; an answer it
    /// refuses costs its worker the link, and the job runs elsewhere.
    pub fn run_jobs<T>(
        &mut self,
        jobs: &[Job],
        decode: impl Fn(usize, &[u8]) -> Result<T, String>,
    ) -> Result<Vec<T>, EvalError> {
        let mut todo: VecDeque<usize> = (0..jobs.len()).collect();
        let mut done: Vec<Option<T>> = (0..jobs.len()).map(|_| None).collect();
        let mut remaining = jobs.len();
        while remaining > 0 {
            self.accept()?;
            self.reap(&mut todo)?;
            for link in &mut self.links {
                let (answers, refused) = link.poll();
                if let Some(e) = refused {
                    (self.say)(&format!(
                        "refusing a result from worker {:016x}: {e}",
                        link.id
                    ));
                }
                for a in answers {
                    if let Some(t) = &mut self.timings {
                        t.push(a.timing);
                    }
                    // A job run twice keeps its first answer.
                    if done[a.job].is_some() {
                        continue;
                    }
                    match decode(a.job, &a.body) {
                        Ok(value) => {
                            done[a.job] = Some(value);
                            remaining -= 1;
                        }
                        Err(e) => {
                            (self.say)(&format!(
                                "refusing a result from worker {:016x}: {e}",
                                link.id
                            ));
                            link.break_off();
                            todo.push_front(a.job);
                        }
                    }
                }
            }
            self.drop_links(&mut todo, Link::is_broken, "disconnected");
            if remaining == 0 {
                break;
            }
            todo.retain(|&j| done[j].is_none());
            for link in &mut self.links {
                while link.has_room() {
                    let Some(job) = todo.pop_front() else { break };
                    let mut header = jobs[job].header;
                    header.job_id = self.next_job;
                    self.next_job += 1;
                    let deadline = jobs[job].timed.then_some(self.opts.deadline);
                    if let Err(e) = link.send(header, &jobs[job].genes, job, deadline) {
                        (self.say)(&format!("cannot send to worker {:016x}: {e}", link.id));
                        todo.push_front(job);
                    }
                }
            }
            self.drop_links(&mut todo, Link::is_broken, "disconnected");
            if self.links.is_empty() && self.children.is_empty() && self.opts.spawn > 0 {
                return Err(EvalError::NoWorkers {
                    respawns: self.opts.max_respawns,
                });
            }
            self.tell_waiting();
            self.sleep()?;
        }
        Ok(done.into_iter().flatten().collect())
    }

    /// Runs Q(λ) trials on the workers, one job each: the unit of
    /// parallelism for a learner that is sequential within a trial.
    pub fn train(&mut self, trials: &[TrainJob]) -> Result<Vec<TrainResult>, EvalError> {
        let jobs: Vec<Job> = trials
            .iter()
            .map(|t| Job {
                header: JobHeader {
                    version: PROTOCOL_VERSION,
                    kind: KIND_TRAIN,
                    key: t.key,
                    env: t.env,
                    guide: t.guide,
                    learn: t.learn,
                    ..JobHeader::default()
                },
                genes: Vec::new(),
                timed: false,
            })
            .collect();
        self.run_jobs(&jobs, |i, body| {
            decode_training(body, trials[i].learn.episodes).map_err(|e| e.to_string())
        })
    }
}

impl Evaluator for IpcPool {
    fn evaluate(&mut self, batch: Batch<'_>) -> Result<Vec<Evaluation>, EvalError> {
        let n = batch.genomes.len();
        let length = batch.genomes.first().map_or(0, Vec::len);
        if batch.genomes.iter().any(|g| g.len() != length) {
            return Err(EvalError::Ragged);
        }
        let workers = self.links.len().max(self.opts.spawn).max(1);
        let ranges = chunks(n, workers * self.opts.chunks_per_worker);
        let jobs: Vec<Job> = ranges
            .iter()
            .map(|r| {
                let genomes = &batch.genomes[r.clone()];
                Job {
                    header: JobHeader {
                        version: PROTOCOL_VERSION,
                        kind: KIND_EVALUATE,
                        method: batch.method.code(),
                        key: batch.key,
                        first_index: r.start as u64,
                        genomes: genomes.len() as u32,
                        genome_length: length as u32,
                        max_duration: u32::from(batch.max_duration),
                        env: batch.env,
                        guide: batch.guide,
                        ..JobHeader::default()
                    },
                    genes: genomes.iter().flatten().map(|&g| g.into()).collect(),
                    timed: true,
                }
            })
            .collect();
        let method = batch.method;
        let results = self.run_jobs(&jobs, |i, body| {
            ChunkResult::decode(body, method, ranges[i].len(), length).map_err(|e| e.to_string())
        })?;
        Ok(assemble(batch.genomes, &ranges, results))
    }
}

/// Puts the chunks' results in population order and writes the guided
/// actions back into the genomes.
fn assemble(
    genomes: &mut [crate::ga::Genome],
    ranges: &[Range<usize>],
    results: Vec<ChunkResult>,
) -> Vec<Evaluation> {
    let mut out = Vec::with_capacity(genomes.len());
    for (range, result) in ranges.iter().zip(results) {
        let chunk = &mut genomes[range.clone()];
        if !result.actions.is_empty() {
            let genes = chunk.iter_mut().flat_map(|g| g.iter_mut());
            for (gene, &a) in genes.zip(&result.actions) {
                // Checked on decoding: every action is 0..=3.
                gene.action = Action::from_index(a).unwrap_or(gene.action);
            }
        }
        out.extend(result.evaluations);
    }
    out
}

impl Drop for IpcPool {
    fn drop(&mut self) {
        for link in &self.links {
            link.shut_down();
        }
        self.children.stop_all();
        self.node.try_cleanup_dead_nodes();
    }
}

#[cfg(test)]
mod tests {
    use super::chunks;

    #[test]
    fn chunks_cover_everything_once_in_order() {
        for (n, parts) in [(100, 8), (100, 1), (7, 20), (1, 4), (0, 3), (10_000, 12)] {
            let c = chunks(n, parts);
            let flat: Vec<usize> = c.iter().flat_map(|r| r.clone()).collect();
            assert_eq!(flat, (0..n).collect::<Vec<_>>(), "n={n} parts={parts}");
            assert!(c.len() <= parts.max(1));
        }
    }
}
