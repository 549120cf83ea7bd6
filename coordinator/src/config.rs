//! The run configuration: every parameter of SPEC §1–5 with the paper's
//! defaults (and the Q(λ) baseline's), read from TOML and validated field by field.

use crate::ga::GaParams;
use lander_model::check::ParamError;
use lander_model::stream::streams;
use lander_model::StreamKey;
use lander_model::{Env, GuideParams, LearnParams, Method, Scoring, World};
use rand::Rng;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Everything one trial needs. Every key is optional in the file; unknown
/// keys are errors.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RunConfig {
    pub method: Method,
    pub seed: u64,
    /// Trials are numbered from 1; trial `t` draws `x0` and `pad_x` from
    /// `(seed, t)`.
    pub trial: u64,
    /// Threads for in-process evaluation; 0 means one per core.
    pub threads: usize,
    pub world: World,
    pub scoring: Scoring,
    pub guided: GuideParams,
    pub ga: GaParams,
    pub qlearning: LearnParams,
}

impl Default for RunConfig {
    fn default() -> Self {
        RunConfig {
            method: Method::Guided,
            seed: 1,
            trial: 1,
            threads: 0,
            world: World::default(),
            scoring: Scoring::default(),
            guided: GuideParams::default(),
            ga: GaParams::default(),
            qlearning: LearnParams::default(),
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    // `error` rather than `source`: the message says it once, and a source
    // would be said again by `{:#}`.
    #[error("cannot read {path}: {error}")]
    Read { path: String, error: std::io::Error },
    #[error("{path}: {message}")]
    Parse { path: String, message: String },
    // Not a `source`: the message already says it all, once.
    #[error("invalid configuration: {0}")]
    Invalid(ParamError),
    #[error("{path}: invalid configuration: {error}")]
    InvalidFile { path: String, error: ParamError },
}

impl From<ParamError> for ConfigError {
    fn from(e: ParamError) -> ConfigError {
        ConfigError::Invalid(e)
    }
}

impl RunConfig {
    /// Reads and validates a TOML file.
    pub fn load(path: &Path) -> Result<RunConfig, ConfigError> {
        let shown = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|error| ConfigError::Read {
            path: shown.clone(),
            error,
        })?;
        let cfg: RunConfig = toml::from_str(&text).map_err(|e| ConfigError::Parse {
            path: shown.clone(),
            message: toml_error(&text, &e),
        })?;
        cfg.validate().map_err(|e| match e {
            ConfigError::Invalid(error) => ConfigError::InvalidFile { path: shown, error },
            other => other,
        })?;
        Ok(cfg)
    }

    /// Checks every field, naming the first that is out of range. Each
    /// section checks itself; run it again after every override.
    pub fn validate(&self) -> Result<(), ConfigError> {
        // Here as well as where the threads start, so that a file's value
        // is refused naming the file.
        lander_model::check::check(
            "threads",
            self.threads <= crate::evaluator::MAX_THREADS,
            format_args!(
                "must be 0 (one per core) to {} (got {})",
                crate::evaluator::MAX_THREADS,
                self.threads
            ),
        )?;
        self.world.check()?;
        self.scoring.check()?;
        self.guided.check()?;
        self.ga.check()?;
        Ok(self.qlearning.check()?)
    }

    /// The environment of one attempt: the configured world, the trial's
    /// start column and the restart's pad.
    pub fn env(&self, restart: u64) -> Env {
        Env {
            world: self.world,
            scoring: self.scoring,
            x0: start_x(self),
            pad_x: pad_x(self, restart),
        }
    }
}

/// The most characters of a TOML file's line that an error quotes: a
/// file's one long line (a 1 MB value) would otherwise be printed whole.
const SHOWN_CHARS: usize = 120;

/// The most characters of a line of a parse error's message: long enough
/// for the list of a section's keys that an unknown key's message gives,
/// short of a long value echoed whole.
const MESSAGE_CHARS: usize = 1_000;

/// A TOML parse error of `text` as the user reads it: where, the line
/// around that place (clipped to [`SHOWN_CHARS`]) with a caret under it,
/// and what is wrong.
/// An error without a place in `text` (from a value, not a file's text) is
/// its message alone.
pub fn toml_error(text: &str, e: &toml::de::Error) -> String {
    let Some(span) = e.span().filter(|s| s.start <= text.len()) else {
        return clipped(e.to_string().trim_end());
    };
    let message = clipped(e.message().trim_end());
    let start = text.floor_char_boundary(span.start);
    let line_start = text[..start].rfind('\n').map_or(0, |i| i + 1);
    let line_end = text[start..].find('\n').map_or(text.len(), |i| start + i);
    let line_no = text[..start].matches('\n').count() + 1;
    let column = text[line_start..start].chars().count();
    let (shown, caret) = clip(text[line_start..line_end].trim_end_matches('\r'), column);
    let gutter = " ".repeat(line_no.to_string().len());
    format!(
        "TOML parse error at line {line_no}, column {}\n{gutter} |\n{line_no} | {shown}\n{gutter} | {}^\n{message}",
        column + 1,
        " ".repeat(caret)
    )
}

/// Each line of `message` cut to at most [`MESSAGE_CHARS`] characters,
/// with `…` where it was cut: a value echoed in it may be a whole long
/// line.
pub fn clipped(message: &str) -> String {
    let lines: Vec<String> = message
        .lines()
        .map(|l| clip_to(l, 0, MESSAGE_CHARS).0)
        .collect();
    lines.join("\n")
}

/// `line` cut to at most [`SHOWN_CHARS`] characters around the character
/// at `at`, with `…` where it was cut, and where `at` falls in what is
/// shown.
fn clip(line: &str, at: usize) -> (String, usize) {
    clip_to(line, at, SHOWN_CHARS)
}

/// `line` cut to at most `most` characters around the character at `at`,
/// as [`clip`].
fn clip_to(line: &str, at: usize, most: usize) -> (String, usize) {
    let chars: Vec<char> = line.chars().collect();
    if chars.len() <= most {
        return (line.to_string(), at);
    }
    let from = at.saturating_sub(most / 2).min(chars.len() - most);
    let to = from + most;
    let mut shown: String = chars[from..to].iter().collect();
    let mut caret = at - from;
    if from > 0 {
        shown.insert(0, '…');
        caret += 1;
    }
    if to < chars.len() {
        shown.push('…');
    }
    (shown, caret)
}

/// The trial's start column, `U[0, W)` from `(seed, trial)`.
fn start_x(cfg: &RunConfig) -> f64 {
    let key = StreamKey::new(cfg.seed, cfg.trial, 0, 0);
    key.rng(streams::START).random::<f64>() * cfg.world.width
}

/// The pad of a restart, `U[margin, W − margin)` from `(seed, trial, restart)`.
fn pad_x(cfg: &RunConfig, restart: u64) -> f64 {
    let key = StreamKey::new(cfg.seed, cfg.trial, restart, 0);
    let m = cfg.world.pad_margin;
    m + key.rng(streams::PAD).random::<f64>() * (cfg.world.width - 2.0 * m)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<RunConfig, String> {
        let cfg: RunConfig = toml::from_str(text).map_err(|e| e.to_string())?;
        cfg.validate().map_err(|e| e.to_string())?;
        Ok(cfg)
    }

    #[test]
    fn an_empty_file_gives_the_papers_defaults() {
        let cfg = parse("").unwrap();
        assert_eq!(cfg, RunConfig::default());
        assert_eq!(cfg.ga.population, 100);
        assert_eq!(cfg.ga.genome_length, 50);
        assert_eq!(cfg.ga.crossover_rate, 0.7);
        assert_eq!(cfg.ga.mutation_rate, 0.05);
        assert_eq!(cfg.ga.max_generations, 500);
        assert_eq!(cfg.ga.elites, 4);
        assert_eq!(cfg.guided.epsilon, 0.1);
        assert_eq!(cfg.world.width, 400.0);
    }

    #[test]
    fn overrides_are_read_from_their_sections() {
        let cfg = parse("method = \"ga\"\n[ga]\npopulation = 20\ncrossover = \"buckland\"\n[world]\nwidth = 500.0\n").unwrap();
        assert_eq!(cfg.method, Method::Ga);
        assert_eq!(cfg.ga.population, 20);
        assert_eq!(cfg.ga.crossover, crate::ga::Crossover::Buckland);
        assert_eq!(cfg.world.width, 500.0);
    }

    #[test]
    fn bad_values_are_refused_naming_the_field() {
        for (text, field) in [
            ("[ga]\npopulation = 0", "ga.population"),
            ("[ga]\ncrossover_rate = 1.5", "ga.crossover_rate"),
            ("[ga]\ncrossover_rate = -0.1", "ga.crossover_rate"),
            ("[ga]\nmutation_rate = nan", "ga.mutation_rate"),
            ("[ga]\nmax_duration = 0", "ga.max_duration"),
            ("[ga]\nelites = 101", "ga.elites"),
            // As many elites as genomes: nothing would ever be bred.
            ("[ga]\nelites = 100", "ga.elites"),
            ("[world]\nwidth = nan", "world.width"),
            ("[world]\nheight = inf", "world.height"),
            ("[guided]\nepsilon = 2.0", "guided.epsilon"),
            ("[scoring]\nw2 = nan", "scoring.w2"),
            ("[qlearning]\ntilings = 0", "qlearning.tilings"),
            ("[qlearning]\ngamma = 1.5", "qlearning.gamma"),
            (
                "[qlearning]\ntile_widths = [40.0, 30.0, 0.0, 0.5, 0.25]",
                "qlearning.tile_widths",
            ),
            ("[qlearning]\nepisodes = 0", "qlearning.episodes"),
            ("[qlearning]\nmemory_bits = 28", "qlearning.memory_bits"),
            ("[world]\nmax_ticks = 4000000000", "world.max_ticks"),
            ("[scoring]\nw3 = 1e308", "scoring.w3"),
            ("[ga]\npopulation = 100000000", "ga.population"),
            (
                "[ga]\npopulation = 10001\ngenome_length = 10000",
                "ga.population",
            ),
            ("[world]\nthrust = 1e308\nmass = 1e-300", "world.thrust"),
            ("[world]\nmass = 1e-9", "world.thrust"),
            ("[world]\ngravity = -1e9", "world.gravity"),
            (
                "threads = 100000",
                "threads must be 0 (one per core) to 1024",
            ),
            // rot turned to NaN, written out as nulls.
            (
                "[world]\nrotation_step = 1.7e308",
                "world.rotation_step must be from -2π to 2π",
            ),
            ("[world]\nrotation_step = -6.3", "world.rotation_step"),
            (
                "[world]\ngravity = -1.63",
                "world.gravity must not be negative",
            ),
            (
                "[world]\nthrust = -350",
                "world.thrust must not be negative",
            ),
            // R infinite for some flight: Q(λ)'s values became NaN.
            (
                "[guided]\nr = 1e308",
                "guided.r must be from -1e12 to 1e12 (got 1e308)",
            ),
            (
                "[guided]\nw_y = 1e-300",
                "guided.w_y must be at least 1e-12",
            ),
            (
                "[guided]\nw_y = 0",
                "guided.w_y must be at least 1e-12 (got 0.0)",
            ),
            ("[guided]\nw_t = -6", "guided.w_t must not be negative"),
            // The value given, not its size.
            (
                "[scoring]\nw1 = -inf",
                "scoring.w1 must be a finite number (got -inf)",
            ),
            ("[scoring]\nw1 = -2e12", "(got -2000000000000.0)"),
        ] {
            let err = parse(text).unwrap_err();
            assert!(err.contains(field), "{text:?} gave {err:?}");
        }
    }

    #[test]
    fn unknown_keys_and_methods_are_refused() {
        let err = parse("[ga]\npopulaton = 10").unwrap_err();
        assert!(err.contains("unknown field `populaton`"), "{err}");
        let err = parse("colour = 1").unwrap_err();
        assert!(err.contains("unknown field `colour`"), "{err}");
        let err = parse("method = \"annealing\"").unwrap_err();
        assert!(err.contains("unknown variant `annealing`"), "{err}");
    }
}

#[cfg(test)]
mod shipped {
    use super::*;

