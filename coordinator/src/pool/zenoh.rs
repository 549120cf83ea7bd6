//! The zenoh transport, for workers on other hosts. Workers declare a
//! liveliness token that says who they are; the coordinator subscribes to
//! the tokens, so it sees a worker arrive, and leave when its token goes
//! (a closed connection, or a lease run out). A job is a query to the
//! worker's own key; its reply is the result. Every callback only forwards
//! into a channel the pool sleeps on, so zenoh's threads never block.

use super::link::{check, words_of, Due};
use super::{Answer, Arrival, ChunkTiming, Transport, WorkerLink, DEPTH};
use crate::evaluator::EvalError;
use lander_protocol::envelope::{decode_result, encode_job};
use lander_protocol::host::host_clock_ns;
use lander_protocol::net::{self, NetError, RunKeys};
use lander_protocol::wire::{JobHeader, WireGene};
use lander_protocol::Farewell;
use std::collections::VecDeque;
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError, Sender};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use zenoh::handlers::CallbackDrop;
use zenoh::query::{ConsolidationMode, Reply};
use zenoh::sample::{Sample, SampleKind};
use zenoh::{Session, Wait};

/// A query without a deadline (a whole Q(λ) trial) still ends some day.
const NO_DEADLINE: Duration = Duration::from_secs(7 * 24 * 3600);

enum Event {
    Arrived(Arrival),
    Left(u64),
    /// Something changed in a link's queries.
    Bell,
}

impl From<NetError> for EvalError {
    fn from(e: NetError) -> EvalError {
        EvalError::Net(e.to_string())
    }
}

/// The coordinator's zenoh session and its view of the run's workers.
pub struct Zenoh {
    session: Session,
    keys: RunKeys,
    events: Receiver<Event>,
    bell: Sender<Event>,
    arrived: Vec<Arrival>,
    left: Vec<u64>,
    /// Whether TLS put zenoh's I/O on one thread ([`net::guard_tls`]).
    pub io_on_one_thread: bool,
    /// What spawned workers are told to connect to.
    worker_args: Vec<String>,
    // Dropping these would undeclare them.
    _tokens: zenoh::pubsub::Subscriber<()>,
    _alive: zenoh::liveliness::LivelinessToken,
}

impl Zenoh {
    /// Opens the session with `config` (a coordinator's, from
    /// [`net::coordinator_config`]) and starts watching the run's liveliness
    /// tokens.
    pub fn open(run_id: &str, config: zenoh::Config) -> Result<Zenoh, EvalError> {
        let io_on_one_thread = net::guard_tls(&config);
        let listening = net::listening(&config);
        let session = zenoh::open(config)
            .wait()
            .map_err(net::fail("opening the zenoh session"))?;
        let keys = RunKeys::new(run_id);
        let (bell, events) = channel();
        let tx = bell.clone();
        let watch = keys.clone();
        let tokens = session
            .liveliness()
            .declare_subscriber(keys.alive_all())
            .history(true)
            .callback(move |sample: Sample| {
                let Some((id, version, pid, host)) = watch.parse_alive(sample.key_expr().as_str())
                else {
                    return;
                };
                let event = match sample.kind() {
                    SampleKind::Put => Event::Arrived(Arrival {
                        id,
                        pid,
                        version,
                        host,
                    }),
                    SampleKind::Delete => Event::Left(id),
                };
                let _ = tx.send(event);
            })
            .wait()
            .map_err(net::fail("watching for workers"))?;
        let alive = session
            .liveliness()
            .declare_token(keys.coordinator(&session.zid().to_string()))
            .wait()
            .map_err(net::fail("declaring the coordinator's token"))?;
        let mut worker_args = vec!["--transport".to_string(), "zenoh".to_string()];
        for endpoint in &listening {
            worker_args.push("--connect".into());
            worker_args.push(reachable(endpoint));
        }
        Ok(Zenoh {
            session,
            keys,
            events,
            bell,
            arrived: Vec::new(),
            left: Vec::new(),
            io_on_one_thread,
            worker_args,
            _tokens: tokens,
            _alive: alive,
        })
    }

    fn take(&mut self, event: Event) {
        match event {
            Event::Arrived(a) => self.arrived.push(a),
            Event::Left(id) => self.left.push(id),
            Event::Bell => {}
        }
    }
}

/// A listen endpoint as a worker on this host connects to it.
fn reachable(endpoint: &str) -> String {
    endpoint
        .replace("0.0.0.0", "127.0.0.1")
        .replace("[::]", "[::1]")
}

impl Transport for Zenoh {
    type Link = Link;

    fn name(&self) -> &'static str {
        "zenoh"
    }

    fn arrivals(&mut self) -> Result<Vec<Arrival>, EvalError> {
        while let Ok(event) = self.events.try_recv() {
            self.take(event);
        }
        Ok(std::mem::take(&mut self.arrived))
    }

    fn connect(&mut self, a: &Arrival) -> Result<Link, String> {
        Ok(Link {
            id: a.id,
            pid: a.pid,
            session: self.session.clone(),
            jobs: self.keys.jobs(a.id),
            leave: self.keys.leave(a.id),
            bell: self.bell.clone(),
            busy: VecDeque::new(),
            due: Due::new(),
            broken: false,
        })
    }

    fn departures(&mut self) -> Vec<u64> {
        while let Ok(event) = self.events.try_recv() {
            self.take(event);
        }
        std::mem::take(&mut self.left)
    }

    fn sleep(&mut self, max: Duration) -> Result<(), EvalError> {
        match self.events.recv_timeout(max) {
            Ok(event) => {
                self.take(event);
                Ok(())
            }
            Err(RecvTimeoutError::Timeout) => Ok(()),
            // The transport holds a sender itself, so this cannot happen.
            Err(RecvTimeoutError::Disconnected) => {
                Err(EvalError::Net("event channel closed".into()))
            }
        }
    }

    fn worker_args(&self) -> Vec<String> {
        self.worker_args.clone()
    }

    /// A leave message is one put, which a router may still be forwarding
    /// when the session closes; a worker whose coordinator token vanished
    /// before it had seen it would then wait forever.
    fn farewell(&self) -> Duration {
        Duration::from_secs(2)
    }

    fn close(&mut self) {
        let _ = self.session.close().wait();
    }
}

