//! `lander`: the command line. Each subcommand lives in `cli/`; this file
//! only parses arguments, installs the log, handles SIGINT and SIGTERM,
//! and turns errors into a message and an exit code.

// The flags' doc comments are clap's help texts, where `<name>` is a
// placeholder for the user, not HTML.
#![allow(rustdoc::invalid_html_tags)]

mod cli;

use clap::Parser;
use lander_coordinator::stop::Stop;
use std::process::ExitCode;
use std::sync::atomic::{AtomicU64, Ordering};

fn main() -> ExitCode {
    let args = cli::Cli::parse();
    if let Err(e) = lander_telemetry::log::init("lander", args.log_format, false) {
        eprintln!("lander: error: {e}");
        return ExitCode::FAILURE;
    }
    let stop = Stop::new();
    if let Err(e) = stop_on_signals(&stop) {
        tracing::error!("cannot handle SIGINT and SIGTERM: {e}");
        return ExitCode::FAILURE;
    }
    match cli::dispatch(args, &stop) {
        Ok(()) => ExitCode::SUCCESS,
        // Whoever read stdout stopped reading (`lander guide ... | head`):
        // what it took was what it wanted, and the run's files are written.
        Err(e) if cli::closed_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            tracing::error!("{e:#}");
            // 128 + SIGINT, as a shell reports a process Ctrl-C stopped.
            ExitCode::from(if stop.asked() { 130 } else { 1 })
        }
    }
}

/// SIGINT and SIGTERM ask `stop`: the work stops at its next look, and the
/// pool's `Drop` tells the workers and removes the run's files. Another
/// signal, [`AGAIN`] or more after the first, ends the process at once,
/// with 130 and no checkpoint saved.
fn stop_on_signals(stop: &Stop) -> std::io::Result<()> {
    use signal_hook::consts::{SIGINT, SIGTERM};
    let start = std::time::Instant::now();
    // When the first signal came, in nanoseconds after `start`, plus one:
    // zero means none has.
    let first = std::sync::Arc::new(AtomicU64::new(0));
    for signal in [SIGINT, SIGTERM] {
        let (flag, first) = (stop.flag(), first.clone());
        let handler = move || {
            let now = start.elapsed().as_nanos() as u64 + 1;
            match first.compare_exchange(0, now, Ordering::SeqCst, Ordering::SeqCst) {
                Ok(_) => flag.store(true, Ordering::SeqCst),
                Err(then) if now - then >= AGAIN.as_nanos() as u64 => {
                    let said = b"lander: a second signal: exiting at once, saving nothing more\n";
                    // SAFETY: write(2) is async-signal-safe; the buffer is
                    // valid for its length.
                    let _ = unsafe { libc::write(2, said.as_ptr().cast(), said.len()) };
                    signal_hook::low_level::exit(130);
                }
                Err(_) => {}
            }
        };
        // SAFETY: the handler only reads the monotonic clock
        // (clock_gettime), works atomics, and calls write(2) and _exit(2):
        // all async-signal-safe. It allocates nothing and takes no lock.
        unsafe { signal_hook::low_level::register(signal, handler) }?;
    }
    Ok(())
}

/// How long after the first signal another counts as a second request,
/// the one that exits at once. One request can arrive twice, microseconds
/// apart: `timeout -s INT` signals the process and then its group.
const AGAIN: std::time::Duration = std::time::Duration::from_millis(100);
