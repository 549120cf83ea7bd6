//! The evaluator pool over zenoh between real processes and real sessions
//! on loopback: identical results to iceoryx2 and in-process, no lost work
//! when a worker dies, a liar refused and told so, strangers
//! without credentials kept out, and malformed frames refused by a worker
//! that serves on.

use lander_tests::{
    ended_saying, ended_within, json_out, lines_in, signal, stderr, wait_until, without_wall_time,
    worker_children, Iox, KillOnDrop,
};
use serde_json::Value;
use std::fs;
use std::path::Path;
use std::process::{Child, Stdio};

/// A guided run that cannot land, so it flies exactly 3 × 150 generations.
const LONG: &[&str] = &[
    "--method",
    "guided",
    "--seed",
    "5",
    "--population",
    "300",
    "--max-generations",
    "150",
    "--max-restarts",
    "2",
    "--json",
];

/// A loopback endpoint no other test uses.
fn endpoint(test: u16) -> String {
    let port = 20_000 + (std::process::id() % 2_000) as u16 * 10 + test;
    format!("tcp/127.0.0.1:{port}")
}

fn never_lands(dir: &Path) -> String {
    let path = dir.join("never-lands.toml");
    fs::write(&path, "[scoring]\nsafe_speed = 0.0\n").unwrap();
    path.to_str().unwrap().to_string()
}

fn start(iox: &Iox, out: &Path, args: &[&str]) -> Child {
    iox.command("lander")
        .args(["run", "--out", out.to_str().unwrap()])
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// `args` for a coordinator that waits for zenoh workers to attach to run
/// `run_id` at `ep`.
fn attached<'a>(args: &[&'a str], run_id: &'a str, ep: &'a str) -> Vec<&'a str> {
    let mut all = args.to_vec();
    all.extend([
        "--attach",
        "--run-id",
        run_id,
        "--transport",
        "zenoh",
        "--listen",
        ep,
    ]);
    all
}

/// A `lander-worker` that attaches to run `run_id` at `ep` over zenoh.
fn zenoh_worker(iox: &Iox, run_id: &str, ep: &str) -> std::process::Command {
    let mut worker = iox.command("lander-worker");
    worker
        .args(["--run", run_id, "--transport", "zenoh", "--connect", ep])
        .stderr(Stdio::piped());
    worker
}

/// The summary without wall time, and `generations.jsonl`.
fn results(out: &std::process::Output, dir: &Path) -> (Value, Vec<u8>) {
    assert!(out.status.success(), "{}", stderr(out));
    (
        without_wall_time(json_out(out)),
        fs::read(dir.join("generations.jsonl")).unwrap(),
    )
}

fn expected(iox: &Iox, args: &[&str]) -> (Value, Vec<u8>) {
    let dir = tempfile::tempdir().unwrap();
    let out = start(iox, dir.path(), args).wait_with_output().unwrap();
    results(&out, dir.path())
}

#[test]
fn zenoh_matches_iceoryx2_and_in_process() {
    let iox = Iox::new("zenoh_same");
    let args = [
        "--method",
        "ga",
        "--seed",
        "3",
        "--population",
        "60",
        "--max-generations",
        "80",
        "--json",
    ];
    let inproc = expected(&iox, &args);
    let mut ipc = args.to_vec();
    ipc.extend(["--workers", "2"]);
    assert_eq!(expected(&iox, &ipc), inproc);
    let ep = endpoint(0);
    let mut net = args.to_vec();
    net.extend(["--workers", "2", "--transport", "zenoh", "--listen", &ep]);
    assert_eq!(expected(&iox, &net), inproc);
}

