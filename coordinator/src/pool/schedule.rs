//! Getting a generation's chunks flown: how a generation is cut
//! (`chunk_ranges`, largest first), chunks handed out while the rest of
//! their step is bred (`Pool::hand_early`, which reads the answers that
//! arrived first, so that a worker that answered all it held gets more),
//! and [`Pool::run_chunks`]'s loop of
//! collecting answers, handing out what is queued round-robin
//! (`Pool::dispatch`), taking back from a busy worker for an idle one
//! (`Pool::rebalance`), and only then decoding.

use super::progress::{subject, Progress};
use super::spawn::ChildId;
use super::verify::{Check, Outcome, Verdict};
use super::{Answer, Polled, Pool, Transport, WorkerLink};
use crate::evaluator::EvalError;
use lander_protocol::spin::Spin;
use lander_protocol::wire::{JobHeader, WireGene};
use lander_telemetry::events::Cause;
use lander_telemetry::Event;
use std::collections::VecDeque;
use std::ops::Range;
use std::time::{Duration, Instant};

/// How long a spawned worker whose link broke is given to exit before it
/// is told as disconnected: a killed process's sockets close a moment
/// before it can be reaped.
const EXIT_GRACE: Duration = Duration::from_millis(50);

/// Splits `n` genomes into about `parts` contiguous chunks, largest first,
/// for `workers` workers. The chunks are dealt round-robin, so each round of
/// them is smaller than the last (with four chunks each, 4, 3, 2 and 1
/// tenths of a worker's share): a worker that finishes early then waits
/// for a small chunk rather than a large one, and the chunk it takes back
/// from a busy worker is small too. Measured against equal chunks, 28
/// alternated `lander bench` runs: ipc efficiency better in 18, scaling in 19.
pub(super) fn chunk_ranges(n: usize, parts: usize, workers: usize) -> Vec<Range<usize>> {
    let (parts, workers) = (parts.clamp(1, n.max(1)), workers.max(1));
    let rounds = parts.div_ceil(workers);
    let weights: Vec<usize> = (0..parts).map(|j| rounds - j / workers).collect();
    let total: usize = weights.iter().sum();
    let mut ranges = Vec::with_capacity(parts);
    let (mut weight, mut start) = (0, 0);
    for w in weights {
        weight += w;
        let end = (n * weight + total / 2) / total;
        if end > start {
            ranges.push(start..end);
            start = end;
        }
    }
    ranges
}

/// A worker refused, as events name it, and why.
struct Refusal {
    worker: u64,
    pid: u32,
    why: String,
}

/// One look at `link`'s answers.
fn look(link: &mut impl WorkerLink) -> Polled {
    let (answers, refused) = link.poll();
    Polled {
        id: link.id(),
        pid: link.pid(),
        answers,
        refused,
    }
}

/// The chunks a generation handed out while it was bred
/// ([`Pool::hand_early`]).
#[derive(Default)]
pub(super) struct Early {
    pub sent: Vec<usize>,
    /// The link to try first for the next one.
    next: usize,
    /// The workers woken for theirs.
    woken: Vec<u64>,
}

/// One chunk for the pool: its header (the job id is filled in each time
/// it is sent), its genes, and whether the pool's deadline applies to it.
pub struct Chunk {
    pub header: JobHeader,
    pub genes: Vec<WireGene>,
    /// A whole Q(λ) trial may rightly take minutes, so only evaluation
    /// chunks have deadlines; a dead trainer is still found by its exit or
    /// its node's death.
    pub timed: bool,
}

impl<T: Transport> Pool<T> {
    /// Chunks moved so far from a busy worker to an idle one.
    pub fn taken_back(&self) -> u64 {
        self.taken_back
    }

    /// Chunks flown so far by the coordinator itself
    /// ([`PoolOptions::share`](super::PoolOptions::share)).
    pub fn flown_here(&self) -> u64 {
        self.flown_here
    }

    /// Runs every chunk on the workers and returns the answers in chunk
    /// order. `decode(i, body)` checks and decodes the answer to chunk
    /// `i`; an answer it refuses costs its worker the link, and the chunk
    /// runs elsewhere. `finished(i, result)` hears of each result taken:
    /// again for a chunk whose first was given up, as every answer of a
    /// worker refused since is, with the result taken in its place.
    pub fn run_chunks<R>(
        &mut self,
        chunks: &[Chunk],
        decode: impl Fn(usize, &[u8]) -> Result<R, String>,
        finished: impl FnMut(usize, &R),
    ) -> Result<Vec<R>, EvalError> {
        self.run_checked(chunks, decode, &Check::none(), finished)
    }

