//! Serving over iceoryx2: announce itself to a run, then serve jobs from
//! its own services until the run ends or a signal arrives. Between jobs
//! it polls for the next for a bounded, adaptive time where it has a CPU
//! of its own (`Spin`), and otherwise sleeps in a WaitSet.

use super::{answer, Exit, Note};
use iceoryx2::identifiers::UniqueListenerId;
use iceoryx2::prelude::*;
use iceoryx2::waitset::WaitSetRunResult;
use lander_protocol::iox::{self, IpcError, RunNames};
use lander_protocol::spin::Spin;
use lander_protocol::wire::{ResultHeader, WorkerAnnounce, PROTOCOL_VERSION};
use lander_protocol::Farewell;
use std::cell::{Cell, RefCell};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

/// How often an idle worker looks around: re-announces itself until it has
/// work, reaps dead nodes, and checks its coordinator is still there.
const HOUSEKEEPING: Duration = Duration::from_millis(500);

/// Serves run `run` as worker `id`, telling the user through `say`;
/// `held` is raised by a SIGINT or SIGTERM that comes before iceoryx2
/// handles them, at the node's first wait.
pub fn serve(
    run: &str,
    id: u64,
    spin: Spin,
    held: &AtomicBool,
    say: &dyn Fn(Note, &str),
) -> Result<Exit, IpcError> {
    iox::quiet_logs();
    let config = iox::config()?;
    let names = RunNames::new(run);
    let node = iox::node(
        &format!("lander-worker-{id:016x}"),
        &config,
        SignalHandlingMode::HandleTerminationRequests,
    )?;
    // iceoryx2 takes SIGINT and SIGTERM over at the node's first wait;
    // one that came before is in `held`.
    let exit = if terminated(&node, Duration::ZERO) || held.load(Ordering::SeqCst) {
        Ok(Exit::Signal)
    } else {
        serve_on(&node, &names, &config, id, spin, say)
    };
    // Unless its coordinator ended the run (and clears up after it once
    // its workers have gone), the worker clears what dead processes of the
    // run left, a killed coordinator's node above all: a worker stopped
    // because its coordinator is gone (`parent.rs`) may be the last
    // process of the run. A worker of a finished run leaves at once, for
    // its coordinator waits for it.
    if !matches!(exit, Ok(Exit::Told(Farewell::RunOver))) {
        iox::clean_up_dead_before_leaving(&node);
    }
    exit
}

/// Serves the run from `node`, once its coordinator exists.
fn serve_on(
    node: &Node<ipc::Service>,
    names: &RunNames,
    config: &Config,
    id: u64,
    mut spin: Spin,
    say: &dyn Fn(Note, &str),
) -> Result<Exit, IpcError> {
    // Install the signal handler now, so SIGTERM while waiting ends cleanly.
    if terminated(node, Duration::ZERO) {
        return Ok(Exit::Signal);
    }
    if !wait_for_run(node, names, config, say)? {
        return Ok(Exit::Signal);
    }

    let eval = iox::eval_service(node, &names.eval(id))?;
    let server = eval
        .server_builder()
        .initial_max_slice_len(4096)
        // One answer a job (`iox::eval_service`).
        .max_loaned_responses_per_request(1)
        .allocation_strategy(AllocationStrategy::PowerOfTwo)
        .create()
        .map_err(iox::fail("creating the evaluation server"))?;
    let jobs = iox::event_service(node, &names.jobs(id))?
        .listener_builder()
        .create()
        .map_err(iox::fail("listening for jobs"))?;
    let wake_service = iox::event_service(node, &names.wake())?;
    let mut coordinator = Coordinator::of(&wake_service);
    let wake = wake_service
        .notifier_builder()
        .create()
        .map_err(iox::fail("creating the wake notifier"))?;
    let announcer = iox::register_service(node, &names.register())?
        .publisher_builder()
        .create()
        .map_err(iox::fail("creating the announcer"))?;
    let announce = || -> Result<(), IpcError> {
        let me = WorkerAnnounce {
            version: PROTOCOL_VERSION,
            pid: std::process::id(),
            worker_id: id,
        };
        announcer.send_copy(me).map_err(iox::fail("announcing"))?;
        wake.notify().map_err(iox::fail("waking the coordinator"))?;
        Ok(())
    };
    announce()?;
    say(
        Note::Info,
        &format!("serving run {} as worker {id:016x}", names.run()),
    );

    let waitset = WaitSetBuilder::new()
        .signal_handling_mode(SignalHandlingMode::HandleTerminationRequests)
        .create::<ipc::Service>()
        .map_err(iox::fail("creating the wait set"))?;
    let job_guard = waitset
        .attach_notification(&jobs)
        .map_err(iox::fail("waiting on jobs"))?;
    let tick = waitset
        .attach_interval(HOUSEKEEPING)
        .map_err(iox::fail("attaching the housekeeping interval"))?;

    let served = Cell::new(false);
    let outcome: RefCell<Result<Option<Exit>, IpcError>> = RefCell::new(Ok(None));
    let stop = |r: Result<Option<Exit>, IpcError>| {
        *outcome.borrow_mut() = r;
        CallbackProgression::Stop
    };
    let mut on_event = |attachment: WaitSetAttachmentId<ipc::Service>| {
        if attachment.has_event_from(&job_guard) {
            spin.woke();
            match farewell(&jobs) {
                Ok(None) => {}
                Ok(told) => return stop(Ok(told)),
                Err(e) => return stop(Err(e)),
            }
            let drained = || {
                wake.notify()
                    .map(|_| ())
                    .map_err(iox::fail("waking the coordinator"))
            };
            match serve_waiting(&server, id, say, &drained) {
                Ok(0) => {}
                Ok(_) => served.set(true),
                Err(e) => return stop(Err(e)),
            }
            // The next chunk often comes soon: look for it a while before
            // sleeping, where this worker has a CPU of its own.
            while spin.poll(|| server.has_requests().unwrap_or(true)) {
                if let Err(e) = serve_waiting(&server, id, say, &drained) {
                    return stop(Err(e));
                }
            }
        } else if attachment.has_event_from(&tick) {
            iox::clean_up_dead(node);
            if coordinator.gone(&wake_service) {
                // The coordinator says the run is over before it leaves; a
                // word still waiting here means it ended the run cleanly.
                let exit = farewell(&jobs).ok().flatten();
                return stop(Ok(Some(exit.unwrap_or(Exit::CoordinatorGone))));
            }
            if !served.get() {
                if let Err(e) = announce() {
                    return stop(Err(e));
                }
            }
        }
        CallbackProgression::Continue
    };
    let result = loop {
        match waitset
            .wait_and_process(&mut on_event)
            .map_err(iox::fail("waiting for jobs"))?
        {
            // A wait cut short by a signal that asks nothing of the worker,
            // such as SIGCONT after a SIGSTOP; SIGTERM and SIGINT come back
            // as a termination request.
            WaitSetRunResult::Interrupt => continue,
            other => break other,
        }
    };
    let exit = outcome.into_inner()?;
    Ok(exit.unwrap_or(match result {
        WaitSetRunResult::TerminationRequest => Exit::Signal,
        _ => Exit::Told(Farewell::RunOver),
    }))
}

