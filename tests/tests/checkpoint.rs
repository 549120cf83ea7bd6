//! `lander run --resume`: a run SIGKILLed early, midway or during a
//! restart, in-process and on 2 workers, goes on from its checkpoint to the
//! very outputs of a run never stopped; SIGTERM saves it too; damaged,
//! foreign or missing checkpoints are refused, changing nothing.

use lander_tests::{
    binary, lander, lines_in, stderr, wait_until, without_wall_time, Iox, KillOnDrop,
};
use serde_json::Value;
use std::fs;
use std::path::Path;
use std::process::{Command, Output, Stdio};

/// A run long enough to be caught midway, short enough for a test: guided
/// or general GA, 1,000 genomes, restarts after 40 generations; both
/// methods restart three times (160 and 152 generations).
const CONFIG: &str =
    "seed = 2\ntrial = 3\n[ga]\npopulation = 1000\nmax_generations = 40\nmax_restarts = 3\n";

/// Polls `ready` every millisecond for up to a minute: a generation takes
/// a few, and a kill should land near where it was aimed.
fn soon(mut ready: impl FnMut() -> bool) -> bool {
    let end = std::time::Instant::now() + std::time::Duration::from_secs(60);
    while std::time::Instant::now() < end {
        if ready() {
            return true;
        }
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
    false
}

fn config(dir: &Path) -> String {
    let path = dir.join("run.toml");
    fs::write(&path, CONFIG).unwrap();
    path.to_str().unwrap().to_string()
}

fn args<'a>(cfg: &'a str, method: &'a str, out: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut a = vec![
        "run",
        "--config",
        cfg,
        "--method",
        method,
        "--json",
        "--out",
        out,
        "--checkpoint-every",
        "5",
    ];
    a.extend_from_slice(extra);
    a
}

/// What must not differ between a run and its resumed twin.
fn outputs(dir: &Path, out: &Output) -> (Vec<u8>, Vec<u8>, Value) {
    assert!(out.status.success(), "{}", stderr(out));
    let summary: Value = serde_json::from_slice(&out.stdout).expect("--json prints JSON");
    (
        fs::read(dir.join("generations.jsonl")).unwrap(),
        fs::read(dir.join("best.json")).unwrap(),
        without_wall_time(summary),
    )
}

/// The generations logged so far, as (index, restart).
fn logged(path: &Path) -> Vec<(u64, u64)> {
    fs::read_to_string(path)
        .unwrap_or_default()
        .lines()
        .filter_map(|l| serde_json::from_str::<Value>(l).ok())
        .map(|v| {
            (
                v["index"].as_u64().unwrap_or(0),
                v["restart"].as_u64().unwrap_or(0),
            )
        })
        .collect()
}

/// Where to kill a run, judged from its log.
#[derive(Clone, Copy, Debug)]
enum When {
    Early,
    Midway,
    InARestart,
}

impl When {
    fn now(self, log: &[(u64, u64)]) -> bool {
        match self {
            When::Early => log.len() >= 12,
            When::Midway => log.len() >= 45,
            When::InARestart => log.iter().any(|&(_, restart)| restart >= 2),
        }
    }
}

fn kill_and_resume(method: &str, workers: bool, when: When, whole: &(Vec<u8>, Vec<u8>, Value)) {
    let dir = tempfile::tempdir().unwrap();
    let cfg = config(dir.path());
    let out = dir.path().join("run");
    let out_s = out.to_str().unwrap();
    let iox = Iox::new(&format!("ckpt_{method}_{when:?}"));
    let run_id = format!("ckpt{}{:?}{}", method, when, std::process::id()).to_lowercase();
    let extra: Vec<&str> = if workers {
        vec!["--workers", "2", "--run-id", &run_id]
    } else {
        Vec::new()
    };
    let mut child = iox
        .command("lander")
        .args(args(&cfg, method, out_s, &extra))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let log = out.join("generations.jsonl");
    let caught = soon(|| when.now(&logged(&log)));
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(caught, "{method} {when:?}: the run never got there");
    assert!(
        !out.join("best.json").exists(),
        "{method} {when:?}: the run ended before the kill"
    );
    assert!(
        out.join("checkpoint.bin").exists(),
        "{method} {when:?}: no checkpoint"
    );
    if workers {
        assert_workers_leave(&run_id);
    }
    let resumed = iox.lander(&["run", "--resume", out_s, "--json"]);
    assert_eq!(
        &outputs(&out, &resumed),
        whole,
        "{method} {when:?}, workers {workers}"
    );
    assert!(
        !out.join("checkpoint.bin").exists(),
        "a finished run keeps no checkpoint"
    );
    assert_nothing_left(&iox);
}

