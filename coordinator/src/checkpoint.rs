//! `checkpoint.bin`: a `lander run` saved between generations (a GA) or
//! episodes (Q(λ)), so that a killed run goes on with `--resume` to the
//! very results it would have had. The file is versioned and checksummed, and written whole or not at
//! all (a temporary file, fsync, rename, fsync of the folder).
//!
//! Layout: the magic `LANDERCK`, the format version (u32), the CRC-32 of
//! the body (u32) and the body's length (u64), all little-endian, then the
//! body: a [`Checkpoint`] in postcard.

use crate::config::RunConfig;
use crate::trial::TrialState;
use lander_model::learn::LearnState;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The file's name in a run's folder.
pub const FILE: &str = "checkpoint.bin";
/// Bumped whenever the body's layout changes; other versions are refused.
/// Format 2 added Q(λ) runs.
pub const FORMAT: u32 = 2;
const MAGIC: &[u8; 8] = b"LANDERCK";
const HEADER: usize = 8 + 4 + 4 + 8;

/// What a run saves: its configuration and where its trial stands.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Checkpoint {
    pub config: RunConfig,
    pub state: Saved,
}

/// Where a saved trial stands, by what it does.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Saved {
    /// A GA trial (ga, guided), between generations.
    Evolving(TrialState),
    /// A Q(λ) trial, between episodes.
    Learning(LearnState),
}

/// A [`Checkpoint`] to write, borrowing its parts: the same bytes, with
/// nothing copied to write them (a Q(λ) state may hold hundreds of MB of
/// weights). Its fields and variants mirror [`Checkpoint`]'s and
/// [`Saved`]'s, in the same order.
#[derive(Serialize)]
pub struct CheckpointRef<'a> {
    pub config: &'a RunConfig,
    pub state: SavedRef<'a>,
}

