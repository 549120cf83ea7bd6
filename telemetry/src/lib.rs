//! How a lander run is watched while it goes and read about afterwards.
//! Nothing here knows the model, the GA or a transport: the coordinator
//! and the worker hand in what happened, as plain numbers and [`Event`]s.
//!
//! - [`log`]: the binaries' `tracing` subscriber (readable text or JSON
//!   lines on stderr, filtered by `RUST_LOG`), drawn around the progress
//!   bars rather than through them;
//! - [`metrics`]: every Prometheus metric the coordinator and the worker
//!   export, with their names and help in one place;
//! - [`serve`]: `--metrics ADDR`, the HTTP endpoint that serves them;
//! - [`events`]: [`Event`], `events.jsonl`, and [`Telemetry`], the one
//!   handle through which the coordinator reports what happened to its
//!   run and its workers.

pub mod events;
pub mod log;
pub mod metrics;
pub mod serve;

pub use events::{Event, Telemetry, WorkerRef};
pub use metrics::{CoordinatorMetrics, WorkerMetrics};
pub use serve::{MetricsServer, ServeError};
