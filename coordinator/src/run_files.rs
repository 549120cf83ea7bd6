//! What a run writes: `generations.jsonl` as it goes, then `best.json`, and
//! the one-object JSON summary printed by `lander run --json`; and the list
//! of every file a run owns in its folder, so a new run can clear them.

use crate::config::RunConfig;
use crate::trial::TrialResult;
use lander_model::{format_genome, Method, Outcome};
use serde::Serialize;
use std::fs::File;
use std::io::{Seek, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Which trial a record is about, and whether it landed: the fields every
/// record of a trial starts with.
#[derive(Debug, Serialize)]
pub struct TrialHeader {
    pub method: Method,
    pub seed: u64,
    pub trial: u64,
    pub x0: f64,
    pub pad_x: f64,
    pub landed: bool,
}

impl TrialHeader {
    pub fn new(cfg: &RunConfig, result: &TrialResult) -> TrialHeader {
        TrialHeader {
            method: cfg.method,
            seed: cfg.seed,
            trial: cfg.trial,
            x0: result.x0,
            pad_x: result.pad_x,
            landed: result.landed,
        }
    }
}

/// The summary of one trial; the field order is the documented one.
#[derive(Debug, Serialize)]
pub struct RunSummary {
    #[serde(flatten)]
    pub id: TrialHeader,
    pub generations: u64,
    pub restarts: u64,
    pub best_fitness: f64,
    pub best_genome: String,
    pub wall_s: f64,
}

impl RunSummary {
    pub fn new(cfg: &RunConfig, result: &TrialResult, wall_s: f64) -> RunSummary {
        RunSummary {
            id: TrialHeader::new(cfg, result),
            generations: result.generations,
            restarts: result.restarts,
            best_fitness: result.best.outcome.fitness,
            best_genome: format_genome(&result.best.genome),
            wall_s,
        }
    }
}

/// `best.json`: the best individual of the last attempt, its flight, and
/// the configuration the trial ran with.
#[derive(Debug, Serialize)]
pub struct BestRecord<'a> {
    #[serde(flatten)]
    pub id: TrialHeader,
    /// The generation, counted across restarts, that flew it.
    pub generation: u64,
    pub restart: u64,
    pub genome: String,
    pub outcome: &'a Outcome,
    /// The whole configuration, not just the world: `lander replay --run`
    /// must fly the genome under the same world and scoring, and parse it
    /// with the same `ga.max_duration`, without the user passing --config
    /// again. Its `threads` is left at 0: the thread count changes no
    /// result, and best.json is the same whatever it was.
    pub config: RunConfig,
}

impl<'a> BestRecord<'a> {
    pub fn new(cfg: &'a RunConfig, result: &'a TrialResult) -> BestRecord<'a> {
        BestRecord {
            id: TrialHeader::new(cfg, result),
            generation: result.best.index,
            restart: result.restarts,
            genome: format_genome(&result.best.genome),
            outcome: &result.best.outcome,
            config: RunConfig {
                threads: 0,
                ..cfg.clone()
            },
        }
    }
}

/// Every file `lander run` writes into its folder, for any method (the
/// GA's log and best lander, Q(λ)'s episodes and summary), and keys its
/// first JSON object (the whole file, or a log's first line) always has.
const RUN_OUTPUTS: [(&str, &[&str]); 5] = [
    ("generations.jsonl", &["index", "best", "mean"]),
    ("events.jsonl", &["time", "run", "event"]),
    (BEST, &["method", "seed", "trial", "genome"]),
    ("episodes.jsonl", &["episode", "return", "epsilon"]),
    ("summary.json", &["method", "seed", "trial", "x0", "pad_x"]),
];

/// Whose results a folder holds, each known by a file that only its
/// command writes: a run's checkpoint, best lander or Q(λ) episodes, an
/// experiment's `experiment.json`, a sweep's `sweep.json`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Results {
    Run,
    Experiment,
    Sweep,
}

impl Results {
    const ALL: [Results; 3] = [Results::Run, Results::Experiment, Results::Sweep];

