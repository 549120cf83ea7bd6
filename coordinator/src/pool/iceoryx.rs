//! The iceoryx2 transport: workers on this host announce themselves on the
//! run's registration service, and each has its own request-response and
//! event services, since iceoryx2 delivers a request to every server.

use super::link::{check, Due};
use super::{Answer, Arrival, ChunkTiming, Transport, WorkerLink, DEPTH};
use crate::evaluator::EvalError;
use iceoryx2::pending_response::PendingResponse;
use iceoryx2::port::client::Client;
use iceoryx2::port::listener::{Listener, ListenerWaitError};
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use lander_protocol::host::host_clock_ns;
use lander_protocol::iox::{self, IpcError, RunNames, JOB_EVENT, MAX_QUEUED};
use lander_protocol::wire::{JobHeader, ResultHeader, WireGene, WorkerAnnounce};
use lander_protocol::Farewell;
use std::collections::HashMap;
use std::collections::VecDeque;
use std::time::{Duration, Instant};

// Chunks taken back need room in a worker's queue beside the ones queued.
const _: () = assert!(DEPTH < MAX_QUEUED);

/// How often dead nodes are looked for.
const REAP_EVERY: Duration = Duration::from_millis(500);

/// The coordinator's iceoryx2 node and the run's shared services.
pub struct Iceoryx {
    names: RunNames,
    node: Node<ipc::Service>,
    register: Subscriber<ipc::Service, WorkerAnnounce, ()>,
    wake: Listener<ipc::Service>,
    last_reap: Instant,
    /// This host's name, which every worker shares.
    host: String,
    /// Links opened for spawned workers that have not announced
    /// themselves yet ([`Transport::expect`]), by worker id.
    opened: HashMap<u64, Link>,
}

impl Iceoryx {
    /// Opens the run's registration and wake-up services, after cleaning
    /// up what dead nodes left behind.
    pub fn open(run_id: &str) -> Result<Iceoryx, EvalError> {
        iox::quiet_logs();
        let config = iox::config()?;
        let names = RunNames::new(run_id);
        // Ctrl-C should stop the coordinator at once; a later run reaps what
        // it leaves behind, as this one does now.
        let node = iox::node(
            &format!("lander-coordinator-{run_id}"),
            &config,
            SignalHandlingMode::Disabled,
        )?;
        iox::clean_up_dead(&node);
        // After this one's node is made, so that of two started at once
        // one sees the other, whichever made its node second.
        if let Some(pid) = iox::other_alive_named(&node)? {
            return Err(iox::IpcError {
                what: format!("run {run_id}"),
                detail: format!(
                    "another coordinator (process {pid}) runs it on this host; give this one another --run-id"
                ),
            }
            .into());
        }
        let register = iox::register_service(&node, &names.register())?
            .subscriber_builder()
            .create()
            .map_err(iox::fail("subscribing to registrations"))?;
        let wake = iox::event_service(&node, &names.wake())?
            .listener_builder()
            .create()
            .map_err(iox::fail("listening for workers"))?;
        Ok(Iceoryx {
            names,
            node,
            register,
            wake,
            last_reap: Instant::now(),
            host: lander_protocol::host::name(),
            opened: HashMap::new(),
        })
    }
}

impl Transport for Iceoryx {
    type Link = Link;

