//! Everything in `deploy/` exercised for real: the scripts, the example
//! zenoh configurations, the systemd worker unit and the router, each with
//! real processes and real zenoh sessions on loopback. Every run must give
//! results byte-identical to the same run in one process.

use lander_protocol::net::{self, NetError, NetOptions};
use lander_tests::{binary, stderr, wait_until, without_wall_time, worker_children};
use serde_json::Value;
use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Output, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// A small guided run: quick, but long enough to need many jobs.
const RUN: &[&str] = &[
    "--method",
    "guided",
    "--population",
    "60",
    "--max-generations",
    "40",
    "--max-restarts",
    "0",
    "--json",
    "--seed",
    "2",
];

/// How long any one process may take before the test gives up on it.
const PATIENCE: Duration = Duration::from_secs(180);

/// The `deploy/` folder.
fn deploy(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../deploy")
        .join(path)
        .canonicalize()
        .unwrap_or_else(|e| panic!("deploy/{path}: {e}"))
}

/// A loopback port no other test uses.
fn port(k: u16) -> u16 {
    30_000 + (std::process::id() % 1_000) as u16 * 10 + k
}

fn s(p: &Path) -> &str {
    p.to_str().expect("a UTF-8 path")
}

/// A child process whose output goes to files, killed (with any
/// `lander-worker` children of its own) if the test ends early.
struct Proc {
    child: Option<Child>,
    name: String,
    out: PathBuf,
    err: PathBuf,
}

impl Proc {
    /// Starts `cmd` as from a terminal: a script's SIGINT trap works
    /// however the test itself was started.
    fn spawn(name: &str, dir: &Path, cmd: &mut Command) -> Proc {
        let out = dir.join(format!("{name}.stdout"));
        let err = dir.join(format!("{name}.stderr"));
        let child = lander_tests::as_from_a_terminal(cmd)
            .stdin(Stdio::null())
            .stdout(fs::File::create(&out).unwrap())
            .stderr(fs::File::create(&err).unwrap())
            .spawn()
            .unwrap_or_else(|e| panic!("starting {name}: {e}"));
        Proc {
            child: Some(child),
            name: name.to_string(),
            out,
            err,
        }
    }

    fn id(&self) -> u32 {
        self.child.as_ref().expect("still running").id()
    }

    /// What it printed on stderr so far.
    fn stderr(&self) -> String {
        fs::read_to_string(&self.err).unwrap_or_default()
    }

    /// Waits for `text` on its stderr.
    fn await_line(&self, text: &str) {
        assert!(
            wait_until(60, || self.stderr().contains(text)),
            "{} never said {text:?}; stderr:\n{}",
            self.name,
            self.stderr()
        );
    }

    /// Waits for it to exit, for at most `patience`.
    fn wait(mut self, patience: Duration) -> Output {
        let end = Instant::now() + patience;
        let child = self.child.as_mut().expect("still running");
        let status: ExitStatus = loop {
            if let Some(status) = child.try_wait().unwrap() {
                break status;
            }
            if Instant::now() > end {
                panic!(
                    "{} still running after {patience:?}; stderr:\n{}",
                    self.name,
                    self.stderr()
                );
            }
            std::thread::sleep(Duration::from_millis(20));
        };
        self.child = None;
        Output {
            status,
            stdout: fs::read(&self.out).unwrap_or_default(),
            stderr: fs::read(&self.err).unwrap_or_default(),
        }
    }

    /// Sends `signal` ("TERM", "INT") and waits for it to exit.
    fn stop(self, signal: &str) -> Output {
        lander_tests::signal(self.id(), signal);
        self.wait(Duration::from_secs(20))
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        if let Some(child) = &mut self.child {
            for worker in worker_children(child.id()) {
                // SAFETY: kill(2) on a pid this test started, just read from /proc.
                unsafe { libc::kill(worker as i32, libc::SIGKILL) };
            }
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

/// The summary without wall time, and `generations.jsonl`, of a finished
/// `lander run` that wrote to `out`.
fn results(done: &Output, out: &Path) -> (Value, Vec<u8>) {
    assert!(done.status.success(), "lander failed: {}", stderr(done));
    let summary: Value = serde_json::from_slice(&done.stdout)
        .unwrap_or_else(|e| panic!("stdout is not one JSON object ({e}): {}", stderr(done)));
    (
        without_wall_time(summary),
        fs::read(out.join("generations.jsonl")).unwrap(),
    )
}

/// The same run in one process: what every distributed run must match.
fn in_process() -> &'static (Value, Vec<u8>) {
    static EXPECTED: OnceLock<(Value, Vec<u8>)> = OnceLock::new();
    EXPECTED.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let done = Command::new(binary("lander"))
            .args(["run", "--out", s(dir.path())])
            .args(RUN)
            .output()
            .unwrap();
        results(&done, dir.path())
    })
}

