//! `lander-worker`: a worker process that flies landers for a coordinator.
//!
//! - [`serve`]: the loops that answer jobs, over iceoryx2 or zenoh.
//! - [`cpu`]: where the process runs (one CPU, the batch class).
//! - [`parent`]: a spawned worker stops when the coordinator that spawned
//!   it is gone.

mod cpu;
mod parent;
mod serve;

use clap::{Parser, ValueEnum};
use lander_protocol::iox::check_run_id;
use lander_protocol::net::NetOptions;
use lander_protocol::spin::{Spin, MAX_SPIN_US};
use lander_protocol::Farewell;
use lander_telemetry::log::LogFormat;
use lander_telemetry::MetricsServer;
use serve::{Exit, Note};
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Duration;

#[derive(Parser, Debug)]
#[command(
    name = "lander-worker",
    version,
    // `--cpu -1` is refused as a CPU number, not read as an unknown flag.
    allow_negative_numbers = true,
    about = "Serves lander evaluation jobs for one run, over iceoryx2 shared memory or zenoh",
    long_about = "Serves lander evaluation jobs for one run, over iceoryx2 shared memory on \
        this host or zenoh from any host.\n\n\
        `lander run --workers N` starts its own workers; you only start this by hand to \
        attach workers to a run:\n\n\
        \x20   lander run --attach --run-id demo        # in one terminal\n\
        \x20   lander-worker --run demo                 # in others, as many as you like\n\n\
        Workers may join or leave at any time; a chunk a departed worker held is flown \
        again by another, with identical results. A worker started before its run waits \
        for it. It exits when the run ends, its coordinator disappears, or on SIGINT/SIGTERM, \
        with status 0 (a worker stopped loses no work: its chunks are flown again); with \
        --rejoin it outlives its coordinator instead, waiting for the run to be resumed. A \
        worker its coordinator dropped (a missed deadline) exits with 3, one whose answers \
        it refused with 4, and an error with 1.\n\n\
        Across hosts, over zenoh:\n\n\
        \x20   lander run --attach --run-id demo --transport zenoh --listen tcp/0.0.0.0:7447 \\\n\
        \x20       --users users.txt                   # on the coordinator's host\n\
        \x20   lander-worker --run demo --transport zenoh --connect tcp/10.0.0.5:7447 \\\n\
        \x20       --credentials me.txt                # on each worker host\n\n\
        TLS settings go in a zenoh JSON5 file given with --zenoh-config; deploy/ in the \
        source has examples, a script that starts N workers and systemd units."
)]
struct Args {
    /// The run to serve, as printed by `lander run --attach`.
    #[arg(long, value_name = "ID")]
    run: String,
    /// This worker's id, in hex [default: random].
    #[arg(long, value_name = "HEX", value_parser = parse_hex)]
    id: Option<u64>,
    /// Print warnings and errors only.
    #[arg(long)]
    quiet: bool,
    /// Run on this CPU only (`lander run --workers N` pins its workers to
    /// one CPU each when N is at most the number of CPUs).
    #[arg(long, value_name = "N")]
    cpu: Option<usize>,
    /// iceoryx2: after answering, poll for the next job this long before
    /// sleeping, shorter and shorter while none comes (0: never). Only for
    /// a worker with a CPU of its own: `lander run --workers N` passes it
    /// when the coordinator has a CPU left over.
    #[arg(
        long,
        value_name = "MICROSECONDS",
        default_value_t = 0,
        value_parser = clap::value_parser!(u64).range(0..=MAX_SPIN_US)
    )]
    spin_us: u64,
    /// iceoryx2 for a coordinator on this host, zenoh for one anywhere.
    #[arg(long, value_enum, default_value_t = TransportArg::Iceoryx2)]
    transport: TransportArg,
    /// zenoh: the coordinator's endpoint, such as tcp/10.0.0.5:7447.
    #[arg(long, value_name = "ENDPOINT")]
    connect: Vec<String>,
    /// zenoh: a JSON5 zenoh configuration, for TLS and anything else.
    #[arg(long, value_name = "FILE")]
    zenoh_config: Option<PathBuf>,
    /// zenoh: a file whose first line is `user:password`, for a coordinator
    /// started with --users.
    #[arg(long, value_name = "FILE")]
    credentials: Option<PathBuf>,
    /// Serve Prometheus metrics at http://ADDR/metrics: jobs, genomes,
    /// refused frames, busy seconds. ADDR is HOST:PORT, or a PORT on
    /// loopback.
    #[arg(long, value_name = "ADDR")]
    metrics: Option<String>,
    /// How diagnostics are written to stderr: `text` or `json` (one JSON
    /// object per line). RUST_LOG filters them.
    #[arg(long, value_name = "FORMAT", default_value = "text")]
    log_format: LogFormat,
    /// Testing only: answer every evaluation with a wrong fitness, for
    /// the tests of the coordinator's --verify.
    #[arg(long, hide = true)]
    lie: bool,
    /// Set by a coordinator that spawns this worker, to its own pid: the
    /// worker stops once that process is gone (src/parent.rs).
    #[arg(long, value_name = "PID", hide = true)]
    parent: Option<u32>,
    /// Outlive the coordinator: when it dies or stops before the run's
    /// end, wait for the run to go on (`lander run --resume` with the same
    /// `--run-id`) and serve it again, until the run finishes or a signal
    /// stops the worker, each time under a new worker id (a coordinator
    /// that saw the worker leave takes no id back). For workers kept by a
    /// service manager.
    #[arg(long, conflicts_with_all = ["parent", "id"])]
    rejoin: bool,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
