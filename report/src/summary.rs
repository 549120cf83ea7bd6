//! The experiment's summary: per-method success and generations, the paired
//! comparison of the two GAs, the Q(λ) results, and the paper's statements
//! each checked against the data. [`Summary::markdown`] renders it for
//! `summary.md` and the terminal; the report page builds its own HTML from
//! the same [`Summary`].

use crate::model::{Method, TrialRecord};
use crate::stats::{mean, quartiles, wilcoxon_signed_rank, Quartiles, Wilcoxon};
use serde::Serialize;
use std::fmt::Write;

/// How one GA method did over its trials.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MethodSummary {
    /// `ga` or `guided` in JSON.
    pub method: Method,
    pub trials: usize,
    pub landed: usize,
    pub success_rate: f64,
    /// Generations to a safe landing, counted across restarts, over the
    /// trials that landed.
    pub generations: Option<Quartiles>,
    pub mean_restarts: Option<f64>,
    pub mean_wall_s: Option<f64>,
}

/// The general GA against the guided GA, trial by trial.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Paired {
    /// Trials both GAs ran: see [`pairs()`].
    pub pairs: usize,
    /// Pairs in which the guided GA needed fewer generations ([`guided_fewer`]).
    pub guided_fewer: usize,
    pub ga_fewer: usize,
    pub ties: usize,
    /// On generations flown (general minus guided). A trial that never
    /// landed counts with every generation it flew, a lower bound.
    pub wilcoxon: Option<Wilcoxon>,
    /// Pairs in which the guided GA's mean fitness was above the general
    /// GA's in every generation both flew.
    pub guided_mean_higher_throughout: usize,
    /// Of the generations both flew, summed over pairs, the share in which
    /// the guided GA's mean fitness was higher.
    pub guided_mean_higher_share: f64,
}

/// How the Q(λ) baseline did.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LearningSummary {
    pub trials: usize,
    pub episodes: u32,
    /// Trials with at least one safe landing.
    pub landed: usize,
    pub success_rate: f64,
    /// Episodes to the first landing, over the trials that landed.
    pub first_landing: Option<Quartiles>,
    pub mean_final_landing_rate: f64,
}

/// A statement the paper makes, and whether this experiment bears it out.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Claim {
    pub paper: String,
    pub measured: String,
    pub holds: bool,
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Summary {
    pub name: String,
    pub seed: u64,
    pub trials: u64,
    pub methods: Vec<MethodSummary>,
    pub paired: Option<Paired>,
    pub qlearning: Option<LearningSummary>,
    pub claims: Vec<Claim>,
}

fn of(records: &[TrialRecord], method: Method) -> impl Iterator<Item = &TrialRecord> {
    records.iter().filter(move |r| r.method == method)
}

fn rate(part: usize, whole: usize) -> f64 {
    if whole == 0 {
        0.0
    } else {
        part as f64 / whole as f64
    }
}

impl Summary {
    /// Summarises the records of an experiment named `name`.
    pub fn new(name: &str, seed: u64, trials: u64, records: &[TrialRecord]) -> Summary {
        let methods: Vec<MethodSummary> = [Method::Ga, Method::Guided]
            .into_iter()
            .filter(|&m| of(records, m).next().is_some())
            .map(|m| method_summary(records, m))
            .collect();
        let paired = paired(records);
        let qlearning = learning_summary(records);
        let mut summary = Summary {
            name: name.to_string(),
            seed,
            trials,
            methods,
            paired,
            qlearning,
            claims: Vec::new(),
        };
        summary.claims = claims(&summary);
        summary
    }

    /// How `method` did, if it is a GA method with records.
    pub fn method(&self, method: Method) -> Option<&MethodSummary> {
        self.methods.iter().find(|m| m.method == method)
    }

