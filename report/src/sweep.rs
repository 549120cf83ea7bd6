//! A sweep's table: one experiment run under many settings, one row per
//! setting, so that settings can be compared at a glance. Each row takes
//! its quartiles, counts and p-value from the setting's own [`Summary`]
//! (so it agrees with that setting's `summary.json` to the last digit) and
//! adds percentile bootstrap intervals ([`crate::bootstrap`]) for the
//! median generations of each GA and for the share of pairs the guided GA
//! won. [`SweepSummary::csv`] and [`SweepSummary::markdown`] render it;
//! the plots are in [`crate::plots`] and the page in
//! [`crate::sweep_page`].

use crate::bootstrap::{median_interval, share_interval, Interval, LEVEL, RESAMPLES};
use crate::model::{Method, TrialRecord};
use crate::plots::thousands;
use crate::stats::Quartiles;
use crate::summary::{guided_fewer, landed_generations, num, pairs, pvalue, Summary};
use serde::Serialize;
use serde_json::Value;
use std::fmt::Write;

/// The paper's result to compare a sweep with: its guided GA needed fewer
/// generations than its general GA in 24 of 25 pairs.
pub const PAPER_PAIRS_WON: (usize, usize) = (24, 25);

/// [`PAPER_PAIRS_WON`] as a share, 0.96.
pub const PAPER_SHARE_WON: f64 = 24.0 / 25.0;

/// One setting of a sweep, as the coordinator hands it over.
pub struct SettingInput<'a> {
    /// Unique display name, e.g. "epsilon/guided.epsilon=0.05" or a
    /// user's name.
    pub name: &'a str,
    /// The setting's folder relative to the sweep folder, e.g.
    /// "settings/epsilon-guided.epsilon-0.05"; the page links to
    /// `<folder>/report.html`.
    pub folder: &'a str,
    /// The grid it belongs to, if it came from one (None for an explicitly
    /// listed setting).
    pub grid: Option<&'a str>,
    /// The overridden keys and their values, in the sweep file's order,
    /// e.g. ("guided.epsilon", json!(0.05)), ("ga.crossover",
    /// json!("buckland")).
    pub values: Vec<(String, Value)>,
    /// The setting's summary exactly as its own experiment folder's
    /// summary.json holds it ([`Summary::new`] over its records).
    pub summary: &'a Summary,
    /// The setting's trial records (all methods).
    pub records: &'a [TrialRecord],
}

/// A grid of the sweep: its name and its keys in order; the plots are
/// drawn per grid.
pub struct GridInput<'a> {
    pub name: &'a str,
    pub keys: Vec<String>,
}

/// One overridden key of a setting and its value. A list of these rather
/// than a JSON object keeps the sweep file's order whatever map type
/// serde_json is built with.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SettingValue {
    pub key: String,
    pub value: Value,
}

/// How one GA method did under a setting.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MethodRow {
    /// `ga` or `guided` in JSON.
    pub method: Method,
    pub trials: usize,
    pub landed: usize,
    pub success_rate: f64,
    /// Generations to a safe landing over the trials that landed, as the
    /// setting's [`Summary`] has them.
    pub generations: Option<Quartiles>,
    /// The bootstrap interval of `generations.median`, over the same
    /// sample ([`landed_generations`]).
    pub median_interval: Option<Interval>,
}

/// The general GA against the guided GA under a setting.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PairRow {
    pub pairs: usize,
    pub guided_fewer: usize,
    pub ga_fewer: usize,
    pub ties: usize,
    /// `guided_fewer / pairs`: the share of pairs the guided GA won (a tie
    /// is not a win).
    pub share_won: f64,
    /// The bootstrap interval of `share_won`, resampling pairs.
    pub share_won_interval: Option<Interval>,
    /// The two-sided p-value of the setting's Wilcoxon signed-rank test;
    /// `None` if no pair differs.
    pub wilcoxon_p: Option<f64>,
}

