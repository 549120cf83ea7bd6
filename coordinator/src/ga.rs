//! The general GA's operators (SPEC §3): random genomes, roulette-wheel
//! selection, elitism, crossover and mutation.
//!
//! Every function takes its generator from the caller, who keys it by
//! `(seed, trial, restart, generation)`, so a generation is rebuilt the same
//! way wherever and however often it is run.

use lander_model::check::{check, non_negative, probability, ParamError};
use lander_model::{Action, Gene};
use rand::Rng;
use serde::{Deserialize, Serialize};

pub type Genome = Vec<Gene>;

/// How two parents exchange genes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Crossover {
    /// Each gene swaps with probability 0.5, as the paper describes.
    Uniform,
    /// The original code's quirk: `swapRate = U·L`, swap when `U < swapRate`,
    /// so nearly every gene swaps.
    Buckland,
}

/// The GA's parameters, the `[ga]` section of a run configuration.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GaParams {
    pub population: usize,
    pub genome_length: usize,
    /// Durations lie in `0..=max_duration`; new genes draw from `1..=max_duration`.
    pub max_duration: u8,
    pub crossover: Crossover,
    pub crossover_rate: f64,
    pub mutation_rate: f64,
    /// A duration mutation adds `trunc((U − U) · duration_mutation_span)`.
    pub duration_mutation_span: f64,
    pub elites: usize,
    /// Generations per attempt; after this many without a safe landing the
    /// trial restarts.
    pub max_generations: u64,
    /// Restarts allowed before a trial ends unlanded; 0 is a single attempt.
    pub max_restarts: u64,
}

impl Default for GaParams {
    fn default() -> Self {
        GaParams {
            population: 100,
            genome_length: 50,
            max_duration: 30,
            crossover: Crossover::Uniform,
            crossover_rate: 0.7,
            mutation_rate: 0.05,
            duration_mutation_span: 15.0,
            elites: 4,
            max_generations: 500,
            max_restarts: 9,
        }
    }
}

/// The most genes one generation may hold (`ga.population ×
/// ga.genome_length`): each limit alone would still let a generation need
/// tens of gigabytes, and a run that asks for more memory than the host
/// has is killed without a word.
pub const MAX_GENES: usize = 100_000_000;

/// About what a trial keeps per gene of its generation: the parents and
/// their offspring, two bytes each (`/usr/bin/time -f %M` of a run of
/// 20,000 genomes of 1,000 genes: 95 MB).
pub const BYTES_PER_GENE: usize = 5;

impl GaParams {
    /// The genes of one generation: `population × genome_length`.
    pub fn genes(&self) -> usize {
        self.population * self.genome_length
    }

    /// Checks every field, naming the first out of range.
    pub fn check(&self) -> Result<(), ParamError> {
        check(
            "ga.population",
            (1..=1_000_000).contains(&self.population),
            "must be 1 to 1,000,000",
        )?;
        check(
            "ga.genome_length",
            (1..=10_000).contains(&self.genome_length),
            "must be 1 to 10,000",
        )?;
        let genes = self.genes();
        check(
            "ga.population",
            genes <= MAX_GENES,
            format_args!(
                "times ga.genome_length must be at most {MAX_GENES} genes a generation \
                 (got {} × {} = {genes}); a run keeps about {BYTES_PER_GENE} bytes a \
                 gene, so this one would need about {} MB",
                self.population,
                self.genome_length,
                (genes * BYTES_PER_GENE).div_ceil(1_000_000)
            ),
        )?;
        check(
            "ga.max_duration",
            self.max_duration >= 1,
            "must be at least 1",
        )?;
        probability("ga.crossover_rate", self.crossover_rate)?;
        probability("ga.mutation_rate", self.mutation_rate)?;
        non_negative("ga.duration_mutation_span", self.duration_mutation_span)?;
        // Elites are copied unchanged: a population of elites alone would
        // fly the same genomes every generation, breeding nothing.
        check(
            "ga.elites",
            self.elites < self.population,
            format_args!(
                "must be fewer than ga.population (--population), or no child is bred: {} elites in a population of {}",
                self.elites, self.population
            ),
        )?;
        check(
            "ga.max_generations",
            self.max_generations >= 1,
            "must be at least 1",
        )?;
        Ok(())
    }
}

