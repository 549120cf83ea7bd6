//! Helpers for the end-to-end tests in `tests/tests/`: find the real
//! binaries, run them, and read what they wrote.

pub mod browser;

pub use lander_coordinator::pool::worker_children;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

/// The folder the test binary was built into, `target/<profile>`.
fn profile_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("the test knows its own path");
    // target/<profile>/deps/<test>
    exe.parent()
        .and_then(Path::parent)
        .expect("test binaries live in target/<profile>/deps")
        .to_path_buf()
}

/// What cargo sets for the package under test, not for a build.
const PACKAGE_VARIABLES: &[&str] = &[
    "CARGO_MANIFEST_",
    "CARGO_PKG_",
    "CARGO_CRATE_NAME",
    "CARGO_BIN_",
    "CARGO_PRIMARY_PACKAGE",
    "CARGO_TARGET_TMPDIR",
    "CARGO_RUSTC_CURRENT_DIR",
    "OUT_DIR",
];

/// The path of one of the workspace's binaries, built with the same profile
/// as the tests on first use, so `cargo test` alone is enough.
pub fn binary(name: &str) -> PathBuf {
    static BUILT: OnceLock<()> = OnceLock::new();
    let dir = profile_dir();
    BUILT.get_or_init(|| {
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let mut cmd = Command::new(cargo);
        // `--bins` for the executables (`cargo test` builds only those of
        // packages with integration tests); `--tests` so that they get the
        // dev-dependencies' features as under `cargo test --workspace`, not
        // a second zenoh.
        cmd.args(["build", "--workspace", "--bins", "--tests", "--quiet"]);
        // cargo gives this test process its package's variables
        // (CARGO_MANIFEST_DIR, CARGO_PKG_NAME, …). ring's build script
        // reruns when they change, so passing them on would rebuild ring,
        // rustls and zenoh here, and again at the next `cargo test`.
        for (key, _) in std::env::vars_os() {
            let key = key.to_string_lossy();
            if PACKAGE_VARIABLES.iter().any(|p| key.starts_with(p)) {
                cmd.env_remove(&*key);
            }
        }
        match dir.file_name().and_then(|n| n.to_str()) {
            Some("debug") | None => {}
            Some(profile) => {
                cmd.args(["--profile", profile]);
            }
        }
        let status = cmd.status().expect("cargo runs");
        assert!(status.success(), "building the binaries failed");
    });
    dir.join(name)
}

/// Runs `lander` with `args` and returns its output.
pub fn lander(args: &[&str]) -> Output {
    Command::new(binary("lander"))
        .args(args)
        .output()
        .expect("lander starts")
}

