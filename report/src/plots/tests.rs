//! The figures drawn end to end from sample records: each comes back as
//! an SVG document and a sound 800×500 PNG, says what it shows, and draws
//! "no data" rather than failing when there is nothing to show.

use super::*;
use crate::model::{BestLander, FitnessPoint, Learning, Method, TrialRecord};

const PNG_SIGNATURE: [u8; 8] = [0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1a, b'\n'];

fn record(method: Method, trial: u64, landed: bool, generations: u64) -> TrialRecord {
    let fitness = (1..=generations)
        .map(|g| {
            let last = g == generations && landed;
            FitnessPoint {
                index: g,
                restart: g / 50,
                best: if last {
                    9_999_999.0
                } else {
                    500.0 + 20.0 * g as f64
                },
                mean: if last {
                    100_300.0
                } else {
                    200.0 + 8.0 * g as f64
                },
            }
        })
        .collect();
    TrialRecord {
        method,
        seed: 1,
        trial,
        x0: 100.0,
        pad_x: 200.0,
        landed,
        generations: Some(generations),
        restarts: Some(generations / 50),
        episodes: None,
        wall_s: 1.0,
        fitness,
        best: Some(BestLander {
            genome: "0:5".to_string(),
            fitness: if landed { 9_999_999.0 } else { 1234.0 },
            safe: landed,
            pad_x: 200.0,
        }),
        learning: None,
    }
}

fn learner(trial: u64, episodes: u32) -> TrialRecord {
    let returns = (0..episodes)
        .map(|e| -100.0 + f64::from(e) * 3.0 + f64::from(e % 7) * 10.0)
        .collect();
    TrialRecord {
        method: Method::Qlearning,
        seed: 1,
        trial,
        x0: 100.0,
        pad_x: 200.0,
        landed: true,
        generations: None,
        restarts: None,
        episodes: Some(episodes / 2),
        wall_s: 1.0,
        fitness: vec![],
        best: None,
        learning: Some(Learning {
            episodes,
            first_safe: Some(episodes / 2),
            landing_rate_last_100: 0.5,
            returns,
        }),
    }
}

fn sample() -> Vec<TrialRecord> {
    vec![
        record(Method::Ga, 1, true, 40),
        record(Method::Guided, 1, true, 12),
        record(Method::Ga, 2, false, 120),
        record(Method::Guided, 2, true, 30),
        record(Method::Ga, 3, true, 75),
        record(Method::Guided, 3, true, 9),
        learner(1, 300),
        learner(2, 250),
    ]
}

/// Width and height from the IHDR chunk, after checking the signature,
/// and a full decode to be sure the image data is sound.
fn png_size(png: &[u8]) -> (u32, u32) {
    assert_eq!(png[..8], PNG_SIGNATURE, "PNG signature");
    assert_eq!(&png[12..16], b"IHDR");
    let ihdr = (
        u32::from_be_bytes(png[16..20].try_into().unwrap()),
        u32::from_be_bytes(png[20..24].try_into().unwrap()),
    );
    let mut reader = png::Decoder::new(png).read_info().expect("PNG header");
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).expect("PNG data");
    assert_eq!((info.width, info.height), ihdr);
    ihdr
}

fn check(plot: &Plot, texts: &[&str]) {
    let svg = plot.svg.trim_start();
    assert!(
        svg.starts_with("<svg"),
        "SVG starts with: {}",
        &svg[..40.min(svg.len())]
    );
    assert!(svg.trim_end().ends_with("</svg>"));
    for text in texts {
        assert!(plot.svg.contains(text), "SVG lacks {text:?}");
    }
    assert_eq!(png_size(&plot.png), (WIDTH, HEIGHT));
}

#[test]
fn plots_generations_per_trial() {
    let plot = generations_per_trial(&sample()).unwrap();
    check(
        &plot,
        &[
            "Generations to a safe landing",
            "general GA",
            "guided GA",
            "did not land",
            "trial",
        ],
    );
}

#[test]
fn plots_fitness_per_generation() {
    let plot = fitness_per_generation(&sample(), 2).unwrap();
    check(
        &plot,
        &[
            "trial 2",
            "general GA best",
            "general GA mean",
            "guided GA best",
            "guided GA mean",
            "safe landing",
            "(fitness 9,999,999)",
            "symlog",
            "10M",
        ],
    );
}

#[test]
fn fitness_handles_a_method_without_records() {
    let records: Vec<_> = sample()
        .into_iter()
        .filter(|r| r.method != Method::Guided)
        .collect();
    let plot = fitness_per_generation(&records, 1).unwrap();
    check(&plot, &["general GA best", "guided GA: no data"]);
}

