//! The coordinator's end of one worker: its client, its job notifier and
//! the chunk it is working on.

use iceoryx2::pending_response::PendingResponse;
use iceoryx2::port::client::Client;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::prelude::*;
use lander_protocol::iox::{self, IpcError, RunNames, JOB_EVENT, MAX_QUEUED, SHUTDOWN_EVENT};
use lander_protocol::wire::{
    JobHeader, ResultHeader, Status, WireError, WireGene, WorkerAnnounce, PROTOCOL_VERSION,
};
use std::collections::VecDeque;
use std::time::{Duration, Instant};

/// Chunks queued at a worker at once, so it never waits for a round trip
/// between one chunk and the next.
pub const DEPTH: usize = 2;

type EvalClient = Client<ipc::Service, [WireGene], JobHeader, [u8], ResultHeader>;
type Pending = PendingResponse<ipc::Service, [WireGene], JobHeader, [u8], ResultHeader>;

struct InFlight {
    job_id: u64,
    /// The pool's index of the job.
    job: usize,
    pending: Pending,
    sent: Instant,
    /// Whether another chunk was ahead of it at the worker.
    queued: bool,
    deadline: Option<Instant>,
}

/// One answered job, its body checked but not decoded.
pub struct Answer {
    pub job: usize,
    pub body: Vec<u8>,
    pub timing: ChunkTiming,
}

/// How long a chunk took, seen from both ends.
#[derive(Clone, Copy, Debug)]
pub struct ChunkTiming {
    /// From sending the request to reading the answer.
    pub round_trip: Duration,
    /// The worker's own time on the job.
    pub compute: Duration,
    /// Whether the chunk waited behind another at the worker, which then
    /// counts in its round trip.
    pub queued: bool,
}

pub struct Link {
    pub id: u64,
    pub pid: u32,
    client: EvalClient,
    jobs: Notifier<ipc::Service>,
    /// Oldest first; the worker answers in order.
    busy: VecDeque<InFlight>,
    broken: bool,
}

impl Link {
    /// Connects to an announced worker's services.
    pub fn open(
        node: &Node<ipc::Service>,
        names: &RunNames,
        w: WorkerAnnounce,
    ) -> Result<Link, IpcError> {
        let client = iox::eval_service(node, &names.eval(w.worker_id))?
            .client_builder()
            .initial_max_slice_len(4096)
            .allocation_strategy(AllocationStrategy::PowerOfTwo)
            .create()
            .map_err(iox::fail("creating a client"))?;
        let jobs = iox::event_service(node, &names.jobs(w.worker_id))?
            .notifier_builder()
            .create()
            .map_err(iox::fail("creating a job notifier"))?;
        Ok(Link {
            id: w.worker_id,
            pid: w.pid,
            client,
            jobs,
            busy: VecDeque::new(),
            broken: false,
        })
    }

    /// True while the worker can queue another chunk.
    pub fn has_room(&self) -> bool {
        self.busy.len() < DEPTH.min(MAX_QUEUED) && !self.broken
    }

    pub fn is_broken(&self) -> bool {
        self.broken
    }

    pub fn deadline(&self) -> Option<Instant> {
        self.busy.iter().filter_map(|f| f.deadline).min()
    }

    pub fn overdue(&self, now: Instant) -> bool {
        self.deadline().is_some_and(|d| now >= d)
    }

    /// Gives up on the jobs in flight, returning them.
    pub fn abandon(&mut self) -> Vec<usize> {
        self.busy.drain(..).map(|f| f.job).collect()
    }

    /// Sends `genes` under `header` as the pool's job `job`.
    pub fn send(
        &mut self,
        header: JobHeader,
        genes: &[WireGene],
        job: usize,
        deadline: Option<Duration>,
    ) -> Result<(), IpcError> {
        let sent = (|| {
            let mut request = self
                .client
                .loan_slice_uninit(genes.len())
                .map_err(iox::fail("loaning a request"))?;
            *request.user_header_mut() = header;
            let pending = request
                .write_from_slice(genes)
                .send()
                .map_err(iox::fail("sending a request"))?;
            if pending.number_of_server_connections() == 0 {
                return Err(IpcError {
                    what: "sending a request".into(),
                    detail: "the worker's server is gone".into(),
                });
            }
            self.jobs
                .notify_with_custom_event_id(EventId::new(JOB_EVENT))
                .map_err(iox::fail("notifying the worker"))?;
            Ok(pending)
        })();
        match sent {
            Ok(pending) => {
                let now = Instant::now();
                let queued = !self.busy.is_empty();
                self.busy.push_back(InFlight {
                    job_id: header.job_id,
                    job,
                    pending,
                    sent: now,
                    queued,
                    deadline: deadline.map(|d| now + d),
                });
                Ok(())
            }
            Err(e) => {
                self.broken = true;
                Err(e)
            }
        }
    }