/// `lander run --attach` on zenoh with `extra` flags, writing to `dir/run`, once
/// its session is open and it waits for workers.
fn coordinator(dir: &Path, run_id: &str, extra: &[&str]) -> Proc {
    let out = dir.join("run");
    let coordinator = Proc::spawn(
        "coordinator",
        dir,
        Command::new(binary("lander"))
            .args(["run", "--out", s(&out)])
            .args(RUN)
            .args(["--attach", "--run-id", run_id, "--transport", "zenoh"])
            // Every test here starts two member workers: the run is too
            // short to be sure the second joins before it ends otherwise.
            .args(["--min-workers", "2"])
            .args(extra),
    );
    coordinator.await_line("waiting for workers");
    coordinator
}

/// Waits for the coordinator and checks its results against the
/// in-process run.
fn assert_same_as_in_process(coordinator: Proc, dir: &Path) {
    let done = coordinator.wait(PATIENCE);
    let got = results(&done, &dir.join("run"));
    let expected = in_process();
    assert_eq!(got.0, expected.0, "the summary differs from in-process");
    assert!(
        got.1 == expected.1,
        "generations.jsonl differs from in-process"
    );
}

/// `deploy/start-workers.sh` with `args`, using this build's worker.
fn start_workers(name: &str, dir: &Path, args: &[&str]) -> Proc {
    Proc::spawn(
        name,
        dir,
        Command::new(deploy("start-workers.sh"))
            .args(args)
            .env("LANDER_WORKER", binary("lander-worker")),
    )
}

/// `start-workers.sh` starting two workers for `run_id` at `endpoint`,
/// with `extra` flags.
fn two_workers(dir: &Path, run_id: &str, endpoint: &str, extra: &[&str]) -> Proc {
    let mut args = vec!["--run", run_id, "--connect", endpoint, "-n", "2"];
    args.extend_from_slice(extra);
    start_workers("start-workers", dir, &args)
}

/// A bare `lander-worker` over zenoh.
fn worker(name: &str, dir: &Path, run_id: &str, args: &[&str]) -> Proc {
    Proc::spawn(
        name,
        dir,
        Command::new(binary("lander-worker"))
            .args(["--run", run_id, "--transport", "zenoh"])
            .args(args),
    )
}

/// Runs one of the deploy scripts to completion.
fn script(name: &str, args: &[&str]) -> Output {
    Command::new(deploy(name))
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("running deploy/{name}: {e}"))
}

/// Starts a worker that must be kept out, and waits until it has been
/// turned away by the live coordinator (or router) at least once.
fn stranger(name: &str, dir: &Path, run_id: &str, args: &[&str]) -> Proc {
    let stranger = worker(name, dir, run_id, args);
    stranger.await_line("cannot reach a coordinator");
    stranger
}

/// A stranger never got in, all through the run, and stops cleanly on
/// SIGTERM.
fn assert_kept_out(stranger: Proc) {
    let name = stranger.name.clone();
    let out = stranger.stop("TERM");
    let said = stderr(&out);
    assert!(
        !said.contains("serving run"),
        "{name} joined the run: {said}"
    );
    assert!(said.contains("stopped by signal"), "{name}: {said}");
    assert!(out.status.success(), "{name}: {said}");
}

/// The workers of a script that served a run: all connected, all told
/// the run finished, the script itself exited 0. Returns what it said.
fn assert_served(script: Proc, workers: usize) -> String {
    let done = script.wait(Duration::from_secs(30));
    let said = stderr(&done);
    assert!(done.status.success(), "start-workers.sh failed: {said}");
    assert_eq!(said.matches("serving run").count(), workers, "{said}");
    assert_eq!(
        said.matches("run finished after ").count(),
        workers,
        "{said}"
    );
    assert!(
        said.contains(&format!("all {workers} worker(s) exited cleanly")),
        "{said}"
    );
    said
}

fn need_openssl() {
    let found = Command::new("openssl")
        .arg("version")
        .output()
        .is_ok_and(|o| o.status.success());
    assert!(
        found,
        "openssl is needed to test deploy/make-certs.sh: install it (apt-get install openssl)"
    );
}

