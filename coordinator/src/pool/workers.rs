//! The workers' lifecycle, as the pool sees it: starting the pool and its
//! spawned workers (`spawn`), accepting the workers that announce
//! themselves, waiting for them, reaping the ones that exit, leave or miss
//! a deadline (their chunks go back in the queue, and spawned ones are
//! replaced), sleeping between looks, and shutting everything down when
//! the pool is dropped.

use super::link::overdue;
use super::spawn::{ChildId, Children, Placement};
use super::{iceoryx, IpcPool, Pool, PoolOptions, Transport, WorkerLink, DEPTH};
use crate::evaluator::EvalError;
use lander_protocol::host::Pinned;
use lander_protocol::wire::PROTOCOL_VERSION;
use lander_protocol::Farewell;
use lander_telemetry::events::{Cause, Death};
use lander_telemetry::{Event, Telemetry, WorkerRef};
use std::collections::{HashMap, HashSet, VecDeque};
use std::time::{Duration, Instant};

/// How long the pool sleeps at most before looking after its workers.
const SLICE: Duration = Duration::from_millis(25);

impl IpcPool {
    /// Opens the run's iceoryx2 services and, when asked to, spawns its
    /// workers.
    pub fn start(opts: PoolOptions, telemetry: Telemetry) -> Result<IpcPool, EvalError> {
        let transport = iceoryx::Iceoryx::open(&opts.run_id)?;
        Pool::with_transport(transport, opts, telemetry)
    }
}

impl<T: Transport> Pool<T> {
    /// A pool over `transport` that spawns `opts.spawn` workers.
    pub fn with_transport(
        transport: T,
        opts: PoolOptions,
        telemetry: Telemetry,
    ) -> Result<Pool<T>, EvalError> {
        let allowed = lander_protocol::host::allowed_cpus();
        let placement = Placement::new(opts.spawn, &allowed, opts.pin, opts.spin);
        let mut pool = Pool {
            beside: placement.coordinator,
            cpus: allowed.len().max(1),
            stands_in: false,
            depth: DEPTH,
            episodes_per_chunk: lander_protocol::wire::MOST_EPISODES_PER_CHUNK,
            children: Children::new(
                opts.worker_exe.clone(),
                opts.run_id.clone(),
                worker_args(&transport),
                opts.max_respawns,
                placement.clone(),
            ),
            transport,
            links: Vec::new(),
            dropped: HashSet::new(),
            refused: HashSet::new(),
            next_job: 0,
            taken_back: 0,
            flown_here: 0,
            handed_early: 0,
            told_waiting: false,
            arrived: Vec::new(),
            answer_spin: lander_protocol::spin::Spin::new(opts.spin),
            timings: None,
            busy: Default::default(),
            pace: Default::default(),
            hosts: HashMap::new(),
            vetted: HashSet::new(),
            telemetry,
            ending: Farewell::Stopped,
            opts,
        };
        // Each worker's link is opened one spawn behind: the next worker
        // starts first (opening a link takes most of a millisecond, which
        // its start would wait for), and still every link is open before
        // its worker's server is up, a few milliseconds after its start.
        let mut last = None;
        for _ in 0..pool.opts.spawn {
            let child = pool.children.spawn()?;
            if let Some(before) = last.replace(child) {
                pool.transport.expect(before.id);
            }
        }
        if let Some(last) = last {
            pool.transport.expect(last.id);
        }
        Ok(pool)
    }

    /// Workers connected now.
    pub fn workers(&self) -> usize {
        self.links.len()
    }

