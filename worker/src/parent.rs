//! A spawned worker outlives no coordinator. The coordinator that spawns a
//! worker names itself with `--parent PID`; a thread of the worker looks
//! four times a second whether its parent is still that process. When it
//! is not (the coordinator died and the worker was handed to init or a
//! subreaper), the worker stops as SIGTERM asks it to. This covers the case
//! its transport cannot: a coordinator killed before the worker ever
//! reached it, whose services may be gone before the worker looks.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

/// Set once the parent is found gone, before the worker is asked to stop.
static GONE: AtomicBool = AtomicBool::new(false);

/// Whether the worker was stopped because its coordinator is gone.
pub fn gone() -> bool {
    GONE.load(Ordering::Relaxed)
}

/// How often the parent is looked at: a sleeping thread's wake-up, no CPU
/// to speak of.
const LOOK: Duration = Duration::from_millis(250);

/// Starts the thread that stops this worker once `parent` is no longer its
/// parent.
pub fn watch(parent: u32) -> std::io::Result<()> {
    std::thread::Builder::new()
        .name("parent".into())
        .spawn(move || {
            while std::os::unix::process::parent_id() == parent {
                std::thread::sleep(LOOK);
            }
            tracing::warn!(
                "the coordinator that started this worker (pid {parent}) is gone; stopping"
            );
            GONE.store(true, Ordering::Relaxed);
            // SAFETY: kill(2) on this process's own pid with a valid signal
            // number touches no memory of ours; both transports' loops
            // handle SIGTERM as a request to stop.
            unsafe { libc::kill(libc::getpid(), libc::SIGTERM) };
        })?;
    Ok(())
}
