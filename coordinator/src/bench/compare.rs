//! The comparison behind `lander bench`: a warm-up, then rounds in which
//! each mode flies the whole workload as one block, in an order that
//! rotates from round to round, and the [`Report`]: each mode's figures, the [`Ratios`] between
//! modes, and whether every mode's results agree.

use super::mode::{Mode, ModeKind, ModeReport};
use super::Workload;
use crate::evaluator::EvalError;
use serde::Serialize;

/// How a comparison runs, and what its report says of it.
#[derive(Clone, Copy, Debug)]
pub struct Plan {
    /// Rounds; each runs every mode over the whole workload once.
    pub rounds: usize,
    /// N: the workers (and threads) of the parallel modes the ratios compare.
    pub workers: usize,
    /// The chunks per worker the pools were given: reported, not used here.
    pub chunks_per_worker: u16,
}

/// Ratios between modes, where the report holds both.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Ratios {
    /// iceoryx2 with N workers over iceoryx2 with 1.
    pub scaling: Option<f64>,
    /// The scaling if the workers did nothing but compute, perfectly
    /// balanced: one worker's compute per generation over the mean per
    /// worker with N. Below N when N busy CPUs each run slower than one
    /// does alone (a shared host, clock boost, shared caches): no pool can
    /// scale past it.
    pub compute_scaling: Option<f64>,
    /// iceoryx2 with N workers over in-process with N threads.
    pub ipc_efficiency: Option<f64>,
    /// zenoh with N workers over in-process with N threads.
    pub zenoh_efficiency: Option<f64>,
}

impl Ratios {
    /// The ratios between `modes` for N = `n` workers; the first mode of a
    /// kind counts. Scaling needs N above 1.
    pub fn of(modes: &[ModeReport], n: usize) -> Ratios {
        let find = |kind: ModeKind| modes.iter().find(|m| m.kind == kind);
        let rate = |kind| find(kind).map(|m| m.genomes_per_s);
        let compute = |kind| find(kind).and_then(|m| m.generation).map(|g| g.compute_us);
        let ratio = |a: Option<f64>, b: Option<f64>| Some(a? / b?);
        let ipc_1 = ModeKind::Iceoryx2 { workers: 1 };
        let ipc_n = ModeKind::Iceoryx2 { workers: n };
        let inproc_n = ModeKind::InProcess { threads: n };
        let zenoh_n = ModeKind::Zenoh { workers: n };
        Ratios {
            scaling: ratio(rate(ipc_n), rate(ipc_1)).filter(|_| n > 1),
            compute_scaling: ratio(compute(ipc_1), compute(ipc_n)).filter(|_| n > 1),
            ipc_efficiency: ratio(rate(ipc_n), rate(inproc_n)),
            zenoh_efficiency: ratio(rate(zenoh_n), rate(inproc_n)),
        }
    }
}

/// What `lander bench` found, as `--json` prints it.
#[derive(Debug, Serialize)]
pub struct Report {
    pub method: &'static str,
    pub population: usize,
    pub in_flight: usize,
    pub generations: usize,
    pub rounds: usize,
    pub workers: usize,
    pub chunks_per_worker: u16,
    pub modes: Vec<ModeReport>,
    pub ratios: Ratios,
    pub hashes_agree: bool,
}

/// Runs `work` over `modes` as `plan` says and reports on it. A short
/// warm-up (the first step, by every mode) is left out of every figure;
/// then, round after round, each mode flies every generation back to back
/// as one block, as a run does, so that its threads or workers stay warm
/// between generations; the order of the blocks rotates by one each round,
/// so that noise hits all modes alike. Only time inside the evaluator
/// counts; start-up does not.
pub fn run(work: &Workload, modes: &mut [Mode], plan: &Plan) -> Result<Report, EvalError> {
    if !work.steps.is_empty() {
        for m in modes.iter_mut() {
            let _placed = m.place_thread();
            m.block(work, 0..1)?;
            m.reset();
        }
    }
    let k = modes.len();
    for round in 0..plan.rounds {
        for i in 0..k {
            let mode = &mut modes[(i + round) % k];
            // Placed as a run's loop is, for the whole block.
            let _placed = mode.place_thread();
            mode.block(work, 0..work.steps.len())?;
        }
        modes.iter_mut().for_each(Mode::end_round);
    }
    let reports: Vec<ModeReport> = modes.iter().map(Mode::report).collect();
    Ok(Report {
        method: work.cfg.method.name(),
        population: work.cfg.ga.population,
        in_flight: work.in_flight,
        generations: work.steps.len(),
        rounds: plan.rounds,
        workers: plan.workers,
        chunks_per_worker: plan.chunks_per_worker,
        ratios: Ratios::of(&reports, plan.workers),
        modes: reports,
        hashes_agree: hashes_agree(modes),
    })
}