    /// Collects the answers that arrived, checked against the jobs they
    /// answer but not yet decoded. An answer that fails its checks breaks
    /// the link and is reported beside the good ones; the jobs still in
    /// flight, the refused one among them, are then run elsewhere.
    pub fn poll(&mut self) -> (Vec<Answer>, Option<String>) {
        let mut answered = Vec::new();
        let mut i = 0;
        while i < self.busy.len() {
            let flight = &self.busy[i];
            let answer = match flight.pending.receive() {
                Ok(Some(response)) => {
                    let h = response.user_header();
                    let timing = ChunkTiming {
                        round_trip: flight.sent.elapsed(),
                        compute: Duration::from_nanos(h.compute_ns),
                        queued: flight.queued,
                    };
                    check(flight.job_id, h, response.payload()).map(|body| (body, timing))
                }
                Ok(None) if flight.pending.is_connected() => {
                    i += 1;
                    continue;
                }
                Ok(None) | Err(_) => {
                    self.broken = true;
                    break;
                }
            };
            match answer {
                Ok((body, timing)) => {
                    answered.push(Answer {
                        job: flight.job,
                        body,
                        timing,
                    });
                    self.busy.remove(i);
                }
                Err(e) => {
                    self.broken = true;
                    return (answered, Some(e));
                }
            }
        }
        (answered, None)
    }

    /// Marks the link unusable, for an answer the caller refused.
    pub fn break_off(&mut self) {
        self.broken = true;
    }

    /// Tells the worker the run is over.
    pub fn shut_down(&self) {
        let _ = self
            .jobs
            .notify_with_custom_event_id(EventId::new(SHUTDOWN_EVENT));
    }
}

/// Checks a response against the job it answers and returns its body.
fn check(job_id: u64, h: &ResultHeader, body: &[u8]) -> Result<Vec<u8>, String> {
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
            String::from_utf8_lossy(body)
        )),
        None => Err(format!("unknown status {}", h.status)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lander_protocol::wire::ChunkResult;
    use lander_protocol::{Evaluation, Outcome, State};

    fn header(version: u32, status: Status, job_id: u64) -> ResultHeader {
        ResultHeader {
            version,
            status: status as u32,
            job_id,
            ..ResultHeader::default()
        }
    }

    fn body() -> Vec<u8> {
        let e = Evaluation {
            outcome: Outcome {
                state: State {
                    x: 1.0,
                    y: 60.0,
                    vx: 0.0,
                    vy: -0.1,
                    rot: 0.0,
                },
                ticks: 10,
                n: 10,
                touched_down: true,
                safe: false,
                fitness: 700.0,
            },
            simulated_ticks: 10,
        };
        ChunkResult {
            evaluations: vec![e],
            actions: Vec::new(),
        }
        .encode()
    }

    #[test]
    fn a_good_answer_passes() {
        let h = header(PROTOCOL_VERSION, Status::Done, 7);
        assert_eq!(check(7, &h, &body()), Ok(body()));
    }

    #[test]
    fn answers_it_cannot_check_are_refused_with_the_reason() {
        let other = header(PROTOCOL_VERSION + 1, Status::Done, 7);
        let e = check(7, &other, &body()).unwrap_err();
        assert!(e.contains("protocol version"), "{e}");
        let wrong_job = header(PROTOCOL_VERSION, Status::Done, 8);
        assert!(check(7, &wrong_job, &body()).unwrap_err().contains("job 8"));
        let refused = header(PROTOCOL_VERSION, Status::WrongVersion, 7);
        let e = check(7, &refused, b"speaks version 9").unwrap_err();
        assert!(
            e.contains("refused") && e.contains("speaks version 9"),
            "{e}"
        );
    }
}
