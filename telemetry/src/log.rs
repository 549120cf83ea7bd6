//! The binaries' log: every diagnostic goes through `tracing`, and this
//! subscriber writes it to stderr.
//!
//! - Text (the default) reads as the tools always have: `lander: worker
//!   … exited`, with `warning:` or `error:` before what needs attention.
//! - JSON writes one object per line: `timestamp`, `level`, `target` and
//!   `fields` (the message and any structured values).
//! - `RUST_LOG` filters, as `tracing-subscriber`'s `EnvFilter` reads it.
//!   Unset, lander's own crates log at `info` and everything else,
//!   zenoh among it, at `warn`, but for zenoh's warning at each failed
//!   attempt to connect and its error at each handshake refused (a
//!   waiting worker says it once, itself) and its warning that gossip,
//!   which lander turns off, is off.
//!
//! Progress bars are drawn on stderr too. Every bar is added to [`bars`],
//! and each log line is written with the bars lifted (`suspend`), so
//! neither garbles the other.

use indicatif::MultiProgress;
use std::fmt;
use std::io::Write;
use std::sync::OnceLock;
use tracing::{Event, Level, Subscriber};
use tracing_subscriber::fmt::format::Writer;
use tracing_subscriber::fmt::{FmtContext, FormatEvent, FormatFields, MakeWriter};
use tracing_subscriber::registry::LookupSpan;
use tracing_subscriber::EnvFilter;

/// How log lines are written.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LogFormat {
    /// For people: `program: message`.
    #[default]
    Text,
    /// One JSON object per line, for machines.
    Json,
}

impl std::str::FromStr for LogFormat {
    type Err = String;
    fn from_str(s: &str) -> Result<LogFormat, String> {
        match s {
            "text" => Ok(LogFormat::Text),
            "json" => Ok(LogFormat::Json),
            _ => Err(format!("`{s}` is not a log format: use text or json")),
        }
    }
}

/// What is logged when `RUST_LOG` is unset: lander's crates at `info`
/// (`warn` for a quiet worker), the rest at `warn`.
fn default_filter(quiet: bool) -> String {
    let ours = if quiet { "warn" } else { "info" };
    [
        "lander",
        "lander_coordinator",
        "lander_worker",
        "lander_telemetry",
        "lander_protocol",
    ]
    .iter()
    .fold("warn".to_string(), |f, c| format!("{f},{c}={ours}"))
        // zenoh warns of every failed attempt to connect, and says
        // zenoh's internals at every handshake refused (a wrong password);
        // a worker waiting for its coordinator retries, and says so
        // itself, once.
        + ",zenoh::net::runtime::orchestrator=error"
        + ",zenoh_transport::unicast::establishment=off"
        // And at every coordinator's start, that gossip is off (lander
        // turns it off: its sessions meet by the addresses they are given,
        // through no region gateway).
        + ",zenoh::net::routing::hat::peer=error"
}

/// Installs the subscriber for the process. `program` starts every text
/// line; `quiet` keeps lander's own info lines out unless `RUST_LOG` says
/// otherwise. A bad `RUST_LOG` is an error naming it.
pub fn init(program: &str, format: LogFormat, quiet: bool) -> Result<(), String> {
    let filter = match std::env::var("RUST_LOG") {
        Ok(spec) if !spec.trim().is_empty() => {
            EnvFilter::try_new(&spec).map_err(|e| format!("RUST_LOG `{spec}`: {e}"))?
        }
        _ => EnvFilter::new(default_filter(quiet)),
    };
    let builder = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(AroundBars);
    let installed = match format {
        LogFormat::Text => builder.event_format(Plain).try_init(),
        LogFormat::Json => builder
            .json()
            .with_current_span(false)
            .with_span_list(false)
            .try_init(),
    };
    installed.map_err(|e| format!("cannot install the log: {e}"))?;
    rename(program);
    let _ = FORMAT.set(format);
    Ok(())
}

/// The format the process logs in, so that the workers a coordinator
/// spawns log in it too.
static FORMAT: OnceLock<LogFormat> = OnceLock::new();

/// The format [`init`] installed; text if none was.
pub fn format() -> LogFormat {
    FORMAT.get().copied().unwrap_or_default()
}

/// Every progress bar of the process, so that log lines are written
/// around them.
pub fn bars() -> &'static MultiProgress {
    static BARS: OnceLock<MultiProgress> = OnceLock::new();
    BARS.get_or_init(MultiProgress::new)
}

/// Writes each log line to stderr with the progress bars lifted.
struct AroundBars;

/// One line's bytes, written out whole when dropped.
struct Line(Vec<u8>);

impl Write for Line {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Drop for Line {
    fn drop(&mut self) {
        let line = std::mem::take(&mut self.0);
        // Nothing sensible is left to do when stderr is gone.
        bars().suspend(|| {
            let _ = std::io::stderr().lock().write_all(&line);
        });
    }
}

impl<'a> MakeWriter<'a> for AroundBars {
    type Writer = Line;
    fn make_writer(&'a self) -> Line {
        Line(Vec::with_capacity(128))
    }
}

/// The text format: `program: message key=value`, with `warning: ` or
/// `error: ` before the message at those levels.
struct Plain;

/// The name that opens each text line: the program's, and which one of
/// them where several run (`lander-worker <id>`).
static PROGRAM: std::sync::RwLock<String> = std::sync::RwLock::new(String::new());

/// Names the program anew in the lines from here on, as a worker that
/// serves a run again under another id.
pub fn rename(program: &str) {
    if let Ok(mut name) = PROGRAM.write() {
        *name = program.to_string();
    }
}

impl<S, N> FormatEvent<S, N> for Plain
where
    S: Subscriber + for<'a> LookupSpan<'a>,
    N: for<'a> FormatFields<'a> + 'static,
{
    fn format_event(
        &self,
        ctx: &FmtContext<'_, S, N>,
        mut writer: Writer<'_>,
        event: &Event<'_>,
    ) -> fmt::Result {
        match PROGRAM.read() {
            Ok(program) => write!(writer, "{program}: ")?,
            Err(_) => write!(writer, "?: ")?,
        }
        match *event.metadata().level() {
            Level::ERROR => write!(writer, "error: ")?,
            Level::WARN => write!(writer, "warning: ")?,
            _ => {}
        }
        ctx.field_format().format_fields(writer.by_ref(), event)?;
        writeln!(writer)
    }
}

#[cfg(test)]
mod tests {
    use super::default_filter;
    use tracing_subscriber::EnvFilter;

    #[test]
    fn the_default_filter_parses_and_keeps_other_crates_at_warn() {
        let f = default_filter(false);
        assert!(f.starts_with("warn,"), "{f}");
        assert!(f.contains("lander_coordinator=info"), "{f}");
        assert!(default_filter(true).contains("lander_worker=warn"));
        assert!(
            f.contains(",zenoh::net::runtime::orchestrator=error,"),
            "{f}"
        );
        assert!(
            f.contains(",zenoh_transport::unicast::establishment=off,"),
            "{f}"
        );
        assert!(f.ends_with(",zenoh::net::routing::hat::peer=error"), "{f}");
        EnvFilter::try_new(&f).unwrap();
    }
}