/// Every mode's results hashed the same in every round, and the same as
/// every other mode's.
pub fn hashes_agree(modes: &[Mode]) -> bool {
    modes.iter().all(|m| m.tally.consistent)
        && modes.windows(2).all(|w| w[0].tally.hash == w[1].tally.hash)
}

#[cfg(test)]
mod tests {
    use super::super::fake::{workload, Fake, Log};
    use super::super::Breakdown;
    use super::*;
    use ModeKind::*;

    fn report(kind: ModeKind, genomes_per_s: f64, compute_us: Option<f64>) -> ModeReport {
        ModeReport {
            kind,
            name: kind.name(),
            workers: kind.workers(),
            genomes: 0,
            genomes_per_s,
            ticks_per_s: 0.0,
            rtt_p50_us: None,
            rtt_p99_us: None,
            rtt_max_us: None,
            overhead_p99_us: None,
            coordinator_cpu_us_per_generation: 0.0,
            coordinator_cpu_us_per_chunk: None,
            worker_utilisation: None,
            generation: compute_us.map(|compute_us| Breakdown {
                compute_us,
                ..Breakdown::default()
            }),
            hash: String::new(),
        }
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-9
    }

    fn plan(rounds: usize, workers: usize) -> Plan {
        Plan {
            rounds,
            workers,
            chunks_per_worker: 4,
        }
    }

    #[test]
    fn ratios_compare_the_modes_of_the_right_kinds() {
        let modes = [
            report(InProcess { threads: 1 }, 100.0, None),
            report(InProcess { threads: 2 }, 200.0, None),
            report(Iceoryx2 { workers: 1 }, 80.0, Some(3000.0)),
            report(Iceoryx2 { workers: 2 }, 150.0, Some(2000.0)),
            report(Zenoh { workers: 2 }, 120.0, Some(2500.0)),
        ];
        let r = Ratios::of(&modes, 2);
        assert_eq!(
            r,
            Ratios {
                scaling: Some(150.0 / 80.0),
                compute_scaling: Some(1.5),
                ipc_efficiency: Some(0.75),
                zenoh_efficiency: Some(0.6),
            }
        );
        assert_eq!(r.scaling, Some(1.875));
        // With one worker there is no scaling; efficiency compares ones.
        assert_eq!(
            Ratios::of(&modes, 1),
            Ratios {
                scaling: None,
                compute_scaling: None,
                ipc_efficiency: Some(0.8),
                zenoh_efficiency: None,
            }
        );
        // N = 3 matches no mode: nothing to compare.
        assert_eq!(Ratios::of(&modes, 3), Ratios::default());
    }

    #[test]
    fn a_ratio_needs_both_of_its_modes() {
        let no_inproc_n = [
            report(InProcess { threads: 1 }, 100.0, None),
            report(Iceoryx2 { workers: 1 }, 80.0, None),
            report(Iceoryx2 { workers: 2 }, 160.0, None),
        ];
        let r = Ratios::of(&no_inproc_n, 2);
        assert_eq!(r.scaling, Some(2.0));
        // No breakdown, no compute scaling; no inproc-2, no efficiencies.
        assert_eq!(r.compute_scaling, None);
        assert_eq!(r.ipc_efficiency, None);
        assert_eq!(r.zenoh_efficiency, None);
        // The first mode of a kind counts.
        let twice = [
            report(Iceoryx2 { workers: 2 }, 90.0, None),
            report(InProcess { threads: 2 }, 60.0, None),
            report(Iceoryx2 { workers: 2 }, 30.0, None),
        ];
        assert_eq!(Ratios::of(&twice, 2).ipc_efficiency, Some(1.5));
    }

    #[test]
    fn modes_fly_in_blocks_in_an_order_that_rotates_after_a_warm_up() {
        let log = Log::default();
        let mut modes: Vec<Mode> = ["a", "b", "c"]
            .into_iter()
            .enumerate()
            .map(|(i, label)| {
                let fake = Fake::new(label, 1, &log);
                Mode::new(InProcess { threads: i + 1 }, Box::new(fake))
            })
            .collect();
        let work = workload(2, 3, 1);
        run(&work, &mut modes, &plan(2, 2)).unwrap();
        // Generations are numbered from 1; the warm-up flies the first.
        // Then each mode flies both generations as a block, and the
        // blocks' order moves on by one in the second round.
        #[rustfmt::skip]
        let want: Vec<(&str, u64)> = vec![
            ("a", 1), ("b", 1), ("c", 1),
            ("a", 1), ("a", 2), ("b", 1), ("b", 2), ("c", 1), ("c", 2),
            ("b", 1), ("b", 2), ("c", 1), ("c", 2), ("a", 1), ("a", 2),
        ];
        assert_eq!(*log.borrow(), want);
    }

