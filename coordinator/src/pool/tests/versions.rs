//! A worker this pool started that speaks another protocol version.

use crate::evaluator::EvalError;
use crate::pool::{Arrival, Pool, PoolOptions, Transport};
use lander_protocol::wire::PROTOCOL_VERSION;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Announces whichever process wrote its pid to `pid_file`, with a version
/// this build does not speak.
struct OtherBuild {
    pid_file: PathBuf,
}

impl Transport for OtherBuild {
    type Link = super::fake::Recorder;
    fn name(&self) -> &'static str {
        "other"
    }
    fn arrivals(&mut self) -> Result<Vec<Arrival>, EvalError> {
        let pid = std::fs::read_to_string(&self.pid_file).unwrap_or_default();
        Ok(pid
            .trim()
            .parse()
            .ok()
            .into_iter()
            .map(|pid| Arrival {
                id: 1,
                pid,
                version: PROTOCOL_VERSION + 1,
                host: String::new(),
            })
            .collect())
    }
    fn connect(&mut self, _: &Arrival) -> Result<Self::Link, String> {
        Err("never asked: the version is refused first".into())
    }
    fn departures(&mut self) -> Vec<u64> {
        Vec::new()
    }
    fn sleep(&mut self, max: Duration) -> Result<(), EvalError> {
        std::thread::sleep(max.min(Duration::from_millis(5)));
        Ok(())
    }
    fn worker_args(&self) -> Vec<String> {
        Vec::new()
    }
    fn close(&mut self) {}
}

#[test]
fn a_spawned_worker_of_another_build_ends_the_wait_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let pid_file = dir.path().join("pid");
    let exe = crate::pool::spawn::script(
        &dir.path().join("lander-worker"),
        &format!("echo $$ > {}\nexec sleep 60\n", pid_file.display()),
    );
    let opts = PoolOptions {
        spawn: 1,
        worker_exe: exe.clone(),
        ..super::fake::options()
    };
    let mut pool = Pool::with_transport(OtherBuild { pid_file }, opts, Default::default()).unwrap();
    let started = Instant::now();
    let e = pool
        .wait_for_workers(1, Duration::from_secs(60))
        .unwrap_err();
    assert!(
        matches!(&e, EvalError::WorkerVersion { got, .. } if *got == PROTOCOL_VERSION + 1),
        "{e}"
    );
    let message = e.to_string();
    assert!(
        message.contains(&exe.display().to_string()) && message.contains("different builds"),
        "{message}"
    );
    // Refused at its announcement, not after the patience ran out, and its
    // process killed rather than waited for.
    assert!(started.elapsed() < Duration::from_secs(30));
    let before_drop = Instant::now();
    drop(pool);
    assert!(before_drop.elapsed() < Duration::from_secs(4));
}
