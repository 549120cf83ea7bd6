//! How each chunk went, in the stamps of both ends: [`ChunkTiming`], and the
//! pool's record of them for `lander bench`.

use super::{Pool, Transport};
use lander_protocol::host::host_clock_ns;
use lander_protocol::wire::ResultHeader;
use std::time::Duration;

/// How a chunk went, seen from both ends, in nanoseconds of the host's
/// monotonic clock ([`host_clock_ns`]). The worker's two stamps are on the
/// coordinator's clock only when both run on one host.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChunkTiming {
    /// The worker that answered.
    pub worker: u64,
    /// The coordinator sent the request.
    pub sent_ns: u64,
    /// The coordinator read the answer.
    pub read_ns: u64,
    /// The worker started the job.
    pub started_ns: u64,
    /// The worker finished the job.
    pub finished_ns: u64,
}

impl ChunkTiming {
    /// The timing of an answer under `h` read now, to a request sent to
    /// `worker` at `sent_ns`.
    pub fn read_now(worker: u64, sent_ns: u64, h: &ResultHeader) -> ChunkTiming {
        ChunkTiming {
            worker,
            sent_ns,
            read_ns: host_clock_ns(),
            started_ns: h.started_ns,
            finished_ns: h.finished_ns,
        }
    }

    /// From sending the request to reading the answer.
    pub fn round_trip(&self) -> Duration {
        Duration::from_nanos(self.read_ns.saturating_sub(self.sent_ns))
    }

    /// The worker's own time on the job.
    pub fn compute(&self) -> Duration {
        Duration::from_nanos(self.finished_ns.saturating_sub(self.started_ns))
    }
}

impl<T: Transport> Pool<T> {
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
}
