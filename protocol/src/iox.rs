//! The iceoryx2 services of a run: their names, limits and configuration.
//!
//! iceoryx2 has no work queue: a request reaches every connected server. So
//! each worker has services of its own, and the coordinator chooses which
//! worker gets a chunk. Everything is named under `lander/<run>/`, so two
//! runs on one host never meet.
//!
//! | service                       | pattern          | direction             |
//! |-------------------------------|------------------|-----------------------|
//! | `lander/<run>/register`       | publish-subscribe| worker → coordinator  |
//! | `lander/<run>/wake`           | event            | worker → coordinator  |
//! | `lander/<run>/worker/<w>/eval`| request-response | coordinator ↔ worker  |
//! | `lander/<run>/worker/<w>/jobs`| event            | coordinator → worker  |

use crate::wire::{JobHeader, ResultHeader, WireGene, WorkerAnnounce};
use iceoryx2::node::NodeView;
use iceoryx2::prelude::*;
use iceoryx2::service::port_factory::{event, publish_subscribe, request_response};
use std::fmt::Debug;
use std::time::Duration;

/// The file-name prefix of the project's iceoryx2 resources. iceoryx2 keeps
/// one management file per prefix for good, so runs share one prefix and
/// differ in service names.
pub const DEFAULT_PREFIX: &str = "lander_";
/// Environment variables that move a run's resources elsewhere, for tests.
pub const PREFIX_ENV: &str = "LANDER_IOX2_PREFIX";
pub const ROOT_ENV: &str = "LANDER_IOX2_ROOT";

/// Where iceoryx2 keeps its node and service files unless [`ROOT_ENV`]
/// says otherwise, when the host has a `/dev/shm`: tmpfs, so that opening
/// a service never waits on a disk's fsync. iceoryx2's own default,
/// `/tmp/iceoryx2`, is on disk on many hosts, and there a run with 2
/// workers took 4–17 ms longer to start (docs/performance.md).
pub const DEFAULT_ROOT: &str = "/dev/shm/lander-iceoryx2";

/// The most workers one run takes.
pub const MAX_WORKERS: usize = 128;

/// The longest run id: it goes into every service name of the run, and
/// iceoryx2 bounds a name's length.
pub const MAX_RUN_ID: usize = 64;

/// Checks a run id given by a user: 1 to [`MAX_RUN_ID`] letters, digits,
/// '-' or '_', which names services and keys on every transport. The error
/// says what is allowed.
pub fn check_run_id(id: &str) -> Result<(), String> {
    let ok = !id.is_empty()
        && id.len() <= MAX_RUN_ID
        && id
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_');
    if ok {
        Ok(())
    } else {
        // A long id is shown cut: it may be a whole file pasted in.
        let shown: String = id.chars().take(MAX_RUN_ID + 1).collect();
        let cut = if shown.len() < id.len() { "…" } else { "" };
        Err(format!(
            "must be 1 to {MAX_RUN_ID} letters, digits, '-' or '_' (got {shown:?}{cut})"
        ))
    }
}

/// Requests that may sit in one worker's queue at once: the chunks the
/// coordinator waits for, plus chunks it took back for an idle worker that
/// the worker has not reached yet. A request sent to a full queue would
/// push out its oldest, so the coordinator keeps count of both.
pub const MAX_QUEUED: usize = 8;

/// Event ids on a worker's `jobs` service: a job waits, or the worker is
/// told to leave ([`farewell_event`]).
pub const JOB_EVENT: usize = 1;
const RUN_OVER_EVENT: usize = 2;
const DROPPED_EVENT: usize = 3;
const REFUSED_EVENT: usize = 4;
const STOPPED_EVENT: usize = 5;

/// The event id that tells a worker to leave, and why.
pub fn farewell_event(why: crate::Farewell) -> usize {
    match why {
        crate::Farewell::RunOver => RUN_OVER_EVENT,
        crate::Farewell::Dropped => DROPPED_EVENT,
        crate::Farewell::Refused => REFUSED_EVENT,
        crate::Farewell::Stopped => STOPPED_EVENT,
    }
}