    fn markers(self) -> &'static [&'static str] {
        match self {
            Results::Run => &[crate::checkpoint::FILE, BEST, EPISODES],
            Results::Experiment => &[EXPERIMENT],
            Results::Sweep => &[SWEEP],
        }
    }

    /// "a run", "an experiment", "a sweep".
    pub fn what(self) -> &'static str {
        match self {
            Results::Run => "a run",
            Results::Experiment => "an experiment",
            Results::Sweep => "a sweep",
        }
    }
}

/// A folder holding another command's results.
#[derive(Debug, thiserror::Error)]
#[error(
    "{} holds {}'s results ({}), which {} would overwrite; choose another --out",
    dir.display(), theirs.what(), file, mine.what()
)]
pub struct OthersResults {
    pub dir: PathBuf,
    pub theirs: Results,
    pub file: &'static str,
    pub mine: Results,
}

/// Refuses `dir` for `mine`'s outputs where it holds another command's
/// results, which they would partly overwrite (`generations.jsonl`,
/// `summary.json` and `report.html` are written by more than one
/// command), naming the file that tells whose they are.
pub fn refuse_others(dir: &Path, mine: Results) -> Result<(), OthersResults> {
    let found = Results::ALL
        .into_iter()
        .filter(|&r| r != mine)
        .flat_map(|r| r.markers().iter().map(move |&m| (r, m)))
        .find(|(_, m)| dir.join(m).exists());
    match found {
        None => Ok(()),
        Some((theirs, file)) => Err(OthersResults {
            dir: dir.to_path_buf(),
            theirs,
            file,
            mine,
        }),
    }
}

/// Why a folder cannot be readied for a run.
#[derive(Debug, thiserror::Error)]
pub enum ClearError {
    #[error(
        "{0} is not a file a lander run wrote, and a run would overwrite it; \
         give the run another --out"
    )]
    NotARunsFile(PathBuf),
    #[error(transparent)]
    Write(#[from] WriteError),
}

/// Removes the files an earlier run left in `dir` and returns their
/// names. A run rewrites only some of them, and an interrupted run none, so
/// without this a folder could pair one run's log with another run's best
/// lander, and a replay would draw the stale one. A file of a run's name
/// that no run wrote (a `summary.json` of something else in `--out .`)
/// is refused before anything is removed.
pub fn clear_run_outputs(dir: &Path) -> Result<Vec<&'static str>, ClearError> {
    let present: Vec<(&'static str, PathBuf)> = RUN_OUTPUTS
        .iter()
        .map(|&(name, keys)| (name, dir.join(name), keys))
        .filter(|(_, path, _)| path.exists())
        .map(|(name, path, keys)| {
            if written_by_a_run(&path, keys) {
                Ok((name, path))
            } else {
                Err(ClearError::NotARunsFile(path))
            }
        })
        .collect::<Result<_, _>>()?;
    for (_, path) in &present {
        std::fs::remove_file(path).map_err(at(path))?;
    }
    Ok(present.into_iter().map(|(name, _)| name).collect())
}

/// True if the file at `path` is empty, or its first JSON object (the
/// whole file, or a log's first line) has every one of `keys`.
fn written_by_a_run(path: &Path, keys: &[&str]) -> bool {
    use std::io::{BufRead, BufReader, Read};
    // Far more than any run's file holds at its start.
    const LIMIT: u64 = 1 << 20;
    let Ok(file) = File::open(path) else {
        return false;
    };
    let mut first = String::new();
    let mut reader = BufReader::new(file.take(LIMIT));
    let read = if path.extension().is_some_and(|e| e == "jsonl") {
        reader.read_line(&mut first)
    } else {
        reader.read_to_string(&mut first)
    };
    if read.is_err() {
        return false;
    }
    if first.trim().is_empty() {
        return true;
    }
    match serde_json::from_str::<serde_json::Value>(&first) {
        Ok(serde_json::Value::Object(object)) => keys.iter().all(|k| object.contains_key(*k)),
        _ => false,
    }
}

// The cause is part of the message, not a `source`: a chain printed
// whole (`{:#}`) would say it twice.
#[derive(Debug, thiserror::Error)]
#[error("{path}: {cause}")]
pub struct WriteError {
    pub path: PathBuf,
    pub cause: std::io::Error,
}

fn at(path: &Path) -> impl Fn(std::io::Error) -> WriteError + '_ {
    move |cause| WriteError {
        path: path.to_path_buf(),
        cause,
    }
}

