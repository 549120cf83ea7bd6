//! Serving over zenoh: connect to the coordinator, declare this worker's
//! job queryable and liveliness token, and answer queries until the run
//! ends, the coordinator goes, or a signal arrives. Every frame is decoded
//! with the envelope's checks; a bad one is refused, counted and logged.

use super::{answer, Exit, Note};
use lander_protocol::envelope::{decode_job, encode_result};
use lander_protocol::net::{self, worker_config, NetError, NetOptions, RunKeys};
use lander_protocol::wire::PROTOCOL_VERSION;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use zenoh::query::Query;
use zenoh::sample::{Sample, SampleKind};
use zenoh::{Session, Wait};

/// How long the worker waits for a job before looking at its flags.
const POLL: Duration = Duration::from_millis(200);

/// Serves run `run` as worker `id` until it ends; `stop` is raised by
/// SIGINT or SIGTERM.
pub fn serve(
    run: &str,
    id: u64,
    options: &NetOptions,
    stop: &AtomicBool,
    say: &dyn Fn(Note, &str),
) -> Result<Exit, NetError> {
    let Some(session) = connect(options, stop, say)? else {
        return Ok(Exit::Signal);
    };
    let exit = serve_session(&session, run, id, stop, say);
    let _ = session.close().wait();
    exit
}

/// Opens the session, retrying while the coordinator is not there yet.
fn connect(
    options: &NetOptions,
    stop: &AtomicBool,
    say: &dyn Fn(Note, &str),
) -> Result<Option<Session>, NetError> {
    let config = worker_config(options)?;
    if net::guard_tls(&config) {
        say(Note::Info, net::TLS_NOTE);
    }
    let mut told = false;
    loop {
        let Some(opened) = open(&config, stop) else {
            return Ok(None);
        };
        match opened {
            Ok(session) => return Ok(Some(session)),
            Err(e) => {
                if !told {
                    say(
                        Note::Warning,
                        &format!(
                            "cannot reach a coordinator at {}: {}; retrying \
                             (is it running, and are the credentials right? \
                             RUST_LOG=info,zenoh_transport=error shows zenoh's reason)",
                            options.connect.join(", "),
                            net::tidy(&e.to_string())
                        ),
                    );
                    told = true;
                }
                if stopped_within(stop, RETRY) {
                    return Ok(None);
                }
            }
        }
    }
}

/// How long the worker waits between attempts to reach its coordinator.
const RETRY: Duration = Duration::from_millis(500);

/// One attempt to open a session, `None` if `stop` is raised first: an
/// attempt waits up to the connect timeout, and a signal should not.
// On its own thread, so that this one can watch `stop`; a thread left
// opening when the worker stops ends with the process.
fn open(config: &zenoh::Config, stop: &AtomicBool) -> Option<zenoh::Result<Session>> {
    let (sent, opened) = std::sync::mpsc::sync_channel(1);
    let config = config.clone();
    std::thread::spawn(move || {
        let _ = sent.send(zenoh::open(config).wait());
    });
    loop {
        if stop.load(Ordering::Relaxed) {
            return None;
        }
        match opened.recv_timeout(WATCH) {
            Ok(result) => return Some(result),
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {}
            // The opening thread panicked: no session.
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                return Some(Err("the thread opening the session failed".into()))
            }
        }
    }
}

/// How often a waiting worker looks at `stop`.
const WATCH: Duration = Duration::from_millis(50);

/// Sleeps for `time`, waking to look at `stop`; true if it was raised.
fn stopped_within(stop: &AtomicBool, time: Duration) -> bool {
    let until = std::time::Instant::now() + time;
    while std::time::Instant::now() < until {
        if stop.load(Ordering::Relaxed) {
            return true;
        }
        std::thread::sleep(WATCH);
    }
    stop.load(Ordering::Relaxed)
}