#[test]
fn a_zenoh_worker_killed_mid_run_loses_no_work() {
    let iox = Iox::new("zenoh_kill");
    let dir = tempfile::tempdir().unwrap();
    let cfg = never_lands(dir.path());
    let mut args = LONG.to_vec();
    args.extend(["--config", &cfg]);
    let calm = expected(&iox, &args);

    let ep = endpoint(1);
    args.extend(["--workers", "2", "--transport", "zenoh", "--listen", &ep]);
    let child = start(&iox, dir.path(), &args);
    let log = dir.path().join("generations.jsonl");
    assert!(
        wait_until(60, || lines_in(&log) >= 20),
        "the run did not get going"
    );
    let workers = worker_children(child.id());
    assert_eq!(workers.len(), 2);
    signal(workers[0], "KILL");
    let out = child.wait_with_output().unwrap();
    let got = results(&out, dir.path());
    assert_eq!(got.0, calm.0);
    assert!(
        got.1 == calm.1,
        "generations.jsonl differs from the undisturbed run"
    );
    assert_eq!(got.0["generations"], 450);
    assert!(stderr(&out).contains("exited"), "{}", stderr(&out));
}

#[test]
fn a_worker_with_wrong_credentials_is_refused_and_the_run_is_unaffected() {
    let iox = Iox::new("zenoh_auth");
    let dir = tempfile::tempdir().unwrap();
    let cfg = never_lands(dir.path());
    let mut args = LONG.to_vec();
    args.extend(["--config", &cfg]);
    let calm = expected(&iox, &args);

    let users = dir.path().join("users.txt");
    fs::write(&users, "worker:correct-horse\n").unwrap();
    let good = dir.path().join("good.txt");
    fs::write(&good, "worker:correct-horse\n").unwrap();
    let bad = dir.path().join("bad.txt");
    fs::write(&bad, "worker:battery-staple\n").unwrap();

    let ep = endpoint(2);
    let run_id = format!("auth{}", std::process::id());
    let mut coordinator_args = attached(&args, &run_id, &ep);
    coordinator_args.extend(["--users", users.to_str().unwrap()]);
    let out_dir = dir.path().join("run");
    let coordinator = start(&iox, &out_dir, &coordinator_args);
    let worker = |creds: &Path| {
        zenoh_worker(&iox, &run_id, &ep)
            .args(["--credentials", creds.to_str().unwrap()])
            .spawn()
            .unwrap()
    };
    let stranger_log = dir.path().join("stranger.log");
    let stranger = zenoh_worker(&iox, &run_id, &ep)
        .args(["--credentials", bad.to_str().unwrap()])
        // Its own log, as a user sees it.
        .env_remove("RUST_LOG")
        .stderr(fs::File::create(&stranger_log).unwrap())
        .spawn()
        .unwrap();
    let member = worker(&good);
    let out = coordinator.wait_with_output().unwrap();
    let got = results(&out, &out_dir);
    assert_eq!(got.0, calm.0);
    assert!(got.1 == calm.1);

    ended_saying(member, 0, "serving run");
    // Its attempt refused, the stranger says so (a signal during an
    // attempt stops it before it ends).
    let said = || fs::read_to_string(&stranger_log).unwrap_or_default();
    let refused = wait_until(60, || said().contains("cannot reach a coordinator"));
    signal(stranger.id(), "TERM");
    stranger.wait_with_output().unwrap();
    let said = said();
    assert!(!said.contains("serving run"), "the stranger joined: {said}");
    assert!(refused, "{said}");
    // Once, in its own words, not in zenoh's at every attempt.
    assert!(said.contains("are the credentials right?"), "{said}");
    assert_eq!(said.matches("cannot reach").count(), 1, "{said}");
    assert!(!said.contains("OpenSyn"), "zenoh's internals: {said}");
}

/// How many jobs a worker said it answered as it left.
fn jobs_answered(said: &str) -> u64 {
    let (_, after) = said
        .split_once("run finished after ")
        .unwrap_or_else(|| panic!("the worker did not see the run finish: {said}"));
    let jobs = after.split_whitespace().next().unwrap_or_default();
    jobs.parse()
        .unwrap_or_else(|_| panic!("no job count in: {said}"))
}

