//! The sweep file: grids expanded, keys and values checked, errors naming
//! the grid or setting and the key.

use super::*;
use crate::ga::Crossover;

fn parse(text: &str) -> Result<Sweep, String> {
    Sweep::parse(text, false)
}

const BASE: &str = "name = \"s\"\ntrials = 3\nmethods = [\"ga\", \"guided\"]\n";

#[test]
fn a_grid_is_every_combination_with_the_last_key_fastest() {
    let sweep = parse(&format!(
        "{BASE}[grids.g]\n\"ga.population\" = [20, 40]\n\"guided.epsilon\" = [0.0, 0.1, 0.2]\n"
    ))
    .unwrap();
    assert_eq!(sweep.settings.len(), 6);
    let got: Vec<(u64, f64)> = sweep
        .settings
        .iter()
        .map(|s| {
            (
                s.experiment.ga.population as u64,
                s.experiment.guided.epsilon,
            )
        })
        .collect();
    assert_eq!(
        got,
        [
            (20, 0.0),
            (20, 0.1),
            (20, 0.2),
            (40, 0.0),
            (40, 0.1),
            (40, 0.2)
        ]
    );
    let first = &sweep.settings[0];
    assert_eq!(first.name, "g: ga.population=20, guided.epsilon=0.0");
    assert_eq!(first.folder, "g-ga.population-20-guided.epsilon-0.0");
    assert_eq!(first.grid.as_deref(), Some("g"));
    // Everything else is the base's.
    assert_eq!(first.experiment.trials, 3);
    assert_eq!(first.experiment.seed, sweep.base.seed);
    assert_eq!(first.experiment.ga.elites, sweep.base.ga.elites);
    assert_eq!(sweep.base.ga.population, 100);
}

#[test]
fn dotted_quoted_and_nested_keys_say_the_same() {
    let quoted = parse(&format!(
        "{BASE}[grids.g]\n\"ga.crossover\" = [\"buckland\"]\n"
    ))
    .unwrap();
    let dotted = parse(&format!("{BASE}[grids.g]\nga.crossover = [\"buckland\"]\n")).unwrap();
    let nested = parse(&format!("{BASE}[grids.g.ga]\ncrossover = [\"buckland\"]\n")).unwrap();
    assert_eq!(quoted.settings, dotted.settings);
    assert_eq!(quoted.settings, nested.settings);
    assert_eq!(
        quoted.settings[0].experiment.ga.crossover,
        Crossover::Buckland
    );
}

#[test]
fn listed_settings_follow_the_grids_and_may_change_nothing() {
    let sweep = parse(&format!(
        "{BASE}[grids.eps]\n\"guided.epsilon\" = [0.0]\n\
         [[settings]]\nname = \"baseline\"\n\
         [[settings]]\nname = \"wide\"\n\"guided.w_y\" = 5.0\nga.population = 30\n"
    ))
    .unwrap();
    let names: Vec<&str> = sweep.settings.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, ["eps: guided.epsilon=0.0", "baseline", "wide"]);
    assert_eq!(sweep.settings[1].experiment.guided, sweep.base.guided);
    assert_eq!(sweep.settings[2].experiment.guided.w_y, 5.0);
    assert_eq!(sweep.settings[2].experiment.ga.population, 30);
    assert_eq!(sweep.settings[2].folder, "wide");
    assert_eq!(sweep.settings[2].grid, None);
}

/// Every setting's folder is its own: a grid's folder that looks like a
/// listed setting's name, or like one already given, gets its position.
#[test]
fn no_two_settings_share_a_folder() {
    let sweep = parse(&format!(
        "{BASE}[grids.a]\n\"ga.population\" = [50]\n\
         [grids.b]\n\"ga.crossover\" = [\"uniform\", \"buckland\"]\n\
         [[settings]]\nname = \"a-ga.population-50\"\n\
         [[settings]]\nname = \"a-ga.population-50-1\"\n"
    ))
    .unwrap();
    let folders: Vec<&str> = sweep.settings.iter().map(|s| s.folder.as_str()).collect();
    assert_eq!(
        folders,
        [
            "a-ga.population-50-1-2",
            "b-ga.crossover-uniform",
            "b-ga.crossover-buckland",
            "a-ga.population-50",
            "a-ga.population-50-1",
        ]
    );
}

