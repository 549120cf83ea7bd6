//! The model: everything lander computes, as pure functions over plain data.
//!
//! - [`genome`]: actions, genes and the `"a:d,a:d"` text form.
//! - [`params`]: the world, the fitness's and the guided pass's constants,
//!   Q(λ)'s parameters, a flight's [`Env`], and the [`Pass`]s; each checks
//!   its own ranges with [`check`].
//! - [`outcome`]: what a flight, an evaluation and a training trial end in.
//! - [`stream`]: the keyed random streams behind every draw.
//! - [`sim`]: the physics and the hull impact test (SPEC §1), [`fly`].
//! - [`score`]: the fitness of eq. 1 and the reinforcement function R of eq. 3.
//! - [`guide`](mod@guide): the guided evolve pass (SPEC §4).
//! - [`evaluate`](mod@evaluate): one genome under a [`Pass`].
//! - [`reference`](mod@reference): a deliberately plain simulation, the oracle that the
//!   fast one must match bit for bit.
//! - [`tiles`], [`qlearn`], [`learn`]: the hashed tile coder, Watkins's
//!   Q(λ), and the lander as its task (SPEC §5).
//!
//! The model knows nothing of processes, transports, files or the command
//! line: no locks, no I/O, no allocation in the flight loop. With the
//! `zero-copy` feature the parameter types also derive iceoryx2's
//! `ZeroCopySend`, so that a job's header can carry them as they are.

pub mod check;
pub mod evaluate;
pub mod genome;
pub mod guide;
pub mod learn;
pub mod outcome;
pub mod params;
pub mod qlearn;
pub mod reference;
pub mod score;
pub mod sim;
pub mod stream;
pub mod tiles;

pub use check::ParamError;
pub use evaluate::evaluate;
pub use genome::{format_genome, parse_genome, Action, Gene, GenomeError};
pub use guide::guide;
pub use learn::TrainJob;
pub use outcome::{EpisodeRecord, Evaluation, Outcome, State, TrainResult, Training};
pub use params::{Env, GuideParams, LearnParams, Method, Pass, Scoring, World};
pub use sim::{fly, fly_traced, Flight, Lander, Physics, HULL, HULL_RADIUS};
pub use stream::StreamKey;

/// The paper's world with the given start column and pad, for tests.
#[cfg(test)]
pub(crate) fn test_env(x0: f64, pad_x: f64) -> Env {
    Env {
        world: World::default(),
        scoring: Scoring::default(),
        x0,
        pad_x,
    }
}