/// A liar over zenoh, every answer checked: refused and told so (it exits
/// 4, saying so), and the results those of in-process; the
/// honest worker is told the run finished.
#[test]
fn a_zenoh_liar_is_told_it_was_refused_and_the_results_stand() {
    let iox = Iox::new("zenoh_liar");
    let args = [
        "--method",
        "guided",
        "--seed",
        "3",
        "--population",
        "60",
        "--max-generations",
        "20",
        "--max-restarts",
        "0",
        "--json",
    ];
    let calm = expected(&iox, &args);
    let dir = tempfile::tempdir().unwrap();
    let ep = endpoint(5);
    let run_id = format!("liar{}", std::process::id());
    let mut coordinator_args = attached(&args, &run_id, &ep);
    coordinator_args.extend(["--min-workers", "2", "--verify", "1"]);
    let coordinator = start(&iox, dir.path(), &coordinator_args);
    let liar = zenoh_worker(&iox, &run_id, &ep)
        .arg("--lie")
        .spawn()
        .unwrap();
    let honest = zenoh_worker(&iox, &run_id, &ep).spawn().unwrap();
    let out = coordinator.wait_with_output().unwrap();
    let got = results(&out, dir.path());
    assert_eq!(got.0, calm.0);
    assert!(got.1 == calm.1, "generations.jsonl differs from in-process");
    ended_saying(liar, 4, "the coordinator refused this worker's answers");
    ended_saying(honest, 0, "run finished");
}

/// `lander-worker --rejoin` over zenoh: the coordinator it serves is
/// SIGKILLed midway, and its session with it breaks; resumed at the same
/// endpoint, the coordinator is found again by the worker, which serves
/// it to the results of a run never stopped and then exits 0.
#[test]
fn a_zenoh_worker_started_with_rejoin_serves_the_resumed_run() {
    let iox = Iox::new("zenoh_rejoin");
    let dir = tempfile::tempdir().unwrap();
    let cfg = never_lands(dir.path());
    let mut args = LONG.to_vec();
    args.extend(["--config", &cfg]);
    let calm = expected(&iox, &args);
    let ep = endpoint(8);
    let run_id = format!("rejoin{}", std::process::id());
    let mut saving = attached(&args, &run_id, &ep);
    saving.extend(["--checkpoint-every", "5"]);
    let mut first = start(&iox, dir.path(), &saving);
    let worker = KillOnDrop::new(
        zenoh_worker(&iox, &run_id, &ep)
            .arg("--rejoin")
            .spawn()
            .unwrap(),
    );
    let log = dir.path().join("generations.jsonl");
    assert!(
        wait_until(60, || lines_in(&log) >= 100),
        "the run never got going"
    );
    first.kill().unwrap();
    first.wait().unwrap();
    let mut resume = vec!["run", "--resume", dir.path().to_str().unwrap(), "--json"];
    resume.extend(&attached(&[], &run_id, &ep));
    let resumed = iox
        .command("lander")
        .args(&resume)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let resumed = ended_within(resumed, 120, "the resumed coordinator");
    let got = results(&resumed, dir.path());
    assert_eq!(got.0, calm.0);
    assert!(got.1 == calm.1, "generations.jsonl differs from in-process");
    let ended = wait_until(30, || lander_tests::has_exited(worker.id()));
    assert!(ended, "the worker did not leave when the run finished");
    let served = ended_saying(worker.into_inner(), 0, "run finished");
    let said = stderr(&served);
    assert!(said.contains("the coordinator is gone; waiting"), "{said}");
}

