//! The pool's unit tests, one file per concern, over the fakes behind the
//! [`Transport`](super::Transport) seam (`fake`): no processes, no
//! transport, except where a test needs a real child process.

mod answers;
mod breeding;
mod checks;
mod chunking;
mod deaths;
mod dispatch;
mod fake;
mod farewells;
mod refusals;
mod share;
mod training;
mod versions;
