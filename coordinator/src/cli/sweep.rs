//! `lander sweep FILE.toml`: one experiment under many settings, all trials
//! as one workload on all cores or on workers, with a bar for the sweep,
//! one per setting under way, one per running GA trial and one for the
//! Q(λ) trials; written trial by trial so that `--resume` can finish an
//! interrupted sweep.

use super::experiment::{in_flight, say_busy, style, Training};
use super::transport::TransportArgs;
use super::watch::{trial_label, Watched};
use anyhow::Context;
use clap::Args;
use indicatif::{MultiProgress, ProgressBar};
use lander_coordinator::config::RunConfig;
use lander_coordinator::experiment::{keep, ExperimentError, Progress};
use lander_coordinator::stop::Stop;
use lander_coordinator::sweep::outputs::write_sweep_outputs;
use lander_coordinator::sweep::{Plan, Sweep, SweepStore, SweepTrial};
use lander_coordinator::trial::Generation;
use lander_model::Method;
use lander_report::model::TrialRecord;
use std::collections::HashMap;
use std::path::PathBuf;
use std::time::Instant;

/// A sweep has trials to spare: more of them in flight means fewer rounds,
/// each with more chunks to share out. On 2 workers, 64 in flight took
/// 0.75–0.93 of the time of 8 (docs/performance.md); in-process it changes
/// nothing.
const IN_FLIGHT_PER_WORKER: usize = 32;

#[derive(Args, Debug)]
pub struct SweepArgs {
    /// The sweep file, such as experiments/fidelity.toml.
    file: PathBuf,
    /// Trials per method in every setting, overriding the file's count.
    #[arg(long)]
    trials: Option<u64>,
    /// Output folder [default: results/<name>].
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Finish an interrupted sweep in --out, skipping every trial it
    /// already finished.
    #[arg(long)]
    resume: bool,
    /// Run a sweep of more than 10,000 settings.
    #[arg(long)]
    allow_large: bool,
    /// In-process evaluation threads; 0 means one per core.
    #[arg(long, default_value_t = 0, value_parser = super::threads_parser())]
    threads: usize,
    /// GA trials stepped together, a generation of each per round, fewer
    /// where their generations would hold over 4 × 10^8 genes [default:
    /// 32 per spawned worker, or per evaluation thread without --workers
    /// (so per local core with --attach)].
    #[arg(long, value_name = "N")]
    in_flight: Option<usize>,
    /// Print the sweep's table as one JSON object on stdout.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    transport: TransportArgs,
}

pub fn sweep(args: SweepArgs, stop: &Stop) -> anyhow::Result<()> {
    let watch = args.transport.watch()?;
    let result = sweep_watched(&args, &watch, stop);
    watch.end(&result, stop.asked());
    result
}

fn sweep_watched(args: &SweepArgs, watch: &super::watch::Watch, stop: &Stop) -> anyhow::Result<()> {
    let mut sweep = Sweep::load(&args.file, args.allow_large)?;
    if let Some(trials) = args.trials {
        sweep = sweep
            .with_trials(trials)
            .map_err(anyhow::Error::msg)
            .with_context(|| args.file.display().to_string())?;
    }
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("results").join(&sweep.base.name));
    super::out_folder(&out)?;
    // Everything is checked before the folder is written: one refused
    // leaves nothing that would refuse the corrected command.
    let mut store = SweepStore::at(&out, &sweep, args.resume)?;
    let mut records = store
        .settings
        .iter()
        .map(|s| s.finished())
        .collect::<Result<Vec<_>, _>>()?;
    let plan = Plan::new(&sweep, &records);
    let total: usize = sweep
        .settings
        .iter()
        .map(|s| s.experiment.trial_count() as usize)
        .sum();
    let done = total - plan.trials();
    args.transport.check_threads(args.threads != 0)?;
    let in_flight = in_flight(
        args.in_flight,
        IN_FLIGHT_PER_WORKER,
        args.transport.workers,
        args.threads,
    )?;
    let since = Instant::now();
    let mut backend = args
        .transport
        .evaluator(args.threads, &watch.telemetry, stop)?;
    lander_coordinator::experiment::can_run(&plan.tasks, backend.as_ref())?;
    store.create()?;
    watch.keep(store.take_hold());
    watch.begin(&out, "sweep")?;

    let bars = lander_telemetry::log::bars();
    let overall = bars.add(ProgressBar::new(total as u64));
    overall.set_style(style(&format!(
        "sweep of {} settings [{{bar:30}}] {{pos}}/{{len}} trials ({{elapsed}}, eta {{eta}})",
        sweep.settings.len()
    )));
    overall.set_position(done as u64);
    if done > 0 {
        overall.println(format!(
            "resuming {}: {done} trials finished, {} to go ({} to run)",
            out.display(),
            plan.trials(),
            plan.tasks.len()
        ));
    }
    // A trial that settings share is counted under its first setting.
    let label = |task: usize, cfg: &RunConfig| {
        let setting = plan.groups[task][0].setting;
        trial_label(Some(&sweep.settings[setting].name), cfg)
    };
    let mut progress = Watched {
        inner: Bars {
            sweep: &sweep,
            plan: &plan,
            bars,
            overall: &overall,
            settings: HashMap::new(),
            running: HashMap::new(),
            training: Training::new("    {prefix}"),
            store: &store,
            records: &mut records,
        },
        telemetry: &watch.telemetry,
        label: &label,
        labels: HashMap::new(),
    };
    lander_coordinator::experiment::run(&plan.tasks, backend.as_mut(), in_flight, &mut progress)
        .with_context(|| {
            let again =
                super::resume_command("sweep", &args.file, &out, args.trials, args.allow_large);
            format!("the sweep stopped; `{again}` finishes it")
        })?;
    say_busy(backend.as_ref(), args.transport.workers, since);
    backend.run_over();
    drop(backend);
    overall.finish_and_clear();

    let summary = write_sweep_outputs(&store, &sweep, records)?;
    if args.json {
        outln!("{}", serde_json::to_string(&summary)?)?;
    } else {
        outln!("{}", summary.markdown())?;
        outln!("wrote {}", out.join("report.html").display())?;
    }
    Ok(())
}

