//! The vocabulary shared by the coordinator and the workers.
//!
//! Everything here is plain data: genes and genomes, the environment a
//! flight happens in, the parameters of the fitness and the guided pass, and
//! the keys of the random streams. A worker receives all of it with each job
//! and keeps no state between jobs, so any worker can take any job.
//!
//! [`wire`] says how jobs and results are laid out between processes and
//! checks what arrives; [`iox`] names and opens the iceoryx2 services;
//! [`envelope`] frames messages for the network and [`net`] configures zenoh.

pub mod check;
pub mod envelope;
pub mod genome;
pub mod iox;
pub mod net;
pub mod outcome;
pub mod params;
pub mod stream;
pub mod wire;

pub use genome::{format_genome, parse_genome, Action, Gene, GenomeError};
pub use outcome::{EpisodeRecord, Evaluation, Outcome, State, TrainResult, Training};
pub use params::{Env, GuideParams, LearnParams, Method, Scoring, World};
pub use stream::StreamKey;