#[test]
fn one_coordinator_spreads_a_generation_over_48_attached_zenoh_workers() {
    const WORKERS: usize = 48;
    let iox = Iox::new("zenoh_48");
    let args = [
        "--method",
        "guided",
        "--seed",
        "2",
        "--population",
        "480",
        "--max-generations",
        "3",
        "--max-restarts",
        "0",
        "--json",
    ];
    let calm = expected(&iox, &args);

    let dir = tempfile::tempdir().unwrap();
    let ep = endpoint(4);
    let run_id = format!("many{}", std::process::id());
    let many = WORKERS.to_string();
    let mut coordinator_args = attached(&args, &run_id, &ep);
    coordinator_args.extend(["--min-workers", &many]);
    let coordinator = start(&iox, dir.path(), &coordinator_args);
    let workers: Vec<Child> = (0..WORKERS)
        .map(|_| zenoh_worker(&iox, &run_id, &ep).spawn().unwrap())
        .collect();
    let out = coordinator.wait_with_output().unwrap();
    let got = results(&out, dir.path());
    assert_eq!(got.0, calm.0);
    assert!(got.1 == calm.1, "generations.jsonl differs from in-process");
    assert!(
        stderr(&out).contains("waiting for 48 workers before the first generation"),
        "{}",
        stderr(&out)
    );
    // The first generation went out once all had joined, four chunks to
    // each: every worker answered some of it.
    let mut jobs = 0;
    for worker in workers {
        let done = worker.wait_with_output().unwrap();
        let said = stderr(&done);
        assert!(done.status.success(), "{said}");
        let answered = jobs_answered(&said);
        assert!(answered >= 1, "a worker answered nothing: {said}");
        jobs += answered;
    }
    assert!(jobs >= 4 * WORKERS as u64, "{jobs} jobs in all");
}

#[test]
fn min_workers_needs_attach_and_a_sensible_count() {
    let iox = Iox::new("zenoh_min");
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().to_str().unwrap();
    let alone = iox.lander(&["run", "--min-workers", "2", "--out", out_dir]);
    assert!(!alone.status.success());
    assert!(stderr(&alone).contains("--attach"), "{}", stderr(&alone));
    for bad in ["0", "129"] {
        let out = iox.lander(&["run", "--attach", "--min-workers", bad, "--out", out_dir]);
        assert!(!out.status.success(), "--min-workers {bad}");
        assert!(
            stderr(&out).contains("--min-workers must be 1 to 128"),
            "{}",
            stderr(&out)
        );
    }
}