/// One row of the sweep table.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SettingRow {
    pub name: String,
    pub folder: String,
    pub grid: Option<String>,
    pub values: Vec<SettingValue>,
    /// The GA methods the setting ran, general GA first.
    pub methods: Vec<MethodRow>,
    /// Share of Q(λ) trials that landed at least once, if it ran.
    pub qlearning_success_rate: Option<f64>,
    /// `None` unless both GAs ran at least one trial of the same number.
    pub paired: Option<PairRow>,
}

impl SettingRow {
    /// The value the setting gives `key`, if it overrides it.
    pub fn value(&self, key: &str) -> Option<&Value> {
        self.values.iter().find(|v| v.key == key).map(|v| &v.value)
    }

    /// How `method` did, if it is a GA method the setting ran.
    pub fn method(&self, method: Method) -> Option<&MethodRow> {
        self.methods.iter().find(|m| m.method == method)
    }
}

/// The whole sweep: what every setting shares, and a row per setting in
/// the order given.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SweepSummary {
    pub name: String,
    pub seed: u64,
    /// Trials per method in each setting.
    pub trials: u64,
    /// Bootstrap resamples behind every interval.
    pub resamples: usize,
    /// The intervals' confidence level.
    pub level: f64,
    pub settings: Vec<SettingRow>,
}

/// The seed of one bootstrap in a sweep: a mix of the sweep's seed, the
/// setting's name and the quantity resampled (`ga`, `guided` or `share`).
/// Intervals are therefore byte-identical from run to run, and a setting
/// keeps its intervals when settings are added, removed or reordered
/// (which seeding by position would not give). Each quantity gets its own
/// stream so that the three intervals' Monte Carlo errors are independent.
///
/// The name and the quantity are hashed with 64-bit FNV-1a, with a 0xFF
/// byte between them (it never occurs in UTF-8, so ("ab", "c") and
/// ("a", "bc") differ), and the hash and seed are mixed by SplitMix64's
/// finaliser. Both are fixed here rather than taken from std's `Hasher`,
/// whose output may change between Rust releases.
pub fn bootstrap_seed(sweep_seed: u64, setting: &str, quantity: &str) -> u64 {
    const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
    const FNV_PRIME: u64 = 0x0100_0000_01b3;
    let bytes = setting.bytes().chain([0xff]).chain(quantity.bytes());
    let hash = bytes.fold(FNV_OFFSET, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(FNV_PRIME)
    });
    splitmix(sweep_seed ^ splitmix(hash))
}

/// SplitMix64's finaliser: every input bit moves about half the output's.
fn splitmix(x: u64) -> u64 {
    let x = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
    let x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    let x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^ (x >> 31)
}

