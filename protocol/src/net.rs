//! zenoh for workers on other hosts: the session configurations of the
//! coordinator, the workers and `lander router`, which of their endpoints a
//! stranger could join through, and the run's key expressions. Endpoints
//! are explicit and scouting is off, so a session reaches only the hosts it
//! is told of; shared memory is not compiled in, so queries never take
//! zenoh's shared-memory path.

use crate::envelope::MAX_FRAME;
use std::path::{Path, PathBuf};
use zenoh::Config;

/// How a session is secured and where it listens or connects.
#[derive(Clone, Debug, Default)]
pub struct NetOptions {
    /// Endpoints to listen on, such as `tcp/0.0.0.0:7447`.
    pub listen: Vec<String>,
    /// Endpoints to connect to, such as `tcp/10.0.0.5:7447`.
    pub connect: Vec<String>,
    /// A zenoh JSON5 configuration file applied first, for TLS and anything
    /// else zenoh offers.
    pub config_file: Option<PathBuf>,
    /// The coordinator's `user:password` dictionary: only workers that
    /// present one of its pairs may join.
    pub users: Option<PathBuf>,
    /// A worker's credentials, `user:password` on the first line of a file.
    pub credentials: Option<PathBuf>,
}

#[derive(Debug, thiserror::Error)]
pub enum NetError {
    #[error("zenoh configuration {key}: {detail}")]
    Config { key: String, detail: String },
    #[error("{path}: {detail}")]
    File { path: PathBuf, detail: String },
    #[error("{what}: {detail}")]
    Zenoh { what: String, detail: String },
}

/// A zenoh failure while doing `what`.
pub fn fail<E: std::fmt::Display>(what: &str) -> impl Fn(E) -> NetError + '_ {
    move |e| NetError::Zenoh {
        what: what.to_string(),
        detail: tidy(&e.to_string()),
    }
}

fn set(cfg: &mut Config, key: &str, value: &str) -> Result<(), NetError> {
    cfg.insert_json5(key, value).map_err(|e| NetError::Config {
        key: key.to_string(),
        detail: tidy(&e.to_string()),
    })
}

/// The part of a zenoh error meant for people: its message without the
/// debug wrapping and the source location zenoh appends.
pub fn tidy(error: &str) -> String {
    let message = error
        .split_once("msg: \"")
        .and_then(|(_, rest)| rest.split_once('"'))
        .map_or(error, |(msg, _)| msg);
    message.split(" at /").next().unwrap_or(message).to_string()
}

fn json(v: &impl serde::Serialize) -> String {
    serde_json::to_string(v).unwrap_or_default()
}

/// The settings both ends share, over `options.config_file` if given.
fn base(options: &NetOptions, mode: &str) -> Result<Config, NetError> {
    let mut cfg = match &options.config_file {
        Some(path) => from_file(path, mode)?,
        None => Config::default(),
    };
    set(&mut cfg, "mode", &json(&mode))?;
    set(&mut cfg, "scouting/multicast/enabled", "false")?;
    set(&mut cfg, "scouting/gossip/enabled", "false")?;
    // Both ends notice a silent peer (a cut cable, a frozen host) within
    // the lease; a killed process is noticed at once by its closed socket.
    set(&mut cfg, "transport/link/tx/lease", "3000")?;
    limit_messages(&mut cfg)?;
    if !options.listen.is_empty() {
        set(&mut cfg, "listen/endpoints", &json(&options.listen))?;
    }
    if !options.connect.is_empty() {
        set(&mut cfg, "connect/endpoints", &json(&options.connect))?;
    }
    Ok(cfg)
}

/// zenoh's key for the largest message a session puts together from
/// fragments.
const MAX_MESSAGE_KEY: &str = "transport/link/rx/max_message_size";

/// The largest message a session takes: a frame ([`MAX_FRAME`]) and room
/// for zenoh's own headers.
pub const MAX_MESSAGE: usize = MAX_FRAME + (1 << 20);

/// Caps the messages a session puts together at [`MAX_MESSAGE`] (zenoh's
/// own default is 1 GiB, held in memory before any frame check could
/// refuse it), or keeps a file's lower cap.
fn limit_messages(cfg: &mut Config) -> Result<(), NetError> {
    let given = cfg
        .get_json(MAX_MESSAGE_KEY)
        .ok()
        .and_then(|v| v.parse::<usize>().ok());
    if given.is_none_or(|g| g > MAX_MESSAGE) {
        set(cfg, MAX_MESSAGE_KEY, &MAX_MESSAGE.to_string())?;
    }
    Ok(())
}

