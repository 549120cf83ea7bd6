//! A sweep file: a base experiment (the keys of an experiment file) and the
//! settings to compare it under, as grids (`[grids.NAME]`, every
//! combination of the listed values) and as named settings
//! (`[[settings]]`). Every key and value is checked here, before anything
//! runs, and an error names the grid or setting and the key.

use crate::config::{clipped, toml_error, ConfigError};
use crate::experiment::file::{is_folder_name, FOLDER_NAME_RULE};
use crate::experiment::Experiment;
use serde::Serialize;
use std::path::Path;
use toml::{Table, Value};

/// The most settings a sweep may hold unless the caller allows more.
pub const MAX_SETTINGS: usize = 10_000;

/// The most settings any sweep may hold, allowed more or not: each is an
/// experiment's configuration in memory and a folder of its own, so a
/// million take gigabytes and as many folders.
pub const MAX_LARGE_SETTINGS: usize = 1_000_000;

/// The most trials a sweep may run in all, its settings' together,
/// allowed more settings or not: each is planned as a task holding its
/// configuration, about a kilobyte, before any runs, so 2 million take
/// about 2 GB.
pub const MAX_SWEEP_TRIALS: u64 = 2_000_000;

/// The sections of the run configuration a setting may change.
const SECTIONS: [&str; 5] = ["world", "scoring", "guided", "ga", "qlearning"];

/// A grid: every combination of its keys' values, the last key varying
/// fastest.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Grid {
    pub name: String,
    /// Dotted keys such as `guided.epsilon`, in the file's order.
    pub keys: Vec<String>,
    /// The values of each key, in the file's order.
    pub values: Vec<Vec<Value>>,
}

impl Grid {
    /// How many settings the grid holds, saturating.
    fn size(&self) -> usize {
        self.values
            .iter()
            .fold(1usize, |n, v| n.saturating_mul(v.len()))
    }

    /// The `i`th combination, one value per key.
    fn combination(&self, mut i: usize) -> Vec<(String, Value)> {
        let mut picked = vec![Value::Boolean(false); self.keys.len()];
        for k in (0..self.keys.len()).rev() {
            let n = self.values[k].len();
            picked[k] = self.values[k][i % n].clone();
            i /= n;
        }
        self.keys.iter().cloned().zip(picked).collect()
    }
}

/// A setting listed by name in `[[settings]]`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Listed {
    pub name: String,
    pub values: Vec<(String, Value)>,
}

/// One setting of the sweep: the base experiment with some keys changed.
#[derive(Clone, Debug, PartialEq)]
pub struct Setting {
    /// Unique: `GRID: key=value, …` for a grid's, the given name for a
    /// listed one.
    pub name: String,
    /// The folder under `settings/` its experiment is written to.
    pub folder: String,
    pub grid: Option<String>,
    pub values: Vec<(String, Value)>,
    pub experiment: Experiment,
}

/// What `lander sweep FILE.toml` runs. Trial `t` of every setting starts
/// from the same `x0` over the same first pad (the base's seed), so the
/// settings are paired with each other as the methods are within one.
#[derive(Clone, Debug, PartialEq)]
pub struct Sweep {
    pub base: Experiment,
    pub grids: Vec<Grid>,
    pub listed: Vec<Listed>,
    /// The grids' settings in the file's order, then the listed ones.
    pub settings: Vec<Setting>,
}

/// What a sweep folder's `sweep.json` holds: enough to tell whether a
/// folder belongs to this sweep.
#[derive(Serialize)]
pub struct Definition<'a> {
    pub base: &'a Experiment,
    pub grids: &'a [Grid],
    pub settings: &'a [Listed],
}

