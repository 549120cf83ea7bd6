//! What an experiment's numbers become: statistics ([`stats`]), plots
//! ([`plots`]), flight replays ([`replay`]) and the self-contained HTML
//! report ([`page`]). Everything here is a pure function of the trial
//! records in [`model`]; reading and writing files is the caller's job.

pub mod model;
pub mod page;
pub mod plots;
pub mod replay;
pub mod stats;
pub mod summary;
