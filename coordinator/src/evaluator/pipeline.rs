//! A generation flown while it is bred: one thread breeds every genome in
//! order while a crew of the pool's other threads flies each as soon as it
//! is ready, then the breeder flies what is left.
//!
//! Breeding draws from one sequential stream, so it cannot be split; bred
//! before the flying, a generation would leave every other thread idle
//! meanwhile. One thread breeds them all, rather than whichever takes the
//! next, so that the generator's state stays in one core's cache.
//!
//! The fliers claim genomes in runs that shrink as the generation runs out
//! ([`claim_size`]): a claim and its count of done genomes each write a
//! counter every flier writes, and a genome's flight takes 2–3 µs, so one
//! claim a genome cost each thread a few percent of its time.
//!
//! **The crew stays awake between generations.** A trial's generations
//! follow each other a few microseconds apart (the breeder records one and
//! sets up the next), and a rayon thread that finds no work sleeps after
//! about ten: waking it again cost 18–30 µs a generation on a virtual
//! machine, a sixth of a two-thread generation. So a helper that has flown
//! its share does not go back to rayon at once: it polls for the next
//! generation for a bounded, adaptive time ([`Spin`], as a worker process
//! does), and only then retires to rayon's pool, where its thread sleeps.
//! It spins only where every thread of the pool has a CPU of its own; the
//! next generation calls a retired helper back, and work of another kind
//! for the pool (a batch flown whole) dismisses it at once.

use crate::ga::Genome;
use lander_model::Evaluation;
use lander_protocol::spin::Spin;
use std::panic::AssertUnwindSafe;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

/// Spins on a genome not yet bred, or on a helper's last flight, before
/// yielding the CPU: breeding a genome takes about half a microsecond,
/// and the breeder has a CPU of its own unless there are more threads
/// than CPUs, when the yield lets it run.
const SPINS_BEFORE_YIELD: u32 = 256;

/// How long a wait yields before it sleeps. Flying a genome takes a few
/// microseconds; a wait this long means the thread waited for is not
/// running (the host took its CPU), and yielding would keep this CPU busy
/// for nothing until it runs again.
const YIELDS_FOR: Duration = Duration::from_micros(200);

/// Between looks, once a wait sleeps.
const NAP: Duration = Duration::from_micros(50);

/// The tracing target of each generation's phases, at `trace`: how long
/// the trial's own step took before it (`between_us`, from the last
/// generation's collection), breeding (`breed_us`, the other threads
/// flying meanwhile), flying the rest on every thread (`fly_us`), waiting
/// for the helpers' last flights (`collect_us`), and how many genomes the
/// breeder flew itself. `RUST_LOG=lander::pipeline=trace` shows them;
/// `scripts/pipeline-phases.py` sums them up.
pub const PHASES: &str = "lander::pipeline";

/// What flies genome `i` of a generation.
pub(super) type Fly = Arc<dyn Fn(usize, &mut Genome) -> Evaluation + Send + Sync>;

/// Where a genome of the generation under way stands.
enum Slot {
    Empty,
    Bred(Genome),
    Flown(Genome, Evaluation),
}

/// One generation's genomes, handed from the breeder to the fliers and
/// back.
struct Handover {
    slots: Vec<Mutex<Slot>>,
    flier: Fly,
    /// Genomes bred so far: slots below it are filled.
    ready: AtomicUsize,
    /// Genomes claimed so far; past the population once all are, as a
    /// claim is clipped to it.
    claimed: AtomicUsize,
    /// Genomes taken and done with, flown or (breeding having ended early)
    /// found empty.
    done: AtomicUsize,
    /// A flier panicked: the breeder, waiting for it, panics too.
    failed: AtomicBool,
    /// The threads that fly it, the breeder's among them.
    fliers: usize,
}

impl Handover {
    fn new(population: usize, fly: Fly, fliers: usize) -> Handover {
        Handover {
            slots: (0..population).map(|_| Mutex::new(Slot::Empty)).collect(),
            flier: fly,
            ready: AtomicUsize::new(0),
            claimed: AtomicUsize::new(0),
            done: AtomicUsize::new(0),
            failed: AtomicBool::new(false),
            fliers,
        }
    }