    /// The summary as Markdown: the headline table, the comparison, the
    /// Q(λ) results and the paper's statements.
    pub fn markdown(&self) -> String {
        let mut md = String::new();
        let _ = writeln!(md, "# Experiment `{}`\n", self.name);
        let _ = writeln!(
            md,
            "{} trials per method, seed {}.\n",
            self.trials, self.seed
        );
        if !self.methods.is_empty() {
            md.push_str("| Method | Trials | Landed | Success | Generations to land: median [Q1, Q3] | Mean restarts |\n");
            md.push_str("|---|---|---|---|---|---|\n");
            for m in &self.methods {
                let _ = writeln!(
                    md,
                    "| {} | {} | {} | {:.0}% | {} | {} |",
                    m.method.label(),
                    m.trials,
                    m.landed,
                    100.0 * m.success_rate,
                    m.generations.map_or("–".into(), |q| format!(
                        "{} [{}, {}]",
                        num(q.median),
                        num(q.q1),
                        num(q.q3)
                    )),
                    m.mean_restarts.map_or("–".into(), |r| format!("{r:.2}")),
                );
            }
            md.push('\n');
        }
        if let Some(p) = &self.paired {
            let _ = writeln!(md, "## General GA against guided GA\n");
            let _ = writeln!(
                md,
                "In {} of {} paired trials the guided GA needed fewer generations; the general GA needed fewer in {}, and {} were ties.\n",
                p.guided_fewer, p.pairs, p.ga_fewer, p.ties
            );
            match &p.wilcoxon {
                Some(w) => {
                    let _ = writeln!(
                        md,
                        "Wilcoxon signed-rank test on generations (general − guided): n = {} non-zero pairs, W+ = {}, W− = {}, two-sided p = {} ({}).\n",
                        w.n,
                        num(w.w_plus),
                        num(w.w_minus),
                        pvalue(w.p_value),
                        if w.exact { "exact" } else { "normal approximation" }
                    );
                }
                None => md.push_str("No pair differs, so there is no signed-rank test.\n\n"),
            }
            let _ = writeln!(
                md,
                "The guided GA's mean fitness was higher in every generation of {} of {} pairs, and in {:.1}% of all generations both flew.\n",
                p.guided_mean_higher_throughout,
                p.pairs,
                100.0 * p.guided_mean_higher_share
            );
            md.push_str("A trial that never landed counts with every generation it flew, a lower bound.\n\n");
        }
        if let Some(q) = &self.qlearning {
            let _ = writeln!(md, "## Q(λ)\n");
            let _ = writeln!(
                md,
                "{} of {} trials landed at least once in {} episodes{}; the mean landing rate over the last 100 episodes was {:.1}%.\n",
                q.landed,
                q.trials,
                q.episodes,
                q.first_landing.map_or(String::new(), |f| format!(
                    " (first landing: median episode {} [{}, {}])",
                    num(f.median),
                    num(f.q1),
                    num(f.q3)
                )),
                100.0 * q.mean_final_landing_rate
            );
        }
        if !self.claims.is_empty() {
            let _ = writeln!(md, "## The paper's statements\n");
            md.push_str("| The paper says | Measured here | Holds |\n|---|---|---|\n");
            for c in &self.claims {
                let _ = writeln!(
                    md,
                    "| {} | {} | {} |",
                    c.paper,
                    c.measured,
                    if c.holds { "yes" } else { "no" }
                );
            }
        }
        md
    }
}

