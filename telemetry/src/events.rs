//! What happened to a run and its workers: [`Event`]s, told through one
//! [`Telemetry`] handle, which logs each, appends it to the run folder's
//! `events.jsonl` and counts it in the metrics.
//!
//! Each line of `events.jsonl` is one JSON object:
//! `{"time": RFC 3339, "run": run id, "event": kind, …}`, where a worker's
//! events carry `worker` (its id in hex), `host` and `pid`. A resumed run
//! appends to the file, so it tells the whole story.

use crate::metrics::CoordinatorMetrics;
use serde::{Serialize, Serializer};
use std::fmt;
use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::SystemTime;

/// The file, in a run's folder.
pub const EVENTS_FILE: &str = "events.jsonl";

/// A worker, as events name it.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct WorkerRef {
    #[serde(rename = "worker", serialize_with = "hex")]
    pub id: u64,
    pub host: String,
    pub pid: u32,
}

fn hex<S: Serializer>(id: &u64, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&format!("{id:016x}"))
}

/// Why a worker died.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Death {
    /// Its process exited (a worker this run spawned).
    Exited,
    /// Its connection broke.
    Disconnected,
}

/// Why chunks were sent again.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Cause {
    Exited,
    Disconnected,
    Left,
    Deadline,
    Refused,
}

impl Cause {
    pub fn name(self) -> &'static str {
        match self {
            Cause::Exited => "exited",
            Cause::Disconnected => "disconnected",
            Cause::Left => "left",
            Cause::Deadline => "deadline",
            Cause::Refused => "refused",
        }
    }
}

/// One thing that happened.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum Event {
    RunStarted {
        command: String,
    },
    RunFinished,
    /// By SIGINT or SIGTERM; the run can be resumed.
    RunInterrupted,
    /// Stopped by an error, as the command reports it on stderr.
    RunFailed {
        error: String,
    },
    WorkerJoined {
        #[serde(flatten)]
        worker: WorkerRef,
    },
    WorkerLeft {
        #[serde(flatten)]
        worker: WorkerRef,
    },
    WorkerDied {
        #[serde(flatten)]
        worker: WorkerRef,
        why: Death,
    },
    /// It held a chunk past the deadline; it is dropped (and, if this run
    /// spawned it, killed).
    WorkerTimedOut {
        #[serde(flatten)]
        worker: WorkerRef,
    },
    /// Refused for good: a malformed or wrong answer, or another protocol
    /// version.
    WorkerRefused {
        #[serde(flatten)]
        worker: WorkerRef,
        why: String,
    },
    /// A spawned worker that died was replaced by process `pid`.
    WorkerRespawned {
        pid: u32,
    },
    /// The chunks a lost worker held go back to be flown again.
    ChunksRedispatched {
        #[serde(flatten)]
        worker: WorkerRef,
        chunks: usize,
        why: Cause,
    },
}

impl fmt::Display for Event {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Event::RunStarted { command } => write!(f, "{command} started"),
            Event::RunFinished => write!(f, "run finished"),
            Event::RunInterrupted => write!(f, "run interrupted"),
            Event::RunFailed { error } => write!(f, "run failed: {error}"),
            Event::WorkerJoined { worker: w } => {
                write!(
                    f,
                    "worker {:016x} joined (pid {} on {})",
                    w.id, w.pid, w.host
                )
            }
            Event::WorkerLeft { worker: w } => write!(f, "worker {:016x} left", w.id),
            Event::WorkerDied { worker: w, why } => {
                let how = match why {
                    Death::Exited => "exited",
                    Death::Disconnected => "disconnected",
                };
                write!(f, "worker {:016x} (pid {}) {how}", w.id, w.pid)
            }
            Event::WorkerTimedOut { worker: w } => {
                write!(
                    f,
                    "worker {:016x} (pid {}) missed its deadline",
                    w.id, w.pid
                )
            }
            Event::WorkerRefused { worker: w, why } => write!(
                f,
                "refusing worker {:016x} (pid {} on {}) for good: {why}",
                w.id, w.pid, w.host
            ),
            Event::WorkerRespawned { pid } => {
                write!(
                    f,
                    "started worker process {pid} in place of one that is gone"
                )
            }
            Event::ChunksRedispatched {
                worker: w,
                chunks,
                why,
            } => write!(
                f,
                "{chunks} chunk(s) of worker {:016x} go back to be flown again ({})",
                w.id,
                why.name()
            ),
        }
    }
}

