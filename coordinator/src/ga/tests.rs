//! The operators against their probabilities, and elitism.

use super::*;
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

/// Asserts `hits / trials` is within 5 standard errors of `p`.
fn assert_rate(hits: usize, trials: usize, p: f64, what: &str) {
    let observed = hits as f64 / trials as f64;
    let sigma = (p * (1.0 - p) / trials as f64).sqrt();
    assert!(
        (observed - p).abs() < 5.0 * sigma,
        "{what}: observed {observed:.5}, expected {p:.5} ± {:.5}",
        5.0 * sigma
    );
}

#[test]
fn new_genes_are_uniform_with_durations_from_one() {
    let p = GaParams::default();
    let mut r = rng(1);
    let genes: Vec<Gene> = (0..40_000).map(|_| random_gene(&p, &mut r)).collect();
    for a in Action::ALL {
        let hits = genes.iter().filter(|g| g.action == a).count();
        assert_rate(hits, genes.len(), 0.25, "action share");
    }
    assert!(genes.iter().all(|g| (1..=30).contains(&g.duration)));
    assert!(genes.iter().any(|g| g.duration == 1) && genes.iter().any(|g| g.duration == 30));
}

#[test]
fn mutation_rates_match_their_probabilities() {
    let p = GaParams {
        mutation_rate: 0.2,
        ..GaParams::default()
    };
    let original = vec![Gene::new(Action::Thrust, 15); 100_000];
    let mut mutated = original.clone();
    mutate(&p, &mut mutated, &mut rng(2));
    // A redrawn action is a different one 3 times in 4.
    let actions = mutated
        .iter()
        .filter(|g| g.action != Action::Thrust)
        .count();
    assert_rate(actions, mutated.len(), 0.2 * 0.75, "action mutation");
    // A nudge moves the duration unless |U − U| < 1/15: P = (14/15)².
    let durations = mutated.iter().filter(|g| g.duration != 15).count();
    assert_rate(
        durations,
        mutated.len(),
        0.1 * (14.0f64 / 15.0).powi(2),
        "duration mutation",
    );
    assert!(mutated.iter().all(|g| g.duration <= 29 && g.duration >= 1));
}

#[test]
fn duration_mutation_clamps_to_zero_and_the_bound() {
    let p = GaParams {
        mutation_rate: 1.0,
        ..GaParams::default()
    };
    let mut low = vec![Gene::new(Action::Drift, 0); 10_000];
    mutate(&p, &mut low, &mut rng(3));
    let mut high = vec![Gene::new(Action::Drift, 30); 10_000];
    mutate(&p, &mut high, &mut rng(4));
    assert!(low.iter().any(|g| g.duration == 0) && low.iter().all(|g| g.duration <= 14));
    assert!(high.iter().any(|g| g.duration == 30) && high.iter().all(|g| g.duration >= 16));
}

fn swapped_fraction(p: &GaParams, seed: u64) -> (usize, usize) {
    let a = vec![Gene::new(Action::RotateLeft, 1); p.genome_length];
    let b = vec![Gene::new(Action::Drift, 2); p.genome_length];
    let mut r = rng(seed);
    let mut swapped = 0;
    let trials = 4000;
    for _ in 0..trials {
        let (x, y) = crossover(p, &a, &b, &mut r);
        for (gx, gy) in x.iter().zip(&y) {
            assert_ne!(gx, gy, "children always hold one gene of each parent");
        }
        swapped += x.iter().filter(|g| g.action == Action::Drift).count();
    }
    (swapped, trials * p.genome_length)
}

#[test]
fn uniform_crossover_swaps_half_the_genes_at_the_crossover_rate() {
    let p = GaParams::default();
    let (swapped, genes) = swapped_fraction(&p, 5);
    // 0.7 of pairs cross, and then each gene swaps with probability 0.5.
    let observed = swapped as f64 / genes as f64;
    assert!((observed - 0.35).abs() < 0.02, "observed {observed}");
    let never = GaParams {
        crossover_rate: 0.0,
        ..p
    };
    assert_eq!(swapped_fraction(&never, 6).0, 0);
}

#[test]
fn buckland_crossover_swaps_nearly_every_gene() {
    let p = GaParams {
        crossover: Crossover::Buckland,
        crossover_rate: 1.0,
        ..GaParams::default()
    };
    let (swapped, genes) = swapped_fraction(&p, 7);
    // E[min(U·L, 1)] = 1 − 1/(2L) for L = 50.
    let observed = swapped as f64 / genes as f64;
    assert!((observed - 0.99).abs() < 0.005, "observed {observed}");
}

#[test]
fn the_wheel_picks_in_proportion_to_fitness() {
    let wheel = Wheel::new(&[1.0, 0.0, 2.0, -5.0, 3.0, 4.0]);
    let mut r = rng(8);
    let mut counts = [0usize; 6];
    let spins = 100_000;
    for _ in 0..spins {
        counts[wheel.spin(&mut r)] += 1;
    }
    assert_eq!(counts[1], 0, "zero fitness is never picked");
    assert_eq!(counts[3], 0, "negative fitness counts as zero");
    for (i, share) in [(0, 0.1), (2, 0.2), (4, 0.3), (5, 0.4)] {
        assert_rate(counts[i], spins, share, "wheel share");
    }
    let flat = Wheel::new(&[0.0, 0.0]);
    let picks: Vec<usize> = (0..100).map(|_| flat.spin(&mut r)).collect();
    assert!(picks.contains(&0) && picks.contains(&1));
}