impl Sweep {
    /// Reads and checks a sweep file. More than [`MAX_SETTINGS`] settings
    /// is an error unless `allow_large`.
    pub fn load(path: &Path, allow_large: bool) -> Result<Sweep, ConfigError> {
        let shown = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|error| ConfigError::Read {
            path: shown.clone(),
            error,
        })?;
        Sweep::parse(&text, allow_large).map_err(|message| ConfigError::Parse {
            path: shown,
            message,
        })
    }

    /// Parses and checks a sweep file's text.
    pub fn parse(text: &str, allow_large: bool) -> Result<Sweep, String> {
        let mut doc: Table = toml::from_str(text).map_err(|e| toml_error(text, &e))?;
        let grids = doc.remove("grids");
        let listed = doc.remove("settings");
        let base: Experiment = Value::Table(doc)
            .try_into()
            .map_err(|e| toml_error(text, &e))?;
        base.validate().map_err(|e| e.to_string())?;
        let grids = grids.map_or(Ok(Vec::new()), |g| read_grids(g, &base))?;
        let listed = listed.map_or(Ok(Vec::new()), |s| read_listed(s, &base))?;
        Sweep::build(base, grids, listed, allow_large)
    }

    /// The same sweep with `trials` trials per method in every setting.
    pub fn with_trials(&self, trials: u64) -> Result<Sweep, String> {
        let mut base = self.base.clone();
        base.trials = trials;
        base.validate().map_err(|e| format!("--trials: {e}"))?;
        Sweep::build(base, self.grids.clone(), self.listed.clone(), true)
    }

    /// What `sweep.json` records.
    pub fn definition(&self) -> Definition<'_> {
        Definition {
            base: &self.base,
            grids: &self.grids,
            settings: &self.listed,
        }
    }

    fn build(
        base: Experiment,
        grids: Vec<Grid>,
        listed: Vec<Listed>,
        allow_large: bool,
    ) -> Result<Sweep, String> {
        let count = grids
            .iter()
            .fold(listed.len(), |n, g| n.saturating_add(g.size()));
        if count == 0 {
            return Err(
                "the sweep has no settings: add a [grids.NAME] table or [[settings]]".into(),
            );
        }
        if count > MAX_SETTINGS && !allow_large {
            return Err(format!(
                "the sweep has {count} settings, more than {MAX_SETTINGS}; pass --allow-large to run it anyway"
            ));
        }
        if count > MAX_LARGE_SETTINGS {
            return Err(format!(
                "the sweep has {count} settings, more than the {MAX_LARGE_SETTINGS} any sweep may have"
            ));
        }
        // A setting changes neither `trials` nor `methods`.
        let each = base.trial_count();
        let trials = (count as u64).saturating_mul(each);
        if trials > MAX_SWEEP_TRIALS {
            return Err(format!(
                "the sweep runs {trials} trials ({count} settings of {each}: `trials` times `methods`), more than the {MAX_SWEEP_TRIALS} any sweep may run"
            ));
        }
        let full = Value::try_from(&base).map_err(|e| e.to_string())?;
        let mut settings = Vec::with_capacity(count);
        for grid in &grids {
            for i in 0..grid.size() {
                let values = grid.combination(i);
                let name = format!("{}: {}", grid.name, shown(&values));
                let folder = fitted(folder_of(&grid.name, &values), settings.len());
                settings.push((name, folder, Some(grid.name.clone()), values));
            }
        }
        for l in &listed {
            settings.push((l.name.clone(), l.name.clone(), None, l.values.clone()));
        }
        let settings = settings
            .into_iter()
            .map(|(name, folder, grid, values)| {
                let experiment = apply(&full, &base, &name, &folder, &values)?;
                Ok(Setting {
                    name,
                    folder,
                    grid,
                    values,
                    experiment,
                })
            })
            .collect::<Result<Vec<_>, String>>()?;
        let mut sweep = Sweep {
            base,
            grids,
            listed,
            settings,
        };
        sweep.make_folders_unique();
        sweep.check_unique_names()?;
        Ok(sweep)
    }

    fn check_unique_names(&self) -> Result<(), String> {
        let mut seen = std::collections::HashSet::new();
        for s in &self.settings {
            if !seen.insert(s.name.as_str()) {
                return Err(format!("two settings are named '{}'", s.name));
            }
        }
        Ok(())
    }

    /// Two grid values can look alike once made fit for a folder name
    /// (`a/b` and `a_b`), and a grid's folder like a listed setting's
    /// name: the grid's setting gets its position appended (and a count
    /// after that, should that be taken too). Listed names stay as given;
    /// two alike were refused.
    fn make_folders_unique(&mut self) {
        use std::collections::HashSet;
        let mut taken: HashSet<String> = self
            .settings
            .iter()
            .filter(|s| s.grid.is_none())
            .map(|s| s.folder.clone())
            .collect();
        for (i, s) in self.settings.iter_mut().enumerate() {
            if s.grid.is_none() {
                continue;
            }
            let mut folder = s.folder.clone();
            let mut n = 0;
            while taken.contains(&folder) {
                n += 1;
                folder = match n {
                    1 => format!("{}-{}", s.folder, i + 1),
                    _ => format!("{}-{}-{n}", s.folder, i + 1),
                };
            }
            taken.insert(folder.clone());
            s.folder = folder;
        }
    }
}

