//! `lander experiment` and `lander replay` as a user runs them: every output
//! file, their agreement, determinism across backends, and resuming after a
//! kill.

use lander_tests::{json_lines, lander, stderr, wait_until, Iox};
use serde_json::Value;
use std::collections::BTreeMap;
use std::fs;
use std::path::Path;
use std::process::Command;

/// A small experiment: 3 trials of every method, with small caps.
const SMALL: &str = r#"
name = "small"
seed = 3
trials = 3
methods = ["ga", "guided", "qlearning"]
figure_trial = 2
[ga]
population = 40
max_generations = 60
max_restarts = 1
[qlearning]
episodes = 300
"#;

fn write_file(dir: &Path, text: &str) -> String {
    let path = dir.join("small.toml");
    fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

fn run_experiment(file: &str, out: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec!["experiment", file, "--json", "--out", out.to_str().unwrap()];
    args.extend_from_slice(extra);
    lander(&args)
}

/// `trials.csv` as rows of column name to value.
fn csv_rows(path: &Path) -> Vec<BTreeMap<String, String>> {
    let text = fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    lines
        .map(|l| {
            header
                .iter()
                .zip(l.split(','))
                .map(|(h, v)| (h.to_string(), v.to_string()))
                .collect()
        })
        .collect()
}

/// The rows without the wall time, which no two runs share.
fn results_of(dir: &Path) -> Vec<BTreeMap<String, String>> {
    let mut rows = csv_rows(&dir.join("trials.csv"));
    for r in &mut rows {
        r.remove("wall_s");
    }
    rows
}

#[test]
fn a_small_experiment_writes_every_file_and_they_agree() {
    let dir = tempfile::tempdir().unwrap();
    let file = write_file(dir.path(), SMALL);
    let out = dir.path().join("out");
    let run = run_experiment(&file, &out, &[]);
    assert!(run.status.success(), "{}", stderr(&run));
    let summary: Value = serde_json::from_slice(&run.stdout).unwrap();

    for name in [
        "trials.csv",
        "generations.jsonl",
        "summary.json",
        "summary.md",
        "report.html",
        "fig3-generations.svg",
        "fig3-generations.png",
        "fig4-fitness-trial2.svg",
        "fig4-fitness-trial2.png",
        "qlearning-curve.svg",
        "qlearning-curve.png",
    ] {
        let bytes = fs::read(out.join(name)).unwrap_or_else(|_| panic!("{name} missing"));
        assert!(!bytes.is_empty(), "{name} is empty");
        if name.ends_with(".png") {
            assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "{name}");
        }
        if name.ends_with(".svg") {
            assert!(String::from_utf8_lossy(&bytes).contains("<svg"), "{name}");
        }
    }
    let stored: Value =
        serde_json::from_str(&fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(stored, summary, "stdout and summary.json differ");

    // One CSV row per method and trial, in trial order.
    let rows = csv_rows(&out.join("trials.csv"));
    let order: Vec<(&str, &str)> = rows
        .iter()
        .map(|r| (r["method"].as_str(), r["trial"].as_str()))
        .collect();
    assert_eq!(
        order,
        [
            ("ga", "1"),
            ("guided", "1"),
            ("qlearning", "1"),
            ("ga", "2"),
            ("guided", "2"),
            ("qlearning", "2"),
            ("ga", "3"),
            ("guided", "3"),
            ("qlearning", "3"),
        ]
    );
    // Paired: a trial's methods share x0 and pad_x.
    for t in rows.chunks(3) {
        assert!(t
            .iter()
            .all(|r| r["x0"] == t[0]["x0"] && r["pad_x"] == t[0]["pad_x"]));
    }

    // generations.jsonl holds every generation the CSV counts.
    let lines = json_lines(&out.join("generations.jsonl"));
    for r in rows.iter().filter(|r| r["method"] != "qlearning") {
        let flown = lines
            .iter()
            .filter(|l| {
                l["method"] == r["method"].as_str()
                    && l["trial"] == r["trial"].parse::<u64>().unwrap()
            })
            .count();
        assert_eq!(flown.to_string(), r["generations"], "{r:?}");
        assert!(r["episodes"].is_empty());
    }

    // The summary counts what the CSV says.
    for m in summary["methods"].as_array().unwrap() {
        let name = m["method"].as_str().unwrap();
        let of: Vec<_> = rows.iter().filter(|r| r["method"] == name).collect();
        let landed = of.iter().filter(|r| r["landed"] == "true").count();
        assert_eq!(m["trials"], of.len());
        assert_eq!(m["landed"], landed);
    }
    let q = &summary["qlearning"];
    assert_eq!(q["trials"], 3);
    assert_eq!(q["episodes"], 300);
    let q_rows: Vec<_> = rows.iter().filter(|r| r["method"] == "qlearning").collect();
    let q_landed = q_rows.iter().filter(|r| r["landed"] == "true").count();
    assert_eq!(q["landed"], q_landed);
    for r in q_rows {
        assert!(r["generations"].is_empty());
        assert_eq!(r["landed"] == "true", !r["episodes"].is_empty());
    }
    let p = &summary["paired"];
    assert_eq!(p["pairs"], 3);
    let fewer = rows
        .chunks(3)
        .filter(|t| {
            t[1]["generations"].parse::<u64>().unwrap()
                < t[0]["generations"].parse::<u64>().unwrap()
        })
        .count();
    assert_eq!(p["guided_fewer"], fewer);
    assert!(!summary["claims"].as_array().unwrap().is_empty());

    let md = fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(md.contains("Wilcoxon signed-rank test") || p["wilcoxon"].is_null());
    assert!(md.contains("## The paper's statements"));

    // The best landing replays from the folder.
    let svg = dir.path().join("best.svg");
    let replay = || {
        lander(&[
            "replay",
            "--run",
            out.to_str().unwrap(),
            "--out",
            svg.to_str().unwrap(),
        ])
    };
    let replayed = replay();
    assert!(replayed.status.success(), "{}", stderr(&replayed));
    assert!(fs::read_to_string(&svg).unwrap().contains("<svg"));

    // An experiment.json out of an experiment's ranges is refused, named,
    // before any flight: this world would fly 4 × 10^9 ticks a lander.
    let definition = out.join("experiment.json");
    let kept = fs::read_to_string(&definition).unwrap();
    let mut exp: Value = serde_json::from_str(&kept).unwrap();
    exp["world"]["max_ticks"] = u32::MAX.into();
    fs::write(&definition, exp.to_string()).unwrap();
    let refused = replay();
    assert!(!refused.status.success());
    let said = stderr(&refused);
    assert!(
        said.contains("experiment.json") && said.contains("world.max_ticks"),
        "{said}"
    );
    fs::write(&definition, kept).unwrap();

    // Without experiment.json, the folder is not taken for a run's.
    fs::remove_file(out.join("experiment.json")).unwrap();
    let refused = replay();
    assert!(!refused.status.success());
    assert!(
        stderr(&refused).contains("holds trial records (trials/) but no experiment.json"),
        "{}",
        stderr(&refused)
    );
}

#[test]
fn results_do_not_depend_on_workers_or_trials_in_flight() {
    let dir = tempfile::tempdir().unwrap();
    let file = write_file(dir.path(), SMALL);
    let inproc = dir.path().join("inproc");
    let serial = dir.path().join("serial");
    let workers = dir.path().join("workers");
    assert!(run_experiment(&file, &inproc, &[]).status.success());
    assert!(
        run_experiment(&file, &serial, &["--in-flight", "1", "--threads", "1"])
            .status
            .success()
    );
    let iox = Iox::new("experiment");
    let out = iox.lander(&[
        "experiment",
        &file,
        "--json",
        "--workers",
        "2",
        "--out",
        workers.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    // One worker and a coordinator flying a share: its three Q(λ) trials
    // fill the worker's queue, and the coordinator takes the last back.
    let shared = dir.path().join("shared");
    let out = iox.lander(&[
        "experiment",
        &file,
        "--workers",
        "1",
        "--coordinator-share",
        "always",
        "--out",
        shared.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let expected = results_of(&inproc);
    assert_eq!(results_of(&serial), expected);
    assert_eq!(results_of(&workers), expected);
    assert_eq!(results_of(&shared), expected);
    for run in [&workers, &shared] {
        assert_eq!(
            fs::read(inproc.join("generations.jsonl")).unwrap(),
            fs::read(run.join("generations.jsonl")).unwrap()
        );
    }
}

#[test]
fn a_killed_experiment_resumes_where_it_stopped() {
    let dir = tempfile::tempdir().unwrap();
    // Long enough that the kill lands mid-run.
    let text = SMALL
        .replace("trials = 3", "trials = 8")
        .replace("max_generations = 60", "max_generations = 400")
        .replace("episodes = 300", "episodes = 3000");
    let file = write_file(dir.path(), &text);
    let whole = dir.path().join("whole");
    let out = dir.path().join("killed");
    assert!(run_experiment(&file, &whole, &[]).status.success());

    let mut child = Command::new(lander_tests::binary("lander"))
        .args(["experiment", &file, "--out", out.to_str().unwrap()])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let trials = out.join("trials");
    let started = wait_until(60, || fs::read_dir(&trials).map_or(0, |d| d.count()) >= 2);
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(started, "no trial finished within a minute");
    assert!(
        !out.join("summary.json").exists(),
        "the run ended before the kill"
    );
    let kept = fs::read_dir(&trials).unwrap().count();
    assert!(kept < 24, "every trial had finished");

    // Without --resume the folder is refused, not overwritten.
    let refused = run_experiment(&file, &out, &[]);
    assert!(!refused.status.success());
    assert!(
        stderr(&refused).contains("--resume"),
        "{}",
        stderr(&refused)
    );
    // A different experiment may not resume it.
    let other = run_experiment(&file, &out, &["--resume", "--trials", "9"]);
    assert!(!other.status.success());
    assert!(
        stderr(&other).contains("trials: ") && stderr(&other).contains(" there, 9 here"),
        "{}",
        stderr(&other)
    );

    let resumed = run_experiment(&file, &out, &["--resume"]);
    assert!(resumed.status.success(), "{}", stderr(&resumed));
    assert_eq!(results_of(&out), results_of(&whole));
    assert_eq!(fs::read_dir(&trials).unwrap().count(), 24);
}

#[test]
fn bad_experiment_files_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let missing = lander(&["experiment", "/nonexistent/paper.toml"]);
    assert!(!missing.status.success());
    assert!(stderr(&missing).contains("/nonexistent/paper.toml"));
    // The OS's reason, said once; and no claim that it is a run's config.
    let said = stderr(&missing);
    assert_eq!(said.matches("No such file").count(), 1, "{said}");
    assert!(!said.contains("config file"), "{said}");
    for (text, field) in [
        ("trials = 0", "trials"),
        ("methods = [\"ga\", \"sarsa\"]", "sarsa"),
        ("[ga]\nmutation_rate = 2.0", "ga.mutation_rate"),
        ("colour = \"red\"", "colour"),
    ] {
        let file = write_file(dir.path(), text);
        let out = run_experiment(&file, &dir.path().join("never"), &[]);
        assert!(!out.status.success(), "{text}");
        let err = stderr(&out);
        assert!(
            err.contains(field) && err.contains("small.toml"),
            "{text}: {err}"
        );
        assert!(!err.contains("panicked"), "{err}");
    }
    assert!(!dir.path().join("never").exists());
    let file = write_file(dir.path(), SMALL);
    let zero = run_experiment(&file, &dir.path().join("never"), &["--trials", "0"]);
    assert!(stderr(&zero).contains("trials"), "{}", stderr(&zero));
    let none = run_experiment(&file, &dir.path().join("never"), &["--in-flight", "0"]);
    assert!(!none.status.success());
    assert!(stderr(&none).contains("--in-flight"), "{}", stderr(&none));
    let many = run_experiment(&file, &dir.path().join("never"), &["--threads", "5000"]);
    assert!(
        stderr(&many).contains("'--threads <THREADS>': 5000 is not in 0..=1024"),
        "{}",
        stderr(&many)
    );
    // Refused before the folder is written: the corrected command would
    // otherwise find an experiment it was not asked to resume.
    assert!(!dir.path().join("never").exists());
    let both = run_experiment(
        &file,
        &dir.path().join("never"),
        &["--threads", "2", "--attach"],
    );
    assert!(
        stderr(&both).contains("--threads is for in-process"),
        "{}",
        stderr(&both)
    );
    assert!(!dir.path().join("never").exists());
    // A run's or a sweep's folder is refused, its files left as they were.
    for marker in ["best.json", "sweep.json"] {
        let theirs = dir.path().join(marker);
        fs::create_dir(&theirs).unwrap();
        fs::write(theirs.join(marker), "{}").unwrap();
        fs::write(theirs.join("summary.json"), "theirs").unwrap();
        let out = run_experiment(&file, &theirs, &[]);
        assert!(!out.status.success());
        assert!(stderr(&out).contains(marker), "{}", stderr(&out));
        assert_eq!(
            fs::read_to_string(theirs.join("summary.json")).unwrap(),
            "theirs"
        );
        assert!(!theirs.join("experiment.json").exists());
    }
}

#[test]
fn the_report_loads_in_a_browser_with_its_plots_and_a_running_replay() {
    use lander_tests::browser;
    use std::time::Duration;
    let dir = tempfile::tempdir().unwrap();
    let file = write_file(dir.path(), SMALL);
    let out = dir.path().join("out");
    let run = run_experiment(&file, &out, &[]);
    assert!(run.status.success(), "{}", stderr(&run));

    let page = browser::open(&out.join("report.html")).expect("chromium opens report.html");
    page.wait_for(
        "document.querySelectorAll('canvas').length > 0",
        Duration::from_secs(20),
    )
    .expect("the replay's canvas appears");
    // The replay plays by itself: its canvas gets drawn on.
    let mut painted = false;
    for _ in 0..100 {
        if page
            .canvas_is_painted("canvas")
            .expect("the canvas can be read")
        {
            painted = true;
            break;
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    assert!(painted, "the replay canvas stayed blank");
    let (total, decoded) = page.images_decoded().expect("images can be counted");
    assert_eq!(total, 3, "Figure 3, Figure 4 and the learning curve");
    assert_eq!(decoded, total, "undecoded: {:?}", page.undecoded_images());
    let errors = page.console_errors();
    assert!(errors.is_empty(), "console errors: {errors:?}");
}

/// An `--out` that cannot be made is named itself, not a folder inside it.
#[test]
fn an_out_folder_that_cannot_be_made_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let file = write_file(dir.path(), SMALL);
    let blocker = dir.path().join("a-file");
    fs::write(&blocker, "").unwrap();
    let out = blocker.join("results");
    let said = stderr(&run_experiment(&file, &out, &[]));
    assert!(
        said.contains(&format!("{}: cannot create the folder", out.display())),
        "{said}"
    );
    assert!(!said.contains("results/trials"), "{said}");
}