    #[test]
    fn the_warm_up_is_left_out_of_every_figure() {
        let log = Log::default();
        // The warm-up's answers differ and its one chunk computes for a
        // whole second: none of it may show.
        let mut fake = Fake::new("a", 1, &log).with_chunks(1_000);
        fake.wrong_on = vec![0];
        fake.warm_up_compute_ns = Some(1_000_000_000);
        let mut modes = vec![
            Mode::new(Iceoryx2 { workers: 1 }, Box::new(fake)),
            Mode::new(InProcess { threads: 1 }, Box::new(Fake::new("b", 1, &log))),
        ];
        // 3 genomes × 2 trials × 4 generations × 3 rounds.
        let work = workload(4, 3, 2);
        let r = run(&work, &mut modes, &plan(3, 1)).unwrap();
        assert_eq!(log.borrow().len(), 2 * (1 + 4 * 3));
        assert!(r.modes.iter().all(|m| m.genomes == 72), "{r:?}");
        // Each fake genome simulates 10 ticks.
        assert!(modes.iter().all(|m| m.tally.ticks == 720));
        assert_eq!(modes[0].tally.generations, 12);
        assert_eq!(modes[0].tally.timings.len(), 12);
        assert_eq!(modes[0].tally.breakdowns.len(), 12);
        // Every chunk computes from 10 to 1010 ns after it is sent and is
        // read at 1020 ns: 20 ns of overhead.
        let b = r.modes[0].generation.unwrap();
        assert!(close(b.compute_us, 1.0), "{b:?}");
        assert!(close(r.modes[0].rtt_max_us.unwrap(), 1.02), "{r:?}");
        assert!(close(r.modes[0].overhead_p99_us.unwrap(), 0.02), "{r:?}");
        assert_eq!(r.modes[1].generation, None);
        assert_eq!(r.modes[1].rtt_p50_us, None);
        assert!(r.hashes_agree, "the warm-up's answers count: {r:?}");
    }

    #[test]
    fn the_report_says_what_ran_and_the_ratios_of_its_modes() {
        let log = Log::default();
        // One worker computes 4 µs a generation; two share it, 1.6 µs each.
        let mut modes = vec![
            Mode::new(InProcess { threads: 1 }, Box::new(Fake::new("i1", 1, &log))),
            Mode::new(InProcess { threads: 2 }, Box::new(Fake::new("i2", 2, &log))),
            Mode::new(
                Iceoryx2 { workers: 1 },
                Box::new(Fake::new("x1", 1, &log).with_chunks(4_000)),
            ),
            Mode::new(
                Iceoryx2 { workers: 2 },
                Box::new(Fake::new("x2", 2, &log).with_chunks(1_600)),
            ),
        ];
        let work = workload(3, 5, 2);
        let r = run(&work, &mut modes, &plan(2, 2)).unwrap();
        let names: Vec<&str> = r.modes.iter().map(|m| m.name.as_str()).collect();
        assert_eq!(names, ["inproc-1", "inproc-2", "iceoryx2-1", "iceoryx2-2"]);
        let workers: Vec<usize> = r.modes.iter().map(|m| m.workers).collect();
        assert_eq!(workers, [1, 2, 1, 2]);
        assert_eq!(
            (r.method, r.population, r.in_flight, r.generations),
            ("guided", 5, 2, 3)
        );
        assert_eq!((r.rounds, r.workers, r.chunks_per_worker), (2, 2, 4));
        assert!(r.modes.iter().all(|m| m.genomes == 5 * 2 * 3 * 2));
        let rate = |i: usize| r.modes[i].genomes_per_s;
        assert!(close(r.ratios.compute_scaling.unwrap(), 2.5), "{r:?}");
        assert_eq!(r.ratios.scaling, Some(rate(3) / rate(2)));
        assert_eq!(r.ratios.ipc_efficiency, Some(rate(3) / rate(1)));
        assert_eq!(r.ratios.zenoh_efficiency, None);
        assert!(r.hashes_agree);
        let hash = &r.modes[0].hash;
        assert_eq!(hash.len(), 16);
        assert!(r.modes.iter().all(|m| &m.hash == hash));
    }