/// A zenoh configuration file for a session of `mode`; one that names
/// another mode is refused (a worker's file given to the router, say).
fn from_file(path: &Path, mode: &str) -> Result<Config, NetError> {
    let refuse = |detail: String| NetError::File {
        path: path.to_path_buf(),
        detail,
    };
    readable(path)?;
    let cfg = Config::from_file(path).map_err(|e| refuse(tidy(&e.to_string())))?;
    let named = cfg.get_json("mode").unwrap_or_default();
    if named != "null" && named != json(&mode) {
        return Err(refuse(format!(
            "mode is {named}, but this session is a {mode}; set mode: \"{mode}\" or leave it out"
        )));
    }
    Ok(cfg)
}

/// `ZENOH_RUNTIME` for zenoh's I/O on one thread. zenoh 1.10's TLS link
/// reads and writes one rustls stream from two threads at once
/// (eclipse-zenoh/zenoh#2557), which corrupts it within seconds under
/// lander's traffic; on one thread the two never overlap.
pub const TLS_SAFE_RUNTIME: &str = "(rx: (handover: app), tx: (handover: app), \
     acc: (handover: app), net: (handover: app), app: (worker_threads: 1))";

/// What to tell the user when [`guard_tls`] acted.
pub const TLS_NOTE: &str = "TLS: running zenoh's I/O on one thread \
     (eclipse-zenoh/zenoh#2557; set ZENOH_RUNTIME to override)";

/// Whether `cfg` opens TLS links: any listen or connect endpoint `tls/…`.
pub fn uses_tls(cfg: &Config) -> bool {
    ["listen/endpoints", "connect/endpoints"]
        .iter()
        .any(|key| cfg.get_json(key).is_ok_and(|v| v.contains("\"tls/")))
}

/// For a session with TLS links, sets [`TLS_SAFE_RUNTIME`] unless the user
/// set `ZENOH_RUNTIME` already; true if it did. zenoh reads the variable
/// once, when the process opens its first session, so this must run before
/// that and while no other thread reads the environment.
pub fn guard_tls(cfg: &Config) -> bool {
    if !uses_tls(cfg) || std::env::var_os("ZENOH_RUNTIME").is_some() {
        return false;
    }
    std::env::set_var("ZENOH_RUNTIME", TLS_SAFE_RUNTIME);
    true
}

/// The coordinator: a peer that listens and checks workers' credentials.
pub fn coordinator_config(options: &NetOptions) -> Result<Config, NetError> {
    let mut cfg = base(options, "peer")?;
    check_users(&mut cfg, options)?;
    Ok(cfg)
}

/// A router, for a coordinator and workers that cannot reach each other:
/// all of them connect to it, and it forwards jobs and results. Given a
/// user dictionary it checks everyone who connects, coordinator included.
pub fn router_config(options: &NetOptions) -> Result<Config, NetError> {
    let mut cfg = base(options, "router")?;
    check_users(&mut cfg, options)?;
    Ok(cfg)
}

/// Admits only sessions presenting a pair from `options.users`, if given,
/// or from the dictionary a configuration file names. Either is checked
/// here: zenoh takes an empty dictionary as no authentication at all, so a
/// user who named one would believe strangers kept out when they are not.
fn check_users(cfg: &mut Config, options: &NetOptions) -> Result<(), NetError> {
    if let Some(users) = &options.users {
        set(
            cfg,
            "transport/auth/usrpwd/dictionary_file",
            &json(&users.display().to_string()),
        )?;
    }
    let named = cfg
        .get_json("transport/auth/usrpwd/dictionary_file")
        .ok()
        .and_then(|v| serde_json::from_str::<Option<String>>(&v).ok().flatten());
    if let Some(path) = named {
        dictionary(Path::new(&path))?;
    }
    Ok(())
}

/// Checks a user dictionary: `user:password` lines, at least one of them
/// (blank lines aside). Returns how many users it admits.
fn dictionary(path: &Path) -> Result<usize, NetError> {
    let text = readable(path)?;
    let refuse = |detail: String| NetError::File {
        path: path.to_path_buf(),
        detail,
    };
    let mut users = 0;
    for (n, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        match line.split_once(':') {
            Some((user, password)) if !user.is_empty() && !password.is_empty() => users += 1,
            _ => return Err(refuse(format!("line {} must be user:password", n + 1))),
        }
    }
    if users == 0 {
        return Err(refuse(
            "holds no user:password line, so it would admit anyone".into(),
        ));
    }
    Ok(users)
}

