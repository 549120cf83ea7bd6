//! How a command evaluates: in this process, or on `lander-worker`
//! processes it spawns or that attach themselves, over iceoryx2 on this
//! host or zenoh from any host.

use super::watch::{Watch, WatchArgs};
use anyhow::Context;
use clap::{Args, ValueEnum};
use lander_coordinator::evaluator::{Backend, InProcess, DEFAULT_SPIN, DEFAULT_SPIN_US};
use lander_coordinator::pool::zenoh::Zenoh;
use lander_coordinator::pool::{cpu_to_spare, IpcPool, Pool, PoolOptions, DEPTH};
use lander_coordinator::stop::Stop;
use lander_protocol::iox::{check_run_id, MAX_WORKERS};
use lander_protocol::net::{
    any_port, connecting, coordinator_config, listening, strangers_warning, NetOptions,
};
use lander_protocol::spin::MAX_SPIN_US;
use lander_telemetry::Telemetry;
use std::path::PathBuf;
use std::time::Duration;

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransportArg {
    /// Shared memory, for workers on this host.
    Iceoryx2,
    /// The network, for workers on any host.
    Zenoh,
}

/// Whether the coordinator flies a share of each generation itself,
/// between answers, rather than sleeping while its workers fly. Unless
/// `Never`, it also flies the share of the worker on its own CPU
/// (`PoolOptions::stand_in`).
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum CoordinatorShare {
    /// Where spawned workers leave a CPU idle: fewer of them than CPUs.
    /// Never with --attach, whose workers may be on this host's CPUs.
    Auto,
    Always,
    Never,
}

impl CoordinatorShare {
    /// Whether the coordinator of `spawned` workers (0: attached ones)
    /// flies a share.
    pub fn applies(self, spawned: usize) -> bool {
        match self {
            CoordinatorShare::Always => true,
            CoordinatorShare::Never => false,
            CoordinatorShare::Auto => {
                spawned > 0 && cpu_to_spare(spawned, lander_protocol::host::allowed_cpus().len())
            }
        }
    }

    /// Whether the coordinator flies the share of the worker on its CPU
    /// (`PoolOptions::stand_in`): unless it never flies.
    pub fn stands_in(self) -> bool {
        self != CoordinatorShare::Never
    }
}

/// The longest `--deadline`: a day for one chunk is already no deadline.
const MAX_DEADLINE_S: f64 = 86_400.0;

/// Where a zenoh coordinator listens unless told otherwise: this host only.
const DEFAULT_LISTEN: &str = "tcp/127.0.0.1:7447";

#[derive(Args, Debug)]
pub struct TransportArgs {
    /// Worker processes to spawn on this host, reached over --transport
    /// (iceoryx2 shared memory by default); 0 evaluates in this process.
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub workers: usize,
    /// Wait for workers started elsewhere with `lander-worker --run <id>`;
    /// they may join or leave at any time.
    #[arg(long)]
    attach: bool,
    /// With --attach: wait for N workers to join before the first
    /// generation, so that it is spread over all of them [default: 1].
    #[arg(long, value_name = "N", requires = "attach")]
    min_workers: Option<usize>,
    /// The run id that names this run's iceoryx2 services or zenoh keys;
    /// over iceoryx2, refused while another coordinator on this host runs
    /// it [default: random].
    #[arg(long, value_name = "ID")]
    run_id: Option<String>,
    /// Seconds a worker may take over one chunk before it goes to another,
    /// and a spawned worker to join before it is replaced.
    #[arg(long, value_name = "SECS", default_value_t = 30.0)]
    deadline: f64,
    /// How workers are reached: iceoryx2 on this host, zenoh from any host.
    #[arg(long, value_enum, default_value_t = TransportArg::Iceoryx2)]
    transport: TransportArg,
    /// zenoh: where to listen for workers, such as tcp/0.0.0.0:7447
    /// [default: tcp/127.0.0.1:7447].
    #[arg(long, value_name = "ENDPOINT")]
    listen: Vec<String>,
    /// zenoh: a JSON5 zenoh configuration, for TLS and anything else.
    #[arg(long, value_name = "FILE")]
    zenoh_config: Option<PathBuf>,
    /// zenoh: a file of `user:password` lines; only workers with one of
    /// them may join.
    #[arg(long, value_name = "FILE")]
    users: Option<PathBuf>,
    /// Let spawned workers run on any CPU. By default each of N workers is
    /// pinned to a CPU of its own when there are at least N; leave them
    /// free when other programs need the same CPUs.
    #[arg(long)]
    no_pin: bool,
    /// Microseconds an evaluation thread polls for the next generation, a
    /// spawned iceoryx2 worker for its next chunk, or the coordinator for
    /// its workers' answers, before sleeping, halving while none comes;
    /// only where each has a CPU of its own (the coordinator: where it
    /// flies the share of the worker on its CPU). 0 never spins.
    #[arg(long, value_name = "MICROSECONDS", default_value_t = DEFAULT_SPIN_US)]
    spin_us: u64,
    /// The share of answered chunks, 0 to 1, flown again on this host and
    /// compared; a worker that answered wrongly is dropped for good and
    /// its chunks flown again [default: 0.02 over zenoh, 0 over iceoryx2].
    #[arg(long, value_name = "RATE")]
    verify: Option<f64>,
    /// Whether the coordinator flies queued chunks itself between answers
    /// instead of sleeping [default: auto: where the spawned workers leave
    /// a CPU idle, and the share of the worker on the coordinator's CPU;
    /// never: not even that].
    #[arg(long, value_enum, value_name = "WHEN")]
    coordinator_share: Option<CoordinatorShare>,
    #[command(flatten)]
    pub watch: WatchArgs,
}