#[test]
fn a_long_folder_name_is_cut_and_numbered() {
    let grid = "g".repeat(64);
    let keys: String = [
        "guided.w_y",
        "guided.w_t",
        "guided.r",
        "guided.h1",
        "guided.h2",
    ]
    .iter()
    .chain(&["ga.crossover_rate", "ga.mutation_rate"])
    .map(|k| format!("\"{k}\" = [0.5, 0.50000000000001]\n"))
    .collect();
    let sweep = parse(&format!("{BASE}[grids.{grid}]\n{keys}")).unwrap();
    assert_eq!(sweep.settings.len(), 128);
    let folders: std::collections::HashSet<&str> =
        sweep.settings.iter().map(|s| s.folder.as_str()).collect();
    assert_eq!(folders.len(), 128, "each setting a folder of its own");
    let mut cut = 0;
    for (i, s) in sweep.settings.iter().enumerate() {
        let whole = folder_of(&grid, &s.values);
        assert!(
            s.folder.starts_with(&format!("{grid}-guided.w_y-0.5")),
            "{}",
            s.folder
        );
        if whole.len() <= NAME_MAX {
            assert_eq!(s.folder, whole, "a name that fits is kept");
        } else {
            assert_eq!(s.folder.len(), MAX_FOLDER, "{}", s.folder);
            assert!(s.folder.ends_with(&format!("-{}", i + 1)), "{}", s.folder);
            cut += 1;
        }
    }
    let last = &sweep.settings[127].folder;
    assert!(cut > 0 && last.len() == MAX_FOLDER, "{last}");
}

#[test]
fn a_key_given_twice_is_refused() {
    for (text, wanted) in [
        (
            "[[settings]]\nname = \"x\"\n\"guided.epsilon\" = 0.5\nguided = { epsilon = 0.0 }\n",
            "setting 'x', key 'guided.epsilon': given twice (\"guided.epsilon\", \
             guided.epsilon and epsilon in a [guided] table say the same)",
        ),
        (
            "[grids.a]\n\"guided.epsilon\" = [0.1, 0.5]\nguided = { epsilon = [0.0] }\n",
            "grid 'a', key 'guided.epsilon': given twice",
        ),
    ] {
        let text = format!("{BASE}{text}");
        let err = parse(&text).expect_err(&text);
        assert!(err.contains(wanted), "{text}\n→ {err}");
    }
}

#[test]
fn the_base_section_changes_every_setting() {
    let sweep = parse(&format!(
        "{BASE}[ga]\nmax_generations = 50\n[grids.g]\n\"guided.epsilon\" = [0.0, 0.5]\n"
    ))
    .unwrap();
    assert!(sweep
        .settings
        .iter()
        .all(|s| s.experiment.ga.max_generations == 50));
}

#[test]
fn equal_values_in_a_grid_are_refused() {
    let sweep = parse(&format!(
        "{BASE}[grids.g]\n\"qlearning.tile_widths\" = [[1.0, 2.0, 3.0, 4.0, 5.0], [1.0, 2.0, 3.0, 4.0, 5.0]]\n"
    ));
    // Two equal values make two settings of the same name: refused.
    let err = sweep.expect_err("equal grid values");
    assert!(err.contains("two settings are named"), "{err}");
}

#[test]
fn trials_can_be_overridden_for_every_setting() {
    let sweep = parse(&format!(
        "{BASE}[grids.g]\n\"guided.epsilon\" = [0.0, 0.5]\n"
    ))
    .unwrap();
    let fewer = sweep.with_trials(1).unwrap();
    assert!(fewer.settings.iter().all(|s| s.experiment.trials == 1));
    assert_eq!(fewer.base.trials, 1);
    assert!(sweep.with_trials(0).unwrap_err().contains("trials"));
}

