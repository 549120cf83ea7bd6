//! `lander replay`: draws one flight as an SVG or an animated HTML page,
//! from a genome given on the command line or the best lander of a run or
//! an experiment folder, flown in the world that folder records.

use super::flight::{check_start, load, StartNames};
use anyhow::{bail, Context};
use clap::{ArgGroup, Args};
use lander_coordinator::config::RunConfig;
use lander_coordinator::experiment::outputs::ordered;
use lander_coordinator::experiment::{Experiment, Store};
use lander_coordinator::recording::{best_landing, trace};
use lander_coordinator::run_files::{BEST, EXPERIMENT};
use lander_model::{parse_genome, Env, Method};
use lander_report::model::Recording;
use lander_report::replay::{flight_html, flight_svg};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// Two modes, one of which must be chosen; the usage spells out both, since
/// clap's own would show only one.
#[derive(Args, Debug)]
#[command(
    group(ArgGroup::new("flight").required(true).args(["genome", "run"])),
    override_usage = "lander replay --run <DIR> [--out <FILE>]\n       \
                      lander replay --genome <GENOME> --x0 <X0> --pad-x <PAD_X> \
                      [--config <FILE>] [--out <FILE>]"
)]
pub struct ReplayArgs {
    /// The genome, as `action:duration` pairs: `"1:12,2:30,3:4"`; needs
    /// --x0 and --pad-x.
    #[arg(long, requires_all = ["x0", "pad_x"], conflicts_with = "run")]
    genome: Option<String>,
    /// Start column for --genome, in [0, W).
    #[arg(
        long,
        requires = "genome",
        conflicts_with = "run",
        allow_negative_numbers = true
    )]
    x0: Option<f64>,
    /// Pad centre for --genome, in [pad_margin, W − pad_margin): [50, 350)
    /// by default.
    #[arg(
        long,
        requires = "genome",
        conflicts_with = "run",
        allow_negative_numbers = true
    )]
    pad_x: Option<f64>,
    /// A run folder (`lander run --out`) or an experiment folder
    /// (`lander experiment --out`): replays its best lander in the world
    /// its run recorded.
    #[arg(long, value_name = "DIR")]
    run: Option<PathBuf>,
    /// A TOML run configuration for the world's constants, for --genome.
    /// Refused with --run: a folder records its own (only a best.json
    /// from before runs recorded it takes one).
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
    method: Method,
    trial: u64,
    x0: f64,
    pad_x: f64,
    genome: String,
    /// The configuration the run used; absent from a best.json written
    /// before runs recorded it.
    #[serde(default)]
    config: Option<RunConfig>,
}

pub fn replay(args: ReplayArgs) -> anyhow::Result<()> {
    let draw: fn(&Recording) -> String = match args.out.extension().and_then(|e| e.to_str()) {
        Some("svg") => flight_svg,
        Some("html") => flight_html,
        _ => bail!(
            "--out must end in .svg or .html (got {})",
            args.out.display()
        ),
    };
    let recording = match &args.run {
        Some(dir) => from_folder(dir, &args)?,
        None => from_genome(&args)?,
    };
    std::fs::write(&args.out, draw(&recording))
        .with_context(|| format!("writing {}", args.out.display()))?;
    outln!("{}; wrote {}", recording.title, args.out.display())?;
    Ok(())
}

fn from_genome(args: &ReplayArgs) -> anyhow::Result<Recording> {
    let (Some(genome), Some(x0), Some(pad_x)) = (&args.genome, args.x0, args.pad_x) else {
        bail!("give --run DIR, or --genome with --x0 and --pad-x");
    };
    let cfg = load(args.config.as_deref())?;
    let env = Env {
        world: cfg.world,
        scoring: cfg.scoring,
        x0,
        pad_x,
    };
    check_start(&env, &StartNames::FLAGS)?;
    let genes = parse_genome(genome, cfg.ga.max_duration).context("--genome")?;
    let (mut recording, outcome) = trace(&env, &genes, String::new());
    recording.title = format!("x0 {x0}, pad {pad_x}: {}", ending(outcome.safe));
    Ok(recording)
}

