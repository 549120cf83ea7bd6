//! `lander fly` and `lander guide`: one genome, for inspection; and the
//! check that a start given by hand is one SPEC §1 could draw, which
//! `lander replay` shares.

use anyhow::{anyhow, ensure, Context};
use clap::Args;
use lander_coordinator::config::{ConfigError, RunConfig};
use lander_model::stream::streams;
use lander_model::{fly_traced, guide as guide_pass};
use lander_model::{format_genome, parse_genome, Env, Gene, StreamKey};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Where a single flight happens.
#[derive(Args, Debug)]
pub struct FlightArgs {
    /// The genome, as `action:duration` pairs: `"1:12,2:30,3:4"`.
    #[arg(long)]
    genome: String,
    /// Start column, in [0, W).
    #[arg(long, allow_negative_numbers = true)]
    x0: f64,
    /// Pad centre, in [pad_margin, W − pad_margin): [50, 350) by default.
    #[arg(long, allow_negative_numbers = true)]
    pad_x: f64,
    /// World width W in pixels [default: 400, or the --config file's].
    #[arg(long, allow_negative_numbers = true)]
    width: Option<f64>,
    /// World height H in pixels; the lander starts world.start_drop (50)
    /// below it [default: 300, or the --config file's].
    #[arg(long, allow_negative_numbers = true)]
    height: Option<f64>,
    /// A TOML run configuration for the world's other constants.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
}

impl FlightArgs {
    fn resolve(&self) -> anyhow::Result<(Env, RunConfig, Vec<Gene>)> {
        let mut cfg = load(self.config.as_deref())?;
        cfg.world.width = self.width.unwrap_or(cfg.world.width);
        cfg.world.height = self.height.unwrap_or(cfg.world.height);
        cfg.validate().map_err(|e| self.flagged(e))?;
        let env = Env {
            world: cfg.world,
            scoring: cfg.scoring,
            x0: self.x0,
            pad_x: self.pad_x,
        };
        check_start(&env, &StartNames::FLAGS)?;
        let genes = parse_genome(&self.genome, cfg.ga.max_duration).context("--genome")?;
        Ok((env, cfg, genes))
    }

    /// Names the flag behind a world field it set, and shows the value as
    /// `{:?}` does (`1e308`): the check's own message spells a large
    /// number out in full, 309 digits for 1e308.
    fn flagged(&self, e: ConfigError) -> anyhow::Error {
        let flags = [
            ("world.width", "--width", self.width),
            ("world.height", "--height", self.height),
        ];
        if let ConfigError::Invalid(p) = &e {
            for (field, flag, value) in flags {
                if let (true, Some(v)) = (p.field == field, value) {
                    let problem = p.problem.split(" (got ").next().unwrap_or(&p.problem);
                    return anyhow!("{flag} {problem} (got {v:?})");
                }
            }
        }
        // Another field, such as world.pad_margin, that a flag's value
        // made wrong: say which flags were given.
        let given: Vec<String> = flags
            .iter()
            .filter_map(|(_, flag, value)| Some(format!("{flag} {:?}", (*value)?)))
            .collect();
        if given.is_empty() {
            e.into()
        } else {
            anyhow::Error::from(e).context(format!("with {}", given.join(", ")))
        }
    }
}

/// The run configuration in `path`, or the defaults.
pub(super) fn load(path: Option<&Path>) -> Result<RunConfig, ConfigError> {
    path.map_or_else(|| Ok(RunConfig::default()), RunConfig::load)
}

/// What the numbers of a start are called where they came from: flags on
/// the command line, or fields of a file.
pub(super) struct StartNames<'a> {
    pub x0: &'a str,
    pub pad_x: &'a str,
}

impl StartNames<'static> {
    pub const FLAGS: StartNames<'static> = StartNames {
        x0: "--x0",
        pad_x: "--pad-x",
    };
}

