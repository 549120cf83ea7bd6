//! `lander run`, `fly` and `guide` as a user runs them.

use lander_tests::{json_lines, json_out, lander, stderr, without_wall_time};
use std::fs;

fn run_in(dir: &std::path::Path, extra: &[&str]) -> serde_json::Value {
    let out = dir.to_str().unwrap();
    let mut args = vec!["run", "--seed", "1", "--json", "--out", out];
    args.extend_from_slice(extra);
    json_out(&lander(&args))
}

#[test]
fn guided_seed_1_lands_and_repeats_exactly() {
    let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let first = run_in(a.path(), &["--method", "guided"]);
    assert_eq!(first["landed"], true);
    assert_eq!(first["method"], "guided");
    let keys: Vec<&str> = first
        .as_object()
        .unwrap()
        .keys()
        .map(String::as_str)
        .collect();
    assert_eq!(
        keys,
        [
            "method",
            "seed",
            "trial",
            "x0",
            "pad_x",
            "landed",
            "generations",
            "restarts",
            "best_fitness",
            "best_genome",
            "wall_s"
        ]
    );
    let second = run_in(b.path(), &["--method", "guided"]);
    assert_eq!(without_wall_time(first.clone()), without_wall_time(second));
    let log = |d: &tempfile::TempDir| fs::read(d.path().join("generations.jsonl")).unwrap();
    assert_eq!(log(&a), log(&b));

    // Every generation is a line; the last is the landing.
    let lines = json_lines(&a.path().join("generations.jsonl"));
    assert_eq!(lines.len() as u64, first["generations"].as_u64().unwrap());
    assert_eq!(lines.last().unwrap()["best"], 9_999_999.0);
    for key in ["index", "restart", "best", "mean", "evaluated", "ticks"] {
        assert!(lines[0].get(key).is_some(), "generations.jsonl lacks {key}");
    }

    // best.json holds the landing genome, which `lander fly` confirms.
    let best: serde_json::Value =
        serde_json::from_slice(&fs::read(a.path().join("best.json")).unwrap()).unwrap();
    assert_eq!(best["genome"], first["best_genome"]);
    let flown = json_out(&lander(&[
        "fly",
        "--genome",
        best["genome"].as_str().unwrap(),
        "--x0",
        &first["x0"].to_string(),
        "--pad-x",
        &first["pad_x"].to_string(),
    ]));
    assert_eq!(flown["safe"], true);
    assert_eq!(flown["fitness"], 9_999_999.0);
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    for method in ["ga", "guided"] {
        let dirs: Vec<_> = (0..3).map(|_| tempfile::tempdir().unwrap()).collect();
        let runs: Vec<_> = ["1", "2", "3"]
            .iter()
            .zip(&dirs)
            .map(|(t, d)| {
                run_in(
                    d.path(),
                    &[
                        "--method",
                        method,
                        "--threads",
                        t,
                        "--max-generations",
                        "30",
                        "--max-restarts",
                        "1",
                    ],
                )
            })
            .collect();
        let read = |file: &str| -> Vec<Vec<u8>> {
            dirs.iter()
                .map(|d| fs::read(d.path().join(file)).unwrap())
                .collect()
        };
        let (logs, bests) = (read("generations.jsonl"), read("best.json"));
        for i in 1..3 {
            assert_eq!(
                without_wall_time(runs[0].clone()),
                without_wall_time(runs[i].clone())
            );
            assert_eq!(logs[0], logs[i], "{method}: generations.jsonl differs");
            assert_eq!(bests[0], bests[i], "{method}: best.json differs");
        }
    }
}

