//! `lander-worker`: a worker process that flies landers for a coordinator.

use clap::Parser;
use lander_worker::serve::{serve, Exit, Note};
use std::process::ExitCode;

#[derive(Parser, Debug)]
#[command(
    name = "lander-worker",
    version,
    about = "Serves lander evaluation jobs for one run over iceoryx2 shared memory",
    long_about = "Serves lander evaluation jobs for one run over iceoryx2 shared memory.\n\n\
        `lander run --workers N` starts its own workers; you only start this by hand to \
        attach workers to a run:\n\n\
        \x20   lander run --attach --run-id demo        # in one terminal\n\
        \x20   lander-worker --run demo                 # in others, as many as you like\n\n\
        Workers may join or leave at any time; a chunk a departed worker held is flown \
        again by another, with identical results. A worker started before its run waits \
        for it. It exits when the run ends, its coordinator disappears, or on SIGINT/SIGTERM."
)]
struct Args {
    /// The run to serve, as printed by `lander run --attach`.
    #[arg(long, value_name = "ID")]
    run: String,
    /// This worker's id, in hex [default: random].
    #[arg(long, value_name = "HEX", value_parser = parse_hex)]
    id: Option<u64>,
    /// Print errors only.
    #[arg(long)]
    quiet: bool,
}

fn parse_hex(s: &str) -> Result<u64, String> {
    u64::from_str_radix(s, 16).map_err(|e| format!("`{s}` is not a hex id: {e}"))
}

fn main() -> ExitCode {
    let args = Args::parse();
    if args.run.is_empty()
        || !args
            .run
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
    {
        eprintln!(
            "lander-worker: error: --run must be letters, digits, '-' or '_' (got {:?})",
            args.run
        );
        return ExitCode::FAILURE;
    }
    let id = args.id.unwrap_or_else(rand::random);
    let say = |msg: &str| eprintln!("lander-worker {id:016x}: {msg}");
    let note = |kind: Note, msg: &str| {
        if kind == Note::Warning || !args.quiet {
            say(msg)
        }
    };
    match serve(&args.run, id, &note) {
        Ok(exit) => {
            note(
                Note::Info,
                match exit {
                    Exit::RunFinished => "run finished; exiting",
                    Exit::CoordinatorGone => "the coordinator is gone; exiting",
                    Exit::Signal => "stopped by signal; exiting",
                },
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            say(&format!("error: {e}"));
            ExitCode::FAILURE
        }
    }
}