fn mode(path: &Path) -> u32 {
    std::os::unix::fs::PermissionsExt::mode(&fs::metadata(path).unwrap().permissions()) & 0o777
}

#[test]
fn start_workers_serves_a_run_with_make_users_credentials() {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    let creds = dir.join("creds");
    let made = script("make-users.sh", &[s(&creds), "host-b", "host-c"]);
    assert!(made.status.success(), "{}", stderr(&made));
    let users = fs::read_to_string(creds.join("users.txt")).unwrap();
    assert_eq!(users.lines().count(), 2, "{users}");
    for user in ["host-b", "host-c"] {
        let file = creds.join(format!("{user}.credentials"));
        let line = fs::read_to_string(&file).unwrap();
        assert!(line.starts_with(&format!("{user}:")), "{line}");
        assert!(users.contains(&line), "{line} is not in users.txt");
        assert_eq!(mode(&file), 0o600, "{user}.credentials is not private");
    }
    // Running it again keeps the passwords it made.
    let again = script("make-users.sh", &[s(&creds), "host-b"]);
    assert!(again.status.success(), "{}", stderr(&again));
    assert_eq!(fs::read_to_string(creds.join("users.txt")).unwrap(), users);

    let run_id = format!("script{}", std::process::id());
    let listen = format!("tcp/127.0.0.1:{}", port(0));
    let users = creds.join("users.txt");
    let coordinator_cfg = deploy("zenoh/coordinator.json5");
    let worker_cfg = deploy("zenoh/worker.json5");
    let coordinator = coordinator(
        dir,
        &run_id,
        &[
            "--listen",
            &listen,
            "--users",
            s(&users),
            "--zenoh-config",
            s(&coordinator_cfg),
        ],
    );
    let workers = two_workers(
        dir,
        &run_id,
        &listen,
        &[
            "--credentials",
            s(&creds.join("host-b.credentials")),
            "--zenoh-config",
            s(&worker_cfg),
        ],
    );
    assert_same_as_in_process(coordinator, dir);
    assert_served(workers, 2);
}

#[test]
fn start_workers_serves_each_workers_metrics_for_the_scrape_config() {
    let config = deploy("prometheus/prometheus.yml");
    let checked = Command::new("promtool")
        .args(["check", "config"])
        .arg(&config)
        .output()
        .expect("Debian's promtool is installed (.ci/run installs it)");
    assert!(checked.status.success(), "{}", stderr(&checked));
    let dir = tempfile::tempdir().unwrap();
    let nowhere = format!("tcp/127.0.0.1:{}", port(1));
    let first = format!("127.0.0.1:{}", port(8));
    let run_id = format!("metrics{}", std::process::id());
    let workers = two_workers(dir.path(), &run_id, &nowhere, &["--metrics", &first]);
    // Waiting for a coordinator, each worker already serves its metrics,
    // on consecutive ports.
    for k in [8, 9] {
        let addr = format!("127.0.0.1:{}", port(k));
        assert!(
            wait_until(30, || lander_tests::http_get(&addr, "/metrics")
                .is_ok_and(|t| t.contains("lander_worker_jobs_total 0"))),
            "no worker metrics at {addr}: {}",
            workers.stderr()
        );
    }
    let out = workers.stop("TERM");
    assert!(out.status.success(), "{}", stderr(&out));
}