/// A worker: a client of the coordinator, never listening itself.
pub fn worker_config(options: &NetOptions) -> Result<Config, NetError> {
    let mut cfg = base(options, "client")?;
    set(&mut cfg, "listen/endpoints", "[]")?;
    // One attempt per open; the worker loops, so it can still be stopped.
    set(&mut cfg, "connect/timeout_ms", "2000")?;
    if let Some(path) = &options.credentials {
        let (user, password) = credentials(path)?;
        set(&mut cfg, "transport/auth/usrpwd/user", &json(&user))?;
        set(&mut cfg, "transport/auth/usrpwd/password", &json(&password))?;
    }
    Ok(cfg)
}

fn readable(path: &Path) -> Result<String, NetError> {
    std::fs::read_to_string(path).map_err(|e| NetError::File {
        path: path.to_path_buf(),
        detail: e.to_string(),
    })
}

/// Reads `user:password` from the first line of a file, so the password
/// stays off command lines and out of `ps`.
pub fn credentials(path: &Path) -> Result<(String, String), NetError> {
    let text = readable(path)?;
    let line = text.lines().next().unwrap_or("").trim();
    match line.split_once(':') {
        Some((user, password)) if !user.is_empty() && !password.is_empty() => {
            Ok((user.to_string(), password.to_string()))
        }
        _ => Err(NetError::File {
            path: path.to_path_buf(),
            detail: "the first line must be user:password".into(),
        }),
    }
}

/// The endpoints `cfg` listens on (its own mode's, where they differ by
/// mode), as written: `tcp/0.0.0.0:7447`.
pub fn listening(cfg: &Config) -> Vec<String> {
    endpoints(cfg, "listen/endpoints")
}

/// The endpoints `cfg` connects to, for its own mode where the file gives
/// them by mode.
pub fn connecting(cfg: &Config) -> Vec<String> {
    endpoints(cfg, "connect/endpoints")
}

fn endpoints(cfg: &Config, key: &str) -> Vec<String> {
    let read = |key: &str| -> serde_json::Value {
        cfg.get_json(key)
            .ok()
            .and_then(|j| serde_json::from_str(&j).ok())
            .unwrap_or_default()
    };
    let endpoints = match read(key) {
        serde_json::Value::Object(by_mode) => read("mode")
            .as_str()
            .and_then(|mode| by_mode.get(mode).cloned())
            .unwrap_or_default(),
        list => list,
    };
    endpoints
        .as_array()
        .map(|list| {
            list.iter()
                .filter_map(|e| e.as_str().map(String::from))
                .collect()
        })
        .unwrap_or_default()
}

/// The listen endpoints of `cfg` that a stranger on another host could
/// join through: not loopback, and not guarded by a user dictionary or by
/// TLS that asks for a client certificate.
pub fn open_to_strangers(cfg: &Config) -> Vec<String> {
    let on = |key: &str| cfg.get_json(key).is_ok_and(|v| v != "null" && v != "false");
    if on("transport/auth/usrpwd/dictionary_file") {
        return Vec::new();
    }
    let mutual_tls = on("transport/link/tls/enable_mtls");
    listening(cfg)
        .into_iter()
        .filter(|e| !(loopback(e) || mutual_tls && e.starts_with("tls/")))
        .collect()
}

/// A warning for the user if `cfg` listens where strangers could join
/// (see [`open_to_strangers`]): `then_can` says what they could then do,
/// and `remedy` how to stop them.
pub fn strangers_warning(cfg: &Config, then_can: &str, remedy: &str) -> Option<String> {
    let open = open_to_strangers(cfg);
    (!open.is_empty()).then(|| {
        format!(
            "listening on {} without authentication: anyone who can reach it \
             can {then_can}; {remedy}",
            open.join(", ")
        )
    })
}

fn loopback(endpoint: &str) -> bool {
    let address = endpoint.split_once('/').map_or(endpoint, |(_, a)| a);
    let address = address.split_once('#').map_or(address, |(a, _)| a);
    let host = address.rsplit_once(':').map_or(address, |(h, _)| h);
    host.starts_with("127.") || host == "localhost" || host == "[::1]"
}

