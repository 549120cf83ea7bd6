//! One command at a time in an output folder: `lander run`, `experiment`
//! and `sweep` hold their folder while they write to it, so that a second
//! command given the same `--out` is refused rather than let the two clear
//! and interleave each other's files.
//!
//! The hold is an advisory lock (`flock`) on the folder itself: it leaves
//! no file behind, and the kernel lets go of it when the process ends,
//! however it ends, so a killed command never leaves its folder locked.
//! A filesystem that has no such locks, or none on a folder (NFS takes an
//! `flock` as a byte-range lock, which a folder opened to be read cannot
//! hold), is written without one, with a warning.

use std::fs::{File, TryLockError};
use std::path::{Path, PathBuf};

/// Held while a command writes into its folder; dropped, the folder is
/// free again.
#[derive(Debug)]
pub struct FolderLock {
    _folder: Option<File>,
}

/// Why a folder could not be held.
#[derive(Debug, thiserror::Error)]
pub enum LockError {
    #[error(
        "{0} is in use by another lander command; wait for it to end, or choose another --out"
    )]
    InUse(PathBuf),
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
        let io = |cause| LockError::Io {
            path: dir.to_path_buf(),
            cause,
        };
        let folder = File::open(dir).map_err(io)?;
        match folder.try_lock() {
            Ok(()) => Ok(FolderLock {
                _folder: Some(folder),
            }),
            Err(TryLockError::WouldBlock) => Err(LockError::InUse(dir.to_path_buf())),
            Err(TryLockError::Error(e)) if unlockable(&e) => {
                tracing::warn!(
                    "{}: this filesystem cannot lock a folder ({e}); \
                     nothing keeps a second command out of it",
                    dir.display()
                );
                Ok(FolderLock { _folder: None })
            }
            Err(TryLockError::Error(e)) => Err(io(e)),
        }
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