    /// [`Pool::run_chunks`], with the answers `check` finds due held until
    /// a check of them is in (`verify`).
    pub(super) fn run_checked<R>(
        &mut self,
        chunks: &[Chunk],
        decode: impl Fn(usize, &[u8]) -> Result<R, String>,
        check: &Check<'_, R>,
        finished: impl FnMut(usize, &R),
    ) -> Result<Vec<R>, EvalError> {
        self.run_checked_after(chunks, &[], decode, check, finished)
    }

    /// [`Pool::run_checked`], the chunks `sent` already handed out
    /// ([`Pool::hand_early`]).
    pub(super) fn run_checked_after<R>(
        &mut self,
        chunks: &[Chunk],
        sent: &[usize],
        decode: impl Fn(usize, &[u8]) -> Result<R, String>,
        check: &Check<'_, R>,
        mut finished: impl FnMut(usize, &R),
    ) -> Result<Vec<R>, EvalError> {
        self.await_first_workers()?;
        let mut progress = Progress::new(chunks.len());
        progress.todo.retain(|c| !sent.contains(c));
        while !progress.is_finished() {
            if self.opts.stop.asked() {
                return Err(EvalError::Interrupted);
            }
            self.accept()?;
            self.reap(&mut progress.todo)?;
            let (fresh, refused) = self.collect(&mut progress);
            let todo = &mut progress.todo;
            self.drop_refused(todo);
            // A killed worker's connection closes as its process exits, a
            // moment before the process can be reaped: a spawned worker
            // whose link broke is given that moment, and the exits are
            // looked for again, so that an exit is told as one.
            let broken: Vec<u32> = self
                .links
                .iter()
                .filter(|l| l.is_broken())
                .map(|l| l.pid())
                .collect();
            if !broken.is_empty() {
                self.children.await_exit(&broken, EXIT_GRACE);
                self.reap(todo)?;
            }
            self.drop_links(todo, |l| l.is_broken(), Cause::Disconnected);
            // Workers refused in this pass: their remaining answers are
            // not read.
            let mut distrusted = refused;
            // A worker that ran dry gets more before anything is decoded:
            // decoding can wait, an idle worker should not.
            progress.drop_answered();
            self.hand_out(chunks, &mut progress, check, &mut distrusted, &mut finished);
            for (worker, a) in fresh {
                if distrusted.contains(&worker) {
                    progress.again(a.chunk);
                    continue;
                }
                let (c, is_check) = progress.subject(a.chunk);
                let verdict = match decode(c, &a.body) {
                    Err(e) => Verdict::refused(a.chunk, worker, format!("a result: {e}")),
                    Ok(value) if is_check => {
                        self.judge_check(&mut progress, check, c, value, worker)
                    }
                    Ok(value) => self.judge(&mut progress, check, c, value, worker),
                };
                self.apply(
                    &mut progress,
                    a.chunk,
                    verdict,
                    &mut distrusted,
                    &mut finished,
                );
            }
            self.drop_refused(&mut progress.todo);
            // The checks of the answers just held, and the chunks of a
            // worker just refused, go out now, not after a sleep (a check
            // with no other worker to fly it is decided here, and may end
            // the generation).
            self.hand_out(chunks, &mut progress, check, &mut distrusted, &mut finished);
            if progress.is_finished() {
                break;
            }
            if self.links.is_empty() && self.children.is_empty() && self.opts.spawn > 0 {
                return Err(EvalError::NoWorkers {
                    respawns: self.opts.max_respawns,
                });
            }
            self.tell_waiting();
            // A refused worker's chunks that found no room, and those of a
            // link that broke in this pass, go out at the next pass, not
            // after a sleep; with a share of its own, the coordinator
            // sleeps only when it has nothing to fly.
            if distrusted.is_empty()
                && !self.links.iter().any(|l| l.is_broken())
                && !self.fly_a_share(chunks, &mut progress, check, &mut finished)
                && !self.spin_for_answers()
            {
                self.sleep()?;
                self.answer_spin.woke();
            }
        }
        // An answer no longer waited for (a check of an answer settled
        // otherwise, as when its worker was refused and its chunk flown
        // again) must not be read as one of the next generation's.
        self.abandon_in_flight();
        Ok(progress.into_results())
    }

