//! `--verify RATE`: a reproducible sample of answered evaluation chunks is
//! flown again and compared bit for bit. Evaluation is deterministic, so
//! one differing number shows a worker wrong (bad memory, another build
//! that still speaks the protocol, a bug).
//!
//! An answer due for a check is held, not taken, and its chunk is flown
//! again by another worker where there is one (the idlest with room), or
//! else here. Where the two workers agree the answer is taken; where they
//! disagree, the chunk flown here decides, and whichever of them differs
//! from it is dropped for good, with every chunk it answered in the
//! generation flown again (`Pool::run_checked`, `Progress::disown`).
//!
//! The sample depends only on the chunk's stream key and first genome,
//! never on timing or on who answered, so the same run samples the same
//! chunks every time. Besides the sample, each worker's answers are
//! checked until one is taken: a worker wrong on every answer is then
//! caught before any of its answers is.

use super::progress::{Held, Progress};
use super::schedule::Chunk;
use super::{Pool, Transport, WorkerLink};
use lander_protocol::wire::{ChunkResult, EvalJob, JobHeader, KIND_EVALUATE};
use std::collections::VecDeque;

/// How [`Pool::run_checked`] checks answers.
pub(super) struct Check<'a, R> {
    /// Whether the answer to chunk `c` is checked; `first`: its worker has
    /// had no answer taken yet.
    pub due: &'a dyn Fn(usize, bool) -> bool,
    /// Chunk `c` flown here: the answer that decides.
    pub here: &'a dyn Fn(usize) -> Result<R, String>,
    /// What in the second answer to chunk `c` differs from the first
    /// ("its evaluation of genome 7"), if anything.
    pub differs: &'a dyn Fn(usize, &R, &R) -> Option<String>,
    /// Whether `here` may also fly chunks as the coordinator's own share
    /// (`PoolOptions::share`, `Pool::fly_a_share`).
    pub shares: bool,
}

impl<'a, R: 'a> Check<'a, R> {
    /// Checks nothing, and flies nothing here.
    pub fn none() -> Check<'a, R> {
        Check {
            due: &never,
            here: &nowhere::<R>,
            differs: &alike::<R>,
            shares: false,
        }
    }

    /// Checks nothing; `here` flies a chunk as the coordinator's share.
    pub fn sharing(here: &'a dyn Fn(usize) -> Result<R, String>) -> Check<'a, R> {
        Check {
            due: &never,
            here,
            differs: &alike::<R>,
            shares: true,
        }
    }
}

fn never(_: usize, _: bool) -> bool {
    false
}

fn nowhere<R>(_: usize) -> Result<R, String> {
    Err("nothing is flown here".into())
}

fn alike<R>(_: usize, _: &R, _: &R) -> Option<String> {
    None
}

/// What becomes of one answer.
pub(super) struct Verdict<R> {
    pub outcome: Outcome<R>,
    /// The workers found wrong, and why.
    pub refusals: Vec<(u64, String)>,
}

pub(super) enum Outcome<R> {
    /// Taken as its chunk's result, the answer of the worker named.
    Take(R, u64),
    /// Held until its check is in, or a check whose answer is no longer
    /// held: nothing to do.
    Nothing,
    /// Sent again (a chunk, or a check as `Progress` numbers them): no
    /// answer of the worker named is taken for it.
    Again(usize, u64),
}

impl<R> Verdict<R> {
    fn take(value: R, by: u64) -> Verdict<R> {
        Verdict {
            outcome: Outcome::Take(value, by),
            refusals: Vec::new(),
        }
    }

    fn nothing() -> Verdict<R> {
        Verdict {
            outcome: Outcome::Nothing,
            refusals: Vec::new(),
        }
    }

    /// Worker `by`'s answer to `i` (as sent) refused, and `i` sent again.
    pub fn refused(i: usize, by: u64, why: String) -> Verdict<R> {
        Verdict {
            outcome: Outcome::Again(i, by),
            refusals: vec![(by, why)],
        }
    }
}

