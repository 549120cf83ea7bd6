//! One command at a time in an output folder: `lander run`, `experiment`
//! and `sweep` hold their folder while they write to it, so that a second
//! command given the same `--out` is refused rather than let the two clear
//! and interleave each other's files.
//!
//! The hold is an advisory lock (`flock`) on the folder itself: it leaves
//! no file behind, and the kernel lets go of it when the process ends,
//! however it ends, so a killed command never leaves its folder locked.
//! A sweep holds its own folder but not each setting's under it, so a
//! command given a setting's folder holds the sweep's too
//! ([`FolderLock::hold_sweep_of`]).
//! A filesystem that has no such locks, or none on a folder (NFS takes an
//! `flock` as a byte-range lock, which a folder opened to be read cannot
//! hold), is written without one, with a warning.

use crate::run_files::SWEEP;
use std::fs::{File, TryLockError};
use std::path::{Path, PathBuf};

/// Held while a command writes into its folder; dropped, the folder is
/// free again.
#[derive(Debug)]
pub struct FolderLock {
    /// The folders held (none where the filesystem cannot lock them).
    _folders: Vec<File>,
}

/// Why a folder could not be held.
#[derive(Debug, thiserror::Error)]
pub enum LockError {
    #[error(
        "{0} is in use by another lander command; wait for it to end, or choose another --out"
    )]
    InUse(PathBuf),
    #[error(
        "{setting} is a setting of the sweep in {sweep}, which `lander sweep` is running; \
         wait for it to end, or choose another --out"
    )]
    SweepInUse { setting: PathBuf, sweep: PathBuf },
    #[error("{path}: cannot lock the folder: {cause}")]
    Io {
        path: PathBuf,
        cause: std::io::Error,
    },
}

impl FolderLock {
    /// Holds `dir`, a folder that exists, or says that another command
    /// holds it.
    pub fn hold(dir: &Path) -> Result<FolderLock, LockError> {
        FolderLock::take(dir, File::try_lock)
    }

    /// Holds `dir` shared: beside other shared holds, but not beside one
    /// taken by [`FolderLock::hold`].
    fn hold_shared(dir: &Path) -> Result<FolderLock, LockError> {
        FolderLock::take(dir, File::try_lock_shared)
    }

    fn take(
        dir: &Path,
        lock: fn(&File) -> Result<(), TryLockError>,
    ) -> Result<FolderLock, LockError> {
        let io = |cause| LockError::Io {
            path: dir.to_path_buf(),
            cause,
        };
        let folder = File::open(dir).map_err(io)?;
        match lock(&folder) {
            Ok(()) => Ok(FolderLock {
                _folders: vec![folder],
            }),
            Err(TryLockError::WouldBlock) => Err(LockError::InUse(dir.to_path_buf())),
            Err(TryLockError::Error(e)) if unlockable(&e) => {
                tracing::warn!(
                    "{}: this filesystem cannot lock a folder ({e}); \
                     nothing keeps a second command out of it",
                    dir.display()
                );
                Ok(FolderLock {
                    _folders: Vec::new(),
                })
            }
            Err(TryLockError::Error(e)) => Err(io(e)),
        }
    }

    /// Holds, where `dir` is a setting's folder of a sweep
    /// (`<sweep>/settings/<name>`, the sweep's definition beside
    /// `settings`), the sweep's folder, shared, or says that the sweep is
    /// running: commands on different settings of a sweep may run side by
    /// side (each holds its own setting's folder as well), but none beside
    /// the sweep itself.
    pub fn hold_sweep_of(dir: &Path) -> Result<Option<FolderLock>, LockError> {
        let Some(sweep) = sweep_of(dir) else {
            return Ok(None);
        };
        match FolderLock::hold_shared(&sweep) {
            Err(LockError::InUse(_)) => Err(LockError::SweepInUse {
                setting: dir.to_path_buf(),
                sweep,
            }),
            held => held.map(Some),
        }
    }

    /// This hold and `other` as one.
    pub fn and(mut self, other: Option<FolderLock>) -> FolderLock {
        self._folders
            .extend(other.into_iter().flat_map(|l| l._folders));
        self
    }