/// The workers of killed run `run_id` see their coordinator gone and leave.
fn assert_workers_leave(run_id: &str) {
    let gone = wait_until(20, || {
        let found = Command::new("pgrep").args(["-f", run_id]).output().unwrap();
        found.stdout.is_empty()
    });
    assert!(gone, "workers of the killed run {run_id} are still there");
}

/// No shared memory or iceoryx2 file of the test's namespace is left.
fn assert_nothing_left(iox: &Iox) {
    assert_eq!(
        iox.shm_files(),
        Vec::<String>::new(),
        "shared memory left behind"
    );
    assert_eq!(
        iox.root_files(),
        Vec::<std::path::PathBuf>::new(),
        "iceoryx2 files left behind"
    );
}

#[test]
fn a_killed_run_resumes_to_the_outputs_of_a_run_never_stopped() {
    for method in ["ga", "guided"] {
        let dir = tempfile::tempdir().unwrap();
        let cfg = config(dir.path());
        let out = dir.path().join("whole");
        let run = lander(&args(&cfg, method, out.to_str().unwrap(), &[]));
        let whole = outputs(&out, &run);
        let log = logged(&out.join("generations.jsonl"));
        assert!(
            log.iter().any(|&(_, r)| r >= 2) && log.len() > 60,
            "{method}: the run must restart twice for the test to mean anything ({} generations)",
            log.len()
        );
        for workers in [false, true] {
            for when in [When::Early, When::Midway, When::InARestart] {
                kill_and_resume(method, workers, when, &whole);
            }
        }
    }
}

/// The configuration written in `dir`, and the outputs of a guided run
/// of it never stopped (in `dir/whole`).
fn guided_whole(dir: &Path) -> (String, (Vec<u8>, Vec<u8>, Value)) {
    let cfg = config(dir);
    let whole_dir = dir.join("whole");
    let whole = outputs(
        &whole_dir,
        &lander(&args(&cfg, "guided", whole_dir.to_str().unwrap(), &[])),
    );
    (cfg, whole)
}

/// `stop` sent to a guided run 20 generations in, checkpointing only when
/// stopped, in-process or over 2 workers (where the stop comes amid a
/// generation's answers): it must save, and a resume must finish it to
/// the outputs of a run never stopped. Returns the stopped run's output.
fn stopped_then_resumed(workers: bool, stop: impl FnOnce(u32)) -> Output {
    let dir = tempfile::tempdir().unwrap();
    let (cfg, whole) = guided_whole(dir.path());
    let out = dir.path().join("run");
    let out_s = out.to_str().unwrap();
    let iox = Iox::new(&format!("stopped_{workers}"));
    let extra: &[&str] = if workers { &["--workers", "2"] } else { &[] };
    let mut a = args(&cfg, "guided", out_s, extra);
    let at = a.iter().position(|&a| a == "--checkpoint-every").unwrap() + 1;
    a[at] = "0";
    let child = iox
        .command("lander")
        .args(&a)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    assert!(wait_until(60, || lines_in(&out.join("generations.jsonl")) >= 20));
    stop(child.id());
    let stopped = child.wait_with_output().unwrap();
    assert!(!stopped.status.success());
    assert!(
        stderr(&stopped).contains("--resume"),
        "{}",
        stderr(&stopped)
    );
    assert!(out.join("checkpoint.bin").exists(), "{}", stderr(&stopped));
    let resumed = lander(&["run", "--resume", out_s, "--json"]);
    assert_eq!(outputs(&out, &resumed), whole);
    stopped
}