impl<T: Transport> Pool<T> {
    /// Judges `value`, worker `by`'s answer to chunk `c`: taken, or held
    /// for a check on another worker, or checked here where there is no
    /// other. Until one of a worker's answers is taken, all are due.
    pub(super) fn judge<R>(
        &self,
        progress: &mut Progress<R>,
        check: &Check<'_, R>,
        c: usize,
        value: R,
        by: u64,
    ) -> Verdict<R> {
        let first = !self.vetted.contains(&by);
        if !(check.due)(c, first) {
            return Verdict::take(value, by);
        }
        if self.links.iter().any(|l| l.id() != by && !l.is_broken()) {
            progress.hold(c, value, by);
            return Verdict::nothing();
        }
        self.decide(check, c, Held { value, by }, None)
    }

    /// Judges `value`, worker `checker`'s answer to the check of chunk `c`:
    /// where it agrees with the held answer, that is taken; where not, the
    /// chunk flown here decides.
    pub(super) fn judge_check<R>(
        &mut self,
        progress: &mut Progress<R>,
        check: &Check<'_, R>,
        c: usize,
        value: R,
        checker: u64,
    ) -> Verdict<R> {
        let Some(held) = progress.release(c) else {
            return Verdict::nothing();
        };
        let agree = (check.differs)(c, &held.value, &value).is_none();
        // Two workers neither of which has an answer taken agreeing prove
        // nothing of a build they may share: the chunk flown here decides.
        let vouched = self.vetted.contains(&held.by) || self.vetted.contains(&checker);
        if agree && vouched {
            self.vetted.insert(checker);
            return Verdict::take(held.value, held.by);
        }
        let verdict = self.decide(check, c, held, Some((value, checker)));
        // Taken, the held answer agreed with this host's; the checker, not
        // refused, agreed too.
        let taken = matches!(verdict.outcome, Outcome::Take(..));
        if taken && !verdict.refusals.iter().any(|(w, _)| *w == checker) {
            self.vetted.insert(checker);
        }
        verdict
    }

    /// Flies chunk `c` here and judges the `held` answer, and the
    /// `checker`'s where there is one, against it.
    pub(super) fn decide<R>(
        &self,
        check: &Check<'_, R>,
        c: usize,
        held: Held<R>,
        checker: Option<(R, u64)>,
    ) -> Verdict<R> {
        self.count_check("coordinator");
        let truth = match (check.here)(c) {
            Ok(truth) => truth,
            Err(e) => return Verdict::refused(c, held.by, e),
        };
        let mut refusals = Vec::new();
        if let Some((value, w)) = &checker {
            if let Some(what) = (check.differs)(c, &truth, value) {
                let why = format!(
                    "{what} differs from this host's (--verify, checking worker {:016x})",
                    held.by
                );
                refusals.push((*w, why));
            }
        }
        let Some(what) = (check.differs)(c, &truth, &held.value) else {
            return Verdict {
                outcome: Outcome::Take(held.value, held.by),
                refusals,
            };
        };
        let also = checker.map_or(String::new(), |(_, w)| {
            format!(", flown again on worker {w:016x}")
        });
        refusals.push((
            held.by,
            format!("{what} differs from this host's (--verify{also})"),
        ));
        Verdict {
            outcome: Outcome::Again(c, held.by),
            refusals,
        }
    }

    /// Sends each queued check to the idlest worker with room other than
    /// the one whose answer it checks; decides here each check with no
    /// other worker to go to. Returns the verdicts decided here, each
    /// under its chunk.
    pub(super) fn dispatch_checks<R>(
        &mut self,
        chunks: &[Chunk],
        progress: &mut Progress<R>,
        check: &Check<'_, R>,
    ) -> Vec<(usize, Verdict<R>)> {
        let mut decided = Vec::new();
        let mut waiting = VecDeque::new();
        while let Some(c) = progress.checks.pop_front() {
            let Some(by) = progress.held(c).map(|h| h.by) else {
                continue;
            };
            let others: Vec<usize> = (0..self.links.len())
                .filter(|&i| self.links[i].id() != by && !self.links[i].is_broken())
                .collect();
            let idlest = others
                .iter()
                .copied()
                .filter(|&i| self.has_room(i))
                .min_by_key(|&i| self.links[i].in_flight());
            match idlest {
                Some(i) => {
                    let mut unsent = VecDeque::new();
                    if self.hand(i, chunks, progress.check_of(c), &mut unsent) {
                        self.count_check("worker");
                    } else {
                        waiting.push_back(c);
                    }
                }
                None if !others.is_empty() => waiting.push_back(c),
                None => {
                    if let Some(held) = progress.release(c) {
                        decided.push((c, self.decide(check, c, held, None)));
                    }
                }
            }
        }
        progress.checks = waiting;
        decided
    }

