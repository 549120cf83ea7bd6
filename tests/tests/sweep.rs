//! `lander sweep` as a user runs it: every output file and their agreement
//! with each setting's own summary, each setting equal to `lander
//! experiment` run on it alone, the same results in-process, on workers and
//! after a kill and `--resume`, bad files refused, and the report in a
//! browser.

use lander_tests::{lander, stderr, wait_until, Iox};
use serde_json::Value;
use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

/// The base of every sweep here: 3 trials of each method, small caps.
const BASE: &str = r#"
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

/// Two settings: a grid of one value, and a listed setting.
const SETTINGS: &str = r#"
[grids.eps]
"guided.epsilon" = [0.0]
[[settings]]
name = "wide"
"guided.w_y" = 6.0
"#;

/// Each setting's overrides as an experiment file's sections.
const ALONE: [(&str, &str); 2] = [
    ("eps-guided.epsilon-0.0", "[guided]\nepsilon = 0.0\n"),
    ("wide", "[guided]\nw_y = 6.0\n"),
];

fn write_file(dir: &Path, name: &str, text: &str) -> String {
    let path = dir.join(name);
    fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

fn sweep(file: &str, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["sweep", file, "--json", "--out", out.to_str().unwrap()];
    args.extend_from_slice(extra);
    lander(&args)
}

/// A CSV file as rows of column name to value.
fn csv_rows(path: &Path) -> Vec<BTreeMap<String, String>> {
    let mut reader = csv::Reader::from_path(path).unwrap();
    let header: Vec<String> = reader.headers().unwrap().iter().map(String::from).collect();
    reader
        .records()
        .map(|r| {
            header
                .iter()
                .cloned()
                .zip(r.unwrap().iter().map(String::from))
                .collect()
        })
        .collect()
}

/// A setting's trial rows without the wall time, which no two runs share.
fn trials_of(dir: &Path) -> Vec<BTreeMap<String, String>> {
    let mut rows = csv_rows(&dir.join("trials.csv"));
    for r in &mut rows {
        r.remove("wall_s");
    }
    rows
}

/// A setting's folder, its trial rows and its `generations.jsonl`.
type SettingResults = (String, Vec<BTreeMap<String, String>>, Vec<u8>);

/// Everything a sweep computed, wall times aside: the sweep's table and
/// each setting's trials and generations.
fn results_of(out: &Path) -> (Vec<u8>, Vec<SettingResults>) {
    let settings = ALONE
        .iter()
        .map(|(folder, _)| {
            let dir = out.join("settings").join(folder);
            (
                folder.to_string(),
                trials_of(&dir),
                fs::read(dir.join("generations.jsonl")).unwrap(),
            )
        })
        .collect();
    (fs::read(out.join("sweep.csv")).unwrap(), settings)
}

fn number(v: &Value) -> String {
    match v.as_f64() {
        Some(x) => x.to_string(),
        None => String::new(),
    }
}

fn parse(cell: &str) -> f64 {
    cell.parse()
        .unwrap_or_else(|_| panic!("not a number: {cell:?}"))
}

#[test]
fn a_small_sweep_writes_every_file_and_each_setting_is_its_own_experiment() {
    let dir = tempfile::tempdir().unwrap();
    let file = write_file(dir.path(), "sweep.toml", &format!("{BASE}{SETTINGS}"));
    let out = dir.path().join("out");
    let run = sweep(&file, &out, &[]);
    assert!(run.status.success(), "{}", stderr(&run));
    let printed: Value = serde_json::from_slice(&run.stdout).expect("--json prints JSON");
    assert_eq!(printed["settings"].as_array().map(Vec::len), Some(2));

    for name in [
        "sweep.json",
        "sweep.csv",
        "sweep.md",
        "summary.json",
        "report.html",
        "grid-eps-share-won.svg",
        "grid-eps-share-won.png",
        "grid-eps-generations.svg",
        "grid-eps-generations.png",
    ] {
        assert!(out.join(name).is_file(), "{name} is missing");
    }
    let rows = csv_rows(&out.join("sweep.csv"));
    assert_eq!(rows.len(), 2);
    assert_eq!(rows[0]["setting"], "eps: guided.epsilon=0.0");
    assert_eq!(rows[1]["setting"], "wide");
    assert_eq!(rows[1]["guided.w_y"], "6.0");
    assert_eq!(rows[0]["guided.w_y"], "");

    for ((folder, alone), row) in ALONE.iter().zip(&rows) {
        let setting = out.join("settings").join(folder);
        for name in [
            "experiment.json",
            "trials.csv",
            "generations.jsonl",
            "summary.json",
            "report.html",
        ] {
            assert!(setting.join(name).is_file(), "{folder}/{name} is missing");
        }
        // The sweep's row says what the setting's own summary says.
        let summary: Value =
            serde_json::from_str(&fs::read_to_string(setting.join("summary.json")).unwrap())
                .unwrap();
        for m in summary["methods"].as_array().unwrap() {
            let name = m["method"].as_str().unwrap();
            assert_eq!(row[&format!("{name}_trials")], m["trials"].to_string());
            assert_eq!(row[&format!("{name}_landed")], m["landed"].to_string());
            assert_eq!(
                parse(&row[&format!("{name}_success_rate")]),
                m["success_rate"].as_f64().unwrap()
            );
            for q in ["q1", "median", "q3"] {
                assert_eq!(
                    row[&format!("{name}_generations_{q}")]
                        .parse::<f64>()
                        .map(|x| x.to_string())
                        .unwrap_or_default(),
                    number(&m["generations"][q]),
                    "{folder} {name} {q}"
                );
            }
        }
        let paired = &summary["paired"];
        for key in ["pairs", "guided_fewer", "ga_fewer", "ties"] {
            assert_eq!(row[key], paired[key].to_string(), "{folder} {key}");
        }
        let share = parse(&row["share_won"]);
        assert_eq!(
            share,
            paired["guided_fewer"].as_f64().unwrap() / paired["pairs"].as_f64().unwrap()
        );
        let (low, high) = (parse(&row["share_won_low"]), parse(&row["share_won_high"]));
        assert!(low <= share && share <= high, "{low} ≤ {share} ≤ {high}");
        assert_eq!(
            row["wilcoxon_p"].parse::<f64>().ok(),
            paired["wilcoxon"]["p_value"].as_f64()
        );
        let ql = &summary["qlearning"]["success_rate"];
        assert_eq!(parse(&row["qlearning_success_rate"]), ql.as_f64().unwrap());

        // `lander experiment` on the setting alone gives the same trials.
        let exp = write_file(
            dir.path(),
            &format!("{folder}.toml"),
            &format!("{BASE}{alone}"),
        );
        let by_itself = dir.path().join(format!("alone-{folder}"));
        let run = lander(&[
            "experiment",
            &exp,
            "--json",
            "--out",
            by_itself.to_str().unwrap(),
        ]);
        assert!(run.status.success(), "{}", stderr(&run));
        assert_eq!(trials_of(&by_itself), trials_of(&setting), "{folder}");
        assert_eq!(
            fs::read(by_itself.join("generations.jsonl")).unwrap(),
            fs::read(setting.join("generations.jsonl")).unwrap(),
            "{folder}"
        );
    }
}

/// A sweep long enough that a kill lands mid-run.
fn longer() -> String {
    format!("{BASE}{SETTINGS}")
        .replace("trials = 3", "trials = 6")
        .replace("max_generations = 60", "max_generations = 300")
        .replace("episodes = 300", "episodes = 2000")
}

fn finished_trials(out: &Path) -> usize {
    ALONE
        .iter()
        .map(|(folder, _)| {
            fs::read_dir(out.join("settings").join(folder).join("trials")).map_or(0, |d| d.count())
        })
        .sum()
}

#[test]
fn results_are_the_same_in_process_on_workers_and_after_a_kill_and_resume() {
    let dir = tempfile::tempdir().unwrap();
    let file = write_file(dir.path(), "sweep.toml", &longer());
    let inproc = dir.path().join("inproc");
    let run = sweep(&file, &inproc, &[]);
    assert!(run.status.success(), "{}", stderr(&run));

    let iox = Iox::new("sweep");
    let workers = dir.path().join("workers");
    let run = iox.lander(&[
        "sweep",
        &file,
        "--workers",
        "2",
        "--out",
        workers.to_str().unwrap(),
    ]);
    assert!(run.status.success(), "{}", stderr(&run));
    assert_eq!(results_of(&workers), results_of(&inproc));

    let killed = dir.path().join("killed");
    let mut child = Command::new(lander_tests::binary("lander"))
        .args(["sweep", &file, "--out", killed.to_str().unwrap()])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let started = wait_until(60, || finished_trials(&killed) >= 2);
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(started, "no trial finished within a minute");
    assert!(
        !killed.join("sweep.csv").exists(),
        "the sweep ended before the kill"
    );
    assert!(finished_trials(&killed) < 36, "every trial had finished");

    // Without --resume the folder is refused; another sweep may not resume it.
    let refused = sweep(&file, &killed, &[]);
    assert!(!refused.status.success());
    assert!(
        stderr(&refused).contains("--resume"),
        "{}",
        stderr(&refused)
    );
    let other = sweep(&file, &killed, &["--resume", "--trials", "7"]);
    assert!(!other.status.success());
    assert!(
        stderr(&other).contains("base.trials: ") && stderr(&other).contains(" there, 7 here"),
        "{}",
        stderr(&other)
    );

    let resumed = sweep(&file, &killed, &["--resume"]);
    assert!(resumed.status.success(), "{}", stderr(&resumed));
    assert_eq!(results_of(&killed), results_of(&inproc));
    assert_eq!(finished_trials(&killed), 36);
}

#[test]
fn bad_sweep_files_are_refused_naming_the_setting_and_key() {
    let dir = tempfile::tempdir().unwrap();
    let never = dir.path().join("never");
    let many: Vec<String> = (1..=101).map(|v| v.to_string()).collect();
    let restarts: Vec<String> = (0..100).map(|v| v.to_string()).collect();
    let large = format!(
        "[grids.big]\n\"ga.max_generations\" = [{}]\n\"ga.max_restarts\" = [{}]\n",
        many.join(", "),
        restarts.join(", ")
    );
    for (text, wanted) in [
        (
            "[grids.g]\n\"guided.epsilom\" = [0.1]\n",
            &["grid 'g'", "guided.epsilom", "unknown key"][..],
        ),
        (
            "[grids.g]\n\"ga.population\" = [\"many\"]\n",
            &["setting 'g: ga.population=many'", "ga.population"],
        ),
        (
            "[grids.g]\n\"guided.epsilon\" = []\n",
            &["grid 'g'", "guided.epsilon", "empty"],
        ),
        (large.as_str(), &["10100 settings", "--allow-large"]),
        (
            "[[settings]]\nname = \"a\"\n[[settings]]\nname = \"a\"\n",
            &["two settings are named 'a'"],
        ),
    ] {
        let file = write_file(dir.path(), "bad.toml", &format!("{BASE}{text}"));
        let out = sweep(&file, &never, &[]);
        assert!(!out.status.success(), "{text}");
        let err = stderr(&out);
        assert!(err.contains("bad.toml"), "{err}");
        for w in wanted {
            assert!(err.contains(w), "{text}\n→ {err}\n(wanted {w:?})");
        }
        assert!(!err.contains("panicked"), "{err}");
        assert!(!never.exists(), "a refused sweep wrote {}", never.display());
    }
    let missing = sweep("/nonexistent/sweep.toml", &never, &[]);
    assert!(!missing.status.success());
    assert!(stderr(&missing).contains("/nonexistent/sweep.toml"));
    // Bad flags, refused before the folder is written: the corrected
    // command would otherwise find a sweep it was not asked to resume.
    let file = write_file(
        dir.path(),
        "good.toml",
        &format!("{BASE}[grids.g]\n\"guided.epsilon\" = [0.1]\n"),
    );
    for (flags, said) in [
        (
            &["--threads", "5000"][..],
            "'--threads <THREADS>': 5000 is not in 0..=1024",
        ),
        (&["--in-flight", "0"], "--in-flight"),
        (
            &["--threads", "2", "--workers", "1"],
            "--threads is for in-process",
        ),
    ] {
        let out = sweep(&file, &never, flags);
        assert!(!out.status.success(), "{flags:?}");
        assert!(stderr(&out).contains(said), "{}", stderr(&out));
        assert!(!never.exists(), "{flags:?} wrote {}", never.display());
    }
}

#[test]
fn the_sweep_report_loads_in_a_browser_with_its_plots_and_links() {
    use lander_tests::browser;
    let dir = tempfile::tempdir().unwrap();
    // A grid of two keys, for the heatmap, beside a grid of one.
    let text = format!(
        "{BASE}{SETTINGS}[grids.w]\n\"guided.w_y\" = [3.0, 6.0]\n\"guided.w_t\" = [6.0, 12.0]\n"
    )
    .replace("trials = 3", "trials = 2")
    .replace(
        "[\"ga\", \"guided\", \"qlearning\"]",
        "[\"ga\", \"guided\"]",
    );
    let file = write_file(dir.path(), "sweep.toml", &text);
    let out = dir.path().join("out");
    let run = sweep(&file, &out, &[]);
    assert!(run.status.success(), "{}", stderr(&run));

    let page = browser::open(&out.join("report.html")).expect("chromium opens report.html");
    let (total, decoded) = page.images_decoded().expect("images can be counted");
    assert_eq!(
        total, 3,
        "the eps grid's two plots and the w grid's heatmap"
    );
    assert_eq!(decoded, total, "undecoded: {:?}", page.undecoded_images());
    let errors = page.console_errors();
    assert!(errors.is_empty(), "console errors: {errors:?}");
    // Every setting links to its own report, and every link leads to a file.
    let links = page
        .eval_json("[...document.querySelectorAll('a')].map(a => a.getAttribute('href'))")
        .expect("links can be read");
    let links: Vec<String> = serde_json::from_value(links).expect("a list of links");
    let reports: Vec<&String> = links
        .iter()
        .filter(|l| l.ends_with("report.html"))
        .collect();
    assert_eq!(reports.len(), 6, "{links:?}");
    for link in reports {
        let path: PathBuf = out.join(link);
        assert!(path.is_file(), "{link} leads nowhere");
    }
}

#[test]
fn the_resume_hint_after_an_interrupt_is_a_command_that_finishes_the_sweep() {
    let dir = tempfile::tempdir().unwrap();
    let file = write_file(dir.path(), "sweep.toml", &longer());
    let out = dir.path().join("out");
    let child = Command::new(lander_tests::binary("lander"))
        .args(["sweep", &file, "--trials", "5", "--out"])
        .arg(&out)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    assert!(
        wait_until(60, || finished_trials(&out) >= 2),
        "no trial finished within a minute"
    );
    let stopped = lander_tests::interrupt(child);
    let said = stderr(&stopped);
    let hint = said
        .split('`')
        .find(|s| s.starts_with("lander sweep "))
        .unwrap_or_else(|| panic!("no resume hint in: {said}"));
    assert!(hint.ends_with("--resume --trials 5"), "{hint}");
    let args: Vec<&str> = hint.split(' ').skip(1).collect();
    let resumed = Command::new(lander_tests::binary("lander"))
        .args(&args)
        .output()
        .unwrap();
    assert!(resumed.status.success(), "{}", stderr(&resumed));
    assert!(out.join("sweep.csv").exists());
}
