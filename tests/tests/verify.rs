//! `--verify`: a worker that answers well-formed but wrong fitness is
//! caught by the in-process check of its chunks, dropped for good, and its
//! chunks flown again, so the run's results are the same as in-process. Real processes: a coordinator and two attached iceoryx2
//! workers, one of them started with the hidden `--lie`.

use lander_tests::{json_out, lander, stderr, without_wall_time, Iox};
use serde_json::Value;
use std::fs;
use std::process::Stdio;

const RUN: [&str; 7] = ["run", "--method", "guided", "--seed", "1", "--trial", "16"];

#[test]
fn a_lying_worker_is_caught_dropped_and_its_work_done_again() {
    let dir = tempfile::tempdir().unwrap();
    let reference = dir.path().join("inproc");
    let mut args = RUN.to_vec();
    args.extend(["--json", "--out", reference.to_str().unwrap()]);
    let expected = without_wall_time(json_out(&lander(&args)));

    let iox = Iox::new("verify");
    let run_id = format!("verify{}", std::process::id());
    let out = dir.path().join("attached");
    let mut args = RUN.to_vec();
    args.extend([
        "--json",
        "--out",
        out.to_str().unwrap(),
        "--attach",
        "--min-workers",
        "2",
        "--run-id",
        &run_id,
        // Every answer checked: at a lower rate a liar's unsampled answers
        // of the generations before it is caught stand, and the results
        // may differ (docs/reliability.md).
        "--verify",
        "1",
    ]);
    let coordinator = iox
        .command("lander")
        .args(&args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let liar_id = "00000000000bad1d";
    let honest_id = "000000000000600d";
    let worker = |id: &str, lie: bool| {
        let mut cmd = iox.command("lander-worker");
        cmd.args(["--run", &run_id, "--id", id]);
        if lie {
            cmd.arg("--lie");
        }
        cmd.stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap()
    };
    let mut liar = worker(liar_id, true);
    let mut honest = worker(honest_id, false);
    let done = coordinator.wait_with_output().unwrap();
    let said = stderr(&done);
    assert_eq!(without_wall_time(json_out(&done)), expected, "{said}");
    assert_eq!(
        fs::read(out.join("generations.jsonl")).unwrap(),
        fs::read(reference.join("generations.jsonl")).unwrap()
    );
    assert_eq!(
        fs::read(out.join("best.json")).unwrap(),
        fs::read(reference.join("best.json")).unwrap()
    );
    assert!(
        said.contains(&format!("refusing worker {liar_id}"))
            && said.contains("differs from this host's (--verify)"),
        "{said}"
    );
    assert!(
        !said.contains(&format!("refusing worker {honest_id}")),
        "{said}"
    );
    // events.jsonl names the liar, and only the liar, as refused, and
    // its chunks as flown again.
    let events = lander_tests::events(&out);
    let refused: Vec<&Value> = events
        .iter()
        .filter(|e| e["event"] == "worker_refused")
        .collect();
    assert_eq!(refused.len(), 1, "{events:?}");
    assert_eq!(refused[0]["worker"], liar_id);
    assert!(refused[0]["why"].as_str().unwrap().contains("(--verify)"));
    assert!(events.iter().any(|e| e["event"] == "chunks_redispatched"
        && e["worker"] == liar_id
        && e["why"] == "refused"));
    // Both workers end: the liar told to leave, the honest one at the end.
    liar.wait().unwrap();
    honest.wait().unwrap();
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