enum TransportArg {
    Iceoryx2,
    Zenoh,
}

fn parse_hex(s: &str) -> Result<u64, String> {
    u64::from_str_radix(s, 16).map_err(|e| format!("`{s}` is not a hex id: {e}"))
}

/// How long a worker started with `--rejoin` waits before it looks for
/// its run again.
const REJOIN_PAUSE: Duration = Duration::from_millis(500);

/// The status of a worker its coordinator dropped.
const DROPPED: u8 = 3;
/// The status of a worker whose answers its coordinator refused.
const REFUSED: u8 = 4;

fn main() -> ExitCode {
    let args = Args::parse();
    if args.lie {
        serve::start_lying();
    }
    // Before any thread starts, so that every thread inherits both.
    let placed = args.cpu.map(cpu::pin_to).transpose();
    let batch = cpu::run_as_batch_job();
    let mut id = args.id.unwrap_or_else(rand::random);
    let program = format!("lander-worker {id:016x}");
    if let Err(e) = lander_telemetry::log::init(&program, args.log_format, args.quiet) {
        eprintln!("{program}: error: {e}");
        return ExitCode::FAILURE;
    }
    if let Err(e) = check_run_id(&args.run) {
        tracing::error!("--run {e}");
        return ExitCode::FAILURE;
    }
    // SIGINT and SIGTERM raise `stop` (over iceoryx2, until its node
    // handles them): a Ctrl-C (it reaches spawned workers too, in their
    // coordinator's process group) that killed the worker while it made
    // its node, or probed the iceoryx2 root, left files half written that
    // no later cleanup could read. Before the watch on the parent starts:
    // a worker whose coordinator is gone as it starts would otherwise die
    // of the SIGTERM the watch sends it.
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGTERM, signal_hook::consts::SIGINT] {
        if let Err(e) = signal_hook::flag::register(signal, stop.clone()) {
            tracing::error!("cannot handle signal {signal}: {e}");
            return ExitCode::FAILURE;
        }
    }
    if let Some(Err(e)) = args.parent.map(parent::watch) {
        tracing::error!("cannot watch the coordinator that started this worker: {e}");
        return ExitCode::FAILURE;
    }
    if args.transport != TransportArg::Zenoh {
        for (flag, given) in [
            ("--connect", !args.connect.is_empty()),
            ("--zenoh-config", args.zenoh_config.is_some()),
            ("--credentials", args.credentials.is_some()),
        ] {
            if given {
                tracing::error!("{flag} is for --transport zenoh");
                return ExitCode::FAILURE;
            }
        }
    }
    if let (Err(e), Some(n)) = (placed, args.cpu) {
        tracing::error!("--cpu {n}: cannot run there: {e}");
        return ExitCode::FAILURE;
    }
    if let Err(e) = batch {
        tracing::warn!("cannot use the batch scheduling class: {e}");
    }
    // Served until the worker exits.
    let _metrics = match &args.metrics {
        Some(addr) => {
            let metrics = serve::count_jobs();
            match MetricsServer::start(addr, move || metrics.encode()) {
                Ok(server) => Some(server),
                Err(e) => {
                    tracing::error!("{e}");
                    return ExitCode::FAILURE;
                }
            }
        }
        None => None,
    };
    if args.transport == TransportArg::Zenoh
        && args.connect.is_empty()
        && args.zenoh_config.is_none()
    {
        tracing::error!("--transport zenoh needs --connect ENDPOINT (or a --zenoh-config)");
        return ExitCode::FAILURE;
    }
    let note = |kind: Note, msg: &str| match kind {
        Note::Warning => tracing::warn!("{msg}"),
        Note::Info => tracing::info!("{msg}"),
    };
    let served = loop {
        let served = serve_once(&args, id, &stop, &note);
        match served {
            Ok(exit) if args.rejoin && comes_back_after(exit) => {
                // A new id: the coordinator may have seen this worker
                // leave, and takes no id back.
                id = rand::random();
                note(
                    Note::Info,
                    &format!(
                        "{}; waiting for run {} to go on, as worker {id:016x} (--rejoin: \
                         `lander run --resume` with --run-id {} brings it back)",
                        leaving(exit).1,
                        args.run,
                        args.run
                    ),
                );
                lander_telemetry::log::rename(&format!("lander-worker {id:016x}"));
                // Not at once: a dead coordinator's zenoh token may linger
                // (for a router's lease), and would be seen again.
                std::thread::sleep(REJOIN_PAUSE);
            }
            other => break other,
        }
    };
    match served {
        Ok(exit) => {
            let (kind, why, code) = leaving(exit);
            let jobs = serve::answered();
            note(kind, &format!("{why} after {jobs} jobs; exiting"));
            code
        }
        Err(e) => {
            tracing::error!("{e}");
            ExitCode::FAILURE
        }
    }
}