#[test]
fn sigterm_saves_the_run_and_resume_finishes_it() {
    stopped_then_resumed(false, |pid| lander_tests::signal(pid, "TERM"));
}

/// Stopped over workers, the generation under way is saved as it was
/// bred, not with the guided genes of the answers already in: flown again
/// on resuming, those would draw otherwise.
#[test]
fn sigterm_over_workers_saves_the_generation_as_bred_and_resume_finishes_it() {
    stopped_then_resumed(true, |pid| lander_tests::signal(pid, "TERM"));
}

/// One request can come as two signals: `timeout -s INT` signals the
/// process and then its group. Two signals 10 ms apart stop the run as one
/// does, saving it (the second, taken for another request, exited at once
/// with nothing saved); a resume finishes it.
#[test]
fn a_signal_that_comes_twice_at_once_saves_the_run_as_one_does() {
    let stopped = stopped_then_resumed(false, |pid| {
        // From here rather than from a shell, whose start-up on a loaded
        // host could put the two past the 100 ms that make a second signal
        // a second request. The 10 ms between them keep the second from
        // merging into the first while it is still pending.
        let pid = libc::pid_t::try_from(pid).unwrap();
        // SAFETY: kill(2) on the child this test started, which has not
        // been waited for and so cannot have been replaced.
        assert_eq!(unsafe { libc::kill(pid, libc::SIGINT) }, 0);
        std::thread::sleep(std::time::Duration::from_millis(10));
        // SAFETY: as above.
        assert_eq!(unsafe { libc::kill(pid, libc::SIGINT) }, 0);
    });
    assert_eq!(stopped.status.code(), Some(130), "{}", stderr(&stopped));
    assert!(
        !stderr(&stopped).contains("second signal"),
        "{}",
        stderr(&stopped)
    );
}

/// `lander-worker --rejoin` outlives its coordinator: an attached run is
/// SIGKILLed, resumed, SIGTERMed and resumed again seconds later, and the
/// two workers started with `--rejoin` serve all three coordinators (each
/// waits for a worker, so each finishing shows it served), then exit 0 as
/// the run finishes, with the outputs of a run never stopped. A worker
/// without it leaves each time: told nothing by a killed coordinator, told
/// the run stopped by a SIGTERMed one.
#[test]
fn a_worker_started_with_rejoin_serves_the_run_through_a_kill_and_a_stop() {
    let dir = tempfile::tempdir().unwrap();
    let (cfg, whole) = guided_whole(dir.path());
    let out = dir.path().join("run");
    let out_s = out.to_str().unwrap();
    let log = out.join("generations.jsonl");
    let iox = Iox::new("rejoin");
    let run_id = format!("rejoin{}", std::process::id());
    let worker = |extra: &[&str]| {
        iox.command("lander-worker")
            .args(["--run", &run_id])
            .args(extra)
            .stderr(Stdio::piped())
            .spawn()
            .unwrap()
    };
    let attached = ["--attach", "--run-id", &run_id];
    let coordinator = |a: &[&str]| {
        iox.command("lander")
            .args(a)
            .args(attached)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap()
    };
    let staying = [
        KillOnDrop::new(worker(&["--rejoin"])),
        KillOnDrop::new(worker(&["--rejoin"])),
    ];
    let leaving = worker(&[]);

    // Each coordinator waits for all three workers before it starts, so
    // that each hears its farewell.
    let all = ["--min-workers", "3"];
    let mut first = coordinator(&args(&cfg, "guided", out_s, &all));
    assert!(
        soon(|| logged(&log).len() >= 12),
        "the first coordinator never got going"
    );
    first.kill().unwrap();
    first.wait().unwrap();
    // Resumed at once, before the workers look for their coordinator
    // (twice a second): they must tell the new one from the dead one.
    let second = coordinator(&["run", "--resume", out_s, all[0], all[1]]);
    let left = wait_until(20, || lander_tests::has_exited(leaving.id()));
    assert!(
        left,
        "a worker took the resumed coordinator for the dead one"
    );
    lander_tests::ended_saying(leaving, 0, "the coordinator is gone");
    let leaving = worker(&[]);
    assert!(
        soon(|| logged(&log).len() >= 45),
        "the resumed coordinator never got going"
    );
    lander_tests::signal(second.id(), "TERM");
    let stopped = second.wait_with_output().unwrap();
    assert!(!stopped.status.success());
    assert!(
        !out.join("best.json").exists(),
        "the run ended before the stop"
    );
    lander_tests::ended_saying(leaving, 0, "the coordinator stopped before the run's end");

    // No coordinator for a while: the two wait.
    std::thread::sleep(std::time::Duration::from_secs(3));
    let last = iox
        .command("lander")
        .args(["run", "--resume", out_s, "--json"])
        .args(attached)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let last = lander_tests::ended_within(last, 120, "the last coordinator");
    assert_eq!(outputs(&out, &last), whole);
    for worker in staying {
        let ended = wait_until(30, || lander_tests::has_exited(worker.id()));
        assert!(ended, "a worker did not leave when the run finished");
        let served = lander_tests::ended_saying(worker.into_inner(), 0, "run finished");
        let said = stderr(&served);
        for words in [
            "the coordinator is gone; waiting",
            "the coordinator stopped before the run's end; waiting",
        ] {
            assert!(said.contains(words), "{words:?} unsaid: {said}");
        }
        assert_eq!(said.matches("to go on").count(), 2, "{said}");
    }
    assert_nothing_left(&iox);
}