/// Whether `endpoint` asks for any free port (`tcp/127.0.0.1:0`): the
/// port chosen is not one a worker told this endpoint could reach.
pub fn any_port(endpoint: &str) -> bool {
    let address = endpoint.split_once('/').map_or(endpoint, |(_, a)| a);
    let address = address.split(['#', '?']).next().unwrap_or(address);
    address
        .rsplit_once(':')
        .is_some_and(|(_, port)| port == "0")
}

/// The key expressions of one run.
#[derive(Clone, Debug)]
pub struct RunKeys {
    run: String,
}

impl RunKeys {
    pub fn new(run: &str) -> RunKeys {
        RunKeys {
            run: run.to_string(),
        }
    }

    /// Every worker's liveliness token.
    pub fn alive_all(&self) -> String {
        format!("lander/{}/alive/**", self.run)
    }

    /// A worker's liveliness token: its id, protocol version and pid.
    pub fn alive(&self, id: u64, version: u32, pid: u32, host: &str) -> String {
        format!(
            "lander/{}/alive/{id:016x}/{version}/{pid}/{}",
            self.run,
            key_safe(host)
        )
    }

    /// Reads id, version, pid and host back from a token's key. A token
    /// without a host (from a build before hosts were told) reads as host
    /// `""`, so that such a worker is still refused by its version.
    pub fn parse_alive(&self, key: &str) -> Option<(u64, u32, u32, String)> {
        let rest = key.strip_prefix(&format!("lander/{}/alive/", self.run))?;
        let mut parts = rest.split('/');
        let id = u64::from_str_radix(parts.next()?, 16).ok()?;
        let version = parts.next()?.parse().ok()?;
        let pid = parts.next()?.parse().ok()?;
        let host = parts.next().unwrap_or_default().to_string();
        parts.next().is_none().then_some((id, version, pid, host))
    }

    /// The liveliness token of the coordinator whose session is
    /// `instance`: a worker leaves when it goes, and a coordinator that
    /// takes the run up after it (a resume) declares another.
    pub fn coordinator(&self, instance: &str) -> String {
        format!("lander/{}/coordinator/{}", self.run, key_safe(instance))
    }

    /// Every coordinator token of the run ([`RunKeys::coordinator`]).
    pub fn coordinators(&self) -> String {
        format!("lander/{}/coordinator/*", self.run)
    }

    /// Where a worker takes jobs.
    pub fn jobs(&self, id: u64) -> String {
        format!("lander/{}/worker/{id:016x}/jobs", self.run)
    }

    /// Where a worker is told to leave ([`leave_word`]).
    pub fn leave(&self, id: u64) -> String {
        format!("lander/{}/worker/{id:016x}/leave", self.run)
    }
}

/// What is put on a worker's leave key: nothing where the run is over.
const DROPPED_WORD: &[u8] = b"dropped";
const REFUSED_WORD: &[u8] = b"refused";
const STOPPED_WORD: &[u8] = b"stopped";

/// The value put on a worker's leave key for `why`.
pub fn leave_word(why: crate::Farewell) -> &'static [u8] {
    match why {
        crate::Farewell::RunOver => b"",
        crate::Farewell::Dropped => DROPPED_WORD,
        crate::Farewell::Refused => REFUSED_WORD,
        crate::Farewell::Stopped => STOPPED_WORD,
    }
}

/// Why a value put on a worker's leave key tells it to leave (any word
/// but those of [`leave_word`]: the run is over).
pub fn farewell_in(word: &[u8]) -> crate::Farewell {
    match word {
        DROPPED_WORD => crate::Farewell::Dropped,
        REFUSED_WORD => crate::Farewell::Refused,
        STOPPED_WORD => crate::Farewell::Stopped,
        _ => crate::Farewell::RunOver,
    }
}