/// Serves the run once, until the coordinator tells the worker to leave,
/// goes away, or a signal comes.
fn serve_once(
    args: &Args,
    id: u64,
    stop: &AtomicBool,
    note: &dyn Fn(Note, &str),
) -> Result<Exit, String> {
    match args.transport {
        TransportArg::Iceoryx2 => {
            let spin = Spin::new(Duration::from_micros(args.spin_us));
            serve::serve(&args.run, id, spin, stop, note).map_err(|e| e.to_string())
        }
        TransportArg::Zenoh => {
            let options = NetOptions {
                connect: args.connect.clone(),
                config_file: args.zenoh_config.clone(),
                credentials: args.credentials.clone(),
                ..NetOptions::default()
            };
            serve::zenoh::serve(&args.run, id, &options, stop, note).map_err(|e| e.to_string())
        }
    }
}

/// Whether a worker started with `--rejoin` waits for its run again after
/// `exit`: its coordinator went away or stopped, and a resume may follow.
fn comes_back_after(exit: Exit) -> bool {
    matches!(exit, Exit::CoordinatorGone | Exit::Told(Farewell::Stopped))
}

/// What the worker says as it leaves after `exit`, and its status.
fn leaving(exit: Exit) -> (Note, &'static str, ExitCode) {
    match exit {
        Exit::Told(Farewell::RunOver) => (Note::Info, "run finished", ExitCode::SUCCESS),
        Exit::Told(Farewell::Stopped) => (
            Note::Info,
            "the coordinator stopped before the run's end",
            ExitCode::SUCCESS,
        ),
        Exit::CoordinatorGone => (Note::Info, "the coordinator is gone", ExitCode::SUCCESS),
        Exit::Signal if parent::gone() => (Note::Info, "the coordinator is gone", ExitCode::SUCCESS),
        Exit::Signal => (Note::Info, "stopped by signal", ExitCode::SUCCESS),
        // Not a success: a service manager that restarts failed workers
        // brings this one back, as a new worker.
        Exit::Told(Farewell::Dropped) => (
            Note::Warning,
            "the coordinator dropped this worker (a missed deadline or a broken link: its log says which)",
            ExitCode::from(DROPPED),
        ),
        // A status of its own, which a service manager is told not to
        // restart: the same answers would be refused again.
        Exit::Told(Farewell::Refused) => (
            Note::Warning,
            "the coordinator refused this worker's answers (wrong under --verify, or not decoding: its log says which)",
            ExitCode::from(REFUSED),
        ),
    }
}