#[test]
fn bad_checkpoints_are_refused_and_nothing_is_overwritten() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = config(dir.path());
    let out = dir.path().join("run");
    let out_s = out.to_str().unwrap();
    let child = Command::new(binary("lander"))
        .args(args(&cfg, "ga", out_s, &[]))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut child = child;
    assert!(wait_until(60, || lines_in(&out.join("generations.jsonl")) >= 20));
    child.kill().unwrap();
    child.wait().unwrap();
    let saved = fs::read(out.join("checkpoint.bin")).unwrap();
    let log = fs::read(out.join("generations.jsonl")).unwrap();
    let refused = |extra: &[&str], wanted: &[&str]| {
        let mut a = vec!["run", "--resume", out_s];
        a.extend_from_slice(extra);
        let run = lander(&a);
        assert!(!run.status.success(), "{extra:?}");
        let err = stderr(&run);
        for w in wanted {
            assert!(err.contains(w), "{extra:?}: {err}\n(wanted {w:?})");
        }
        assert!(!err.contains("panicked"), "{err}");
        assert_eq!(
            fs::read(out.join("generations.jsonl")).unwrap(),
            log,
            "the log changed"
        );
        assert!(!out.join("best.json").exists());
    };
    // Another configuration.
    refused(
        &["--population", "50"],
        &["checkpoint.bin", "ga.population differs"],
    );
    refused(
        &["--method", "guided"],
        &["checkpoint.bin", "method differs"],
    );
    // Truncated, corrupt, of another format, missing.
    fs::write(out.join("checkpoint.bin"), &saved[..saved.len() / 2]).unwrap();
    refused(&[], &["checkpoint.bin", "truncated"]);
    let mut corrupt = saved.clone();
    let at = corrupt.len() - 10;
    corrupt[at] ^= 0x40;
    fs::write(out.join("checkpoint.bin"), &corrupt).unwrap();
    refused(&[], &["checkpoint.bin", "corrupt"]);
    let mut other = saved.clone();
    other[8] = 9;
    fs::write(out.join("checkpoint.bin"), &other).unwrap();
    refused(&[], &["checkpoint.bin", "format 9"]);
    // Whole and checksummed, but of a configuration no run accepts.
    let path = out.join("checkpoint.bin");
    let mut bad = lander_coordinator::checkpoint::decode(&path, &saved).unwrap();
    bad.config.world.height = 1.0;
    fs::write(&path, lander_coordinator::checkpoint::encode(&bad.as_ref())).unwrap();
    refused(
        &[],
        &["checkpoint.bin: invalid configuration: world.height"],
    );
    fs::remove_file(out.join("checkpoint.bin")).unwrap();
    refused(&[], &["checkpoint.bin"]);
    // A fresh run does not overwrite an unfinished one.
    fs::write(out.join("checkpoint.bin"), &saved).unwrap();
    let fresh = lander(&args(&cfg, "ga", out_s, &[]));
    assert!(!fresh.status.success());
    assert!(stderr(&fresh).contains("--resume"), "{}", stderr(&fresh));
    assert_eq!(fs::read(out.join("generations.jsonl")).unwrap(), log);
}

