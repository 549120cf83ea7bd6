//! Everything that evolves and orchestrates.
//!
//! - [`config`]: the run configuration and its validation.
//! - [`ga`]: the GA's operators.
//! - [`trial`]: one trial, generation by generation, with restarts.
//! - [`evaluator`]: who flies a generation; in-process over threads.
//! - [`pool`]: the evaluator pool over worker processes, reached over
//!   iceoryx2 on this host or zenoh from any host.
//! - [`bench`](mod@bench): the throughput comparison behind `lander bench`.
//! - [`run_files`]: what a run writes: JSON lines, `best.json`, the summary.
//! - [`folder_lock`]: one command at a time in an output folder.
//! - [`checkpoint`]: `checkpoint.bin`, a run saved between generations.
//! - [`experiment`]: many paired trials, resumable, with tables, plots and a report.
//! - [`recording`]: genomes flown into Recordings for replays.
//! - [`sweep`]: one experiment under many settings, as one workload.
//! - [`stop`]: the handle that asks the evaluators to stop.

pub mod bench;
pub mod checkpoint;
pub mod config;
pub mod evaluator;
pub mod experiment;
pub mod folder_lock;
pub mod ga;
pub mod pool;
pub mod recording;
pub mod run_files;
pub mod stop;
pub mod sweep;
pub mod trial;