    fn name(&self) -> &'static str {
        "iceoryx2"
    }

    fn answers_in_shared_memory(&self) -> bool {
        true
    }

    fn arrivals(&mut self) -> Result<Vec<Arrival>, EvalError> {
        let mut arrived = Vec::new();
        while let Some(sample) = self
            .register
            .receive()
            .map_err(iox::fail("reading registrations"))?
        {
            let w = *sample;
            arrived.push(Arrival {
                id: w.worker_id,
                pid: w.pid,
                version: w.version,
                // Workers over iceoryx2 share this host.
                host: self.host.clone(),
            });
        }
        Ok(arrived)
    }

    fn connect(&mut self, a: &Arrival) -> Result<Link, String> {
        if let Some(mut link) = self.opened.remove(&a.id) {
            link.pid = a.pid;
            return Ok(link);
        }
        Link::open(&self.node, &self.names, a.id, a.pid).map_err(|e| e.to_string())
    }

    /// Opens the worker's services and its client now. A connection's
    /// shared memory is set up by whichever end comes second, page by
    /// page (iceoryx2 sizes it for every segment a dynamic data segment
    /// may grow to: 1.0 MB for a worker's answers, `iox::eval_service`):
    /// with the client there first, the worker's server sets it up as it
    /// starts, on its own CPU, and the client later opens it. A link
    /// that fails to open here is opened again when the worker announces
    /// itself.
    fn expect(&mut self, id: u64) {
        if let Ok(link) = Link::open(&self.node, &self.names, id, 0) {
            self.opened.insert(id, link);
        }
    }

    fn departures(&mut self) -> Vec<u64> {
        // A dead node's server disconnects, which its link sees; cleaning
        // up lets a later run start clean.
        if self.last_reap.elapsed() >= REAP_EVERY {
            iox::clean_up_dead(&self.node);
            self.last_reap = Instant::now();
        }
        Vec::new()
    }

    fn sleep(&mut self, max: Duration) -> Result<(), EvalError> {
        match self.wake.timed_wait(|_| {}, max) {
            // A signal, such as SIGCHLD from a worker that died, only ends
            // the sleep early; the caller looks around anyway.
            Ok(_) | Err(ListenerWaitError::InterruptSignal) => Ok(()),
            Err(e) => Err(iox::fail("waiting for workers")(e).into()),
        }
    }

    fn worker_args(&self) -> Vec<String> {
        Vec::new()
    }

    /// The dead worker's files are cleared at once, as its replacement's
    /// services are about to be opened: nothing else of the run clears
    /// them sooner (`iox::config`), and workers killed often would
    /// otherwise leave several behind at a time.
    fn forget(&mut self, id: u64) {
        self.opened.remove(&id);
        iox::clean_up_dead(&self.node);
        self.last_reap = Instant::now();
    }

    fn close(&mut self) {
        self.opened.clear();
        // The workers of a run that ended leave this to the coordinator.
        iox::clean_up_dead_before_leaving(&self.node);
    }
}

type EvalClient = Client<ipc::Service, [WireGene], JobHeader, [u8], ResultHeader>;
type Pending = PendingResponse<ipc::Service, [WireGene], JobHeader, [u8], ResultHeader>;

struct InFlight {
    job_id: u64,
    /// The pool's index of the chunk.
    chunk: usize,
    pending: Pending,
    /// When the request was sent, on the host's clock.
    sent_ns: u64,
    deadline: Option<Duration>,
}

pub struct Link {
    pub id: u64,
    pub pid: u32,
    client: EvalClient,
    jobs: Notifier<ipc::Service>,
    /// Oldest first; the worker answers in order.
    busy: VecDeque<InFlight>,
    due: Due,
    /// Jobs taken back that may still sit in the worker's queue, which the
    /// worker skips when it reaches them. They take room there until an
    /// answer to a later job shows the worker is past them: a full queue
    /// would drop its oldest request.
    passed_over: Vec<u64>,
    /// Requests sent since the worker was last notified.
    unannounced: bool,
    broken: bool,
}

impl Link {
    /// Connects to an announced worker's services.
    fn open(
        node: &Node<ipc::Service>,
        names: &RunNames,
        worker_id: u64,
        pid: u32,
    ) -> Result<Link, IpcError> {
        let client = iox::eval_service(node, &names.eval(worker_id))?
            .client_builder()
            .initial_max_slice_len(4096)
            .allocation_strategy(AllocationStrategy::PowerOfTwo)
            .create()
            .map_err(iox::fail("creating a client"))?;
        let jobs = iox::event_service(node, &names.jobs(worker_id))?
            .notifier_builder()
            .create()
            .map_err(iox::fail("creating a job notifier"))?;
        Ok(Link {
            id: worker_id,
            pid,
            client,
            jobs,
            busy: VecDeque::new(),
            due: Due::new(),
            passed_over: Vec::new(),
            unannounced: false,
            broken: false,
        })
    }
}

impl WorkerLink for Link {
    fn id(&self) -> u64 {
        self.id
    }