/// Where a run's events go: the log, `events.jsonl` once the run has a
/// folder, and the metrics when they are on. Cloned freely; every clone
/// tells the same run.
#[derive(Clone, Default)]
pub struct Telemetry {
    inner: Arc<Inner>,
}

#[derive(Default)]
struct Inner {
    run: String,
    metrics: Option<Arc<CoordinatorMetrics>>,
    file: Mutex<Option<(PathBuf, File)>>,
    /// Events are not logged (a stress test's kills are on purpose).
    unlogged: bool,
}

/// One line of `events.jsonl`.
#[derive(Serialize)]
struct Line<'a> {
    time: String,
    run: &'a str,
    #[serde(flatten)]
    event: &'a Event,
}

impl Telemetry {
    /// The telemetry of run `run`, counting into `metrics` if given.
    pub fn new(run: impl Into<String>, metrics: Option<Arc<CoordinatorMetrics>>) -> Telemetry {
        Telemetry {
            inner: Arc::new(Inner {
                run: run.into(),
                metrics,
                file: Mutex::new(None),
                unlogged: false,
            }),
        }
    }

    /// Telemetry that tells nothing: for `lander bench --stress`, whose
    /// workers die because it kills them.
    pub fn silent() -> Telemetry {
        Telemetry {
            inner: Arc::new(Inner {
                unlogged: true,
                ..Inner::default()
            }),
        }
    }

    pub fn run(&self) -> &str {
        &self.inner.run
    }

    /// The metrics, when `--metrics` is on.
    pub fn metrics(&self) -> Option<&CoordinatorMetrics> {
        self.inner.metrics.as_deref()
    }

    /// From now on, events are also appended to `dir/events.jsonl`.
    pub fn record_to(&self, dir: &Path) -> std::io::Result<()> {
        let path = dir.join(EVENTS_FILE);
        let file = OpenOptions::new().create(true).append(true).open(&path)?;
        *self.file() = Some((path, file));
        Ok(())
    }

    fn file(&self) -> std::sync::MutexGuard<'_, Option<(PathBuf, File)>> {
        self.inner.file.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Tells `event`: logs it, records it, counts it.
    pub fn event(&self, event: Event) {
        if !self.inner.unlogged {
            log(&event);
        }
        if let Some(m) = self.metrics() {
            count(m, &event);
        }
        let mut file = self.file();
        if let Some((path, f)) = file.as_mut() {
            let line = Line {
                time: humantime::format_rfc3339_millis(SystemTime::now()).to_string(),
                run: &self.inner.run,
                event: &event,
            };
            // An event is a few short strings and numbers: it serializes.
            let mut text = serde_json::to_vec(&line).unwrap_or_default();
            text.push(b'\n');
            // One write per line, so that a reader never sees half of one.
            if let Err(e) = f.write_all(&text) {
                tracing::warn!(
                    "cannot write {}: {e}; events are logged only",
                    path.display()
                );
                *file = None;
            }
        }
    }
}

/// Reads `dir/events.jsonl` back, one JSON object per event; a line that
/// is not JSON is an error naming the file and the line.
pub fn read(dir: &Path) -> std::io::Result<Vec<serde_json::Value>> {
    let path = dir.join(EVENTS_FILE);
    let text = std::fs::read_to_string(&path)?;
    text.lines()
        .enumerate()
        .map(|(i, line)| {
            serde_json::from_str(line).map_err(|e| {
                std::io::Error::new(
                    std::io::ErrorKind::InvalidData,
                    format!("{} line {}: {e}", path.display(), i + 1),
                )
            })
        })
        .collect()
}