#[test]
fn plots_learning_curve() {
    let plot = learning_curve(&sample()).unwrap();
    check(
        &plot,
        &[
            "Q(λ) learning curve",
            "mean return",
            "moving avg, 100 ep.",
            "2 trials",
        ],
    );
}

#[test]
fn empty_inputs_draw_no_data() {
    let none: Vec<TrialRecord> = vec![];
    let plot = generations_per_trial(&none).unwrap();
    check(&plot, &["no data: no GA trial records"]);
    let plot = fitness_per_generation(&none, 1).unwrap();
    check(&plot, &["no data: no GA records for trial 1"]);
    let plot = fitness_per_generation(&sample(), 99).unwrap();
    check(&plot, &["no data: no GA records for trial 99"]);
    let plot = learning_curve(&none).unwrap();
    check(&plot, &["no data: no Q-learning records"]);
    // Records of the wrong kind count as none.
    let learners = vec![learner(1, 10)];
    check(&generations_per_trial(&learners).unwrap(), &["no data"]);
    let mut empty = learner(1, 0);
    empty.learning.as_mut().unwrap().returns.clear();
    let ga_only = vec![record(Method::Ga, 1, true, 3), empty];
    check(&learning_curve(&ga_only).unwrap(), &["no data"]);
}

#[test]
fn odd_values_do_not_panic() {
    let mut r = record(Method::Ga, 1, false, 1);
    r.fitness[0].best = f64::NAN;
    r.fitness[0].mean = f64::INFINITY;
    r.generations = None;
    check(
        &fitness_per_generation(&[r.clone()], 1).unwrap(),
        &["no data"],
    );
    check(&generations_per_trial(&[r]).unwrap(), &["general GA"]);
    let one = record(Method::Guided, 5, true, 1);
    check(
        &fitness_per_generation(std::slice::from_ref(&one), 5).unwrap(),
        &["guided GA best"],
    );
    check(&generations_per_trial(&[one]).unwrap(), &["guided GA"]);
    let mut flat = learner(1, 1);
    flat.learning.as_mut().unwrap().returns = vec![5.0];
    check(&learning_curve(&[flat]).unwrap(), &["1 trial"]);
}

/// The x of the SVG text `label` centred under a point: an x-axis tick
/// label. plotters writes `<text x=".." y=".." .. text-anchor="middle" ..>`
/// and then the text on a line of its own.
fn centred_label_x(svg: &str, label: &str) -> i32 {
    match text_at(svg, label, "middle") {
        Some((x, _)) => x,
        None => panic!("no x-axis label {label:?}"),
    }
}

/// The y of the SVG text `label` set right-aligned: a y-axis tick label.
fn left_label_y(svg: &str, label: &str) -> i32 {
    match text_at(svg, label, "end") {
        Some((_, y)) => y,
        None => panic!("no y-axis label {label:?}"),
    }
}

/// Where the unrotated text `label` with anchor `anchor` sits, if it does.
fn text_at(svg: &str, label: &str, anchor: &str) -> Option<(i32, i32)> {
    let attribute = |tag: &str, name: &str| -> Option<String> {
        let start = tag.find(&format!(" {name}=\""))? + name.len() + 3;
        let end = start + tag[start..].find('"')?;
        Some(tag[start..end].to_string())
    };
    svg.split("<text").skip(1).find_map(|chunk| {
        let (tag, rest) = chunk.split_once('>')?;
        let text = rest.split("</text>").next()?.trim();
        if text != label || attribute(tag, "text-anchor")? != anchor || tag.contains("rotate") {
            return None;
        }
        Some((
            attribute(tag, "x")?.parse().ok()?,
            attribute(tag, "y")?.parse().ok()?,
        ))
    })
}