#[test]
fn start_workers_checks_its_arguments_and_passes_on_signals() {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    for name in ["start-workers.sh", "make-certs.sh", "make-users.sh"] {
        assert_eq!(
            mode(&deploy(name)) & 0o111,
            0o111,
            "deploy/{name} is not executable"
        );
    }
    for (args, complaint) in [
        (&[][..], "--run ID is required"),
        (&["--run", "x"][..], "--connect ENDPOINT is required"),
        (
            &["--connect", "tcp/127.0.0.1:1"][..],
            "--run ID is required",
        ),
        (
            &["--run", "x", "--connect", "tcp/127.0.0.1:1", "-n", "0"][..],
            "-n must be a positive whole number",
        ),
        (&["--run", "x", "--bogus"][..], "unknown argument"),
        (
            &[
                "--run",
                "x",
                "--connect",
                "tcp/127.0.0.1:1",
                "--metrics",
                "9464",
            ][..],
            "--metrics must be HOST:PORT",
        ),
        (
            &[
                "--run",
                "x",
                "--connect",
                "tcp/127.0.0.1:1",
                "-n",
                "2",
                "--metrics",
                "h:65535",
            ][..],
            "are not all valid ports",
        ),
        (
            &[
                "--run",
                "x",
                "--connect",
                "tcp/127.0.0.1:1",
                "--credentials",
                "/nonexistent/creds",
            ][..],
            "/nonexistent/creds",
        ),
    ] {
        let out = script("start-workers.sh", args);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", stderr(&out));
        assert!(
            stderr(&out).contains("usage:"),
            "{args:?}: {}",
            stderr(&out)
        );
        assert!(
            stderr(&out).contains(complaint),
            "{args:?}: {}",
            stderr(&out)
        );
    }

    // A worker that fails makes the script fail.
    let failing = ["/bin/false", "/usr/bin/false"]
        .into_iter()
        .find(|p| Path::new(p).exists())
        .expect("false(1) exists");
    let out = Command::new(deploy("start-workers.sh"))
        .args(["--run", "x", "--connect", "tcp/127.0.0.1:1", "-n", "2"])
        .env("LANDER_WORKER", failing)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("2 of 2 worker(s) failed"),
        "{}",
        stderr(&out)
    );

    // Workers waiting for a coordinator that never comes: one per core by
    // default, and SIGTERM or SIGINT to the script stops them all.
    let cores: usize = String::from_utf8(Command::new("nproc").output().unwrap().stdout)
        .unwrap()
        .trim()
        .parse()
        .unwrap();
    let nowhere = format!("tcp/127.0.0.1:{}", port(1));
    for (signal, n) in [("TERM", None), ("INT", Some("3"))] {
        let mut args = vec!["--run", "nobody", "--connect", &nowhere];
        if let Some(n) = n {
            args.extend(["-n", n]);
        }
        let expect = n.map_or(cores, |n| n.parse().unwrap());
        let script = start_workers(&format!("waiting-{signal}"), dir, &args);
        let pid = script.id();
        assert!(
            wait_until(30, || worker_children(pid).len() == expect
                && script
                    .stderr()
                    .matches("cannot reach a coordinator")
                    .count()
                    == expect),
            "expected {expect} waiting workers, found {}: {}",
            worker_children(pid).len(),
            script.stderr()
        );
        let workers = worker_children(pid);
        let out = script.stop(signal);
        let said = stderr(&out);
        assert!(out.status.success(), "SIG{signal}: {said}");
        assert!(said.contains("stopping"), "SIG{signal}: {said}");
        assert_eq!(
            said.matches("stopped by signal after ").count(),
            expect,
            "SIG{signal}: {said}"
        );
        for w in workers {
            assert!(
                !Path::new(&format!("/proc/{w}")).exists()
                    || fs::read_to_string(format!("/proc/{w}/stat"))
                        .is_ok_and(|st| !st.contains("(lander-worker)")),
                "worker {w} outlived the script"
            );
        }
    }
}

/// Copies deploy/zenoh/`name` to `dir/copy`, with its `/etc/lander/` paths
/// pointing into `certs` and every `(from, to)` replacement made.
fn example(name: &str, copy: &str, certs: &Path, dir: &Path, edits: &[(&str, &str)]) -> PathBuf {
    let mut text = fs::read_to_string(deploy(&format!("zenoh/{name}"))).unwrap();
    text = text.replace("/etc/lander/", &format!("{}/", s(certs)));
    for (from, to) in edits {
        assert!(text.contains(from), "deploy/zenoh/{name} has no {from:?}");
        text = text.replace(from, to);
    }
    let path = dir.join(copy);
    fs::write(&path, text).unwrap();
    path
}

