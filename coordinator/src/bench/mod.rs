//! `lander bench`: one fixed, seeded workload evaluated in several modes.
//! Each mode flies the workload as one warm block per round, the blocks'
//! order rotating from round to round, so machine noise falls on all of
//! them alike. Only time inside `evaluate`
//! counts; start-up does not.
//!
//! - [`workload`]: the work, the same for every mode and round.
//! - [`mode`]: a mode under test, typed by [`ModeKind`], and its figures.
//! - [`compare`]: the warm-up, the rounds, the ratios and the agreement of
//!   the modes' results: [`run`] and its [`Report`].
//! - [`figures`]: where a generation's time went, from chunk timings.
//! - [`stress`]: `--stress`, a mode under churn checked against a reference.
//!
//! The command line (`cli/bench.rs`) only parses, builds the evaluators and
//! prints.

pub mod compare;
#[cfg(test)]
mod fake;
pub mod figures;
pub mod mode;
pub mod stress;
pub mod workload;

pub use compare::{hashes_agree, run, Plan, Ratios, Report};
pub use figures::{overheads, percentile, Breakdown};
pub use mode::{Measured, Mode, ModeKind, ModeReport, Tally};
pub use stress::{kill_gap, StressReport, MAX_KILL_RATE};
pub use workload::{Population, Workload};