    fn population(&self) -> usize {
        self.slots.len()
    }

    fn slot(&self, i: usize) -> std::sync::MutexGuard<'_, Slot> {
        self.slots[i].lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Breeds every genome `bred` yields into its slot, in order.
    fn breed(&self, bred: impl Iterator<Item = Genome>) {
        // However breeding ends, no flier is left waiting.
        let _all_ready = AllReady(&self.ready, self.population());
        for (i, genome) in bred.enumerate().take(self.population()) {
            *self.slot(i) = Slot::Bred(genome);
            self.ready.store(i + 1, Ordering::Release);
        }
    }

    /// Flies the next genomes not yet taken, each as soon as it is bred,
    /// until none is left; returns how many this thread flew.
    fn fly(&self) -> usize {
        let mut flew = 0;
        let population = self.population();
        loop {
            let left = population.saturating_sub(self.claimed.load(Ordering::Relaxed));
            if left == 0 {
                return flew;
            }
            let take = claim_size(left, self.fliers);
            let first = self.claimed.fetch_add(take, Ordering::Relaxed);
            let claim = first..(first + take).min(population);
            if claim.is_empty() {
                return flew;
            }
            let _done = Done(self, claim.len());
            for i in claim {
                flew += 1;
                wait_until(|| self.ready.load(Ordering::Acquire) > i);
                let taken = std::mem::replace(&mut *self.slot(i), Slot::Empty);
                if let Slot::Bred(mut genome) = taken {
                    let evaluation = (self.flier)(i, &mut genome);
                    *self.slot(i) = Slot::Flown(genome, evaluation);
                }
            }
        }
    }

    /// Waits until every genome taken has been flown, then returns them in
    /// order.
    fn collect(&self) -> Vec<(Genome, Evaluation)> {
        wait_until(|| self.done.load(Ordering::Acquire) >= self.population());
        assert!(
            !self.failed.load(Ordering::Acquire),
            "an evaluation thread panicked flying a genome"
        );
        (0..self.population())
            .filter_map(
                |i| match std::mem::replace(&mut *self.slot(i), Slot::Empty) {
                    Slot::Flown(genome, evaluation) => Some((genome, evaluation)),
                    _ => None,
                },
            )
            .collect()
    }
}

/// How many genomes a flier claims at once, of `left` not yet claimed by
/// `fliers` threads: an even share's half, at least one (guided
/// scheduling, as OpenMP's `schedule(guided)`). The claim counter and the
/// done counter cross between the cores a few times a generation rather
/// than once a genome, and the last claims are single genomes, so that
/// the threads still finish together.
fn claim_size(left: usize, fliers: usize) -> usize {
    (left / (2 * fliers.max(1))).max(1)
}

/// Counts the genomes of a claim as done when dropped, and a panic flying
/// one as a failure, so that the breeder never waits for them in vain.
struct Done<'a>(&'a Handover, usize);

impl Drop for Done<'_> {
    fn drop(&mut self) {
        if std::thread::panicking() {
            self.0.failed.store(true, Ordering::Release);
        }
        self.0.done.fetch_add(self.1, Ordering::Release);
    }
}

/// The threads that fly a generation beside its breeder: the pool's
/// threads but one, called to each generation and kept awake between
/// generations for a while (see the module's docs).
pub(super) struct Crew {
    /// Helpers wanted: every thread of the pool but the breeder's.
    hands: usize,
    /// The longest a helper polls for the next generation; zero where the
    /// threads do not each have a CPU of their own.
    spin: Duration,
    /// The generation under way, and its number.
    board: Mutex<(u64, Option<Arc<Handover>>)>,
    /// The number of the generation on the board, for helpers polling
    /// without the lock.
    posted: AtomicU64,
    /// Helpers called and not yet retired.
    on_duty: AtomicUsize,
    /// How often the helpers were dismissed (`dismiss`).
    dismissed: AtomicU64,
    /// The spins of retired helpers, whose budgets the next ones keep.
    spins: Mutex<Vec<Spin>>,
    /// When the last generation was collected, where [`PHASES`] is traced.
    collected: Mutex<Option<Instant>>,
}

