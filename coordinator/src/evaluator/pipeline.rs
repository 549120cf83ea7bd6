//! A generation flown while it is bred: one thread breeds every genome in
//! order while the pool's other threads fly each as soon as it is ready,
//! then the breeder flies what is left.
//!
//! Breeding draws from one sequential stream, so it cannot be split; run
//! before the flying, it was a sixth of a one-trial run and idled every
//! other thread meanwhile. One thread breeds them all, rather than
//! whichever takes the next, so that the generator's state stays in one
//! core's cache.

use crate::ga::Genome;
use lander_model::Evaluation;
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Mutex, PoisonError};

/// Spins on a genome not yet bred before yielding the CPU: breeding one
/// takes about half a microsecond, and the breeder has a CPU of its own
/// unless there are more threads than CPUs, when the yield lets it run.
const SPINS_BEFORE_YIELD: u32 = 256;

/// Flies the genomes `bred` yields, `fly(i, genome)` for the `i`th, on
/// the current rayon pool; returns them as flown, in order.
pub(super) fn fly_as_bred<I, F>(bred: I, population: usize, fly: F) -> Vec<(Genome, Evaluation)>
where
    I: Iterator<Item = Genome> + Send,
    F: Fn(usize, &mut Genome) -> Evaluation + Sync,
{
    let slots: Vec<Mutex<Option<Genome>>> = (0..population).map(|_| Mutex::new(None)).collect();
    let ready = AtomicUsize::new(0);
    let claimed = AtomicUsize::new(0);
    let breeder = Mutex::new(Some(bred));
    let take =
        |slot: &Mutex<Option<Genome>>| slot.lock().unwrap_or_else(PoisonError::into_inner).take();
    // Role 0 runs first on this thread (rayon runs a split's left half in
    // place), so the breeder never waits for anyone, and a flier waits
    // only for a breeder already at work.
    let parts: Vec<Vec<(usize, Genome, Evaluation)>> = (0..rayon::current_num_threads())
        .into_par_iter()
        .with_max_len(1)
        .map(|role| {
            if role == 0 {
                // However breeding ends, no flier is left waiting.
                let _all_ready = AllReady(&ready, population);
                let bred = breeder
                    .lock()
                    .unwrap_or_else(PoisonError::into_inner)
                    .take();
                for (i, genome) in bred.into_iter().flatten().enumerate().take(population) {
                    *slots[i].lock().unwrap_or_else(PoisonError::into_inner) = Some(genome);
                    ready.store(i + 1, Ordering::Release);
                }
            }
            let mut flown = Vec::new();
            loop {
                let i = claimed.fetch_add(1, Ordering::Relaxed);
                if i >= population {
                    return flown;
                }
                wait_until(|| ready.load(Ordering::Acquire) > i);
                if let Some(mut genome) = take(&slots[i]) {
                    let evaluation = fly(i, &mut genome);
                    flown.push((i, genome, evaluation));
                }
            }
        })
        .collect();
    let mut flown: Vec<(usize, Genome, Evaluation)> = parts.into_iter().flatten().collect();
    flown.sort_unstable_by_key(|f| f.0);
    flown.into_iter().map(|(_, g, e)| (g, e)).collect()
}

/// Marks every slot ready when dropped.
struct AllReady<'a>(&'a AtomicUsize, usize);

impl Drop for AllReady<'_> {
    fn drop(&mut self) {
        self.0.store(self.1, Ordering::Release);
    }
}

fn wait_until(done: impl Fn() -> bool) {
    let mut spins = 0;
    while !done() {
        if spins < SPINS_BEFORE_YIELD {
            spins += 1;
            std::hint::spin_loop();
        } else {
            std::thread::yield_now();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::RunConfig;
    use crate::ga::random_population;
    use lander_model::stream::streams;
    use lander_model::{evaluate, Pass, StreamKey};

    fn genomes(n: usize) -> Vec<Genome> {
        let mut cfg = RunConfig::default();
        cfg.ga.population = n;
        random_population(
            &cfg.ga,
            &mut StreamKey::new(1, 2, 0, 3).rng(streams::OPERATORS),
        )
    }

    fn fly(i: usize, g: &mut Genome) -> Evaluation {
        let cfg = RunConfig::default();
        let key = StreamKey::new(1, 2, 0, 3);
        evaluate(&cfg.env(0), Pass::Guide, &cfg.guided, key, i as u64, g)
    }

    fn on(threads: usize, bred: Vec<Genome>, population: usize) -> Vec<(Genome, Evaluation)> {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| fly_as_bred(bred.into_iter(), population, fly))
    }

    #[test]
    fn each_genome_flies_once_as_one_thread_flies_it_on_any_thread_count() {
        let one_by_one: Vec<(Genome, Evaluation)> = genomes(40)
            .into_iter()
            .enumerate()
            .map(|(i, mut g)| {
                let e = fly(i, &mut g);
                (g, e)
            })
            .collect();
        for threads in [1, 2, 3, 8] {
            assert!(
                on(threads, genomes(40), 40) == one_by_one,
                "{threads} threads"
            );
        }
    }

    #[test]
    fn a_breeding_that_ends_early_leaves_no_flier_waiting() {
        assert_eq!(on(3, genomes(5), 10).len(), 5);
        assert_eq!(
            on(3, genomes(20), 10).len(),
            10,
            "no more than the population"
        );
    }
}
