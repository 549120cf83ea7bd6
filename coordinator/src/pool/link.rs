//! The seam between the pool and its transports: how a [`Transport`] finds
//! workers ([`Arrival`]) and the [`WorkerLink`] to each, the [`Answer`]s a
//! link hands back, and the checks every answer passes before the pool
//! sees it, whatever carried it.

use super::ChunkTiming;
use crate::evaluator::EvalError;
use lander_protocol::wire::{
    JobHeader, ResultHeader, Status, WireError, WireGene, PROTOCOL_VERSION,
};
use lander_protocol::Farewell;
use std::time::{Duration, Instant};

/// A worker that announced itself.
#[derive(Clone, Debug)]
pub struct Arrival {
    pub id: u64,
    pub pid: u32,
    pub version: u32,
    /// The host it runs on, as it said (empty where it did not).
    pub host: String,
}

/// One answered chunk, its body checked but not decoded.
pub struct Answer {
    pub chunk: usize,
    pub body: Vec<u8>,
    pub timing: ChunkTiming,
}

/// How a transport finds its workers and waits for them.
pub trait Transport {
    type Link: WorkerLink;
    /// Its name in the metrics: `iceoryx2`, `zenoh`.
    fn name(&self) -> &'static str;
    /// Workers that announced themselves since the last look.
    fn arrivals(&mut self) -> Result<Vec<Arrival>, EvalError>;
    fn connect(&mut self, arrival: &Arrival) -> Result<Self::Link, String>;
    /// Says that a worker of this id is starting, spawned by the pool: the
    /// transport may open its link now, while the worker starts, for
    /// [`Transport::connect`] to hand over once it announces itself.
    fn expect(&mut self, _id: u64) {}
    /// Says that the spawned worker of this id has exited: a link opened
    /// for it that it never took up is closed, and what it left behind
    /// may be cleared before its replacement starts.
    fn forget(&mut self, _id: u64) {}
    /// Workers the transport has seen go since the last look.
    fn departures(&mut self) -> Vec<u64>;
    /// Sleeps until a worker may have said something, at most `max`.
    fn sleep(&mut self, max: Duration) -> Result<(), EvalError>;
    /// What a spawned `lander-worker` needs on its command line to find
    /// this transport.
    fn worker_args(&self) -> Vec<String>;
    /// How long, when the pool ends, to wait for workers told to leave to
    /// be seen going, so that closing cannot overtake the message telling
    /// them. Zero where a worker also learns it from the transport itself.
    fn farewell(&self) -> Duration {
        Duration::ZERO
    }
    /// Whether answers arrive with no thread of this process to deliver
    /// them (shared memory): only then may the coordinator poll for them
    /// on its CPU before it sleeps (`Pool::spin_for_answers`).
    fn answers_in_shared_memory(&self) -> bool {
        false
    }
    /// Tidies up when the pool ends.
    fn close(&mut self);
}

/// The coordinator's end of one worker: the chunks it is working on.
pub trait WorkerLink {
    fn id(&self) -> u64;
    fn pid(&self) -> u32;
    /// True while the worker can queue another chunk.
    fn has_room(&self) -> bool;
    fn is_broken(&self) -> bool;
    fn deadline(&self) -> Option<Instant>;
    /// Gives up on the chunks in flight, returning them.
    fn abandon(&mut self) -> Vec<usize>;
    /// Chunks sent and not yet answered.
    fn in_flight(&self) -> usize;
    /// Takes back the last chunk queued, one the worker has not started,
    /// so that an idle worker can run it; `None` where the transport cannot
    /// tell the worker to skip it, since it would then be flown twice.
    fn take_back(&mut self) -> Option<usize> {
        None
    }
    /// Sends `genes` under `header` as the pool's chunk `chunk`; the worker
    /// may not look until [`WorkerLink::notify`].
    fn send(
        &mut self,
        header: JobHeader,
        genes: &[WireGene],
        chunk: usize,
        deadline: Option<Duration>,
    ) -> Result<(), String>;
    /// Tells the worker about the chunks sent since the last call, where
    /// the transport needs telling.
    fn notify(&mut self) -> Result<(), String> {
        Ok(())
    }
    /// Collects the answers that arrived, checked against the jobs they
    /// answer but not yet decoded. An answer that fails its checks breaks
    /// the link and is reported beside the good ones; the chunks still in
    /// flight, the refused one among them, are then run elsewhere.
    fn poll(&mut self) -> (Vec<Answer>, Option<String>);
    /// Marks the link unusable, for an answer the caller refused.
    fn break_off(&mut self);
    /// Tells the worker to leave, and why.
    fn shut_down(&self, why: Farewell);
}