impl Crew {
    /// A crew for a pool of `threads` threads, whose helpers spin for at
    /// most `spin` between generations.
    pub(super) fn new(threads: usize, spin: Duration) -> Crew {
        Crew {
            hands: threads.saturating_sub(1),
            spin,
            board: Mutex::new((0, None)),
            posted: AtomicU64::new(0),
            on_duty: AtomicUsize::new(0),
            dismissed: AtomicU64::new(0),
            spins: Mutex::new(Vec::new()),
            collected: Mutex::new(None),
        }
    }

    /// Flies the genomes `bred` yields, `fly(i, genome)` for the `i`th,
    /// on `pool`, breeding them on this thread; returns them as flown, in
    /// order.
    pub(super) fn fly_as_bred(
        self: &Arc<Self>,
        pool: &rayon::ThreadPool,
        bred: impl Iterator<Item = Genome>,
        population: usize,
        fly: Fly,
    ) -> Vec<(Genome, Evaluation)> {
        let traced = tracing::enabled!(target: PHASES, tracing::Level::TRACE);
        let posted = traced.then(Instant::now);
        let handover = Arc::new(Handover::new(population, fly, self.hands + 1));
        self.post(Arc::clone(&handover));
        self.call_helpers(pool);
        handover.breed(bred);
        let bred_at = traced.then(Instant::now);
        let flown_here = handover.fly();
        let flown_at = traced.then(Instant::now);
        // The handover stays on the board, empty, until the next replaces
        // it: taking it off would call the helpers for nothing.
        let flown = handover.collect();
        if let (Some(posted), Some(bred_at), Some(flown_at)) = (posted, bred_at, flown_at) {
            self.trace_phases(posted, bred_at, flown_at, flown_here, flown.len());
        }
        flown
    }

    /// Says how a generation's time went (see [`PHASES`]).
    fn trace_phases(
        &self,
        posted: Instant,
        bred: Instant,
        flown: Instant,
        flown_here: usize,
        population: usize,
    ) {
        let now = Instant::now();
        let mut collected = self
            .collected
            .lock()
            .unwrap_or_else(PoisonError::into_inner);
        let micros = |d: Duration| d.as_secs_f64() * 1e6;
        tracing::trace!(
            target: PHASES,
            between_us = collected.map(|c| micros(posted.saturating_duration_since(c))),
            breed_us = micros(bred - posted),
            fly_us = micros(flown - bred),
            collect_us = micros(now - flown),
            breeder_flew = flown_here,
            population,
            "generation flown as bred"
        );
        // After the line is written, so that writing it is not counted as
        // the trial's step.
        *collected = Some(Instant::now());
    }

    /// Puts a generation on the board under a new number.
    fn post(&self, handover: Arc<Handover>) {
        let mut board = self.board.lock().unwrap_or_else(PoisonError::into_inner);
        board.0 += 1;
        board.1 = Some(handover);
        // SeqCst, with `on_duty` in `call_helpers` and `retire`: either the
        // caller sees a helper retired and calls another, or the helper
        // sees this generation and stays.
        self.posted.store(board.0, Ordering::SeqCst);
    }

    /// Calls helpers until `hands` are on duty.
    fn call_helpers(self: &Arc<Self>, pool: &rayon::ThreadPool) {
        while self.take_duty() {
            let crew = Arc::clone(self);
            let spin = self
                .spins
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .pop();
            // Dismissals from now on send it back, even one before it starts.
            let dismissals = self.dismissed.load(Ordering::SeqCst);
            pool.spawn(move || crew.serve(spin, dismissals));
        }
    }