#[test]
fn mutual_tls_with_make_certs_admits_members_only() {
    need_openssl();
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    let certs = dir.join("certs");
    let made = script("make-certs.sh", &[s(&certs), "IP:127.0.0.1,DNS:localhost"]);
    assert!(made.status.success(), "{}", stderr(&made));
    for file in [
        "ca.pem",
        "ca-key.pem",
        "coordinator.pem",
        "coordinator-key.pem",
        "worker.pem",
        "worker-key.pem",
    ] {
        assert!(certs.join(file).is_file(), "make-certs.sh made no {file}");
    }
    for key in ["ca-key.pem", "coordinator-key.pem", "worker-key.pem"] {
        assert_eq!(mode(&certs.join(key)), 0o600, "{key} is not private");
    }
    // Another CA's certificate is no way in.
    let rogue = dir.join("rogue");
    let made = script("make-certs.sh", &[s(&rogue), "IP:127.0.0.1"]);
    assert!(made.status.success(), "{}", stderr(&made));
    let bad_usage = script("make-certs.sh", &[s(&rogue)]);
    assert_eq!(bad_usage.status.code(), Some(2));
    assert!(stderr(&bad_usage).contains("usage:"));

    let coordinator_cfg = example(
        "coordinator-tls.json5",
        "coordinator.json5",
        &certs,
        dir,
        &[],
    );
    let worker_cfg = example("worker-tls.json5", "worker.json5", &certs, dir, &[]);
    let no_cert = example(
        "worker-tls.json5",
        "no-certificate.json5",
        &certs,
        dir,
        &[
            ("enable_mtls: true", "enable_mtls: false"),
            ("connect_private_key:", "// connect_private_key:"),
            ("connect_certificate:", "// connect_certificate:"),
        ],
    );
    let key = format!("{}/worker-key.pem", s(&certs));
    let cert = format!("{}/worker.pem", s(&certs));
    let other_ca = example(
        "worker-tls.json5",
        "other-ca.json5",
        &certs,
        dir,
        &[
            (&key, &format!("{}/worker-key.pem", s(&rogue))),
            (&cert, &format!("{}/worker.pem", s(&rogue))),
        ],
    );

    let run_id = format!("tls{}", std::process::id());
    let listen = format!("tls/127.0.0.1:{}", port(2));
    let plain = format!("tcp/127.0.0.1:{}", port(2));
    let coordinator = coordinator(
        dir,
        &run_id,
        &["--zenoh-config", s(&coordinator_cfg), "--listen", &listen],
    );
    // zenoh 1.10's TLS needs its I/O on one thread (deploy/README.md).
    assert!(
        coordinator
            .stderr()
            .contains("TLS: running zenoh's I/O on one thread"),
        "{}",
        coordinator.stderr()
    );
    let strangers = [
        stranger(
            "no-certificate",
            dir,
            &run_id,
            &["--zenoh-config", s(&no_cert), "--connect", &listen],
        ),
        stranger(
            "other-ca",
            dir,
            &run_id,
            &["--zenoh-config", s(&other_ca), "--connect", &listen],
        ),
        stranger("plain-tcp", dir, &run_id, &["--connect", &plain]),
    ];
    let members = two_workers(dir, &run_id, &listen, &["--zenoh-config", s(&worker_cfg)]);
    assert_same_as_in_process(coordinator, dir);
    let said = assert_served(members, 2);
    assert_eq!(
        said.matches("TLS: running zenoh's I/O on one thread")
            .count(),
        2,
        "{said}"
    );
    for stranger in strangers {
        assert_kept_out(stranger);
    }
}

/// KEY=VALUE lines as systemd's EnvironmentFile= reads them (comments,
/// blank lines, optional quotes).
fn env_file(text: &str) -> BTreeMap<String, String> {
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(|l| {
            let (key, value) = l
                .split_once('=')
                .unwrap_or_else(|| panic!("not KEY=VALUE: {l}"));
            let value = value.trim();
            let unquoted = ['"', '\'']
                .into_iter()
                .find_map(|q| value.strip_prefix(q)?.strip_suffix(q))
                .unwrap_or(value);
            (key.trim().to_string(), unquoted.to_string())
        })
        .collect()
}

/// The unit's own Environment= settings, `Environment="NAME=value"`.
fn unit_environment(unit: &str) -> BTreeMap<String, String> {
    unit.lines()
        .filter_map(|l| l.trim().strip_prefix("Environment="))
        .map(|v| {
            let v = v
                .strip_prefix('"')
                .and_then(|v| v.strip_suffix('"'))
                .unwrap_or(v);
            let (key, value) = v.split_once('=').expect("Environment=NAME=value");
            (key.to_string(), value.to_string())
        })
        .collect()
}

/// The variables a unit's ExecStart= uses, `${NAME}` or `$NAME`.
fn unit_variables(exec: &str) -> Vec<String> {
    let mut names = Vec::new();
    let mut rest = exec;
    while let Some(at) = rest.find('$') {
        rest = &rest[at + 1..];
        let name: String = rest
            .trim_start_matches('{')
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect();
        names.push(name);
    }
    names
}

