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
