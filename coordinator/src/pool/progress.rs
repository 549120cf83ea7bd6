//! Where a generation's chunks stand while [`Pool::run_chunks`] runs them:
//! queued, in flight, answered and taken, or held until a check of the
//! answer is in (`--verify`, `verify.rs`).
//!
//! Of `n` chunks, a check of chunk `c` travels as chunk `n + c`, so that
//! its answer comes back apart from the chunk's own and is never taken for
//! it.
//!
//! [`Pool::run_chunks`]: super::Pool::run_chunks

use std::collections::{BTreeMap, VecDeque};

/// The chunk, of `n`, that `i` as sent flies: `i` itself, or the chunk a
/// check numbered `n + c` checks.
pub(super) fn subject(i: usize, n: usize) -> usize {
    if i >= n {
        i - n
    } else {
        i
    }
}

/// An answer held until a check of it is in.
pub(super) struct Held<R> {
    pub value: R,
    /// The worker that gave it.
    pub by: u64,
}

pub(super) struct Progress<R> {
    n: usize,
    /// Chunks to hand out (checks among them only until `sort`).
    pub todo: VecDeque<usize>,
    /// Checks to hand out: the chunks whose held answer they check.
    pub checks: VecDeque<usize>,
    done: Vec<Option<R>>,
    /// The worker whose answer each chunk took.
    owner: Vec<Option<u64>>,
    /// Chunks and checks with an answer in hand, decoded or not.
    answered: Vec<bool>,
    /// Chunks without a taken answer.
    remaining: usize,
    /// Answers waiting for their check, by chunk. Ordered, so that what a
    /// refused worker gave goes out again in chunk order.
    held: BTreeMap<usize, Held<R>>,
}

impl<R> Progress<R> {
    /// `n` chunks, all queued.
    pub fn new(n: usize) -> Progress<R> {
        Progress {
            n,
            todo: (0..n).collect(),
            checks: VecDeque::new(),
            done: (0..n).map(|_| None).collect(),
            owner: vec![None; n],
            answered: vec![false; 2 * n],
            remaining: n,
            held: BTreeMap::new(),
        }
    }

    /// The chunk that `i`, as sent, flies, and whether `i` is a check of it.
    pub fn subject(&self, i: usize) -> (usize, bool) {
        (subject(i, self.n), i >= self.n)
    }

    /// What a check of chunk `c` travels as.
    pub fn check_of(&self, c: usize) -> usize {
        self.n + c
    }

    /// Marks `i` answered; false where it had an answer already (a chunk
    /// run twice keeps its first).
    pub fn first_answer(&mut self, i: usize) -> bool {
        !std::mem::replace(&mut self.answered[i], true)
    }

    /// Every chunk and check has an answer in hand or none may come.
    pub fn is_finished(&self) -> bool {
        self.remaining == 0
    }

    /// Drops from `todo` what has an answer in hand.
    pub fn drop_answered(&mut self) {
        let answered = &self.answered;
        self.todo.retain(|&i| !answered[i]);
    }

    /// Moves the checks in `todo` (put back by a worker that went) to
    /// `checks`, keeping only those whose answer is still held.
    pub fn sort(&mut self) {
        let n = self.n;
        let mut checks = Vec::new();
        self.todo.retain(|&i| {
            if i >= n {
                checks.push(i - n);
            }
            i < n
        });
        for c in checks {
            self.queue_check(c);
        }
    }

    /// Takes `value` from worker `by` as chunk `c`'s result.
    pub fn take(&mut self, c: usize, value: R, by: u64) {
        self.done[c] = Some(value);
        self.owner[c] = Some(by);
        self.remaining -= 1;
    }

    /// Takes `value`, flown here, as chunk `c`'s result: no worker owns it,
    /// and an answer to it from a worker that had it is not read.
    pub fn take_here(&mut self, c: usize, value: R) {
        self.answered[c] = true;
        self.todo.retain(|&i| i != c);
        self.done[c] = Some(value);
        self.owner[c] = None;
        self.remaining -= 1;
    }