    fn count_check(&self, on: &str) {
        if let Some(m) = self.telemetry.metrics() {
            m.chunks_checked.with_label_values(&[on]).inc();
        }
    }
}

/// Whether the answer to the chunk under `header` is checked: with `rate`
/// above 0, when the chunk is in the sample or the answer is its worker's
/// `first`.
pub(super) fn due(header: &JobHeader, rate: f64, first: bool) -> bool {
    header.kind == KIND_EVALUATE && rate > 0.0 && (first || sampled(header, rate))
}

/// Whether the chunk under `header` is one of the `rate` share checked.
pub(super) fn sampled(header: &JobHeader, rate: f64) -> bool {
    if header.kind != KIND_EVALUATE || rate <= 0.0 {
        return false;
    }
    let k = header.key;
    let mut x: u64 = 0x5eed_0f7e_51f1_ed00;
    for part in [k.seed, k.trial, k.restart, k.generation, header.first_index] {
        x = splitmix(x ^ part);
    }
    // The top 53 bits as a uniform number in [0, 1).
    ((x >> 11) as f64 / (1u64 << 53) as f64) < rate
}

/// SplitMix64's step: every input bit moves about half the output's.
fn splitmix(x: u64) -> u64 {
    let x = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
    let x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    let x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^ (x >> 31)
}

/// `chunk` flown here.
pub(super) fn fly_here(chunk: &Chunk) -> Result<ChunkResult, String> {
    let job = EvalJob::from_wire(&chunk.header, &chunk.genes)
        .map_err(|e| format!("its chunk cannot be flown here: {e}"))?;
    Ok(job.run())
}

/// What in `answer` differs from `truth`, both answers to `chunk`.
pub(super) fn differs(chunk: &Chunk, truth: &ChunkResult, answer: &ChunkResult) -> Option<String> {
    if truth.evaluations.len() != answer.evaluations.len() {
        return Some("its number of evaluations".into());
    }
    let wrong = truth
        .evaluations
        .iter()
        .zip(&answer.evaluations)
        .position(|(a, b)| a != b);
    if let Some(i) = wrong {
        return Some(format!(
            "its evaluation of genome {}",
            chunk.header.first_index + i as u64
        ));
    }
    (truth.actions != answer.actions).then(|| "its guided actions".into())
}

#[cfg(test)]
mod tests {
    use super::*;
    use lander_model::StreamKey;

    fn header(generation: u64, first_index: u64) -> JobHeader {
        JobHeader {
            kind: KIND_EVALUATE,
            key: StreamKey::new(1, 2, 0, generation),
            first_index,
            ..JobHeader::default()
        }
    }

    #[test]
    fn the_sample_is_reproducible_and_near_its_rate() {
        for rate in [0.01, 0.05, 0.2] {
            let picked = (0..20_000)
                .filter(|&i| sampled(&header(i / 10, (i % 10) * 10), rate))
                .count();
            let share = picked as f64 / 20_000.0;
            assert!((share - rate).abs() < rate * 0.2 + 0.002, "{rate}: {share}");
        }
        let h = header(7, 30);
        assert_eq!(sampled(&h, 0.5), sampled(&h, 0.5));
        assert!(!sampled(&h, 0.0));
        assert!(sampled(&h, 1.0));
    }

    #[test]
    fn a_workers_first_answer_is_checked_at_any_rate_above_zero() {
        let unsampled = (0..1000)
            .map(|i| header(i, 0))
            .find(|h| !sampled(h, 0.01))
            .unwrap();
        assert!(!due(&unsampled, 0.01, false));
        assert!(due(&unsampled, 0.01, true));
        assert!(!due(&unsampled, 0.0, true), "rate 0 checks nothing");
        let training = JobHeader {
            kind: lander_protocol::wire::KIND_TRAIN,
            ..unsampled
        };
        assert!(!due(&training, 1.0, true), "training jobs are not checked");
    }
}
