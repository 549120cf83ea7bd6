//! Watching a run from outside, with real components: a Prometheus server
//! (Debian's `prometheus`, which `.ci/run` installs) scrapes a coordinator
//! and its two spawned workers' counts every second while the run goes;
//! `promtool check metrics` checks what a coordinator and a worker serve;
//! `--log-format json` writes JSON lines; and a bad `--metrics` is an
//! error at start.

use lander_tests::{
    free_port, http_get, interrupt, joined, signal, stderr, wait_until, worker_children, Iox,
};
use serde_json::Value;
use std::io::Write;
use std::path::Path;
use std::process::{Child, Command, Stdio};

/// A Prometheus server on loopback that scrapes `targets` every second,
/// stopped when dropped.
struct Prometheus {
    child: Child,
    addr: String,
    _dir: tempfile::TempDir,
}

impl Prometheus {
    fn start(targets: &[&str]) -> Prometheus {
        let dir = tempfile::tempdir().unwrap();
        let config = dir.path().join("prometheus.yml");
        let list: Vec<String> = targets.iter().map(|t| format!("'{t}'")).collect();
        std::fs::write(
            &config,
            format!(
                "global:\n  scrape_interval: 1s\n  evaluation_interval: 1s\n\
                 scrape_configs:\n  - job_name: lander\n    static_configs:\n      \
                 - targets: [{}]\n",
                list.join(", ")
            ),
        )
        .unwrap();
        let addr = format!("127.0.0.1:{}", free_port());
        let log = std::fs::File::create(dir.path().join("prometheus.log")).unwrap();
        let child = Command::new("prometheus")
            .arg(format!("--config.file={}", config.display()))
            .arg(format!(
                "--storage.tsdb.path={}",
                dir.path().join("data").display()
            ))
            .arg(format!("--web.listen-address={addr}"))
            .stdout(Stdio::null())
            .stderr(log)
            .spawn()
            .expect("Debian's prometheus is installed (.ci/run installs it)");
        let prometheus = Prometheus {
            child,
            addr,
            _dir: dir,
        };
        assert!(
            wait_until(60, || http_get(&prometheus.addr, "/-/ready").is_ok()),
            "Prometheus never became ready"
        );
        prometheus
    }

    /// The value of an instant query that yields one series, if it does.
    fn query(&self, promql: &str) -> Option<f64> {
        let body = http_get(
            &self.addr,
            &format!("/api/v1/query?query={}", encode(promql)),
        )
        .ok()?;
        let v: Value = serde_json::from_str(&body).ok()?;
        v["data"]["result"][0]["value"][1].as_str()?.parse().ok()
    }
}

