//! Q(λ) trials over the pool: a trial longer than a chunk may fly goes out
//! in legs, and comes back as the trial flown whole.

use crate::config::RunConfig;
use crate::evaluator::Trainer;
use lander_model::learn::run_training;
use lander_model::{LearnParams, StreamKey, TrainJob, TrainResult};

fn trial(episodes: u32, trial: u64) -> TrainJob {
    let cfg = RunConfig::default();
    TrainJob::whole(
        cfg.env(0),
        cfg.guided,
        LearnParams {
            episodes,
            ..cfg.qlearning
        },
        StreamKey::new(5, trial, 0, 0),
    )
}

#[test]
fn a_long_trial_goes_out_in_legs_and_comes_back_whole() {
    let mut pool = super::fake::flying(2);
    pool.episodes_per_chunk = 7;
    // 20 episodes in legs of 7, 7 and 6; 5 in one; and a leg of a trial
    // (episodes 4 to 18 of 30, from where a first leg left it) in two.
    let first = run_training(&TrainJob {
        until: 4,
        ..trial(30, 3)
    })
    .unwrap();
    let later = TrainJob {
        from: first.state,
        until: 18,
        ..trial(30, 3)
    };
    let trials = [trial(20, 1), trial(5, 2), later];
    let mut told: Vec<(usize, TrainResult)> = Vec::new();
    let results = pool
        .train(&trials, &mut |i, r| told.push((i, r.clone())))
        .unwrap();
    let whole: Vec<TrainResult> = trials.iter().map(|t| run_training(t).unwrap()).collect();
    assert!(results == whole, "legs differ from the trials flown whole");
    told.sort_by_key(|(i, _)| *i);
    let told: Vec<TrainResult> = told.into_iter().map(|(_, r)| r).collect();
    assert!(told == whole, "each trial is told once, whole");
    let sent: usize = pool.links.iter().map(|l| l.sent.len()).sum();
    assert_eq!(sent, 3 + 1 + 2, "chunks sent");
}
