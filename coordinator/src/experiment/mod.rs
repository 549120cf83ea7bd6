//! `lander experiment`: many paired trials of several methods, run on one
//! backend, stored trial by trial so an interrupted run can resume, and
//! turned into tables, plots and a report.
//!
//! - [`file`](mod@file): the experiment file and its validation;
//! - [`runner`]: the trials, stepped together on the backend;
//! - [`store`]: the folder's finished trials, written atomically;
//! - [`outputs`]: the CSV, JSON lines, summary, plots and report.

pub mod file;
pub mod outputs;
pub mod runner;
pub mod store;

pub use file::Experiment;
pub use runner::{
    can_run, experiment_tasks, keep, run, trials, ExperimentError, Progress, Task, TrialId,
};
pub use store::{Store, StoreError};