    #[test]
    fn the_shipped_defaults_file_is_the_built_in_defaults() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../experiments/defaults.toml");
        assert_eq!(RunConfig::load(&path).unwrap(), RunConfig::default());
    }

    fn parse_error(text: &str) -> String {
        let e = toml::from_str::<RunConfig>(text).unwrap_err();
        toml_error(text, &e)
    }

    #[test]
    fn a_parse_error_shows_its_line_with_a_caret_under_the_place() {
        assert_eq!(
            parse_error("[ga]\npopulation = = 3\n"),
            "TOML parse error at line 2, column 14\n  |\n2 | population = = 3\n  |              ^\n\
             extra `=`, expected nothing"
        );
    }

    #[test]
    fn a_long_line_is_shown_clipped_around_the_place() {
        let text = format!("{} = = 3\n", "x".repeat(1_000_000));
        let shown = parse_error(&text);
        let lines: Vec<&str> = shown.lines().collect();
        assert_eq!(lines[0], "TOML parse error at line 1, column 1000004");
        let line = lines[2].strip_prefix("1 | ").unwrap();
        assert_eq!(line.chars().count(), SHOWN_CHARS + 1, "{line}");
        assert!(line.starts_with('…') && line.ends_with("x = = 3"), "{line}");
        let caret = lines[3].strip_prefix("  | ").unwrap();
        assert_eq!(caret.trim_start().to_string(), "^");
        let under = line.chars().nth(caret.len() - 1).unwrap();
        assert_eq!(under, '=');
        assert_eq!(line.chars().nth(caret.len() - 3), Some('='));
        assert!(shown.len() < 400, "{} bytes", shown.len());
    }

