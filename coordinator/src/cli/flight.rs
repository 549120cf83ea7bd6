//! `lander fly` and `lander guide`: one genome, for inspection.

use anyhow::Context;
use clap::Args;
use lander_coordinator::config::RunConfig;
use lander_protocol::stream::streams;
use lander_protocol::{format_genome, parse_genome, Env, Gene, StreamKey};
use lander_worker::{fly_traced, guide as guide_pass};
use serde::Serialize;
use std::path::PathBuf;

/// Where a single flight happens.
#[derive(Args, Debug)]
pub struct FlightArgs {
    /// The genome, as `action:duration` pairs: `"1:12,2:30,3:4"`.
    #[arg(long)]
    genome: String,
    /// Start column.
    #[arg(long)]
    x0: f64,
    /// Pad centre.
    #[arg(long)]
    pad_x: f64,
    #[arg(long)]
    width: Option<f64>,
    #[arg(long)]
    height: Option<f64>,
    /// A TOML run configuration for the world's other constants.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
}

impl FlightArgs {
    fn resolve(&self) -> anyhow::Result<(Env, RunConfig, Vec<Gene>)> {
        let mut cfg = match &self.config {
            Some(path) => RunConfig::load(path)?,
            None => RunConfig::default(),
        };
        cfg.world.width = self.width.unwrap_or(cfg.world.width);
        cfg.world.height = self.height.unwrap_or(cfg.world.height);
        cfg.validate()?;
        for (name, v) in [("--x0", self.x0), ("--pad-x", self.pad_x)] {
            anyhow::ensure!(v.is_finite(), "{name} must be a finite number (got {v})");
        }
        let genes = parse_genome(&self.genome, cfg.ga.max_duration).context("--genome")?;
        let env = Env {
            world: cfg.world,
            scoring: cfg.scoring,
            x0: self.x0,
            pad_x: self.pad_x,
        };
        Ok((env, cfg, genes))
    }
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
    println!("{}", serde_json::to_string(&landing)?);
    Ok(())
}

#[derive(Args, Debug)]
pub struct GuideArgs {
    #[command(flatten)]
    flight: FlightArgs,
    /// Probability of keeping a gene's action when R prefers another; with
    /// 0 the pass is greedy and deterministic.
    #[arg(long)]
    epsilon: f64,
    /// The random stream `(seed, trial, restart, generation, index)` of the
    /// pass, as in a run.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    #[arg(long, default_value_t = 0)]
    trial: u64,
    #[arg(long, default_value_t = 0)]
    restart: u64,
    #[arg(long, default_value_t = 0)]
    generation: u64,
    #[arg(long, default_value_t = 0)]
    index: u64,
}

pub fn guide(args: GuideArgs) -> anyhow::Result<()> {
    let (env, mut cfg, genes) = args.flight.resolve()?;
    cfg.guided.epsilon = args.epsilon;
    cfg.validate().context("--epsilon")?;
    let key = StreamKey::new(args.seed, args.trial, args.restart, args.generation);
    let mut rng = key.rng(streams::guide(args.index));
    let guided = guide_pass(&env, &cfg.guided, &genes, &mut rng);
    println!(
        "{}",
        serde_json::json!({ "genome": format_genome(&guided) })
    );
    Ok(())
}