    /// Gives up on every chunk still in flight, at a generation's end: an
    /// answer to one is then never read.
    pub(super) fn abandon_in_flight(&mut self) {
        self.arrived.clear();
        for link in &mut self.links {
            link.abandon();
        }
    }

    /// Hands out what waits: checks to workers other than the one they
    /// check (deciding here those with no other worker to go to), then
    /// chunks taken back from a busy worker for an idle one, then the
    /// queue.
    fn hand_out<R>(
        &mut self,
        chunks: &[Chunk],
        progress: &mut Progress<R>,
        check: &Check<'_, R>,
        distrusted: &mut Vec<u64>,
        finished: &mut impl FnMut(usize, &R),
    ) {
        progress.sort();
        for (c, verdict) in self.dispatch_checks(chunks, progress, check) {
            self.apply(progress, c, verdict, distrusted, finished);
        }
        self.drop_refused(&mut progress.todo);
        self.rebalance(chunks, progress);
        progress.sort();
        self.dispatch(chunks, &mut progress.todo);
    }

    /// Carries out the verdict on an answer to `i` (a chunk or a check, as
    /// sent): takes the result, or sends `i` again, and refuses the workers
    /// found wrong, putting back all they answered in the generation.
    fn apply<R>(
        &mut self,
        progress: &mut Progress<R>,
        i: usize,
        verdict: Verdict<R>,
        distrusted: &mut Vec<u64>,
        finished: &mut impl FnMut(usize, &R),
    ) {
        let mut again_of = None;
        match verdict.outcome {
            Outcome::Take(value, by) => {
                let (c, _) = progress.subject(i);
                self.vetted.insert(by);
                finished(c, &value);
                progress.take(c, value, by);
            }
            Outcome::Nothing => {}
            Outcome::Again(i, by) => {
                progress.again(i);
                // A chunk it answered is flown again; a check it flew is
                // only sent elsewhere.
                again_of = (!progress.subject(i).1).then_some(by);
            }
        }
        for (worker, why) in verdict.refusals {
            if !distrusted.contains(&worker) {
                distrusted.push(worker);
                let also = usize::from(again_of == Some(worker));
                self.refuse_worker(
                    progress,
                    Refusal {
                        worker,
                        pid: 0,
                        why,
                    },
                    also,
                );
            }
        }
    }

    /// Refuses a worker for good: breaks its link, says why, and puts back
    /// every chunk it answered in the generation (`also`: besides those
    /// just put back).
    fn refuse_worker<R>(&mut self, progress: &mut Progress<R>, refusal: Refusal, also: usize) {
        let Refusal {
            worker,
            mut pid,
            why,
        } = refusal;
        for link in self.links.iter_mut().filter(|l| l.id() == worker) {
            link.break_off();
            pid = link.pid();
        }
        let who = self.worker_ref(worker, pid);
        self.refuse(worker, who.clone(), why);
        // Its other answers are no longer believed either.
        let chunks = progress.disown(worker) + also;
        if chunks > 0 {
            self.telemetry.event(Event::ChunksRedispatched {
                worker: who,
                chunks,
                why: Cause::Refused,
            });
        }
    }

    /// The answers that arrived, each with the worker that gave it, to
    /// chunks not answered before (a chunk run twice keeps its first
    /// answer); checked, not yet decoded. A worker whose answer failed its
    /// link's checks (its job, its envelope, an error in its place) is
    /// refused now, as one whose answer does not decode is: the second
    /// list holds those workers, none of whose answers may be believed.
    fn collect<R>(&mut self, progress: &mut Progress<R>) -> (Vec<(u64, Answer)>, Vec<u64>) {
        let mut fresh = Vec::new();
        let mut refusals = Vec::new();
        let mut polled = std::mem::take(&mut self.arrived);
        polled.extend(self.links.iter_mut().map(look));
        for Polled {
            id,
            pid,
            answers,
            refused,
        } in polled
        {
            if let Some(e) = refused {
                refusals.push(Refusal {
                    worker: id,
                    pid,
                    why: format!("a result: {e}"),
                });
            }
            for a in answers {
                self.busy.workers += a.timing.compute();
                if let Some(m) = self.telemetry.metrics() {
                    m.round_trip(a.timing.round_trip());
                }
                if let Some(t) = &mut self.timings {
                    t.push(a.timing);
                }
                if progress.first_answer(a.chunk) {
                    fresh.push((id, a));
                }
            }
        }
        // Once every answer is in hand: those of a refused worker go back
        // to be flown again, and are counted with the rest of its work.
        let mut refused = Vec::new();
        for refusal in refusals {
            if refused.contains(&refusal.worker) {
                continue;
            }
            refused.push(refusal.worker);
            let in_hand = fresh.iter().filter(|(w, _)| *w == refusal.worker).count();
            self.refuse_worker(progress, refusal, in_hand);
        }
        (fresh, refused)
    }

