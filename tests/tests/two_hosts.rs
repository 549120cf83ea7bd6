//! Two hosts, simulated by two network namespaces joined by a veth pair:
//! the coordinator in one, its workers in the other, talking zenoh over a
//! real (virtual) link that is cut and restored mid-run. Needs root (CI runs
//! as root); where namespaces are refused the test fails and says why,
//! rather than passing without having checked anything.

use lander_tests::{binary, json_out, lines_in, stderr, wait_until, without_wall_time, Iox};
use std::fs;
use std::process::{Command, Stdio};
use std::time::Duration;

/// Runs `ip` with `args`; the error says what failed.
fn ip(args: &[&str]) -> Result<(), String> {
    let out = Command::new("ip")
        .args(args)
        .output()
        .map_err(|e| format!("ip {}: {e}", args.join(" ")))?;
    if out.status.success() {
        Ok(())
    } else {
        Err(format!(
            "ip {}: {}",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr).trim()
        ))
    }
}

/// Two namespaces `a` (10.77.n.1) and `b` (10.77.n.2), removed on drop.
struct Hosts {
    a: String,
    b: String,
    link_a: String,
    addr_a: String,
}

impl Hosts {
    fn create() -> Result<Hosts, String> {
        let n = std::process::id() % 200 + 20;
        let hosts = Hosts {
            a: format!("lander_a_{n}"),
            b: format!("lander_b_{n}"),
            link_a: format!("lva{n}"),
            addr_a: format!("10.77.{n}.1"),
        };
        let link_b = format!("lvb{n}");
        let addr_b = format!("10.77.{n}.2");
        ip(&["netns", "add", &hosts.a])?;
        ip(&["netns", "add", &hosts.b])?;
        ip(&[
            "link",
            "add",
            &hosts.link_a,
            "type",
            "veth",
            "peer",
            "name",
            &link_b,
        ])?;
        ip(&["link", "set", &hosts.link_a, "netns", &hosts.a])?;
        ip(&["link", "set", &link_b, "netns", &hosts.b])?;
        for (ns, link, addr) in [
            (&hosts.a, &hosts.link_a, &hosts.addr_a),
            (&hosts.b, &link_b, &addr_b),
        ] {
            ip(&["-n", ns, "addr", "add", &format!("{addr}/24"), "dev", link])?;
            ip(&["-n", ns, "link", "set", link, "up"])?;
            ip(&["-n", ns, "link", "set", "lo", "up"])?;
        }
        Ok(hosts)
    }

    fn link(&self, state: &str) {
        ip(&["-n", &self.a, "link", "set", &self.link_a, state]).unwrap();
    }
}

impl Drop for Hosts {
    fn drop(&mut self) {
        let _ = ip(&["netns", "del", &self.a]);
        let _ = ip(&["netns", "del", &self.b]);
    }
}

#[test]
fn workers_on_another_host_survive_a_cut_link() {
    let hosts = Hosts::create().unwrap_or_else(|e| {
        panic!("setting up the two hosts needs root (network namespaces and a veth pair): {e}")
    });
    let iox = Iox::new("two_hosts");
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("never-lands.toml");
    fs::write(&cfg, "[scoring]\nsafe_speed = 0.0\n").unwrap();
    let users = dir.path().join("users.txt");
    fs::write(&users, "worker:s3cret\n").unwrap();
    let cfg = cfg.to_str().unwrap();
    let args = [
        "--method",
        "guided",
        "--seed",
        "11",
        "--population",
        "300",
        "--max-generations",
        "150",
        "--max-restarts",
        "1",
        "--json",
        "--config",
        cfg,
    ];
    let calm_dir = dir.path().join("calm");
    let mut calm_args = vec!["run", "--out", calm_dir.to_str().unwrap()];
    calm_args.extend(args);
    let calm = without_wall_time(json_out(&iox.lander(&calm_args)));
    let calm_log = fs::read(calm_dir.join("generations.jsonl")).unwrap();

    let run_id = format!("hosts{}", std::process::id());
    let listen = format!("tcp/{}:7447", hosts.addr_a);
    let out = dir.path().join("run");
    let lander = binary("lander");
    let coordinator = Command::new("ip")
        .args(["netns", "exec", &hosts.a])
        .arg(&lander)
        .args(["run", "--out", out.to_str().unwrap()])
        .args(args)
        .args([
            "--attach",
            "--run-id",
            &run_id,
            "--transport",
            "zenoh",
            "--listen",
            &listen,
            // Both workers join before the first generation, so both are
            // there when the link is cut, and both see the run end: a
            // worker that joined only after the run would wait for its
            // coordinator for ever, as workers do.
            "--min-workers",
            "2",
        ])
        .args(["--users", users.to_str().unwrap()])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let worker = binary("lander-worker");
    let workers: Vec<_> = (0..2)
        .map(|_| {
            Command::new("ip")
                .args(["netns", "exec", &hosts.b])
                .arg(&worker)
                .args([
                    "--run",
                    &run_id,
                    "--transport",
                    "zenoh",
                    "--connect",
                    &listen,
                ])
                .args(["--credentials", users.to_str().unwrap()])
                .stderr(Stdio::piped())
                .spawn()
                .unwrap()
        })
        .collect();
    let log = out.join("generations.jsonl");
    assert!(
        wait_until(60, || lines_in(&log) >= 20),
        "the run did not get going"
    );
    hosts.link("down");
    let at_cut = lines_in(&log);
    std::thread::sleep(Duration::from_secs(2));
    hosts.link("up");
    assert!(at_cut < 300, "the run ended before the link was cut");

    let done = coordinator.wait_with_output().unwrap();
    assert!(done.status.success(), "{}", stderr(&done));
    assert_eq!(without_wall_time(json_out(&done)), calm);
    assert!(
        fs::read(&log).unwrap() == calm_log,
        "generations.jsonl differs"
    );
    for mut w in workers {
        // A worker that never leaves would hang the test; fail instead,
        // with what it said.
        let left = wait_until(60, || w.try_wait().unwrap().is_some());
        if !left {
            let _ = w.kill();
        }
        let w = w.wait_with_output().unwrap();
        assert!(
            left,
            "a worker had not left a minute after the run ended: {}",
            stderr(&w)
        );
        assert!(w.status.success(), "{}", stderr(&w));
    }
}
