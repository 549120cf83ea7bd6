//! Helpers for the end-to-end tests in `tests/tests/`: find the real
//! binaries, run them, and read what they wrote.

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

/// The path of one of the workspace's binaries, built with the same profile
/// as the tests on first use, so `cargo test` alone is enough.
pub fn binary(name: &str) -> PathBuf {
    static BUILT: OnceLock<()> = OnceLock::new();
    let dir = profile_dir();
    BUILT.get_or_init(|| {
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let mut cmd = Command::new(cargo);
        cmd.args(["build", "--workspace", "--bins", "--quiet"]);
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

/// A JSON summary with its wall time removed, for byte comparisons.
pub fn without_wall_time(mut v: Value) -> Value {
    if let Some(obj) = v.as_object_mut() {
        obj.remove("wall_s");
    }
    v
}

pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}