/// The sweep's bar, one per setting under way (its trials finished), one
/// per running GA trial and one for the Q(λ) trials; finished trials go to
/// their settings' stores at once.
struct Bars<'a> {
    sweep: &'a Sweep,
    plan: &'a Plan,
    bars: &'a MultiProgress,
    overall: &'a ProgressBar,
    settings: HashMap<usize, ProgressBar>,
    running: HashMap<usize, ProgressBar>,
    training: Training,
    store: &'a SweepStore,
    records: &'a mut Vec<Vec<TrialRecord>>,
}

impl Bars<'_> {
    /// Adds the bar of a setting when its first trial starts, under the
    /// sweep's bar and the bars of the settings already under way.
    fn show_setting(&mut self, setting: usize) {
        if self.settings.contains_key(&setting) {
            return;
        }
        let s = &self.sweep.settings[setting];
        let len = s.experiment.trial_count();
        let bar = self
            .bars
            .insert(1 + self.settings.len(), ProgressBar::new(len));
        bar.set_style(style("  {prefix} [{bar:20}] {pos}/{len} trials"));
        bar.set_prefix(s.name.clone());
        bar.set_position(self.records[setting].len() as u64);
        self.settings.insert(setting, bar);
    }
}

impl Progress<usize> for Bars<'_> {
    fn started(&mut self, task: usize, cfg: &RunConfig) {
        let plan = self.plan;
        let group = &plan.groups[task];
        for m in group {
            self.show_setting(m.setting);
        }
        let first = group[0];
        let name = &self.sweep.settings[first.setting].name;
        let more = match group.len() {
            1 => String::new(),
            n => format!(" (+{} settings)", n - 1),
        };
        if cfg.method == Method::Qlearning {
            self.training.started(self.bars);
            return;
        }
        let bar = self.bars.add(ProgressBar::new(cfg.ga.max_generations));
        bar.set_style(style("    {prefix} [{bar:20}] gen {pos}/{len} {msg}"));
        bar.set_prefix(format!(
            "{name}{more}: {} trial {}",
            first.trial.method.name(),
            first.trial.trial
        ));
        self.running.insert(task, bar);
    }

    fn generation(&mut self, task: usize, g: &Generation) {
        if let Some(bar) = self.running.get(&task) {
            bar.set_position(g.generation);
            bar.set_message(format!("restart {} best {:.1}", g.restart, g.best));
        }
    }

    fn finished(&mut self, task: usize, record: TrialRecord) -> Result<(), ExperimentError> {
        // A trial heard again only replaces its records.
        let mut added = false;
        for &SweepTrial { setting, .. } in &self.plan.groups[task] {
            self.store.settings[setting]
                .save(&record)
                .map_err(|e| ExperimentError::Store(e.to_string()))?;
            if !keep(&mut self.records[setting], record.clone()) {
                continue;
            }
            added = true;
            self.overall.inc(1);
            let whole = self.sweep.settings[setting].experiment.trial_count() as usize;
            let finished = self.records[setting].len();
            if let Some(bar) = self.settings.get(&setting) {
                bar.set_position(finished as u64);
                if finished == whole {
                    bar.finish_and_clear();
                    self.bars.remove(bar);
                    self.settings.remove(&setting);
                }
            }
        }
        if !added {
            return Ok(());
        }
        if record.method == Method::Qlearning {
            self.training.finished(self.bars);
        } else if let Some(bar) = self.running.remove(&task) {
            bar.finish_and_clear();
            self.bars.remove(&bar);
        }
        Ok(())
    }
}