/// `key=value, key=value`, strings without their quotes.
fn shown(values: &[(String, Value)]) -> String {
    values
        .iter()
        .map(|(k, v)| format!("{k}={}", plain(v)))
        .collect::<Vec<_>>()
        .join(", ")
}

/// A value as a reader writes it: strings bare, the rest as TOML.
pub fn plain(v: &Value) -> String {
    match v {
        Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

/// `GRID-key-value-key-value`, with every character a folder name cannot
/// hold replaced by `_`.
fn folder_of(grid: &str, values: &[(String, Value)]) -> String {
    let mut folder = grid.to_string();
    for (k, v) in values {
        folder.push('-');
        folder.push_str(k);
        folder.push('-');
        folder.push_str(&plain(v));
    }
    folder
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "-_.".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// The longest folder name most file systems take, in bytes.
const NAME_MAX: usize = 255;

/// What a grid's setting's folder name longer than [`NAME_MAX`] is cut
/// to, leaving room for [`Sweep::make_folders_unique`]'s suffixes.
const MAX_FOLDER: usize = 240;

/// `folder`, where it is longer than [`NAME_MAX`], cut to [`MAX_FOLDER`]
/// bytes with the setting's `position` (from 0) appended, so that cut
/// names stay apart; shorter names are kept as they are. `folder_of`
/// leaves only ASCII, so any byte is a place to cut.
fn fitted(folder: String, position: usize) -> String {
    if folder.len() <= NAME_MAX {
        return folder;
    }
    let mark = format!("-{}", position + 1);
    format!("{}{mark}", &folder[..MAX_FOLDER - mark.len()])
}

fn read_grids(grids: Value, base: &Experiment) -> Result<Vec<Grid>, String> {
    let Value::Table(grids) = grids else {
        return Err("grids: must be tables, one per grid: [grids.NAME]".into());
    };
    let full = Value::try_from(base).map_err(|e| e.to_string())?;
    let mut out = Vec::new();
    for (name, table) in grids {
        let at = format!("grid '{name}'");
        if !is_folder_name(&name) {
            return Err(format!("{at}: its name {FOLDER_NAME_RULE}"));
        }
        let Value::Table(table) = table else {
            return Err(format!(
                "{at}: must be a table of keys and their values, such as \"guided.epsilon\" = [0.0, 0.1]"
            ));
        };
        let keyed = flatten(table);
        if keyed.is_empty() {
            return Err(format!("{at}: names no keys"));
        }
        once_each(&keyed).map_err(|key| format!("{at}, key '{key}': {}", given_twice(&key)))?;
        let mut keys = Vec::new();
        let mut values = Vec::new();
        for (key, value) in keyed {
            check_key(&full, &key).map_err(|e| format!("{at}, key '{key}': {e}"))?;
            let Value::Array(list) = value else {
                return Err(format!(
                    "{at}, key '{key}': must be a list of values, such as [0.0, 0.1]"
                ));
            };
            if list.is_empty() {
                return Err(format!("{at}, key '{key}': the list of values is empty"));
            }
            keys.push(key);
            values.push(list);
        }
        out.push(Grid { name, keys, values });
    }
    Ok(out)
}

fn read_listed(listed: Value, base: &Experiment) -> Result<Vec<Listed>, String> {
    let Value::Array(listed) = listed else {
        return Err("settings: must be a list of tables, each [[settings]] with a name".into());
    };
    let full = Value::try_from(base).map_err(|e| e.to_string())?;
    let mut out = Vec::new();
    for (i, table) in listed.into_iter().enumerate() {
        let Value::Table(mut table) = table else {
            return Err(format!("settings[{i}]: must be a table"));
        };
        let name = match table.remove("name") {
            Some(Value::String(name)) => name,
            Some(_) => return Err(format!("settings[{i}]: name must be a string")),
            None => return Err(format!("settings[{i}]: needs a name")),
        };
        if !is_folder_name(&name) {
            return Err(format!("setting '{name}': its name {FOLDER_NAME_RULE}"));
        }
        let values = flatten(table);
        once_each(&values)
            .map_err(|key| format!("setting '{name}', key '{key}': {}", given_twice(&key)))?;
        for (key, _) in &values {
            check_key(&full, key).map_err(|e| format!("setting '{name}', key '{key}': {e}"))?;
        }
        out.push(Listed { name, values });
    }
    Ok(out)
}

/// Dotted keys for every value that is not a table, so that
/// `"guided.epsilon" = 0.1`, `guided.epsilon = 0.1` and a `[x.guided]`
/// table all say the same.
fn flatten(table: Table) -> Vec<(String, Value)> {
    let mut out = Vec::new();
    for (key, value) in table {
        match value {
            Value::Table(inner) => {
                for (k, v) in flatten(inner) {
                    out.push((format!("{key}.{k}"), v));
                }
            }
            other => out.push((key, other)),
        }
    }
    out
}

/// What is wrong with `key` given twice: its forms say the same.
fn given_twice(key: &str) -> String {
    let (section, field) = key.split_once('.').unwrap_or((key, ""));
    format!("given twice (\"{key}\", {key} and {field} in a [{section}] table say the same)")
}

/// Each key once: the forms [`flatten`] reads say the same, so a key given
/// in two of them would set one value and name the other. Returns a key
/// given twice.
fn once_each(values: &[(String, Value)]) -> Result<(), String> {
    let mut seen = std::collections::HashSet::new();
    match values.iter().find(|(key, _)| !seen.insert(key.as_str())) {
        Some((key, _)) => Err(key.clone()),
        None => Ok(()),
    }
}

/// A key a setting may change: a field of one of the [`SECTIONS`].
fn check_key(full: &Value, key: &str) -> Result<(), String> {
    let mut parts = key.split('.');
    let section = parts.next().unwrap_or_default();
    if !SECTIONS.contains(&section) {
        return Err(format!(
            "not a key a setting may change; settings change the keys of the sections {}",
            SECTIONS.join(", ")
        ));
    }
    let mut at = full.get(section);
    for part in parts {
        at = at.and_then(|v| v.get(part));
    }
    match at {
        Some(Value::Table(_)) | None => {
            let known: Vec<&str> = full
                .get(section)
                .and_then(Value::as_table)
                .map(|t| t.keys().map(String::as_str).collect())
                .unwrap_or_default();
            Err(format!("unknown key; [{section}] has {}", known.join(", ")))
        }
        Some(_) => Ok(()),
    }
}

/// The base experiment with `values` set, each key checked for its type as
/// it is set, and the whole checked for range.
fn apply(
    full: &Value,
    base: &Experiment,
    name: &str,
    folder: &str,
    values: &[(String, Value)],
) -> Result<Experiment, String> {
    let mut doc = full.clone();
    for (key, value) in values {
        set(&mut doc, key, value.clone());
        let _: Experiment = doc.clone().try_into().map_err(|e| {
            format!(
                "setting '{name}', key '{key}': {}",
                clipped(e.to_string().trim())
            )
        })?;
    }
    let mut exp: Experiment = doc.try_into().map_err(|e| clipped(&e.to_string()))?;
    exp.name = if is_folder_name(folder) {
        folder.to_string()
    } else {
        base.name.clone()
    };
    exp.validate()
        .map_err(|e| format!("setting '{name}': {e}"))?;
    Ok(exp)
}

/// Sets a dotted key that [`check_key`] accepted.
fn set(doc: &mut Value, key: &str, value: Value) {
    let mut at = doc;
    let mut parts = key.split('.').peekable();
    while let Some(part) = parts.next() {
        let Some(table) = at.as_table_mut() else {
            return;
        };
        if parts.peek().is_none() {
            table.insert(part.to_string(), value);
            return;
        }
        let Some(next) = table.get_mut(part) else {
            return;
        };
        at = next;
    }
}

#[cfg(test)]
mod tests;
