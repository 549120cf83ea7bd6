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

/// A pool whose first link answers trial 0 well and trial 2 with bytes
/// that do not decode, and whose second flies as it should.
fn one_spoiling_the_third() -> crate::pool::Pool<super::fake::Nowhere> {
    let mut pool = super::fake::flying(2);
    pool.links[0].spoils = Some(2);
    pool
}

#[test]
fn a_trial_whose_result_is_given_up_is_told_again_with_the_one_taken_in_its_place() {
    let mut pool = one_spoiling_the_third();
    let trials = [trial(5, 1), trial(5, 2), trial(5, 3)];
    let mut told: Vec<(usize, TrainResult)> = Vec::new();
    let results = pool
        .train(&trials, &mut |i, r| told.push((i, r.clone())))
        .unwrap();
    let whole: Vec<TrainResult> = trials.iter().map(|t| run_training(t).unwrap()).collect();
    assert!(results == whole);
    // The first link answered trial 0 before its answer to trial 2 was
    // refused: what it gave is no longer believed, and trial 0 is flown
    // again on the second, and told again.
    let order: Vec<usize> = told.iter().map(|(i, _)| *i).collect();
    assert_eq!(order.iter().filter(|&&i| i == 0).count(), 2, "{order:?}");
    assert_eq!(order.len(), 4, "{order:?}");
    for (i, r) in &told {
        assert!(*r == whole[*i], "trial {i} told otherwise than flown whole");
    }
    let ids: Vec<u64> = pool.links.iter().map(|l| l.id).collect();
    assert_eq!(ids, [1], "the spoiling link is refused");
}

#[test]
fn an_experiment_keeps_one_record_a_trial_told_twice() {
    use crate::experiment::{keep, run, ExperimentError, Progress, Task};
    use crate::trial::Generation;
    use lander_model::Method;
    use lander_report::model::TrialRecord;
    #[derive(Default)]
    struct Kept {
        records: Vec<TrialRecord>,
        told: usize,
    }
    impl Progress<u64> for Kept {
        fn started(&mut self, _: u64, _: &RunConfig) {}
        fn generation(&mut self, _: u64, _: &Generation) {}
        fn finished(&mut self, _: u64, mut record: TrialRecord) -> Result<(), ExperimentError> {
            record.wall_s = 0.0;
            self.told += 1;
            keep(&mut self.records, record);
            Ok(())
        }
    }
    let defaults = RunConfig::default();
    let tasks: Vec<Task<u64>> = (1..=3)
        .map(|t| Task {
            key: t,
            cfg: RunConfig {
                method: Method::Qlearning,
                trial: t,
                qlearning: LearnParams {
                    episodes: 5,
                    ..defaults.qlearning
                },
                ..defaults.clone()
            },
        })
        .collect();
    let mut spoilt = Kept::default();
    run(&tasks, &mut one_spoiling_the_third(), 8, &mut spoilt).unwrap();
    let mut honest = Kept::default();
    run(&tasks, &mut super::fake::flying(2), 8, &mut honest).unwrap();
    assert_eq!((spoilt.told, honest.told), (4, 3));
    let sorted = |mut r: Vec<TrialRecord>| {
        r.sort_by_key(|r| r.trial);
        serde_json::to_string(&r).unwrap()
    };
    assert_eq!(sorted(spoilt.records), sorted(honest.records));
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