/// The coordinator a worker serves, told apart by its listener on the
/// run's wake service: a coordinator gone is no longer there, and one that
/// takes the run up after it (a resume, under the same run id) listens
/// under another id, so that the worker, which announced itself to the
/// first, announces itself again.
struct Coordinator(Vec<UniqueListenerId>);

impl Coordinator {
    fn of(wake: &iox::EventService) -> Coordinator {
        Coordinator(listeners(wake))
    }

    /// Whether the coordinator is gone. Until one listens, none is: the
    /// run's wake service outlives a dead coordinator while other workers
    /// hold it, and a worker that took that for the run would leave and
    /// come back every look; it waits, announcing itself, instead. One not
    /// listening yet when the worker first looked is the one found
    /// listening later.
    fn gone(&mut self, wake: &iox::EventService) -> bool {
        let now = listeners(wake);
        if self.0.is_empty() {
            self.0 = now;
            return false;
        }
        !self.0.iter().any(|id| now.contains(id))
    }
}

fn listeners(wake: &iox::EventService) -> Vec<UniqueListenerId> {
    let mut ids = Vec::new();
    wake.dynamic_config().list_listeners(|l| {
        ids.push(l.listener_id);
        CallbackProgression::Continue
    });
    ids
}

/// Drains the job events; the exit one of them tells the worker to take,
/// if one does.
fn farewell(
    jobs: &iceoryx2::port::listener::Listener<ipc::Service>,
) -> Result<Option<Exit>, IpcError> {
    let mut told = None;
    jobs.try_wait(|ev| {
        told = told.or(iox::farewell_of(ev.id.as_value()));
    })
    .map_err(iox::fail("reading job events"))?;
    Ok(told.map(Exit::Told))
}

/// Sleeps up to `timeout`; true if SIGTERM or SIGINT asked the worker to
/// stop. Another signal only cuts the sleep short.
fn terminated(node: &Node<ipc::Service>, timeout: Duration) -> bool {
    matches!(
        node.wait(timeout),
        Err(iceoryx2::node::NodeWaitFailure::TerminationRequest)
    )
}

/// Waits until the run's coordinator exists. False on a signal.
fn wait_for_run(
    node: &Node<ipc::Service>,
    names: &RunNames,
    config: &Config,
    say: &dyn Fn(Note, &str),
) -> Result<bool, IpcError> {
    let mut told = false;
    while !iox::run_exists(names, config)? {
        if !told {
            say(
                Note::Info,
                &format!(
                    "waiting for run {}: no coordinator has started it yet \
                 (start one with `lander run --attach --run-id {}`)",
                    names.run(),
                    names.run()
                ),
            );
            told = true;
        }
        if terminated(node, Duration::from_millis(200)) {
            return Ok(false);
        }
    }
    Ok(true)
}

type Server = iceoryx2::port::server::Server<
    ipc::Service,
    [lander_protocol::wire::WireGene],
    lander_protocol::wire::JobHeader,
    [u8],
    ResultHeader,
>;

/// Answers every request waiting at the server, and calls `drained` once
/// none is left, so the coordinator wakes once per drained queue rather than
/// once per answer: on a machine with few cores each of its wake-ups takes
/// a core from a worker. Returns how many it answered.
fn serve_waiting(
    server: &Server,
    id: u64,
    say: &dyn Fn(Note, &str),
    drained: &impl Fn() -> Result<(), IpcError>,
) -> Result<usize, IpcError> {
    let mut count = 0;
    while let Some(request) = server.receive().map_err(iox::fail("receiving a job"))? {
        // The coordinator gave this chunk to an idle worker instead.
        if !request.is_connected() {
            continue;
        }
        let (result, body) = answer(request.user_header(), request.payload(), id, say);
        if !request.is_connected() {
            continue;
        }
        let mut response = request
            .loan_slice_uninit(body.len())
            .map_err(iox::fail("loaning a response"))?;
        *response.user_header_mut() = result;
        response
            .write_from_slice(&body)
            .send()
            .map_err(iox::fail("sending a result"))?;
        count += 1;
    }
    if count > 0 {
        drained()?;
    }
    Ok(count)
}