/// A Q(λ) trial of `episodes` episodes, checkpointed every `every`.
fn qlearning<'a>(out: &'a str, episodes: &'a str, every: &'a str) -> Vec<&'a str> {
    let mut a = vec!["run", "--method", "qlearning", "--seed", "4", "--json"];
    a.extend([
        "--episodes",
        episodes,
        "--checkpoint-every",
        every,
        "--out",
        out,
    ]);
    a
}

/// What must not differ between a Q(λ) run and its resumed twin.
fn learned(dir: &Path, out: &Output) -> (Vec<u8>, Value, Value) {
    assert!(out.status.success(), "{}", stderr(out));
    let summary: Value = serde_json::from_slice(&out.stdout).expect("--json prints JSON");
    let file: Value = serde_json::from_slice(&fs::read(dir.join("summary.json")).unwrap()).unwrap();
    (
        fs::read(dir.join("episodes.jsonl")).unwrap(),
        without_wall_time(summary),
        without_wall_time(file),
    )
}

#[test]
fn a_killed_or_stopped_qlearning_run_resumes_to_the_outputs_of_one_never_stopped() {
    let dir = tempfile::tempdir().unwrap();
    let whole_dir = dir.path().join("whole");
    let whole_s = whole_dir.to_str().unwrap();
    let whole = learned(&whole_dir, &lander(&qlearning(whole_s, "60000", "0")));
    for (signal, every) in [("KILL", "2000"), ("TERM", "0")] {
        let out = dir.path().join(format!("run-{signal}"));
        let out_s = out.to_str().unwrap();
        let child = Command::new(binary("lander"))
            .args(qlearning(out_s, "60000", every))
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        assert!(
            soon(|| lines_in(&out.join("episodes.jsonl")) >= 9000),
            "{signal}"
        );
        lander_tests::signal(child.id(), signal);
        let stopped = child.wait_with_output().unwrap();
        assert!(
            !stopped.status.success(),
            "{signal}: the run finished first"
        );
        let saved = out.join("checkpoint.bin");
        assert!(saved.exists(), "{signal}: {}", stderr(&stopped));
        // The log may run past the checkpoint; resuming cuts it back. The
        // trial saved by SIGTERM goes on on a worker, in legs to the end.
        let iox = Iox::new(&format!("ckpt_q_{signal}"));
        let mut r = vec!["run", "--resume", out_s, "--json"];
        if signal == "TERM" {
            r.extend(["--workers", "1"]);
        }
        let resumed = iox.lander(&r);
        assert!(
            stderr(&resumed).contains("resuming"),
            "{signal}: {}",
            stderr(&resumed)
        );
        assert_eq!(learned(&out, &resumed), whole, "{signal}");
        assert!(!saved.exists(), "a finished run keeps no checkpoint");
    }
}