    /// Waits until `n` workers have announced themselves, for at most
    /// `patience` (`Duration::MAX`: for as long as it takes).
    pub fn wait_for_workers(&mut self, n: usize, patience: Duration) -> Result<(), EvalError> {
        let end = Instant::now().checked_add(patience);
        let mut todo = VecDeque::new();
        while self.links.len() < n {
            if self.opts.stop.asked() {
                return Err(EvalError::Interrupted);
            }
            if end.is_some_and(|end| Instant::now() >= end) {
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

    /// Connects to workers that announced themselves since the last look.
    pub(super) fn accept(&mut self) -> Result<(), EvalError> {
        for w in self.transport.arrivals()? {
            if self.dropped.contains(&w.id) || self.links.iter().any(|l| l.id() == w.id) {
                continue;
            }
            let worker = WorkerRef {
                id: w.id,
                host: w.host.clone(),
                pid: w.pid,
            };
            if w.version != PROTOCOL_VERSION {
                // One this pool started will never speak another version:
                // the executables come from different builds, and none of
                // its workers is of use.
                if self.children.started(ChildId {
                    id: w.id,
                    pid: w.pid,
                }) {
                    self.children.kill_all();
                    return Err(EvalError::WorkerVersion {
                        exe: self.opts.worker_exe.display().to_string(),
                        got: w.version,
                    });
                }
                self.telemetry.event(Event::WorkerRefused {
                    worker,
                    why: format!(
                        "it speaks protocol version {}, this coordinator {}",
                        w.version, PROTOCOL_VERSION
                    ),
                });
                // It re-announces until served; say so once.
                self.dropped.insert(w.id);
                continue;
            }
            match self.transport.connect(&w) {
                Ok(link) => {
                    self.links.push(link);
                    self.hosts.insert(w.id, w.host);
                    self.telemetry.event(Event::WorkerJoined { worker });
                }
                Err(e) => tracing::warn!("cannot reach worker {:016x}: {e}", w.id),
            }
        }
        self.count_workers();
        Ok(())
    }

    /// Sets the metrics' count of connected workers.
    pub(super) fn count_workers(&self) {
        if let Some(m) = self.telemetry.metrics() {
            m.workers_connected
                .with_label_values(&[self.transport.name()])
                .set(self.links.len() as i64);
        }
    }

    /// A connected worker, as events name it.
    pub(super) fn worker_ref(&self, id: u64, pid: u32) -> WorkerRef {
        WorkerRef {
            id,
            host: self.hosts.get(&id).cloned().unwrap_or_default(),
            pid,
        }
    }

    /// Drops links whose process exited or whose node died, and replaces
    /// spawned workers that are gone. Their chunks go back in `todo`.
    pub(super) fn reap(&mut self, todo: &mut VecDeque<usize>) -> Result<(), EvalError> {
        self.stop_workers_never_joined();
        for gone in self.children.exited() {
            self.transport.forget(gone.id);
            let pid = gone.pid;
            // Nothing to drop for a worker dropped already, which the pool
            // killed, or one that died before it joined; such a one is
            // told by the id it was given.
            let joined = self.drop_links(todo, |l| ChildId::of(l) == gone, Cause::Exited);
            if !joined && !self.dropped.contains(&gone.id) {
                self.telemetry.event(Event::WorkerDied {
                    worker: spawned(gone.id, pid),
                    why: Death::Exited,
                });
            }
            match self.children.respawn()? {
                Some(new) => {
                    self.transport.expect(new.id);
                    self.telemetry
                        .event(Event::WorkerRespawned { pid: new.pid })
                }
                None => tracing::warn!("worker process {pid} exited; no respawns left"),
            }
        }
        let gone = self.transport.departures();
        self.drop_links(todo, |l| gone.contains(&l.id()), Cause::Left);
        let now = Instant::now();
        self.drop_links(todo, |l| overdue(l, now), Cause::Deadline);
        Ok(())
    }

    /// Stops the spawned workers that have not joined within the chunk
    /// deadline of their start (a `lander-worker` that hangs before it
    /// announces itself): told as timed out, and replaced as the dead
    /// are, so that a run whose workers never come ends with an error
    /// once the respawns are spent, rather than waiting for ever.
    fn stop_workers_never_joined(&mut self) {
        // Looked at every pass: nothing is allocated unless one is late.
        let links = &self.links;
        let late: Vec<ChildId> = self
            .children
            .not_joined(
                |c| links.iter().any(|l| ChildId::of(l) == c),
                self.opts.deadline,
            )
            .filter(|c| !self.dropped.contains(&c.id))
            .collect();
        for late in late {
            let ChildId { id, pid } = late;
            self.dropped.insert(id);
            tracing::warn!(
                "worker process {pid} has not joined within {} s of its start; stopping it",
                self.opts.deadline.as_secs_f64()
            );
            self.telemetry.event(Event::WorkerTimedOut {
                worker: spawned(id, pid),
            });
            self.children.kill(late);
        }
    }

    /// Forgets the links `gone` picks, putting their chunks back first, and
    /// tells why. Returns whether it dropped any.
    pub(super) fn drop_links(
        &mut self,
        todo: &mut VecDeque<usize>,
        gone: impl Fn(&T::Link) -> bool,
        why: Cause,
    ) -> bool {
        let mut dropped = Vec::new();
        self.links.retain_mut(|link| {
            if !gone(link) {
                return true;
            }
            let chunks = link.abandon();
            for &chunk in chunks.iter().rev() {
                todo.push_front(chunk);
            }
            // A worker we stop trusting is told to leave and why and, if
            // we spawned it, killed (the next reap replaces it).
            link.shut_down(if matches!(why, Cause::Refused) {
                Farewell::Refused
            } else {
                Farewell::Dropped
            });
            dropped.push((link.id(), link.pid(), chunks.len()));
            false
        });
        for &(id, pid, requeued) in &dropped {
            self.children.kill(ChildId { id, pid });
            self.dropped.insert(id);
            let worker = self.worker_ref(id, pid);
            let lost = match why {
                Cause::Exited => Some(Event::WorkerDied {
                    worker: worker.clone(),
                    why: Death::Exited,
                }),
                Cause::Disconnected => Some(Event::WorkerDied {
                    worker: worker.clone(),
                    why: Death::Disconnected,
                }),
                Cause::Left => Some(Event::WorkerLeft {
                    worker: worker.clone(),
                }),
                Cause::Deadline => Some(Event::WorkerTimedOut {
                    worker: worker.clone(),
                }),
                // Told when its answer was refused.
                Cause::Refused => None,
            };
            if let Some(event) = lost {
                self.telemetry.event(event);
            }
            if requeued > 0 {
                self.telemetry.event(Event::ChunksRedispatched {
                    worker,
                    chunks: requeued,
                    why,
                });
            }
            self.hosts.remove(&id);
        }
        self.count_workers();
        !dropped.is_empty()
    }

    /// Sleeps until a worker says something or the next deadline is due.
    pub(super) fn sleep(&mut self) -> Result<(), EvalError> {
        let until_deadline = self
            .links
            .iter()
            .filter_map(|l| l.deadline())
            .min()
            .map(|d| d.saturating_duration_since(Instant::now()));
        let slice = until_deadline.map_or(SLICE, |d| d.min(SLICE));
        self.transport.sleep(slice)
    }

    /// Before the first chunk: waits, as long as it takes, for the
    /// `min_workers` the run was asked to start with.
    pub(super) fn await_first_workers(&mut self) -> Result<(), EvalError> {
        let wanted = std::mem::take(&mut self.opts.min_workers);
        if self.links.len() < wanted {
            self.tell_waiting();
            tracing::info!(
                "waiting for {wanted} workers before the first generation ({} so far)",
                self.links.len()
            );
            self.wait_for_workers(wanted, Duration::MAX)?;
        }
        Ok(())
    }

    /// Says how to start workers where the pool, attached, has none: once
    /// as it starts, and again each time its last worker goes.
    pub(super) fn tell_waiting(&mut self) {
        if !self.links.is_empty() {
            self.told_waiting = false;
        } else if self.opts.spawn == 0 && !self.told_waiting {
            tracing::info!(
                "waiting for workers: start them with `lander-worker --run {}{}`",
                self.opts.run_id,
                self.transport
                    .worker_args()
                    .iter()
                    .map(|a| format!(" {a}"))
                    .collect::<String>()
            );
            self.told_waiting = true;
        }
    }

    /// Waits at most `grace` for every worker to be seen going.
    fn await_leaving(&mut self, grace: Duration) {
        let mut staying: HashSet<u64> = self.links.iter().map(WorkerLink::id).collect();
        let end = Instant::now() + grace;
        while !staying.is_empty() {
            let left = end.saturating_duration_since(Instant::now());
            if left.is_zero() || self.transport.sleep(left).is_err() {
                break;
            }
            for id in self.transport.departures() {
                staying.remove(&id);
            }
        }
    }
}

impl<T: Transport> Drop for Pool<T> {
    fn drop(&mut self) {
        for link in &self.links {
            link.shut_down(self.ending);
        }
        self.await_leaving(self.transport.farewell());
        let told: Vec<ChildId> = self.links.iter().map(ChildId::of).collect();
        let stuck = self.children.stop_all(&told);
        if stuck > 0 {
            tracing::warn!("killed {stuck} worker(s) that did not leave when the run ended");
        }
        self.transport.close();
    }
}

impl<T: Transport> Pool<T> {
    /// Pins the calling thread, which is to run the pool's loop, beside
    /// the last worker where there is a worker on every CPU (`Placement`),
    /// until the guard is dropped; `None` elsewhere, or with a warning if
    /// it cannot be pinned. Scoped to the loop, so that the threads and
    /// pools the caller starts before or after it run anywhere; rayon's
    /// global pool, which breeds an experiment's trials inside the loop
    /// where one thread would not keep the workers busy (`Pace`), is
    /// started first for the same reason (a thread inherits its creator's
    /// CPUs).
    pub fn place_thread(&self) -> Option<Pinned> {
        let cpu = self.beside?;
        rayon::broadcast(|_| ());
        Pinned::here(cpu)
            .inspect_err(|e| tracing::warn!("cannot pin the coordinator to CPU {cpu}: {e}"))
            .ok()
    }
}

/// What every spawned worker is told on its command line: the transport's
/// arguments and the coordinator's log format (they share its stderr).
/// Its CPU and spin budget are its own (`Placement`).
fn worker_args<T: Transport>(transport: &T) -> Vec<String> {
    let mut args = transport.worker_args();
    if lander_telemetry::log::format() == lander_telemetry::log::LogFormat::Json {
        args.extend(["--log-format".to_string(), "json".to_string()]);
    }
    args
}

/// A worker spawned on this host, as events name it before it has joined
/// (and so before its link knows its host).
fn spawned(id: u64, pid: u32) -> WorkerRef {
    WorkerRef {
        id,
        host: lander_protocol::host::name(),
        pid,
    }
}

#[cfg(test)]
mod tests {
    use super::Placement;
    use std::time::Duration;

    const MS: Duration = Duration::from_millis(1);

    /// The spin budgets of `workers` workers on CPUs 0 to `cpus - 1`.
    fn spins(workers: usize, cpus: usize, pin: bool, spin: Duration) -> Vec<Option<u128>> {
        let allowed: Vec<usize> = (0..cpus).collect();
        let p = Placement::new(workers, &allowed, pin, spin);
        (0..workers)
            .map(|w| p.spin_us(p.cpus.get(w).copied()))
            .collect()
    }

    #[test]
    fn workers_spin_only_where_no_other_process_of_the_run_needs_their_cpu() {
        // 1, 2 and 3 workers on 2 CPUs: with 1 it and the coordinator have
        // a CPU each; with 2 the coordinator shares the second worker's;
        // with 3 nobody is pinned.
        assert_eq!(spins(1, 2, true, MS), [Some(1000)]);
        assert_eq!(spins(2, 2, true, MS), [Some(1000), None]);
        assert_eq!(spins(3, 2, true, MS), [None, None, None]);
        assert_eq!(spins(7, 8, true, MS), vec![Some(1000); 7]);
        assert_eq!(spins(8, 8, true, MS).iter().flatten().count(), 7);
        // Unpinned, a worker has a CPU of its own only with CPUs to spare.
        assert_eq!(spins(2, 2, false, MS), [None, None]);
        assert_eq!(spins(1, 2, false, MS), [Some(1000)]);
        assert_eq!(spins(1, 8, true, Duration::ZERO), [None]);
    }

    #[test]
    fn the_coordinator_shares_the_last_workers_cpu_only_with_a_worker_on_every_cpu() {
        let on = |workers: usize, pin: bool| Placement::new(workers, &[3, 5], pin, MS).coordinator;
        assert_eq!(on(2, true), Some(5));
        assert_eq!(on(1, true), None, "a CPU to spare");
        assert_eq!(on(3, true), None, "more workers than CPUs: nobody pinned");
        assert_eq!(on(2, false), None, "--no-pin");
        assert_eq!(Placement::new(2, &[3, 5], true, MS).cpus, [3, 5]);
    }
}
