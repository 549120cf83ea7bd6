//! `lander`: the command line. Each subcommand lives in `cli/`; this file
//! only parses arguments and turns errors into a message and an exit code.

mod cli;

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    let args = cli::Cli::parse();
    if let Err(e) = lander_coordinator::stop::install() {
        eprintln!("error: cannot handle SIGINT and SIGTERM: {e}");
        return ExitCode::FAILURE;
    }
    match cli::dispatch(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            // 128 + SIGINT, as a shell reports a process Ctrl-C stopped.
            ExitCode::from(if lander_coordinator::stop::asked() {
                130
            } else {
                1
            })
        }
    }
}