/// Refuses a start SPEC §1 would never draw: `x0` outside `[0, W)` or
/// `pad_x` outside `[pad_margin, W − pad_margin)` (a world too low to start
/// in is refused by `RunConfig::validate`). Such a flight still flies, to
/// numbers that mean nothing: a fitness of −1e308 for a pad 1e308 px away.
pub(super) fn check_start(env: &Env, names: &StartNames) -> anyhow::Result<()> {
    let w = &env.world;
    ensure!(
        (0.0..w.width).contains(&env.x0),
        "{} must be in [0, {:?}), the world's width (got {:?})",
        names.x0,
        w.width,
        env.x0
    );
    let (low, high) = (w.pad_margin, w.width - w.pad_margin);
    ensure!(
        (low..high).contains(&env.pad_x),
        "{} must be in [{low:?}, {high:?}), world.pad_margin from either edge (got {:?})",
        names.pad_x,
        env.pad_x
    );
    Ok(())
}

#[derive(Args, Debug)]
pub struct FlyArgs {
    #[command(flatten)]
    flight: FlightArgs,
    /// Write a CSV row per tick: tick, action, x, y, vx, vy, rot.
    #[arg(long, value_name = "FILE")]
    trace: Option<PathBuf>,
}

#[derive(Serialize)]
struct Landing {
    x: f64,
    y: f64,
    vx: f64,
    vy: f64,
    rot: f64,
    ticks: u32,
    n: u32,
    safe: bool,
    fitness: f64,
}

#[derive(Serialize)]
struct TraceRow {
    tick: u32,
    action: u8,
    x: f64,
    y: f64,
    vx: f64,
    vy: f64,
    rot: f64,
}

pub fn fly(args: FlyArgs) -> anyhow::Result<()> {
    let (env, _, genes) = args.flight.resolve()?;
    let mut rows = Vec::new();
    let o = fly_traced(&env, &genes, |tick, action, s| {
        if args.trace.is_some() {
            rows.push(TraceRow {
                tick,
                action: action.index(),
                x: s.x,
                y: s.y,
                vx: s.vx,
                vy: s.vy,
                rot: s.rot,
            });
        }
    });
    if let Some(path) = &args.trace {
        let context = || format!("writing trace {}", path.display());
        let mut w = csv::Writer::from_path(path).with_context(context)?;
        for row in &rows {
            w.serialize(row).with_context(context)?;
        }
        w.flush().with_context(context)?;
    }
    let s = o.state;
    let landing = Landing {
        x: s.x,
        y: s.y,
        vx: s.vx,
        vy: s.vy,
        rot: s.rot,
        ticks: o.ticks,
        n: o.n,
        safe: o.safe,
        fitness: o.fitness,
    };
    outln!("{}", serde_json::to_string(&landing)?)?;
    Ok(())
}

#[derive(Args, Debug)]
pub struct GuideArgs {
    #[command(flatten)]
    flight: FlightArgs,
    /// Probability of keeping a gene's action when R prefers another; with
    /// 0 the pass is greedy and deterministic [default: the --config file's
    /// guided.epsilon, else 0.1].
    #[arg(long)]
    epsilon: Option<f64>,
    /// The random stream `(seed, trial, restart, generation, index)` of the
    /// pass, as in a run: its seed.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// The stream's trial number.
    #[arg(long, default_value_t = 0)]
    trial: u64,
    /// The stream's restart, counted from 0.
    #[arg(long, default_value_t = 0)]
    restart: u64,
    /// The stream's generation within its restart.
    #[arg(long, default_value_t = 0)]
    generation: u64,
    /// The individual's index in its population, which picks its stream.
    #[arg(long, default_value_t = 0)]
    index: u64,
}

pub fn guide(args: GuideArgs) -> anyhow::Result<()> {
    let (env, mut cfg, genes) = args.flight.resolve()?;
    if let Some(epsilon) = args.epsilon {
        cfg.guided.epsilon = epsilon;
        cfg.validate().context("--epsilon")?;
    }
    let key = StreamKey::new(args.seed, args.trial, args.restart, args.generation);
    let mut rng = key.short_rng(streams::guide(args.index));
    let guided = guide_pass(&env, &cfg.guided, &genes, &mut rng);
    outln!(
        "{}",
        serde_json::json!({ "genome": format_genome(&guided) })
    )?;
    Ok(())
}