#[test]
fn a_qlearning_run_on_workers_killed_resumes_from_its_last_leg() {
    let dir = tempfile::tempdir().unwrap();
    let whole_dir = dir.path().join("whole");
    let whole = learned(
        &whole_dir,
        &lander(&qlearning(whole_dir.to_str().unwrap(), "60000", "0")),
    );
    // Resumed on workers, and in-process.
    for resume_on_workers in [true, false] {
        let iox = Iox::new(&format!("ckpt_q_{resume_on_workers}"));
        let run_id = format!("ckptq{resume_on_workers}{}", std::process::id());
        let out = dir.path().join(format!("run-{resume_on_workers}"));
        let out_s = out.to_str().unwrap();
        let mut a = qlearning(out_s, "60000", "2000");
        a.extend(["--workers", "2", "--run-id", &run_id]);
        let mut child = iox
            .command("lander")
            .args(&a)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let saved = out.join("checkpoint.bin");
        // Killed with two legs of 2,000 episodes flown and saved (the log
        // is written before the checkpoint), the trial on a worker.
        assert!(
            soon(|| lines_in(&out.join("episodes.jsonl")) >= 4000),
            "the legs never came back"
        );
        child.kill().unwrap();
        child.wait().unwrap();
        assert!(
            !out.join("summary.json").exists(),
            "the run ended before the kill"
        );
        assert_workers_leave(&run_id);
        let mut r = vec!["run", "--resume", out_s, "--json"];
        if resume_on_workers {
            r.extend(["--workers", "2"]);
        }
        let resumed = iox.lander(&r);
        let said = stderr(&resumed);
        let after: u32 = said
            .split("after episode ")
            .nth(1)
            .and_then(|rest| rest.split_whitespace().next())
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("{said}"));
        assert!(
            after >= 2000 && after.is_multiple_of(2000),
            "resumed after episode {after}, not at a leg's end"
        );
        assert_eq!(
            learned(&out, &resumed),
            whole,
            "resumed on workers: {resume_on_workers}"
        );
        assert!(!saved.exists(), "a finished run keeps no checkpoint");
        assert_nothing_left(&iox);
    }
}

/// A Q(λ) checkpoint whole and checksummed, but of a trial its own
/// configuration could not have reached, is refused naming the file and
/// the fault, in-process and on workers alike (where the pool's own
/// checks would otherwise speak first, less clearly), before anything in
/// the folder is touched.
#[test]
fn a_qlearning_checkpoint_that_does_not_fit_is_refused_before_the_folder_is_touched() {
    use lander_coordinator::checkpoint::{self, Checkpoint, Saved};
    let dir = tempfile::tempdir().unwrap();
    let mut config = lander_coordinator::config::RunConfig {
        method: lander_model::Method::Qlearning,
        ..Default::default()
    };
    config.qlearning.episodes = 500;
    let state = lander_model::learn::LearnState {
        episodes: 600,
        rng_word: 0,
        first_safe: None,
        recent: Vec::new(),
        weights: Vec::new(),
    };
    checkpoint::save(
        dir.path(),
        &Checkpoint {
            config,
            state: Saved::Learning(state),
        }
        .as_ref(),
    )
    .unwrap();
    let before: Vec<_> = fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    let saved = fs::read(dir.path().join("checkpoint.bin")).unwrap();
    let iox = Iox::new("ckpt_unfit");
    let d = dir.path().to_str().unwrap();
    for extra in [&[][..], &["--workers", "1"][..]] {
        let mut a = vec!["run", "--resume", d];
        a.extend_from_slice(extra);
        let run = iox.lander(&a);
        assert!(!run.status.success(), "{extra:?}");
        let err = stderr(&run);
        assert!(
            err.contains("checkpoint.bin: the saved trial does not fit its configuration: 600 episodes flown of a trial of 500"),
            "{extra:?}: {err}"
        );
        let after: Vec<_> = fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        assert_eq!(after, before, "{extra:?}: the folder changed");
        assert_eq!(fs::read(dir.path().join("checkpoint.bin")).unwrap(), saved);
    }
}
