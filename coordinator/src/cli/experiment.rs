//! `lander experiment FILE.toml`: the paper's experiment or any other, on
//! all cores or on workers, with a progress bar per running GA trial and
//! one for the Q(λ) trials, written trial by trial so that `--resume` can
//! finish an interrupted run.

use super::transport::TransportArgs;
use super::watch::{trial_label, Watched};
use anyhow::Context;
use clap::Args;
use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use lander_coordinator::config::RunConfig;
use lander_coordinator::evaluator::{Backend, Busy};
use lander_coordinator::experiment::outputs::{ordered, write_outputs};
use lander_coordinator::experiment::{
    can_run, experiment_tasks, keep, run, trials, Experiment, ExperimentError, Progress, Store,
    TrialId,
};
use lander_coordinator::stop::Stop;
use lander_coordinator::trial::Generation;
use lander_model::Method;
use lander_report::model::TrialRecord;
use std::collections::{HashMap, HashSet};
use std::path::PathBuf;
use std::time::{Duration, Instant};

#[derive(Args, Debug)]
pub struct ExperimentArgs {
    /// The experiment file, such as experiments/paper.toml.
    file: PathBuf,
    /// Trials per method, overriding the file's count for a quick look.
    #[arg(long)]
    trials: Option<u64>,
    /// Output folder [default: results/<name>].
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Finish an interrupted experiment in --out, skipping the trials it
    /// already finished.
    #[arg(long)]
    resume: bool,
    /// In-process evaluation threads; 0 means one per core.
    #[arg(long, default_value_t = 0, value_parser = super::threads_parser())]
    threads: usize,
    /// GA trials stepped together, a generation of each per round, fewer
    /// where their generations would hold over 4 × 10^8 genes [default:
    /// 4 per spawned worker, or per evaluation thread without --workers
    /// (so per local core with --attach)].
    #[arg(long, value_name = "N")]
    in_flight: Option<usize>,
    /// Print the summary as one JSON object on stdout.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    transport: TransportArgs,
}

pub fn experiment(args: ExperimentArgs, stop: &Stop) -> anyhow::Result<()> {
    let watch = args.transport.watch()?;
    let result = experiment_watched(&args, &watch, stop);
    watch.end(&result, stop.asked());
    result
}

fn experiment_watched(
    args: &ExperimentArgs,
    watch: &super::watch::Watch,
    stop: &Stop,
) -> anyhow::Result<()> {
    let mut exp = Experiment::load(&args.file)?;
    if let Some(trials) = args.trials {
        exp.trials = trials;
        exp.validate().context("--trials")?;
    }
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("results").join(&exp.name));
    super::out_folder(&out)?;
    // Everything is checked before the folder is written: one refused
    // leaves nothing that would refuse the corrected command.
    let mut store = Store::at(&out, &exp, args.resume)?;
    let mut records = store.finished()?;
    let done: HashSet<TrialId> = records.iter().map(TrialId::of).collect();
    let todo: Vec<TrialId> = trials(&exp)
        .into_iter()
        .filter(|t| !done.contains(t))
        .collect();
    let todo = experiment_tasks(&exp, &todo);
    args.transport.check_threads(args.threads != 0)?;
    let in_flight = in_flight(args.in_flight, 4, args.transport.workers, args.threads)?;
    let since = Instant::now();
    let mut backend = args
        .transport
        .evaluator(args.threads, &watch.telemetry, stop)?;
    can_run(&todo, backend.as_ref())?;
    store.create()?;
    watch.keep(store.take_hold());
    watch.begin(&out, "experiment")?;

    let bars = lander_telemetry::log::bars();
    let overall = bars.add(ProgressBar::new(exp.trial_count()));
    overall.set_style(style(
        "trials [{bar:30}] {pos}/{len} ({elapsed}, eta {eta})",
    ));
    overall.set_position(done.len() as u64);
    if !done.is_empty() {
        overall.println(format!(
            "resuming {}: {} trials finished, {} to go",
            out.display(),
            done.len(),
            todo.len()
        ));
    }
    let mut progress = Watched {
        inner: Bars {
            bars,
            overall: &overall,
            running: HashMap::new(),
            training: Training::new("{prefix:>18}"),
            store: &store,
            records: &mut records,
        },
        telemetry: &watch.telemetry,
        label: &|_, cfg: &RunConfig| trial_label(None, cfg),
        labels: HashMap::new(),
    };
    run(&todo, backend.as_mut(), in_flight, &mut progress).with_context(|| {
        let again = super::resume_command("experiment", &args.file, &out, args.trials, false);
        format!("the experiment stopped; `{again}` finishes it")
    })?;
    say_busy(backend.as_ref(), args.transport.workers, since);
    backend.run_over();
    drop(backend);
    overall.finish_and_clear();

    let records = ordered(&exp, records);
    let summary = write_outputs(&out, &exp, &records)?;
    if args.json {
        outln!("{}", serde_json::to_string(&summary)?)?;
    } else {
        outln!("{}", summary.markdown())?;
        outln!("wrote {}", out.join("report.html").display())?;
    }
    Ok(())
}

/// How many GA trials to step together: `asked`, or `per` per spawned
/// worker or per evaluation thread.
pub(super) fn in_flight(
    asked: Option<usize>,
    per: usize,
    workers: usize,
    threads: usize,
) -> anyhow::Result<usize> {
    anyhow::ensure!(
        asked != Some(0),
        "--in-flight must be at least 1: it is how many GA trials run at once"
    );
    let width = match (workers, threads) {
        (0, 0) => std::thread::available_parallelism().map_or(1, |n| n.get()),
        (0, threads) => threads,
        (workers, _) => workers,
    };
    // Saturating: --threads and --workers are checked for range later,
    // as the backend starts.
    Ok(asked.unwrap_or(per.saturating_mul(width)))
}