pub fn random_gene(p: &GaParams, rng: &mut impl Rng) -> Gene {
    Gene::new(
        Action::ALL[rng.random_range(0..4)],
        rng.random_range(1..=p.max_duration),
    )
}

pub fn random_population(p: &GaParams, rng: &mut impl Rng) -> Vec<Genome> {
    (0..p.population)
        .map(|_| (0..p.genome_length).map(|_| random_gene(p, rng)).collect())
        .collect()
}

/// Indices of `fitness` from best to worst; ties keep population order.
pub fn ranking(fitness: &[f64]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..fitness.len()).collect();
    order.sort_by(|&a, &b| fitness[b].total_cmp(&fitness[a]));
    order
}

/// The first `k` of [`ranking`]: the `k` best, best first, ties in
/// population order. Chosen without ordering the rest, which a generation
/// waits for between flying one generation and breeding the next.
pub fn elites(fitness: &[f64], k: usize) -> Vec<usize> {
    // Ties broken by index make the order total, so the `k` chosen and
    // their order are those of the stable sort.
    let better = |&a: &usize, &b: &usize| fitness[b].total_cmp(&fitness[a]).then(a.cmp(&b));
    let mut order: Vec<usize> = (0..fitness.len()).collect();
    let k = k.min(order.len());
    if k < order.len() {
        order.select_nth_unstable_by(k, better);
        order.truncate(k);
    }
    order.sort_unstable_by(better);
    order
}

/// A roulette wheel over fitness: index `i` comes up with probability
/// `fitness[i] / Σ fitness`. Negative fitness counts as zero; a wheel with
/// nothing on it picks uniformly.
pub struct Wheel {
    cumulative: Vec<f64>,
}

impl Wheel {
    pub fn new(fitness: &[f64]) -> Wheel {
        let cumulative = fitness
            .iter()
            .scan(0.0, |sum, &f| {
                *sum += f.max(0.0);
                Some(*sum)
            })
            .collect();
        Wheel { cumulative }
    }

    pub fn spin(&self, rng: &mut impl Rng) -> usize {
        let n = self.cumulative.len();
        let total = self.cumulative.last().copied().unwrap_or(0.0);
        if total.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return rng.random_range(0..n);
        }
        let slice = rng.random::<f64>() * total;
        self.cumulative.partition_point(|&c| c <= slice).min(n - 1)
    }
}

/// Crosses two parents into two children.
pub fn crossover(p: &GaParams, a: &[Gene], b: &[Gene], rng: &mut impl Rng) -> (Genome, Genome) {
    let (mut x, mut y) = (Genome::new(), Genome::new());
    crossover_into(p, a, b, rng, (&mut x, &mut y));
    (x, y)
}

/// [`crossover`], writing the two children over `into`, whose memory it
/// reuses.
pub fn crossover_into(
    p: &GaParams,
    a: &[Gene],
    b: &[Gene],
    rng: &mut impl Rng,
    (x, y): (&mut Genome, &mut Genome),
) {
    x.clear();
    x.extend_from_slice(a);
    y.clear();
    y.extend_from_slice(b);
    if rng.random::<f64>() >= p.crossover_rate {
        return;
    }
    let swap_rate = match p.crossover {
        Crossover::Uniform => 0.5,
        Crossover::Buckland => rng.random::<f64>() * p.genome_length as f64,
    };
    for (gx, gy) in x.iter_mut().zip(y.iter_mut()) {
        // Under uniform crossover half the genes swap, at random: a branch
        // on it would be mispredicted every other gene.
        let swap = rng.random::<f64>() < swap_rate;
        let (a, b) = (*gx, *gy);
        *gx = std::hint::select_unpredictable(swap, b, a);
        *gy = std::hint::select_unpredictable(swap, a, b);
    }
}