    #[test]
    fn one_mode_that_answers_differently_breaks_the_agreement() {
        // Calls: 0 the warm-up, 1 and 2 round one, 3 and 4 round two.
        let run_with_odd = |wrong_on: Vec<usize>| {
            let log = Log::default();
            let mut odd = Fake::new("b", 1, &log);
            odd.wrong_on = wrong_on;
            let mut modes = vec![
                Mode::new(InProcess { threads: 1 }, Box::new(Fake::new("a", 1, &log))),
                Mode::new(Iceoryx2 { workers: 1 }, Box::new(odd)),
                Mode::new(Zenoh { workers: 1 }, Box::new(Fake::new("c", 1, &log))),
            ];
            let r = run(&workload(2, 3, 1), &mut modes, &plan(2, 1)).unwrap();
            let consistent: Vec<bool> = modes.iter().map(|m| m.tally.consistent).collect();
            (r, consistent)
        };
        let (r, consistent) = run_with_odd(vec![]);
        assert!(r.hashes_agree);
        assert_eq!(consistent, [true; 3]);
        // Odd in every round: true to itself, but not to the others.
        let (r, consistent) = run_with_odd(vec![1, 2, 3, 4]);
        assert!(!r.hashes_agree);
        assert_eq!(r.modes[0].hash, r.modes[2].hash);
        assert_ne!(r.modes[0].hash, r.modes[1].hash);
        assert_eq!(consistent, [true; 3]);
        // Odd in round one only: its last round hashes as the others', but
        // it disagrees with itself.
        let (r, consistent) = run_with_odd(vec![2]);
        assert!(!r.hashes_agree);
        assert!(r.modes.iter().all(|m| m.hash == r.modes[0].hash));
        assert_eq!(consistent, [true, false, true]);
    }

    #[test]
    fn results_that_change_between_rounds_disagree_even_when_all_modes_change_alike() {
        let log = Log::default();
        // Calls: 0 the warm-up, 1 and 2 round one, 3 and 4 round two.
        let mut modes: Vec<Mode> = (1..=2)
            .map(|n| {
                let mut fake = Fake::new("a", n, &log);
                fake.wrong_on = vec![3];
                Mode::new(InProcess { threads: n }, Box::new(fake))
            })
            .collect();
        let work = workload(2, 3, 1);
        let r = run(&work, &mut modes, &plan(2, 2)).unwrap();
        assert_eq!(r.modes[0].hash, r.modes[1].hash);
        assert!(modes.iter().all(|m| !m.tally.consistent));
        assert!(!r.hashes_agree);
        assert!(!hashes_agree(&modes));
    }

    #[test]
    fn the_json_keeps_its_keys_in_order_and_names_modes_by_name() {
        let log = Log::default();
        let mut modes = vec![Mode::new(
            Iceoryx2 { workers: 1 },
            Box::new(Fake::new("a", 1, &log).with_chunks(500)),
        )];
        let r = run(&workload(1, 2, 1), &mut modes, &plan(1, 1)).unwrap();
        let json = serde_json::to_string(&r).unwrap();
        let keys = [
            "\"method\":\"guided\"",
            "\"population\":2",
            "\"in_flight\":1",
            "\"generations\":1",
            "\"rounds\":1",
            "\"workers\":1",
            "\"chunks_per_worker\":4",
            "\"modes\":[{\"name\":\"iceoryx2-1\",\"workers\":1,\"genomes\":2,",
            "\"genomes_per_s\"",
            "\"ticks_per_s\"",
            "\"rtt_p50_us\"",
            "\"rtt_p99_us\"",
            "\"rtt_max_us\"",
            "\"overhead_p99_us\"",
            "\"coordinator_cpu_us_per_generation\"",
            "\"coordinator_cpu_us_per_chunk\"",
            "\"worker_utilisation\"",
            "\"generation\":{\"wall_us\"",
            "\"hash\"",
            "\"ratios\":{\"scaling\":null,\"compute_scaling\":null,\"ipc_efficiency\":null,\"zenoh_efficiency\":null}",
            "\"hashes_agree\":true}",
        ];
        let mut at = 0;
        for key in keys {
            let found = json[at..]
                .find(key)
                .unwrap_or_else(|| panic!("{key} in {json}"));
            at += found + key.len();
        }
        assert!(!json.contains("kind"), "{json}");
    }
}