fn ending(safe: bool) -> &'static str {
    if safe {
        "landed safely"
    } else {
        "crashed"
    }
}

fn from_folder(dir: &Path, args: &ReplayArgs) -> anyhow::Result<Recording> {
    let best = dir.join(BEST);
    if best.exists() {
        return from_best(&best, args.config.as_deref());
    }
    let definition = dir.join(EXPERIMENT);
    if definition.exists() {
        if args.config.is_some() {
            bail!(
                "{} records the experiment's configuration; replay {} without --config",
                definition.display(),
                dir.display()
            );
        }
        let text = std::fs::read_to_string(&definition)
            .with_context(|| format!("reading {}", definition.display()))?;
        let exp: Experiment = serde_json::from_str(&text)
            .with_context(|| format!("{} is not an experiment", definition.display()))?;
        // Checked as the experiment checked it: its world bounds the
        // flight replayed.
        exp.validate()
            .with_context(|| format!("{}", definition.display()))?;
        let records = Store::read_only(dir, &exp).finished()?;
        return best_landing(&exp, &ordered(&exp, records))
            .with_context(|| format!("{} has no GA trial to replay", dir.display()));
    }
    if dir.join("episodes.jsonl").exists() {
        bail!(
            "{} holds a Q(λ) run (episodes.jsonl), which has no genome to replay",
            dir.display()
        );
    }
    if dir.join("trials").is_dir() {
        bail!(
            "{} holds trial records (trials/) but no experiment.json, which says how \
             they were flown; it is not a whole experiment's folder",
            dir.display()
        );
    }
    if dir.join("generations.jsonl").exists() {
        bail!(
            "{} holds a run that did not finish (generations.jsonl, but no best.json)",
            dir.display()
        );
    }
    bail!(
        "{} holds neither a run (best.json) nor an experiment (experiment.json)",
        dir.display()
    )
}

/// A run's best lander, flown in the world the run recorded.
fn from_best(path: &Path, config: Option<&Path>) -> anyhow::Result<Recording> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let b: BestJson = serde_json::from_str(&text)
        .with_context(|| format!("{} is not a run's best.json", path.display()))?;
    let cfg = recorded_config(path, b.config, config)?;
    let genes = parse_genome(&b.genome, cfg.ga.max_duration)
        .with_context(|| format!("{}: genome", path.display()))?;
    let env = Env {
        world: cfg.world,
        scoring: cfg.scoring,
        x0: b.x0,
        pad_x: b.pad_x,
    };
    let names = StartNames {
        x0: &format!("{}: x0", path.display()),
        pad_x: &format!("{}: pad_x", path.display()),
    };
    check_start(&env, &names)?;
    let (mut recording, outcome) = trace(&env, &genes, String::new());
    recording.title = format!(
        "{}, trial {}: {}",
        b.method.label(),
        b.trial,
        ending(outcome.safe)
    );
    Ok(recording)
}

/// The configuration to replay a best.json in: the one it records, checked
/// as a run checks its own. A --config beside it is refused rather than
/// preferred or ignored, since either would fly a different world than the
/// run did without saying so. Only a best.json from before runs recorded
/// their configuration needs --config, for a run made with one.
fn recorded_config(
    path: &Path,
    recorded: Option<RunConfig>,
    given: Option<&Path>,
) -> anyhow::Result<RunConfig> {
    match (recorded, given) {
        (Some(cfg), None) => {
            cfg.validate()
                .with_context(|| format!("{}: config", path.display()))?;
            Ok(cfg)
        }
        (Some(_), Some(_)) => bail!(
            "{} records the configuration its run used; replay it without --config",
            path.display()
        ),
        (None, Some(file)) => Ok(RunConfig::load(file)?),
        (None, None) => {
            tracing::warn!(
                "{} records no configuration (an older run); replaying in the default \
                 world, so give --config FILE if the run used one",
                path.display()
            );
            Ok(RunConfig::default())
        }
    }
}
