//! A generation flown while it is bred: one thread breeds every genome in
//! order while the pool's other threads fly each as soon as it is ready,
//! then the breeder flies what is left.
//!
//! Breeding draws from one sequential stream, so it cannot be split; bred
//! before the flying, a generation would leave every other thread idle
//! meanwhile. One thread breeds them all, rather than whichever takes the
//! next, so that the generator's state stays in one core's cache.

use crate::ga::Genome;
use lander_model::Evaluation;
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Mutex, PoisonError};

/// Spins on a genome not yet bred before yielding the CPU: breeding one
/// takes about half a microsecond, and the breeder has a CPU of its own
/// unless there are more threads than CPUs, when the yield lets it run.
const SPINS_BEFORE_YIELD: u32 = 256;

/// One generation's genomes, handed from the breeder to the fliers.
struct Handover {
    population: usize,
    slots: Vec<Mutex<Option<Genome>>>,
    /// Genomes bred so far: slots below it are filled.
    ready: AtomicUsize,
    /// The next genome to fly.
    claimed: AtomicUsize,
}

type Flown = Vec<(usize, Genome, Evaluation)>;

impl Handover {
    /// Breeds every genome `bred` yields into its slot, in order.
    fn breed(&self, bred: impl Iterator<Item = Genome>) {
        // However breeding ends, no flier is left waiting.
        let _all_ready = AllReady(&self.ready, self.population);
        for (i, genome) in bred.enumerate().take(self.population) {
            *self.slots[i].lock().unwrap_or_else(PoisonError::into_inner) = Some(genome);
            self.ready.store(i + 1, Ordering::Release);
        }
    }

    /// Flies the next genome not yet taken, as soon as it is bred, until
    /// none is left.
    fn fly(&self, fly: &(impl Fn(usize, &mut Genome) -> Evaluation + Sync)) -> Flown {
        let mut flown = Vec::new();
        loop {
            let i = self.claimed.fetch_add(1, Ordering::Relaxed);
            if i >= self.population {
                return flown;
            }
            wait_until(|| self.ready.load(Ordering::Acquire) > i);
            let taken = self.slots[i]
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .take();
            if let Some(mut genome) = taken {
                let evaluation = fly(i, &mut genome);
                flown.push((i, genome, evaluation));
            }
        }
    }
}

/// Flies the genomes `bred` yields, `fly(i, genome)` for the `i`th, on
/// the current rayon pool; returns them as flown, in order.
pub(super) fn fly_as_bred<I, F>(bred: I, population: usize, fly: F) -> Vec<(Genome, Evaluation)>
where
    I: Iterator<Item = Genome> + Send,
    F: Fn(usize, &mut Genome) -> Evaluation + Sync,
{
    let handover = Handover {
        population,
        slots: (0..population).map(|_| Mutex::new(None)).collect(),
        ready: AtomicUsize::new(0),
        claimed: AtomicUsize::new(0),
    };
    let fliers = rayon::current_num_threads().saturating_sub(1);
    // `join` runs its first closure on this thread, at once: the breeder
    // never waits for anyone, and a flier waits only for a breeder
    // already at work.
    let (mine, theirs) = rayon::join(
        || {
            handover.breed(bred);
            handover.fly(&fly)
        },
        || {
            (0..fliers)
                .into_par_iter()
                .with_max_len(1)
                .map(|_| handover.fly(&fly))
                .collect::<Vec<Flown>>()
        },
    );
    let mut flown: Flown = mine
        .into_iter()
        .chain(theirs.into_iter().flatten())
        .collect();
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
    fn more_threads_than_genomes_fly_each_once() {
        let one_by_one = on(1, genomes(3), 3);
        assert!(on(8, genomes(3), 3) == one_by_one);
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
