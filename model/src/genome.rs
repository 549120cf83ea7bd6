//! Genes, genomes and their text form `"action:duration,..."`.

use serde::{Deserialize, Serialize};
use std::fmt;

/// One of the lander's four controls. The discriminants are the SPEC's
/// action indices, which also order ties in the guided pass.
#[repr(u8)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Action {
    RotateLeft = 0,
    RotateRight = 1,
    Thrust = 2,
    Drift = 3,
}

impl Action {
    /// All actions in index order.
    pub const ALL: [Action; 4] = [
        Action::RotateLeft,
        Action::RotateRight,
        Action::Thrust,
        Action::Drift,
    ];

    /// The action with index `i`, or `None` when `i` is out of range.
    pub fn from_index(i: u8) -> Option<Action> {
        Self::ALL.get(usize::from(i)).copied()
    }

    pub fn index(self) -> u8 {
        self as u8
    }
}

/// `duration` ticks of `action`. A duration of 0 is legal and makes the
/// gene a no-op.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Gene {
    pub action: Action,
    pub duration: u8,
}

impl Gene {
    pub fn new(action: Action, duration: u8) -> Gene {
        Gene { action, duration }
    }
}

impl fmt::Display for Gene {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.action.index(), self.duration)
    }
}

#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum GenomeError {
    #[error("genome is empty")]
    Empty,
    #[error("gene {index} ({text:?}): expected `action:duration`, e.g. `2:15`")]
    Shape { index: usize, text: String },
    #[error("gene {index} ({text:?}): action must be 0 (RotateLeft), 1 (RotateRight), 2 (Thrust) or 3 (Drift)")]
    Action { index: usize, text: String },
    #[error("gene {index} ({text:?}): duration must be an integer in 0..={max}")]
    Duration { index: usize, text: String, max: u8 },
}

/// Renders a genome as `"1:12,2:30,3:4"`.
pub fn format_genome(genes: &[Gene]) -> String {
    let parts: Vec<String> = genes.iter().map(Gene::to_string).collect();
    parts.join(",")
}

/// Parses `"1:12,2:30,3:4"`, accepting durations up to `max_duration`.
/// Whitespace around genes is ignored.
pub fn parse_genome(text: &str, max_duration: u8) -> Result<Vec<Gene>, GenomeError> {
    if text.trim().is_empty() {
        return Err(GenomeError::Empty);
    }
    text.split(',')
        .enumerate()
        .map(|(index, raw)| parse_gene(index, raw.trim(), max_duration))
        .collect()
}

fn parse_gene(index: usize, text: &str, max: u8) -> Result<Gene, GenomeError> {
    let owned = || text.to_string();
    let (a, d) = text.split_once(':').ok_or_else(|| GenomeError::Shape {
        index,
        text: owned(),
    })?;
    let action = a
        .trim()
        .parse::<u8>()
        .ok()
        .and_then(Action::from_index)
        .ok_or_else(|| GenomeError::Action {
            index,
            text: owned(),
        })?;
    let duration = d
        .trim()
        .parse::<u8>()
        .ok()
        .filter(|&d| d <= max)
        .ok_or_else(|| GenomeError::Duration {
            index,
            text: owned(),
            max,
        })?;
    Ok(Gene { action, duration })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn parses_the_documented_example() {
        let g = parse_genome("1:12,2:30,3:4", 30).unwrap();
        assert_eq!(
            g,
            vec![
                Gene::new(Action::RotateRight, 12),
                Gene::new(Action::Thrust, 30),
                Gene::new(Action::Drift, 4)
            ]
        );
        assert_eq!(format_genome(&g), "1:12,2:30,3:4");
    }

    #[test]
    fn rejects_bad_genes_naming_the_gene() {
        assert_eq!(parse_genome("", 30), Err(GenomeError::Empty));
        assert!(matches!(
            parse_genome("1:2,4:3", 30),
            Err(GenomeError::Action { index: 1, .. })
        ));
        assert!(matches!(
            parse_genome("1:31", 30),
            Err(GenomeError::Duration { index: 0, .. })
        ));
        assert!(matches!(
            parse_genome("1:2,3", 30),
            Err(GenomeError::Shape { index: 1, .. })
        ));
        assert!(matches!(
            parse_genome("1:-2", 30),
            Err(GenomeError::Duration { .. })
        ));
    }

    proptest! {
        #[test]
        fn text_form_round_trips(genes in proptest::collection::vec((0u8..4, 0u8..=30), 1..60)) {
            let genome: Vec<Gene> = genes
                .iter()
                .map(|&(a, d)| Gene::new(Action::from_index(a).unwrap(), d))
                .collect();
            prop_assert_eq!(parse_genome(&format_genome(&genome), 30).unwrap(), genome);
        }
    }
}
