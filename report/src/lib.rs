//! What an experiment's numbers become: statistics ([`stats`]), the
//! summary ([`summary`]), plots ([`plots`]), flight replays ([`replay`])
//! and the self-contained HTML report ([`page`]), all escaped by
//! [`escape`]. Everything here is a pure function of the trial records and
//! recordings in [`model`]; reading and writing files is the caller's job.

pub mod escape;
pub mod model;
pub mod page;
pub mod plots;
pub mod replay;
pub mod stats;
pub mod summary;
