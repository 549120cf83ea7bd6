//! A step of several batches still to be bred: whether the pool breeds
//! them as it hands them out or first, in parallel (`Pace`), each flies as
//! it does in-process.

use super::fake::Nowhere;
use crate::config::RunConfig;
use crate::evaluator::{Batch, Evaluator, InProcess};
use crate::ga::{random_population, Genome};
use crate::pool::backend::Pace;
use crate::pool::{Pool, DEPTH, SHARED_STEP_DEPTH};
use crate::trial::offspring;
use lander_model::stream::streams;
use lander_model::{Evaluation, Pass, StreamKey};
use std::time::Duration;

const TRIALS: u64 = 3;

/// Each trial's parents, and their made-up fitness.
fn parents(cfg: &RunConfig) -> Vec<(Vec<Genome>, Vec<f64>)> {
    (0..TRIALS)
        .map(|t| {
            let mut rng = StreamKey::new(9, t, 0, 1).rng(streams::OPERATORS);
            let genomes = random_population(&cfg.ga, &mut rng);
            let fitness = (0..genomes.len()).map(|i| (i % 7) as f64).collect();
            (genomes, fitness)
        })
        .collect()
}

/// A guided batch of `genomes` under `cfg` and `key`, flown as they are
/// unless given what breeds them.
fn guided<'a>(cfg: &RunConfig, key: StreamKey, genomes: &'a mut Vec<Genome>) -> Batch<'a> {
    Batch::new(
        cfg.env(0),
        Pass::Guide,
        cfg.guided,
        key,
        cfg.ga.max_duration,
        genomes,
    )
}

/// Flies one step of `TRIALS` batches still to be bred on `evaluator`.
fn step(evaluator: &mut dyn Evaluator) -> (Vec<Vec<Evaluation>>, Vec<Vec<Genome>>) {
    step_of(evaluator, TRIALS as usize)
}

/// Flies one step of the first `trials` batches still to be bred.
fn step_of(
    evaluator: &mut dyn Evaluator,
    trials: usize,
) -> (Vec<Vec<Evaluation>>, Vec<Vec<Genome>>) {
    let cfg = RunConfig::default();
    let mut from = parents(&cfg);
    from.truncate(trials);
    let mut genomes: Vec<Vec<Genome>> = vec![Vec::new(); from.len()];
    let batches: Vec<Batch<'_>> = (0..)
        .zip(&from)
        .zip(&mut genomes)
        .map(|((t, (parents, fitness)), genomes)| {
            let key = StreamKey::new(9, t, 0, 2);
            let bred = offspring(&cfg.ga, parents, fitness, key);
            guided(&cfg, key, genomes).breeding(Some(bred))
        })
        .collect();
    let evaluations = evaluator.evaluate_many(batches).unwrap();
    (evaluations, genomes)
}

/// A pool over two links that fly each chunk as a worker does, paced as
/// `pace` says.
fn paced(pace: Pace) -> Pool<Nowhere> {
    let mut pool = super::fake::flying(2);
    pool.pace = pace;
    pool
}

#[test]
fn batches_bred_as_handed_out_or_first_fly_as_in_process() {
    let in_process = step(&mut InProcess::new(2).unwrap());
    let slow_breeding = Pace {
        breeding: Duration::from_millis(10),
        flying: Duration::from_millis(1),
    };
    for pace in [Pace::default(), slow_breeding] {
        let mut pool = paced(pace);
        assert!(step(&mut pool) == in_process, "{pace:?}");
        // The step's breeding was timed, for the next step to go by.
        assert!(pool.pace.breeding > Duration::ZERO, "{pace:?}");
    }
}

/// Where the coordinator flies a share of a single trial's step, a slow
/// worker holds two chunks at most, so that the step ends on the small
/// ones; in a step of several trials it holds four.
#[test]
fn a_worker_holds_two_chunks_of_one_trials_step_shared_here_and_four_of_more() {
    for (trials, most) in [(1, SHARED_STEP_DEPTH), (TRIALS as usize, DEPTH)] {
        let mut pool = super::fake::flying(1);
        pool.opts.share = true;
        pool.opts.chunks_per_worker = 4;
        pool.links[0].looks_per_answer = 3;
        let in_process = step_of(&mut InProcess::new(2).unwrap(), trials);
        assert!(step_of(&mut pool, trials) == in_process, "{trials} trials");
        assert_eq!(pool.links[0].most_held, most, "{trials} trials");
        assert!(pool.flown_here() > 0, "{trials} trials: nothing flown here");
    }
}