#[test]
fn listening_beyond_loopback_without_authentication_is_warned_about() {
    let iox = Iox::new("zenoh_warn");
    let dir = tempfile::tempdir().unwrap();
    let port = 20_000 + (std::process::id() % 2_000) as u16 * 10 + 3;
    let listen = format!("tcp/0.0.0.0:{port}");
    let out = iox.lander(&[
        "run",
        "--method",
        "guided",
        "--population",
        "20",
        "--max-generations",
        "3",
        "--max-restarts",
        "0",
        "--json",
        "--workers",
        "1",
        "--transport",
        "zenoh",
        "--listen",
        &listen,
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("without authentication"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn bad_zenoh_options_are_refused() {
    let iox = Iox::new("zenoh_bad");
    let out = iox
        .command("lander-worker")
        .args(["--run", "x", "--transport", "zenoh"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(stderr(&out).contains("--connect"), "{}", stderr(&out));
    let dir = tempfile::tempdir().unwrap();
    let missing = iox.lander(&[
        "run",
        "--workers",
        "1",
        "--transport",
        "zenoh",
        "--users",
        "/nonexistent/users.txt",
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    assert!(!missing.status.success());
    assert!(
        stderr(&missing).contains("/nonexistent/users.txt"),
        "{}",
        stderr(&missing)
    );
    // zenoh takes an empty dictionary as no authentication at all.
    let empty = dir.path().join("users.txt");
    std::fs::write(&empty, "\n").unwrap();
    let open = iox.lander(&[
        "run",
        "--workers",
        "1",
        "--transport",
        "zenoh",
        "--users",
        empty.to_str().unwrap(),
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    assert!(!open.status.success());
    assert!(
        stderr(&open).contains("would admit anyone"),
        "{}",
        stderr(&open)
    );
}

#[test]
fn malformed_frames_are_refused_counted_and_the_worker_serves_on() {
    use lander_protocol::envelope::{encode_result, MAGIC};
    use lander_protocol::net::{coordinator_config, NetOptions, RunKeys};
    use lander_protocol::wire::ResultHeader;
    use zenoh::Wait;
    let ep = endpoint(7);
    let options = NetOptions {
        listen: vec![ep.clone()],
        ..NetOptions::default()
    };
    let session = zenoh::open(coordinator_config(&options).unwrap())
        .wait()
        .unwrap();
    let iox = Iox::new("frames");
    let run_id = format!("frames{}", std::process::id());
    let metrics = format!("127.0.0.1:{}", lander_tests::free_port());
    let worker = zenoh_worker(&iox, &run_id, &ep)
        .args(["--id", "f00d", "--metrics", &metrics])
        .spawn()
        .unwrap();
    let jobs = RunKeys::new(&run_id).jobs(0xf00d);
    let mut truncated = MAGIC.to_vec();
    truncated.extend([1, 0]);
    let frames: Vec<Vec<u8>> = vec![
        Vec::new(),
        b"not a frame at all".to_vec(),
        truncated,
        // Well formed, but a result where a job belongs.
        encode_result(&ResultHeader::default(), b"x"),
    ];
    // The first frame is sent again until the worker's queryable answers.
    let refused = |frame: &[u8]| -> Option<String> {
        let replies = session.get(&jobs).payload(frame.to_vec()).wait().ok()?;
        let reply = replies
            .recv_timeout(std::time::Duration::from_secs(5))
            .ok()??;
        match reply.result() {
            Ok(_) => Some("answered".into()),
            Err(e) => Some(
                e.payload()
                    .try_to_string()
                    .map_or(String::new(), |s| s.to_string()),
            ),
        }
    };
    let mut first = None;
    assert!(
        wait_until(30, || {
            first = refused(&frames[0]);
            first.is_some()
        }),
        "the worker never answered"
    );
    let mut why = vec![first.unwrap()];
    for frame in &frames[1..] {
        why.push(refused(frame).expect("an answer to each frame"));
    }
    assert!(
        why.iter().all(|w| w != "answered" && !w.is_empty()),
        "{why:?}"
    );
    let text = lander_tests::http_get(&metrics, "/metrics").unwrap();
    assert!(
        text.contains("lander_worker_rejected_frames_total 4"),
        "{text}"
    );
    // Still serving: a fifth frame gets its refusal too.
    assert!(refused(b"again").is_some_and(|w| w != "answered"));
    signal(worker.id(), "TERM");
    let out = worker.wait_with_output().unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    let said = stderr(&out);
    assert!(
        said.contains("rejected frame #1") && said.contains("rejected frame #5"),
        "{said}"
    );
}

#[test]
fn a_worker_with_no_coordinator_says_so_once_and_stops_on_a_signal() {
    let iox = Iox::new("zenoh_alone");
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("worker.log");
    // Nothing listens at this endpoint: every attempt to connect fails.
    let mut worker = zenoh_worker(&iox, "alone", &endpoint(6))
        .stderr(fs::File::create(&log).unwrap())
        .spawn()
        .unwrap();
    let said = || fs::read_to_string(&log).unwrap_or_default();
    assert!(
        wait_until(60, || said().contains("cannot reach a coordinator")),
        "the worker did not say it cannot reach its coordinator: {}",
        said()
    );
    // A second attempt under way: the warning is not repeated.
    assert!(
        wait_until(10, || worker.try_wait().unwrap().is_none()),
        "the worker left by itself"
    );
    std::thread::sleep(std::time::Duration::from_secs(3));
    signal(worker.id(), "TERM");
    let status = worker.wait().unwrap();
    let said = said();
    assert!(status.success(), "{said}");
    assert!(said.contains("stopped by signal"), "{said}");
    assert_eq!(said.matches("Unable to connect").count(), 1, "{said}");
    assert!(
        !said.contains(".rs:"),
        "a source location was shown: {said}"
    );
}