/// What became of a query so far.
#[derive(Default)]
struct Slot {
    reply: Option<Result<Vec<u8>, String>>,
    /// zenoh finished the query: replied, timed out, or the worker went.
    finished: bool,
}

struct InFlight {
    job_id: u64,
    chunk: usize,
    slot: Arc<Mutex<Slot>>,
    /// When the request was sent, on the host's clock.
    sent_ns: u64,
    deadline: Option<Duration>,
}

pub struct Link {
    id: u64,
    pid: u32,
    session: Session,
    jobs: String,
    leave: String,
    bell: Sender<Event>,
    /// Oldest first; the worker answers in order.
    busy: VecDeque<InFlight>,
    due: Due,
    broken: bool,
}

impl WorkerLink for Link {
    fn id(&self) -> u64 {
        self.id
    }

    fn pid(&self) -> u32 {
        self.pid
    }

    fn has_room(&self) -> bool {
        self.busy.len() < DEPTH && !self.broken
    }

    fn is_broken(&self) -> bool {
        self.broken
    }

    fn deadline(&self) -> Option<Instant> {
        self.due
            .at(self.busy.iter().filter_map(|f| f.deadline).min())
    }

    fn abandon(&mut self) -> Vec<usize> {
        self.busy.drain(..).map(|f| f.chunk).collect()
    }

    fn in_flight(&self) -> usize {
        self.busy.len()
    }

    fn send(
        &mut self,
        header: JobHeader,
        genes: &[WireGene],
        chunk: usize,
        deadline: Option<Duration>,
    ) -> Result<(), String> {
        let sent_ns = host_clock_ns();
        let slot = Arc::new(Mutex::new(Slot::default()));
        let (on_reply, on_end) = (slot.clone(), slot.clone());
        let (bell, bell_end) = (self.bell.clone(), self.bell.clone());
        let sent = self
            .session
            .get(&self.jobs)
            .payload(encode_job(&header, genes))
            .consolidation(ConsolidationMode::None)
            // zenoh's own timeout only ends the query; the pool's deadline
            // decides, a little earlier, timing a query from the answer to
            // the one before it (`Due`): up to `DEPTH` deadlines after it
            // was sent.
            .timeout(deadline.map_or(NO_DEADLINE, |d| d * DEPTH as u32 + Duration::from_secs(5)))
            .with(CallbackDrop {
                callback: move |reply: Reply| {
                    let answer = match reply.into_result() {
                        Ok(sample) => Ok(sample.payload().to_bytes().into_owned()),
                        Err(e) => Err(words_of(&e.payload().to_bytes())),
                    };
                    if let Ok(mut s) = on_reply.lock() {
                        s.reply.get_or_insert(answer);
                    }
                    let _ = bell.send(Event::Bell);
                },
                drop: move || {
                    if let Ok(mut s) = on_end.lock() {
                        s.finished = true;
                    }
                    let _ = bell_end.send(Event::Bell);
                },
            })
            .wait();
        if let Err(e) = sent {
            self.broken = true;
            return Err(format!("sending a query: {e}"));
        }
        self.due.sent(self.busy.len(), Instant::now());
        self.busy.push_back(InFlight {
            job_id: header.job_id,
            chunk,
            slot,
            sent_ns,
            deadline,
        });
        Ok(())
    }

    fn poll(&mut self) -> (Vec<Answer>, Option<String>) {
        let mut answered = Vec::new();
        let mut i = 0;
        while i < self.busy.len() {
            let flight = &self.busy[i];
            let (reply, finished) = match flight.slot.lock() {
                Ok(mut s) => (s.reply.take(), s.finished),
                Err(_) => (None, true),
            };
            let answer = match reply {
                Some(Ok(frame)) => {
                    decode_result(&frame)
                        .map_err(|e| e.to_string())
                        .and_then(|(h, body)| {
                            let timing = ChunkTiming::read_now(self.id, flight.sent_ns, &h);
                            check(flight.job_id, &h, &body).map(|body| (body, timing))
                        })
                }
                Some(Err(e)) => Err(format!("the worker answered with an error: {e}")),
                None if finished => {
                    // The query ended unanswered: the worker is gone.
                    self.broken = true;
                    break;
                }
                None => {
                    i += 1;
                    continue;
                }
            };
            match answer {
                Ok((body, timing)) => {
                    answered.push(Answer {
                        chunk: flight.chunk,
                        body,
                        timing,
                    });
                    self.busy.remove(i);
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

    fn break_off(&mut self) {
        self.broken = true;
    }

    fn shut_down(&self, why: Farewell) {
        let _ = self.session.put(&self.leave, net::leave_word(why)).wait();
    }
}

#[cfg(test)]
mod tests {
    use super::reachable;

    #[test]
    fn spawned_workers_connect_to_loopback() {
        assert_eq!(reachable("tcp/0.0.0.0:7447"), "tcp/127.0.0.1:7447");
        assert_eq!(reachable("tcp/[::]:7447"), "tcp/[::1]:7447");
        assert_eq!(reachable("tcp/10.0.0.5:7447"), "tcp/10.0.0.5:7447");
    }
}
