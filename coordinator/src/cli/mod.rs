//! The subcommands of `lander` and their arguments.

/// `println!` that returns an error where stdout cannot be written (a
/// full disk, a closed pipe) instead of panicking; `main` ends quietly on
/// a closed pipe, as `lander guide ... | head` closes it.
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        writeln!(std::io::stdout().lock(), $($arg)*)
            .map_err(|e| anyhow::Error::new($crate::cli::StdoutError(e)))
    }};
}

mod bench;
mod experiment;
mod flight;
mod learning;
mod replay;
mod router;
mod run;
mod stress;
mod sweep;
mod transport;
mod watch;

use clap::{Parser, Subcommand};
use lander_coordinator::stop::Stop;
use lander_model::Method;
use lander_telemetry::log::LogFormat;

/// A write to stdout that failed, as `outln!` reports it.
// The cause is part of the message, not a `source`: a chain printed whole
// would say it twice.
#[derive(Debug, thiserror::Error)]
#[error("writing to stdout: {0}")]
pub struct StdoutError(pub std::io::Error);

impl StdoutError {
    /// Whether the reader of stdout stopped reading.
    pub fn is_closed_pipe(&self) -> bool {
        self.0.kind() == std::io::ErrorKind::BrokenPipe
    }
}

/// Whether `e` is stdout's reader having stopped reading: the command's
/// work is done and it ends quietly; any other broken pipe is an error.
pub fn closed_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|cause| {
        cause
            .downcast_ref::<StdoutError>()
            .is_some_and(StdoutError::is_closed_pipe)
    })
}

#[derive(Parser, Debug)]
#[command(
    name = "lander",
    version,
    about = "The guided genetic algorithm for Lunar Lander planning (Liu, UBC)",
    long_about = "Evolves landing plans for the Lunar Lander with the general GA or the guided GA \
                  of Liu's paper, and flies single genomes for inspection."
)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
    /// How diagnostics are written to stderr: `text` for people, `json`
    /// for one JSON object per line. RUST_LOG filters them.
    #[arg(long, global = true, value_name = "FORMAT", default_value = "text")]
    pub log_format: LogFormat,
}

// Every subcommand takes negative numbers as values (`--x0 -5`), so that
// one out of range is refused by its own check, naming the flag, rather
// than read as an unknown flag.
#[derive(Subcommand, Debug)]
enum Command {
    /// Run one trial and write its generations and best lander.
    #[command(allow_negative_numbers = true)]
    Run(run::RunArgs),
    /// Fly one genome and print where and how it touched down.
    #[command(allow_negative_numbers = true)]
    Fly(flight::FlyArgs),
    /// Apply the guided evolve pass to one genome and print the result.
    #[command(allow_negative_numbers = true)]
    Guide(flight::GuideArgs),
    /// Run an experiment of many paired trials and write tables, plots and a report.
    #[command(allow_negative_numbers = true)]
    Experiment(experiment::ExperimentArgs),
    /// Run one experiment under many settings as one workload, and compare
    /// the settings in tables, plots and a report.
    #[command(allow_negative_numbers = true)]
    Sweep(sweep::SweepArgs),
    /// Draw a flight as an SVG or an animated HTML page.
    #[command(allow_negative_numbers = true)]
    Replay(replay::ReplayArgs),
    /// Compare evaluation throughput in-process, over iceoryx2 and over zenoh, side by side.
    #[command(allow_negative_numbers = true)]
    Bench(bench::BenchArgs),
    /// Relay between a coordinator and workers on hosts that cannot reach
    /// each other: a zenoh router, until SIGTERM or SIGINT.
    #[command(allow_negative_numbers = true)]
    Router(router::RouterArgs),
}

/// Refuses an `--out` that names something other than a folder (a file),
/// where creating the folder or a file in it would fail with the system's
/// "File exists" or "Not a directory".
pub(super) fn out_folder(out: &std::path::Path) -> anyhow::Result<()> {
    if out.exists() && !out.is_dir() {
        anyhow::bail!(
            "{} is not a folder; give --out a folder for the results",
            out.display()
        );
    }
    Ok(())
}

/// The command that finishes an interrupted `lander experiment` or `lander
/// sweep` (`command`) of `file` in `out`, with the flags that change what
/// it runs: without them the folder would be refused as another's.
pub(super) fn resume_command(
    command: &str,
    file: &std::path::Path,
    out: &std::path::Path,
    trials: Option<u64>,
    allow_large: bool,
) -> String {
    let mut again = format!(
        "lander {command} {} --out {} --resume",
        file.display(),
        out.display()
    );
    if let Some(trials) = trials {
        again.push_str(&format!(" --trials {trials}"));
    }
    if allow_large {
        again.push_str(" --allow-large");
    }
    again
}

/// Runs a subcommand; those that evaluate stop when `stop` is asked.
pub fn dispatch(cli: Cli, stop: &Stop) -> anyhow::Result<()> {
    match cli.command {
        Command::Run(args) => run::run(args, stop),
        Command::Fly(args) => flight::fly(args),
        Command::Guide(args) => flight::guide(args),
        Command::Bench(args) => bench::bench(args, stop),
        Command::Experiment(args) => experiment::experiment(args, stop),
        Command::Sweep(args) => sweep::sweep(args, stop),
        Command::Replay(args) => replay::replay(args),
        Command::Router(args) => router::router(args),
    }
}

/// A `--threads` flag's parser: 0 (one per core) to the most threads an
/// evaluator starts, refused naming the flag beyond.
pub fn threads_parser() -> clap::builder::RangedU64ValueParser<usize> {
    let most = lander_coordinator::evaluator::MAX_THREADS as u64;
    clap::builder::RangedU64ValueParser::<usize>::new().range(0..=most)
}

/// A `--method` flag's parser: one of `methods`, by name, listed in the
/// help and in the error for any other word.
pub fn method_parser(
    methods: &'static [Method],
) -> impl clap::builder::TypedValueParser<Value = Method> {
    use clap::builder::TypedValueParser;
    clap::builder::PossibleValuesParser::new(methods.iter().map(|m| m.name()))
        .try_map(|name| name.parse::<Method>())
}
