//! `--verify`: a worker that answers well-formed but wrong fitness is
//! caught when the other worker flies a checked chunk again and disagrees
//! (each worker's first answers are always checked), and the chunk flown
//! in-process decides. The liar is dropped for good and its chunks flown
//! again, so the run's results are the same as in-process; without
//! `--verify` the same liar changes them. Real processes: a coordinator and
//! two attached iceoryx2 workers, one of them started with the hidden
//! `--lie`.

use lander_tests::{ended_saying, json_out, lander, stderr, without_wall_time, Iox};
use serde_json::Value;
use std::fs;
use std::process::Stdio;

const RUN: [&str; 7] = ["run", "--method", "guided", "--seed", "1", "--trial", "16"];

const LIAR: &str = "00000000000bad1d";
const HONEST: &str = "000000000000600d";

/// What a run left: its summary, generations.jsonl, best.json, what it
/// said, and its events.
struct Ran {
    summary: Value,
    generations: Vec<u8>,
    best: Vec<u8>,
    said: String,
    events: Vec<Value>,
    /// How the lying worker ended, and what it said (none in-process).
    liar: Option<std::process::Output>,
}

fn ran(
    out: &std::path::Path,
    done: &std::process::Output,
    liar: Option<std::process::Output>,
) -> Ran {
    Ran {
        liar,
        summary: without_wall_time(json_out(done)),
        generations: fs::read(out.join("generations.jsonl")).unwrap(),
        best: fs::read(out.join("best.json")).unwrap(),
        said: stderr(done),
        events: lander_tests::events(out),
    }
}

/// RUN in-process.
fn honest_run(dir: &std::path::Path) -> Ran {
    let out = dir.join("inproc");
    let mut args = RUN.to_vec();
    args.extend(["--json", "--out", out.to_str().unwrap()]);
    ran(&out, &lander(&args), None)
}

/// RUN over two attached workers, the liar and an honest one, checked at
/// `rate`.
fn with_a_liar(dir: &std::path::Path, rate: &str) -> Ran {
    let out = dir.join(format!("attached-{rate}"));
    let mut args = RUN.to_vec();
    args.extend(["--json", "--out", out.to_str().unwrap()]);
    let (done, liar) = beside_a_liar(&args, rate);
    ran(&out, &done, Some(liar))
}

/// The `lander` command `args`, over two attached workers, the liar and an
/// honest one, checked at `rate`; once it succeeded, with how the liar
/// ended.
fn beside_a_liar(args: &[&str], rate: &str) -> (std::process::Output, std::process::Output) {
    let name = format!("{}{}", args[0], rate.replace('.', "_"));
    let iox = Iox::new(&name);
    let run_id = format!("{}{}", name.replace('_', ""), std::process::id());
    let mut args = args.to_vec();
    args.extend(["--attach", "--min-workers", "2", "--run-id", &run_id]);
    args.extend(["--verify", rate]);
    let coordinator = iox
        .command("lander")
        .args(&args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let worker = |id: &str, lie: bool| {
        let mut cmd = iox.command("lander-worker");
        cmd.args(["--run", &run_id, "--id", id]);
        if lie {
            cmd.arg("--lie");
        }
        cmd.stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap()
    };
    let liar = worker(LIAR, true);
    let honest = worker(HONEST, false);
    let done = coordinator.wait_with_output().unwrap();
    assert!(done.status.success(), "{}", stderr(&done));
    // Both workers end: the liar told to leave, the honest one at the end.
    let liar = liar.wait_with_output().unwrap();
    ended_saying(honest, 0, "run finished");
    (done, liar)
}

/// A small experiment of both GAs.
const EXPERIMENT: &str = r#"
name = "checked"
seed = 5
trials = 3
methods = ["ga", "guided"]
[ga]
population = 40
max_generations = 40
max_restarts = 1
"#;

#[test]
fn an_experiment_beside_a_liar_checked_at_1_has_the_results_of_one_in_process() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("checked.toml");
    fs::write(&file, EXPERIMENT).unwrap();
    let file = file.to_str().unwrap();
    let (inproc, attached) = (dir.path().join("inproc"), dir.path().join("attached"));
    let here = lander(&["experiment", file, "--out", inproc.to_str().unwrap()]);
    assert!(here.status.success(), "{}", stderr(&here));
    let args = ["experiment", file, "--out", attached.to_str().unwrap()];
    let (done, _) = beside_a_liar(&args, "1");
    assert!(
        stderr(&done).contains(&format!("refusing worker {LIAR}")),
        "{}",
        stderr(&done)
    );
    let read = |d: &std::path::Path, name: &str| fs::read_to_string(d.join(name)).unwrap();
    assert!(read(&inproc, "generations.jsonl") == read(&attached, "generations.jsonl"));
    // trials.csv ends each row with the trial's wall time, which no two
    // runs share.
    let without_wall = |text: String| -> Vec<String> {
        text.lines()
            .map(|l| l.rsplit_once(',').map_or(l, |(row, _)| row).to_string())
            .collect()
    };
    assert_eq!(
        without_wall(read(&inproc, "trials.csv")),
        without_wall(read(&attached, "trials.csv"))
    );
}