/// [`Saved`], borrowed.
#[derive(Serialize)]
pub enum SavedRef<'a> {
    Evolving(&'a TrialState),
    Learning(&'a LearnState),
}

impl Checkpoint {
    pub fn as_ref(&self) -> CheckpointRef<'_> {
        CheckpointRef {
            config: &self.config,
            state: match &self.state {
                Saved::Evolving(s) => SavedRef::Evolving(s),
                Saved::Learning(s) => SavedRef::Learning(s),
            },
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    #[error("{path}: {message}")]
    Io { path: PathBuf, message: String },
    #[error("{path} is not a lander checkpoint")]
    NotACheckpoint { path: PathBuf },
    #[error("{path} is a checkpoint of format {found}; this lander reads format {FORMAT}")]
    Format { path: PathBuf, found: u32 },
    #[error("{path} is {}: {found} bytes of a {expected}-byte checkpoint", if found < expected { "truncated" } else { "longer than its checkpoint" })]
    Truncated {
        path: PathBuf,
        found: usize,
        expected: usize,
    },
    #[error("{path} is corrupt: its checksum does not match its contents")]
    Corrupt { path: PathBuf },
    #[error("{path} cannot be decoded: {message}")]
    Decode { path: PathBuf, message: String },
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> CheckpointError + '_ {
    move |e| CheckpointError::Io {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// The file's bytes for `checkpoint`.
pub fn encode(checkpoint: &CheckpointRef) -> Vec<u8> {
    // postcard cannot fail on these plain types but for running out of
    // memory, which aborts anyway.
    let body = postcard::to_stdvec(checkpoint).unwrap_or_default();
    let mut bytes = Vec::with_capacity(HEADER + body.len());
    bytes.extend_from_slice(MAGIC);
    bytes.extend_from_slice(&FORMAT.to_le_bytes());
    bytes.extend_from_slice(&crc32fast::hash(&body).to_le_bytes());
    bytes.extend_from_slice(&(body.len() as u64).to_le_bytes());
    bytes.extend_from_slice(&body);
    bytes
}

/// Reads a checkpoint's bytes, refusing anything but a whole, intact
/// checkpoint of this format; `path` names the file in errors.
pub fn decode(path: &Path, bytes: &[u8]) -> Result<Checkpoint, CheckpointError> {
    let path = path.to_path_buf();
    if bytes.len() < MAGIC.len() || &bytes[..MAGIC.len()] != MAGIC {
        return Err(CheckpointError::NotACheckpoint { path });
    }
    let field = |at: usize, n: usize| bytes.get(at..at + n);
    let (Some(format), Some(crc), Some(len)) = (field(8, 4), field(12, 4), field(16, 8)) else {
        return Err(CheckpointError::Truncated {
            path,
            found: bytes.len(),
            expected: HEADER,
        });
    };
    let le4 = |b: &[u8]| u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
    let format = le4(format);
    if format != FORMAT {
        return Err(CheckpointError::Format {
            path,
            found: format,
        });
    }
    let mut len8 = [0u8; 8];
    len8.copy_from_slice(len);
    let expected = usize::try_from(u64::from_le_bytes(len8))
        .unwrap_or(usize::MAX)
        .saturating_add(HEADER);
    if bytes.len() != expected {
        return Err(CheckpointError::Truncated {
            path,
            found: bytes.len(),
            expected,
        });
    }
    let body = &bytes[HEADER..];
    if crc32fast::hash(body) != le4(crc) {
        return Err(CheckpointError::Corrupt { path });
    }
    postcard::from_bytes(body).map_err(|e| CheckpointError::Decode {
        path,
        message: e.to_string(),
    })
}

/// Writes `checkpoint` into `dir` atomically and durably: after a crash
/// the folder holds either the previous checkpoint or this one.
pub fn save(dir: &Path, checkpoint: &CheckpointRef) -> Result<(), CheckpointError> {
    crate::run_files::replace_durably(&dir.join(FILE), &encode(checkpoint))
        .map_err(|e| io(&e.path)(e.cause))
}

/// Removes `dir`'s checkpoint, if it has one: the run it saved is over.
pub fn remove(dir: &Path) -> Result<(), CheckpointError> {
    let path = dir.join(FILE);
    match std::fs::remove_file(&path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(io(&path)(e)),
        _ => Ok(()),
    }
}

/// Reads `dir`'s checkpoint.
pub fn load(dir: &Path) -> Result<Checkpoint, CheckpointError> {
    let path = dir.join(FILE);
    let bytes = std::fs::read(&path).map_err(io(&path))?;
    decode(&path, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trial::TrialRun;

    fn checkpoint() -> Checkpoint {
        let mut cfg = RunConfig::default();
        cfg.ga.population = 6;
        cfg.ga.genome_length = 4;
        let run = TrialRun::new(&cfg).unwrap();
        Checkpoint {
            config: cfg,
            state: Saved::Evolving(run.state().unwrap()),
        }
    }

    #[test]
    fn a_save_that_fails_leaves_the_last_checkpoint_and_no_half_file() {
        let dir = tempfile::tempdir().unwrap();
        save(dir.path(), &checkpoint().as_ref()).unwrap();
        let good = std::fs::read(dir.path().join(FILE)).unwrap();
        // The next save's file, written where every write fails as on a
        // full disk.
        let tmp = dir.path().join(format!("{FILE}.tmp"));
        std::os::unix::fs::symlink("/dev/full", &tmp).unwrap();
        let err = save(dir.path(), &checkpoint().as_ref())
            .unwrap_err()
            .to_string();
        assert!(err.contains("checkpoint.bin.tmp"), "{err}");
        assert!(err.contains("No space left"), "{err}");
        assert!(!tmp.exists() && tmp.symlink_metadata().is_err());
        assert_eq!(std::fs::read(dir.path().join(FILE)).unwrap(), good);
    }

    #[test]
    fn a_checkpoint_reads_back_as_written_of_either_kind() {
        let mut cfg = RunConfig {
            method: lander_model::Method::Qlearning,
            ..RunConfig::default()
        };
        cfg.qlearning.memory_bits = 8;
        let run = lander_model::learn::LearnRun::new(
            &cfg.env(0),
            &cfg.guided,
            &cfg.qlearning,
            lander_model::StreamKey::new(1, 2, 0, 0),
        );
        let learning = Checkpoint {
            config: cfg,
            state: Saved::Learning(run.state()),
        };
        for c in [checkpoint(), learning] {
            let path = Path::new("x/checkpoint.bin");
            // Written borrowed, read back owned: the same bytes as the
            // owned checkpoint's.
            let owned = postcard::to_stdvec(&c).unwrap();
            assert_eq!(postcard::to_stdvec(&c.as_ref()).unwrap(), owned);
            assert_eq!(decode(path, &encode(&c.as_ref())).unwrap(), c);
            let dir = tempfile::tempdir().unwrap();
            save(dir.path(), &c.as_ref()).unwrap();
            assert_eq!(load(dir.path()).unwrap(), c);
            assert!(!dir.path().join("checkpoint.bin.tmp").exists());
        }
    }

    #[test]
    fn damaged_checkpoints_are_refused_saying_how() {
        let bytes = encode(&checkpoint().as_ref());
        let path = Path::new("run/checkpoint.bin");
        let said = |b: &[u8]| decode(path, b).unwrap_err().to_string();
        assert!(said(b"{\"json\": 1}").contains("not a lander checkpoint"));
        assert!(said(&bytes[..10]).contains("truncated"));
        assert!(said(&bytes[..bytes.len() - 1]).contains("truncated"));
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(said(&longer).contains("longer than its checkpoint"));
        let mut flipped = bytes.clone();
        let last = flipped.len() - 3;
        flipped[last] ^= 0x10;
        assert!(said(&flipped).contains("corrupt"));
        let mut newer = bytes.clone();
        newer[8..12].copy_from_slice(&(FORMAT + 1).to_le_bytes());
        let e = said(&newer);
        assert!(
            e.contains(&format!("format {}", FORMAT + 1)) && e.contains("run/checkpoint.bin"),
            "{e}"
        );
    }

    #[test]
    fn a_resumed_trial_ends_as_an_uninterrupted_one() {
        use crate::evaluator::InProcess;
        use crate::trial::{finish_trial, run_trial};
        let mut cfg = RunConfig::default();
        cfg.ga.population = 20;
        cfg.ga.max_generations = 15;
        cfg.ga.max_restarts = 2;
        let mut ev = InProcess::new(1).unwrap();
        let mut whole = Vec::new();
        let result = run_trial(&cfg, &mut ev, &mut |g| {
            whole.push(g.clone());
            Ok(())
        })
        .unwrap();
        assert!(whole.len() > 15, "the trial restarted");
        // Stopped after every generation in turn, saved, read back, resumed:
        // on two threads too, where each generation flies as it is bred.
        let mut two = InProcess::new(2).unwrap();
        for (stop, threads) in [1, 7, 15, 16, whole.len() - 1]
            .into_iter()
            .flat_map(|s| [(s, 1), (s, 2)])
        {
            let ev: &mut InProcess = if threads == 1 { &mut ev } else { &mut two };
            let mut run = TrialRun::new(&cfg).unwrap();
            let mut seen = Vec::new();
            let mut saved = None;
            let _ = finish_trial(&mut run, ev, &mut |g, run| {
                seen.push(g.clone());
                if seen.len() == stop {
                    saved = Some(encode(&CheckpointRef {
                        config: &cfg,
                        state: SavedRef::Evolving(&run.state().unwrap()),
                    }));
                    return Err("stop".into());
                }
                Ok(())
            });
            let back = decode(Path::new("c"), &saved.unwrap()).unwrap();
            let Saved::Evolving(state) = back.state else {
                panic!("a GA trial saved as another");
            };
            let mut resumed = TrialRun::resume(&back.config, state).unwrap();
            let end = finish_trial(&mut resumed, ev, &mut |g, _| {
                seen.push(g.clone());
                Ok(())
            })
            .unwrap();
            assert_eq!(seen, whole, "stopped after {stop}, {threads} threads");
            assert_eq!(end, result, "stopped after {stop}, {threads} threads");
        }
    }

    #[test]
    fn a_state_that_does_not_fit_its_configuration_is_refused() {
        let c = checkpoint();
        let Saved::Evolving(state) = c.state else {
            panic!("a GA trial saved as another");
        };
        let mut other = c.config.clone();
        other.ga.population = 7;
        let e = TrialRun::resume(&other, state.clone()).err().unwrap();
        assert!(e.to_string().contains("6 genomes"), "{e}");
        let mut shorter = c.config.clone();
        shorter.ga.max_generations = 0;
        let mut state = state;
        state.generation = 3;
        assert!(TrialRun::resume(&shorter, state).is_err());
    }
}