fn log(event: &Event) {
    match event {
        Event::WorkerDied { .. } | Event::WorkerTimedOut { .. } | Event::WorkerRefused { .. } => {
            tracing::warn!("{event}")
        }
        Event::WorkerLeft { .. }
        | Event::WorkerRespawned { .. }
        | Event::ChunksRedispatched { .. } => tracing::info!("{event}"),
        _ => tracing::debug!("{event}"),
    }
}

fn count(m: &CoordinatorMetrics, event: &Event) {
    let lost = |cause: Cause| m.workers_lost.with_label_values(&[cause.name()]).inc();
    match event {
        Event::WorkerDied {
            why: Death::Exited, ..
        } => lost(Cause::Exited),
        Event::WorkerDied {
            why: Death::Disconnected,
            ..
        } => lost(Cause::Disconnected),
        Event::WorkerLeft { .. } => lost(Cause::Left),
        Event::WorkerTimedOut { .. } => lost(Cause::Deadline),
        Event::WorkerRefused { .. } => lost(Cause::Refused),
        Event::WorkerRespawned { .. } => m.worker_respawns.inc(),
        Event::ChunksRedispatched { chunks, why, .. } => m
            .chunks_redispatched
            .with_label_values(&[why.name()])
            .inc_by(*chunks as u64),
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn worker() -> WorkerRef {
        WorkerRef {
            id: 0xab,
            host: "moon".into(),
            pid: 42,
        }
    }

    #[test]
    fn each_event_is_one_json_line_with_time_run_and_worker() {
        let dir = tempfile::tempdir().unwrap();
        let t = Telemetry::new("r1", Some(Arc::new(CoordinatorMetrics::new())));
        t.event(Event::RunStarted {
            command: "run".into(),
        });
        t.record_to(dir.path()).unwrap();
        t.event(Event::WorkerDied {
            worker: worker(),
            why: Death::Exited,
        });
        t.event(Event::ChunksRedispatched {
            worker: worker(),
            chunks: 3,
            why: Cause::Exited,
        });
        let lines = read(dir.path()).unwrap();
        assert_eq!(lines.len(), 2, "{lines:?}");
        assert_eq!(lines[0]["event"], "worker_died");
        assert_eq!(lines[0]["run"], "r1");
        assert_eq!(lines[0]["worker"], "00000000000000ab");
        assert_eq!(lines[0]["host"], "moon");
        assert_eq!(lines[0]["pid"], 42);
        assert_eq!(lines[0]["why"], "exited");
        assert!(lines[0]["time"].as_str().unwrap().ends_with('Z'));
        assert_eq!(lines[1]["chunks"], 3);
        let m = String::from_utf8(t.metrics().unwrap().encode()).unwrap();
        assert!(
            m.contains("lander_workers_lost_total{cause=\"exited\"} 1"),
            "{m}"
        );
        assert!(
            m.contains("lander_chunks_redispatched_total{cause=\"exited\"} 3"),
            "{m}"
        );
    }

    #[test]
    fn a_failed_run_says_why() {
        let dir = tempfile::tempdir().unwrap();
        let t = Telemetry::new("r", None);
        t.record_to(dir.path()).unwrap();
        t.event(Event::RunFailed {
            error: "no workers left".into(),
        });
        let lines = read(dir.path()).unwrap();
        assert_eq!(lines[0]["event"], "run_failed");
        assert_eq!(lines[0]["error"], "no workers left");
    }

    #[test]
    fn a_resumed_run_appends() {
        let dir = tempfile::tempdir().unwrap();
        for _ in 0..2 {
            let t = Telemetry::new("r", None);
            t.record_to(dir.path()).unwrap();
            t.event(Event::RunFinished);
        }
        assert_eq!(read(dir.path()).unwrap().len(), 2);
    }
}
