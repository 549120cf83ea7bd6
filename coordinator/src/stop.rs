//! Ctrl-C and SIGTERM for the coordinator. The first asks the work to stop
//! at its next look (before an in-process generation, and within a
//! pool's sleep slice over workers), so the error unwinds through the
//! pool's `Drop`: workers are told the run is over and the run's shared
//! memory is removed. A second signal ends the process at once.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, LazyLock};

static ASKED: LazyLock<Arc<AtomicBool>> = LazyLock::new(|| Arc::new(AtomicBool::new(false)));

/// Installs the handlers for SIGINT and SIGTERM.
pub fn install() -> std::io::Result<()> {
    use signal_hook::consts::{SIGINT, SIGTERM};
    for signal in [SIGINT, SIGTERM] {
        // Registered first, so it sees the flag as the previous signal
        // left it: set means this is the second.
        signal_hook::flag::register_conditional_shutdown(signal, 130, ASKED.clone())?;
        signal_hook::flag::register(signal, ASKED.clone())?;
    }
    Ok(())
}

/// Whether a signal asked the work to stop.
pub fn asked() -> bool {
    ASKED.load(Ordering::Relaxed)
}
