//! The work `lander bench` measures: the generations of real trials, the
//! same for every mode and every round.

use crate::config::RunConfig;
use crate::evaluator::EvalError;
use crate::ga::Genome;
use crate::stop::Stop;
use crate::trial::{TrialError, TrialRun};
use lander_model::{Env, Pass, StreamKey};

/// The generations every mode evaluates: those a real run evaluates, so
/// that the bench measures what users get. Each trial in flight is flown
/// in-process, once, before any mode starts, and every generation's
/// genomes are kept as they were before evaluation; a trial that lands
/// gives way to the next trial number. The work is therefore the same for
/// every mode and every round, and as costly, genome for genome, as a
/// run's. A step is one generation of each of `in_flight` trials,
/// evaluated together as `lander experiment` steps the trials it has in
/// flight.
pub struct Workload {
    pub cfg: RunConfig,
    pub pass: Pass,
    pub in_flight: usize,
    /// Per step, one population per trial in flight.
    pub steps: Vec<Vec<Population>>,
}

/// One trial's generation: where it flies and what.
pub struct Population {
    pub env: Env,
    pub key: StreamKey,
    pub genomes: Vec<Genome>,
    /// What a run breeds `genomes` from, where it breeds them from the
    /// generation before (not at an attempt's start): each mode breeds
    /// them again, as that run's evaluator would.
    pub bred_from: Option<Parents>,
}

/// A generation as the guided pass left it, and its fitness.
pub struct Parents {
    pub genomes: Vec<Genome>,
    pub fitness: Vec<f64>,
}

/// The most memory a workload may hold, in bytes: it keeps every
/// generation it measures, so `--generations` or `--population` large
/// enough would take the host's memory before the first mode starts.
pub const MAX_BYTES: u64 = 4_000_000_000;

#[derive(Debug, thiserror::Error)]
pub enum WorkloadError {
    #[error(transparent)]
    Trial(#[from] TrialError),
    #[error(
        "the workload would hold more than {} GB after {steps} generations \
         (each generation's genomes and their parents are kept); ask for \
         fewer --generations, a smaller --population or fewer --in-flight",
        most / 1_000_000_000
    )]
    TooLarge { steps: usize, most: u64 },
}

/// About what a genome of `genes` genes takes kept: its genes, two bytes
/// each, and its vector's header and allocation.
fn genome_bytes(genes: usize) -> u64 {
    2 * genes as u64 + 48
}

impl Population {
    /// About the memory it holds.
    fn bytes(&self) -> u64 {
        let held =
            |genomes: &[Genome]| -> u64 { genomes.iter().map(|g| genome_bytes(g.len())).sum() };
        held(&self.genomes) + self.bred_from.as_ref().map_or(0, |p| held(&p.genomes))
    }
}

impl Workload {
    /// `generations` steps of `in_flight` trials, numbered from the
    /// configuration's trial on; `None` takes as many steps as the first
    /// trial flies generations, so that with one trial in flight the
    /// workload is exactly `lander run`'s. Stops, interrupted, once `stop`
    /// is asked.
    pub fn new(
        cfg: &RunConfig,
        pass: Pass,
        generations: Option<u64>,
        in_flight: usize,
        stop: &Stop,
    ) -> Result<Workload, WorkloadError> {
        Workload::within(cfg, pass, generations, in_flight, stop, MAX_BYTES)
    }

    /// [`Workload::new`], holding at most `most` bytes.
    fn within(
        cfg: &RunConfig,
        pass: Pass,
        generations: Option<u64>,
        in_flight: usize,
        stop: &Stop,
        most: u64,
    ) -> Result<Workload, WorkloadError> {
        let cfg = RunConfig {
            method: pass.method(),
            ..cfg.clone()
        };
        // Asked for a count, a workload too large is refused at once;
        // otherwise as it grows past the bound.
        if let Some(n) = generations {
            let step =
                2 * (in_flight * cfg.ga.population) as u64 * genome_bytes(cfg.ga.genome_length);
            if n.saturating_mul(step) > most {
                return Err(WorkloadError::TooLarge {
                    steps: n as usize,
                    most,
                });
            }
        }
        let mut held = 0;
        let mut flights = (0..in_flight as u64)
            .map(|t| Flown::new(&cfg, t, in_flight as u64))
            .collect::<Result<Vec<_>, _>>()?;
        let mut steps = Vec::new();
        let first = cfg.trial;
        loop {
            let done = match generations {
                Some(n) => steps.len() as u64 >= n,
                None => flights.first().is_none_or(|f| f.finished(first)),
            };
            if done {
                break;
            }
            if stop.asked() {
                return Err(TrialError::Eval(EvalError::Interrupted).into());
            }
            let step = flights
                .iter_mut()
                .map(Flown::next)
                .collect::<Result<Vec<_>, _>>()?;
            held += step.iter().map(Population::bytes).sum::<u64>();
            if held > most {
                return Err(WorkloadError::TooLarge {
                    steps: steps.len(),
                    most,
                });
            }
            steps.push(step);
        }
        Ok(Workload {
            cfg,
            pass,
            in_flight,
            steps,
        })
    }