#[test]
fn a_lying_worker_is_caught_dropped_and_its_work_done_again() {
    let dir = tempfile::tempdir().unwrap();
    let expected = honest_run(dir.path());
    for rate in ["0.2", "1"] {
        let got = with_a_liar(dir.path(), rate);
        let said = &got.said;
        assert_eq!(got.summary, expected.summary, "{rate}: {said}");
        assert!(
            got.generations == expected.generations,
            "{rate}: generations.jsonl differs"
        );
        assert_eq!(got.best, expected.best, "{rate}");
        assert!(
            said.contains(&format!("refusing worker {LIAR}"))
                && said.contains("differs from this host's (--verify, "),
            "{rate}: {said}"
        );
        assert!(
            !said.contains(&format!("refusing worker {HONEST}")),
            "{said}"
        );
        // The liar is told its answers were refused, and fails with a
        // status of its own, which a service manager is told not to
        // restart (deploy/systemd).
        let liar = got.liar.as_ref().unwrap();
        let liar_said = stderr(liar);
        assert_eq!(liar.status.code(), Some(4), "{rate}: {liar_said}");
        assert!(
            liar_said.contains("the coordinator refused this worker's answers"),
            "{rate}: {liar_said}"
        );
        // events.jsonl names the liar, and only the liar, as refused, and
        // its chunks as flown again.
        let refused: Vec<&Value> = got
            .events
            .iter()
            .filter(|e| e["event"] == "worker_refused")
            .collect();
        assert_eq!(refused.len(), 1, "{rate}: {:?}", got.events);
        assert_eq!(refused[0]["worker"], LIAR);
        // The honest worker flew again a chunk the liar answered, or the
        // liar one the honest worker answered: either way the refusal
        // names the other worker.
        let why = refused[0]["why"].as_str().unwrap();
        assert!(why.contains("(--verify, ") && why.contains(HONEST), "{why}");
        assert!(got
            .events
            .iter()
            .any(|e| e["event"] == "chunks_redispatched"
                && e["worker"] == LIAR
                && e["why"] == "refused"));
    }
}

#[test]
fn without_verify_the_liar_changes_the_results() {
    let dir = tempfile::tempdir().unwrap();
    let expected = honest_run(dir.path());
    let got = with_a_liar(dir.path(), "0");
    assert!(
        got.generations != expected.generations,
        "the liar went unnoticed and changed nothing: the lie is too weak to test --verify"
    );
    assert!(!got.events.iter().any(|e| e["event"] == "worker_refused"));
    let liar = got.liar.unwrap();
    assert!(liar.status.success(), "{}", stderr(&liar));
    assert!(stderr(&liar).contains("run finished"));
}

#[test]
fn verify_is_refused_in_process_and_out_of_range() {
    for (extra, wanted) in [
        (
            &["--verify", "0.1"][..],
            "--verify needs --workers or --attach",
        ),
        (
            &["--workers", "1", "--verify", "1.5"],
            "--verify must be a share from 0 to 1",
        ),
        (
            &["--workers", "1", "--verify", "NaN"],
            "--verify must be a share from 0 to 1",
        ),
    ] {
        let mut args = RUN.to_vec();
        args.extend_from_slice(extra);
        let out = lander(&args);
        assert!(!out.status.success(), "{extra:?}");
        assert!(stderr(&out).contains(wanted), "{extra:?}: {}", stderr(&out));
    }
}