#[test]
fn bad_input_names_the_grid_or_setting_and_the_key() {
    for (text, wanted) in [
        (
            "[grids.g]\n\"guided.epsilonn\" = [0.1]\n",
            &["grid 'g'", "guided.epsilonn", "unknown key", "w_y"][..],
        ),
        (
            "[grids.g]\n\"guided.epsilon\" = [\"high\"]\n",
            &[
                "setting 'g: guided.epsilon=high'",
                "guided.epsilon",
                "string",
            ],
        ),
        (
            "[grids.g]\n\"guided.epsilon\" = []\n",
            &["grid 'g'", "guided.epsilon", "empty"],
        ),
        ("[grids.g]\n", &["grid 'g'", "no keys"]),
        (
            "[grids.g]\n\"guided.epsilon\" = 0.1\n",
            &["grid 'g'", "guided.epsilon", "list of values"],
        ),
        (
            "[grids.g]\nseed = [1, 2]\n",
            &["grid 'g'", "seed", "not a key a setting may change"],
        ),
        (
            "[grids.g]\n\"guided.epsilon\" = [1.5]\n",
            &["setting 'g: guided.epsilon=1.5'", "guided.epsilon"],
        ),
        (
            "[[settings]]\nname = \"a\"\n[[settings]]\nname = \"a\"\n",
            &["two settings are named 'a'"],
        ),
        (
            "[[settings]]\n\"ga.population\" = 5\n",
            &["settings[0]", "needs a name"],
        ),
        (
            "[[settings]]\nname = \"a\"\n\"ga.population\" = \"many\"\n",
            &["setting 'a'", "ga.population"],
        ),
        (
            "[[settings]]\nname = \"../x\"\n",
            &["setting '../x'", "name"],
        ),
        ("", &["no settings"]),
        ("trials = 0\n[[settings]]\nname = \"a\"\n", &["trials"]),
        ("trails = 3\n[[settings]]\nname = \"a\"\n", &["trails"]),
    ] {
        let text = format!("{BASE}{text}");
        let err = parse(&text).expect_err(&text);
        for w in wanted {
            assert!(err.contains(w), "{text}\n→ {err}\n(wanted {w:?})");
        }
    }
}

#[test]
fn more_than_ten_thousand_settings_need_a_flag() {
    let values: Vec<String> = (1..=101).map(|v| v.to_string()).collect();
    let list = values.join(", ");
    let text = format!(
        "{BASE}[grids.g]\n\"ga.max_generations\" = [{list}]\n\"ga.max_restarts\" = [{}]\n",
        (0..100)
            .map(|v| v.to_string())
            .collect::<Vec<_>>()
            .join(", ")
    );
    let err = Sweep::parse(&text, false).expect_err("10,100 settings");
    assert!(
        err.contains("10100 settings") && err.contains("--allow-large"),
        "{err}"
    );
    assert_eq!(Sweep::parse(&text, true).unwrap().settings.len(), 10_100);
}

#[test]
fn no_flag_allows_a_sweep_of_more_than_two_million_trials() {
    // 10,000 settings of 3 trials of 2 methods run; of 101 trials, not.
    let grid = |trials: u64| {
        let values: Vec<String> = (1..=10_000).map(|v| v.to_string()).collect();
        format!(
            "name = \"s\"\ntrials = {trials}\nmethods = [\"ga\", \"guided\"]\n\
             [grids.g]\n\"ga.max_generations\" = [{}]\n",
            values.join(", ")
        )
    };
    assert_eq!(
        Sweep::parse(&grid(3), false).unwrap().settings.len(),
        10_000
    );
    for allow_large in [false, true] {
        let err = Sweep::parse(&grid(101), allow_large).expect_err("2,020,000 trials");
        assert!(
            err.contains("2020000 trials") && err.contains("`trials` times `methods`"),
            "{err}"
        );
    }
}

#[test]
fn no_flag_allows_a_grid_past_a_million_settings() {
    let hundred = (1..=100)
        .map(|v| v.to_string())
        .collect::<Vec<_>>()
        .join(", ");
    let keys = [
        "ga.max_generations",
        "ga.max_restarts",
        "ga.population",
        "ga.genome_length",
        "guided.w_y",
        "guided.h1",
        "guided.h2",
        "guided.w_t",
        "scoring.w1",
        "scoring.w2",
    ];
    // 100^6 settings, and 100^10, more than a usize counts.
    for n in [6, 10] {
        let grid: String = keys[..n]
            .iter()
            .map(|k| format!("\"{k}\" = [{hundred}]\n"))
            .collect();
        let text = format!("{BASE}[grids.g]\n{grid}");
        let err = Sweep::parse(&text, true).expect_err("a grid too large for any flag");
        assert!(
            err.contains("more than the 1000000 any sweep may have"),
            "{n} keys: {err}"
        );
    }
}

#[test]
fn the_shipped_fidelity_study_loads() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../experiments/fidelity.toml");
    let sweep = Sweep::load(&path, false).expect("fidelity.toml loads");
    assert_eq!(sweep.base.trials, 100);
    let grids: Vec<&str> = sweep.grids.iter().map(|g| g.name.as_str()).collect();
    assert_eq!(grids, ["crossover", "epsilon", "population", "weights"]);
}