#[test]
fn ranking_is_best_first_and_stable_on_ties() {
    assert_eq!(ranking(&[1.0, 5.0, 3.0, 5.0]), vec![1, 3, 2, 0]);
}

proptest! {
    /// Ties, -0.0 beside 0.0, infinities and NaN included.
    #[test]
    fn elites_are_the_head_of_the_ranking(
        fitness in proptest::collection::vec(
            prop_oneof![
                (0u8..4).prop_map(f64::from),
                Just(-0.0), Just(f64::INFINITY), Just(f64::NEG_INFINITY), Just(f64::NAN),
                -1e6f64..1e6,
            ],
            0..120,
        ),
        k in 0usize..130,
    ) {
        let head: Vec<usize> = ranking(&fitness).into_iter().take(k).collect();
        prop_assert_eq!(elites(&fitness, k), head);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn elites_pass_through_unchanged_and_the_population_refills(
        seed in any::<u64>(),
        fitness in proptest::collection::vec(0.0f64..1000.0, 4..40),
        elites in 0usize..5,
    ) {
        let p = GaParams { population: fitness.len(), elites, ..GaParams::default() };
        let mut r = rng(seed);
        let population = random_population(&p, &mut r);
        let next = next_generation(&p, &population, &fitness, &mut r);
        prop_assert_eq!(next.len(), p.population);
        for (k, &i) in ranking(&fitness).iter().take(elites).enumerate() {
            prop_assert_eq!(&next[k], &population[i]);
        }
        for g in &next {
            prop_assert_eq!(g.len(), p.genome_length);
        }
    }

    /// The generation bred one genome at a time is the one the loop that
    /// fills it pair by pair breeds, draws and all, odd populations (whose
    /// last pair has one child too many) and any number of elites included.
    #[test]
    fn offspring_breeds_the_generation_pair_by_pair(
        seed in any::<u64>(),
        fitness in proptest::collection::vec(-10.0f64..1000.0, 1..40),
        elites in 0usize..6,
    ) {
        let p = offspring_params(&fitness, elites);
        let population = random_population(&p, &mut rng(seed));
        let (mut r1, mut r2) = (rng(seed ^ 1), rng(seed ^ 1));
        prop_assert_eq!(
            next_generation(&p, &population, &fitness, &mut r1),
            pair_by_pair(&p, &population, &fitness, &mut r2)
        );
        prop_assert_eq!(r1.random::<u64>(), r2.random::<u64>(), "the draws after it");
    }

    /// Bred into the memory of old genomes, of any length and any number,
    /// the generation is the one bred into fresh memory, draws and all.
    #[test]
    fn offspring_bred_into_old_genomes_are_those_bred_fresh(
        seed in any::<u64>(),
        fitness in proptest::collection::vec(-10.0f64..1000.0, 1..40),
        elites in 0usize..6,
        old in proptest::collection::vec(0usize..20, 0..50),
    ) {
        let p = offspring_params(&fitness, elites);
        let population = random_population(&p, &mut rng(seed));
        let buffers: Vec<Genome> = old
            .iter()
            .map(|&n| vec![Gene::new(Action::Thrust, 3); n])
            .collect();
        let mut fresh = Offspring::new(&p, &population, &fitness, rng(seed ^ 1));
        let mut reused =
            Offspring::new(&p, &population, &fitness, rng(seed ^ 1)).reusing(buffers);
        prop_assert_eq!(fresh.by_ref().collect::<Vec<_>>(), reused.by_ref().collect::<Vec<_>>());
        prop_assert_eq!(fresh.rng.random::<u64>(), reused.rng.random::<u64>(), "the draws after it");
    }
}

/// The GA of the properties of [`Offspring`]: a population as large as
/// `fitness`, at most `elites` elites, genomes of 7 genes.
fn offspring_params(fitness: &[f64], elites: usize) -> GaParams {
    GaParams {
        population: fitness.len(),
        elites: elites.min(fitness.len()),
        genome_length: 7,
        ..GaParams::default()
    }
}

/// SPEC §3's generation as a loop that fills it pair by pair: the oracle
/// of [`Offspring`].
fn pair_by_pair(
    p: &GaParams,
    population: &[Genome],
    fitness: &[f64],
    rng: &mut impl Rng,
) -> Vec<Genome> {
    let mut next: Vec<Genome> = ranking(fitness)
        .into_iter()
        .take(p.elites)
        .map(|i| population[i].clone())
        .collect();
    let wheel = Wheel::new(fitness);
    while next.len() < p.population {
        let mum = &population[wheel.spin(rng)];
        let dad = &population[wheel.spin(rng)];
        let (mut a, mut b) = crossover(p, mum, dad, rng);
        mutate(p, &mut a, rng);
        mutate(p, &mut b, rng);
        next.push(a);
        if next.len() < p.population {
            next.push(b);
        }
    }
    next
}

#[test]
fn a_generation_of_more_than_the_most_genes_is_refused_with_its_memory() {
    let mut p = GaParams::default();
    (p.population, p.genome_length) = (10_000, 10_000);
    assert_eq!(p.check(), Ok(()), "exactly the most genes");
    (p.population, p.genome_length) = (1_000_000, 10_000);
    let e = p.check().unwrap_err();
    assert_eq!(e.field, "ga.population");
    assert_eq!(
        e.problem,
        "times ga.genome_length must be at most 100000000 genes a generation \
         (got 1000000 × 10000 = 10000000000); a run keeps about 5 bytes a gene, \
         so this one would need about 50000 MB"
    );
}
