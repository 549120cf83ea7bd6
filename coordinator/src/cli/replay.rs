//! `lander replay`: draws one flight as an SVG or an animated HTML page,
//! from a genome given on the command line or the best lander of a run or
//! an experiment folder.

use anyhow::{bail, Context};
use clap::Args;
use lander_coordinator::config::RunConfig;
use lander_coordinator::experiment::outputs::ordered;
use lander_coordinator::experiment::{Experiment, Store};
use lander_coordinator::replay::{best_landing, trace};
use lander_protocol::{parse_genome, Env};
use lander_report::model::Flight;
use lander_report::plots::method_label as label;
use lander_report::replay::{flight_html, flight_svg};
use serde::Deserialize;
use std::path::{Path, PathBuf};

#[derive(Args, Debug)]
pub struct ReplayArgs {
    /// The genome, as `action:duration` pairs: `"1:12,2:30,3:4"`.
    #[arg(long, requires_all = ["x0", "pad_x"], conflicts_with = "run")]
    genome: Option<String>,
    /// Start column.
    #[arg(long)]
    x0: Option<f64>,
    /// Pad centre.
    #[arg(long)]
    pad_x: Option<f64>,
    /// A run folder (`lander run --out`) or an experiment folder
    /// (`lander experiment --out`): replays its best lander.
    #[arg(long, value_name = "DIR", required_unless_present = "genome")]
    run: Option<PathBuf>,
    /// A TOML run configuration for the world's constants (for --genome,
    /// or a run made with --config).
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Where to draw it: `.svg` for the trajectory and the lander at
    /// touchdown, `.html` for an animated replay.
    #[arg(long, value_name = "FILE", default_value = "flight.html")]
    out: PathBuf,
}

/// The fields of a run's `best.json` a replay needs.
#[derive(Deserialize)]
struct BestJson {
    method: String,
    trial: u64,
    x0: f64,
    pad_x: f64,
    genome: String,
}

pub fn replay(args: ReplayArgs) -> anyhow::Result<()> {
    let draw: fn(&Flight) -> String = match args.out.extension().and_then(|e| e.to_str()) {
        Some("svg") => flight_svg,
        Some("html") => flight_html,
        _ => bail!(
            "--out must end in .svg or .html (got {})",
            args.out.display()
        ),
    };
    let flight = match &args.run {
        Some(dir) => from_folder(dir, &args)?,
        None => from_genome(&args)?,
    };
    std::fs::write(&args.out, draw(&flight))
        .with_context(|| format!("writing {}", args.out.display()))?;
    println!("{}; wrote {}", flight.title, args.out.display());
    Ok(())
}

fn config(args: &ReplayArgs) -> anyhow::Result<RunConfig> {
    Ok(match &args.config {
        Some(path) => RunConfig::load(path)?,
        None => RunConfig::default(),
    })
}

fn from_genome(args: &ReplayArgs) -> anyhow::Result<Flight> {
    let (Some(genome), Some(x0), Some(pad_x)) = (&args.genome, args.x0, args.pad_x) else {
        bail!("give --genome with --x0 and --pad-x, or --run DIR");
    };
    for (name, v) in [("--x0", x0), ("--pad-x", pad_x)] {
        anyhow::ensure!(v.is_finite(), "{name} must be a finite number (got {v})");
    }
    let cfg = config(args)?;
    let genes = parse_genome(genome, cfg.ga.max_duration).context("--genome")?;
    let env = Env {
        world: cfg.world,
        scoring: cfg.scoring,
        x0,
        pad_x,
    };
    let (mut flight, outcome) = trace(&env, &genes, String::new());
    flight.title = format!(
        "x0 {x0}, pad {pad_x}: {}",
        if outcome.safe {
            "landed safely"
        } else {
            "crashed"
        }
    );
    Ok(flight)
}

fn from_folder(dir: &Path, args: &ReplayArgs) -> anyhow::Result<Flight> {
    let best = dir.join("best.json");
    if best.exists() {
        let text = std::fs::read_to_string(&best)
            .with_context(|| format!("reading {}", best.display()))?;
        let b: BestJson = serde_json::from_str(&text)
            .with_context(|| format!("{} is not a run's best.json", best.display()))?;
        let cfg = config(args)?;
        let genes = parse_genome(&b.genome, cfg.ga.max_duration)
            .with_context(|| format!("{}: genome", best.display()))?;
        let env = Env {
            world: cfg.world,
            scoring: cfg.scoring,
            x0: b.x0,
            pad_x: b.pad_x,
        };
        let (mut flight, outcome) = trace(&env, &genes, String::new());
        let ending = if outcome.safe {
            "landed safely"
        } else {
            "crashed"
        };
        flight.title = format!("{}, trial {}: {ending}", label(&b.method), b.trial);
        return Ok(flight);
    }
    let definition = dir.join("experiment.json");
    if definition.exists() {
        let text = std::fs::read_to_string(&definition)
            .with_context(|| format!("reading {}", definition.display()))?;
        let exp: Experiment = serde_json::from_str(&text)
            .with_context(|| format!("{} is not an experiment", definition.display()))?;
        let records = Store::read_only(dir).finished()?;
        return best_landing(&exp, &ordered(&exp, records))
            .with_context(|| format!("{} has no GA trial to replay", dir.display()));
    }
    bail!(
        "{} holds neither a run (best.json) nor an experiment (experiment.json)",
        dir.display()
    )
}
