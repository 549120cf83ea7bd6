//! A bounded, adaptive spin before sleeping, as OpenMP's blocktime: a
//! worker process, or an in-process evaluation thread, that has just
//! finished some work polls for the next for a while before it blocks (and
//! the coordinator, flying the share of the worker on its CPU, for the
//! answers it waits for), because on a virtual machine waking a process
//! whose CPU has gone idle costs 8–17 µs and more (docs/performance.md).
//!
//! Spinning is only worth it, and only allowed, where the spinner has a
//! CPU of its own: the caller decides that and passes a zero budget
//! otherwise. The budget adapts: a spin that finds nothing halves it, so
//! a process whose work has stopped coming spins less and less and then
//! not at all; a sleep that ends sooner than the full budget would have
//! lasted doubles it again. A process spins only right after work, so one
//! that sleeps through a long pause uses no CPU at all.

use std::time::{Duration, Instant};

/// The longest spin either side accepts, in microseconds: beyond a few
/// milliseconds a sleep costs nothing next to the wait.
pub const MAX_SPIN_US: u64 = 10_000;

/// Below this share of the full budget, a spin is not worth starting.
const FLOOR_SHARE: u32 = 16;

#[derive(Clone, Debug)]
pub struct Spin {
    max: Duration,
    budget: Duration,
    /// When the last spin gave up and the caller went to sleep.
    slept_at: Option<Instant>,
}

impl Spin {
    /// Spins of at most `max`; `Duration::ZERO` never spins.
    pub fn new(max: Duration) -> Spin {
        Spin {
            max,
            budget: max,
            slept_at: None,
        }
    }

    /// The longest the next spin may last.
    pub fn budget(&self) -> Duration {
        self.budget
    }

    /// Polls `ready` until it says true or the budget is spent; returns
    /// what it last said. A miss halves the budget, to nothing below
    /// `1/16` of the full one.
    pub fn poll(&mut self, mut ready: impl FnMut() -> bool) -> bool {
        if self.budget.is_zero() {
            self.slept_at = Some(Instant::now());
            return ready();
        }
        let end = Instant::now() + self.budget;
        loop {
            if ready() {
                return true;
            }
            if Instant::now() >= end {
                self.missed();
                self.slept_at = Some(Instant::now());
                return false;
            }
            std::hint::spin_loop();
        }
    }

    /// The caller woke from the sleep that followed a miss: had the work
    /// come within the full budget, spinning would have caught it, so the
    /// budget grows back.
    pub fn woke(&mut self) {
        if let Some(slept) = self.slept_at.take() {
            if slept.elapsed() < self.max {
                self.budget = (self.budget * 2).clamp(self.floor(), self.max);
            }
        }
    }

    fn missed(&mut self) {
        self.budget /= 2;
        if self.budget < self.floor() {
            self.budget = Duration::ZERO;
        }
    }

    fn floor(&self) -> Duration {
        self.max / FLOOR_SHARE
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_zero_budget_never_spins() {
        let mut spin = Spin::new(Duration::ZERO);
        let mut polls = 0;
        assert!(!spin.poll(|| {
            polls += 1;
            false
        }));
        assert_eq!(polls, 1, "one look, no spinning");
        spin.woke();
        assert_eq!(spin.budget(), Duration::ZERO);
    }

    #[test]
    fn work_found_keeps_the_budget() {
        let mut spin = Spin::new(Duration::from_millis(50));
        let mut polls = 0;
        assert!(spin.poll(|| {
            polls += 1;
            polls == 3
        }));
        assert_eq!(spin.budget(), Duration::from_millis(50));
    }

    #[test]
    fn misses_halve_the_budget_down_to_nothing() {
        let max = Duration::from_micros(160);
        let mut spin = Spin::new(max);
        let mut budgets = Vec::new();
        for _ in 0..6 {
            assert!(!spin.poll(|| false));
            budgets.push(spin.budget().as_micros());
        }
        // 80, 40, 20, 10 (the floor is 160 / 16 = 10), then nothing.
        assert_eq!(budgets, [80, 40, 20, 10, 0, 0]);
    }

    #[test]
    fn a_short_sleep_grows_the_budget_back_and_a_long_one_does_not() {
        let max = Duration::from_secs(3600);
        let mut spin = Spin::new(max);
        for _ in 0..10 {
            spin.missed();
        }
        assert_eq!(spin.budget(), Duration::ZERO);
        // The work came well within the full budget after the sleep began.
        spin.slept_at = Some(Instant::now());
        spin.woke();
        assert_eq!(spin.budget(), max / FLOOR_SHARE);
        spin.slept_at = Some(Instant::now());
        spin.woke();
        assert_eq!(spin.budget(), max / 8);
        // A sleep longer than the full budget: spinning would not have
        // caught it.
        let mut short = Spin::new(Duration::from_micros(100));
        short.missed();
        let before = short.budget();
        short.slept_at = Some(Instant::now());
        std::thread::sleep(Duration::from_millis(2));
        short.woke();
        assert_eq!(short.budget(), before);
    }
}
