//! The evaluator pool between real processes over iceoryx2: identical
//! results whatever the worker count, and no lost work when workers die,
//! hang, or come and go.

use lander_tests::{
    ended_saying, events, free_port, has_exited, http_get, interrupt, joined, json_lines, json_out,
    lines_in, signal, stderr, wait_until, without_wall_time, worker_children, worker_id_of, Iox,
};
use serde_json::Value;
use std::fs;
use std::path::Path;
use std::process::{Child, Stdio};

/// These tests time faults (a worker stopped, hung or killed mid-run)
/// against deadlines and take-backs. Run sixteen at once on 2 cores, each
/// with its own coordinator and workers, two of them failed now and then:
/// a node file left after Ctrl-C, and a stopped worker whose chunks were
/// all flown elsewhere before its deadline. They run one at a time.
fn serial() -> std::sync::MutexGuard<'static, ()> {
    static ONE: std::sync::Mutex<()> = std::sync::Mutex::new(());
    ONE.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// A run long enough to disturb: landing is made impossible, so it flies
/// exactly 3 × 150 generations of 300 guided genomes.
const LONG: &[&str] = &[
    "--method",
    "guided",
    "--seed",
    "7",
    "--population",
    "300",
    "--max-generations",
    "150",
    "--max-restarts",
    "2",
    "--json",
];

fn never_lands(dir: &Path) -> String {
    let path = dir.join("never-lands.toml");
    fs::write(&path, "[scoring]\nsafe_speed = 0.0\n").unwrap();
    path.to_str().unwrap().to_string()
}

/// Runs `lander run` to the end and returns its summary and its log:
/// `generations.jsonl`, or `episodes.jsonl` for Q-learning.
fn finished(iox: &Iox, out: &Path, extra: &[&str]) -> (Value, Vec<u8>) {
    let mut args = vec!["run", "--out", out.to_str().unwrap()];
    args.extend_from_slice(extra);
    let summary = without_wall_time(json_out(&iox.lander(&args)));
    let log = ["generations.jsonl", "episodes.jsonl"]
        .iter()
        .find_map(|name| fs::read(out.join(name)).ok())
        .expect("the run wrote its log");
    (summary, log)
}