/// A run's log of one JSON line per generation (`generations.jsonl`) or
/// per episode (`episodes.jsonl`). Lines go to the file whole, so that a
/// reader following it never sees part of one: a line goes at once where
/// the last went [`FLUSH_EVERY`] or more before it, and otherwise with a
/// later line, a checkpoint or the run's end. So while lines come fast a
/// reader sees them within about [`FLUSH_EVERY`]; the last of a fast run
/// of them waits for whatever comes next. Stopped by a signal or an
/// error, a run flushes what it flew before it saves its checkpoint
/// ([`RunLog::sync`]); a run that ends flushes it all ([`RunLog::finish`]).
pub struct RunLog {
    path: PathBuf,
    file: File,
    /// Whole lines written and not yet in the file.
    pending: Vec<u8>,
    /// When lines last went to the file.
    flushed: Instant,
    flush_every: Duration,
}

/// The longest lines stay pending while more come. A write(2) for every
/// line cost a guided generation on 2 threads 2–5 µs, about 3% of it.
pub const FLUSH_EVERY: Duration = Duration::from_millis(10);

/// The most bytes of lines held back, whatever the time: a Q(λ) trial
/// writes about 8 MB of lines a second.
const MOST_PENDING: usize = 64 << 10;

/// The log of the GA methods.
pub const GENERATIONS: &str = "generations.jsonl";
/// A GA run's best lander.
pub const BEST: &str = "best.json";
/// The experiment an experiment's folder belongs to.
pub const EXPERIMENT: &str = "experiment.json";
/// The sweep a sweep's folder belongs to.
pub const SWEEP: &str = "sweep.json";
/// The log of Q(λ).
pub const EPISODES: &str = "episodes.jsonl";

/// The key that numbers a log's lines from 1, where it has one.
fn numbered_by(file: &str) -> Option<&'static str> {
    match file {
        GENERATIONS => Some("index"),
        EPISODES => Some("episode"),
        _ => None,
    }
}

impl RunLog {
    /// A new log `file` in `dir`, replacing any.
    pub fn create(dir: &Path, file: &str) -> Result<RunLog, WriteError> {
        std::fs::create_dir_all(dir).map_err(at(dir))?;
        let path = dir.join(file);
        let file = File::create(&path).map_err(at(&path))?;
        Ok(RunLog::new(path, file))
    }

    fn new(path: PathBuf, file: File) -> RunLog {
        RunLog {
            path,
            file,
            pending: Vec::new(),
            flushed: Instant::now(),
            flush_every: FLUSH_EVERY,
        }
    }

    /// The log of a resumed run: its first `keep` lines, what its
    /// checkpoint had flown, and then the new ones. Lines past them,
    /// written after the checkpoint, are cut, so that each generation or
    /// episode is in the log once. Fewer than `keep` lines is an error,
    /// and changes nothing.
    pub fn resume(dir: &Path, file: &str, keep: u64) -> Result<RunLog, WriteError> {
        let path = dir.join(file);
        let text = std::fs::read(&path).map_err(at(&path))?;
        let refuse = |message: String| Err(at(&path)(std::io::Error::other(message)));
        let mut end = 0;
        for line in 1..=keep {
            let Some(i) = text[end..].iter().position(|&b| b == b'\n') else {
                return refuse(format!(
                    "holds fewer lines than its checkpoint's {keep}; the folder is not one run's"
                ));
            };
            // A damaged line kept would stay in the finished log, and so
            // would one out of its place (another run's, or edited).
            let kept = &text[end..end + i];
            let fields = match serde_json::from_slice::<serde_json::Map<_, _>>(kept) {
                Ok(fields) => fields,
                Err(e) => {
                    return refuse(format!(
                        "line {line} is not a log line ({e}); the log is damaged"
                    ))
                }
            };
            if let Some(key) = numbered_by(file) {
                let number = fields.get(key).and_then(serde_json::Value::as_u64);
                if number != Some(line) {
                    let found =
                        number.map_or(format!("no \"{key}\""), |n| format!("\"{key}\": {n}"));
                    return refuse(format!(
                        "line {line} has {found} where this run's log has {line}; the log is not this run's"
                    ));
                }
            }
            end += i + 1;
        }
        let mut file = std::fs::OpenOptions::new()
            .write(true)
            .open(&path)
            .map_err(at(&path))?;
        file.set_len(end as u64).map_err(at(&path))?;
        file.seek(std::io::SeekFrom::End(0)).map_err(at(&path))?;
        Ok(RunLog::new(path, file))
    }

