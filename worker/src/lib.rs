//! Everything that flies landers.
//!
//! - [`sim`]: the physics and the hull impact test (SPEC §1), [`fly`].
//! - [`score`]: the fitness of eq. 1 and the reinforcement function R of eq. 3.
//! - [`guide`]: the guided evolve pass (SPEC §4).
//! - [`evaluate`]: one genome under a method, as a worker serves it.
//! - [`reference`]: a deliberately plain simulation, the baseline that the
//!   fast one must match bit for bit.
//! - [`tiles`], [`qlearn`], [`learn`]: the hashed tile coder, Watkins's
//!   Q(λ), and the lander as its task (SPEC §5).
//! - [`serve`]: the worker process's loop, serving jobs over iceoryx2 or
//!   zenoh.
//! - [`cpu`]: pinning to a CPU and the batch scheduling class; the clocks
//!   that time chunks.
//!
//! All but `serve` and `cpu` is pure: no locks, no I/O, no allocation in the flight loop.

pub mod cpu;
pub mod evaluate;
pub mod guide;
pub mod learn;
pub mod qlearn;
pub mod reference;
pub mod score;
pub mod serve;
pub mod sim;
pub mod tiles;

pub use evaluate::{evaluate, run_job};
pub use guide::guide;
pub use lander_protocol::{Evaluation, Method, Outcome, State};
pub use sim::{fly, fly_traced, Flight, Lander, Physics, HULL, HULL_RADIUS};

/// The paper's world with the given start column and pad, for tests.
#[cfg(test)]
pub(crate) fn test_env(x0: f64, pad_x: f64) -> lander_protocol::Env {
    lander_protocol::Env {
        world: lander_protocol::World::default(),
        scoring: lander_protocol::Scoring::default(),
        x0,
        pad_x,
    }
}