#[test]
fn bad_configuration_is_refused_naming_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("bad.toml");
    for (text, needle) in [
        ("[ga]\npopulation = 0\n", "ga.population"),
        ("[ga]\ncrossover_rate = 1.5\n", "ga.crossover_rate"),
        ("[ga]\nmax_duration = 0\n", "ga.max_duration"),
        ("[guided]\nepsilon = nan\n", "guided.epsilon"),
        ("[world]\nheight = 100\n", "world.height must be more than"),
        ("[ga]\npopsize = 10\n", "unknown field `popsize`"),
        ("method = \"annealing\"\n", "unknown variant `annealing`"),
        ("[ga\n", "bad.toml"),
    ] {
        fs::write(&cfg, text).unwrap();
        let out = lander(&[
            "run",
            "--config",
            cfg.to_str().unwrap(),
            "--out",
            dir.path().to_str().unwrap(),
        ]);
        assert!(!out.status.success(), "{text:?} was accepted");
        let said = stderr(&out);
        assert!(said.contains(needle), "{text:?}: {said}");
        assert!(said.contains("bad.toml"), "the file unnamed: {said}");
        assert!(!said.contains("panicked"));
    }
    let missing = lander(&["run", "--config", "/nonexistent/cfg.toml"]);
    assert!(!missing.status.success());
    assert!(stderr(&missing).contains("/nonexistent/cfg.toml"));

    let zero = lander(&[
        "run",
        "--population",
        "0",
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    assert!(!zero.status.success());
    assert_eq!(
        stderr(&zero).matches("ga.population").count(),
        1,
        "said once: {}",
        stderr(&zero)
    );
    let method = lander(&["run", "--method", "annealing"]);
    assert!(!method.status.success());
    assert!(stderr(&method).contains("annealing"));
}

#[test]
fn fly_prints_the_landing_and_traces_every_tick() {
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("trace.csv");
    let out = json_out(&lander(&[
        "fly",
        "--genome",
        "1:12,2:30,3:4",
        "--x0",
        "200",
        "--pad-x",
        "100",
        "--trace",
        trace.to_str().unwrap(),
    ]));
    for key in ["x", "y", "vx", "vy", "rot", "ticks", "n", "safe", "fitness"] {
        assert!(out.get(key).is_some(), "fly output lacks {key}");
    }
    assert_eq!(out["n"], 46);
    let csv = fs::read_to_string(&trace).unwrap();
    let rows: Vec<&str> = csv.lines().collect();
    assert_eq!(rows[0], "tick,action,x,y,vx,vy,rot");
    assert_eq!(rows.len() as u64, 1 + out["ticks"].as_u64().unwrap());
    assert!(rows[1].starts_with("1,1,200.0,"), "{}", rows[1]);

    let bad = lander(&[
        "fly", "--genome", "1:12,7:3", "--x0", "200", "--pad-x", "100",
    ]);
    assert!(!bad.status.success());
    assert!(stderr(&bad).contains("gene 1"), "{}", stderr(&bad));
}

#[test]
fn guide_with_epsilon_zero_is_deterministic_and_needs_no_seed() {
    let args = [
        "guide",
        "--genome",
        "3:20,3:20,3:20,2:10",
        "--x0",
        "150",
        "--pad-x",
        "160",
        "--epsilon",
        "0",
    ];
    let a = json_out(&lander(&args));
    let b = json_out(&lander(&args));
    assert_eq!(a, b);
    let genome = a["genome"].as_str().unwrap();
    let durations: Vec<&str> = genome
        .split(',')
        .map(|g| g.split(':').nth(1).unwrap())
        .collect();
    assert_eq!(durations, ["20", "20", "20", "10"]);
    let bad = lander(&[
        "guide",
        "--genome",
        "3:20",
        "--x0",
        "1",
        "--pad-x",
        "100",
        "--epsilon",
        "1.5",
    ]);
    assert!(!bad.status.success());
    assert!(stderr(&bad).contains("guided.epsilon"), "{}", stderr(&bad));
}

/// A stdout that cannot be written is an error, said and exited with; one
/// whose reader stopped reading (`| head`) ends the command quietly.
#[test]
fn an_unwritable_stdout_is_an_error_and_a_closed_pipe_is_quiet() {
    use std::io::Read;
    use std::process::{Command, Stdio};
    let args = [
        "fly", "--genome", "1:12,3:3", "--x0", "200", "--pad-x", "100",
    ];
    let full = Command::new(lander_tests::binary("lander"))
        .args(args)
        .stdout(fs::File::create("/dev/full").unwrap())
        .output()
        .unwrap();
    assert_eq!(full.status.code(), Some(1), "{}", stderr(&full));
    assert!(
        stderr(&full).contains("writing to stdout"),
        "{}",
        stderr(&full)
    );
    assert!(!stderr(&full).contains("panicked"), "{}", stderr(&full));

    // Far more than a pipe holds, read no further than its first bytes.
    let genome = vec!["1:5"; 20_000].join(",");
    let mut child = Command::new(lander_tests::binary("lander"))
        .args([
            "guide", "--genome", &genome, "--x0", "200", "--pad-x", "100",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut first = [0u8; 10];
    child.stdout.take().unwrap().read_exact(&mut first).unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(!stderr(&out).contains("panicked"), "{}", stderr(&out));
}

#[test]
fn qlearning_swaps_in_and_repeats_exactly() {
    let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let args = ["--method", "qlearning", "--episodes", "120"];
    let first = run_in(a.path(), &args);
    let second = run_in(b.path(), &args);
    assert_eq!(without_wall_time(first.clone()), without_wall_time(second));
    assert_eq!(first["method"], "qlearning");
    assert_eq!(first["episodes"], 120);
    assert!(first.get("first_safe_episode").is_some());
    let rate = first["landing_rate_last_100"].as_f64().unwrap();
    assert!((0.0..=1.0).contains(&rate));
    let log = |d: &tempfile::TempDir| fs::read(d.path().join("episodes.jsonl")).unwrap();
    assert_eq!(log(&a), log(&b));
    let lines = json_lines(&a.path().join("episodes.jsonl"));
    assert_eq!(lines.len(), 120);
    for key in ["episode", "return", "ticks", "safe", "epsilon"] {
        assert!(lines[0].get(key).is_some(), "episodes.jsonl lacks {key}");
    }
}

#[test]
fn a_start_no_run_could_draw_is_refused_naming_the_flag() {
    for (x0, pad_x, height, needle) in [
        ("-5", "100", "300", "--x0 must be in [0, 400.0)"),
        ("400", "100", "300", "--x0 must be in [0, 400.0)"),
        ("5", "10", "300", "--pad-x must be in [50.0, 350.0)"),
        ("5", "350", "300", "--pad-x must be in [50.0, 350.0)"),
        ("5", "100", "40", "--height must be more than"),
    ] {
        let out = lander(&[
            "fly", "--genome", "1:3", "--x0", x0, "--pad-x", pad_x, "--height", height,
        ]);
        assert!(
            !out.status.success(),
            "x0 {x0}, pad {pad_x}, height {height}"
        );
        let e = stderr(&out);
        assert!(e.contains(needle) && !e.contains("panicked"), "{e}");
    }
    // The edges SPEC §1 can draw are flown.
    let edge = lander(&["fly", "--genome", "1:3", "--x0", "0", "--pad-x", "50"]);
    assert!(edge.status.success(), "{}", stderr(&edge));
}

/// A flag that the run would not use is refused, never recorded in its
/// configuration while changing nothing.
#[test]
fn flags_the_run_would_not_use_are_refused_naming_them() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("never");
    let q = ["run", "--method", "qlearning"];
    let ga = ["run", "--method", "ga"];
    for (args, needle) in [
        (
            &[&q[..], &["--population", "7"]].concat(),
            "--population applies only to the GA methods",
        ),
        (
            &[&q[..], &["--max-generations", "9"]].concat(),
            "--max-generations applies only",
        ),
        (
            &[&q[..], &["--max-restarts", "0"]].concat(),
            "--max-restarts applies only",
        ),
        (
            &[&q[..], &["--threads", "2"]].concat(),
            "--threads does not apply to qlearning",
        ),
        (
            &[&ga[..], &["--episodes", "50"]].concat(),
            "--episodes applies only to --method qlearning",
        ),
        (
            &[&ga[..], &["--workers", "1", "--threads", "4"]].concat(),
            "--threads is for in-process",
        ),
        (
            &[&ga[..], &["--threads", "2", "--no-pin"]].concat(),
            "--no-pin needs --workers",
        ),
        (
            &[&ga[..], &["--population", "4"]].concat(),
            "ga.elites must be fewer than ga.population",
        ),
    ] {
        let said = lander(&[&args[..], &["--out", out.to_str().unwrap()]].concat());
        assert!(!said.status.success(), "{args:?} was accepted");
        assert!(
            stderr(&said).contains(needle),
            "{args:?}: {}",
            stderr(&said)
        );
        assert!(!out.exists(), "{args:?} made its folder");
    }
    // The method a --config file names counts as --method does.
    let cfg = dir.path().join("q.toml");
    fs::write(&cfg, "method = \"qlearning\"\n").unwrap();
    let said = lander(&[
        "run",
        "--config",
        cfg.to_str().unwrap(),
        "--population",
        "7",
    ]);
    assert!(
        stderr(&said).contains("--population applies only"),
        "{}",
        stderr(&said)
    );
}

#[test]
fn a_negative_number_is_refused_as_a_value_naming_its_flag() {
    let guide = ["guide", "--genome", "1:3", "--x0", "5", "--pad-x", "100"];
    for (args, needle) in [
        (
            &["--epsilon", "-1"][..],
            "guided.epsilon must be in [0, 1] (got -1)",
        ),
        (&["--seed", "-1"], "invalid value '-1' for '--seed <SEED>'"),
    ] {
        let out = lander(&[&guide[..], args].concat());
        assert!(!out.status.success(), "{args:?}");
        assert!(stderr(&out).contains(needle), "{}", stderr(&out));
    }
    let out = lander(&["run", "--threads", "-2"]);
    assert!(!out.status.success());
    assert!(
        stderr(&out).contains("invalid value '-2' for '--threads <THREADS>'"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn replaying_a_run_flies_it_in_the_world_the_run_recorded() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("long.toml");
    fs::write(&cfg, "[ga]\nmax_duration = 60\n").unwrap();
    let run = dir.path().join("run");
    let summary = run_in(
        &run,
        &[
            "--config",
            cfg.to_str().unwrap(),
            "--max-generations",
            "3",
            "--max-restarts",
            "0",
        ],
    );
    let best: serde_json::Value =
        serde_json::from_slice(&fs::read(run.join("best.json")).unwrap()).unwrap();
    assert_eq!(best["config"]["ga"]["max_duration"], 60);
    // Its genome is one only that configuration admits.
    let genome = summary["best_genome"].as_str().unwrap();
    let longest = genome
        .split(',')
        .map(|g| g.split_once(':').unwrap().1.parse::<u32>().unwrap())
        .max()
        .unwrap();
    assert!(longest > 30, "no gene past the default bound in {genome}");
    let (x0, pad_x) = (summary["x0"].to_string(), summary["pad_x"].to_string());
    let default_world = lander(&["fly", "--genome", genome, "--x0", &x0, "--pad-x", &pad_x]);
    assert!(!default_world.status.success());
    assert!(stderr(&default_world).contains("--genome"));

    let svg = dir.path().join("best.svg");
    let (run, svg) = (run.to_str().unwrap(), svg.to_str().unwrap());
    let replayed = lander(&["replay", "--run", run, "--out", svg]);
    assert!(replayed.status.success(), "{}", stderr(&replayed));
    assert!(fs::read_to_string(svg).unwrap().contains("<svg"));
    let both = lander(&["replay", "--run", run, "--config", cfg.to_str().unwrap()]);
    assert!(!both.status.success());
    assert!(
        stderr(&both).contains("without --config"),
        "{}",
        stderr(&both)
    );

    // A best.json whose start no run could draw is refused, naming it.
    let mut damaged = best.clone();
    damaged["x0"] = serde_json::json!(-5.0);
    let best_path = std::path::Path::new(run).join("best.json");
    fs::write(&best_path, damaged.to_string()).unwrap();
    let refused = lander(&["replay", "--run", run, "--out", svg]);
    assert!(!refused.status.success());
    assert!(
        stderr(&refused).contains("best.json: x0 must be in"),
        "{}",
        stderr(&refused)
    );
}

#[test]
fn a_run_replaces_an_earlier_runs_outputs_and_leaves_an_experiment_alone() {
    let dir = tempfile::tempdir().unwrap();
    run_in(
        dir.path(),
        &["--max-generations", "2", "--max-restarts", "0"],
    );
    assert!(dir.path().join("best.json").exists());
    let out = dir.path().to_str().unwrap();
    let learn = lander(&[
        "run",
        "--method",
        "qlearning",
        "--episodes",
        "3",
        "--out",
        out,
    ]);
    assert!(learn.status.success(), "{}", stderr(&learn));
    assert!(stderr(&learn).contains("removed"), "{}", stderr(&learn));
    for gone in ["best.json", "generations.jsonl"] {
        assert!(!dir.path().join(gone).exists(), "{gone} outlived its run");
    }
    assert!(dir.path().join("episodes.jsonl").exists());
    // A finished run has nothing to resume, and says so.
    let again = lander(&["run", "--resume", out]);
    assert!(!again.status.success());
    assert!(
        stderr(&again).contains("the run there finished (it wrote summary.json"),
        "{}",
        stderr(&again)
    );

    // A run into `dir` fails, naming `needle`.
    let refused_in = |dir: &std::path::Path, needle: &str| {
        let out = lander(&[
            "run",
            "--max-generations",
            "1",
            "--out",
            dir.to_str().unwrap(),
        ]);
        assert!(!out.status.success());
        assert!(stderr(&out).contains(needle), "{}", stderr(&out));
    };

    // A file of a run's name that no run wrote is neither removed nor
    // overwritten.
    let theirs = tempfile::tempdir().unwrap();
    fs::write(theirs.path().join("summary.json"), "{\"total\": 3}").unwrap();
    refused_in(
        theirs.path(),
        "summary.json is not a file a lander run wrote",
    );
    assert_eq!(
        fs::read_to_string(theirs.path().join("summary.json")).unwrap(),
        "{\"total\": 3}"
    );

    for marker in ["experiment.json", "sweep.json"] {
        let theirs = tempfile::tempdir().unwrap();
        fs::write(theirs.path().join(marker), "{}").unwrap();
        refused_in(theirs.path(), marker);
        assert!(!theirs.path().join("generations.jsonl").exists());
        // Resumed as a run, it is named for what it is.
        let resumed = lander(&["run", "--resume", theirs.path().to_str().unwrap()]);
        assert!(!resumed.status.success());
        assert!(
            stderr(&resumed).contains(&format!("({marker}), not a run's")),
            "{}",
            stderr(&resumed)
        );
    }
}

/// A Q(λ) run in-process into `dir` that would go on for hours, once it
/// has written its first episode.
fn endless_learning_in(dir: &std::path::Path) -> std::process::Child {
    use lander_tests::{binary, lines_in, wait_until};
    use std::process::{Command, Stdio};
    let child = Command::new(binary("lander"))
        .args(["run", "--method", "qlearning", "--episodes", "10000000"])
        .args(["--out", dir.to_str().unwrap()])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    assert!(
        wait_until(60, || lines_in(&dir.join("episodes.jsonl")) > 0),
        "no episode was written"
    );
    child
}

#[test]
fn ctrl_c_stops_an_in_process_q_learning_run_with_its_episodes_kept() {
    let dir = tempfile::tempdir().unwrap();
    let child = endless_learning_in(dir.path());
    let log = dir.path().join("episodes.jsonl");
    lander_tests::interrupt(child);
    // Every episode flown is kept, whole and in order; there is no summary.
    let episodes: Vec<u64> = json_lines(&log)
        .iter()
        .map(|e| e["episode"].as_u64().unwrap())
        .collect();
    assert!(episodes.len() < 10_000_000);
    assert_eq!(episodes, (1..=episodes.len() as u64).collect::<Vec<_>>());
    assert!(!dir.path().join("summary.json").exists());
}

#[test]
fn a_folder_in_use_is_refused_to_every_other_command_and_left_whole() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let child = endless_learning_in(dir.path());
    let log = dir.path().join("episodes.jsonl");
    let elsewhere = tempfile::tempdir().unwrap();
    let file = elsewhere.path().join("e.toml");
    std::fs::write(&file, "name = \"e\"\ntrials = 1\nmethods = [\"ga\"]\n").unwrap();
    let file = file.to_str().unwrap();
    for args in [
        &["run", "--out", out][..],
        &["run", "--method", "qlearning", "--out", out],
        &["run", "--resume", out],
        &["experiment", file, "--out", out],
    ] {
        let other = lander(args);
        assert!(!other.status.success(), "{args:?}");
        let said = stderr(&other);
        assert!(
            said.contains(&format!("{out} is in use by another lander command")),
            "{args:?}: {said}"
        );
    }
    lander_tests::interrupt(child);
    // The run's episodes are whole and in order, and it resumes.
    let episodes = json_lines(&log).len() as u64;
    let numbers: Vec<u64> = json_lines(&log)
        .iter()
        .map(|e| e["episode"].as_u64().unwrap())
        .collect();
    assert_eq!(numbers, (1..=episodes).collect::<Vec<_>>());
    assert!(dir.path().join("checkpoint.bin").exists());
    assert!(!dir.path().join("experiment.json").exists());
}

#[test]
fn an_out_that_is_a_file_is_refused_by_every_command_that_writes_a_folder() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("a-file");
    fs::write(&file, "mine").unwrap();
    let sweep = dir.path().join("sweep.toml");
    fs::write(
        &sweep,
        "name = \"s\"\ntrials = 1\nmethods = [\"ga\"]\n[[settings]]\nname = \"x\"\n",
    )
    .unwrap();
    let paper = concat!(env!("CARGO_MANIFEST_DIR"), "/../experiments/paper.toml");
    let out = file.to_str().unwrap();
    for args in [
        vec!["run", "--out", out],
        vec!["experiment", paper, "--out", out],
        vec!["sweep", sweep.to_str().unwrap(), "--out", out],
    ] {
        let ran = lander(&args);
        assert!(!ran.status.success(), "{args:?}");
        let said = stderr(&ran);
        assert!(
            said.contains(&format!("{out} is not a folder; give --out")),
            "{said}"
        );
    }
    assert_eq!(fs::read_to_string(&file).unwrap(), "mine");
}

/// A run whose summary finds stdout's reader gone has still finished, its
/// outputs written: it exits 0, and its events say it finished.
#[test]
fn a_run_whose_stdout_reader_left_is_recorded_as_finished() {
    use std::process::{Command, Stdio};
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let mut child = Command::new(lander_tests::binary("lander"))
        .args([
            "run",
            "--json",
            "--max-generations",
            "3",
            "--max-restarts",
            "0",
        ])
        .args(["--out", out.to_str().unwrap()])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let done = child.wait_with_output().unwrap();
    assert!(done.status.success(), "{}", stderr(&done));
    assert!(out.join("best.json").exists());
    let events = json_lines(&out.join("events.jsonl"));
    assert_eq!(
        events.last().unwrap()["event"],
        "run_finished",
        "{events:?}"
    );
}