/// `name` as one chunk of a zenoh key: characters that mean something in
/// a key expression (`/`, `*`, `$`, `?`, `#`) and anything outside
/// `[A-Za-z0-9._-]` become `_`; an empty name is `unknown`.
fn key_safe(name: &str) -> String {
    if name.is_empty() {
        return "unknown".into();
    }
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "._-".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_carry_id_version_pid_and_host() {
        let keys = RunKeys::new("r1");
        let key = keys.alive(0xabc, 2, 77, "moon-1.local");
        assert_eq!(key, "lander/r1/alive/0000000000000abc/2/77/moon-1.local");
        assert_eq!(
            keys.parse_alive(&key),
            Some((0xabc, 2, 77, "moon-1.local".into()))
        );
        assert_eq!(
            keys.alive(1, 2, 3, "a/b*c"),
            "lander/r1/alive/0000000000000001/2/3/a_b_c"
        );
        assert_eq!(
            keys.parse_alive("lander/r1/alive/1/2/3"),
            Some((1, 2, 3, String::new()))
        );
        assert_eq!(keys.parse_alive("lander/r2/alive/1/2/3"), None);
        assert_eq!(keys.parse_alive("lander/r1/alive/zz/2/3"), None);
        assert_eq!(keys.parse_alive("lander/r1/alive/1/2/3/h/5"), None);
    }

    #[test]
    fn strangers_get_in_only_where_nothing_checks_them() {
        let options = NetOptions {
            listen: vec![
                "tcp/127.0.0.1:7447".into(),
                "tcp/0.0.0.0:7447".into(),
                "tcp/[::1]:7447".into(),
                "tls/10.0.0.5:7447".into(),
                "tcp/localhost:7447#iface=lo".into(),
            ],
            ..NetOptions::default()
        };
        let mut cfg = coordinator_config(&options).unwrap();
        assert_eq!(listening(&cfg).len(), 5);
        assert_eq!(
            open_to_strangers(&cfg),
            ["tcp/0.0.0.0:7447", "tls/10.0.0.5:7447"]
        );
        // Mutual TLS guards the TLS endpoint only.
        cfg.insert_json5("transport/link/tls/enable_mtls", "true")
            .unwrap();
        assert_eq!(open_to_strangers(&cfg), ["tcp/0.0.0.0:7447"]);
        // A user dictionary guards every link.
        cfg.insert_json5("transport/auth/usrpwd/dictionary_file", r#""users.txt""#)
            .unwrap();
        assert!(open_to_strangers(&cfg).is_empty());
    }

    #[test]
    fn a_router_with_users_lets_no_stranger_in() {
        let dir = std::env::temp_dir().join(format!("lander-router-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let users = dir.join("users.txt");
        std::fs::write(&users, "coordinator:secret\n").unwrap();
        let mut options = NetOptions {
            listen: vec!["tcp/0.0.0.0:7447".into()],
            ..NetOptions::default()
        };
        let open = router_config(&options).unwrap();
        assert_eq!(open_to_strangers(&open), ["tcp/0.0.0.0:7447"]);
        options.users = Some(users.clone());
        assert!(open_to_strangers(&router_config(&options).unwrap()).is_empty());
        options.users = Some(dir.join("missing.txt"));
        let e = router_config(&options).unwrap_err().to_string();
        assert!(e.contains("missing.txt"), "{e}");
        // An empty dictionary would admit anyone, so it is refused, as is a
        // line that is not user:password.
        for (text, why) in [
            ("", "no user"),
            ("\n  \n", "no user"),
            ("a:b\nnobody\n", "line 2"),
        ] {
            std::fs::write(&users, text).unwrap();
            options.users = Some(users.clone());
            let e = router_config(&options).unwrap_err().to_string();
            assert!(e.contains("users.txt") && e.contains(why), "{e}");
            let e = coordinator_config(&options).unwrap_err().to_string();
            assert!(e.contains(why), "{e}");
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_file_for_another_mode_is_refused_by_name() {
        let dir = std::env::temp_dir().join(format!("lander-mode-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = |name: &str, text: &str| {
            let path = dir.join(name);
            std::fs::write(&path, text).unwrap();
            NetOptions {
                config_file: Some(path),
                ..NetOptions::default()
            }
        };
        let client = file("client.json5", r#"{ mode: "client" }"#);
        let e = router_config(&client).unwrap_err().to_string();
        assert!(e.contains("client.json5") && e.contains("mode"), "{e}");
        worker_config(&client).unwrap();
        // A file that names no mode suits every session.
        let any = file(
            "any.json5",
            "{ scouting: { multicast: { enabled: false } } }",
        );
        let cfg = router_config(&any).unwrap();
        assert_eq!(cfg.get_json("mode").unwrap(), r#""router""#);
        coordinator_config(&any).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_leave_word_says_why() {
        for why in crate::Farewell::ALL {
            assert_eq!(farewell_in(leave_word(why)), why);
        }
        assert_eq!(farewell_in(b"something else"), crate::Farewell::RunOver);
    }

    #[test]
    fn an_endpoint_on_any_port_is_told_apart() {
        assert!(any_port("tcp/127.0.0.1:0"));
        assert!(any_port("tcp/[::1]:0#iface=lo"));
        assert!(!any_port("tcp/127.0.0.1:7447"));
        assert!(!any_port("tcp/127.0.0.1:70"));
        assert!(!any_port("tls/example.org:7447?x=0"));
    }

    #[test]
    fn messages_are_capped_at_a_frame_or_a_files_lower_cap() {
        let cap = |cfg: &Config| cfg.get_json(MAX_MESSAGE_KEY).unwrap();
        let default = NetOptions::default();
        for cfg in [
            coordinator_config(&default).unwrap(),
            worker_config(&default).unwrap(),
            router_config(&default).unwrap(),
        ] {
            assert_eq!(cap(&cfg), MAX_MESSAGE.to_string());
        }
        let dir = std::env::temp_dir().join(format!("lander-cap-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = |name: &str, size: usize| {
            let path = dir.join(name);
            let text =
                format!("{{ transport: {{ link: {{ rx: {{ max_message_size: {size} }} }} }} }}");
            std::fs::write(&path, text).unwrap();
            NetOptions {
                config_file: Some(path),
                ..NetOptions::default()
            }
        };
        let higher = worker_config(&file("higher.json5", 1 << 30)).unwrap();
        assert_eq!(cap(&higher), MAX_MESSAGE.to_string());
        let lower = worker_config(&file("lower.json5", 1 << 20)).unwrap();
        assert_eq!(cap(&lower), (1usize << 20).to_string());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_bad_endpoint_is_named_without_zenohs_internals() {
        let options = NetOptions {
            listen: vec!["nonsense".into()],
            ..NetOptions::default()
        };
        let e = router_config(&options).unwrap_err().to_string();
        assert!(
            e.starts_with("zenoh configuration listen/endpoints: "),
            "{e}"
        );
        assert!(
            e.contains("nonsense") || e.contains("<protocol>/<address>"),
            "{e}"
        );
        assert!(!e.contains(".rs:") && !e.contains("Json5Err"), "{e}");
    }

    #[test]
    fn endpoints_by_mode_are_read_for_the_sessions_own_mode() {
        let mut cfg = Config::default();
        cfg.insert_json5("mode", r#""router""#).unwrap();
        cfg.insert_json5(
            "listen/endpoints",
            r#"{ router: ["tcp/0.0.0.0:7447"], peer: ["tcp/127.0.0.1:7447"] }"#,
        )
        .unwrap();
        assert_eq!(listening(&cfg), ["tcp/0.0.0.0:7447"]);
    }

    #[test]
    fn tls_is_seen_in_either_direction_and_only_there() {
        let with = |listen: &str, connect: &str| NetOptions {
            listen: vec![listen.into()],
            connect: vec![connect.into()],
            ..NetOptions::default()
        };
        let tls = with("tls/127.0.0.1:7447", "tcp/10.0.0.5:7447");
        assert!(uses_tls(&coordinator_config(&tls).unwrap()));
        let tls = with("tcp/127.0.0.1:7447", "tls/10.0.0.5:7447");
        assert!(uses_tls(&worker_config(&tls).unwrap()));
        let plain = with("tcp/127.0.0.1:7447", "tcp/10.0.0.5:7447");
        assert!(!uses_tls(&coordinator_config(&plain).unwrap()));
        assert!(!uses_tls(&worker_config(&plain).unwrap()));
    }

    #[test]
    fn configurations_are_accepted_by_zenoh() {
        let dir = std::env::temp_dir().join(format!("lander-net-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let users = dir.join("users");
        let creds = dir.join("creds");
        std::fs::write(&users, "w:secret\n").unwrap();
        std::fs::write(&creds, "w:secret\n").unwrap();
        let options = NetOptions {
            listen: vec!["tcp/127.0.0.1:0".into()],
            connect: vec!["tcp/127.0.0.1:7447".into()],
            users: Some(users),
            credentials: Some(creds.clone()),
            ..NetOptions::default()
        };
        coordinator_config(&options).unwrap();
        worker_config(&options).unwrap();
        std::fs::write(&creds, "no colon\n").unwrap();
        let e = worker_config(&options).unwrap_err().to_string();
        assert!(e.contains("user:password"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