/// ExecStart= expanded as systemd does: `${NAME}` in place within one
/// word, a lone `$NAME` word split at whitespace (nothing when empty).
fn exec_start(unit: &str, env: &BTreeMap<String, String>) -> Vec<String> {
    let exec = unit
        .lines()
        .find_map(|l| l.trim().strip_prefix("ExecStart="))
        .expect("the unit has an ExecStart=");
    let value = |name: &str| {
        env.get(name)
            .unwrap_or_else(|| panic!("the unit uses ${name}, which the environment lacks"))
            .clone()
    };
    let mut argv = Vec::new();
    for word in exec.split_whitespace() {
        match word.strip_prefix('$') {
            Some(name) if !name.starts_with('{') => {
                argv.extend(value(name).split_whitespace().map(String::from))
            }
            _ => {
                let mut word = word.to_string();
                while let Some(start) = word.find("${") {
                    let end = start + word[start..].find('}').expect("a closing }");
                    let name = word[start + 2..end].to_string();
                    word.replace_range(start..=end, &value(&name));
                }
                argv.push(word);
            }
        }
    }
    argv
}

/// Each of `lines` appears in the unit as a line of its own.
fn assert_unit_has(unit: &str, lines: &[&str]) {
    for line in lines {
        assert!(
            unit.lines().any(|l| l.trim() == *line),
            "the unit lacks {line}"
        );
    }
}

#[test]
fn the_systemd_worker_unit_serves_a_run() {
    let unit = fs::read_to_string(deploy("systemd/lander-worker@.service")).unwrap();
    assert_unit_has(
        &unit,
        &[
            "EnvironmentFile=/etc/lander/worker.env",
            "Restart=on-failure",
            "NoNewPrivileges=yes",
            "User=lander",
        ],
    );
    let exec = unit
        .lines()
        .find_map(|l| l.strip_prefix("ExecStart="))
        .unwrap();
    let example = env_file(&fs::read_to_string(deploy("systemd/worker.env.example")).unwrap());
    let used = unit_variables(exec);
    assert!(used.contains(&"LANDER_RUN".to_string()), "{used:?}");
    assert!(used.contains(&"LANDER_CONNECT".to_string()), "{used:?}");
    for name in &used {
        assert!(
            example.contains_key(name),
            "worker.env.example does not set {name}"
        );
    }
    // The example itself gives a sensible command line.
    let argv = exec_start(&unit, &example);
    assert_eq!(argv[0], "/usr/local/bin/lander-worker");
    assert_eq!(
        argv[1..],
        [
            "--run",
            "demo",
            "--transport",
            "zenoh",
            "--connect",
            "tcp/10.0.0.5:7447",
            "--rejoin",
            "--credentials",
            "/etc/lander/worker.credentials"
        ]
    );
    // With empty options, no empty argument.
    let mut bare = example.clone();
    bare.insert("LANDER_OPTS".into(), String::new());
    assert_eq!(exec_start(&unit, &bare).len(), 8);

    // Two instances from a real environment file serve a real run.
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    let users = dir.join("users.txt");
    fs::write(&users, "lander:unit-test-password\n").unwrap();
    let run_id = format!("unit{}", std::process::id());
    let listen = format!("tcp/127.0.0.1:{}", port(3));
    let env_path = dir.join("worker.env");
    fs::write(
        &env_path,
        format!(
            "# test\nLANDER_RUN={run_id}\nLANDER_CONNECT={listen}\nLANDER_OPTS=\"--credentials {}\"\n",
            s(&users)
        ),
    )
    .unwrap();
    let argv = exec_start(&unit, &env_file(&fs::read_to_string(&env_path).unwrap()));
    assert_eq!(argv[0], "/usr/local/bin/lander-worker");
    // The instances get what the unit's own Environment= lines would set.
    let environment = unit_environment(&unit);
    let coordinator = coordinator(dir, &run_id, &["--listen", &listen, "--users", s(&users)]);
    let instances: Vec<Proc> = (1..=2)
        .map(|i| {
            Proc::spawn(
                &format!("lander-worker@{i}"),
                dir,
                Command::new(binary("lander-worker"))
                    .args(&argv[1..])
                    .envs(&environment),
            )
        })
        .collect();
    assert_same_as_in_process(coordinator, dir);
    for instance in instances {
        let name = instance.name.clone();
        let done = instance.wait(Duration::from_secs(30));
        let said = stderr(&done);
        // Exit status 0, so Restart=on-failure leaves it stopped.
        assert!(done.status.success(), "{name}: {said}");
        assert!(said.contains("serving run"), "{name}: {said}");
        assert!(said.contains("run finished after "), "{name}: {said}");
    }
}