/// The sweep of `crate::sweep`'s tests with a one-key grid `epsilon` of
/// three settings (one without pairs) and a two-key grid `pair` of three.
fn sweep_sample() -> crate::sweep::SweepSummary {
    use crate::summary::Summary;
    use crate::sweep::{sweep_summary, SettingInput};
    use serde_json::json;
    let [a, b] = crate::sweep::tests::records();
    let ga_only: Vec<TrialRecord> = a
        .iter()
        .filter(|r| r.method == Method::Ga)
        .cloned()
        .collect();
    let runs = [a.clone(), b.clone(), ga_only, b.clone(), a.clone(), a];
    let summaries: Vec<Summary> = runs.iter().map(|r| Summary::new("s", 1, 3, r)).collect();
    let values = [
        ("epsilon", vec![("guided.epsilon", json!(0.1))]),
        ("epsilon", vec![("guided.epsilon", json!(0.0))]),
        ("epsilon", vec![("guided.epsilon", json!(0.5))]),
        (
            "pair",
            vec![
                ("ga.crossover", json!("uniform")),
                ("guided.epsilon", json!(0.0)),
            ],
        ),
        (
            "pair",
            vec![
                ("ga.crossover", json!("buckland")),
                ("guided.epsilon", json!(0.0)),
            ],
        ),
        (
            "pair",
            vec![
                ("ga.crossover", json!("uniform")),
                ("guided.epsilon", json!(0.1)),
            ],
        ),
    ];
    let names: Vec<String> = (0..runs.len()).map(|i| format!("setting {i}")).collect();
    let settings: Vec<SettingInput> = values
        .iter()
        .zip(&runs)
        .zip(&summaries)
        .zip(&names)
        .map(|(((values, records), summary), name)| SettingInput {
            name,
            folder: name,
            grid: Some(values.0),
            values: values
                .1
                .iter()
                .map(|(k, v)| (k.to_string(), v.clone()))
                .collect(),
            summary,
            records,
        })
        .collect();
    sweep_summary("s", 1, 3, &settings)
}

fn grid(name: &'static str, keys: &[&str]) -> crate::sweep::GridInput<'static> {
    crate::sweep::GridInput {
        name,
        keys: keys.iter().map(|k| k.to_string()).collect(),
    }
}

#[test]
fn plots_the_share_won_against_one_key() {
    let sweep = sweep_sample();
    let plot = share_against(&grid("epsilon", &["guided.epsilon"]), &sweep).unwrap();
    check(
        &plot,
        &[
            "Share of pairs won by the guided GA, grid epsilon",
            "guided.epsilon",
            "guided GA",
            "share won, 95% CI",
            "paper: 24 of 25",
            "(share 0.96)",
        ],
    );
    // The values as written, in ascending order though the sweep lists 0.1
    // first.
    let x = |label| centred_label_x(&plot.svg, label);
    assert!(
        x("0.0") < x("0.1") && x("0.1") < x("0.5"),
        "{:?}",
        ["0.0", "0.1", "0.5"].map(x)
    );
}

#[test]
fn plots_the_generations_against_one_key() {
    let sweep = sweep_sample();
    let plot = generations_against(&grid("epsilon", &["guided.epsilon"]), &sweep).unwrap();
    check(
        &plot,
        &[
            "Median generations to land, grid epsilon",
            "general GA",
            "guided GA",
            "median, 95% CI",
            "generations to a safe landing (median)",
        ],
    );
}

#[test]
fn plots_the_heatmap_of_two_keys() {
    let sweep = sweep_sample();
    let plot = heatmap(&grid("pair", &["ga.crossover", "guided.epsilon"]), &sweep).unwrap();
    check(
        &plot,
        &[
            "Share of pairs won by the guided GA, grid pair",
            "ga.crossover",
            "guided.epsilon",
            "share won",
            "paper: 24 of 25",
            "cells: share, 95% CI",
        ],
    );
    // Settings 3, 4 and 5 have shares ⅔, ⅓ and ⅓: each written in its cell.
    assert!(plot.svg.contains(">\n0.67\n<") && plot.svg.contains(">\n0.33\n<"));
    // Words keep the sweep's order; numbers go up.
    let x = |label| centred_label_x(&plot.svg, label);
    assert!(
        x("uniform") < x("buckland"),
        "{:?}",
        ["uniform", "buckland"].map(x)
    );
    let y = |label| left_label_y(&plot.svg, label);
    assert!(y("0.1") < y("0.0"), "{:?}", ["0.0", "0.1"].map(y));
}

#[test]
fn sweep_plots_without_data_say_why() {
    let sweep = sweep_sample();
    let one = grid("epsilon", &["guided.epsilon"]);
    let two = grid("pair", &["ga.crossover", "guided.epsilon"]);
    let missing = grid("missing", &["guided.epsilon"]);
    check(
        &share_against(&two, &sweep).unwrap(),
        &["no data: grid pair has 2 keys; this plot needs 1"],
    );
    check(
        &generations_against(&two, &sweep).unwrap(),
        &["no data: grid pair has 2 keys"],
    );
    check(
        &heatmap(&one, &sweep).unwrap(),
        &["no data: grid epsilon has 1 keys; this plot needs 2"],
    );
    check(
        &share_against(&missing, &sweep).unwrap(),
        &["no data: no settings in grid missing"],
    );
    check(
        &heatmap(&grid("missing", &["a", "b"]), &sweep).unwrap(),
        &["no data: no settings in grid missing"],
    );
    let empty = crate::sweep::sweep_summary("e", 1, 0, &[]);
    check(
        &generations_against(&one, &empty).unwrap(),
        &["no data: no settings in grid epsilon"],
    );
}