/// Why an event with id `event` tells a worker to leave, if it does.
pub fn farewell_of(event: usize) -> Option<crate::Farewell> {
    match event {
        RUN_OVER_EVENT => Some(crate::Farewell::RunOver),
        DROPPED_EVENT => Some(crate::Farewell::Dropped),
        REFUSED_EVENT => Some(crate::Farewell::Refused),
        STOPPED_EVENT => Some(crate::Farewell::Stopped),
        _ => None,
    }
}

pub type EvalService =
    request_response::PortFactory<ipc::Service, [WireGene], JobHeader, [u8], ResultHeader>;
pub type EventService = event::PortFactory<ipc::Service>;
pub type RegisterService = publish_subscribe::PortFactory<ipc::Service, WorkerAnnounce, ()>;

#[derive(Debug, thiserror::Error)]
#[error("iceoryx2: {what}: {detail}")]
pub struct IpcError {
    pub what: String,
    pub detail: String,
}

/// Wraps an iceoryx2 error with what was being done.
pub fn fail<E: Debug>(what: impl Into<String>) -> impl FnOnce(E) -> IpcError {
    let what = what.into();
    move |e| IpcError {
        what,
        detail: format!("{e:?}"),
    }
}

/// The explicit configuration every process of a run uses. Passing one
/// also keeps iceoryx2's "No config file was loaded" warning away.
///
/// A port keeps room for connections whose other end has gone with data
/// unread; iceoryx2's default, 128 of them, is set up page by page as
/// every port is made, a cost each worker pays as it starts. A worker's
/// service has one server and two clients at most, and a worker gone
/// with its announcement unread needs no answer.
pub fn config() -> Result<Config, IpcError> {
    let mut config = Config::default();
    let defaults = &mut config.defaults;
    defaults.request_response.client_expired_connection_buffer = 2;
    defaults.request_response.server_expired_connection_buffer = 2;
    defaults
        .publish_subscribe
        .subscriber_expired_connection_buffer = 8;
    // iceoryx2 cleans up after dead nodes as a node is made, as one is
    // dropped and as a service is opened; any of these can hang for ever
    // on a file a killed process left half made. The runs' processes clean
    // up through `clean_up_dead` alone, which guards against that, where
    // each chooses: the coordinator as it opens the run, every half second
    // after, as it forgets a dead worker and as its run ends; a worker as
    // it looks for a coordinator that may be gone, and as it leaves a run
    // its coordinator did not end.
    config.global.node.cleanup_dead_nodes_on_creation = false;
    config.global.node.cleanup_dead_nodes_on_destruction = false;
    config.global.service.cleanup_dead_nodes_on_open = false;
    let prefix = var(PREFIX_ENV)?.unwrap_or_else(|| DEFAULT_PREFIX.into());
    config.global.prefix =
        FileName::new(prefix.as_bytes()).map_err(fail(format!("{PREFIX_ENV}={prefix}")))?;
    let root = var(ROOT_ENV)?.or_else(|| {
        std::path::Path::new("/dev/shm")
            .is_dir()
            .then(|| DEFAULT_ROOT.to_string())
    });
    if let Some(root) = root {
        let path = Path::new(root.as_bytes()).map_err(fail(format!("{ROOT_ENV}={root}")))?;
        check_root(&root)?;
        config.global.set_root_path(&path);
    }
    Ok(config)
}

/// The environment variable `name`, `None` where it is not set; one set
/// to bytes that are not UTF-8 is an error naming it, where taking it for
/// unset would share another run's files unasked.
fn var(name: &str) -> Result<Option<String>, IpcError> {
    match std::env::var(name) {
        Ok(value) => Ok(Some(value)),
        Err(std::env::VarError::NotPresent) => Ok(None),
        Err(std::env::VarError::NotUnicode(value)) => Err(IpcError {
            what: name.to_string(),
            detail: format!("{value:?} is not UTF-8"),
        }),
    }
}