fn start(iox: &Iox, out: &Path, extra: &[&str]) -> Child {
    iox.command("lander")
        .args(["run", "--out", out.to_str().unwrap()])
        .args(extra)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

fn summary_of(child: Child) -> Value {
    let out = child.wait_with_output().unwrap();
    without_wall_time(json_out(&out))
}

/// Whatever the worker count, and whether the coordinator flies a share
/// of each generation itself or leaves it all to the workers.
#[test]
fn results_are_byte_identical_for_0_1_2_and_3_workers() {
    let _one_at_a_time = serial();
    let iox = Iox::new("counts");
    for method in ["ga", "guided"] {
        let args = [
            "--method",
            method,
            "--seed",
            "3",
            "--max-generations",
            "60",
            "--max-restarts",
            "0",
            "--json",
        ];
        let mut runs = Vec::new();
        let counts = [
            ("0", "auto"),
            ("1", "always"),
            ("1", "never"),
            ("2", "auto"),
            ("3", "always"),
        ];
        for (workers, share) in counts {
            let dir = tempfile::tempdir().unwrap();
            let mut a = args.to_vec();
            a.extend(["--workers", workers]);
            if workers != "0" {
                a.extend(["--coordinator-share", share]);
            }
            runs.push(finished(&iox, dir.path(), &a));
        }
        for ((workers, share), run) in counts.iter().zip(&runs).skip(1) {
            let with = format!("{workers} workers, --coordinator-share {share}");
            assert_eq!(run.0, runs[0].0, "{method}: summary with {with} differs");
            assert!(
                run.1 == runs[0].1,
                "{method}: generations.jsonl with {with} differs"
            );
        }
    }
}

#[test]
fn a_clean_run_leaves_no_processes_and_no_files() {
    let _one_at_a_time = serial();
    let iox = Iox::new("clean");
    let dir = tempfile::tempdir().unwrap();
    // Trial 16 flies 557 generations, long enough for both workers to
    // join: a run of a few dozen may end before the second has announced
    // itself.
    let child = start(
        &iox,
        dir.path(),
        &["--seed", "1", "--trial", "16", "--workers", "2", "--json"],
    );
    summary_of(child);
    // The workers as the run's events name them: the run may end before a
    // look at the coordinator's children would find them both.
    let seen = joined(&json_lines(&dir.path().join("events.jsonl")));
    assert_eq!(seen.len(), 2, "two workers were spawned");
    for worker in seen {
        assert!(has_exited(worker), "worker {worker} outlived the run");
    }
    assert_eq!(iox.shm_files(), Vec::<String>::new());
    assert_eq!(iox.root_files(), Vec::<std::path::PathBuf>::new());
}

#[test]
fn ctrl_c_stops_the_run_cleanly_with_what_it_flew_kept() {
    let _one_at_a_time = serial();
    let iox = Iox::new("sigint");
    let dir = tempfile::tempdir().unwrap();
    let cfg = never_lands(dir.path());
    let (child, workers) = under_way(&iox, dir.path(), &["--config", &cfg], 5);
    interrupt(child);
    for worker in workers {
        assert!(has_exited(worker), "worker {worker} outlived the run");
    }
    assert_eq!(iox.shm_files(), Vec::<String>::new());
    assert_eq!(iox.root_files(), Vec::<std::path::PathBuf>::new());
    // Every generation flown before the signal is in the log, whole.
    let log = json_lines(&dir.path().join("generations.jsonl"));
    assert!(log.len() >= 5, "{} generations kept", log.len());
}

/// Starts `lander run` with `args` on two spawned workers, writing to
/// `dir`, and returns it with its workers' pids once `lines` generations
/// are written and both workers have joined.
fn under_way(iox: &Iox, dir: &Path, args: &[&str], lines: usize) -> (Child, Vec<u32>) {
    let mut args = args.to_vec();
    args.extend(["--workers", "2"]);
    let child = start(iox, dir, &args);
    let log = dir.join("generations.jsonl");
    // Both workers joined too: the coordinator flies in place of the one
    // beside it while that one starts, so the run may get going first,
    // and a worker disturbed before it joined leaves no event of its own.
    // (Read while the run writes it: no file yet is no event yet.)
    let both = || joined(&lander_telemetry::events::read(dir).unwrap_or_default()).len() >= 2;
    assert!(
        wait_until(60, || lines_in(&log) >= lines && both()),
        "the run did not get going over both workers"
    );
    let workers = worker_children(child.id());
    assert_eq!(workers.len(), 2);
    (child, workers)
}

/// Spawned workers are told to spin only where no other process of the
/// run needs their CPU: all of them with one worker fewer than the CPUs;
/// with as many workers as CPUs all but the one whose CPU the coordinator
/// shares; without pinning, none. Read from the workers' own command lines.
#[test]
fn spawned_workers_spin_only_with_a_cpu_to_spare() {
    let _one_at_a_time = serial();
    let iox = Iox::new("spin");
    // The CPUs the coordinator counts: those this process may run on.
    let cpus = lander_protocol::host::allowed_cpus().len().max(1);
    let spins = |workers: usize, extra: &[&str]| -> Vec<bool> {
        let dir = tempfile::tempdir().unwrap();
        let cfg = never_lands(dir.path());
        let many = workers.to_string();
        let mut args = LONG.to_vec();
        args.extend(["--config", &cfg, "--workers", &many]);
        args.extend_from_slice(extra);
        let child = start(&iox, dir.path(), &args);
        let log = dir.path().join("generations.jsonl");
        assert!(
            wait_until(60, || lines_in(&log) >= 5),
            "the run did not get going"
        );
        let told: Vec<bool> = worker_children(child.id())
            .iter()
            .map(|pid| {
                let cmdline = fs::read(format!("/proc/{pid}/cmdline")).unwrap_or_default();
                String::from_utf8_lossy(&cmdline).contains("--spin-us")
            })
            .collect();
        signal(child.id(), "INT");
        let out = child.wait_with_output().unwrap();
        assert_eq!(out.status.code(), Some(130), "{}", stderr(&out));
        assert_eq!(told.len(), workers);
        told
    };
    let spinning = |told: Vec<bool>| told.iter().filter(|&&s| s).count();
    assert_eq!(
        spinning(spins(cpus, &[])),
        cpus - 1,
        "as many workers as CPUs: all but the one beside the coordinator"
    );
    assert_eq!(
        spinning(spins(cpus, &["--no-pin"])),
        0,
        "as many workers as CPUs, unpinned"
    );
    if cpus > 1 {
        assert_eq!(spins(cpus - 1, &[]), vec![true; cpus - 1], "a CPU to spare");
    }
}

/// `--coordinator-share always` has the coordinator fly chunks itself,
/// `never` leaves every chunk to the workers: read from its metrics. With
/// a worker on every CPU, `auto` has it fly a single trial's share of the
/// worker on its own CPU.
#[test]
fn the_coordinator_flies_a_share_only_where_told() {
    let _one_at_a_time = serial();
    let iox = Iox::new("share");
    let flown_here = |workers: usize, share: &str| -> (f64, f64) {
        let dir = tempfile::tempdir().unwrap();
        let cfg = never_lands(dir.path());
        let addr = format!("127.0.0.1:{}", free_port());
        let workers = workers.to_string();
        let mut args = LONG.to_vec();
        args.extend(["--config", &cfg, "--workers", &workers]);
        args.extend(["--coordinator-share", share, "--metrics", &addr]);
        let child = start(&iox, dir.path(), &args);
        // A metric summed over its labels, 0 where it is not served yet.
        let counter = |name: &str| -> f64 {
            let text = http_get(&addr, "/metrics").unwrap_or_default();
            text.lines()
                .filter(|l| {
                    l.strip_prefix(name)
                        .is_some_and(|rest| rest.starts_with([' ', '{']))
                })
                .filter_map(|l| l.rsplit(' ').next()?.parse::<f64>().ok())
                .sum()
        };
        // Chunks go out only once the workers have joined, which on a
        // loaded host may take longer than a few generations: count from
        // there.
        let all = workers.parse::<f64>().unwrap();
        assert!(
            wait_until(60, || counter("lander_workers_connected") >= all),
            "the workers did not join"
        );
        let log = dir.path().join("generations.jsonl");
        let joined = lines_in(&log);
        assert!(
            wait_until(60, || lines_in(&log) >= joined + 20),
            "the run did not get going"
        );
        let counts = (
            counter("lander_chunks_flown_here_total"),
            counter("lander_chunks_dispatched_total"),
        );
        interrupt(child);
        counts
    };
    let (here, sent) = flown_here(1, "always");
    assert!(here > 0.0 && sent > 0.0, "always: {here} here, {sent} sent");
    let (here, sent) = flown_here(1, "never");
    assert!(here == 0.0 && sent > 0.0, "never: {here} here, {sent} sent");
    let cpus = lander_protocol::host::allowed_cpus().len();
    if cpus > 1 {
        let (here, sent) = flown_here(cpus, "auto");
        assert!(
            here > 0.0 && sent > 0.0,
            "auto, {cpus} workers: {here} here, {sent} sent"
        );
        let (here, sent) = flown_here(cpus, "never");
        assert!(
            here == 0.0 && sent > 0.0,
            "never, {cpus} workers: {here} here, {sent} sent"
        );
    }
}

/// Runs LONG over two spawned workers, doing `disturb` to them once 40
/// generations are written, and checks the results match an undisturbed
/// in-process run, the pool said `reported`, and `events.jsonl` holds
/// event `event` for each worker `disturb` returns, under its id.
fn survives(
    test: &str,
    extra: &[&str],
    (reported, event): (&str, &str),
    disturb: impl Fn(&[u32]) -> Vec<u32>,
) {
    let iox = Iox::new(test);
    let dir = tempfile::tempdir().unwrap();
    let cfg = never_lands(dir.path());
    let calm_dir = tempfile::tempdir().unwrap();
    let mut calm = LONG.to_vec();
    calm.extend(["--config", &cfg]);
    let expected = finished(&iox, calm_dir.path(), &calm);

    let mut args = calm.clone();
    args.extend_from_slice(extra);
    let (child, workers) = under_way(&iox, dir.path(), &args, 40);
    let log = dir.path().join("generations.jsonl");
    let disturbed = disturb(&workers);
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    let got = (without_wall_time(json_out(&out)), fs::read(&log).unwrap());
    assert_eq!(got.0, expected.0);
    assert!(
        got.1 == expected.1,
        "generations.jsonl differs from the undisturbed run"
    );
    assert_eq!(got.0["generations"], 450);
    assert!(
        stderr(&out).contains(reported),
        "the pool did not report {reported:?}: {}",
        stderr(&out)
    );
    let events = events(dir.path());
    for pid in disturbed {
        let id = worker_id_of(&events, pid).expect("the worker's joining was recorded");
        assert!(
            events
                .iter()
                .any(|e| e["event"] == event && e["worker"] == id.as_str() && e["pid"] == pid),
            "no {event} event for worker {id} (pid {pid}): {events:?}"
        );
    }
    assert_eq!(
        events.first().map(|e| &e["event"]),
        Some(&"run_started".into())
    );
    assert_eq!(
        events.last().map(|e| &e["event"]),
        Some(&"run_finished".into())
    );
}

#[test]
fn a_worker_killed_mid_run_loses_no_work() {
    let _one_at_a_time = serial();
    survives("kill_one", &[], ("exited", "worker_died"), |w| {
        signal(w[0], "KILL");
        vec![w[0]]
    });
}

#[test]
fn every_worker_killed_once_loses_no_work() {
    let _one_at_a_time = serial();
    survives("kill_all", &[], ("exited", "worker_died"), |w| {
        for &pid in w {
            signal(pid, "KILL");
        }
        w.to_vec()
    });
}

#[test]
fn a_hung_worker_misses_its_deadline_and_loses_no_work() {
    let _one_at_a_time = serial();
    survives(
        "hang",
        &["--deadline", "1"],
        ("missed its deadline", "worker_timed_out"),
        |w| {
            signal(w[0], "STOP");
            vec![w[0]]
        },
    );
}

/// A spawned worker that never announces itself (here a `lander-worker`
/// that only sleeps) is stopped once the deadline has passed since its
/// start, and replaced; with every replacement the same, the run ends
/// with an error instead of waiting for ever.
#[test]
fn spawned_workers_that_never_join_end_the_run_with_an_error() {
    let iox = Iox::new("never_join");
    let dir = tempfile::tempdir().unwrap();
    let bin = dir.path().join("bin");
    std::fs::create_dir(&bin).unwrap();
    std::fs::copy(lander_tests::binary("lander"), bin.join("lander")).unwrap();
    lander_tests::ready_to_run(&bin.join("lander"), "--version");
    lander_tests::script(&bin.join("lander-worker"), "exec sleep 30\n");
    let started = std::time::Instant::now();
    // The copy finds the sleeping `lander-worker` beside it.
    let out = iox
        .command_at(&bin.join("lander"))
        .args([
            "run",
            "--workers",
            "1",
            "--deadline",
            "0.5",
            "--max-generations",
            "2",
        ])
        .args(["--out", dir.path().join("out").to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    let said = stderr(&out);
    assert!(said.contains("has not joined within 0.5 s"), "{said}");
    assert!(said.contains("respawns allowed are used up"), "{said}");
    assert!(
        started.elapsed() < std::time::Duration::from_secs(30),
        "{said}"
    );
    // One watching the folder learns how the run ended, and why.
    let events = json_lines(&dir.path().join("out").join("events.jsonl"));
    let last = events.last().expect("no events recorded");
    assert_eq!(last["event"], "run_failed", "{events:?}");
    let error = last["error"].as_str().unwrap_or_default();
    assert!(error.contains("respawns allowed are used up"), "{error}");
    assert!(said.contains(error), "{error} is not what was said: {said}");
}

/// Attached workers come and go: one frozen past its deadline (dropped,
/// it is told so and exits 3 once thawed), one stopped, until none is
/// left; the coordinator says again how to start them, and the one started
/// then finishes the run with the results of an undisturbed one.
#[test]
fn attached_workers_may_leave_mid_run() {
    let _one_at_a_time = serial();
    let iox = Iox::new("attach");
    let dir = tempfile::tempdir().unwrap();
    let cfg = never_lands(dir.path());
    let mut args = LONG.to_vec();
    // Long enough for a deadline to pass with one worker left flying.
    let restarts = args.iter().position(|&a| a == "--max-restarts").unwrap();
    args[restarts + 1] = "20";
    args.extend(["--config", &cfg]);
    let calm_dir = tempfile::tempdir().unwrap();
    let expected = finished(&iox, calm_dir.path(), &args);

    let run_id = format!("attach{}", std::process::id());
    let mut attached = args.clone();
    attached.extend(["--attach", "--run-id", &run_id, "--deadline", "1"]);
    let said = dir.path().join("coordinator.log");
    let coordinator = iox
        .command("lander")
        .args(["run", "--out", dir.path().to_str().unwrap()])
        .args(&attached)
        .stdout(Stdio::piped())
        .stderr(fs::File::create(&said).unwrap())
        .spawn()
        .unwrap();
    let worker = || {
        iox.command("lander-worker")
            .args(["--run", &run_id])
            .stderr(Stdio::piped())
            .spawn()
            .unwrap()
    };
    let (first, second) = (worker(), worker());
    let log = dir.path().join("generations.jsonl");
    assert!(
        wait_until(60, || lines_in(&log) >= 40),
        "the run did not get going"
    );
    signal(second.id(), "STOP");
    let coordinator_said = || fs::read_to_string(&said).unwrap_or_default();
    let dropped = wait_until(60, || coordinator_said().contains("missed its deadline"));
    signal(second.id(), "CONT");
    assert!(dropped, "no deadline missed: {}", coordinator_said());
    ended_saying(second, 3, "the coordinator dropped this worker");
    signal(first.id(), "TERM");
    // A worker stops cleanly on SIGTERM.
    ended_saying(first, 0, "stopped by signal");
    let told = || fs::read_to_string(&said).map_or(0, |t| t.matches("waiting for workers").count());
    assert!(
        wait_until(60, || told() >= 2),
        "the coordinator did not say again that it waits: {:?}",
        fs::read_to_string(&said)
    );

    let third = worker();
    let out = coordinator.wait_with_output().unwrap();
    let said = fs::read_to_string(&said).unwrap();
    assert!(out.status.success(), "{said}");
    assert!(said.contains(&format!("lander-worker --run {run_id}")));
    assert_eq!(without_wall_time(json_out(&out)), expected.0);
    assert!(fs::read(&log).unwrap() == expected.1);
    ended_saying(third, 0, "run finished");
}

/// Starts a worker for `run`, which no coordinator has started, and waits
/// until it says it is waiting. Returns it and what it says so far, read
/// again on each call, from a file in `dir`.
fn waiting_worker(iox: &Iox, dir: &Path, run: &str) -> (Child, impl Fn() -> String) {
    let err = dir.join("stderr");
    let child = iox
        .command("lander-worker")
        .args(["--run", run])
        .stderr(fs::File::create(&err).unwrap())
        .spawn()
        .unwrap();
    let said = move || fs::read_to_string(&err).unwrap_or_default();
    assert!(
        wait_until(10, || said().contains(&format!("waiting for run {run}"))),
        "{}",
        said()
    );
    (child, said)
}

#[test]
fn a_worker_for_a_missing_run_waits_and_says_so() {
    let _one_at_a_time = serial();
    let iox = Iox::new("missing");
    let dir = tempfile::tempdir().unwrap();
    let (child, _) = waiting_worker(&iox, dir.path(), "nosuchrun");
    std::thread::sleep(std::time::Duration::from_millis(300));
    signal(child.id(), "TERM");
    let status = child.wait_with_output().unwrap().status;
    assert!(
        status.success(),
        "it waits rather than crashing, and stops cleanly"
    );
}

#[test]
fn a_spawned_worker_whose_coordinator_died_before_it_joined_stops() {
    let _one_at_a_time = serial();
    let iox = Iox::new("orphan");
    let dir = tempfile::tempdir().unwrap();
    let err = dir.path().join("stderr");
    // A shell stands for the coordinator: it starts the worker as a
    // coordinator does (`--parent` its own pid), for a run that never
    // starts, and dies once the worker waits for it (or after 10 s).
    let worker = iox.command("lander-worker");
    let out = std::process::Command::new("sh")
        .envs(worker.get_envs().filter_map(|(k, v)| Some((k, v?))))
        .env("SAID", &err)
        .args([
            "-c",
            r#""$0" "$@" --parent $$ >/dev/null & echo $!
               i=0
               until grep -q "waiting for run" "$SAID" || [ $i -ge 100 ]; do
                 sleep 0.1; i=$((i + 1))
               done"#,
        ])
        .arg(worker.get_program())
        .args(["--run", "orphaned"])
        .stderr(fs::File::create(&err).unwrap())
        .output()
        .unwrap();
    let pid: u32 = String::from_utf8(out.stdout)
        .unwrap()
        .trim()
        .parse()
        .unwrap();
    let said = || fs::read_to_string(&err).unwrap_or_default();
    assert!(said().contains("waiting for run orphaned"), "{}", said());
    assert!(
        wait_until(10, || has_exited(pid)),
        "the orphan still runs: {}",
        said()
    );
    assert!(said().contains("is gone; stopping"), "{}", said());
    assert_eq!(iox.root_files(), Vec::<std::path::PathBuf>::new());
    assert_eq!(iox.shm_files(), Vec::<String>::new());
}

#[test]
fn a_worker_whose_coordinator_is_gone_as_it_starts_stops_cleanly() {
    let _one_at_a_time = serial();
    let iox = Iox::new("gone");
    // Pid 1 is not the worker's parent (this test is), so the worker finds
    // its coordinator gone at its first look, as one spawned by a
    // coordinator killed at once would. `--metrics` widens the window
    // between that look and the worker's own start.
    for _ in 0..5 {
        let out = iox
            .command("lander-worker")
            .args(["--run", "gone", "--parent", "1", "--metrics", "127.0.0.1:0"])
            .output()
            .unwrap();
        let said = String::from_utf8_lossy(&out.stderr);
        assert!(
            out.status.success(),
            "it stops as asked, not killed by its own SIGTERM: {:?}: {said}",
            out.status
        );
        assert!(
            said.contains("the coordinator is gone after 0 jobs"),
            "{said}"
        );
    }
    assert_eq!(iox.root_files(), Vec::<std::path::PathBuf>::new());
    assert_eq!(iox.shm_files(), Vec::<String>::new());
}

#[test]
fn a_worker_stopped_and_resumed_keeps_waiting_until_sigint() {
    let _one_at_a_time = serial();
    let iox = Iox::new("resumed");
    let dir = tempfile::tempdir().unwrap();
    let (mut worker, said) = waiting_worker(&iox, dir.path(), "notyet");
    // A stop and a resume cut the worker's sleep short (EINTR); that is no
    // reason to leave (Ctrl-Z and `fg` in its terminal do the same). The
    // serving loop's wait is covered by tests/rebalance.rs.
    signal(worker.id(), "STOP");
    std::thread::sleep(std::time::Duration::from_millis(300));
    signal(worker.id(), "CONT");
    std::thread::sleep(std::time::Duration::from_millis(700));
    assert!(
        worker.try_wait().unwrap().is_none(),
        "the worker left after SIGCONT: {}",
        said()
    );
    signal(worker.id(), "INT");
    assert!(worker.wait().unwrap().success(), "{}", said());
    assert!(said().contains("stopped by signal"), "{}", said());
}

#[test]
fn bad_worker_options_are_refused() {
    let _one_at_a_time = serial();
    let iox = Iox::new("badopts");
    for (args, needle) in [
        (vec!["run", "--workers", "two"], "--workers"),
        (
            vec!["run", "--workers", "-1"],
            "invalid value '-1' for '--workers <N>'",
        ),
        (vec!["run", "--workers", "1000"], "at most 128"),
        (vec!["run", "--workers", "2", "--attach"], "--attach"),
        (vec!["run", "--attach", "--run-id", "bad id!"], "--run-id"),
        (
            vec!["run", "--workers", "1", "--deadline", "0"],
            "--deadline",
        ),
        // Past what a Duration holds: refused, not a panic.
        (
            vec!["run", "--workers", "1", "--deadline", "1e99"],
            "at most 86400 seconds",
        ),
        (
            vec!["run", "--threads", "5000"],
            "invalid value '5000' for '--threads <THREADS>': 5000 is not in 0..=1024",
        ),
        (
            vec!["run", "--workers", "1", "--spin-us", "20000"],
            "--spin-us must be at most 10000",
        ),
        // In-process, where nothing spins, it is refused all the same.
        (
            vec!["run", "--spin-us", "20000"],
            "--spin-us must be at most 10000",
        ),
        (vec!["bench", "--spin-us", "20000"], "--spin-us"),
        (
            vec!["bench", "--transports", "inproc,iceoryx2,inproc"],
            "--transports names \"inproc\" twice",
        ),
        (
            vec!["run", "--workers", "1", "--users", "u.txt"],
            "--users is for --transport zenoh",
        ),
        (
            vec!["run", "--workers", "1", "--listen", "tcp/0.0.0.0:1"],
            "--listen is for",
        ),
        (
            vec![
                "run",
                "--workers",
                "1",
                "--transport",
                "zenoh",
                "--listen",
                "tcp/127.0.0.1:0",
            ],
            "tcp/127.0.0.1:0 (--listen or --zenoh-config): port 0 leaves the workers",
        ),
        (
            vec!["bench", "--stress", "--kill-rate", "1e308"],
            "--kill-rate must be 0 to 100",
        ),
        // Not ignored without the mode they belong to.
        (
            vec!["bench", "--kill-rate", "5"],
            "--kill-rate applies only to --stress",
        ),
        (
            vec!["bench", "--soak", "5"],
            "--soak applies only to --stress",
        ),
        (
            vec!["bench", "--transports", "inproc", "--verify", "0.5"],
            "--verify applies only to the worker-process modes",
        ),
        (
            vec![
                "bench",
                "--transports",
                "inproc",
                "--chunks-per-worker",
                "7",
            ],
            "--chunks-per-worker applies only to the worker-process modes",
        ),
        (
            vec![
                "bench",
                "--transports",
                "inproc",
                "--coordinator-share",
                "never",
            ],
            "--coordinator-share applies only",
        ),
        (
            vec!["bench", "--transports", "inproc", "--no-pin"],
            "--no-pin applies only",
        ),
        (
            vec!["bench", "--transports", "inproc,iceoryx2", "--listen", "x"],
            "--listen applies only to --transports zenoh",
        ),
        (
            vec![
                "bench",
                "--transports",
                "zenoh",
                "--listen",
                "tcp/127.0.0.1:0",
            ],
            "port 0 leaves the workers no port",
        ),
        (
            vec!["bench", "--transports", "inproc", "--verify", "NaN"],
            "--verify must be a share from 0 to 1",
        ),
        (
            vec!["run", "--workers", "1", "--coordinator-share", "sometimes"],
            "--coordinator-share",
        ),
        (
            vec!["run", "--coordinator-share", "always"],
            "--coordinator-share needs --workers or --attach",
        ),
    ] {
        let out = iox.lander(&args);
        assert!(!out.status.success(), "{args:?} was accepted");
        assert!(stderr(&out).contains(needle), "{args:?}: {}", stderr(&out));
    }
    let out = iox
        .command("lander-worker")
        .args(["--run", "a/b"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(stderr(&out).contains("--run"));
    let long = "a".repeat(65);
    for (args, needle) in [
        (vec!["--run", &long], "1 to 64"),
        // A spin past what an Instant can add: refused, not a panic.
        (
            vec!["--run", "somerun", "--spin-us", "18446744073709551615"],
            "--spin-us",
        ),
        (
            vec!["--run", "somerun", "--credentials", "c.txt"],
            "--credentials is for --transport zenoh",
        ),
        // A worker that rejoins takes a new id each time.
        (
            vec!["--run", "somerun", "--rejoin", "--id", "5"],
            "'--rejoin' cannot be used with '--id <HEX>'",
        ),
    ] {
        let out = iox.command("lander-worker").args(&args).output().unwrap();
        assert!(!out.status.success(), "{args:?} was accepted");
        assert!(stderr(&out).contains(needle), "{args:?}: {}", stderr(&out));
    }
    let out = iox
        .command("lander-worker")
        .args(["--run", "somerun", "--cpu", "100000"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(stderr(&out).contains("--cpu 100000"), "{}", stderr(&out));
}

#[test]
fn an_unusable_iceoryx2_folder_is_named_with_its_variable() {
    let _one_at_a_time = serial();
    let iox = Iox::new("badroot");
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("a-file");
    std::fs::write(&file, "").unwrap();
    for root in [
        file.clone(),
        file.join("below"),
        "".into(),
        "relative".into(),
    ] {
        let out = iox
            .command("lander")
            .args(["run", "--workers", "1", "--out"])
            .arg(dir.path().join("out"))
            .env("LANDER_IOX2_ROOT", &root)
            .output()
            .unwrap();
        assert!(!out.status.success(), "{root:?} was accepted");
        let err = stderr(&out);
        assert!(
            err.contains(&format!("{:?}", root.display().to_string()))
                && err.contains("LANDER_IOX2_ROOT"),
            "{err}"
        );
    }
    // Bytes that are not UTF-8 are refused, not taken for the default.
    use std::os::unix::ffi::OsStrExt;
    for var in ["LANDER_IOX2_ROOT", "LANDER_IOX2_PREFIX"] {
        let out = iox
            .command("lander")
            .args(["run", "--workers", "1", "--out"])
            .arg(dir.path().join("out"))
            .env(var, std::ffi::OsStr::from_bytes(b"/tmp/\xff"))
            .output()
            .unwrap();
        assert!(!out.status.success(), "{var} was accepted");
        let err = stderr(&out);
        assert!(err.contains(var) && err.contains("is not UTF-8"), "{err}");
    }
}

#[test]
fn bench_compares_the_modes_and_their_results_agree() {
    let _one_at_a_time = serial();
    let iox = Iox::new("bench");
    let out = iox.lander(&[
        "bench",
        "--generations",
        "3",
        "--rounds",
        "2",
        "--population",
        "30",
        "--json",
    ]);
    let report = json_out(&out);
    let names: Vec<&str> = report["modes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["inproc-1", "inproc-2", "iceoryx2-1", "iceoryx2-2"]);
    assert_eq!(report["hashes_agree"], true);
    for m in report["modes"].as_array().unwrap() {
        assert!(m["genomes_per_s"].as_f64().unwrap() > 0.0);
        assert!(m["ticks_per_s"].as_f64().unwrap() > 0.0);
        let ipc = m["name"].as_str().unwrap().starts_with("iceoryx2");
        assert_eq!(m["rtt_p50_us"].is_number(), ipc, "{m}");
        assert_eq!(m["rtt_p99_us"].is_number(), ipc, "{m}");
        assert_eq!(m["generation"].is_object(), ipc, "{m}");
        if ipc {
            // Each chunk's overhead is at most its round trip, so the p99s
            // keep that order; workers' stamps are on this host's clock.
            let f = |k: &str| m[k].as_f64().unwrap();
            assert!(f("overhead_p99_us") <= f("rtt_p99_us"), "{m}");
            let g = |k: &str| m["generation"][k].as_f64().unwrap();
            let parts = ["coordinator_us", "start_us", "compute_us"]
                .into_iter()
                .chain(["between_us", "waiting_us", "tail_us"]);
            let sum: f64 = parts.clone().map(g).sum();
            assert!((sum - g("wall_us")).abs() < 1e-6 * g("wall_us"), "{m}");
            assert!(parts.map(g).all(|v| v >= 0.0), "{m}");
            assert!(g("compute_us") > 0.0, "{m}");
        }
    }
    assert!(report["ratios"]["scaling"].as_f64().unwrap() > 0.0);
    assert!(report["ratios"]["ipc_efficiency"].as_f64().unwrap() > 0.0);
    // The compute-alone ceiling: one worker's compute per generation over
    // the mean per worker with two.
    let compute = |i: usize| {
        report["modes"][i]["generation"]["compute_us"]
            .as_f64()
            .unwrap()
    };
    let ceiling = report["ratios"]["compute_scaling"].as_f64().unwrap();
    assert!((ceiling - compute(2) / compute(3)).abs() < 1e-9, "{report}");
    let bad = iox.lander(&["bench", "--transports", "carrier-pigeon"]);
    assert!(!bad.status.success());
    assert!(stderr(&bad).contains("--transports"));
    let bad = iox.lander(&["bench", "--stress", "--chunks-per-worker", "2"]);
    assert!(!bad.status.success());
    assert!(stderr(&bad).contains("--chunks-per-worker"));
    let bad = iox.lander(&["bench", "--chunks-per-worker", "0"]);
    assert!(!bad.status.success());
    assert!(
        stderr(&bad).contains("--chunks-per-worker"),
        "{}",
        stderr(&bad)
    );
}

/// `--in-flight` evaluates a generation of several trials as one step, as
/// an experiment does: every mode agrees on it, and it is more work than one
/// trial's generation, not the same work counted again.
#[test]
fn bench_steps_trials_in_flight_together_and_their_results_agree() {
    let _one_at_a_time = serial();
    let iox = Iox::new("bench_in_flight");
    let bench = |in_flight: &str| {
        json_out(&iox.lander(&[
            "bench",
            "--in-flight",
            in_flight,
            "--generations",
            "2",
            "--rounds",
            "1",
            "--population",
            "20",
            "--json",
        ]))
    };
    let (one, three) = (bench("1"), bench("3"));
    assert_eq!(three["in_flight"], 3);
    assert_eq!(three["hashes_agree"], true);
    let hashes = |r: &serde_json::Value| -> Vec<String> {
        r["modes"]
            .as_array()
            .unwrap()
            .iter()
            .map(|m| m["hash"].as_str().unwrap().to_string())
            .collect()
    };
    assert!(hashes(&three).windows(2).all(|w| w[0] == w[1]));
    assert_ne!(hashes(&one)[0], hashes(&three)[0]);
    // 20 genomes × 2 generations × 1 round, per trial in flight.
    for (report, trials) in [(&one, 1), (&three, 3)] {
        for m in report["modes"].as_array().unwrap() {
            assert_eq!(m["genomes"], 40 * trials, "{m}");
        }
    }
    for (args, needle) in [
        (vec!["bench", "--stress", "--in-flight", "2"], "--in-flight"),
        (vec!["bench", "--in-flight", "0"], "--in-flight"),
    ] {
        let out = iox.lander(&args);
        assert!(!out.status.success(), "{args:?} was accepted");
        assert!(stderr(&out).contains(needle), "{args:?}: {}", stderr(&out));
    }
}

#[test]
fn stress_kills_workers_and_loses_nothing() {
    let _one_at_a_time = serial();
    let iox = Iox::new("stress");
    // Kills come at random, about `--kill-rate` a second, and the run
    // lasts about 0.4 s: at 20 a second runs saw 1 to 9 kills and some
    // none at all; at 60, 11 to 17.
    let out = iox.lander(&[
        "bench",
        "--stress",
        "--population",
        "3000",
        "--generations",
        "20",
        "--kill-rate",
        "60",
        "--json",
    ]);
    let report = json_out(&out);
    assert_eq!(report["results_match"], true);
    assert_eq!(report["evaluated"], 60_000);
    assert_eq!(report["expected"], 60_000);
    assert!(
        report["kills"].as_u64().unwrap() >= 1,
        "no worker was killed: {report}"
    );
}

#[test]
fn qlearning_over_workers_matches_in_process_even_when_its_worker_dies() {
    let _one_at_a_time = serial();
    let iox = Iox::new("qlearn");
    // Long enough to be killed in the middle: about 0.8 s of learning,
    // against the 50 ms of CPU time the kill below waits for.
    let args = ["--method", "qlearning", "--episodes", "64000", "--json"];
    let calm_dir = tempfile::tempdir().unwrap();
    let (expected, calm_log) = finished(&iox, calm_dir.path(), &args);

    let dir = tempfile::tempdir().unwrap();
    let mut a = args.to_vec();
    a.extend(["--workers", "2"]);
    let over = finished(&iox, dir.path(), &a);
    assert_eq!(over.0, expected);
    assert!(over.1 == calm_log, "episodes.jsonl differs over workers");

    // One worker holds the trial (the coordinator, sharing, takes only
    // what finds no room at a worker); kill the worker while it learns.
    let dir = tempfile::tempdir().unwrap();
    let mut a = args.to_vec();
    a.extend(["--workers", "1", "--coordinator-share", "always"]);
    let child = start(&iox, dir.path(), &a);
    let mut workers = Vec::new();
    assert!(wait_until(20, || {
        workers = worker_children(child.id());
        !workers.is_empty()
    }));
    // Killed once it has learned for a while, by its own CPU time: a wall
    // clock delay raced with the trial's end on a quiet machine.
    assert!(wait_until(20, || cpu_ms(workers[0]) >= 50));
    signal(workers[0], "KILL");
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stderr(&out).contains("exited"), "{}", stderr(&out));
    assert_eq!(without_wall_time(json_out(&out)), expected);
    assert!(fs::read(dir.path().join("episodes.jsonl")).unwrap() == calm_log);
}

/// The CPU time process `pid` has used, in milliseconds (0 once it is gone).
fn cpu_ms(pid: u32) -> u64 {
    let Ok(stat) = fs::read_to_string(format!("/proc/{pid}/stat")) else {
        return 0;
    };
    // After the command's closing parenthesis: state is field 3, utime and
    // stime fields 14 and 15, in clock ticks (100 a second on Linux).
    let fields: Vec<&str> = stat
        .rsplit_once(')')
        .map_or(Vec::new(), |(_, rest)| rest.split_whitespace().collect());
    let ticks = |i: usize| fields.get(i - 3).and_then(|v| v.parse::<u64>().ok());
    (ticks(14).unwrap_or(0) + ticks(15).unwrap_or(0)) * 10
}

/// The CPUs process `pid` may run on, as /proc lists them ("0-1", "3").
fn cpus_of(pid: &str) -> String {
    fs::read_to_string(format!("/proc/{pid}/status"))
        .unwrap()
        .lines()
        .find_map(|l| l.strip_prefix("Cpus_allowed_list:"))
        .expect("/proc status lists the allowed CPUs")
        .trim()
        .to_string()
}

/// The scheduling policy of process `pid`: 0 normal, 3 batch (field 41 of
/// /proc/PID/stat, counting from 1; the name in field 2 may hold spaces).
fn policy_of(pid: u32) -> u32 {
    let stat = fs::read_to_string(format!("/proc/{pid}/stat")).unwrap();
    let (_, tail) = stat.rsplit_once(')').unwrap();
    tail.split_whitespace()
        .nth(41 - 3)
        .unwrap()
        .parse()
        .unwrap()
}

/// Starts a long run with `extra` flags and returns what its two workers
/// were given once it is under way: their CPUs and scheduling policies.
/// The CPUs of the coordinator's main thread (which runs the pool) and,
/// for each worker, its CPUs and scheduling policy, read during a run.
fn workers_placement(iox: &Iox, extra: &[&str]) -> (String, Vec<(String, u32)>) {
    let dir = tempfile::tempdir().unwrap();
    let cfg = never_lands(dir.path());
    let mut args = LONG.to_vec();
    args.extend(["--config", &cfg]);
    args.extend_from_slice(extra);
    let (child, workers) = under_way(iox, dir.path(), &args, 5);
    let coordinator = cpus_of(&child.id().to_string());
    let placement = workers
        .iter()
        .map(|&w| (cpus_of(&w.to_string()), policy_of(w)))
        .collect();
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    (coordinator, placement)
}

#[test]
fn spawned_workers_get_a_cpu_each_and_the_batch_class() {
    let _one_at_a_time = serial();
    let iox = Iox::new("placement");
    let everywhere = cpus_of("self");
    let (coordinator, pinned) = workers_placement(&iox, &[]);
    let (coordinator_free, free) = workers_placement(&iox, &["--no-pin"]);
    assert_eq!(
        coordinator_free, everywhere,
        "--no-pin pinned the coordinator"
    );
    for (_, policy) in pinned.iter().chain(&free) {
        assert_eq!(
            *policy, 3,
            "a worker is not in the batch class (SCHED_BATCH)"
        );
    }
    for (cpus, _) in &free {
        assert_eq!(cpus, &everywhere, "--no-pin still pinned a worker");
    }
    let n = std::thread::available_parallelism().map_or(1, |n| n.get());
    if n < 2 {
        eprintln!("only {n} CPU here: two workers are not pinned, as designed");
        assert_eq!(pinned, free);
        return;
    }
    let (a, b) = (&pinned[0].0, &pinned[1].0);
    for cpus in [a, b] {
        assert!(
            cpus.parse::<usize>().is_ok(),
            "a worker may run on {cpus}, not on one CPU"
        );
    }
    assert_ne!(a, b, "both workers were pinned to CPU {a}");
    if n == 2 {
        // A worker on every CPU: the coordinator's thread shares one
        // worker's CPU (the last spawned), leaving the other's to it alone.
        assert!(
            coordinator == *a || coordinator == *b,
            "the coordinator runs on {coordinator}, beside neither worker ({a}, {b})"
        );
    } else {
        assert_eq!(
            coordinator, everywhere,
            "a CPU to spare: the coordinator is free"
        );
    }
}

#[test]
fn a_second_coordinator_of_a_running_run_id_is_refused() {
    let _one_at_a_time = serial();
    let iox = Iox::new("dupid");
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("first.log");
    let mut first = iox
        .command("lander")
        .args(["run", "--attach", "--run-id", "dup", "--out"])
        .arg(dir.path().join("first"))
        .stdout(Stdio::null())
        .stderr(fs::File::create(&log).unwrap())
        .spawn()
        .unwrap();
    // Waiting for workers, the first has its run's services open.
    let waiting = wait_until(30, || {
        fs::read_to_string(&log).is_ok_and(|t| t.contains("waiting for workers"))
    });
    let second = waiting.then(|| {
        iox.command("lander")
            .args(["run", "--attach", "--run-id", "dup", "--out"])
            .arg(dir.path().join("second"))
            .output()
            .unwrap()
    });
    // The first is unaffected: a worker attached to it, it flies its run.
    let mut worker = iox
        .command("lander-worker")
        .args(["--run", "dup"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let finished = wait_until(60, || first.try_wait().unwrap().is_some());
    if !finished {
        lander_tests::signal(first.id(), "INT");
    }
    let status = first.wait().unwrap();
    let _ = worker.kill();
    let _ = worker.wait();
    assert!(
        waiting,
        "the first never waited: {:?}",
        fs::read_to_string(&log)
    );
    let second = second.unwrap();
    let said = stderr(&second);
    assert!(!second.status.success(), "{said}");
    assert!(
        said.contains(&format!("another coordinator (process {})", first.id()))
            && said.contains("--run-id"),
        "{said}"
    );
    assert!(
        finished && status.success(),
        "the first did not finish its run: {:?}",
        fs::read_to_string(&log)
    );
    assert!(dir.path().join("first/best.json").exists());
}

/// A Ctrl-C reaches spawned workers too, at any moment of their start. A
/// worker signalled while it made its node left that node's files half
/// written, for good (3 of 60 starts signalled 0–12 ms in); now each one
/// either dies before it has begun or stops cleanly.
#[test]
fn a_worker_signalled_as_it_starts_leaves_no_iceoryx2_file() {
    let iox = Iox::new("start_signal");
    for i in 0..60u64 {
        let worker = iox
            .command("lander-worker")
            .args(["--run", "startsignal", "--quiet"])
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(std::time::Duration::from_micros(i * 200));
        signal(worker.id(), "INT");
        let mut worker = worker;
        worker.wait().unwrap();
        assert_eq!(
            iox.root_files(),
            Vec::<std::path::PathBuf>::new(),
            "iceoryx2 files left by a worker signalled {} µs after its start",
            i * 200
        );
    }
}

/// A Q(λ) agent of 2^24 weights has a state that no network frame is sure
/// to hold: over workers, a run or an experiment whose state would travel
/// between legs is refused up front, naming the field, before any trial
/// of the experiment runs.
#[test]
fn a_learner_too_large_to_travel_between_legs_is_refused_up_front() {
    let _one = serial();
    let iox = Iox::new("q24");
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("q24.toml");
    fs::write(
        &cfg,
        "method = \"qlearning\"\n[qlearning]\nmemory_bits = 24\nepisodes = 300\n",
    )
    .unwrap();
    let run = iox
        .command("lander")
        .args(["run", "--workers", "1", "--checkpoint-every", "100"])
        .arg("--config")
        .arg(&cfg)
        .arg("--out")
        .arg(dir.path().join("run"))
        .output()
        .unwrap();
    assert!(!run.status.success());
    let said = stderr(&run);
    assert!(said.contains("qlearning.memory_bits = 24"), "{said}");
    assert!(said.contains("in-process"), "{said}");
    assert!(
        !said.contains("panicked") && !said.contains("--resume"),
        "{said}"
    );
    // Refused before the folder is touched: nothing to resume or clear
    // before the corrected command.
    assert!(!dir.path().join("run").exists());

    let exp = dir.path().join("exp.toml");
    fs::write(
        &exp,
        "name = \"q24\"\nseed = 1\ntrials = 1\nmethods = [\"ga\", \"qlearning\"]\n\
         [qlearning]\nmemory_bits = 24\nepisodes = 1000000\n",
    )
    .unwrap();
    let out = dir.path().join("exp");
    let experiment = iox
        .command("lander")
        .args(["experiment", "--workers", "1"])
        .arg(&exp)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(!experiment.status.success());
    let said = stderr(&experiment);
    assert!(said.contains("qlearning.memory_bits = 24"), "{said}");
    assert!(said.contains("legs"), "{said}");
    assert!(!said.contains("--resume"), "a refusal, not a stop: {said}");
    assert!(
        !out.exists(),
        "the refused experiment wrote {}",
        out.display()
    );
}