/// A number without needless decimals: 12, 12.5, 12.25.
pub fn num(x: f64) -> String {
    let s = format!("{x:.2}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

pub fn pvalue(p: f64) -> String {
    if p < 0.001 {
        format!("{p:.2e}")
    } else {
        format!("{p:.4}")
    }
}

/// The generations of `method`'s trials that landed: the sample behind
/// [`MethodSummary::generations`] (and a sweep's interval of its median).
pub fn landed_generations(records: &[TrialRecord], method: Method) -> Vec<f64> {
    of(records, method)
        .filter(|r| r.landed)
        .filter_map(|r| r.generations)
        .map(|g| g as f64)
        .collect()
}

/// The general GA's records paired with the guided GA's of the same trial
/// number, in the order of the general GA's records; a trial without a
/// partner is left out. These are the pairs of [`Paired`].
pub fn pairs(records: &[TrialRecord]) -> Vec<(&TrialRecord, &TrialRecord)> {
    of(records, Method::Ga)
        .filter_map(|g| {
            of(records, Method::Guided)
                .find(|r| r.trial == g.trial)
                .map(|r| (g, r))
        })
        .collect()
}

/// The generations a trial flew, as a pair compares them: a trial that
/// never landed counts with every generation it flew (a lower bound of what
/// it would have needed), a record without a count as 0.
pub fn flown(record: &TrialRecord) -> f64 {
    record.generations.unwrap_or(0) as f64
}

/// Whether the guided GA needed fewer generations than the general GA in
/// a pair (by [`flown`]): what [`Paired::guided_fewer`] counts. A tie is
/// not a win.
pub fn guided_fewer(ga: &TrialRecord, guided: &TrialRecord) -> bool {
    flown(guided) < flown(ga)
}

fn method_summary(records: &[TrialRecord], method: Method) -> MethodSummary {
    let trials: Vec<&TrialRecord> = of(records, method).collect();
    let landed = landed_generations(records, method);
    let restarts: Vec<f64> = trials
        .iter()
        .filter_map(|r| r.restarts)
        .map(|r| r as f64)
        .collect();
    let wall: Vec<f64> = trials.iter().map(|r| r.wall_s).collect();
    MethodSummary {
        method,
        trials: trials.len(),
        landed: landed.len(),
        success_rate: rate(landed.len(), trials.len()),
        generations: quartiles(&landed),
        mean_restarts: mean(&restarts),
        mean_wall_s: mean(&wall),
    }
}

fn paired(records: &[TrialRecord]) -> Option<Paired> {
    let pairs = pairs(records);
    if pairs.is_empty() {
        return None;
    }
    let ga: Vec<f64> = pairs.iter().map(|(g, _)| flown(g)).collect();
    let guided: Vec<f64> = pairs.iter().map(|(_, r)| flown(r)).collect();
    let count =
        |f: fn(f64, f64) -> bool| ga.iter().zip(&guided).filter(|(a, b)| f(**a, **b)).count();
    let (mut throughout, mut higher, mut common) = (0, 0, 0);
    for (g, r) in &pairs {
        let both = g.fitness.len().min(r.fitness.len());
        let above = g
            .fitness
            .iter()
            .zip(&r.fitness)
            .filter(|(a, b)| b.mean > a.mean)
            .count();
        throughout += usize::from(both > 0 && above == both);
        higher += above;
        common += both;
    }
    Some(Paired {
        pairs: pairs.len(),
        guided_fewer: pairs.iter().filter(|(g, r)| guided_fewer(g, r)).count(),
        ga_fewer: count(|a, b| a < b),
        ties: count(|a, b| a == b),
        wilcoxon: wilcoxon_signed_rank(&ga, &guided),
        guided_mean_higher_throughout: throughout,
        guided_mean_higher_share: rate(higher, common),
    })
}

fn learning_summary(records: &[TrialRecord]) -> Option<LearningSummary> {
    let trials: Vec<_> = of(records, Method::Qlearning)
        .filter_map(|r| r.learning.as_ref())
        .collect();
    if trials.is_empty() {
        return None;
    }
    let first: Vec<f64> = trials
        .iter()
        .filter_map(|l| l.first_safe)
        .map(f64::from)
        .collect();
    let rates: Vec<f64> = trials.iter().map(|l| l.landing_rate_last_100).collect();
    Some(LearningSummary {
        trials: trials.len(),
        episodes: trials.iter().map(|l| l.episodes).max().unwrap_or(0),
        landed: first.len(),
        success_rate: rate(first.len(), trials.len()),
        first_landing: quartiles(&first),
        mean_final_landing_rate: mean(&rates).unwrap_or(0.0),
    })
}

/// The paper's statements that this experiment can test.
fn claims(s: &Summary) -> Vec<Claim> {
    let mut claims = Vec::new();
    let (ga, guided) = (s.method(Method::Ga), s.method(Method::Guided));
    if let Some(p) = &s.paired {
        claims.push(Claim {
            paper: "The guided GA needed fewer generations than the general GA in 24 of 25 trials (Figure 3).".into(),
            measured: format!("fewer in {} of {} pairs", p.guided_fewer, p.pairs),
            holds: p.guided_fewer * 25 >= p.pairs * 24,
        });
        if let Some(w) = &p.wilcoxon {
            claims.push(Claim {
                paper: "The guided GA performed much better than the general GA.".into(),
                measured: format!(
                    "Wilcoxon p = {}, guided fewer in {} of {} pairs",
                    pvalue(w.p_value),
                    p.guided_fewer,
                    p.pairs
                ),
                holds: w.p_value < 0.05 && p.guided_fewer > p.ga_fewer,
            });
        }
        claims.push(Claim {
            paper: "For all the trials observed, the guided GA's average fitness was higher than the general GA's (Figure 4).".into(),
            measured: format!(
                "higher in every generation of {} of {} pairs; in {:.1}% of generations",
                p.guided_mean_higher_throughout,
                p.pairs,
                100.0 * p.guided_mean_higher_share
            ),
            holds: p.guided_mean_higher_throughout == p.pairs,
        });
    }
    if let (Some(ga), Some(guided)) = (ga, guided) {
        claims.push(Claim {
            paper: "The general and the guided GA were able to achieve the goal almost every time."
                .into(),
            measured: format!(
                "general GA landed in {:.0}%, guided GA in {:.0}% of trials",
                100.0 * ga.success_rate,
                100.0 * guided.success_rate
            ),
            holds: ga.success_rate >= 0.9 && guided.success_rate >= 0.9,
        });
    }
    if let Some(guided) = guided {
        claims.push(Claim {
            paper: "The guided GA could guarantee to reach the goal.".into(),
            measured: format!("landed in {} of {} trials", guided.landed, guided.trials),
            holds: guided.trials > 0 && guided.landed == guided.trials,
        });
    }
    if let Some(q) = &s.qlearning {
        let best_ga = s.methods.iter().map(|m| m.success_rate).fold(0.0, f64::max);
        claims.push(Claim {
            paper: "It was very hard for Q-learning to complete the task.".into(),
            measured: format!(
                "Q(λ) landed at least once in {} of {} trials of {} episodes",
                q.landed, q.trials, q.episodes
            ),
            holds: q.success_rate < best_ga || (s.methods.is_empty() && q.success_rate < 0.5),
        });
    }
    claims
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{FitnessPoint, Learning};

    fn trial(
        method: Method,
        trial: u64,
        generations: u64,
        landed: bool,
        means: &[f64],
    ) -> TrialRecord {
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
            fitness: means
                .iter()
                .zip(1..)
                .map(|(&mean, index)| FitnessPoint {
                    index,
                    restart: 0,
                    best: mean + 1.0,
                    mean,
                })
                .collect(),
            best: None,
            learning: None,
        }
    }

    fn learner(trial: u64, first_safe: Option<u32>, rate: f64) -> TrialRecord {
        TrialRecord {
            method: Method::Qlearning,
            generations: None,
            restarts: None,
            episodes: first_safe,
            landed: first_safe.is_some(),
            learning: Some(Learning {
                episodes: 100,
                first_safe,
                landing_rate_last_100: rate,
                returns: vec![0.0; 100],
            }),
            ..self::trial(Method::Qlearning, trial, 0, false, &[])
        }
    }

    /// Three pairs worked by hand: generations (ga, guided) = (40, 10),
    /// (30, 30), (5, 20). Guided is fewer once, ga once, one tie.
    fn sample() -> Vec<TrialRecord> {
        vec![
            trial(Method::Ga, 1, 40, true, &[-5.0, -4.0, -3.0]),
            trial(Method::Guided, 1, 10, true, &[-2.0, -1.0]),
            trial(Method::Ga, 2, 30, false, &[-1.0, -1.0]),
            trial(Method::Guided, 2, 30, true, &[-2.0, 0.0]),
            trial(Method::Ga, 3, 5, true, &[-9.0]),
            trial(Method::Guided, 3, 20, true, &[-1.0]),
            learner(1, Some(40), 0.5),
            learner(2, None, 0.0),
        ]
    }

    #[test]
    fn methods_are_summarised_over_their_landed_trials() {
        let s = Summary::new("t", 1, 3, &sample());
        let ga = s.method(Method::Ga).unwrap();
        assert_eq!((ga.trials, ga.landed), (3, 2));
        assert!((ga.success_rate - 2.0 / 3.0).abs() < 1e-12);
        // Landed generations 40 and 5: type-7 quartiles 13.75, 22.5, 31.25.
        let q = ga.generations.unwrap();
        assert_eq!((q.q1, q.median, q.q3), (13.75, 22.5, 31.25));
        assert_eq!(ga.mean_restarts, Some(1.0 / 3.0));
        let guided = s.method(Method::Guided).unwrap();
        assert_eq!(guided.landed, 3);
        assert_eq!(guided.generations.unwrap().median, 20.0);
    }

    #[test]
    fn pairs_compare_generations_and_mean_fitness() {
        let p = Summary::new("t", 1, 3, &sample()).paired.unwrap();
        assert_eq!((p.pairs, p.guided_fewer, p.ga_fewer, p.ties), (3, 1, 1, 1));
        // Differences 30, 0, −15: the zero drops, ranks 2 (+) and 1 (−).
        let w = p.wilcoxon.unwrap();
        assert_eq!((w.n, w.w_plus, w.w_minus), (2, 2.0, 1.0));
        // Common generations: pair 1 has 2 (both higher), pair 2 has 2
        // (−2 < −1 no, 0 > −1 yes), pair 3 has 1 (yes): 4 of 5.
        assert_eq!(p.guided_mean_higher_throughout, 2);
        assert!((p.guided_mean_higher_share - 0.8).abs() < 1e-12);
    }

    #[test]
    fn learning_reports_first_landings_and_final_rates() {
        let q = Summary::new("t", 1, 2, &sample()).qlearning.unwrap();
        assert_eq!((q.trials, q.landed, q.episodes), (2, 1, 100));
        assert_eq!(q.first_landing.unwrap().median, 40.0);
        assert_eq!(q.mean_final_landing_rate, 0.25);
    }

    #[test]
    fn claims_are_judged_against_the_data() {
        let s = Summary::new("t", 1, 3, &sample());
        let holds = |start: &str| {
            s.claims
                .iter()
                .find(|c| c.paper.starts_with(start))
                .map(|c| c.holds)
                .unwrap()
        };
        assert!(!holds("The guided GA needed fewer generations"));
        assert!(!holds("For all the trials"));
        assert!(!holds("The general and the guided GA"));
        assert!(holds("The guided GA could guarantee"));
        assert!(holds("It was very hard for Q-learning"));
    }

    #[test]
    fn the_markdown_shows_every_part() {
        let md = Summary::new("paper", 1, 3, &sample()).markdown();
        for part in [
            "| general GA | 3 | 2 | 67% | 22.5 [13.75, 31.25] | 0.33 |",
            "In 1 of 3 paired trials",
            "W+ = 2, W− = 1",
            "1 of 2 trials landed at least once in 100 episodes",
            "## The paper's statements",
        ] {
            assert!(md.contains(part), "missing {part:?} in\n{md}");
        }
    }

    #[test]
    fn no_records_summarise_to_nothing() {
        let s = Summary::new("empty", 1, 0, &[]);
        assert!(s.methods.is_empty() && s.paired.is_none() && s.qlearning.is_none());
        assert!(s.claims.is_empty());
    }
}