/// Mutates each gene independently: a new action with probability `m`, a
/// duration nudge with probability `m/2`.
pub fn mutate(p: &GaParams, genome: &mut [Gene], rng: &mut impl Rng) {
    let m = p.mutation_rate;
    for gene in genome {
        if rng.random::<f64>() < m {
            gene.action = Action::ALL[rng.random_range(0..4)];
        }
        if rng.random::<f64>() < m / 2.0 {
            let nudge =
                ((rng.random::<f64>() - rng.random::<f64>()) * p.duration_mutation_span).trunc();
            let d = (f64::from(gene.duration) + nudge).clamp(0.0, f64::from(p.max_duration));
            gene.duration = d as u8;
        }
    }
}

/// Builds the next generation: the elites unchanged, then pairs of children
/// of roulette-picked parents until the population is full.
pub fn next_generation(
    p: &GaParams,
    population: &[Genome],
    fitness: &[f64],
    rng: &mut impl Rng,
) -> Vec<Genome> {
    Offspring::new(p, population, fitness, rng).collect()
}

/// The next generation bred one genome at a time, in order: the elites
/// unchanged, then the children of roulette-picked pairs. Each genome is
/// ready as soon as it is yielded, so that it can fly while the rest are
/// bred; the draws are those of [`next_generation`], in its order.
pub struct Offspring<'a, R> {
    p: &'a GaParams,
    parents: &'a [Genome],
    elites: std::vec::IntoIter<usize>,
    wheel: Wheel,
    rng: R,
    /// The second child of the last pair, still to be yielded.
    spare: Option<Genome>,
    /// Children still to be yielded after the elites.
    left: usize,
    /// Genomes no longer needed, whose memory the offspring reuse.
    buffers: Vec<Genome>,
}

impl<'a, R: Rng> Offspring<'a, R> {
    /// The generation after `parents`, scored `fitness`, drawing from `rng`.
    pub fn new(p: &'a GaParams, parents: &'a [Genome], fitness: &[f64], rng: R) -> Self {
        let elites = elites(fitness, p.elites);
        Offspring {
            p,
            parents,
            left: p.population - elites.len(),
            elites: elites.into_iter(),
            wheel: Wheel::new(fitness),
            rng,
            spare: None,
            buffers: Vec::new(),
        }
    }

    /// Breeds into the memory of `buffers`, genomes no longer needed (the
    /// generation before the parents), rather than allocating a genome
    /// for each: the same offspring, without a hundred allocations and
    /// frees a generation.
    pub fn reusing(mut self, buffers: Vec<Genome>) -> Self {
        self.buffers = buffers;
        self
    }

    fn buffer(&mut self) -> Genome {
        self.buffers.pop().unwrap_or_default()
    }

    /// How many genomes the generation holds.
    pub fn population(&self) -> usize {
        self.p.population
    }
}

impl<R: Rng> Iterator for Offspring<'_, R> {
    type Item = Genome;

    fn next(&mut self) -> Option<Genome> {
        if let Some(i) = self.elites.next() {
            let mut elite = self.buffer();
            elite.clone_from(&self.parents[i]);
            return Some(elite);
        }
        if self.left == 0 {
            return None;
        }
        self.left -= 1;
        if let Some(b) = self.spare.take() {
            return Some(b);
        }
        let (mut a, mut b) = (self.buffer(), self.buffer());
        let mum = &self.parents[self.wheel.spin(&mut self.rng)];
        let dad = &self.parents[self.wheel.spin(&mut self.rng)];
        crossover_into(self.p, mum, dad, &mut self.rng, (&mut a, &mut b));
        mutate(self.p, &mut a, &mut self.rng);
        // An odd last pair's second child is bred, and its draws made,
        // though it has no place.
        mutate(self.p, &mut b, &mut self.rng);
        if self.left > 0 {
            self.spare = Some(b);
        }
        Some(a)
    }
}

#[cfg(test)]
mod tests;