    /// Holds `value` from worker `by` for chunk `c` and queues its check.
    pub fn hold(&mut self, c: usize, value: R, by: u64) {
        self.held.insert(c, Held { value, by });
        self.queue_check(c);
    }

    /// Queues the check of chunk `c` again, if its answer is still held and
    /// the check is not queued already.
    pub fn queue_check(&mut self, c: usize) {
        if self.held.contains_key(&c) && !self.checks.contains(&c) {
            self.answered[self.n + c] = false;
            self.checks.push_back(c);
        }
    }

    /// The held answer to chunk `c`, if it is held.
    pub fn held(&self, c: usize) -> Option<&Held<R>> {
        self.held.get(&c)
    }

    /// Takes chunk `c`'s held answer out, to be judged.
    pub fn release(&mut self, c: usize) -> Option<Held<R>> {
        self.held.remove(&c)
    }

    /// The worker whose held answer `i`, as sent, checks.
    pub fn checked_worker(&self, i: usize) -> Option<u64> {
        let (c, check) = self.subject(i);
        check.then(|| self.held(c).map(|h| h.by)).flatten()
    }

    /// Puts `i` (a chunk or a check) back at the head of the queue, to be
    /// flown again.
    pub fn again(&mut self, i: usize) {
        self.answered[i] = false;
        self.todo.push_front(i);
    }

    /// Gives up every answer `worker` gave, taken or held: their chunks go
    /// back in the queue. Returns how many.
    pub fn disown(&mut self, worker: u64) -> usize {
        let mut again = Vec::new();
        for c in 0..self.n {
            if self.owner[c] == Some(worker) && self.done[c].take().is_some() {
                self.owner[c] = None;
                self.remaining += 1;
                again.push(c);
            }
        }
        self.held.retain(|&c, h| {
            if h.by == worker {
                again.push(c);
            }
            h.by != worker
        });
        again.sort_unstable();
        for &c in &again {
            self.answered[c] = false;
            self.todo.push_back(c);
        }
        again.len()
    }

    /// The results, in chunk order, once `is_finished`.
    pub fn into_results(self) -> Vec<R> {
        self.done.into_iter().flatten().collect()
    }
}

#[cfg(test)]
mod tests {
    use super::Progress;

    #[test]
    fn a_check_travels_beside_its_chunk_and_is_never_taken_for_it() {
        let mut p: Progress<u32> = Progress::new(3);
        assert_eq!(p.subject(1), (1, false));
        assert_eq!(p.subject(p.check_of(1)), (1, true));
        p.hold(1, 10, 7);
        assert_eq!(p.checks, [1]);
        assert_eq!(p.checked_worker(4), Some(7));
        assert_eq!(p.checked_worker(1), None, "a chunk checks nothing");
        // A check put back by a worker that went is queued once.
        p.todo.push_front(4);
        p.sort();
        assert_eq!((p.todo.len(), p.checks.len()), (3, 1));
    }

    #[test]
    fn a_disowned_worker_gives_back_what_it_answered_taken_or_held() {
        let mut p: Progress<u32> = Progress::new(4);
        p.todo.clear();
        for c in 0..4 {
            assert!(p.first_answer(c));
        }
        p.take(0, 0, 7);
        p.take(1, 10, 8);
        p.hold(2, 20, 7);
        p.take(3, 30, 8);
        assert!(!p.is_finished());
        assert_eq!(p.disown(7), 2);
        assert_eq!(p.todo, [0, 2]);
        assert!(p.held(2).is_none());
        // The check of 2 is left queued, and dropped as nothing is held.
        p.sort();
        p.take(0, 1, 8);
        p.take(2, 21, 8);
        assert!(p.is_finished());
        assert_eq!(p.into_results(), [1, 10, 21, 30]);
    }
}
