//! What crosses a process boundary in lander, and how.
//!
//! The model's plain data ([`lander_model`]) travels in jobs; this crate
//! says how.
//!
//! - [`wire`]: how jobs and results are laid out between processes, and
//!   the checks a receiver makes before it believes them.
//! - [`iox`]: the iceoryx2 services of a run on one host.
//! - [`envelope`]: frames for the network, and the one decoder of network
//!   bytes; [`net`]: zenoh's session configurations.
//! - [`host`]: the host's CPUs and clocks, which both sides read.
//! - [`spin`]: the bounded, adaptive spin before a sleep.

pub mod envelope;
pub mod host;

/// Why a coordinator tells a worker to leave: each transport carries it
/// (`iox::farewell_event`, `net::leave_word`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Farewell {
    /// The run is over.
    RunOver,
    /// The coordinator dropped this worker (a missed deadline, a broken
    /// link) and flies its work elsewhere.
    Dropped,
    /// The coordinator refused this worker's answers (wrong under
    /// `--verify`, or not decoding) and will not take it back.
    Refused,
    /// The coordinator stopped before the run's end (a signal or an
    /// error), and a `--resume` may carry the run on.
    Stopped,
}

impl Farewell {
    /// Every reason, for the tests of each transport's words.
    pub const ALL: [Farewell; 4] = [
        Farewell::RunOver,
        Farewell::Dropped,
        Farewell::Refused,
        Farewell::Stopped,
    ];
}

pub mod iox;
pub mod net;
pub mod spin;
pub mod wire;