    pub fn write(&mut self, record: &impl Serialize) -> Result<(), WriteError> {
        let start = self.pending.len();
        if let Err(e) = serde_json::to_writer(&mut self.pending, record) {
            // No part of a line that failed stays to go out.
            self.pending.truncate(start);
            return Err(at(&self.path)(e.into()));
        }
        self.pending.push(b'\n');
        if self.flushed.elapsed() >= self.flush_every || self.pending.len() >= MOST_PENDING {
            self.finish()?;
        }
        Ok(())
    }

    /// Sends every line written to the file, in one write(2) as a rule.
    /// What a write that failed partway did send is not kept to go again:
    /// a later call (the disk freed) sends only the rest, and the log
    /// holds no line twice, nor part of one.
    pub fn finish(&mut self) -> Result<(), WriteError> {
        while !self.pending.is_empty() {
            match self.file.write(&self.pending) {
                Ok(0) => return Err(at(&self.path)(std::io::ErrorKind::WriteZero.into())),
                Ok(sent) => drop(self.pending.drain(..sent)),
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => return Err(at(&self.path)(e)),
            }
        }
        self.flushed = Instant::now();
        Ok(())
    }

    /// Makes what was written durable, before a checkpoint that counts on
    /// it.
    pub fn sync(&mut self) -> Result<(), WriteError> {
        self.finish()?;
        self.file.sync_data().map_err(at(&self.path))
    }
}

impl Drop for RunLog {
    /// Sends what is pending, as a run that stops without [`RunLog::finish`]
    /// (an error on the way) still wants its lines; a failure here has no
    /// one left to tell.
    fn drop(&mut self) {
        let _ = self.file.write_all(&self.pending);
    }
}

/// Writes `value` as pretty JSON to `path` ([`replace_durably`]): a
/// reader never sees half a file, and after a crash the file is whole,
/// the old one or this.
pub fn write_json(path: &Path, value: &impl Serialize) -> Result<(), WriteError> {
    let mut text = serde_json::to_string_pretty(value).map_err(|e| at(path)(e.into()))?;
    text.push('\n');
    replace_durably(path, text.as_bytes())
}