    #[test]
    fn a_long_value_in_a_message_is_clipped() {
        let text = format!("[ga]\npopulation = \"{}\"\n", "a".repeat(1_000_000));
        let shown = parse_error(&text);
        assert!(
            shown.len() < 1_400,
            "{} bytes: {}",
            shown.len(),
            shown.chars().take(1_400).collect::<String>()
        );
        assert!(shown.contains("line 2"), "{shown}");
        // The place is near the line's start, so the quoted line (after its
        // "2 | " gutter) and the message are each clipped at their end.
        let lines: Vec<&str> = shown.lines().collect();
        let quoted = lines[2].strip_prefix("2 | ").unwrap();
        assert_eq!(quoted.chars().count(), SHOWN_CHARS + 1, "{quoted}");
        assert!(quoted.ends_with("aa…"), "{quoted}");
        assert!(lines[4].starts_with("invalid type: string"), "{shown}");
        assert_eq!(lines[4].chars().count(), MESSAGE_CHARS + 1, "{}", lines[4]);
    }

    #[test]
    fn an_unknown_key_is_shown_with_every_key_of_its_section() {
        let shown = parse_error("[world]\ncolour = 1\n");
        let keys = serde_json::to_value(World::default()).unwrap();
        let keys = keys.as_object().unwrap();
        assert!(keys.len() > 10, "{keys:?}");
        for key in keys.keys() {
            assert!(
                shown.contains(&format!("`{key}`")),
                "{key} missing: {shown}"
            );
        }
    }
}