    pub fn genomes(&self) -> usize {
        self.steps.iter().flatten().map(|p| p.genomes.len()).sum()
    }
}

/// One slot of the trials in flight: the trial it is flying, and which
/// trial comes next when that one ends.
struct Flown {
    cfg: RunConfig,
    run: TrialRun,
    /// Trial numbers this slot takes, `stride` apart.
    stride: u64,
}

impl Flown {
    fn new(cfg: &RunConfig, slot: u64, stride: u64) -> Result<Flown, TrialError> {
        let cfg = RunConfig {
            trial: cfg
                .trial
                .checked_add(slot)
                .ok_or(TrialError::TrialNumber(cfg.trial))?,
            ..cfg.clone()
        };
        Ok(Flown {
            run: TrialRun::new(&cfg)?,
            cfg,
            stride,
        })
    }

    /// Whether this slot's trial `trial` has ended.
    fn finished(&self, trial: u64) -> bool {
        self.cfg.trial != trial || self.run.result().is_some()
    }

    /// The next generation a run flies, as it stands before evaluation;
    /// then evaluates it as a run would, and moves on.
    fn next(&mut self) -> Result<Population, TrialError> {
        if self.run.result().is_some() {
            self.cfg.trial = self
                .cfg
                .trial
                .checked_add(self.stride)
                .ok_or(TrialError::TrialNumber(self.cfg.trial))?;
            self.run = TrialRun::new(&self.cfg)?;
        }
        let bred_from = self.run.parents().map(|(genomes, fitness)| Parents {
            genomes: genomes.to_vec(),
            fitness: fitness.to_vec(),
        });
        let mut batch = self.run.batch();
        let kept = Population {
            env: batch.env,
            key: batch.key,
            genomes: batch.bred_genomes().to_vec(),
            bred_from,
        };
        let evaluations = batch.evaluate_here();
        self.run.accept(&evaluations);
        Ok(kept)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ga::random_population;
    use lander_model::stream::streams;

    fn small() -> RunConfig {
        let mut cfg = RunConfig::default();
        cfg.ga.population = 6;
        cfg.ga.max_generations = 2;
        cfg.ga.max_restarts = 0;
        cfg
    }

    #[test]
    fn the_steps_are_a_runs_generations_and_a_finished_trial_gives_way() {
        let cfg = small();
        let work = Workload::new(&cfg, Pass::Guide, Some(5), 1, &Stop::new()).unwrap();
        let keys: Vec<StreamKey> = work.steps.iter().map(|s| s[0].key).collect();
        // Two generations of trial 1 (no restart), then trial 2's.
        let key = |trial, generation| StreamKey::new(cfg.seed, trial, 0, generation);
        assert_eq!(
            keys,
            [key(1, 1), key(1, 2), key(2, 1), key(2, 2), key(3, 1)]
        );
        // A trial's first generation is its random one; the second is bred
        // from it, as in a run.
        let first = random_population(&cfg.ga, &mut key(1, 1).rng(streams::OPERATORS));
        assert_eq!(work.steps[0][0].genomes, first);
        let random_second = random_population(&cfg.ga, &mut key(1, 2).rng(streams::OPERATORS));
        assert_ne!(work.steps[1][0].genomes, random_second);
        assert_eq!(
            work.steps[2][0].env,
            RunConfig {
                trial: 2,
                ..cfg.clone()
            }
            .env(0)
        );
        assert_eq!(work.genomes(), 5 * 6);
    }

    #[test]
    fn a_bred_generation_breeds_again_into_the_runs_genomes() {
        let cfg = small();
        let work = Workload::new(&cfg, Pass::Guide, Some(5), 1, &Stop::new()).unwrap();
        // Trials 1 and 2 fly generations 1 and 2, trial 3 its first.
        for step in &work.steps {
            let p = &step[0];
            match &p.bred_from {
                None => assert_eq!(p.key.generation, 1, "only an attempt's first is drawn"),
                Some(from) => {
                    let ga = &work.cfg.ga;
                    let bred: Vec<Genome> =
                        crate::trial::offspring(ga, &from.genomes, &from.fitness, p.key).collect();
                    assert_eq!(bred, p.genomes);
                }
            }
        }
        assert_eq!(
            work.steps
                .iter()
                .filter(|s| s[0].bred_from.is_some())
                .count(),
            2
        );
    }

    #[test]
    fn by_default_the_workload_is_the_first_trial_whole() {
        let cfg = small();
        let work = Workload::new(&cfg, Pass::Guide, None, 1, &Stop::new()).unwrap();
        // At most 2 generations and no restart: the trial flies 1 or 2.
        let mut run = TrialRun::new(&RunConfig {
            method: lander_model::Method::Guided,
            ..cfg
        })
        .unwrap();
        let mut flown = 0;
        while run.result().is_none() {
            let evaluations = run.batch().evaluate_here();
            run.accept(&evaluations);
            flown += 1;
        }
        assert_eq!(work.steps.len(), flown);
        assert!(work.steps.iter().all(|s| s[0].key.trial == 1));
    }

    #[test]
    fn a_workload_past_the_memory_bound_is_refused_before_it_is_flown() {
        // 100 genomes of 50 genes and their parents: about 30 kB a step.
        let err = Workload::new(
            &RunConfig::default(),
            Pass::Fly,
            Some(1_000_000),
            1,
            &Stop::new(),
        )
        .err()
        .unwrap();
        assert!(matches!(
            err,
            WorkloadError::TooLarge {
                steps: 1_000_000,
                most: MAX_BYTES
            }
        ));
        assert!(
            err.to_string()
                .contains("more than 4 GB after 1000000 generations"),
            "{err}"
        );
        assert!(Workload::new(&small(), Pass::Fly, Some(3), 2, &Stop::new()).is_ok());
    }

    #[test]
    fn a_workload_without_a_count_is_refused_as_it_grows_past_the_bound() {
        // 6 genomes of 50 genes: 888 bytes a generation, its parents as
        // much again from the second; the first trial flies 2 generations.
        let step = 6 * genome_bytes(50);
        let fly = |most| Workload::within(&small(), Pass::Fly, None, 1, &Stop::new(), most);
        assert!(matches!(
            fly(2 * step),
            Err(WorkloadError::TooLarge { steps: 1, .. })
        ));
        assert_eq!(fly(3 * step).unwrap().steps.len(), 2);
    }

    #[test]
    fn a_stop_ends_the_building_and_the_last_trial_number_is_refused() {
        let stop = Stop::new();
        stop.ask();
        assert!(matches!(
            Workload::new(&small(), Pass::Fly, Some(3), 1, &stop),
            Err(WorkloadError::Trial(TrialError::Eval(
                EvalError::Interrupted
            )))
        ));
        let last = RunConfig {
            trial: u64::MAX,
            ..small()
        };
        assert!(matches!(
            Workload::new(&last, Pass::Fly, Some(1), 2, &Stop::new()),
            Err(WorkloadError::Trial(TrialError::TrialNumber(u64::MAX)))
        ));
    }

    #[test]
    fn trials_in_flight_take_every_other_trial_number() {
        let work = Workload::new(&small(), Pass::Fly, Some(3), 2, &Stop::new()).unwrap();
        let trials: Vec<Vec<u64>> = work
            .steps
            .iter()
            .map(|s| s.iter().map(|p| p.key.trial).collect())
            .collect();
        assert_eq!(trials, [[1, 2], [1, 2], [3, 4]]);
    }

    #[test]
    fn the_configuration_flies_the_pass_it_is_given() {
        let cfg = RunConfig {
            method: lander_model::Method::Qlearning,
            ..small()
        };
        // The pass decides: the configuration's method is the pass's.
        let work = Workload::new(&cfg, Pass::Fly, Some(1), 1, &Stop::new()).unwrap();
        assert_eq!(work.cfg.method, lander_model::Method::Ga);
    }
}