/// Checks that iceoryx2 can keep its files under `root`: a directory, made
/// if missing, in which this process may create a file. iceoryx2 itself
/// says only `InternalError` when it cannot, naming neither the directory
/// nor the variable that moves it.
fn check_root(root: &str) -> Result<(), IpcError> {
    let failed = |detail: String| IpcError {
        what: format!("the directory for its files, {root:?} (set {ROOT_ENV} to move it)"),
        detail,
    };
    let dir = std::path::Path::new(root);
    // iceoryx2 takes a relative or empty root, and then fails to create
    // its files, saying only `ResourceCreationFailed`.
    if !dir.is_absolute() {
        return Err(failed("must be an absolute path".into()));
    }
    std::fs::create_dir_all(dir).map_err(|e| failed(e.to_string()))?;
    let probe = dir.join(format!(".lander-probe-{}", std::process::id()));
    std::fs::File::create(&probe).map_err(|e| failed(format!("cannot create a file: {e}")))?;
    // The probe was made by this process under a name no other takes.
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

/// The process id of another live node on this host of `node`'s name,
/// if there is one: a coordinator's node is named after its run, and two
/// coordinators of one run would share its services and its workers.
pub fn other_alive_named(node: &Node<ipc::Service>) -> Result<Option<i64>, IpcError> {
    let name = node.name().as_str().to_string();
    let mine = *node.id();
    let mut found = None;
    Node::<ipc::Service>::list(node.config(), |state| {
        if let NodeState::Alive(view) = &state {
            let same = view
                .details()
                .as_ref()
                .filter(|d| d.name().as_str() == name);
            if let (true, Some(details)) = (*view.id() != mine, same) {
                found = Some(i64::from(details.process_id().value()));
                return CallbackProgression::Stop;
            }
        }
        CallbackProgression::Continue
    })
    .map_err(fail("listing this host's iceoryx2 nodes"))?;
    Ok(found)
}

/// The iceoryx2 resources of this prefix on the host now: its files in
/// /dev/shm (shared memory) and under the root (services, nodes, event
/// sockets). A soak watches that they do not pile up.
pub fn resource_count() -> usize {
    fn walk(dir: &std::path::Path) -> usize {
        std::fs::read_dir(dir)
            .into_iter()
            .flatten()
            .flatten()
            .map(|e| {
                let path = e.path();
                if path.is_dir() {
                    walk(&path)
                } else {
                    1
                }
            })
            .sum()
    }
    let shm = named_with(std::path::Path::new(SHM_DIR), &prefix()).count();
    let root = std::env::var(ROOT_ENV).unwrap_or_else(|_| DEFAULT_ROOT.into());
    shm + walk(std::path::Path::new(&root))
}

/// The prefix of every shared-memory file of this host's runs.
fn prefix() -> String {
    std::env::var(PREFIX_ENV).unwrap_or_else(|_| DEFAULT_PREFIX.into())
}

/// Where POSIX shared memory lives on Linux.
const SHM_DIR: &str = "/dev/shm";

/// How long a shared-memory file of the runs may stay empty before it is
/// taken for one whose maker died between creating and sizing it, which
/// a live maker does within microseconds, two system calls apart: room
/// for a maker descheduled between them on a busy or throttled host, and
/// short enough that the cleanups it puts off, while workers are killed
/// twice a second, let nothing pile up (`tests/tests/soak.rs`).
const ABANDONED_AFTER: Duration = Duration::from_millis(500);

/// Cleans up what dead processes of the runs left, as iceoryx2's
/// `try_cleanup_dead_nodes` does, unless a shared-memory file of the runs
/// is half made; returns whether it cleaned up. iceoryx2 0.10, cleaning
/// up after a process killed between creating such a file and sizing it,
/// waits for the file to be sized for ever (its dynamic storage's open
/// retries `MappingSizeIsZero` with no timeout), and a coordinator whose
/// workers were killed at random hung there. So this is the only cleanup
/// the runs' processes do (`config` turns iceoryx2's own off), and it
/// first removes the empty files left unchanged for `ABANDONED_AFTER`,
/// then leaves the cleanup to a later call while a younger one is there,
/// which a live process may be about to size. What remains is a process
/// killed mid-creation during the cleanup itself.
pub fn clean_up_dead(node: &Node<ipc::Service>) -> bool {
    let ready = ready_to_clean(std::path::Path::new(SHM_DIR), &prefix(), ABANDONED_AFTER);
    if ready {
        node.try_cleanup_dead_nodes();
    }
    ready
}

/// [`clean_up_dead`] for a process about to leave, which no later call of
/// its own follows: a half-made file there puts the cleanup off until the
/// file is sized or old enough to remove, `ABANDONED_AFTER` at most.
pub fn clean_up_dead_before_leaving(node: &Node<ipc::Service>) {
    let until = std::time::Instant::now() + ABANDONED_AFTER + ABANDONED_AFTER / 4;
    while !clean_up_dead(node) && std::time::Instant::now() < until {
        std::thread::sleep(ABANDONED_AFTER / 20);
    }
}

/// Removes the empty files in `dir` named with `prefix` that have not
/// changed for `age`; false if an empty file of theirs younger than that
/// is there. Files it cannot read or remove, such as another user's, are
/// left, and put nothing off.
fn ready_to_clean(dir: &std::path::Path, prefix: &str, age: Duration) -> bool {
    let mut ready = true;
    for entry in named_with(dir, prefix) {
        match idle_if_empty(&entry) {
            Some(idle) if idle >= age => {
                let _ = std::fs::remove_file(entry.path());
            }
            Some(_) => ready = false,
            None => {}
        }
    }
    ready
}

/// How long `entry`, an empty file, has gone unchanged: for ever where its
/// time is ahead of the clock, which has been set back since; `None` for
/// anything else, or an entry that cannot be read.
fn idle_if_empty(entry: &std::fs::DirEntry) -> Option<Duration> {
    let meta = entry.metadata().ok()?;
    if !meta.is_file() || meta.len() > 0 {
        return None;
    }
    let changed = meta.modified().ok()?;
    Some(changed.elapsed().unwrap_or(Duration::MAX))
}

/// The entries of `dir` whose names start with `prefix`; none where `dir`
/// cannot be read.
fn named_with<'a>(
    dir: &std::path::Path,
    prefix: &'a str,
) -> impl Iterator<Item = std::fs::DirEntry> + 'a {
    std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .filter(move |e| e.file_name().to_string_lossy().starts_with(prefix))
}