/// `--verify`'s default over zenoh: workers on other hosts (other memory,
/// perhaps another build) are checked on 2% of their chunks, which costs
/// this host about 2% of the evaluation work. On one host, iceoryx2
/// workers run this very build on this very memory, and are not checked.
const DEFAULT_VERIFY_ZENOH: f64 = 0.02;

impl TransportArgs {
    /// The run's telemetry, under `--run-id` or a random run id, with its
    /// metrics endpoint when `--metrics` asks for one.
    pub fn watch(&self) -> anyhow::Result<Watch> {
        let run_id = match &self.run_id {
            Some(id) => {
                check_run_id(id).map_err(|e| anyhow::anyhow!("--run-id {e}"))?;
                id.clone()
            }
            None => format!("{:08x}", rand::random::<u32>()),
        };
        self.watch.start(run_id)
    }

    /// Refuses `--threads` (`given`) beside `--workers` or `--attach`:
    /// the workers fly, and the threads would never start.
    pub fn check_threads(&self, given: bool) -> anyhow::Result<()> {
        anyhow::ensure!(
            !given || (self.workers == 0 && !self.attach),
            "--threads is for in-process evaluation; with --workers or --attach the workers fly"
        );
        Ok(())
    }

    /// The evaluator the flags ask for: in-process, spawned workers, or
    /// attached ones, telling `telemetry` what happens to them.
    pub fn evaluator(
        &self,
        threads: usize,
        telemetry: &Telemetry,
        stop: &Stop,
    ) -> anyhow::Result<Box<dyn Backend>> {
        Ok(match self.pool(telemetry, stop)? {
            Some(pool) => pool,
            None => Box::new(
                InProcess::new(threads)?
                    .stopping_on(stop.clone())
                    .spinning(Duration::from_micros(self.spin_us)),
            ),
        })
    }