/// Replaces `path` with `bytes` atomically and durably: a temporary file
/// beside it (its name with `.tmp` added), synced, renamed over it, and
/// the folder synced, so that after a crash `path` holds what it held or
/// `bytes`, never part of them. A temporary file that could not be
/// written whole (a full disk) is removed.
pub fn replace_durably(path: &Path, bytes: &[u8]) -> Result<(), WriteError> {
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(".tmp");
    let tmp = path.with_file_name(name);
    let written = File::create(&tmp).and_then(|mut file| {
        file.write_all(bytes)?;
        file.sync_all()
    });
    if let Err(e) = written {
        let _ = std::fs::remove_file(&tmp);
        return Err(at(&tmp)(e));
    }
    if let Err(e) = std::fs::rename(&tmp, path) {
        let _ = std::fs::remove_file(&tmp);
        return Err(at(path)(e));
    }
    // The rename itself is durable only once the folder is synced.
    let dir = match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir,
        _ => Path::new("."),
    };
    File::open(dir).and_then(|d| d.sync_all()).map_err(at(dir))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A log whose file is a pipe that takes only what its buffer holds,
    /// as a disk that fills midway: each write sends part of the lines.
    #[test]
    fn a_write_that_sends_part_of_the_lines_sends_only_the_rest_later() {
        use std::io::Read;
        use std::os::fd::{AsRawFd, OwnedFd};
        let (mut reader, writer) = std::io::pipe().unwrap();
        let fd = OwnedFd::from(writer);
        // SAFETY: fcntl on a descriptor this test owns, setting one flag.
        let set = unsafe { libc::fcntl(fd.as_raw_fd(), libc::F_SETFL, libc::O_NONBLOCK) };
        assert_eq!(set, 0);
        let mut log = RunLog::new(PathBuf::from("pipe"), File::from(fd));
        log.flush_every = Duration::MAX;
        // Lines enough to fill the pipe's buffer (64 KiB) three times over.
        let lines: Vec<String> = (0..6000)
            .map(|i| format!("line {i:05} {}", "x".repeat(20)))
            .collect();
        for line in &lines {
            log.pending
                .extend_from_slice(serde_json::to_string(line).unwrap().as_bytes());
            log.pending.push(b'\n');
        }
        let mut got = Vec::new();
        let mut partial = 0;
        // Each pass empties the pipe, so that the lines go out in a few.
        let sent = (0..100).any(|_| {
            if let Err(e) = log.finish() {
                assert!(e.to_string().contains("pipe"), "{e}");
                partial += 1;
                let mut chunk = vec![0; 1 << 20];
                let n = reader.read(&mut chunk).unwrap();
                got.extend_from_slice(&chunk[..n]);
                return false;
            }
            true
        });
        assert!(sent, "the lines never all went out");
        drop(log);
        reader.read_to_end(&mut got).unwrap();
        assert!(partial >= 2, "no write was cut short");
        let read: Vec<String> = String::from_utf8(got)
            .unwrap()
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect();
        assert_eq!(read, lines, "a line lost, cut or sent twice");
    }

    #[test]
    fn a_folder_of_another_commands_results_is_refused_naming_its_file() {
        let dir = tempfile::tempdir().unwrap();
        let dir = dir.path();
        for mine in Results::ALL {
            assert!(refuse_others(dir, mine).is_ok(), "an empty folder");
        }
        for (theirs, file) in [
            (Results::Sweep, "sweep.json"),
            (Results::Experiment, "experiment.json"),
            (Results::Run, "best.json"),
            (Results::Run, "checkpoint.bin"),
            (Results::Run, "episodes.jsonl"),
        ] {
            std::fs::write(dir.join(file), "{}").unwrap();
            for mine in Results::ALL {
                match refuse_others(dir, mine) {
                    Ok(()) => assert_eq!(mine, theirs, "{file} refused for {}", mine.what()),
                    Err(e) => {
                        assert_ne!(mine, theirs, "its own {file}");
                        assert_eq!((e.theirs, e.file), (theirs, file));
                        let said = e.to_string();
                        assert!(said.contains(file) && said.contains(mine.what()), "{said}");
                    }
                }
            }
            std::fs::remove_file(dir.join(file)).unwrap();
        }
    }

    #[test]
    fn lines_reach_the_file_whole_at_once_when_slow_together_when_fast_and_all_at_the_end() {
        let dir = tempfile::tempdir().unwrap();
        let dir = dir.path();
        let read = || std::fs::read_to_string(dir.join(GENERATIONS)).unwrap();
        let mut log = RunLog::create(dir, GENERATIONS).unwrap();
        log.flush_every = Duration::ZERO;
        log.write(&serde_json::json!({"index": 1})).unwrap();
        assert_eq!(read(), "{\"index\":1}\n");
        // Lines that come faster than that wait for a later one, or for
        // the end.
        log.flush_every = Duration::from_secs(3600);
        log.write(&serde_json::json!({"index": 2})).unwrap();
        log.write(&serde_json::json!({"index": 3})).unwrap();
        assert_eq!(read(), "{\"index\":1}\n");
        log.finish().unwrap();
        assert_eq!(read(), "{\"index\":1}\n{\"index\":2}\n{\"index\":3}\n");
        // However fast they come, whole lines go once enough are pending,
        // and a line never goes in part.
        let long = "x".repeat(1000);
        for index in 4..200 {
            log.write(&serde_json::json!({"index": index, "pad": long}))
                .unwrap();
            let text = read();
            assert!(text.ends_with('\n'), "a line went in part");
            assert!(log.pending.len() < MOST_PENDING);
        }
        assert!(read().lines().count() > 3, "nothing went before the end");
        drop(log);
        assert_eq!(
            read().lines().count(),
            199,
            "dropped, the log sends the rest"
        );
    }

    #[test]
    fn a_resumed_log_keeps_its_checkpoints_lines_and_refuses_damaged_ones() {
        let dir = tempfile::tempdir().unwrap();
        let dir = dir.path();
        let good = "{\"index\":1}\n{\"index\":2}\n{\"index\":3}\n";
        std::fs::write(dir.join(GENERATIONS), good).unwrap();
        let mut log = RunLog::resume(dir, GENERATIONS, 2).unwrap();
        log.write(&serde_json::json!({"index": 3})).unwrap();
        drop(log);
        assert_eq!(
            std::fs::read_to_string(dir.join(GENERATIONS)).unwrap(),
            good
        );

        let damaged = "{\"index\":1}\nGARBAGE\n{\"index\":3}\n";
        std::fs::write(dir.join(GENERATIONS), damaged).unwrap();
        let err = RunLog::resume(dir, GENERATIONS, 3).err().unwrap();
        assert!(
            err.to_string().contains("line 2 is not a log line"),
            "{err}"
        );
        assert_eq!(
            std::fs::read_to_string(dir.join(GENERATIONS)).unwrap(),
            damaged
        );
        std::fs::write(dir.join(GENERATIONS), good).unwrap();
        let err = RunLog::resume(dir, GENERATIONS, 4).err().unwrap();
        assert!(err.to_string().contains("fewer lines"), "{err}");
    }

    #[test]
    fn a_resumed_log_refuses_lines_out_of_their_place() {
        let dir = tempfile::tempdir().unwrap();
        let dir = dir.path();
        for (file, text, wanted) in [
            (
                GENERATIONS,
                "{\"index\":1}\n{}\n{\"index\":3}\n",
                "line 2 has no \"index\" where this run's log has 2",
            ),
            (
                GENERATIONS,
                "{\"index\":1}\n{\"index\":2298}\n",
                "line 2 has \"index\": 2298 where this run's log has 2",
            ),
            (
                EPISODES,
                "{\"episode\":2}\n",
                "line 1 has \"episode\": 2 where this run's log has 1",
            ),
        ] {
            std::fs::write(dir.join(file), text).unwrap();
            let keep = text.lines().count() as u64;
            let err = RunLog::resume(dir, file, keep).err().unwrap().to_string();
            assert!(err.contains(wanted) && err.contains(file), "{err}");
            let left = std::fs::read_to_string(dir.join(file)).unwrap();
            assert_eq!(left, text, "a refused log is left as it was");
        }
    }

    #[test]
    fn clearing_removes_only_a_runs_own_files() {
        let dir = tempfile::tempdir().unwrap();
        let dir = dir.path();
        let best = r#"{"method": "ga", "seed": 1, "trial": 1, "genome": "1:2"}"#;
        let log = "{\"index\":1,\"best\":2.0,\"mean\":1.0}\n{\"index\":2}\n";
        std::fs::write(dir.join("best.json"), best).unwrap();
        std::fs::write(dir.join("generations.jsonl"), log).unwrap();
        std::fs::write(dir.join("episodes.jsonl"), "").unwrap();
        std::fs::write(dir.join("notes.txt"), "x").unwrap();
        let removed = clear_run_outputs(dir).unwrap();
        assert_eq!(
            removed,
            ["generations.jsonl", "best.json", "episodes.jsonl"]
        );
        assert!(!dir.join("best.json").exists());
        assert!(dir.join("notes.txt").exists(), "not a run's file");
        assert!(clear_run_outputs(dir).unwrap().is_empty());
    }

    #[test]
    fn a_file_of_a_runs_name_that_no_run_wrote_is_refused_and_nothing_removed() {
        let dir = tempfile::tempdir().unwrap();
        let dir = dir.path();
        let best = r#"{"method": "ga", "seed": 1, "trial": 1, "genome": "1:2"}"#;
        std::fs::write(dir.join("best.json"), best).unwrap();
        for stranger in ["{\"total\": 3}", "not json", "[1, 2]"] {
            std::fs::write(dir.join("summary.json"), stranger).unwrap();
            match clear_run_outputs(dir) {
                Err(ClearError::NotARunsFile(path)) => assert!(path.ends_with("summary.json")),
                other => panic!("{stranger:?} was taken for a run's: {other:?}"),
            }
            assert!(dir.join("best.json").exists(), "removed before refusing");
        }
    }
}