    /// Counts one more helper on duty, if fewer than `hands` are.
    fn take_duty(&self) -> bool {
        self.on_duty
            .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |n| {
                (n < self.hands).then_some(n + 1)
            })
            .is_ok()
    }

    /// A helper's life: fly every generation posted, polling for the next
    /// between them, until one does not come within the spin.
    fn serve(&self, spin: Option<Spin>, mut dismissals: u64) {
        let mut spin = spin.unwrap_or_else(|| Spin::new(self.spin));
        spin.woke();
        let mut seen = 0;
        loop {
            let (number, handover) = {
                let board = self.board.lock().unwrap_or_else(PoisonError::into_inner);
                (board.0, board.1.clone())
            };
            if number != seen {
                seen = number;
                if let Some(handover) = handover {
                    // A panic flying a genome is the breeder's to raise
                    // (`Done` marks it); on a pool's spawned job it would
                    // abort the process. The helper serves on, so that the
                    // crew stays whole.
                    let _ = std::panic::catch_unwind(AssertUnwindSafe(|| handover.fly()));
                }
                continue;
            }
            // No other work of the pool is taken up while polling: it
            // could be the breeder's own, which would then find its helper
            // on duty and fly alone. Work of another kind dismisses the
            // helpers instead (`dismiss`).
            let next = spin.poll(|| {
                self.posted.load(Ordering::SeqCst) != seen
                    || self.dismissed.load(Ordering::SeqCst) != dismissals
            });
            let now = self.dismissed.load(Ordering::SeqCst);
            let dismissed = now != dismissals;
            dismissals = now;
            if (!next || dismissed) && !self.retire(seen) {
                self.spins
                    .lock()
                    .unwrap_or_else(PoisonError::into_inner)
                    .push(spin);
                return;
            }
        }
    }

    /// Sends the helpers polling for a generation back to the pool, where
    /// their threads take up other work at once: for a batch flown whole
    /// rather than as it is bred.
    pub(super) fn dismiss(&self) {
        self.dismissed.fetch_add(1, Ordering::SeqCst);
    }

    /// Takes a helper off duty; says whether it must stay after all,
    /// because a generation after `seen`, the last it looked at, was
    /// posted and no other helper was called in its place.
    fn retire(&self, seen: u64) -> bool {
        self.on_duty.fetch_sub(1, Ordering::SeqCst);
        self.posted.load(Ordering::SeqCst) != seen && self.take_duty()
    }
}

/// Marks every slot ready when dropped.
struct AllReady<'a>(&'a AtomicUsize, usize);

impl Drop for AllReady<'_> {
    fn drop(&mut self) {
        self.0.store(self.1, Ordering::Release);
    }
}

