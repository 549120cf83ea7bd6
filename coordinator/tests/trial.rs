//! A trial as a whole: the same result whatever the thread count, restarts
//! that keep `x0` and draw a new pad, and the paper's headline behaviour.

use lander_coordinator::config::RunConfig;
use lander_coordinator::evaluator::InProcess;
use lander_coordinator::trial::{run_trial, Generation, TrialResult};
use lander_model::Method;
use proptest::prelude::*;

fn small(method: Method, seed: u64) -> RunConfig {
    let mut cfg = RunConfig {
        method,
        seed,
        ..RunConfig::default()
    };
    cfg.ga.population = 30;
    cfg.ga.max_generations = 8;
    cfg.ga.max_restarts = 1;
    cfg
}

fn run(cfg: &RunConfig, threads: usize) -> (TrialResult, Vec<Generation>) {
    let mut evaluator = InProcess::new(threads).unwrap();
    let mut log = Vec::new();
    let result = run_trial(cfg, &mut evaluator, &mut |g: &Generation| {
        log.push(g.clone());
        Ok(())
    })
    .unwrap();
    (result, log)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(12))]

    #[test]
    fn a_trial_is_identical_on_one_two_and_three_threads(seed in any::<u64>(), guided in any::<bool>()) {
        let cfg = small(if guided { Method::Guided } else { Method::Ga }, seed);
        let one = run(&cfg, 1);
        prop_assert_eq!(&run(&cfg, 2), &one);
        prop_assert_eq!(&run(&cfg, 3), &one);
    }
}

#[test]
fn restarts_keep_x0_draw_a_new_pad_and_keep_counting() {
    // Two generations of three genomes per attempt will not land.
    let mut cfg = small(Method::Ga, 5);
    cfg.ga.population = 3;
    cfg.ga.max_generations = 2;
    cfg.ga.max_restarts = 3;
    let (result, log) = run(&cfg, 1);
    assert!(!result.landed);
    assert_eq!(result.restarts, 3);
    assert_eq!(result.generations, 8);
    let seen: Vec<(u64, u64, u64)> = log
        .iter()
        .map(|g| (g.index, g.restart, g.generation))
        .collect();
    assert_eq!(
        seen,
        vec![
            (1, 0, 1),
            (2, 0, 2),
            (3, 1, 1),
            (4, 1, 2),
            (5, 2, 1),
            (6, 2, 2),
            (7, 3, 1),
            (8, 3, 2)
        ]
    );
    let (first, last) = (cfg.env(0), cfg.env(3));
    assert_eq!(first.x0, result.x0);
    assert_eq!(last.x0, result.x0);
    assert_eq!(last.pad_x, result.pad_x);
    assert_ne!(first.pad_x, last.pad_x);
    assert!((50.0..350.0).contains(&first.pad_x) && (0.0..400.0).contains(&first.x0));
}

#[test]
fn trials_draw_different_ground() {
    let mut cfg = RunConfig::default();
    let a = cfg.env(0);
    cfg.trial = 2;
    let b = cfg.env(0);
    assert_ne!((a.x0, a.pad_x), (b.x0, b.pad_x));
}

#[test]
fn guided_lands_within_tens_of_generations_on_the_papers_defaults() {
    // SPEC §6's sanity range: guided usually lands within tens of generations.
    for seed in 1..=3 {
        let cfg = RunConfig {
            seed,
            ..RunConfig::default()
        };
        let (result, log) = run(&cfg, 0);
        assert!(result.landed, "seed {seed} did not land");
        assert!(
            result.generations <= 150,
            "seed {seed}: {} generations",
            result.generations
        );
        assert!(result.best.outcome.safe);
        assert_eq!(log.last().map(|g| g.best), Some(9_999_999.0));
    }
}

#[test]
fn the_guided_pass_raises_the_first_generations_mean_fitness() {
    // The paper's Figure 4: guided's mean fitness per generation is higher.
    for seed in 1..=4 {
        let mut cfg = small(Method::Ga, seed);
        cfg.ga.population = 100;
        cfg.ga.max_generations = 1;
        cfg.ga.max_restarts = 0;
        let (_, ga) = run(&cfg, 0);
        cfg.method = Method::Guided;
        let (_, guided) = run(&cfg, 0);
        assert!(
            guided[0].mean > ga[0].mean,
            "seed {seed}: guided {} vs ga {}",
            guided[0].mean,
            ga[0].mean
        );
    }
}