pub(super) fn overdue(link: &impl WorkerLink, now: Instant) -> bool {
    link.deadline().is_some_and(|d| now >= d)
}

/// When a worker with chunks in hand is overdue: a deadline after it last
/// answered, or after it was handed a chunk with none in hand. A worker
/// flies its chunks one after another, so a chunk queued behind others is
/// timed from the answer to the one before it, not from when it was sent:
/// `--deadline` is what a worker may take over one chunk.
#[derive(Clone, Copy, Debug)]
pub(super) struct Due {
    since: Instant,
}

impl Due {
    pub fn new() -> Due {
        Due {
            since: Instant::now(),
        }
    }

    /// A chunk was sent at `now` to a worker that held `held` before it.
    pub fn sent(&mut self, held: usize, now: Instant) {
        if held == 0 {
            self.since = now;
        }
    }

    /// The worker answered at `now`.
    pub fn answered(&mut self, now: Instant) {
        self.since = now;
    }

    /// When the worker is overdue, the chunks in hand allowing `deadline`
    /// each (`None`: no deadline, or no chunk in hand).
    pub fn at(&self, deadline: Option<Duration>) -> Option<Instant> {
        deadline.map(|d| self.since + d)
    }
}

/// The most bytes of a worker's own words (a refusal, an error reply) that
/// the pool passes on to its log and events.
const MOST_WORDS: usize = 512;

/// A worker's own words, as text, cut to [`MOST_WORDS`] bytes: what it
/// says travels into the log and `events.jsonl`, and a frame may be
/// 128 MiB.
pub(super) fn words_of(said: &[u8]) -> String {
    if said.len() <= MOST_WORDS {
        return String::from_utf8_lossy(said).into_owned();
    }
    format!(
        "{}… ({} bytes in all)",
        String::from_utf8_lossy(&said[..MOST_WORDS]),
        said.len()
    )
}

/// Checks a response against the job it answers and returns its body.
pub(super) fn check(job_id: u64, h: &ResultHeader, body: &[u8]) -> Result<Vec<u8>, String> {
    if h.version != PROTOCOL_VERSION {
        return Err(WireError::Version { got: h.version }.to_string());
    }
    if h.job_id != job_id {
        return Err(format!(
            "answer to job {} while job {job_id} was asked",
            h.job_id
        ));
    }
    match Status::from_code(h.status) {
        Some(Status::Done) => Ok(body.to_vec()),
        Some(status) => Err(format!(
            "the worker refused the job ({status:?}): {}",
            words_of(body)
        )),
        None => Err(format!("unknown status {}", h.status)),
    }
}

#[cfg(test)]
mod tests {
    use super::{words_of, Due, MOST_WORDS};
    use std::time::{Duration, Instant};

    #[test]
    fn a_workers_words_are_cut_to_a_bound() {
        assert_eq!(words_of(b"no room"), "no room");
        let long = vec![b'x'; 10 * MOST_WORDS];
        let said = words_of(&long);
        assert!(said.starts_with(&"x".repeat(MOST_WORDS)), "{said}");
        assert!(said.ends_with(&format!("… ({} bytes in all)", 10 * MOST_WORDS)));
        assert!(said.len() < MOST_WORDS + 40, "{}", said.len());
    }

    #[test]
    fn a_chunk_queued_behind_others_is_timed_from_the_answer_before_it() {
        let s = Duration::from_secs;
        let t0 = Instant::now();
        let mut due = Due::new();
        // Two chunks sent a second apart, to a worker holding none.
        due.sent(0, t0);
        due.sent(1, t0 + s(1));
        assert_eq!(due.at(Some(s(10))), Some(t0 + s(10)));
        // The first answered after 8 s: the second has 10 s from then.
        due.answered(t0 + s(8));
        assert_eq!(due.at(Some(s(10))), Some(t0 + s(18)));
        assert_eq!(due.at(None), None, "no deadline");
        // Idle, then handed one: timed from then.
        due.sent(0, t0 + s(30));
        assert_eq!(due.at(Some(s(10))), Some(t0 + s(40)));
    }
}