    /// Refuses worker `id` for good, saying why; its link is dropped by
    /// the next [`Pool::drop_refused`].
    fn refuse(&mut self, id: u64, worker: lander_telemetry::WorkerRef, why: String) {
        if let Some(m) = self.telemetry.metrics() {
            m.chunks_refused.inc();
        }
        self.telemetry.event(Event::WorkerRefused { worker, why });
        self.refused.insert(id);
    }

    /// Drops the links of the workers refused since the last look. Only
    /// theirs: a link that broke otherwise, such as a send to a worker
    /// just killed, is dropped at the loop's next look as its worker's
    /// death, and told as one.
    fn drop_refused(&mut self, todo: &mut VecDeque<usize>) {
        let refused = std::mem::take(&mut self.refused);
        self.drop_links(todo, |l| refused.contains(&l.id()), Cause::Refused);
    }

    /// Once nothing is left to hand out, gives each idle worker the last
    /// queued chunk of the worker with the longest backlog. Chunks of one
    /// generation cost unevenly (one lander crashes at once, another flies
    /// its whole plan), so without this a worker that drew cheap chunks
    /// would wait for one that drew dear ones.
    /// A check is never given to the worker whose answer it checks: it
    /// goes back to be sent to another.
    pub(super) fn rebalance<R>(&mut self, chunks: &[Chunk], progress: &mut Progress<R>) {
        if !progress.todo.is_empty() {
            return;
        }
        for idle in 0..self.links.len() {
            if self.links[idle].in_flight() > 0 || !self.has_room(idle) || self.stands_in_for(idle)
            {
                continue;
            }
            let Some(chunk) = self.take_back_from_backlog() else {
                break;
            };
            if progress.checked_worker(chunk) == Some(self.links[idle].id()) {
                progress.todo.push_back(chunk);
                break;
            }
            self.hand(idle, chunks, chunk, &mut progress.todo);
        }
    }

    /// Takes back the last chunk queued at the worker with the longest
    /// backlog, two or more in flight (one being flown, the last queued),
    /// and counts it; `None` where no worker has one to give.
    fn take_back_from_backlog(&mut self) -> Option<usize> {
        let chunk = self
            .links
            .iter_mut()
            .filter(|l| l.in_flight() >= 2)
            .max_by_key(|l| l.in_flight())
            .and_then(|l| l.take_back())?;
        self.taken_back += 1;
        if let Some(m) = self.telemetry.metrics() {
            m.chunks_taken_back.inc();
        }
        Some(chunk)
    }

    /// With [`PoolOptions::share`](super::PoolOptions::share) and a `check`
    /// that shares, flies one chunk here instead of sleeping, once a worker
    /// has joined; in place of the worker on its CPU
    /// ([`Pool::stands_in_for`], [`Pool::stands_in_while_starting`]), even
    /// before any has: the first still queued (every worker's queue being
    /// full), or else the last queued at the worker with the longest
    /// backlog, taken back as an idle worker takes it (a check taken back
    /// is decided here). Returns whether it flew one. Between chunks the
    /// coordinator collects answers and refills the workers, so that they
    /// never wait on it for longer than one chunk.
    fn fly_a_share<R>(
        &mut self,
        chunks: &[Chunk],
        progress: &mut Progress<R>,
        check: &Check<'_, R>,
        finished: &mut impl FnMut(usize, &R),
    ) -> bool {
        // Without a worker yet the chunks wait for workers, not for room:
        // a run's one Q(λ) trial goes to its worker, not to the
        // coordinator that started before it. Only in place of the worker
        // on its CPU, while that one starts, does the coordinator fly
        // before any has joined.
        let share = (self.opts.share && !self.links.is_empty())
            || self.stands_in_for_any()
            || self.stands_in_while_starting();
        if !share || !check.shares {
            return false;
        }
        let n = chunks.len();
        let flies_here = |i: usize| i < n;
        let (chunk, queued) = match progress.todo.front() {
            Some(&i) if flies_here(i) => (i, true),
            Some(_) => return false,
            None => {
                let Some(i) = self.take_back_from_backlog() else {
                    return false;
                };
                if !flies_here(i) {
                    // A check, decided here as one with no other worker
                    // to go to is: sent out again, it could come back.
                    let (c, _) = progress.subject(i);
                    if let Some(held) = progress.release(c) {
                        let verdict = self.decide(check, c, held, None);
                        self.apply(progress, c, verdict, &mut Vec::new(), finished);
                        self.drop_refused(&mut progress.todo);
                    }
                    return true;
                }
                (i, false)
            }
        };
        // Wall time, as the workers' own is: and a clock read from the vDSO,
        // where the thread's CPU clock would cost a system call a chunk.
        let started = Instant::now();
        let flown = (check.here)(chunk);
        self.busy.here += started.elapsed();
        match flown {
            Ok(value) => {
                finished(chunk, &value);
                progress.take_here(chunk, value);
                self.flown_here += 1;
                if let Some(m) = self.telemetry.metrics() {
                    m.chunks_flown_here.inc();
                }
                true
            }
            Err(e) => {
                // The workers fly it, and every chunk from now on.
                tracing::warn!("the coordinator cannot fly chunk {chunk} itself: {e}");
                self.opts.share = false;
                self.opts.stand_in = false;
                self.stands_in = false;
                if !queued {
                    progress.again(chunk);
                }
                false
            }
        }
    }