#[test]
fn breeding_as_handed_out_keeps_up_while_one_thread_does_not_hold_the_workers_up() {
    let pace = |breeding, flying| Pace {
        breeding: Duration::from_micros(breeding),
        flying: Duration::from_micros(flying),
    };
    // Before any step, and with a single worker, it keeps up.
    assert!(Pace::default().keeps_up(8));
    assert!(pace(400, 100).keeps_up(1));
    // 400 µs of breeding beside 900 µs of flying: the step's work spread
    // over two workers takes (400 + 900) / 2 = 650 µs, over three 433 µs,
    // both more than the breeding; over four 325 µs, over eight 163 µs,
    // less.
    assert!(pace(400, 900).keeps_up(2));
    assert!(pace(400, 900).keeps_up(3));
    assert!(!pace(400, 900).keeps_up(4));
    assert!(!pace(400, 900).keeps_up(8));
    assert!(pace(400, 2800).keeps_up(8));
}

/// A pool over flying links, one per CPU, the last beside the
/// coordinator, cutting a generation as `lander run` does. The workers are
/// slower than the breeding, so that more chunks are bred than their
/// queues hold.
fn on_every_cpu(dir: &std::path::Path) -> Pool<Nowhere> {
    let mut pool = super::fake::on_every_cpu(dir, true);
    for link in &mut pool.links {
        link.looks_per_answer = 3;
    }
    pool.opts.chunks_per_worker = crate::pool::DEPTH;
    pool.opts.stand_in = true;
    pool
}

#[test]
fn the_coordinator_flies_in_place_of_the_worker_on_its_cpu() {
    let dir = tempfile::tempdir().unwrap();
    let mut pool = on_every_cpu(dir.path());
    let others = pool.links.len() - 1;
    // One trial's generation, then several trials' at once: the worker
    // beside the coordinator gets nothing, the coordinator flies what it
    // would have, and the results are in-process's.
    let single = step_of(&mut pool, 1);
    assert!(single == step_of(&mut InProcess::new(2).unwrap(), 1));
    let several = step(&mut pool);
    assert!(several == step(&mut InProcess::new(2).unwrap()));
    let beside = pool.links.last().unwrap().sent.len();
    if others > 0 {
        assert_eq!(beside, 0, "the coordinator's neighbour was sent chunks");
        assert!(pool.flown_here() > 0, "the coordinator flew nothing");
        assert!(
            pool.links[..others].iter().all(|l| !l.sent.is_empty()),
            "a worker not beside the coordinator was sent nothing"
        );
    } else {
        // Alone, that worker flies everything.
        assert!(beside > 0);
    }
    assert_eq!(pool.children.stop_all(&[]), 0);
}

#[test]
fn without_the_stand_in_every_worker_flies_its_share() {
    let dir = tempfile::tempdir().unwrap();
    let mut pool = on_every_cpu(dir.path());
    pool.opts.stand_in = false;
    let several = step(&mut pool);
    assert!(several == step(&mut InProcess::new(2).unwrap()));
    assert!(
        pool.links.iter().all(|l| !l.sent.is_empty()),
        "a worker sent nothing"
    );
    assert_eq!(pool.flown_here(), 0);
    assert_eq!(pool.children.stop_all(&[]), 0);
}

#[test]
fn a_worker_that_keeps_up_with_the_breeding_gets_every_chunk_as_it_is_bred() {
    let dir = tempfile::tempdir().unwrap();
    // Workers that answer at every look: the pool looks for answers as it
    // breeds, so their queues never stay full.
    let mut pool = super::fake::on_every_cpu(dir.path(), true);
    pool.opts.chunks_per_worker = crate::pool::DEPTH;
    pool.opts.stand_in = true;
    let others = pool.links.len() - 1;
    let several = step(&mut pool);
    assert!(several == step(&mut InProcess::new(2).unwrap()));
    if others > 0 {
        let sent: usize = pool.links[..others].iter().map(|l| l.sent.len()).sum();
        assert!(
            sent > others * crate::pool::DEPTH,
            "{sent} chunks went out: no more than the queues hold"
        );
        // Every one of them while the step was bred, none after.
        assert_eq!(pool.handed_early, sent as u64);
        assert_eq!(pool.flown_here(), 0, "a chunk waited for the coordinator");
        assert!(pool.links[others].sent.is_empty());
    } else {
        // Alone, the worker beside the coordinator flies everything.
        assert!(!pool.links[0].sent.is_empty());
    }
    assert_eq!(pool.children.stop_all(&[]), 0);
}

#[test]
fn standing_in_the_coordinator_polls_for_its_last_answers_before_it_sleeps() {
    let in_process = step(&mut InProcess::new(2).unwrap());
    for spin in [Duration::ZERO, Duration::from_secs(5)] {
        let dir = tempfile::tempdir().unwrap();
        let mut pool = on_every_cpu(dir.path());
        pool.answer_spin = lander_protocol::spin::Spin::new(spin);
        assert!(step(&mut pool) == in_process, "{spin:?}");
        let sleeps = pool.transport.sleeps;
        if pool.links.len() == 1 {
            // One CPU: the one worker, beside the coordinator, flies
            // everything, and the coordinator waits for it as it would
            // for any worker, without polling.
            assert!(pool.links[0].sent.len() > 1);
        } else if spin.is_zero() {
            // Slow workers: with nothing left to fly, it slept for them.
            assert!(sleeps > 0, "it never waited");
        } else {
            // Polling, it found every answer before its budget ran out.
            assert_eq!(sleeps, 0, "{spin:?}");
        }
        assert_eq!(pool.children.stop_all(&[]), 0);
    }
}