/// Waits until `done`: spins, then yields, then sleeps, each for a bounded
/// while.
fn wait_until(done: impl Fn() -> bool) {
    for _ in 0..SPINS_BEFORE_YIELD {
        if done() {
            return;
        }
        std::hint::spin_loop();
    }
    let yielding = Instant::now();
    while !done() {
        if yielding.elapsed() < YIELDS_FOR {
            std::thread::yield_now();
        } else {
            std::thread::sleep(NAP);
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
    use lander_protocol::host::thread_cpu_time;

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

    fn pool(threads: usize) -> rayon::ThreadPool {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
    }

    fn on(threads: usize, bred: Vec<Genome>, population: usize) -> Vec<(Genome, Evaluation)> {
        let pool = pool(threads);
        let crew = Arc::new(Crew::new(threads, Duration::from_micros(200)));
        pool.install(|| crew.fly_as_bred(&pool, bred.into_iter(), population, Arc::new(fly)))
    }

    /// Waits up to a second for `done`.
    fn eventually(done: impl Fn() -> bool) -> bool {
        let until = std::time::Instant::now() + Duration::from_secs(1);
        while std::time::Instant::now() < until {
            if done() {
                return true;
            }
            std::thread::sleep(Duration::from_millis(1));
        }
        done()
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
    fn claims_shrink_as_genomes_run_out_and_end_one_at_a_time() {
        // 100 genomes, 2 fliers: a quarter of those left each time.
        let mut left = 100;
        let mut claims = Vec::new();
        while left > 0 {
            let take = claim_size(left, 2).min(left);
            claims.push(take);
            left -= take;
        }
        assert_eq!(
            claims,
            [25, 18, 14, 10, 8, 6, 4, 3, 3, 2, 1, 1, 1, 1, 1, 1, 1]
        );
        // One flier, or more fliers than genomes: still at least one.
        assert_eq!(claim_size(10, 1), 5);
        assert_eq!(claim_size(3, 8), 1);
        assert_eq!(claim_size(1, 0), 1);
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

    #[test]
    fn one_crew_flies_generation_after_generation_then_retires() {
        let alone = on(1, genomes(30), 30);
        for spin in [Duration::ZERO, Duration::from_millis(5)] {
            let pool = pool(2);
            let crew = Arc::new(Crew::new(2, spin));
            for generation in 0..20 {
                let flown = pool.install(|| {
                    crew.fly_as_bred(&pool, genomes(30).into_iter(), 30, Arc::new(fly))
                });
                assert!(flown == alone, "generation {generation}, spin {spin:?}");
                assert!(
                    crew.on_duty.load(Ordering::SeqCst) <= 1,
                    "one helper at most"
                );
            }
            // A pause longer than the spin: the helper goes back to the
            // pool, and its thread to sleep.
            assert!(
                eventually(|| crew.on_duty.load(Ordering::SeqCst) == 0),
                "a helper still on duty after the spin, spin {spin:?}"
            );
        }
    }

    #[test]
    fn a_panic_flying_a_genome_reaches_the_breeder() {
        let pool = pool(2);
        let crew = Arc::new(Crew::new(2, Duration::from_millis(200)));
        let panicking: Fly = Arc::new(|i, g: &mut Genome| {
            assert!(i != 17, "genome 17 cannot fly");
            fly(i, g)
        });
        let result = std::panic::catch_unwind(AssertUnwindSafe(|| {
            pool.install(|| crew.fly_as_bred(&pool, genomes(30).into_iter(), 30, panicking))
        }));
        assert!(result.is_err(), "the panic was lost");
        assert!(
            crew.on_duty.load(Ordering::SeqCst) <= 1,
            "one helper at most"
        );
        // The crew is whole for the next generations: both threads fly.
        let (slow, fliers) = slow_and_watched();
        for generation in 0..2 {
            fliers.lock().unwrap().clear();
            let flown = pool.install(|| {
                crew.fly_as_bred(&pool, genomes(20).into_iter(), 20, Arc::clone(&slow))
            });
            assert!(flown == on(1, genomes(20), 20), "generation {generation}");
            assert_eq!(fliers.lock().unwrap().len(), 2, "generation {generation}");
            assert!(
                crew.on_duty.load(Ordering::SeqCst) <= 1,
                "one helper at most"
            );
        }
        crew.dismiss();
    }

    /// A flier slow enough that a thread free to fly takes some genomes,
    /// and the threads that flew them.
    fn slow_and_watched() -> (
        Fly,
        Arc<Mutex<std::collections::HashSet<std::thread::ThreadId>>>,
    ) {
        let fliers = Arc::new(Mutex::new(std::collections::HashSet::new()));
        let seen = Arc::clone(&fliers);
        let slow: Fly = Arc::new(move |i, g: &mut Genome| {
            seen.lock().unwrap().insert(std::thread::current().id());
            // Until a second thread flies too, within reason: on a loaded
            // host a helper may wake after a breeder alone would have
            // flown the whole generation, and the tests ask whether it
            // takes part at all, not how soon.
            let until = Instant::now() + Duration::from_secs(10);
            while seen.lock().unwrap().len() < 2 && Instant::now() < until {
                std::thread::sleep(Duration::from_millis(1));
            }
            std::thread::sleep(Duration::from_millis(1));
            fly(i, g)
        });
        (slow, fliers)
    }

    #[test]
    fn a_generation_handed_in_from_outside_the_pool_is_flown_by_every_thread() {
        let pool = pool(2);
        let crew = Arc::new(Crew::new(2, Duration::from_millis(200)));
        let (slow, fliers) = slow_and_watched();
        for generation in 0..4 {
            fliers.lock().unwrap().clear();
            // From this thread, outside the pool, as `lander bench` handed
            // generations in: a helper still polling must not take the
            // breeder's work up and leave itself to fly nothing.
            pool.install(|| {
                crew.fly_as_bred(&pool, genomes(20).into_iter(), 20, Arc::clone(&slow))
            });
            assert_eq!(fliers.lock().unwrap().len(), 2, "generation {generation}");
        }
        crew.dismiss();
    }

    #[test]
    fn dismissed_helpers_go_back_to_the_pool_before_their_spin_ends() {
        let pool = pool(2);
        // A spin far longer than the test waits.
        let crew = Arc::new(Crew::new(2, Duration::from_secs(5)));
        pool.install(|| crew.fly_as_bred(&pool, genomes(20).into_iter(), 20, Arc::new(fly)));
        assert_eq!(crew.on_duty.load(Ordering::SeqCst), 1, "the helper polls");
        crew.dismiss();
        assert!(
            eventually(|| crew.on_duty.load(Ordering::SeqCst) == 0),
            "a dismissed helper still on duty"
        );
    }

    #[test]
    fn a_long_wait_sleeps_and_ends_when_its_condition_holds() {
        // Past the spin and the yields, into the naps.
        let long = YIELDS_FOR * 100;
        let set = Arc::new(AtomicBool::new(false));
        // Before the setter starts, which may run at once.
        let (started, cpu) = (Instant::now(), thread_cpu_time());
        let setter = {
            let set = set.clone();
            std::thread::spawn(move || {
                std::thread::sleep(long);
                set.store(true, Ordering::Release);
            })
        };
        wait_until(|| set.load(Ordering::Acquire));
        assert!(set.load(Ordering::Acquire));
        assert!(started.elapsed() >= long);
        // A wait that yielded throughout would have kept its CPU busy.
        let busy = thread_cpu_time() - cpu;
        assert!(busy < long / 2, "the wait kept its CPU busy {busy:?}");
        setter.join().unwrap();
    }

    /// The fields of each line of the phase trace.
    #[derive(Clone, Default)]
    struct Traced(Arc<Mutex<Vec<std::collections::HashMap<&'static str, f64>>>>);

    impl<S: tracing::Subscriber> tracing_subscriber::Layer<S> for Traced {
        fn on_event(
            &self,
            event: &tracing::Event<'_>,
            _: tracing_subscriber::layer::Context<'_, S>,
        ) {
            if event.metadata().target() == PHASES {
                let mut fields = Fields::default();
                event.record(&mut fields);
                self.0.lock().unwrap().push(fields.0);
            }
        }
    }

    #[derive(Default)]
    struct Fields(std::collections::HashMap<&'static str, f64>);

    impl tracing::field::Visit for Fields {
        fn record_f64(&mut self, field: &tracing::field::Field, value: f64) {
            self.0.insert(field.name(), value);
        }
        fn record_u64(&mut self, field: &tracing::field::Field, value: u64) {
            self.0.insert(field.name(), value as f64);
        }
        fn record_debug(&mut self, _: &tracing::field::Field, _: &dyn std::fmt::Debug) {}
    }

    #[test]
    fn the_phase_trace_says_how_each_generation_went() {
        use tracing_subscriber::layer::SubscriberExt;
        let traced = Traced::default();
        let subscriber = tracing_subscriber::registry().with(traced.clone());
        let pool = pool(2);
        let crew = Arc::new(Crew::new(2, Duration::from_millis(200)));
        let (slow, fliers) = slow_and_watched();
        // This thread breeds, so that the trace reaches its subscriber.
        tracing::subscriber::with_default(subscriber, || {
            for _ in 0..3 {
                fliers.lock().unwrap().clear();
                crew.fly_as_bred(&pool, genomes(30).into_iter(), 30, Arc::clone(&slow));
            }
        });
        crew.dismiss();
        let lines = traced.0.lock().unwrap().clone();
        assert_eq!(lines.len(), 3, "a line a generation");
        assert!(
            !lines[0].contains_key("between_us"),
            "nothing before the first"
        );
        for (generation, line) in lines.iter().enumerate() {
            let field = |name: &str| line.get(name).copied().unwrap_or(f64::NAN);
            assert_eq!(field("population"), 30.0, "generation {generation}");
            let flew = field("breeder_flew");
            // Both threads fly (the slow flier waits for the second), and
            // each flight takes at least a millisecond: the breeder's own
            // are all in `fly_us`.
            assert!(flew > 0.0 && flew < 30.0, "the breeder flew {flew}");
            assert!(field("fly_us") >= 1000.0 * flew, "generation {generation}");
            for phase in ["breed_us", "collect_us"] {
                assert!(field(phase) >= 0.0, "{phase} in generation {generation}");
            }
            if generation > 0 {
                assert!(field("between_us") >= 0.0, "generation {generation}");
            }
        }
    }
}
