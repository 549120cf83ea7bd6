//! What an experiment's numbers become: statistics ([`stats`]), the
//! summary ([`summary`]), plots ([`plots`]), flight replays ([`replay`])
//! and the self-contained HTML report ([`page`]), all escaped by
//! [`escape`]. A sweep (one experiment under many settings) becomes a table
//! of its settings ([`sweep`]) with bootstrap intervals ([`bootstrap`]),
//! figures per grid (in [`plots`]) and a page of its own ([`sweep_page`]).
//! Everything here is a pure function of the trial records and recordings
//! in [`model`]; reading and writing files is the caller's job.

pub mod bootstrap;
pub mod escape;
pub mod model;
pub mod page;
pub mod plots;
pub mod replay;
pub mod stats;
pub mod summary;
pub mod sweep;
pub mod sweep_page;