/// The router as systemd would start it: the command line of
/// systemd/lander-router.service, with this build's `lander` and a copy of
/// deploy/zenoh/router.json5 (after `edits` to its text) listening on
/// loopback at `port` instead of every interface at 7447.
fn router(dir: &Path, certs: &Path, port: u16, edits: &[(&str, &str)]) -> Proc {
    let listen = format!("tcp/127.0.0.1:{port}");
    let mut edits = edits.to_vec();
    edits.push(("tcp/0.0.0.0:7447", &listen));
    let config = example("router.json5", "router.json5", certs, dir, &edits);
    let unit = fs::read_to_string(deploy("systemd/lander-router.service")).unwrap();
    let argv: Vec<String> = exec_start(&unit, &BTreeMap::new())
        .into_iter()
        .map(|arg| match arg.as_str() {
            "/usr/local/bin/lander" => s(&binary("lander")).to_string(),
            "/etc/lander/router.json5" => s(&config).to_string(),
            _ => arg,
        })
        .collect();
    let router = Proc::spawn("router", dir, Command::new(&argv[0]).args(&argv[1..]));
    router.await_line(&format!("listening on {listen}"));
    router
}

/// The router stops cleanly on `signal`, so Restart=on-failure leaves it
/// stopped.
fn assert_router_stops(router: Proc, signal: &str) {
    let out = router.stop(signal);
    let said = stderr(&out);
    assert!(out.status.success(), "the router failed: {said}");
    assert!(said.contains("stopped by signal"), "{said}");
}

#[test]
fn the_router_config_routes_jobs_between_coordinator_and_workers() {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    let router_port = port(4);
    let router = router(dir, dir, router_port, &[]);
    let via = format!("tcp/127.0.0.1:{router_port}");
    let coordinator_cfg = example(
        "coordinator-router.json5",
        "coordinator.json5",
        dir,
        dir,
        &[("tcp/10.0.0.9:7447", &via)],
    );
    let run_id = format!("router{}", std::process::id());
    // The coordinator's own port is told to no worker: they reach it only
    // through the router.
    let own = format!("tcp/127.0.0.1:{}", port(5));
    let coordinator = coordinator(
        dir,
        &run_id,
        &["--listen", &own, "--zenoh-config", s(&coordinator_cfg)],
    );
    let workers = two_workers(dir, &run_id, &via, &[]);
    assert_same_as_in_process(coordinator, dir);
    assert_served(workers, 2);
    assert_router_stops(router, "TERM");
}

#[test]
fn a_router_with_the_users_dictionary_keeps_strangers_out() {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    let creds = dir.join("creds");
    let made = script("make-users.sh", &[s(&creds), "coordinator", "host-b"]);
    assert!(made.status.success(), "{}", stderr(&made));
    let router_port = port(6);
    // Uncomment the dictionary line, as router.json5 says to.
    let router = router(
        dir,
        &creds,
        router_port,
        &[(
            "  // transport: { auth: { usrpwd: { dictionary_file:",
            "  transport: { auth: { usrpwd: { dictionary_file:",
        )],
    );
    let line = fs::read_to_string(creds.join("coordinator.credentials")).unwrap();
    let (_, password) = line.trim().split_once(':').unwrap();
    let via = format!("tcp/127.0.0.1:{router_port}");
    let coordinator_cfg = example(
        "coordinator-router.json5",
        "coordinator.json5",
        &creds,
        dir,
        &[
            ("tcp/10.0.0.9:7447", &via),
            (
                r#"// transport: { auth: { usrpwd: { user: "coordinator", password: "..." } } },"#,
                &format!(
                    r#"transport: {{ auth: {{ usrpwd: {{ user: "coordinator", password: "{password}" }} }} }},"#
                ),
            ),
        ],
    );
    let run_id = format!("guarded{}", std::process::id());
    let own = format!("tcp/127.0.0.1:{}", port(7));
    let coordinator = coordinator(
        dir,
        &run_id,
        &["--listen", &own, "--zenoh-config", s(&coordinator_cfg)],
    );
    let stranger = stranger("stranger", dir, &run_id, &["--connect", &via]);
    let members = two_workers(
        dir,
        &run_id,
        &via,
        &["--credentials", s(&creds.join("host-b.credentials"))],
    );
    assert_same_as_in_process(coordinator, dir);
    assert_served(members, 2);
    assert_kept_out(stranger);
    assert_router_stops(router, "INT");
}

