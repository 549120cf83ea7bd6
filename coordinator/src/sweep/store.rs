//! The sweep's folder while it runs: the sweep it belongs to (`sweep.json`)
//! and one experiment folder per setting under `settings/`, each an
//! experiment [`Store`], so that `--resume` skips every finished trial and
//! every tool that reads an experiment folder reads a setting's.

use super::file::Sweep;
use crate::experiment::store::difference_from_file;
use crate::experiment::{Store, StoreError};
use crate::folder_lock::{FolderLock, LockError};
use crate::run_files::{refuse_others, write_json, OthersResults, Results, EXPERIMENT, SWEEP};
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum SweepStoreError {
    #[error("{dir} already holds a sweep's results; pass --resume to finish it (or, finished, to write its tables and figures again), or choose another --out")]
    Occupied { dir: PathBuf },
    #[error("{dir} holds results of a different sweep ({field}); choose another --out")]
    Different { dir: PathBuf, field: String },
    #[error("{dir} holds no sweep to resume (no sweep.json)")]
    NothingToResume { dir: PathBuf },
    #[error("{path}: {message}")]
    Io { path: PathBuf, message: String },
    #[error(transparent)]
    Setting(#[from] StoreError),
    #[error(transparent)]
    Others(#[from] OthersResults),
    #[error(transparent)]
    Lock(#[from] LockError),
}

/// The sweep folder and one experiment store per setting, in the sweep's
/// order.
pub struct SweepStore {
    dir: PathBuf,
    /// The sweep's definition, as `sweep.json` holds it.
    definition: serde_json::Value,
    /// Whether the command resumes the sweep in the folder.
    resume: bool,
    pub settings: Vec<Store>,
    /// The folder, held while this command writes to it; none before it
    /// is made.
    lock: Option<FolderLock>,
}

impl SweepStore {
    /// Opens `dir` for `sweep`: a new folder, or with `resume` one that an
    /// interrupted run of the same sweep left ([`SweepStore::at`], then
    /// [`SweepStore::create`]).
    pub fn open(dir: &Path, sweep: &Sweep, resume: bool) -> Result<SweepStore, SweepStoreError> {
        let mut store = SweepStore::at(dir, sweep, resume)?;
        store.create()?;
        Ok(store)
    }

    /// The store of `sweep` in `dir`, checked as [`SweepStore::open`]
    /// checks it but not yet written ([`Store::at`]); a folder that is
    /// there is held from here on ([`FolderLock`]).
    pub fn at(dir: &Path, sweep: &Sweep, resume: bool) -> Result<SweepStore, SweepStoreError> {
        let lock = FolderLock::hold_if_there(dir)?;
        let fresh = serde_json::to_value(sweep.definition()).map_err(|e| SweepStoreError::Io {
            path: dir.join(SWEEP),
            message: e.to_string(),
        })?;
        check(dir, &fresh, resume)?;
        let settings = sweep
            .settings
            .iter()
            .map(|s| {
                let at = setting_dir(dir, &s.folder);
                // A setting whose first trial had not finished may have no
                // folder yet.
                let begun = at.join(EXPERIMENT).exists();
                Store::within(&at, &s.experiment, resume && begun)
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(SweepStore {
            dir: dir.to_path_buf(),
            definition: fresh,
            resume,
            settings,
            lock,
        })
    }

    /// Creates the folder, holds it, writes the sweep's definition into
    /// it, and creates every setting's folder. A folder made here is
    /// checked again once held: another command may have made and filled
    /// it since [`SweepStore::at`].
    pub fn create(&mut self) -> Result<(), SweepStoreError> {
        std::fs::create_dir_all(&self.dir).map_err(|e| SweepStoreError::Io {
            path: self.dir.clone(),
            message: format!("cannot create the folder: {e}"),
        })?;
        if self.lock.is_none() {
            self.lock = Some(FolderLock::hold(&self.dir)?);
            check(&self.dir, &self.definition, self.resume)?;
        }
        let definition = self.dir.join(SWEEP);
        write_json(&definition, &self.definition).map_err(|e| SweepStoreError::Io {
            path: definition.clone(),
            message: e.cause.to_string(),
        })?;
        for setting in &mut self.settings {
            setting.create()?;
        }
        Ok(())
    }

    /// The hold on the folder, for a caller that writes into it after the
    /// store is gone.
    pub fn take_hold(&mut self) -> Option<FolderLock> {
        self.lock.take()
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }
}

/// Where a setting's experiment folder is.
pub fn setting_dir(dir: &Path, folder: &str) -> PathBuf {
    dir.join("settings").join(folder)
}

/// Whether `dir` may hold the sweep `fresh` defines: no other command's
/// results, and a sweep's only when resuming that one.
fn check(dir: &Path, fresh: &serde_json::Value, resume: bool) -> Result<(), SweepStoreError> {
    refuse_others(dir, Results::Sweep)?;
    let definition = dir.join(SWEEP);
    match (definition.exists(), resume) {
        (true, false) => Err(SweepStoreError::Occupied { dir: dir.into() }),
        (false, true) => Err(SweepStoreError::NothingToResume { dir: dir.into() }),
        (true, true) => check_same(dir, &definition, fresh),
        (false, false) => Ok(()),
    }
}

fn check_same(
    dir: &Path,
    definition: &Path,
    fresh: &serde_json::Value,
) -> Result<(), SweepStoreError> {
    let found = difference_from_file(definition, fresh).map_err(|message| SweepStoreError::Io {
        path: definition.to_path_buf(),
        message,
    })?;
    match found {
        None => Ok(()),
        Some(field) => Err(SweepStoreError::Different {
            dir: dir.to_path_buf(),
            field,
        }),
    }
}