/// Stdout as one JSON value; panics with stderr when the command failed.
pub fn json_out(out: &Output) -> Value {
    assert!(
        out.status.success(),
        "command failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("stdout is one JSON object")
}

/// Every line of a JSON-lines file, parsed.
pub fn json_lines(path: &Path) -> Vec<Value> {
    let text = std::fs::read_to_string(path).expect("the file exists");
    text.lines()
        .map(|l| serde_json::from_str(l).expect("each line is JSON"))
        .collect()
}

/// A JSON summary with its wall time removed, for byte comparisons.
pub fn without_wall_time(mut v: Value) -> Value {
    if let Some(obj) = v.as_object_mut() {
        obj.remove("wall_s");
    }
    v
}

/// `cmd`, started as a terminal starts a program: with SIGINT's default
/// disposition. A test run from a background job (`cargo test &` without
/// job control) inherits SIGINT ignored; then a program signalled before it
/// installs its handlers, or a shell script (bash cannot trap a signal
/// ignored on entry), never sees the SIGINT its test sends.
pub fn as_from_a_terminal(cmd: &mut Command) -> &mut Command {
    use std::os::unix::process::CommandExt;
    // SAFETY: between fork and exec the child only calls signal(2), which
    // is async-signal-safe, and touches no memory of the parent's.
    unsafe {
        cmd.pre_exec(|| {
            libc::signal(libc::SIGINT, libc::SIG_DFL);
            Ok(())
        })
    }
}

pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Waits for `child` to end, and asserts it ended with status `code`
/// having said `words` on stderr; returns what it left.
pub fn ended_saying(child: std::process::Child, code: i32, words: &str) -> Output {
    let out = child.wait_with_output().expect("the process is waited for");
    let said = stderr(&out);
    assert_eq!(out.status.code(), Some(code), "{said}");
    assert!(said.contains(words), "{words:?} unsaid: {said}");
    out
}

/// What `child` left once it ended, within `secs` seconds; one still
/// running then is killed, and the test fails saying what it `waited` for.
/// Its output must fit the pipes' buffers, as read only at its end.
pub fn ended_within(mut child: std::process::Child, secs: u64, waited: &str) -> Output {
    if !wait_until(secs, || has_exited(child.id())) {
        let _ = child.kill();
        let out = child.wait_with_output().expect("the process is waited for");
        panic!("{waited}: still running after {secs} s; {}", stderr(&out));
    }
    child.wait_with_output().expect("the process is waited for")
}

/// A child process killed if the test lets go of it still running, as a
/// failed assertion does: a worker started with `--rejoin` would otherwise
/// wait for its run for ever.
pub struct KillOnDrop(Option<std::process::Child>);

impl KillOnDrop {
    pub fn new(child: std::process::Child) -> KillOnDrop {
        KillOnDrop(Some(child))
    }

    pub fn id(&self) -> u32 {
        self.0.as_ref().map_or(0, std::process::Child::id)
    }

    /// The child, no longer killed when let go of.
    pub fn into_inner(mut self) -> std::process::Child {
        self.0.take().expect("the child is held until taken")
    }
}

impl Drop for KillOnDrop {
    fn drop(&mut self) {
        if let Some(child) = &mut self.0 {
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

/// An isolated iceoryx2 namespace for one test: its own file prefix and
/// root folder, removed afterwards.
pub struct Iox {
    pub prefix: String,
    root: tempfile::TempDir,
}

impl Iox {
    pub fn new(test: &str) -> Iox {
        let prefix = format!("lander_test_{test}_{}_", std::process::id());
        let root = tempfile::tempdir().expect("a temporary folder");
        Iox { prefix, root }
    }

    /// A command for `bin` that uses this namespace.
    pub fn command(&self, bin: &str) -> Command {
        self.command_at(&binary(bin))
    }

    /// A command for the executable at `exe` that uses this namespace,
    /// started [as from a terminal](as_from_a_terminal).
    pub fn command_at(&self, exe: &Path) -> Command {
        let mut cmd = Command::new(exe);
        cmd.env("LANDER_IOX2_PREFIX", &self.prefix)
            .env("LANDER_IOX2_ROOT", self.root.path());
        as_from_a_terminal(&mut cmd);
        cmd
    }

    /// Points this process's own iceoryx2 use at the test's resources, for
    /// a test that opens a pool in-process. The environment is the
    /// process's, so such a test needs a test file of its own.
    pub fn enter(&self) {
        std::env::set_var("LANDER_IOX2_PREFIX", &self.prefix);
        std::env::set_var("LANDER_IOX2_ROOT", self.root.path());
    }

    /// `lander` with `args` in this namespace, run to completion.
    pub fn lander(&self, args: &[&str]) -> Output {
        self.command("lander")
            .args(args)
            .output()
            .expect("lander starts")
    }

    /// This namespace's files in /dev/shm, except the one management file
    /// iceoryx2 keeps per prefix for good.
    pub fn shm_files(&self) -> Vec<String> {
        let Ok(dir) = std::fs::read_dir("/dev/shm") else {
            return Vec::new();
        };
        dir.filter_map(|e| e.ok()?.file_name().into_string().ok())
            .filter(|n| n.starts_with(&self.prefix) && !n.ends_with("global_mgmt"))
            .collect()
    }

    /// Files under this namespace's root, where iceoryx2 keeps services,
    /// node records and event sockets.
    pub fn root_files(&self) -> Vec<PathBuf> {
        fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
            for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
                let path = entry.path();
                if path.is_dir() {
                    walk(&path, out);
                } else {
                    out.push(path);
                }
            }
        }
        let mut out = Vec::new();
        walk(self.root.path(), &mut out);
        out
    }
}

impl Drop for Iox {
    fn drop(&mut self) {
        if let Ok(dir) = std::fs::read_dir("/dev/shm") {
            for entry in dir.flatten() {
                if entry
                    .file_name()
                    .to_string_lossy()
                    .starts_with(&self.prefix)
                {
                    let _ = std::fs::remove_file(entry.path());
                }
            }
        }
    }
}

/// Sends `signal` (e.g. "KILL", "TERM", "STOP") to `pid`.
pub fn signal(pid: u32, signal: &str) {
    let status = Command::new("kill")
        .args([&format!("-{signal}"), &pid.to_string()])
        .status()
        .expect("kill runs");
    assert!(status.success(), "kill -{signal} {pid} failed");
}

/// Sends SIGINT to a `lander` under way and waits for it: it must stop as
/// Ctrl-C stops it, exiting 130 and saying so.
pub fn interrupt(child: std::process::Child) -> Output {
    signal(child.id(), "INT");
    let out = child.wait_with_output().expect("lander is waited for");
    assert_eq!(out.status.code(), Some(130), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("stopped by SIGINT"),
        "{}",
        stderr(&out)
    );
    out
}

/// Lines in a file so far, 0 if it does not exist yet.
pub fn lines_in(path: &Path) -> usize {
    std::fs::read_to_string(path).map_or(0, |t| t.lines().count())
}

/// Polls `ready` every 10 ms for up to `secs` seconds.
pub fn wait_until(secs: u64, mut ready: impl FnMut() -> bool) -> bool {
    let end = std::time::Instant::now() + std::time::Duration::from_secs(secs);
    while std::time::Instant::now() < end {
        if ready() {
            return true;
        }
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    false
}

/// A loopback port free right now (the OS picks it; it is released for the
/// caller to bind).
pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .expect("a free loopback port")
        .port()
}

/// The body of `GET http://addr/path`, or why there is none (no answer
/// yet, or a status other than 200).
pub fn http_get(addr: &str, path: &str) -> Result<String, String> {
    use std::io::{Read, Write};
    let mut s = std::net::TcpStream::connect(addr).map_err(|e| e.to_string())?;
    s.set_read_timeout(Some(std::time::Duration::from_secs(10)))
        .map_err(|e| e.to_string())?;
    write!(s, "GET {path} HTTP/1.0\r\nHost: {addr}\r\n\r\n").map_err(|e| e.to_string())?;
    let mut reply = String::new();
    s.read_to_string(&mut reply).map_err(|e| e.to_string())?;
    let (head, body) = reply.split_once("\r\n\r\n").ok_or("no HTTP reply")?;
    let status = head.split(' ').nth(1).unwrap_or_default();
    if status != "200" {
        return Err(format!("status {status}: {body}"));
    }
    Ok(body.to_string())
}

/// The events of a run folder's `events.jsonl`.
pub fn events(dir: &Path) -> Vec<Value> {
    lander_telemetry::events::read(dir).expect("events.jsonl reads back")
}

/// The process ids of the workers that joined, as their `worker_joined`
/// events give them.
pub fn joined(events: &[Value]) -> Vec<u32> {
    events
        .iter()
        .filter(|e| e["event"] == "worker_joined")
        .filter_map(|e| u32::try_from(e["pid"].as_u64()?).ok())
        .collect()
}

/// The id of the worker with process id `pid`, as its `worker_joined`
/// event gave it.
pub fn worker_id_of(events: &[Value], pid: u32) -> Option<String> {
    events
        .iter()
        .find(|e| e["event"] == "worker_joined" && e["pid"] == pid)
        .and_then(|e| e["worker"].as_str().map(str::to_string))
}

/// A shell script of `body` written at `path`, executable and
/// [`ready_to_run`]: run with `ready`, it ends at once.
pub fn script(path: &Path, body: &str) {
    use std::os::unix::fs::PermissionsExt;
    let text = format!("#!/bin/sh\n[ \"$1\" = ready ] && exit 0\n{body}");
    std::fs::write(path, text).unwrap();
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o755)).unwrap();
    ready_to_run(path, "ready");
}

/// Waits until the file just written at `path` can run, running it once
/// with `arg`, which must end it at once. A process another test forked
/// while the file was open for writing holds it open until that process
/// execs, and until then running the file fails as busy (ETXTBSY); once it
/// has run, no such copy is left, and none can be made.
pub fn ready_to_run(path: &Path, arg: &str) {
    for _ in 0..1000 {
        match Command::new(path).arg(arg).output() {
            Err(e) if e.kind() == std::io::ErrorKind::ExecutableFileBusy => {
                std::thread::sleep(std::time::Duration::from_millis(1));
            }
            ran => {
                let ran = ran.unwrap();
                assert!(ran.status.success(), "{} {arg}: {ran:?}", path.display());
                return;
            }
        }
    }
    panic!("{} stayed busy for a second", path.display());
}

/// True once process `pid` has exited: gone, or a zombie nobody reaped
/// (a worker that outlived its coordinator is reparented, and a
/// container's init may never reap it).
pub fn has_exited(pid: u32) -> bool {
    std::fs::read_to_string(format!("/proc/{pid}/stat")).map_or(true, |stat| {
        stat.rsplit(')')
            .next()
            .unwrap_or("")
            .trim_start()
            .starts_with('Z')
    })
}