#[test]
fn while_the_worker_on_its_cpu_starts_the_coordinator_flies_in_its_place() {
    let in_process = step(&mut InProcess::new(2).unwrap());
    // Once every worker but the one beside the coordinator has joined (on
    // more than one CPU), and before any has: that one is spawned, with no
    // link yet. The first case comes first: without the stand-in it fails
    // where the second waits for ever.
    let others = lander_protocol::host::allowed_cpus().len() - 1;
    let cases = if others > 0 { vec![others, 0] } else { vec![0] };
    for joined in cases {
        let dir = tempfile::tempdir().unwrap();
        let mut pool = on_every_cpu(dir.path());
        pool.links.truncate(joined);
        assert!(step(&mut pool) == in_process, "{joined} joined");
        assert!(
            pool.flown_here() > 0,
            "the coordinator slept while its neighbour started"
        );
        if pool.links.is_empty() {
            assert_eq!(pool.transport.sleeps, 0, "it waited for a worker");
        }
        assert_eq!(pool.children.stop_all(&[]), 0);
    }
}

#[test]
fn while_only_the_worker_on_its_cpu_has_joined_the_coordinator_still_flies_in_its_place() {
    // The others are spawned and still starting: a chunk sent to the one
    // beside the coordinator would wait for the coordinator's own CPU.
    let others = lander_protocol::host::allowed_cpus().len() - 1;
    if others == 0 {
        // One CPU: that worker is the only one, and flies everything
        // (`the_coordinator_flies_in_place_of_the_worker_on_its_cpu`).
        return;
    }
    let in_process = step(&mut InProcess::new(2).unwrap());
    let dir = tempfile::tempdir().unwrap();
    let mut pool = on_every_cpu(dir.path());
    pool.links.drain(..others);
    assert!(step(&mut pool) == in_process);
    assert!(
        pool.links[0].sent.is_empty(),
        "the coordinator's neighbour was sent chunks"
    );
    assert!(pool.flown_here() > 0, "the coordinator flew nothing");
    assert_eq!(pool.children.stop_all(&[]), 0);
}

#[test]
fn a_step_stopped_midway_leaves_its_genomes_as_bred() {
    use crate::evaluator::EvalError;
    let cfg = RunConfig::default();
    let (parents, fitness) = &parents(&cfg)[0];
    let key = StreamKey::new(9, 0, 0, 2);
    let bred: Vec<Genome> = offspring(&cfg.ga, parents, fitness, key).collect();
    // The first link flies its chunk at once; the second holds its own
    // without answering, and the stop comes while the pool waits for it.
    let mut pool = super::fake::flying(1);
    pool.links
        .push(super::fake::Recorder::holding(1, Vec::new()));
    pool.transport.stops = Some(pool.opts.stop.clone());
    let mut genomes = Vec::new();
    let batch =
        guided(&cfg, key, &mut genomes).breeding(Some(offspring(&cfg.ga, parents, fitness, key)));
    assert!(matches!(
        pool.evaluate_many(vec![batch]),
        Err(EvalError::Interrupted)
    ));
    assert_eq!((pool.links[0].sent.len(), pool.links[1].sent.len()), (1, 1));
    // The answer taken had rewritten its genomes' actions...
    let mut flown = bred.clone();
    let mut evaluator = InProcess::new(1).unwrap();
    let batch = guided(&cfg, key, &mut flown);
    evaluator.evaluate_many(vec![batch]).unwrap();
    assert_ne!(flown, bred, "the guided pass changes some actions");
    // ...and they are back as bred: a trial saved now resumes as it
    // would have gone on.
    assert!(genomes == bred, "the genomes are not as bred");
}

#[test]
fn a_batch_read_in_part_before_it_flies_flies_as_one_bred_whole_on_any_thread_count() {
    let cfg = RunConfig::default();
    let (parents, fitness) = &parents(&cfg)[0];
    let key = StreamKey::new(9, 0, 0, 2);
    let fly = |threads: usize, read: usize| {
        let mut genomes = Vec::new();
        let mut batch = guided(&cfg, key, &mut genomes)
            .breeding(Some(offspring(&cfg.ga, parents, fitness, key)));
        batch.bred_up_to(read);
        let evaluations = InProcess::new(threads)
            .unwrap()
            .evaluate_many(vec![batch])
            .unwrap();
        (evaluations, genomes)
    };
    let whole = fly(1, 0);
    assert_eq!(whole.1.len(), cfg.ga.population);
    for threads in [1, 2] {
        assert!(fly(threads, 3) == whole, "{threads} threads");
    }
}