    /// Holds `dir` if it exists: a folder not yet made is held once it is.
    pub fn hold_if_there(dir: &Path) -> Result<Option<FolderLock>, LockError> {
        if dir.is_dir() {
            FolderLock::hold(dir).map(Some)
        } else {
            Ok(None)
        }
    }
}

/// The sweep folder whose setting `dir` is, if it is one, however `dir`
/// was written (relative, through `..` or a link).
fn sweep_of(dir: &Path) -> Option<PathBuf> {
    // The setting's folder may not be made yet; its sweep's is.
    let dir = match dir.canonicalize() {
        Ok(dir) => dir,
        Err(_) => std::path::absolute(dir)
            .ok()?
            .parent()?
            .canonicalize()
            .ok()?
            .join(dir.file_name()?),
    };
    let settings = dir.parent()?;
    let sweep = settings.parent()?;
    (settings.file_name()? == "settings" && sweep.join(SWEEP).is_file())
        .then(|| sweep.to_path_buf())
}

/// Whether `e` says the filesystem cannot lock a folder at all, rather
/// than that something is wrong: no locks (`ENOTSUP`, `ENOLCK` without a
/// lock daemon), or NFS's byte-range lock refusing a read-only folder
/// (`EBADF`, `EINVAL`).
fn unlockable(e: &std::io::Error) -> bool {
    e.kind() == std::io::ErrorKind::Unsupported
        || matches!(
            e.raw_os_error(),
            Some(libc::EBADF | libc::ENOLCK | libc::EINVAL)
        )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_held_folder_is_refused_until_it_is_let_go() {
        let dir = tempfile::tempdir().unwrap();
        let first = FolderLock::hold(dir.path()).unwrap();
        match FolderLock::hold(dir.path()) {
            Err(e @ LockError::InUse(_)) => {
                let said = e.to_string();
                assert!(said.contains(&dir.path().display().to_string()), "{said}");
                assert!(said.contains("--out"), "{said}");
            }
            other => panic!("a held folder was held again: {other:?}"),
        }
        drop(first);
        FolderLock::hold(dir.path()).unwrap();
        // Nothing is left in the folder.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn a_setting_of_a_held_sweep_is_refused_naming_both() {
        let dir = tempfile::tempdir().unwrap();
        let sweep = dir.path().join("sweep");
        let setting = sweep.join("settings").join("mutation_rate=0.1");
        std::fs::create_dir_all(&setting).unwrap();
        // Not a sweep's folder without its definition.
        assert!(FolderLock::hold_sweep_of(&setting).unwrap().is_none());
        std::fs::write(sweep.join(SWEEP), "{}").unwrap();
        let running = FolderLock::hold(&sweep).unwrap();
        match FolderLock::hold_sweep_of(&setting) {
            Err(e @ LockError::SweepInUse { .. }) => {
                let said = e.to_string();
                assert!(said.contains(&setting.display().to_string()), "{said}");
                assert!(said.contains(&sweep.display().to_string()), "{said}");
            }
            other => panic!("a setting of a held sweep was held: {other:?}"),
        }
        drop(running);
        // Held through one of its settings, the sweep is refused in turn.
        let through = FolderLock::hold_sweep_of(&setting).unwrap();
        assert!(through.is_some());
        assert!(matches!(FolderLock::hold(&sweep), Err(LockError::InUse(_))));
        // Another setting, one not made yet, and one written through `..`,
        // are held beside it: only the sweep itself is kept out.
        let other = sweep.join("settings").join("not-made-yet");
        let winding = sweep.join("settings/../settings/b");
        for dir in [other, winding] {
            assert!(
                FolderLock::hold_sweep_of(&dir).unwrap().is_some(),
                "{dir:?}"
            );
        }
        drop(through);
        FolderLock::hold(&sweep).unwrap();
        // A folder not inside a sweep's settings holds nothing more.
        assert!(FolderLock::hold_sweep_of(&sweep).unwrap().is_none());
    }

    #[test]
    fn a_folder_not_there_is_held_once_made() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out");
        assert!(FolderLock::hold_if_there(&out).unwrap().is_none());
        assert!(matches!(
            FolderLock::hold(&out),
            Err(LockError::Io { path, .. }) if path == out
        ));
        std::fs::create_dir(&out).unwrap();
        assert!(FolderLock::hold_if_there(&out).unwrap().is_some());
    }
}