/// Quiets iceoryx2's own log unless `IOX2_LOG_LEVEL` asks for more.
pub fn quiet_logs() {
    set_log_level_from_env_or(LogLevel::Error);
}

/// A node named `name`; signal handling is left to the caller's choice.
pub fn node(
    name: &str,
    config: &Config,
    signals: SignalHandlingMode,
) -> Result<Node<ipc::Service>, IpcError> {
    let node_name: NodeName = name.try_into().map_err(fail(format!("node name {name}")))?;
    NodeBuilder::new()
        .name(&node_name)
        .config(config)
        .signal_handling_mode(signals)
        .create::<ipc::Service>()
        .map_err(fail(format!("creating node {name}")))
}

/// The service names of one run.
#[derive(Clone, Debug)]
pub struct RunNames {
    run: String,
}

impl RunNames {
    pub fn new(run: &str) -> RunNames {
        RunNames { run: run.into() }
    }

    pub fn run(&self) -> &str {
        &self.run
    }

    pub fn register(&self) -> String {
        format!("lander/{}/register", self.run)
    }

    pub fn wake(&self) -> String {
        format!("lander/{}/wake", self.run)
    }

    pub fn eval(&self, worker: u64) -> String {
        format!("lander/{}/worker/{worker:016x}/eval", self.run)
    }

    pub fn jobs(&self, worker: u64) -> String {
        format!("lander/{}/worker/{worker:016x}/jobs", self.run)
    }
}

fn service_name(name: &str) -> Result<ServiceName, IpcError> {
    name.try_into()
        .map_err(fail(format!("service name {name}")))
}

/// Whether the run's services exist yet: a worker waits for this.
pub fn run_exists(names: &RunNames, config: &Config) -> Result<bool, IpcError> {
    ipc::Service::does_exist(
        &service_name(&names.wake())?,
        config,
        MessagingPattern::Event,
    )
    .map_err(fail("looking for the run"))
}

/// A worker's evaluation service, one server (the worker) and one client.
/// Each job has one answer, so a client holds two responses per request:
/// the answer, and room for a stale one to a request it gave up on whose
/// channel it reuses, which would otherwise hold the worker's next answer
/// up. The connection that carries them is sized by that count times
/// every segment the answers' dynamic data segment may grow to, and set
/// up page by page as the worker starts (2.5 MB with iceoryx2's
/// defaults, 8 responses a request).
pub fn eval_service(node: &Node<ipc::Service>, name: &str) -> Result<EvalService, IpcError> {
    node.service_builder(&service_name(name)?)
        .request_response::<[WireGene], [u8]>()
        .request_user_header::<JobHeader>()
        .response_user_header::<ResultHeader>()
        .max_servers(1)
        .max_clients(2)
        .max_nodes(4)
        .max_active_requests_per_client(MAX_QUEUED)
        .max_response_buffer_size(2)
        .max_borrowed_responses_per_pending_response(1)
        .max_loaned_requests(MAX_QUEUED)
        .enable_safe_overflow_for_responses(false)
        .open_or_create()
        .map_err(fail(format!("opening {name}")))
}

