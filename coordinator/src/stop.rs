//! A stop handle: how whoever started the work asks it to stop.
//!
//! The evaluators look at it before each generation (in-process) and
//! within each sleep slice (over workers), so a stop unwinds as an
//! [`EvalError::Interrupted`](crate::evaluator::EvalError) through the
//! pool's `Drop`: workers are told the run is over and the run's shared
//! memory is removed. The `lander` binary sets it from its SIGINT and
//! SIGTERM handlers; a library user sets it with [`Stop::ask`].

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// A flag shared by clones: one [`ask`](Stop::ask) reaches them all. The
/// default is a handle nobody has asked yet.
#[derive(Clone, Debug, Default)]
pub struct Stop(Arc<AtomicBool>);

impl Stop {
    pub fn new() -> Stop {
        Stop::default()
    }

    /// Asks the work to stop at its next look.
    pub fn ask(&self) {
        self.0.store(true, Ordering::Relaxed);
    }

    /// Whether someone asked the work to stop.
    pub fn asked(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }

    /// The flag itself, for a signal handler to set.
    pub fn flag(&self) -> Arc<AtomicBool> {
        self.0.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn asking_one_clone_stops_them_all() {
        let stop = Stop::new();
        let seen = stop.clone();
        assert!(!seen.asked());
        stop.ask();
        assert!(seen.asked());
        assert!(!Stop::default().asked());
    }
}