/// Every example loads the way lander loads it, for the session it is
/// for; a loaded file's mode is checked against that session.
#[test]
fn every_example_zenoh_config_loads_for_its_session() {
    let mut seen = Vec::new();
    for entry in fs::read_dir(deploy("zenoh")).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_str().unwrap().to_string();
        assert!(name.ends_with(".json5"), "deploy/zenoh/{name} is not JSON5");
        let options = NetOptions {
            config_file: Some(path.clone()),
            ..NetOptions::default()
        };
        let loaded = if name.starts_with("coordinator") {
            net::coordinator_config(&options)
        } else if name.starts_with("worker") {
            net::worker_config(&options)
        } else {
            assert_eq!(name, "router.json5");
            net::router_config(&options)
        };
        loaded.unwrap_or_else(|e| panic!("deploy/zenoh/{name} does not load: {e}"));
        seen.push(name);
    }
    seen.sort();
    assert_eq!(
        seen,
        [
            "coordinator-router.json5",
            "coordinator-tls.json5",
            "coordinator.json5",
            "router.json5",
            "worker-tls.json5",
            "worker.json5"
        ]
    );
}

/// Which examples leave a way in for strangers, as the warnings say: the
/// plain router until its dictionary line is uncommented; the TLS
/// coordinator on no interface.
#[test]
fn the_examples_guard_what_their_comments_say() {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    let load = |file: PathBuf, listen: &[&str], make: fn(&NetOptions) -> Result<_, NetError>| {
        let options = NetOptions {
            config_file: Some(file),
            listen: listen.iter().map(|e| e.to_string()).collect(),
            ..NetOptions::default()
        };
        net::open_to_strangers(&make(&options).unwrap())
    };
    let plain = example("router.json5", "plain.json5", dir, dir, &[]);
    assert_eq!(load(plain, &[], net::router_config), ["tcp/0.0.0.0:7447"]);
    // The dictionary the uncommented line names must exist and admit
    // someone: an empty one is refused, since zenoh would then admit anyone.
    fs::write(dir.join("users.txt"), "worker:secret\n").unwrap();
    let guarded = example(
        "router.json5",
        "guarded.json5",
        dir,
        dir,
        &[(
            "  // transport: { auth: { usrpwd: { dictionary_file:",
            "  transport: { auth: { usrpwd: { dictionary_file:",
        )],
    );
    assert!(load(guarded, &[], net::router_config).is_empty());
    let tls = example("coordinator-tls.json5", "tls.json5", dir, dir, &[]);
    assert!(load(tls, &["tls/0.0.0.0:7447"], net::coordinator_config).is_empty());
}

/// What the router unit runs is started by the router tests above; here,
/// the rest of the unit and the walkthrough's install steps, and the
/// router's refusals.
#[test]
fn the_router_unit_runs_lander_router_on_the_installed_config() {
    let unit = fs::read_to_string(deploy("systemd/lander-router.service")).unwrap();
    assert_eq!(
        exec_start(&unit, &BTreeMap::new()),
        [
            "/usr/local/bin/lander",
            "router",
            "-c",
            "/etc/lander/router.json5"
        ]
    );
    assert_unit_has(
        &unit,
        &[
            "Restart=on-failure",
            "NoNewPrivileges=yes",
            "DynamicUser=yes",
            "WantedBy=multi-user.target",
        ],
    );
    let readme = fs::read_to_string(deploy("README.md")).unwrap();
    for step in [
        "install -m 644 deploy/zenoh/router.json5 /etc/lander/",
        "install -m 644 deploy/systemd/lander-router.service /etc/systemd/system/",
    ] {
        assert!(
            readme.contains(step),
            "deploy/README.md no longer says {step:?}"
        );
    }
    let refused = |args: &[&str], says: &str| {
        let out = Command::new(binary("lander"))
            .arg("router")
            .args(args)
            .output()
            .unwrap();
        let said = stderr(&out);
        assert!(!out.status.success(), "router {args:?} started: {said}");
        assert!(said.contains(says), "router {args:?}: {said}");
        assert!(!said.contains("panicked"), "router {args:?}: {said}");
    };
    refused(&[], "--listen ENDPOINT");
    refused(
        &["-c", "/nonexistent/router.json5"],
        "/nonexistent/router.json5",
    );
    let worker = deploy("zenoh/worker.json5");
    refused(&["-c", s(&worker)], "mode is \"client\"");
    refused(&["--listen", "nonsense"], "nonsense");
}
