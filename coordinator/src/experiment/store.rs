//! The experiment's folder while it runs: the experiment it belongs to
//! (`experiment.json`) and one record per finished trial under `trials/`,
//! each written whole or not at all, so `--resume` can trust what it finds.

use super::file::Experiment;
use super::runner::TrialId;
use crate::folder_lock::{FolderLock, LockError};
use crate::run_files::{refuse_others, write_json, OthersResults, Results, EXPERIMENT};
use lander_report::model::TrialRecord;
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    #[error("{path}: {message}")]
    Io { path: PathBuf, message: String },
    #[error("{dir} already holds an experiment's results; pass --resume to finish it (or, finished, to write its tables and figures again), or choose another --out")]
    Occupied { dir: PathBuf },
    #[error("{dir} holds results of a different experiment ({field}); choose another --out")]
    Different { dir: PathBuf, field: String },
    #[error("{dir} holds no experiment to resume (no experiment.json)")]
    NothingToResume { dir: PathBuf },
    #[error("{dir} holds trial records under trials/ but no experiment.json, which would say what experiment they are of; remove trials/ or choose another --out")]
    Orphaned { dir: PathBuf },
    #[error(transparent)]
    Others(#[from] OthersResults),
    #[error(transparent)]
    Lock(#[from] LockError),
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> StoreError + '_ {
    move |e| StoreError::Io {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

pub struct Store {
    dir: PathBuf,
    /// The experiment whose trials a record must be one of (its seed, its
    /// methods and trials, each trial's start, its best lander's genome
    /// and pad).
    expects: Experiment,
    /// Whether the command resumes the experiment in the folder.
    resume: bool,
    /// The folder, held while this command writes to it; none for a
    /// folder only read, one not made yet, or one inside a held folder.
    lock: Option<FolderLock>,
    /// The sweep whose setting the folder is, held where this command was
    /// given the setting's folder itself ([`FolderLock::hold_sweep_of`]).
    sweep: Option<FolderLock>,
    /// Whether this store holds its folder itself: not a setting's inside
    /// a sweep's folder, which the sweep holds (one lock for all its
    /// settings rather than an open folder each).
    holds: bool,
    /// Whether this command writes the folder: not one only read, whose
    /// experiment may be running and writing it.
    writes: bool,
}

impl Store {
    /// Opens `dir` for `exp`: a new folder, or with `resume` one that an
    /// interrupted run of the same experiment left ([`Store::at`], then
    /// [`Store::create`]).
    pub fn open(dir: &Path, exp: &Experiment, resume: bool) -> Result<Store, StoreError> {
        let mut store = Store::at(dir, exp, resume)?;
        store.create()?;
        Ok(store)
    }

    /// The store of `exp` in `dir`, checked as [`Store::open`] checks it
    /// but not yet written: a command makes its other checks before it
    /// calls [`Store::create`], so that one refused leaves no folder that
    /// would refuse the corrected command. [`Store::finished`] reads
    /// nothing from a folder not yet created. A folder that is there is
    /// held from here on ([`FolderLock`]).
    pub fn at(dir: &Path, exp: &Experiment, resume: bool) -> Result<Store, StoreError> {
        Store::checked(dir, exp, resume, true)
    }

    /// [`Store::at`] for a folder inside one this command holds already,
    /// as a sweep holds its settings' folders: not held again.
    pub fn within(dir: &Path, exp: &Experiment, resume: bool) -> Result<Store, StoreError> {
        Store::checked(dir, exp, resume, false)
    }

    fn checked(
        dir: &Path,
        exp: &Experiment,
        resume: bool,
        holds: bool,
    ) -> Result<Store, StoreError> {
        let (sweep, lock) = match holds {
            true => (
                FolderLock::hold_sweep_of(dir)?,
                FolderLock::hold_if_there(dir)?,
            ),
            false => (None, None),
        };
        let store = Store {
            dir: dir.to_path_buf(),
            expects: exp.clone(),
            resume,
            lock,
            sweep,
            holds,
            writes: true,
        };
        store.check()?;
        Ok(store)
    }

    /// Whether the folder may hold this command's results: no other
    /// command's, and an experiment's only when resuming that one.
    fn check(&self) -> Result<(), StoreError> {
        refuse_others(&self.dir, Results::Experiment)?;
        let definition = self.dir.join(EXPERIMENT);
        match (definition.exists(), self.resume) {
            (true, false) => Err(StoreError::Occupied {
                dir: self.dir.clone(),
            }),
            (false, true) => Err(StoreError::NothingToResume {
                dir: self.dir.clone(),
            }),
            (true, true) => self.check_same(&definition, &self.expects),
            // Records nothing says the experiment of would be taken for
            // this one's, with whatever settings made them.
            (false, false) if self.holds_records() => Err(StoreError::Orphaned {
                dir: self.dir.clone(),
            }),
            (false, false) => Ok(()),
        }
    }

    /// Whether `trials/` holds a record, or the temporary file of one.
    fn holds_records(&self) -> bool {
        std::fs::read_dir(self.trials_dir()).is_ok_and(|entries| {
            entries.flatten().any(|e| {
                let name = e.file_name();
                let name = name.to_string_lossy();
                name.ends_with(".json") || name.ends_with(".json.tmp")
            })
        })
    }

    /// Creates the folder, holds it, and writes the experiment's
    /// definition into it. A folder made here is checked again once held:
    /// another command may have made and filled it since [`Store::at`].
    pub fn create(&mut self) -> Result<(), StoreError> {
        let made = |folder: PathBuf| {
            std::fs::create_dir_all(&folder).map_err(|e| StoreError::Io {
                message: format!("cannot create the folder: {e}"),
                path: folder,
            })
        };
        // The folder first, so that an error names it rather than a folder
        // inside it.
        made(self.dir.clone())?;
        if self.holds && self.lock.is_none() {
            self.lock = Some(FolderLock::hold(&self.dir)?);
            self.check()?;
        }
        made(self.trials_dir())?;
        let definition = self.dir.join(EXPERIMENT);
        write_json(&definition, &self.expects).map_err(|e| StoreError::Io {
            path: definition.clone(),
            message: e.cause.to_string(),
        })
    }

    /// The hold on the folder, for a caller that writes into it after the
    /// store is gone.
    pub fn take_hold(&mut self) -> Option<FolderLock> {
        let sweep = self.sweep.take();
        match self.lock.take() {
            Some(lock) => Some(lock.and(sweep)),
            None => sweep,
        }
    }

    /// The folder of `exp` to read finished trials from, each checked as
    /// `--resume` checks it, holding and changing nothing.
    pub fn read_only(dir: &Path, exp: &Experiment) -> Store {
        Store {
            dir: dir.to_path_buf(),
            expects: exp.clone(),
            resume: true,
            lock: None,
            sweep: None,
            holds: false,
            writes: false,
        }
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    fn trials_dir(&self) -> PathBuf {
        self.dir.join("trials")
    }

    fn check_same(&self, definition: &Path, exp: &Experiment) -> Result<(), StoreError> {
        let fail = |message| StoreError::Io {
            path: definition.to_path_buf(),
            message,
        };
        let current = serde_json::to_value(exp).map_err(|e| fail(e.to_string()))?;
        match difference_from_file(definition, &current).map_err(fail)? {
            None => Ok(()),
            Some(field) => Err(StoreError::Different {
                dir: self.dir.clone(),
                field,
            }),
        }
    }

    fn path_of(&self, task: TrialId) -> PathBuf {
        self.trials_dir()
            .join(format!("{}-{:05}.json", task.method.name(), task.trial))
    }

    /// Writes one finished trial, atomically.
    pub fn save(&self, record: &TrialRecord) -> Result<(), StoreError> {
        let path = self.path_of(TrialId::of(record));
        write_json(&path, record).map_err(|e| StoreError::Io {
            path,
            message: e.cause.to_string(),
        })
    }

    /// The trials finished so far, in file-name order; none in a store not
    /// yet created. A temporary file left by an interrupted write is
    /// removed.
    pub fn finished(&self) -> Result<Vec<TrialRecord>, StoreError> {
        let dir = self.trials_dir();
        // Not yet created (`Store::at`): nothing finished. Creating it
        // names what stands in the way, if anything does.
        // (`--out` under a file, too: not a directory.)
        if let Err(e) = std::fs::metadata(&dir) {
            use std::io::ErrorKind::{NotADirectory, NotFound};
            if matches!(e.kind(), NotFound | NotADirectory) {
                return Ok(Vec::new());
            }
        }
        let mut paths: Vec<PathBuf> = std::fs::read_dir(&dir)
            .map_err(io(&dir))?
            .map(|e| e.map(|e| e.path()).map_err(io(&dir)))
            .collect::<Result<_, _>>()?;
        paths.sort();
        let mut records = Vec::new();
        for path in paths {
            match path.extension().and_then(|e| e.to_str()) {
                Some("json") => {}
                // Left by an interrupted write; read only, it may be a
                // running experiment's write under way.
                Some("tmp") => {
                    if self.writes {
                        std::fs::remove_file(&path).map_err(io(&path))?;
                    }
                    continue;
                }
                _ => continue,
            }
            let text = std::fs::read_to_string(&path).map_err(io(&path))?;
            let record: TrialRecord = serde_json::from_str(&text).map_err(|e| StoreError::Io {
                path: path.clone(),
                message: format!("not a trial record: {e}"),
            })?;
            if let Some(wrong) = self.not_ours(&path, &record) {
                return Err(StoreError::Io {
                    path,
                    message: format!("not one of this experiment's trials: {wrong}"),
                });
            }
            records.push(record);
        }
        Ok(records)
    }

    /// Why `record`, read from `path`, is not the trial its file name says
    /// of this experiment, if it is not.
    fn not_ours(&self, path: &Path, record: &TrialRecord) -> Option<String> {
        let id = TrialId::of(record);
        if path != self.path_of(id) {
            return Some(format!(
                "it holds {} trial {}",
                record.method.name(),
                record.trial
            ));
        }
        let expects = &self.expects;
        if record.seed != expects.seed {
            return Some(format!(
                "its seed is {}, the experiment's {}",
                record.seed, expects.seed
            ));
        }
        if !expects.methods.contains(&record.method)
            || !(1..=expects.trials).contains(&record.trial)
        {
            return Some(format!(
                "the experiment runs trials 1 to {} of {}",
                expects.trials,
                expects
                    .methods
                    .iter()
                    .map(|m| m.name())
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        let cfg = expects.config(record.method, record.trial);
        let env = cfg.env(0);
        if record.x0 != env.x0 || record.pad_x != env.pad_x {
            return Some(format!(
                "it starts at x0 {} over the pad at {}, where the trial starts at {} over {}",
                record.x0, record.pad_x, env.x0, env.pad_x
            ));
        }
        // Its best lander is flown again for the report's replay.
        if let Some(best) = &record.best {
            if let Err(e) = lander_model::parse_genome(&best.genome, cfg.ga.max_duration) {
                return Some(format!("its best genome does not read: {e}"));
            }
            let w = &cfg.world;
            if !(w.pad_margin..w.width - w.pad_margin).contains(&best.pad_x) {
                return Some(format!(
                    "its best lander flew to a pad at {:?}, where every pad is in [{}, {})",
                    best.pad_x,
                    w.pad_margin,
                    w.width - w.pad_margin
                ));
            }
        }
        match record.generations {
            Some(n) if n != record.fitness.len() as u64 => Some(format!(
                "it counts {n} generations but holds the fitness of {}",
                record.fitness.len()
            )),
            _ => None,
        }
    }
}

/// The first field where the JSON in the file at `path` differs from
/// `current`, with both values where they are plain ("ga.population: 12
/// there, 7 here"), for a folder's `--resume` check; an unreadable or
/// malformed file is an error.
pub(crate) fn difference_from_file(
    path: &Path,
    current: &serde_json::Value,
) -> Result<Option<String>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| e.to_string())?;
    let stored: serde_json::Value = serde_json::from_str(&text).map_err(|e| e.to_string())?;
    Ok(difference(&stored, current, "").map(|d| d.shown()))
}

/// The dotted path of the first field where two JSON values differ
/// (`ga.population`, `grids[0].values[1]`).
pub fn first_difference(a: &serde_json::Value, b: &serde_json::Value, at: &str) -> Option<String> {
    difference(a, b, at).map(|d| d.at)
}

/// Where two JSON values first differ, and what each holds there (`None`
/// where one has no such field).
struct Difference<'a> {
    at: String,
    was: Option<&'a serde_json::Value>,
    is: Option<&'a serde_json::Value>,
}

impl Difference<'_> {
    /// "ga.population: 12 there, 7 here" where both are plain values;
    /// "grids differs" otherwise.
    fn shown(&self) -> String {
        use serde_json::Value::{Array, Object};
        match (self.was, self.is) {
            (Some(was), Some(is))
                if !matches!(was, Array(_) | Object(_)) && !matches!(is, Array(_) | Object(_)) =>
            {
                format!("{}: {was} there, {is} here", self.at)
            }
            _ => format!("{} differs", self.at),
        }
    }
}

fn difference<'a>(
    a: &'a serde_json::Value,
    b: &'a serde_json::Value,
    at: &str,
) -> Option<Difference<'a>> {
    use serde_json::Value::{Array, Object};
    match (a, b) {
        (Object(x), Object(y)) => {
            let keys = x.keys().chain(y.keys().filter(|k| !x.contains_key(*k)));
            for key in keys {
                let here = if at.is_empty() {
                    key.clone()
                } else {
                    format!("{at}.{key}")
                };
                match (x.get(key), y.get(key)) {
                    (Some(p), Some(q)) => {
                        if let Some(d) = difference(p, q, &here) {
                            return Some(d);
                        }
                    }
                    (was, is) => return Some(Difference { at: here, was, is }),
                }
            }
            None
        }
        (Array(x), Array(y)) if x.len() == y.len() => x
            .iter()
            .zip(y)
            .enumerate()
            .find_map(|(i, (p, q))| difference(p, q, &format!("{at}[{i}]"))),
        _ if a == b => None,
        _ => Some(Difference {
            at: if at.is_empty() {
                "the file".into()
            } else {
                at.into()
            },
            was: Some(a),
            is: Some(b),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lander_model::Method;

    /// A record of `trial` of the default experiment, starting where that
    /// trial starts, of 7 generations.
    fn record(method: Method, trial: u64) -> TrialRecord {
        let env = Experiment::default().config(method, trial).env(0);
        let point = |index| lander_report::model::FitnessPoint {
            index,
            restart: 0,
            best: 2.0,
            mean: 1.0,
        };
        TrialRecord {
            method,
            seed: 1,
            trial,
            x0: env.x0,
            pad_x: env.pad_x,
            landed: true,
            generations: Some(7),
            restarts: Some(0),
            episodes: None,
            wall_s: 0.5,
            fitness: (1..=7).map(point).collect(),
            best: None,
            learning: None,
        }
    }

    #[test]
    fn a_record_that_is_not_the_trial_its_file_names_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let exp = Experiment::default();
        let store = Store::open(dir.path(), &exp, false).unwrap();
        let file = dir.path().join("trials/ga-00001.json");
        let mut seed_2 = record(Method::Ga, 1);
        seed_2.seed = 2;
        let mut moved = record(Method::Ga, 1);
        moved.x0 = -5000.0;
        let mut padded = record(Method::Ga, 1);
        padded.pad_x += 1.0;
        let mut short = record(Method::Ga, 1);
        short.fitness.pop();
        let best = |genome: &str, pad_x| {
            let mut r = record(Method::Ga, 1);
            r.best = Some(lander_report::model::BestLander {
                genome: genome.into(),
                fitness: 1.0,
                safe: false,
                pad_x,
            });
            r
        };
        for (wrong, at, said) in [
            (best("2:30,9:1", 200.0), file.clone(), "its best genome"),
            (best("2:30", 1e308), file.clone(), "a pad at 1e308"),
            (record(Method::Ga, 2), file.clone(), "it holds ga trial 2"),
            (
                record(Method::Guided, 1),
                file.clone(),
                "it holds guided trial 1",
            ),
            (seed_2, file.clone(), "its seed is 2"),
            (moved, file.clone(), "it starts at x0 -5000"),
            (padded, file.clone(), "over the pad at"),
            (
                short,
                file.clone(),
                "it counts 7 generations but holds the fitness of 6",
            ),
            (
                record(Method::Ga, 99),
                dir.path().join("trials/ga-00099.json"),
                "trials 1 to 25",
            ),
        ] {
            write_json(&at, &wrong).unwrap();
            match store.finished() {
                Err(StoreError::Io { path, message }) => {
                    assert_eq!(path, at);
                    assert!(message.contains(said), "{message}");
                }
                other => panic!("{said}: {:?}", other.map(|r| r.len())),
            }
            std::fs::remove_file(&at).unwrap();
        }
        store.save(&best("2:30,0:5", 200.0)).unwrap();
        assert_eq!(store.finished().unwrap().len(), 1);
    }

    #[test]
    fn a_difference_is_found_inside_lists_and_shown_with_both_values() {
        use serde_json::json;
        let there = json!({"grids": [{"name": "e", "values": [[0.0, 0.1]]}], "trials": 3});
        let here = json!({"grids": [{"name": "e", "values": [[0.0, 0.2]]}], "trials": 3});
        let d = difference(&there, &here, "").unwrap();
        assert_eq!(d.shown(), "grids[0].values[0][1]: 0.1 there, 0.2 here");
        let longer = json!({"grids": [], "trials": 3});
        assert_eq!(
            difference(&there, &longer, "").unwrap().shown(),
            "grids differs"
        );
        let fewer = json!({"grids": [{"name": "e", "values": [[0.0, 0.1]]}]});
        assert_eq!(
            difference(&there, &fewer, "").unwrap().shown(),
            "trials differs"
        );
        assert!(difference(&there, &there.clone(), "").is_none());
    }

    #[test]
    fn a_runs_or_a_sweeps_folder_is_refused_and_left_as_it_was() {
        let dir = tempfile::tempdir().unwrap();
        for marker in ["best.json", "sweep.json"] {
            let folder = dir.path().join(marker);
            std::fs::create_dir(&folder).unwrap();
            std::fs::write(folder.join(marker), "{}").unwrap();
            std::fs::write(folder.join("summary.json"), "theirs").unwrap();
            for resume in [false, true] {
                assert!(matches!(
                    Store::open(&folder, &Experiment::default(), resume),
                    Err(StoreError::Others(_))
                ));
            }
            assert!(!folder.join("experiment.json").exists());
            assert!(!folder.join("trials").exists());
            assert_eq!(
                std::fs::read_to_string(folder.join("summary.json")).unwrap(),
                "theirs"
            );
        }
    }

    #[test]
    fn a_folder_is_resumed_only_by_its_own_experiment() {
        let dir = std::env::temp_dir().join(format!("lander-store-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let exp = Experiment::default();
        assert!(matches!(
            Store::open(&dir, &exp, true),
            Err(StoreError::NothingToResume { .. })
        ));
        let store = Store::open(&dir, &exp, false).unwrap();
        store.save(&record(Method::Guided, 2)).unwrap();
        store.save(&record(Method::Ga, 2)).unwrap();
        std::fs::write(dir.join("trials/ga-00003.json.tmp"), "{half").unwrap();
        // Held while open: another command is refused, even one that
        // would resume it.
        assert!(matches!(
            Store::open(&dir, &exp, true),
            Err(StoreError::Lock(LockError::InUse(_)))
        ));
        drop(store);
        assert!(matches!(
            Store::open(&dir, &exp, false),
            Err(StoreError::Occupied { .. })
        ));
        let mut other = exp.clone();
        other.ga.population = 7;
        match Store::open(&dir, &other, true) {
            Err(StoreError::Different { field, .. }) => {
                assert_eq!(field, "ga.population: 100 there, 7 here")
            }
            Err(e) => panic!("{e}"),
            Ok(_) => panic!("a different experiment resumed the folder"),
        }
        let again = Store::open(&dir, &exp, true).unwrap();
        let found = again.finished().unwrap();
        let tasks: Vec<TrialId> = found.iter().map(TrialId::of).collect();
        assert_eq!(
            tasks,
            [Method::Ga, Method::Guided].map(|method| TrialId { method, trial: 2 })
        );
        assert!(!dir.join("trials/ga-00003.json.tmp").exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn records_without_their_experiment_are_not_taken_for_a_new_ones() {
        let dir = tempfile::tempdir().unwrap();
        let dir = dir.path().join("e");
        let exp = Experiment::default();
        let store = Store::open(&dir, &exp, false).unwrap();
        store.save(&record(Method::Ga, 2)).unwrap();
        drop(store);
        std::fs::remove_file(dir.join(EXPERIMENT)).unwrap();
        match Store::at(&dir, &exp, false) {
            Err(e @ StoreError::Orphaned { .. }) => {
                assert!(e.to_string().contains("no experiment.json"), "{e}")
            }
            Err(e) => panic!("{e}"),
            Ok(_) => panic!("the records were taken for this experiment's"),
        }
        // An empty trials/ (a crash before the definition was written)
        // holds nothing to mistake.
        std::fs::remove_file(dir.join("trials/ga-00002.json")).unwrap();
        assert!(Store::at(&dir, &exp, false).is_ok());
    }

    #[test]
    fn a_setting_of_a_sweep_under_way_is_left_to_the_sweep() {
        let dir = tempfile::tempdir().unwrap();
        let sweep = dir.path().join("sweep");
        let setting = sweep.join("settings").join("a");
        let exp = Experiment::default();
        std::fs::create_dir_all(&sweep).unwrap();
        std::fs::write(sweep.join(crate::run_files::SWEEP), "{}").unwrap();
        // The sweep writes its setting as a store within its own hold.
        let running = FolderLock::hold(&sweep).unwrap();
        let mut within = Store::within(&setting, &exp, false).unwrap();
        within.create().unwrap();
        within.save(&record(Method::Ga, 1)).unwrap();
        // Another command given the setting's folder is refused before it
        // reads or writes anything.
        assert!(matches!(
            Store::at(&setting, &exp, true),
            Err(StoreError::Lock(LockError::SweepInUse { .. }))
        ));
        drop(running);
        // Once the sweep has stopped, the setting resumes on its own, and
        // holds the sweep meanwhile.
        let mut alone = Store::at(&setting, &exp, true).unwrap();
        assert_eq!(alone.finished().unwrap().len(), 1);
        assert!(matches!(FolderLock::hold(&sweep), Err(LockError::InUse(_))));
        let hold = alone.take_hold();
        drop(alone);
        assert!(
            FolderLock::hold(&sweep).is_err(),
            "the hold let the sweep go"
        );
        drop(hold);
        FolderLock::hold(&sweep).unwrap();
    }
}
