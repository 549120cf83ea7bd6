//! Q(λ) trials over the pool: a trial longer than a chunk may fly goes out
//! in legs, and comes back as the trial flown whole; one whose state could
//! not travel between legs is refused before anything runs.

use crate::config::RunConfig;
use crate::evaluator::{EvalError, Trainer};
use lander_model::learn::run_training;
use lander_model::params::MAX_MEMORY_BITS;
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

#[test]
fn a_trial_whose_state_cannot_travel_is_refused_before_any_leg_goes_out() {
    let mut pool = super::fake::flying(2);
    pool.episodes_per_chunk = 7;
    let huge = |t: TrainJob| TrainJob {
        learn: LearnParams {
            memory_bits: MAX_MEMORY_BITS,
            ..t.learn
        },
        ..t
    };
    // 20 episodes go out in legs: the state travels between them.
    let err = pool
        .train(&[trial(5, 1), huge(trial(20, 2))], &mut |_, _| ())
        .unwrap_err();
    let said = err.to_string();
    assert!(
        matches!(
            err,
            EvalError::StateTooLarge {
                memory_bits: 24,
                ..
            }
        ),
        "{said}"
    );
    assert!(said.contains("qlearning.memory_bits = 24"), "{said}");
    assert!(said.contains("legs of at most 7"), "{said}");
    let sent: usize = pool.links.iter().map(|l| l.sent.len()).sum();
    assert_eq!(sent, 0, "chunks sent");
    // So does a leg that stops short of the trial's end.
    let short = TrainJob {
        until: 3,
        ..huge(trial(5, 3))
    };
    assert!(pool.can_train(std::slice::from_ref(&short)).is_err());
    // A trial that goes out whole brings no state back and is trained,
    // from its start or from a state that fits a frame.
    let whole = huge(trial(5, 4));
    let first = run_training(&TrainJob {
        until: 2,
        ..whole.clone()
    })
    .unwrap();
    let rest = TrainJob {
        from: first.state,
        ..whole.clone()
    };
    let trials = [whole, rest];
    pool.can_train(&trials).unwrap();
    let results = pool.train(&trials, &mut |_, _| ()).unwrap();
    let alone: Vec<TrainResult> = trials.iter().map(|t| run_training(t).unwrap()).collect();
    assert!(results == alone);
}

#[test]
fn an_experiment_refuses_such_a_trial_before_its_ga_trials_run() {
    use crate::experiment::{run, ExperimentError, Progress, Task};
    use crate::trial::Generation;
    use lander_model::Method;
    struct Seen(usize);
    impl Progress<u8> for Seen {
        fn started(&mut self, _: u8, _: &RunConfig) {
            self.0 += 1;
        }
        fn generation(&mut self, _: u8, _: &Generation) {}
        fn finished(
            &mut self,
            _: u8,
            _: lander_report::model::TrialRecord,
        ) -> Result<(), ExperimentError> {
            Ok(())
        }
    }
    let mut pool = super::fake::flying(2);
    pool.episodes_per_chunk = 7;
    let defaults = RunConfig::default();
    let learning = RunConfig {
        method: Method::Qlearning,
        qlearning: LearnParams {
            memory_bits: MAX_MEMORY_BITS,
            episodes: 20,
            ..defaults.qlearning
        },
        ..defaults
    };
    let tasks = [
        Task {
            key: 0,
            cfg: RunConfig::default(),
        },
        Task {
            key: 1,
            cfg: learning,
        },
    ];
    let mut seen = Seen(0);
    let err = run(&tasks, &mut pool, 8, &mut seen).unwrap_err();
    assert!(
        matches!(err, ExperimentError::Eval(EvalError::StateTooLarge { .. })),
        "{err}"
    );
    assert_eq!(seen.0, 0, "trials started");
}
