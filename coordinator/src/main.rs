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
        Err(e) if closed_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            tracing::error!("{e:#}");
            // 128 + SIGINT, as a shell reports a process Ctrl-C stopped.
            ExitCode::from(if stop.asked() { 130 } else { 1 })
        }
    }
}

/// Whether `e` is stdout's reader having stopped reading: only a write to
/// stdout is let go so; any other broken pipe is an error.
fn closed_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|cause| {
        cause
            .downcast_ref::<cli::StdoutError>()
            .is_some_and(cli::StdoutError::is_closed_pipe)
    })
}

/// SIGINT and SIGTERM ask `stop`: the work stops at its next look, and the
/// pool's `Drop` tells the workers and removes the run's files. A second
/// signal ends the process at once, with 130.
fn stop_on_signals(stop: &Stop) -> std::io::Result<()> {
    use signal_hook::consts::{SIGINT, SIGTERM};
    for signal in [SIGINT, SIGTERM] {
        // Registered first, so it sees the flag as the previous signal
        // left it: set means this is the second.
        signal_hook::flag::register_conditional_shutdown(signal, 130, stop.flag())?;
        signal_hook::flag::register(signal, stop.flag())?;
    }
    Ok(())
}