    fn pid(&self) -> u32 {
        self.pid
    }

    /// True while the worker can queue another chunk.
    fn has_room(&self) -> bool {
        self.busy.len() < DEPTH
            && self.busy.len() + self.passed_over.len() < MAX_QUEUED
            && !self.broken
    }

    fn is_broken(&self) -> bool {
        self.broken
    }

    fn deadline(&self) -> Option<Instant> {
        self.due
            .at(self.busy.iter().filter_map(|f| f.deadline).min())
    }

    /// Gives up on the chunks in flight, returning them.
    fn abandon(&mut self) -> Vec<usize> {
        self.busy.drain(..).map(|f| f.chunk).collect()
    }

    fn in_flight(&self) -> usize {
        self.busy.len()
    }

    /// Dropping the request's pending response tells the worker, which
    /// skips a request no one waits for.
    fn take_back(&mut self) -> Option<usize> {
        if self.passed_over.len() >= MAX_QUEUED - DEPTH {
            return None;
        }
        let flight = self.busy.pop_back()?;
        self.passed_over.push(flight.job_id);
        Some(flight.chunk)
    }

    /// Sends `genes` under `header` as the pool's chunk `chunk`.
    fn send(
        &mut self,
        header: JobHeader,
        genes: &[WireGene],
        chunk: usize,
        deadline: Option<Duration>,
    ) -> Result<(), String> {
        let sent_ns = host_clock_ns();
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
            Ok(pending)
        })();
        match sent {
            Ok(pending) => {
                self.unannounced = true;
                self.due.sent(self.busy.len(), Instant::now());
                self.busy.push_back(InFlight {
                    job_id: header.job_id,
                    chunk,
                    pending,
                    sent_ns,
                    deadline,
                });
                Ok(())
            }
            Err(e) => {
                self.broken = true;
                Err(e.to_string())
            }
        }
    }

    /// One event for all the requests sent since the last: the worker
    /// drains its queue on waking, and each further event would only wake
    /// it again for nothing.
    fn notify(&mut self) -> Result<(), String> {
        if !std::mem::take(&mut self.unannounced) {
            return Ok(());
        }
        let notified = self
            .jobs
            .notify_with_custom_event_id(EventId::new(JOB_EVENT))
            .map_err(|e| iox::fail("notifying the worker")(e).to_string());
        if notified.is_err() {
            self.broken = true;
        }
        notified.map(|_| ())
    }

    /// Collects the answers that arrived, checked against the jobs they
    /// answer but not yet decoded. An answer that fails its checks breaks
    /// the link and is reported beside the good ones; the chunks still in
    /// flight, the refused one among them, are then run elsewhere.
    fn poll(&mut self) -> (Vec<Answer>, Option<String>) {
        let mut answered = Vec::new();
        // The worker answers its queue in order, so the first request still
        // unanswered ends the look: nothing behind it has an answer yet.
        while let Some(flight) = self.busy.front() {
            // Read before receiving: a worker answers, then lets go of the
            // request, so a request seen let go before a receive that finds
            // nothing was truly never answered. Read after, a worker that
            // answered between the two looks would look lost.
            let connected = flight.pending.is_connected();
            let answer = match flight.pending.receive() {
                Ok(Some(response)) => {
                    let h = response.user_header();
                    let timing = ChunkTiming::read_now(self.id, flight.sent_ns, h);
                    check(flight.job_id, h, response.payload()).map(|body| (body, timing))
                }
                Ok(None) if connected => break,
                Ok(None) | Err(_) => {
                    self.broken = true;
                    break;
                }
            };
            match answer {
                Ok((body, timing)) => {
                    let job_id = flight.job_id;
                    answered.push(Answer {
                        chunk: flight.chunk,
                        body,
                        timing,
                    });
                    self.passed_over.retain(|&skipped| skipped > job_id);
                    self.busy.pop_front();
                    self.due.answered(Instant::now());
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
    fn break_off(&mut self) {
        self.broken = true;
    }

    fn shut_down(&self, why: Farewell) {
        let _ = self
            .jobs
            .notify_with_custom_event_id(EventId::new(iox::farewell_event(why)));
    }
}