/// Says how busy the spawned workers were since `since`: their time on
/// jobs over their number times the wall time; and, where the coordinator
/// flew chunks itself (in place of the worker on its CPU, or on a CPU the
/// workers leave idle), for how long.
pub(super) fn say_busy(backend: &dyn Backend, workers: usize, since: Instant) {
    let (Some(busy), true) = (backend.worker_busy(), workers > 0) else {
        return;
    };
    let wall = since.elapsed().as_secs_f64();
    tracing::info!("{}", busy_line(busy, workers, wall));
}

fn busy_line(busy: Busy, workers: usize, wall: f64) -> String {
    let share = 100.0 * busy.workers.as_secs_f64() / (workers as f64 * wall);
    let line = format!("{workers} workers were busy {share:.1}% of {wall:.1} s");
    if busy.here.is_zero() {
        return line;
    }
    format!(
        "{line}, and the coordinator flew chunks itself for {:.1} s of it",
        busy.here.as_secs_f64()
    )
}

pub(super) fn style(template: &str) -> ProgressStyle {
    ProgressStyle::with_template(template)
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> ")
}

/// The Q(λ) trials' one bar, labelled `qlearning` by `head`, the template
/// of the trial bars' label beside it, so that the two line up.
/// They train as one batch, a trial per evaluation thread or worker at a
/// time: a bar per trial would show every one of them training while
/// most wait, and a sweep's hundreds would overrun the terminal. The
/// spinner turns on its own, since a trial says nothing until it ends.
pub(super) struct Training {
    head: &'static str,
    bar: Option<ProgressBar>,
}

impl Training {
    pub(super) fn new(head: &'static str) -> Training {
        Training { head, bar: None }
    }

    /// One more trial to train, shown under `bars`.
    pub(super) fn started(&mut self, bars: &MultiProgress) {
        let head = self.head;
        let bar = self.bar.get_or_insert_with(|| {
            let bar = bars.add(ProgressBar::new(0));
            bar.set_style(style(&format!(
                "{head} {{spinner}} [{{bar:20}}] {{pos}}/{{len}} trials trained"
            )));
            bar.set_prefix("qlearning");
            bar.enable_steady_tick(Duration::from_millis(120));
            bar
        });
        bar.inc_length(1);
    }

    /// One trial trained; the bar goes once every trial it counts has.
    pub(super) fn finished(&mut self, bars: &MultiProgress) {
        let Some(bar) = &self.bar else {
            return;
        };
        bar.inc(1);
        if Some(bar.position()) >= bar.length() {
            bar.finish_and_clear();
            bars.remove(bar);
            self.bar = None;
        }
    }
}

/// One bar for the experiment, one per running GA trial and one for the
/// Q(λ) trials; finished trials go to the store at once.
struct Bars<'a> {
    bars: &'a MultiProgress,
    overall: &'a ProgressBar,
    running: HashMap<TrialId, ProgressBar>,
    training: Training,
    store: &'a Store,
    records: &'a mut Vec<TrialRecord>,
}

impl Progress<TrialId> for Bars<'_> {
    fn started(&mut self, task: TrialId, cfg: &RunConfig) {
        if task.method == Method::Qlearning {
            self.training.started(self.bars);
            return;
        }
        let bar = self.bars.add(ProgressBar::new(cfg.ga.max_generations));
        bar.set_style(style("{prefix:>18} [{bar:20}] gen {pos}/{len} {msg}"));
        bar.set_prefix(format!("{} trial {}", task.method.name(), task.trial));
        self.running.insert(task, bar);
    }

    fn generation(&mut self, task: TrialId, g: &Generation) {
        if let Some(bar) = self.running.get(&task) {
            bar.set_position(g.generation);
            bar.set_message(format!("restart {} best {:.1}", g.restart, g.best));
        }
    }

    fn finished(&mut self, _: TrialId, record: TrialRecord) -> Result<(), ExperimentError> {
        self.store
            .save(&record)
            .map_err(|e| ExperimentError::Store(e.to_string()))?;
        let (id, method) = (TrialId::of(&record), record.method);
        // A trial heard again only replaces its record.
        if !keep(self.records, record) {
            return Ok(());
        }
        if method == Method::Qlearning {
            self.training.finished(self.bars);
        } else if let Some(bar) = self.running.remove(&id) {
            bar.finish_and_clear();
            self.bars.remove(&bar);
        }
        self.overall.inc(1);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::busy_line;
    use lander_coordinator::evaluator::Busy;
    use std::time::Duration;

    #[test]
    fn the_coordinators_own_flying_is_said_beside_the_workers() {
        let busy = Busy {
            workers: Duration::from_millis(1500),
            here: Duration::ZERO,
        };
        // 1.5 s of 2 workers × 2 s.
        assert_eq!(
            busy_line(busy, 2, 2.0),
            "2 workers were busy 37.5% of 2.0 s"
        );
        let busy = Busy {
            here: Duration::from_millis(600),
            ..busy
        };
        assert_eq!(
            busy_line(busy, 2, 2.0),
            "2 workers were busy 37.5% of 2.0 s, and the coordinator flew chunks itself for 0.6 s of it"
        );
    }
}