/// An event service with room for every worker of a run.
pub fn event_service(node: &Node<ipc::Service>, name: &str) -> Result<EventService, IpcError> {
    node.service_builder(&service_name(name)?)
        .event()
        .max_notifiers(MAX_WORKERS + 4)
        .max_listeners(4)
        .max_nodes(MAX_WORKERS + 4)
        .open_or_create()
        .map_err(fail(format!("opening {name}")))
}

/// The registration service: each worker publishes its announcement.
pub fn register_service(
    node: &Node<ipc::Service>,
    name: &str,
) -> Result<RegisterService, IpcError> {
    node.service_builder(&service_name(name)?)
        .publish_subscribe::<WorkerAnnounce>()
        .max_publishers(MAX_WORKERS + 4)
        .max_subscribers(2)
        .max_nodes(MAX_WORKERS + 4)
        .subscriber_max_buffer_size(4)
        .history_size(0)
        .open_or_create()
        .map_err(fail(format!("opening {name}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_farewell_event_says_why_and_a_job_is_none() {
        for why in crate::Farewell::ALL {
            assert_eq!(farewell_of(farewell_event(why)), Some(why));
            assert_ne!(farewell_event(why), JOB_EVENT);
        }
        assert_eq!(farewell_of(JOB_EVENT), None);
    }

    #[test]
    fn a_run_id_is_checked_and_a_long_one_shown_cut() {
        assert_eq!(check_run_id("run-1_a"), Ok(()));
        for bad in ["", "a b", "a/b", &"x".repeat(MAX_RUN_ID + 1)] {
            assert!(check_run_id(bad).is_err(), "{bad:?}");
        }
        let err = check_run_id(&"y".repeat(5000)).unwrap_err();
        assert!(err.len() < 200, "{err}");
        assert!(
            err.ends_with(&format!("(got \"{}\"…)", "y".repeat(MAX_RUN_ID + 1))),
            "{err}"
        );
    }

    #[test]
    fn a_half_made_file_puts_the_cleanup_off_and_one_left_long_enough_is_removed() {
        let dir = tempfile::tempdir().unwrap();
        let file = |name: &str, bytes: &[u8], idle: Duration| {
            let path = dir.path().join(name);
            std::fs::write(&path, bytes).unwrap();
            let then = std::time::SystemTime::now() - idle;
            let f = std::fs::File::options().write(true).open(&path).unwrap();
            f.set_modified(then).unwrap();
            path
        };
        let long = Duration::from_secs(60);
        let abandoned = file("lander_a.connection", b"", long);
        let sized = file("lander_b.connection", b"x", long);
        let foreign = file("other_d.connection", b"", long);
        assert!(ready_to_clean(dir.path(), "lander_", ABANDONED_AFTER));
        assert!(!abandoned.exists());
        assert!(sized.exists() && foreign.exists());

        // One a live process may be about to size puts the cleanup off,
        // and stays, until it is sized or left long enough.
        let fresh = file("lander_c.connection", b"", Duration::ZERO);
        assert!(!ready_to_clean(dir.path(), "lander_", ABANDONED_AFTER));
        assert!(fresh.exists());
        std::fs::write(&fresh, b"x").unwrap();
        assert!(ready_to_clean(dir.path(), "lander_", ABANDONED_AFTER));
        let stale = file("lander_e.connection", b"", long);
        assert!(ready_to_clean(dir.path(), "lander_", ABANDONED_AFTER));
        assert!(!stale.exists() && fresh.exists());

        // A time ahead of the clock is one from before the clock was set
        // back: the file is old, not about to be sized.
        let ahead = dir.path().join("lander_f.connection");
        std::fs::write(&ahead, b"").unwrap();
        let f = std::fs::File::options().write(true).open(&ahead).unwrap();
        f.set_modified(std::time::SystemTime::now() + long).unwrap();
        assert!(ready_to_clean(dir.path(), "lander_", ABANDONED_AFTER));
        assert!(!ahead.exists());
    }
}