    /// With nothing left to fly, where it stands in for the worker on its
    /// CPU, the coordinator has that CPU to itself: it polls for the
    /// answers it waits for, for a bounded, adaptive time
    /// ([`PoolOptions::spin`](super::PoolOptions::spin), halved after
    /// each poll that finds none), before it sleeps, sparing the wake-up
    /// that ends most steps. Only over a transport whose answers arrive
    /// with no thread of this process to deliver them
    /// ([`Transport::answers_in_shared_memory`]): a poll would otherwise
    /// keep a CPU from the threads that deliver them. Returns whether
    /// something came to see to: an answer, a link broken, a stop asked.
    fn spin_for_answers(&mut self) -> bool {
        if !self.transport.answers_in_shared_memory() || !self.stands_in_for_any() {
            return false;
        }
        let mut spin = std::mem::replace(&mut self.answer_spin, Spin::new(Duration::ZERO));
        let came = spin.poll(|| {
            self.look_for_answers();
            !self.arrived.is_empty()
                || self.links.iter().any(|l| l.is_broken())
                || self.opts.stop.asked()
        });
        self.answer_spin = spin;
        came
    }

    /// Whether link `i` may take another chunk: its transport has room
    /// for it, and it holds fewer than the step allows (`Pool::depth`).
    pub(super) fn has_room(&self, i: usize) -> bool {
        self.links[i].has_room() && self.links[i].in_flight() < self.depth
    }

    /// Whether the coordinator flies, in place of link `i`, the chunks
    /// that would go to it: `i` is the worker on the coordinator's CPU, in
    /// a step of evaluation (`Pool::stands_in`), and another worker is
    /// there to fly the rest, joined or still starting. The coordinator
    /// flies between answers as with a share of its own, with no chunk to
    /// hand over and no worker to wake on that CPU; the worker sleeps. A
    /// chunk sent to that worker while the other starts would wait for
    /// the CPU the coordinator flies on, and its step's end with it, for
    /// as long as a scheduler's time slice: milliseconds.
    fn stands_in_for(&self, i: usize) -> bool {
        self.stands_in
            && (self.links.len() > 1 || self.children.any_apart())
            && self
                .children
                .beside_coordinator(ChildId::of(&self.links[i]))
    }

    /// Whether the coordinator flies in place of any worker
    /// ([`Pool::stands_in_for`]).
    fn stands_in_for_any(&self) -> bool {
        (0..self.links.len()).any(|i| self.stands_in_for(i))
    }

    /// Whether the coordinator flies in place of the worker on its CPU
    /// while that worker is still starting: in a step of evaluation
    /// (`Pool::stands_in`), the worker spawned beside it has not joined
    /// yet. The coordinator then flies whatever waits rather than sleep
    /// until a worker joins: a worker takes milliseconds to start, dozens
    /// of a trial's generations.
    fn stands_in_while_starting(&self) -> bool {
        self.stands_in
            && self
                .children
                .beside()
                .is_some_and(|c| !self.links.iter().any(|l| ChildId::of(l) == c))
    }

