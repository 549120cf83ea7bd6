//! What every evaluating command offers for watching it: `--metrics ADDR`
//! and the run's [`Telemetry`], through which its events reach the log,
//! the folder's `events.jsonl` and the metrics; and [`Watched`], which
//! counts an experiment's or a sweep's generations and trials.

use anyhow::Context;
use clap::Args;
use lander_coordinator::config::RunConfig;
use lander_coordinator::experiment::{ExperimentError, Progress};
use lander_coordinator::folder_lock::FolderLock;
use lander_coordinator::trial::Generation;
use lander_report::model::TrialRecord;
use lander_telemetry::{CoordinatorMetrics, Event, MetricsServer, Telemetry};
use std::collections::HashMap;
use std::hash::Hash;
use std::path::Path;
use std::sync::{Arc, Mutex};

#[derive(Args, Debug, Default)]
pub struct WatchArgs {
    /// Serve Prometheus metrics at http://ADDR/metrics while the command
    /// runs. ADDR is HOST:PORT, or a PORT on loopback.
    #[arg(long, value_name = "ADDR")]
    pub metrics: Option<String>,
}

/// A command's telemetry, and its metrics endpoint while it lasts.
pub struct Watch {
    pub telemetry: Telemetry,
    _server: Option<MetricsServer>,
    /// The command's folder, held until it has told how it ended.
    held: Mutex<Option<FolderLock>>,
}

impl WatchArgs {
    /// The telemetry of run `run_id`, with its endpoint listening when
    /// `--metrics` asks for one.
    pub fn start(&self, run_id: String) -> anyhow::Result<Watch> {
        let Some(addr) = &self.metrics else {
            return Ok(Watch {
                telemetry: Telemetry::new(run_id, None),
                _server: None,
                held: Mutex::default(),
            });
        };
        let metrics = Arc::new(CoordinatorMetrics::new());
        let served = metrics.clone();
        let server = MetricsServer::start(addr, move || served.encode())?;
        Ok(Watch {
            telemetry: Telemetry::new(run_id, Some(metrics)),
            _server: Some(server),
            held: Mutex::default(),
        })
    }
}

impl Watch {
    /// Starts recording events in `dir/events.jsonl` and tells that
    /// `command` started.
    pub fn begin(&self, dir: &Path, command: &str) -> anyhow::Result<()> {
        self.telemetry
            .record_to(dir)
            .with_context(|| format!("opening {}", dir.join("events.jsonl").display()))?;
        self.telemetry.event(Event::RunStarted {
            command: command.into(),
        });
        Ok(())
    }

    /// Holds the command's folder (`lock`) until [`Watch::end`] has
    /// written the last line into it.
    pub fn keep(&self, lock: Option<FolderLock>) {
        *self.held.lock().unwrap_or_else(|p| p.into_inner()) = lock;
    }

    /// Tells how the run ended: finished (its outputs written, if stdout's
    /// reader stopped reading), interrupted (and resumable), or failed,
    /// with the error as the command reports it. Then lets go of the
    /// folder.
    pub fn end<T>(&self, result: &anyhow::Result<T>, interrupted: bool) {
        self.telemetry.event(match (result, interrupted) {
            (Ok(_), _) => Event::RunFinished,
            (Err(e), _) if super::closed_pipe(e) => Event::RunFinished,
            (Err(_), true) => Event::RunInterrupted,
            (Err(e), false) => Event::RunFailed {
                error: format!("{e:#}"),
            },
        });
        self.keep(None);
    }
}

/// A trial's name in the metrics: `method/trial`, after its setting in a
/// sweep.
pub fn trial_label(setting: Option<&str>, cfg: &RunConfig) -> String {
    let trial = format!("{}/{}", cfg.method.name(), cfg.trial);
    match setting {
        Some(s) => format!("{s}/{trial}"),
        None => trial,
    }
}

/// An experiment's or sweep's [`Progress`] that also counts generations
/// and trials in the metrics, each trial under the label `label` gives it.
pub struct Watched<'a, K, P> {
    pub inner: P,
    pub telemetry: &'a Telemetry,
    pub label: &'a (dyn Fn(K, &RunConfig) -> String + Sync),
    pub labels: HashMap<K, String>,
}

impl<K: Copy + Eq + Hash, P: Progress<K>> Progress<K> for Watched<'_, K, P> {
    fn started(&mut self, key: K, cfg: &RunConfig) {
        if let Some(m) = self.telemetry.metrics() {
            let label = (self.label)(key, cfg);
            m.trial_started(&label);
            self.labels.insert(key, label);
        }
        self.inner.started(key, cfg);
    }

    fn generation(&mut self, key: K, g: &Generation) {
        if let (Some(m), Some(label)) = (self.telemetry.metrics(), self.labels.get(&key)) {
            m.generation(label, g.best, g.mean, g.evaluated);
        }
        self.inner.generation(key, g);
    }

    fn finished(&mut self, key: K, record: TrialRecord) -> Result<(), ExperimentError> {
        if let (Some(m), Some(label)) = (self.telemetry.metrics(), self.labels.remove(&key)) {
            m.trial_finished(&label);
        }
        self.inner.finished(key, record)
    }
}