    /// The worker pool the flags ask for, under the telemetry's run id, or
    /// `None` for in-process work.
    pub fn pool(
        &self,
        telemetry: &Telemetry,
        stop: &Stop,
    ) -> anyhow::Result<Option<Box<dyn Backend>>> {
        anyhow::ensure!(
            self.workers <= MAX_WORKERS,
            "--workers must be at most {MAX_WORKERS} (got {})",
            self.workers
        );
        anyhow::ensure!(
            self.deadline.is_finite() && self.deadline > 0.0 && self.deadline <= MAX_DEADLINE_S,
            "--deadline must be more than 0 and at most {MAX_DEADLINE_S} seconds (got {:?})",
            self.deadline
        );
        // Checked even where nothing spins, so that a bad value is never
        // taken in silence.
        anyhow::ensure!(
            self.spin_us <= MAX_SPIN_US,
            "--spin-us must be at most {MAX_SPIN_US} (got {})",
            self.spin_us
        );
        if self.transport != TransportArg::Zenoh {
            for (flag, given) in [
                ("--listen", !self.listen.is_empty()),
                ("--zenoh-config", self.zenoh_config.is_some()),
                ("--users", self.users.is_some()),
            ] {
                anyhow::ensure!(!given, "{flag} is for --transport zenoh");
            }
        }
        if let Some(rate) = self.verify {
            anyhow::ensure!(
                (0.0..=1.0).contains(&rate),
                "--verify must be a share from 0 to 1 (got {rate})"
            );
        }
        if self.workers == 0 && !self.attach {
            anyhow::ensure!(
                self.run_id.is_none(),
                "--run-id needs --workers or --attach"
            );
            anyhow::ensure!(
                self.verify.is_none(),
                "--verify needs --workers or --attach: in-process there is no worker to check"
            );
            anyhow::ensure!(
                self.coordinator_share.is_none(),
                "--coordinator-share needs --workers or --attach: in-process every thread flies"
            );
            anyhow::ensure!(
                !self.no_pin,
                "--no-pin needs --workers: in-process threads are not pinned"
            );
            anyhow::ensure!(
                self.transport == TransportArg::Iceoryx2,
                "--transport zenoh needs --workers N or --attach; without them evaluation is in-process"
            );
            return Ok(None);
        }
        anyhow::ensure!(
            !(self.attach && self.workers > 0),
            "--attach and --workers N exclude each other: attach waits for workers started elsewhere"
        );
        let run_id = telemetry.run().to_string();
        let deadline = Duration::from_secs_f64(self.deadline);
        let mut opts = pool_options(run_id, self.workers, deadline, !self.no_pin, stop)?;
        opts.spin = Duration::from_micros(self.spin_us);
        let share = self.coordinator_share.unwrap_or(CoordinatorShare::Auto);
        opts.share = share.applies(self.workers);
        opts.stand_in = share.stands_in();
        opts.verify = match (self.verify, self.transport) {
            (Some(rate), _) => rate,
            (None, TransportArg::Zenoh) => DEFAULT_VERIFY_ZENOH,
            (None, TransportArg::Iceoryx2) => 0.0,
        };
        if let Some(n) = self.min_workers {
            anyhow::ensure!(
                (1..=MAX_WORKERS).contains(&n),
                "--min-workers must be 1 to {MAX_WORKERS} (got {n})"
            );
            opts.min_workers = n;
        }
        if self.attach {
            tracing::info!("run id {}", opts.run_id);
        }
        let telemetry = telemetry.clone();
        Ok(Some(match self.transport {
            TransportArg::Iceoryx2 => Box::new(IpcPool::start(opts, telemetry)?),
            TransportArg::Zenoh => self.zenoh_pool(opts, telemetry)?,
        }))
    }

    fn zenoh_pool(
        &self,
        opts: PoolOptions,
        telemetry: Telemetry,
    ) -> anyhow::Result<Box<dyn Backend>> {
        let options = NetOptions {
            listen: if self.listen.is_empty() {
                vec![DEFAULT_LISTEN.into()]
            } else {
                self.listen.clone()
            },
            config_file: self.zenoh_config.clone(),
            users: self.users.clone(),
            ..NetOptions::default()
        };
        let config = coordinator_config(&options)?;
        refuse_any_port(&config, self.workers > 0)?;
        let then_can = "join this run and send it results";
        let remedy = "pass --users or a mutual-TLS --zenoh-config";
        if let Some(warning) = strangers_warning(&config, then_can, remedy) {
            tracing::warn!("{warning}");
        }
        let transport = Zenoh::open(&opts.run_id, config)?;
        if transport.io_on_one_thread {
            tracing::info!("{}", lander_protocol::net::TLS_NOTE);
        }
        Ok(Box::new(Pool::with_transport(transport, opts, telemetry)?))
    }
}

/// Refuses a zenoh coordinator's listen endpoint on any free port where
/// its workers must reach it there: those it `spawns`, told to connect to
/// it, and attached ones unless it connects to a router they share.
pub fn refuse_any_port(config: &zenoh::Config, spawns: bool) -> anyhow::Result<()> {
    let direct = spawns || connecting(config).is_empty();
    if let Some(e) = listening(config)
        .into_iter()
        .find(|e| direct && any_port(e))
    {
        anyhow::bail!(
            "zenoh listen endpoint {e} (--listen or --zenoh-config): port 0 leaves the workers no port to connect to; name one"
        );
    }
    Ok(())
}

/// A pool that spawns `workers` copies of the `lander-worker` beside this
/// executable (0: workers attach themselves), pinned to a CPU each if
/// `pin`, that ends the run when `stop` is asked.
pub fn pool_options(
    run_id: String,
    workers: usize,
    deadline: Duration,
    pin: bool,
    stop: &Stop,
) -> anyhow::Result<PoolOptions> {
    let worker_exe = std::env::current_exe()
        .context("finding this executable")?
        .with_file_name("lander-worker");
    Ok(PoolOptions {
        run_id,
        spawn: workers,
        worker_exe,
        // A generation handed out whole as it starts.
        chunks_per_worker: DEPTH,
        deadline,
        max_respawns: 3 * workers.max(1),
        pin,
        min_workers: 0,
        spin: DEFAULT_SPIN,
        verify: 0.0,
        share: CoordinatorShare::Auto.applies(workers),
        stand_in: CoordinatorShare::Auto.stands_in(),
        stop: stop.clone(),
    })
}