    /// Hands the last of `chunks`, just cut while the rest of its generation
    /// is still to be bred, to the next worker with room, round-robin, and
    /// wakes a worker with the first such chunk it gets, or with one found
    /// holding nothing (it may have gone to sleep). The answers that
    /// arrived are read first ([`Pool::look_for_answers`]), so that a
    /// worker that answered all it held has room again. The worker beside
    /// the coordinator's thread gets none: it could fly them only once the
    /// coordinator stops breeding, while the others fly theirs meanwhile.
    /// Where none has room, the chunk waits for the hand-out.
    pub(super) fn hand_early(&mut self, chunks: &[Chunk], early: &mut Early) {
        let Some(chunk) = chunks.len().checked_sub(1) else {
            return;
        };
        self.look_for_answers();
        let links = self.links.len();
        let Some(i) = (0..links).map(|k| (early.next + k) % links).find(|&i| {
            self.has_room(i)
                && !self
                    .children
                    .beside_coordinator(ChildId::of(&self.links[i]))
        }) else {
            return;
        };
        early.next = i + 1;
        // A worker that has answered all it held may have gone to sleep.
        let idle = self.links[i].in_flight() == 0;
        if !self.hand(i, chunks, chunk, &mut VecDeque::new()) {
            return;
        }
        early.sent.push(chunk);
        self.handed_early += 1;
        let id = self.links[i].id();
        let first = !early.woken.contains(&id);
        if first {
            early.woken.push(id);
        }
        if first || idle {
            if let Err(e) = self.links[i].notify() {
                // Its chunks go elsewhere when the broken link is dropped.
                tracing::warn!("cannot notify worker {id:016x}: {e}");
            }
        }
    }

    /// Sends queued chunks to workers with room, one per worker per pass,
    /// so that a generation of few chunks is spread over every worker
    /// rather than queued at the first. Workers are told after the first
    /// pass, so that their waking up overlaps the rest of the hand-out, and
    /// again at the end.
    pub(super) fn dispatch(&mut self, chunks: &[Chunk], todo: &mut VecDeque<usize>) {
        let mut sent = true;
        let mut pass = 0;
        while sent && !todo.is_empty() {
            if pass == 1 {
                self.notify_all();
            }
            pass += 1;
            sent = false;
            for i in 0..self.links.len() {
                if !self.has_room(i) || self.stands_in_for(i) {
                    continue;
                }
                let Some(chunk) = todo.pop_front() else { break };
                sent |= self.hand(i, chunks, chunk, todo);
            }
        }
        self.notify_all();
    }

    /// Sends chunk `chunk` (or a check, as `progress` numbers them) to link
    /// `i` under a fresh job id; if it cannot be sent, it goes back at the
    /// head of `todo`.
    pub(super) fn hand(
        &mut self,
        i: usize,
        chunks: &[Chunk],
        chunk: usize,
        todo: &mut VecDeque<usize>,
    ) -> bool {
        let flown = &chunks[subject(chunk, chunks.len())];
        let mut header = flown.header;
        header.job_id = self.next_job;
        self.next_job += 1;
        let deadline = flown.timed.then_some(self.opts.deadline);
        let link = &mut self.links[i];
        match link.send(header, &flown.genes, chunk, deadline) {
            Ok(()) => {
                if let Some(m) = self.telemetry.metrics() {
                    m.chunks_dispatched.inc();
                }
                true
            }
            Err(e) => {
                tracing::warn!("cannot send to worker {:016x}: {e}", link.id());
                todo.push_front(chunk);
                false
            }
        }
    }

    /// Reads the answers that arrived at links with chunks in flight and
    /// keeps them for the step's loop ([`Pool::collect`]): while the
    /// coordinator still breeds, their workers then have room again.
    fn look_for_answers(&mut self) {
        // A link broken or refused is left for the loop to drop: what it
        // holds goes elsewhere, and nothing more of it is read.
        let refused = &self.refused;
        let open =
            |l: &&mut T::Link| l.in_flight() > 0 && !l.is_broken() && !refused.contains(&l.id());
        for link in self.links.iter_mut().filter(open) {
            let polled = look(link);
            if !polled.answers.is_empty() || polled.refused.is_some() {
                self.arrived.push(polled);
            }
        }
    }

    /// Tells every worker about the chunks sent to it since it was last
    /// told.
    fn notify_all(&mut self) {
        for link in &mut self.links {
            if let Err(e) = link.notify() {
                // Its chunks go elsewhere when the broken link is dropped.
                tracing::warn!("cannot notify worker {:016x}: {e}", link.id());
            }
        }
    }
}