impl Drop for Prometheus {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Percent-encodes a query string value.
fn encode(s: &str) -> String {
    s.bytes()
        .map(|b| match b {
            b'A'..=b'Z' | b'a'..=b'z' | b'0'..=b'9' | b'-' | b'_' | b'.' | b'~' => {
                (b as char).to_string()
            }
            _ => format!("%{b:02X}"),
        })
        .collect()
}

/// A configuration under which no lander lands, so that a run lasts its
/// whole budget.
fn never_lands(dir: &Path) -> String {
    let path = dir.join("never-lands.toml");
    std::fs::write(&path, "[scoring]\nsafe_speed = 0.0\n").unwrap();
    path.to_str().unwrap().to_string()
}

/// Starts a long run over two spawned workers with `--metrics ADDR` and
/// `extra` flags, and waits until its endpoint answers.
fn long_run(iox: &Iox, dir: &Path, addr: &str, extra: &[&str]) -> Child {
    let cfg = never_lands(dir);
    let out = dir.join("run");
    let child = iox
        .command("lander")
        .args(extra)
        .args([
            "run",
            "--config",
            &cfg,
            "--seed",
            "5",
            "--population",
            "2000",
        ])
        .args([
            "--max-generations",
            "500",
            "--max-restarts",
            "20",
            "--workers",
            "2",
        ])
        .args(["--metrics", addr, "--out", out.to_str().unwrap()])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    assert!(
        wait_until(30, || http_get(addr, "/metrics").is_ok()),
        "the coordinator never served its metrics"
    );
    child
}

#[test]
fn prometheus_sees_genomes_rise_two_workers_and_a_death() {
    let iox = Iox::new("prometheus");
    let dir = tempfile::tempdir().unwrap();
    let addr = format!("127.0.0.1:{}", free_port());
    let run = long_run(&iox, dir.path(), &addr, &[]);
    let prometheus = Prometheus::start(&[&addr]);

    let genomes = || prometheus.query("lander_genomes_evaluated_total");
    assert!(
        wait_until(60, || genomes().is_some_and(|n| n > 0.0)),
        "no genomes scraped"
    );
    let first = genomes().unwrap();
    assert!(
        wait_until(60, || genomes().is_some_and(|n| n > first)),
        "the genomes-evaluated counter stayed at {first}"
    );
    let connected = || prometheus.query("sum(lander_workers_connected)");
    assert!(
        wait_until(60, || connected() == Some(2.0)),
        "Prometheus saw {:?} workers connected, not 2",
        connected()
    );

    let workers = worker_children(run.id());
    assert_eq!(workers.len(), 2, "{workers:?}");
    signal(workers[0], "KILL");
    let deaths = || prometheus.query(r#"sum(lander_workers_lost_total{cause="exited"})"#);
    assert!(
        wait_until(60, || deaths().is_some_and(|n| n >= 1.0)),
        "Prometheus saw no death: {:?}",
        deaths()
    );
    assert!(
        wait_until(60, || prometheus.query("lander_worker_respawns_total")
            == Some(1.0)),
        "the respawn was not counted"
    );
    interrupt(run);
}

/// `promtool check metrics` on `text`: its complaints, if any.
/// Whether the metrics at `addr` hold counter `name` above 0.
fn counted(addr: &str, name: &str) -> bool {
    http_get(addr, "/metrics").is_ok_and(|t| {
        t.lines().any(|l| {
            l.strip_prefix(name)
                .is_some_and(|v| v.starts_with(' ') && v != " 0")
        })
    })
}

fn promtool(text: &str) -> Result<(), String> {
    let mut child = Command::new("promtool")
        .args(["check", "metrics"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("Debian's promtool is installed (.ci/run installs it)");
    child
        .stdin
        .take()
        .unwrap()
        .write_all(text.as_bytes())
        .unwrap();
    let out = child.wait_with_output().unwrap();
    if out.status.success() {
        Ok(())
    } else {
        Err(format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            stderr(&out)
        ))
    }
}

#[test]
fn promtool_passes_a_coordinators_and_a_workers_metrics() {
    let iox = Iox::new("promtool");
    let dir = tempfile::tempdir().unwrap();
    let run_addr = format!("127.0.0.1:{}", free_port());
    let worker_addr = format!("127.0.0.1:{}", free_port());
    let cfg = never_lands(dir.path());
    let run = iox
        .command("lander")
        .args([
            "run",
            "--config",
            &cfg,
            "--population",
            "500",
            "--max-generations",
            "400",
        ])
        .args(["--attach", "--run-id", "promtool", "--metrics", &run_addr])
        .args(["--out", dir.path().join("run").to_str().unwrap()])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut worker = iox
        .command("lander-worker")
        .args(["--run", "promtool", "--metrics", &worker_addr])
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Scraped once the worker has served jobs, so that every series has a
    // value.
    let served = || counted(&worker_addr, "lander_worker_jobs_total");
    assert!(wait_until(60, served), "the worker served no job");
    for (who, addr) in [("coordinator", &run_addr), ("worker", &worker_addr)] {
        let text = http_get(addr, "/metrics").unwrap();
        assert!(text.contains("process_cpu_seconds_total"), "{who}: {text}");
        promtool(&text).unwrap_or_else(|e| panic!("promtool on the {who}'s metrics: {e}\n{text}"));
    }
    interrupt(run);
    let _ = worker.wait();
}

#[test]
fn json_logs_parse_line_by_line_and_spawned_workers_log_json_too() {
    let iox = Iox::new("jsonlogs");
    let dir = tempfile::tempdir().unwrap();
    let addr = format!("127.0.0.1:{}", free_port());
    let run = long_run(&iox, dir.path(), &addr, &["--log-format", "json"]);
    let run_dir = dir.path().join("run");
    let events = run_dir.join("events.jsonl");
    let joined_now = || joined(&lander_telemetry::events::read(&run_dir).unwrap_or_default()).len();
    assert!(
        wait_until(30, || joined_now() == 2),
        "the workers never joined"
    );
    let workers = worker_children(run.id());
    assert_eq!(workers.len(), 2, "{workers:?}");
    // They share the coordinator's stderr, so they log in its format.
    for pid in &workers {
        let cmdline = std::fs::read(format!("/proc/{pid}/cmdline")).unwrap();
        assert!(
            cmdline.windows(18).any(|w| w == b"--log-format\0json\0"),
            "{}",
            String::from_utf8_lossy(&cmdline)
        );
    }
    // A death and a respawn, so that there is more to log than the start.
    signal(workers[0], "KILL");
    assert!(
        wait_until(30, || std::fs::read_to_string(&events)
            .is_ok_and(|t| t.contains("worker_respawned"))),
        "no respawn recorded"
    );
    let out = interrupt(run);
    let text = stderr(&out);
    let lines: Vec<Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("not JSON ({e}): {l}")))
        .collect();
    let messages: Vec<&str> = lines
        .iter()
        .filter_map(|l| l["fields"]["message"].as_str())
        .collect();
    assert!(
        messages.iter().any(|m| m.contains("exited")),
        "{messages:?}"
    );
    assert!(
        messages.iter().any(|m| m.contains("stopped by SIGINT")),
        "{messages:?}"
    );
    assert!(lines
        .iter()
        .all(|l| l["level"].is_string() && l["timestamp"].is_string()));
}

#[test]
fn a_bad_metrics_address_or_a_port_in_use_is_an_error_at_start() {
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let taken = taken.local_addr().unwrap().to_string();
    for (bin, args) in [
        ("lander", vec!["run", "--metrics", taken.as_str()]),
        (
            "lander-worker",
            vec!["--run", "x", "--metrics", taken.as_str()],
        ),
        ("lander", vec!["run", "--metrics", "nowhere:port"]),
        (
            "lander-worker",
            vec!["--run", "x", "--metrics", "nowhere:port"],
        ),
    ] {
        let out = Command::new(lander_tests::binary(bin))
            .args(&args)
            .output()
            .unwrap();
        assert!(!out.status.success(), "{bin} {args:?}");
        let said = stderr(&out);
        assert!(said.contains("--metrics"), "{bin} {args:?}: {said}");
        assert!(!said.contains("panicked"), "{bin} {args:?}: {said}");
    }
}

/// `bench --stress` serves the churned pool's metrics, where it served
/// none and took any `--metrics` without a word; the comparison's own
/// settings are refused with it.
#[test]
fn bench_stress_serves_its_pools_metrics_and_refuses_the_comparisons_settings() {
    let iox = Iox::new("stress_metrics");
    let addr = format!("127.0.0.1:{}", free_port());
    let bench = iox
        .command("lander")
        .args(["bench", "--stress", "--soak", "600", "--generations", "5"])
        .args([
            "--population",
            "300",
            "--kill-rate",
            "0",
            "--metrics",
            &addr,
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let dispatched = || counted(&addr, "lander_chunks_dispatched_total");
    assert!(wait_until(60, dispatched), "no chunk counted at {addr}");
    interrupt(bench);
    for (flag, value) in [
        ("--verify", "0.5"),
        ("--transports", "zenoh"),
        ("--rounds", "3"),
    ] {
        let out = iox.lander(&["bench", "--stress", flag, value]);
        assert!(!out.status.success(), "{flag}");
        assert!(
            stderr(&out).contains(&format!("'--stress' cannot be used with '{flag}")),
            "{flag}: {}",
            stderr(&out)
        );
    }
}