/// A setting's value as a table shows it: a string as it is ("buckland",
/// not "\"buckland\""), anything else as JSON writes it (0.05, true,
/// `[1,2]`).
pub fn value_text(value: &Value) -> String {
    match value {
        Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

/// The sweep table of the settings of a sweep named `name`, run with `seed`
/// and `trials` trials per method in each setting. Every interval's
/// resamples are seeded by [`bootstrap_seed`], so the same records give
/// the same table, byte for byte, on every run.
pub fn sweep_summary(
    name: &str,
    seed: u64,
    trials: u64,
    settings: &[SettingInput],
) -> SweepSummary {
    SweepSummary {
        name: name.to_string(),
        seed,
        trials,
        resamples: RESAMPLES,
        level: LEVEL,
        settings: settings.iter().map(|s| setting_row(seed, s)).collect(),
    }
}

fn setting_row(sweep_seed: u64, input: &SettingInput) -> SettingRow {
    let seed = |quantity: &str| bootstrap_seed(sweep_seed, input.name, quantity);
    let methods = input
        .summary
        .methods
        .iter()
        .map(|m| MethodRow {
            method: m.method,
            trials: m.trials,
            landed: m.landed,
            success_rate: m.success_rate,
            generations: m.generations,
            median_interval: median_interval(
                &landed_generations(input.records, m.method),
                seed(m.method.name()),
            ),
        })
        .collect();
    let paired = input.summary.paired.as_ref().map(|p| {
        let wins: Vec<bool> = pairs(input.records)
            .into_iter()
            .map(|(ga, guided)| guided_fewer(ga, guided))
            .collect();
        PairRow {
            pairs: p.pairs,
            guided_fewer: p.guided_fewer,
            ga_fewer: p.ga_fewer,
            ties: p.ties,
            share_won: if p.pairs == 0 {
                0.0
            } else {
                p.guided_fewer as f64 / p.pairs as f64
            },
            share_won_interval: share_interval(&wins, seed("share")),
            wilcoxon_p: p.wilcoxon.map(|w| w.p_value),
        }
    });
    SettingRow {
        name: input.name.to_string(),
        folder: input.folder.to_string(),
        grid: input.grid.map(str::to_string),
        values: input
            .values
            .iter()
            .map(|(key, value)| SettingValue {
                key: key.clone(),
                value: value.clone(),
            })
            .collect(),
        methods,
        qlearning_success_rate: input.summary.qlearning.as_ref().map(|q| q.success_rate),
        paired,
    }
}

/// A table as plain text cells, before Markdown or HTML: the header, then
/// one row per setting in order, the setting's name first.
pub(crate) struct Table {
    pub(crate) header: Vec<String>,
    pub(crate) rows: Vec<Vec<String>>,
}

impl SweepSummary {
    /// Every key any setting overrides, in the order first met.
    pub fn keys(&self) -> Vec<&str> {
        let mut keys: Vec<&str> = Vec::new();
        for v in self.settings.iter().flat_map(|s| &s.values) {
            if !keys.contains(&v.key.as_str()) {
                keys.push(&v.key);
            }
        }
        keys
    }

    /// The GA methods any setting ran, general GA first.
    pub fn methods(&self) -> Vec<Method> {
        [Method::Ga, Method::Guided]
            .into_iter()
            .filter(|&m| self.settings.iter().any(|s| s.method(m).is_some()))
            .collect()
    }

    /// Whether any setting ran Q(λ).
    pub fn has_qlearning(&self) -> bool {
        self.settings
            .iter()
            .any(|s| s.qlearning_success_rate.is_some())
    }

    /// The table as CSV, one row per setting: `setting`, `grid`, a column
    /// per key of [`keys`](Self::keys) (empty where a setting leaves the
    /// key alone), then for each GA method `m` of
    /// [`methods`](Self::methods) `m_trials`, `m_landed`,
    /// `m_success_rate`, `m_generations_q1`, `m_generations_median`,
    /// `m_generations_q3`, `m_median_low`, `m_median_high`;
    /// `qlearning_success_rate` if any setting ran Q(λ); and `pairs`,
    /// `guided_fewer`, `ga_fewer`, `ties`, `share_won`, `share_won_low`,
    /// `share_won_high`, `wilcoxon_p`. A value that does not exist is an
    /// empty cell; numbers are written in the shortest form that reads
    /// back to the same `f64`.
    pub fn csv(&self) -> Result<Vec<u8>, csv::Error> {
        let keys = self.keys();
        let methods = self.methods();
        let qlearning = self.has_qlearning();
        let mut header: Vec<String> = vec!["setting".into(), "grid".into()];
        header.extend(keys.iter().map(|k| k.to_string()));
        for m in &methods {
            for column in [
                "trials",
                "landed",
                "success_rate",
                "generations_q1",
                "generations_median",
                "generations_q3",
                "median_low",
                "median_high",
            ] {
                header.push(format!("{}_{column}", m.name()));
            }
        }
        if qlearning {
            header.push("qlearning_success_rate".into());
        }
        header.extend(
            [
                "pairs",
                "guided_fewer",
                "ga_fewer",
                "ties",
                "share_won",
                "share_won_low",
                "share_won_high",
                "wilcoxon_p",
            ]
            .map(String::from),
        );

        let mut out = csv::Writer::from_writer(Vec::new());
        out.write_record(&header)?;
        for s in &self.settings {
            let mut row: Vec<String> = vec![s.name.clone(), s.grid.clone().unwrap_or_default()];
            row.extend(
                keys.iter()
                    .map(|k| s.value(k).map(value_text).unwrap_or_default()),
            );
            for &m in &methods {
                let r = s.method(m);
                let q = r.and_then(|r| r.generations);
                let i = r.and_then(|r| r.median_interval);
                row.extend([
                    cell(r.map(|r| r.trials)),
                    cell(r.map(|r| r.landed)),
                    cell(r.map(|r| r.success_rate)),
                    cell(q.map(|q| q.q1)),
                    cell(q.map(|q| q.median)),
                    cell(q.map(|q| q.q3)),
                    cell(i.map(|i| i.low)),
                    cell(i.map(|i| i.high)),
                ]);
            }
            if qlearning {
                row.push(cell(s.qlearning_success_rate));
            }
            let p = s.paired.as_ref();
            let i = p.and_then(|p| p.share_won_interval);
            row.extend([
                cell(p.map(|p| p.pairs)),
                cell(p.map(|p| p.guided_fewer)),
                cell(p.map(|p| p.ga_fewer)),
                cell(p.map(|p| p.ties)),
                cell(p.map(|p| p.share_won)),
                cell(i.map(|i| i.low)),
                cell(i.map(|i| i.high)),
                cell(p.and_then(|p| p.wilcoxon_p)),
            ]);
            out.write_record(&row)?;
        }
        out.into_inner().map_err(|e| e.into_error().into())
    }

    /// The table as Markdown: a title, what the numbers are, the paper's
    /// figure to compare with, and the table.
    pub fn markdown(&self) -> String {
        let mut md = String::new();
        let _ = writeln!(md, "# Sweep `{}`\n", self.name);
        let _ = writeln!(md, "{}\n", self.description());
        let _ = writeln!(md, "{}\n", paper_note());
        let table = self.table();
        let line = |cells: &[String]| {
            let cells: Vec<String> = cells.iter().map(|c| c.replace('|', "\\|")).collect();
            format!("| {} |\n", cells.join(" | "))
        };
        md.push_str(&line(&table.header));
        let _ = writeln!(md, "|{}", "---|".repeat(table.header.len()));
        for row in &table.rows {
            md.push_str(&line(row));
        }
        md
    }

    /// What the table holds: settings, trials, seed, and how the intervals
    /// were found. One sentence for both the Markdown and the page.
    pub(crate) fn description(&self) -> String {
        let settings = match self.settings.len() {
            1 => "1 setting".to_string(),
            n => format!("{n} settings"),
        };
        format!(
            "{settings}, {} trials per method in each, seed {}. Medians are over the trials that landed; medians and shares come with {} percentile bootstrap intervals over {} resamples, in parentheses.",
            self.trials,
            self.seed,
            percent(self.level),
            thousands(self.resamples as f64),
        )
    }

    /// The table as plain text: the setting's name, its values, then per
    /// GA method landings and median [Q1, Q3] (interval), the Q(λ)
    /// success rate if any setting ran it, and the pairs.
    pub(crate) fn table(&self) -> Table {
        let keys = self.keys();
        let methods = self.methods();
        let qlearning = self.has_qlearning();
        let level = percent(self.level);
        let mut header = vec!["Setting".to_string()];
        header.extend(keys.iter().map(|k| k.to_string()));
        for m in &methods {
            header.push(format!("{}: landed", m.label()));
            header.push(format!(
                "{}: generations, median [Q1, Q3] ({level} CI)",
                m.label()
            ));
        }
        if qlearning {
            header.push(format!("{}: landed", Method::Qlearning.label()));
        }
        header.push("Pairs: guided fewer / general fewer / ties".into());
        header.push(format!("Share won by the guided GA ({level} CI)"));
        header.push("Wilcoxon p".into());

        let rows = self
            .settings
            .iter()
            .map(|s| {
                let mut row = vec![s.name.clone()];
                row.extend(
                    keys.iter()
                        .map(|k| s.value(k).map_or(DASH.into(), value_text)),
                );
                for &m in &methods {
                    let Some(r) = s.method(m) else {
                        row.extend([DASH.into(), DASH.into()]);
                        continue;
                    };
                    row.push(format!(
                        "{} of {} ({})",
                        r.landed,
                        r.trials,
                        percent(r.success_rate)
                    ));
                    row.push(r.generations.map_or(DASH.into(), |q| {
                        format!(
                            "{} [{}, {}]{}",
                            num(q.median),
                            num(q.q1),
                            num(q.q3),
                            interval_text(r.median_interval)
                        )
                    }));
                }
                if qlearning {
                    row.push(s.qlearning_success_rate.map_or(DASH.into(), percent));
                }
                match &s.paired {
                    Some(p) => {
                        row.push(format!(
                            "{} / {} / {} of {}",
                            p.guided_fewer, p.ga_fewer, p.ties, p.pairs
                        ));
                        row.push(format!(
                            "{}{}",
                            num(p.share_won),
                            interval_text(p.share_won_interval)
                        ));
                        row.push(p.wilcoxon_p.map_or(DASH.into(), pvalue));
                    }
                    None => row.extend([DASH.into(), DASH.into(), DASH.into()]),
                }
                row
            })
            .collect();
        Table { header, rows }
    }
}

/// The paper's result, for the reader to hold a sweep against.
pub(crate) fn paper_note() -> String {
    let (won, of) = PAPER_PAIRS_WON;
    format!(
        "For comparison, the paper's guided GA needed fewer generations than its general GA in {won} of {of} pairs (share {}).",
        num(PAPER_SHARE_WON)
    )
}

/// What a table shows for a value that does not exist.
const DASH: &str = "–";

/// A CSV cell: the value, or empty.
fn cell<T: ToString>(value: Option<T>) -> String {
    value.map(|v| v.to_string()).unwrap_or_default()
}

/// " (low–high)", or nothing without an interval.
fn interval_text(interval: Option<Interval>) -> String {
    interval.map_or(String::new(), |i| {
        format!(" ({}–{})", num(i.low), num(i.high))
    })
}

/// A share as a whole percentage: 0.95 → "95%".
fn percent(share: f64) -> String {
    format!("{:.0}%", 100.0 * share)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::model::Learning;
    use serde_json::json;

    pub(crate) fn trial(method: Method, trial: u64, generations: u64, landed: bool) -> TrialRecord {
        TrialRecord {
            method,
            seed: 1,
            trial,
            x0: 1.0,
            pad_x: 100.0,
            landed,
            generations: Some(generations),
            restarts: Some(u64::from(!landed)),
            episodes: None,
            wall_s: 1.0,
            fitness: Vec::new(),
            best: None,
            learning: None,
        }
    }

    fn learner(trial: u64, first_safe: Option<u32>) -> TrialRecord {
        TrialRecord {
            generations: None,
            restarts: None,
            episodes: first_safe,
            landed: first_safe.is_some(),
            learning: Some(Learning {
                episodes: 100,
                first_safe,
                landing_rate_last_100: 0.0,
                returns: vec![0.0; 100],
            }),
            ..self::trial(Method::Qlearning, trial, 0, false)
        }
    }

    /// Two settings of three trials, worked by hand.
    ///
    /// Setting a (ε = 0): generations (ga, guided) = (40, 10), (30, 30)
    /// with the general GA not landing, (5, 20). Guided fewer once (trial
    /// 1), general fewer once (trial 3), one tie.
    ///
    /// Setting b (ε = 0.1, crossover buckland): (50, 12), (44, 20),
    /// (9, 11). Guided fewer twice, general once; Q(λ) landed in 1 of 2.
    pub(crate) fn records() -> [Vec<TrialRecord>; 2] {
        [
            vec![
                trial(Method::Ga, 1, 40, true),
                trial(Method::Guided, 1, 10, true),
                trial(Method::Ga, 2, 30, false),
                trial(Method::Guided, 2, 30, true),
                trial(Method::Ga, 3, 5, true),
                trial(Method::Guided, 3, 20, true),
            ],
            vec![
                trial(Method::Ga, 1, 50, true),
                trial(Method::Guided, 1, 12, true),
                trial(Method::Ga, 2, 44, true),
                trial(Method::Guided, 2, 20, true),
                trial(Method::Ga, 3, 9, true),
                trial(Method::Guided, 3, 11, true),
                learner(1, Some(40)),
                learner(2, None),
            ],
        ]
    }

    /// The sweep of [`records`]: setting a in grid `epsilon`, b listed on
    /// its own.
    pub(crate) fn sample_with(records: &[Vec<TrialRecord>; 2]) -> (SweepSummary, [Summary; 2]) {
        let summaries = [
            Summary::new("a", 9, 3, &records[0]),
            Summary::new("b", 9, 3, &records[1]),
        ];
        let settings = [
            SettingInput {
                name: "epsilon/guided.epsilon=0",
                folder: "settings/epsilon-guided.epsilon-0",
                grid: Some("epsilon"),
                values: vec![("guided.epsilon".into(), json!(0.0))],
                summary: &summaries[0],
                records: &records[0],
            },
            SettingInput {
                name: "b, with buckland",
                folder: "settings/b",
                grid: None,
                values: vec![
                    ("guided.epsilon".into(), json!(0.1)),
                    ("ga.crossover".into(), json!("buckland")),
                ],
                summary: &summaries[1],
                records: &records[1],
            },
        ];
        (sweep_summary("grid", 9, 3, &settings), summaries)
    }

    #[test]
    fn rows_agree_with_each_settings_summary() {
        let records = records();
        let (sweep, summaries) = sample_with(&records);
        assert_eq!((sweep.resamples, sweep.level), (RESAMPLES, LEVEL));
        assert_eq!(sweep.settings.len(), 2);
        for (row, summary) in sweep.settings.iter().zip(&summaries) {
            assert_eq!(row.methods.len(), summary.methods.len());
            for (r, m) in row.methods.iter().zip(&summary.methods) {
                assert_eq!(r.method, m.method);
                assert_eq!((r.trials, r.landed), (m.trials, m.landed));
                assert_eq!(r.success_rate, m.success_rate);
                assert_eq!(r.generations, m.generations);
            }
        }
        // Setting a's general GA landed at 40 and 5: quartiles 13.75, 22.5,
        // 31.25 (type 7).
        let ga = sweep.settings[0].method(Method::Ga).unwrap();
        let q = ga.generations.unwrap();
        assert_eq!((ga.landed, q.q1, q.median, q.q3), (2, 13.75, 22.5, 31.25));
        assert_eq!(sweep.settings[0].qlearning_success_rate, None);
        assert_eq!(sweep.settings[1].qlearning_success_rate, Some(0.5));
        assert_eq!(
            sweep.settings[1].value("ga.crossover"),
            Some(&json!("buckland"))
        );
        assert_eq!(sweep.settings[0].value("ga.crossover"), None);
    }

    #[test]
    fn pairs_and_shares_by_hand() {
        let records = records();
        let (sweep, _) = sample_with(&records);
        let a = sweep.settings[0].paired.as_ref().unwrap();
        assert_eq!((a.pairs, a.guided_fewer, a.ga_fewer, a.ties), (3, 1, 1, 1));
        assert_eq!(a.share_won, 1.0 / 3.0);
        let b = sweep.settings[1].paired.as_ref().unwrap();
        assert_eq!((b.pairs, b.guided_fewer, b.ga_fewer, b.ties), (3, 2, 1, 0));
        assert_eq!(b.share_won, 2.0 / 3.0);
        // b's differences 38, 24, −2: ranks 3 (+), 2 (+), 1 (−); W+ = 5 of
        // 6, which 2 of the 8 sign patterns reach or pass: p = 2·2/8.
        assert_eq!(b.wilcoxon_p, Some(0.5));
    }

    #[test]
    fn intervals_hold_their_point_estimates() {
        let records = records();
        let (sweep, _) = sample_with(&records);
        for row in &sweep.settings {
            for m in &row.methods {
                let (Some(q), Some(i)) = (m.generations, m.median_interval) else {
                    panic!("{}: landed trials have a median and its interval", row.name);
                };
                assert!(i.low <= q.median && q.median <= i.high, "{i:?} {q:?}");
            }
            let p = row.paired.as_ref().unwrap();
            let i = p.share_won_interval.unwrap();
            assert!(i.low <= p.share_won && p.share_won <= i.high, "{i:?}");
            // Three pairs can give shares 0, ⅓, ⅔ and 1 only.
            assert!(i.low >= 0.0 && i.high <= 1.0);
        }
        // The same inputs give the same table.
        assert_eq!(sample_with(&records).0, sweep);
    }

    #[test]
    fn bootstrap_seeds_depend_on_seed_setting_and_quantity() {
        let base = bootstrap_seed(9, "a", "ga");
        assert_ne!(base, bootstrap_seed(10, "a", "ga"));
        assert_ne!(base, bootstrap_seed(9, "b", "ga"));
        assert_ne!(base, bootstrap_seed(9, "a", "guided"));
        assert_ne!(bootstrap_seed(9, "ab", "c"), bootstrap_seed(9, "a", "bc"));
        // Pinned, like the bootstrap's stream: a sweep's intervals must not
        // change between builds.
        assert_eq!(base, 9_744_012_344_443_160_502);
    }

    #[test]
    fn the_csv_reads_back() {
        let records = records();
        let (sweep, _) = sample_with(&records);
        let bytes = sweep.csv().unwrap();
        let mut reader = csv::Reader::from_reader(bytes.as_slice());
        let header: Vec<String> = reader.headers().unwrap().iter().map(String::from).collect();
        let expected: Vec<&str> = vec![
            "setting",
            "grid",
            "guided.epsilon",
            "ga.crossover",
            "ga_trials",
            "ga_landed",
            "ga_success_rate",
            "ga_generations_q1",
            "ga_generations_median",
            "ga_generations_q3",
            "ga_median_low",
            "ga_median_high",
            "guided_trials",
            "guided_landed",
            "guided_success_rate",
            "guided_generations_q1",
            "guided_generations_median",
            "guided_generations_q3",
            "guided_median_low",
            "guided_median_high",
            "qlearning_success_rate",
            "pairs",
            "guided_fewer",
            "ga_fewer",
            "ties",
            "share_won",
            "share_won_low",
            "share_won_high",
            "wilcoxon_p",
        ];
        assert_eq!(header, expected);
        let rows: Vec<csv::StringRecord> = reader.records().map(|r| r.unwrap()).collect();
        assert_eq!(rows.len(), 2);
        let get = |row: usize, column: &str| {
            let at = expected.iter().position(|c| *c == column).unwrap();
            rows[row].get(at).unwrap().to_string()
        };
        assert_eq!(get(0, "setting"), "epsilon/guided.epsilon=0");
        assert_eq!(get(0, "grid"), "epsilon");
        assert_eq!(get(0, "guided.epsilon"), "0.0");
        assert_eq!(get(0, "ga.crossover"), "");
        assert_eq!(get(0, "ga_landed"), "2");
        assert_eq!(get(0, "ga_generations_q1"), "13.75");
        assert_eq!(get(0, "ga_generations_median"), "22.5");
        assert_eq!(get(0, "qlearning_success_rate"), "");
        assert_eq!(get(0, "guided_fewer"), "1");
        assert_eq!(get(0, "share_won").parse::<f64>().unwrap(), 1.0 / 3.0);
        // The comma in the name survives the quoting.
        assert_eq!(get(1, "setting"), "b, with buckland");
        assert_eq!(get(1, "grid"), "");
        assert_eq!(get(1, "guided.epsilon"), "0.1");
        assert_eq!(get(1, "ga.crossover"), "buckland");
        assert_eq!(get(1, "qlearning_success_rate"), "0.5");
        assert_eq!(get(1, "wilcoxon_p"), "0.5");
        let row = &sweep.settings[1];
        let i = row.paired.as_ref().unwrap().share_won_interval.unwrap();
        assert_eq!(get(1, "share_won_low").parse::<f64>().unwrap(), i.low);
        assert_eq!(get(1, "share_won_high").parse::<f64>().unwrap(), i.high);
        let m = row.method(Method::Guided).unwrap().median_interval.unwrap();
        assert_eq!(get(1, "guided_median_low").parse::<f64>().unwrap(), m.low);
    }

    #[test]
    fn the_csv_leaves_out_what_no_setting_ran() {
        let ga_only: Vec<TrialRecord> = vec![trial(Method::Ga, 1, 7, true)];
        let summary = Summary::new("g", 1, 1, &ga_only);
        let sweep = sweep_summary(
            "g",
            1,
            1,
            &[SettingInput {
                name: "only",
                folder: "settings/only",
                grid: None,
                values: Vec::new(),
                summary: &summary,
                records: &ga_only,
            }],
        );
        let text = String::from_utf8(sweep.csv().unwrap()).unwrap();
        let mut lines = text.lines();
        let header = lines.next().unwrap();
        assert!(header.starts_with("setting,grid,ga_trials,"), "{header}");
        assert!(!header.contains("guided_trials") && !header.contains("qlearning"));
        assert!(header.ends_with(
            ",pairs,guided_fewer,ga_fewer,ties,share_won,share_won_low,share_won_high,wilcoxon_p"
        ));
        assert_eq!(lines.next(), Some("only,,1,1,1,7,7,7,7,7,,,,,,,,"));
    }

    #[test]
    fn the_markdown_shows_every_part() {
        let records = records();
        let (sweep, _) = sample_with(&records);
        let md = sweep.markdown();
        let ga = sweep.settings[0].method(Method::Ga).unwrap();
        let i = ga.median_interval.unwrap();
        let a = &sweep.settings[0].paired.as_ref().unwrap();
        let share = a.share_won_interval.unwrap();
        for part in [
            "# Sweep `grid`".to_string(),
            "2 settings, 3 trials per method in each, seed 9.".into(),
            "95% percentile bootstrap intervals over 10,000 resamples".into(),
            "in 24 of 25 pairs (share 0.96)".into(),
            "| Setting | guided.epsilon | ga.crossover | general GA: landed |".into(),
            format!(
                "| epsilon/guided.epsilon=0 | 0.0 | – | 2 of 3 (67%) | 22.5 [13.75, 31.25] ({}–{}) |",
                num(i.low),
                num(i.high)
            ),
            format!(
                "| 1 / 1 / 1 of 3 | 0.33 ({}–{}) | 1.0000 |",
                num(share.low),
                num(share.high)
            ),
            "| b, with buckland | 0.1 | buckland |".into(),
            "| 50% | 2 / 1 / 0 of 3 |".into(),
        ] {
            assert!(md.contains(&part), "missing {part:?} in\n{md}");
        }
    }

    #[test]
    fn a_pipe_in_a_name_does_not_break_the_markdown_table() {
        let records = records();
        let summary = Summary::new("p", 1, 3, &records[0]);
        let sweep = sweep_summary(
            "p",
            1,
            3,
            &[SettingInput {
                name: "a|b",
                folder: "settings/a",
                grid: None,
                values: vec![("ga.crossover".into(), json!("x|y"))],
                summary: &summary,
                records: &records[0],
            }],
        );
        let md = sweep.markdown();
        assert!(md.contains("| a\\|b | x\\|y |"), "{md}");
    }

    #[test]
    fn values_read_as_written() {
        assert_eq!(value_text(&json!("buckland")), "buckland");
        assert_eq!(value_text(&json!(0.05)), "0.05");
        assert_eq!(value_text(&json!(3)), "3");
        assert_eq!(value_text(&json!(true)), "true");
    }
}