fn serve_session(
    session: &Session,
    run: &str,
    id: u64,
    stop: &AtomicBool,
    say: &dyn Fn(Note, &str),
) -> Result<Exit, NetError> {
    let keys = RunKeys::new(run);
    // Why the coordinator told this worker to leave, once it has.
    let leave: Arc<Mutex<Option<Exit>>> = Arc::default();
    let told = leave.clone();
    let _leave = session
        .declare_subscriber(keys.leave(id))
        .callback(move |s: Sample| {
            let why = net::farewell_in(&s.payload().to_bytes());
            if let Ok(mut told) = told.lock() {
                *told = Some(Exit::Told(why));
            }
        })
        .wait()
        .map_err(net::fail("subscribing to the leave key"))?;
    let served: Arc<Mutex<Served>> = Arc::default();
    let seen = served.clone();
    let _coordinator = session
        .liveliness()
        .declare_subscriber(keys.coordinators())
        .history(true)
        .callback(move |s: Sample| {
            if let Ok(mut seen) = seen.lock() {
                seen.saw(s.key_expr().as_str(), s.kind() == SampleKind::Put);
            }
        })
        .wait()
        .map_err(net::fail("watching the coordinator"))?;
    let queryable = session
        .declare_queryable(keys.jobs(id))
        .complete(true)
        .wait()
        .map_err(net::fail("declaring the job queryable"))?;
    // Declared last: once the coordinator sees the token, jobs reach us.
    let _token = session
        .liveliness()
        .declare_token(keys.alive(
            id,
            PROTOCOL_VERSION,
            std::process::id(),
            &lander_protocol::host::name(),
        ))
        .wait()
        .map_err(net::fail("declaring the liveliness token"))?;
    say(
        Note::Info,
        &format!("serving run {run} as worker {id:016x} over zenoh"),
    );
    let mut rejected = 0u64;
    loop {
        if stop.load(Ordering::Relaxed) {
            return Ok(Exit::Signal);
        }
        if let Some(exit) = leave.lock().ok().and_then(|told| *told) {
            return Ok(exit);
        }
        if served.lock().map_or(true, |s| s.gone) {
            return Ok(Exit::CoordinatorGone);
        }
        match queryable.recv_timeout(POLL) {
            Ok(Some(query)) => serve_query(&query, id, &mut rejected, say)?,
            Ok(None) => {}
            Err(_) => return Ok(Exit::CoordinatorGone),
        }
    }
}

/// The coordinator a worker serves, told apart by the key of its
/// liveliness token: gone once that token goes, or once another
/// coordinator's comes (one that took the run up after it, a resume, to
/// which the worker must announce itself anew). A coordinator's session may
/// end and another's begin at the same endpoint before the worker's
/// session notices.
#[derive(Default, Debug)]
struct Served {
    token: Option<String>,
    gone: bool,
}

impl Served {
    /// Takes in a coordinator token at `key`, `put` or deleted.
    fn saw(&mut self, key: &str, put: bool) {
        match (&self.token, put) {
            (None, true) => self.token = Some(key.to_string()),
            (Some(served), true) if served != key => self.gone = true,
            (Some(served), false) if served == key => self.gone = true,
            _ => {}
        }
    }
}

/// Answers one query; a frame that fails the envelope's checks gets an
/// error reply and is counted.
fn serve_query(
    query: &Query,
    id: u64,
    rejected: &mut u64,
    say: &dyn Fn(Note, &str),
) -> Result<(), NetError> {
    let frame = query
        .payload()
        .map(|p| p.to_bytes().into_owned())
        .unwrap_or_default();
    match decode_job(&frame) {
        Ok((header, genes)) => {
            let (result, body) = answer(&header, &genes, id, say);
            query
                .reply(query.key_expr().clone(), encode_result(&result, &body))
                .wait()
                .map_err(net::fail("replying"))
        }
        Err(e) => {
            *rejected += 1;
            super::count_rejected_frame();
            say(
                Note::Warning,
                &format!("rejected frame #{rejected} ({} bytes): {e}", frame.len()),
            );
            query
                .reply_err(e.to_string())
                .wait()
                .map_err(net::fail("replying with an error"))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Served;

    fn after(tokens: &[(&str, bool)]) -> bool {
        let mut served = Served::default();
        for &(key, put) in tokens {
            served.saw(key, put);
        }
        served.gone
    }

    #[test]
    fn the_coordinator_is_gone_when_its_token_goes_or_another_comes() {
        assert!(!after(&[]));
        assert!(!after(&[("c/a", true)]));
        assert!(after(&[("c/a", true), ("c/a", false)]));
        // A resumed coordinator's token before the dead one's went.
        assert!(after(&[("c/a", true), ("c/b", true)]));
        // Another's token going is not this one's.
        assert!(!after(&[("c/a", true), ("c/b", false)]));
        // Nothing is served before a coordinator is seen.
        assert!(!after(&[("c/a", false)]));
    }
}
