//! Headless Chromium for the end-to-end tests: open a local HTML file,
//! collect what its console would show as errors, and ask the page
//! questions in JavaScript.
//!
//! The browser is Debian's `chromium` (or the one `CHROMIUM` names), driven
//! through the Chrome DevTools Protocol over `--remote-debugging-pipe`: the
//! browser reads JSON commands on its fd 3 and writes replies and events on
//! fd 4, each message ending in a NUL byte. That needs no port, no WebSocket
//! and no driver crate, and the browser quits by itself when the pipe closes,
//! so even a test process that dies leaves no browser behind.
//!
//! What counts as a console error is collected from before the page starts
//! loading until the [`Page`] is dropped: `console.error` and failed
//! `console.assert` calls, uncaught exceptions and unhandled promise
//! rejections, the browser's own error messages (a resource that failed to
//! load, a blocked request, ...), and a renderer crash.

use serde_json::{json, Value};
use std::fmt;
use std::fs::File;
use std::io::{BufRead, BufReader, PipeWriter, Write};
use std::os::fd::AsRawFd;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::time::{Duration, Instant};

/// How long one protocol command may take before it counts as hung.
const COMMAND_TIMEOUT: Duration = Duration::from_secs(30);
/// How long a page may take to fire its `load` event.
const LOAD_TIMEOUT: Duration = Duration::from_secs(60);
/// How long a dropped page's browser gets to close before it is killed,
/// and then how long its orphans get to go.
pub const CLOSE_GRACE: Duration = Duration::from_secs(3);

/// The Chromium binary to use: the file `CHROMIUM` names if it is set,
/// otherwise the first of `chromium`, `chromium-browser`, `google-chrome`
/// and `google-chrome-stable` found in /usr/bin or on `PATH`.
pub fn chromium() -> Option<PathBuf> {
    if let Some(path) = std::env::var_os("CHROMIUM") {
        let path = PathBuf::from(path);
        return path.is_file().then_some(path);
    }
    let names = [
        "chromium",
        "chromium-browser",
        "google-chrome",
        "google-chrome-stable",
    ];
    let mut dirs = vec![PathBuf::from("/usr/bin")];
    if let Some(path) = std::env::var_os("PATH") {
        dirs.extend(std::env::split_paths(&path));
    }
    names
        .iter()
        .flat_map(|name| dirs.iter().map(move |dir| dir.join(name)))
        .find(|candidate| candidate.is_file())
}

/// What went wrong while driving the browser.
pub enum BrowserError {
    /// No browser binary was found.
    NotFound,
    /// The browser could not be started, or its pipes set up.
    Launch(std::io::Error),
    /// The browser exited, or closed its end of the pipe.
    Closed {
        /// The last lines the browser wrote to stderr.
        stderr: String,
    },
    /// The browser answered a command with an error, or with something
    /// this module does not understand.
    Protocol(String),
    /// The page could not be loaded.
    Navigation(String),
    /// JavaScript evaluated through [`Page::eval_json`] threw.
    Script(String),
    /// Something did not happen in time.
    Timeout(String),
}

impl fmt::Display for BrowserError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BrowserError::NotFound => match std::env::var_os("CHROMIUM") {
                Some(path) => write!(
                    f,
                    "no Chromium at {} (from CHROMIUM); the browser tests need one",
                    Path::new(&path).display()
                ),
                None => write!(
                    f,
                    "no Chromium found (looked for chromium, chromium-browser, google-chrome \
                     in /usr/bin and on PATH); the browser tests need one: \
                     `apt-get install chromium` (.ci/run does), or set CHROMIUM to its path"
                ),
            },
            BrowserError::Launch(e) => write!(f, "starting Chromium failed: {e}"),
            BrowserError::Closed { stderr } => {
                write!(f, "Chromium exited unexpectedly")?;
                if !stderr.is_empty() {
                    write!(f, "; the end of its stderr:\n{stderr}")?;
                }
                Ok(())
            }
            BrowserError::Protocol(m) => write!(f, "DevTools protocol: {m}"),
            BrowserError::Navigation(m) => write!(f, "loading the page failed: {m}"),
            BrowserError::Script(m) => write!(f, "the script threw: {m}"),
            BrowserError::Timeout(m) => write!(f, "timed out: {m}"),
        }
    }
}

// Debug shows the message, so `.expect()` and a test returning `Result`
// print something a person can act on.
impl fmt::Debug for BrowserError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(self, f)
    }
}

impl std::error::Error for BrowserError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            BrowserError::Launch(e) => Some(e),
            _ => None,
        }
    }
}

/// Opens `file` in a new headless browser; see [`Page::open`].
pub fn open(file: &Path) -> Result<Page, BrowserError> {
    Page::open(file)
}

/// What the reader thread learns from the browser's events.
#[derive(Default)]
struct Events {
    /// Console errors, uncaught exceptions and failed loads, in order.
    errors: Vec<String>,
    /// `(frameId, loaderId)` of each document whose `load` event fired.
    loaded: Vec<(String, String)>,
}

/// One local HTML file open in its own headless Chromium, which is closed
/// (and killed if need be) when the `Page` is dropped.
pub struct Page {
    child: Child,
    writer: Mutex<PipeWriter>,
    replies: Mutex<Receiver<(u64, Value)>>,
    next_id: Mutex<u64>,
    session: String,
    events: Arc<Mutex<Events>>,
    stderr_path: PathBuf,
    // Last, so the profile is removed after the browser has gone.
    _profile: tempfile::TempDir,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

impl Page {
    /// Starts a headless Chromium with a fresh profile, opens `file` in it
    /// as a `file://` URL and waits for the page's `load` event. Console
    /// errors are recorded from before the navigation starts.
    pub fn open(file: &Path) -> Result<Page, BrowserError> {
        let file = file
            .canonicalize()
            .map_err(|e| BrowserError::Navigation(format!("{}: {e}", file.display())))?;
        let mut page = Page::launch()?;
        page.attach()?;
        page.navigate(&file_url(&file))?;
        Ok(page)
    }

    fn launch() -> Result<Page, BrowserError> {
        let binary = chromium().ok_or(BrowserError::NotFound)?;
        let profile = tempfile::Builder::new()
            .prefix("lander-chromium-")
            .tempdir()
            .map_err(BrowserError::Launch)?;
        let stderr_path = profile.path().join("stderr.log");
        let stderr = File::create(&stderr_path).map_err(BrowserError::Launch)?;

        // The browser reads commands from fd 3 and writes to fd 4.
        let (to_browser_r, to_browser_w) = std::io::pipe().map_err(BrowserError::Launch)?;
        let (from_browser_r, from_browser_w) = std::io::pipe().map_err(BrowserError::Launch)?;
        let child_in = to_browser_r.as_raw_fd();
        let child_out = from_browser_w.as_raw_fd();

        let mut cmd = Command::new(&binary);
        cmd.args([
            "--headless",
            "--no-sandbox",
            "--no-zygote",
            "--remote-debugging-pipe",
            "--no-first-run",
            "--no-default-browser-check",
            "--disable-extensions",
            "--disable-component-update",
            "--disable-background-networking",
            "--disable-sync",
            "--disable-default-apps",
            "--disable-dev-shm-usage",
            "--disable-background-timer-throttling",
            "--disable-backgrounding-occluded-windows",
            "--disable-renderer-backgrounding",
            "--mute-audio",
            "--hide-scrollbars",
            "--window-size=1280,1024",
        ])
        .arg(format!("--user-data-dir={}", profile.path().display()))
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(stderr)
        // Its own process group, so that Drop can kill every process the
        // browser started.
        .process_group(0);
        // SAFETY: between fork and exec the closure only calls fcntl and
        // dup2, which are async-signal-safe, on descriptors that stay open
        // until `spawn` returns. Both ends are first copied above fd 4, so
        // neither dup2 overwrites the other's source, and each dup2 makes a
        // new descriptor, which does not inherit close-on-exec.
        unsafe {
            cmd.pre_exec(move || {
                let a = libc::fcntl(child_in, libc::F_DUPFD_CLOEXEC, 10);
                let b = libc::fcntl(child_out, libc::F_DUPFD_CLOEXEC, 10);
                if a < 0 || b < 0 || libc::dup2(a, 3) < 0 || libc::dup2(b, 4) < 0 {
                    return Err(std::io::Error::last_os_error());
                }
                Ok(())
            });
        }
        let child = cmd.spawn().map_err(|e| {
            BrowserError::Launch(std::io::Error::new(
                e.kind(),
                format!("{}: {e}", binary.display()),
            ))
        })?;
        // Only the browser may hold its ends, so that each side sees the
        // other go away.
        drop(to_browser_r);
        drop(from_browser_w);

        let events = Arc::new(Mutex::new(Events::default()));
        let (reply_tx, reply_rx) = mpsc::channel();
        let reader_events = Arc::clone(&events);
        let spawned = std::thread::Builder::new()
            .name("chromium-reader".into())
            .spawn(move || {
                let mut reader = BufReader::new(from_browser_r);
                let mut buf = Vec::new();
                loop {
                    buf.clear();
                    match reader.read_until(0, &mut buf) {
                        Ok(0) | Err(_) => return,
                        Ok(_) => {}
                    }
                    if buf.last() == Some(&0) {
                        buf.pop();
                    }
                    let Ok(msg) = serde_json::from_slice::<Value>(&buf) else {
                        continue;
                    };
                    if let Some(id) = msg.get("id").and_then(Value::as_u64) {
                        if reply_tx.send((id, msg)).is_err() {
                            return;
                        }
                    } else {
                        on_event(&msg, &mut lock(&reader_events));
                    }
                }
            });
        let page = Page {
            child,
            writer: Mutex::new(to_browser_w),
            replies: Mutex::new(reply_rx),
            next_id: Mutex::new(0),
            session: String::new(),
            events,
            stderr_path,
            _profile: profile,
        };
        // On failure, dropping `page` stops the browser.
        spawned.map_err(BrowserError::Launch)?;
        Ok(page)
    }

    /// Opens a fresh tab, attaches to it and turns on the event domains.
    fn attach(&mut self) -> Result<(), BrowserError> {
        let target = self.browser_command("Target.createTarget", json!({"url": "about:blank"}))?;
        let target_id = target["targetId"]
            .as_str()
            .ok_or_else(|| BrowserError::Protocol(format!("no targetId in {target}")))?
            .to_string();
        let attached = self.browser_command(
            "Target.attachToTarget",
            json!({"targetId": target_id, "flatten": true}),
        )?;
        self.session = attached["sessionId"]
            .as_str()
            .ok_or_else(|| BrowserError::Protocol(format!("no sessionId in {attached}")))?
            .to_string();
        for method in ["Runtime.enable", "Log.enable", "Page.enable"] {
            self.command(method, json!({}))?;
        }
        self.command("Page.setLifecycleEventsEnabled", json!({"enabled": true}))?;
        Ok(())
    }

    /// Navigates the tab to `url` and waits for that document's `load`.
    fn navigate(&self, url: &str) -> Result<(), BrowserError> {
        let nav = self.command("Page.navigate", json!({"url": url}))?;
        if let Some(error) = nav.get("errorText").and_then(Value::as_str) {
            return Err(BrowserError::Navigation(format!("{url}: {error}")));
        }
        let frame = nav["frameId"].as_str().unwrap_or_default().to_string();
        let Some(loader) = nav["loaderId"].as_str().map(str::to_string) else {
            // A navigation within the same document: it is already there.
            return Ok(());
        };
        let end = Instant::now() + LOAD_TIMEOUT;
        loop {
            {
                let events = lock(&self.events);
                if events
                    .loaded
                    .iter()
                    .any(|(f, l)| *f == frame && *l == loader)
                {
                    return Ok(());
                }
            }
            // Waiting on the replies doubles as the pause between checks,
            // and tells when the browser has gone.
            match lock(&self.replies).recv_timeout(Duration::from_millis(10)) {
                // A late reply to a command that timed out earlier.
                Ok(_) | Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => return Err(self.closed()),
            }
            if Instant::now() > end {
                return Err(BrowserError::Timeout(format!(
                    "{url} did not fire its load event within {LOAD_TIMEOUT:?}"
                )));
            }
        }
    }

    /// Evaluates the JavaScript expression `js` in the page and returns its
    /// value as JSON, after awaiting it if it is a promise. `undefined`
    /// becomes `null`; a value JSON cannot hold (a DOM node, a function)
    /// comes back as `{}` or `null`. A thrown exception is
    /// [`BrowserError::Script`], and is not recorded as a console error.
    pub fn eval_json(&self, js: &str) -> Result<Value, BrowserError> {
        let reply = self.command(
            "Runtime.evaluate",
            json!({
                "expression": js,
                "returnByValue": true,
                "awaitPromise": true,
                "userGesture": true,
            }),
        )?;
        if let Some(details) = reply.get("exceptionDetails") {
            return Err(BrowserError::Script(exception_text(details)));
        }
        Ok(reply["result"].get("value").cloned().unwrap_or(Value::Null))
    }

    /// Every console error so far: `console.error` and failed
    /// `console.assert` calls, uncaught exceptions and promise rejections,
    /// the browser's own errors (such as a resource that failed to load)
    /// and a renderer crash, each as one line of text.
    pub fn console_errors(&self) -> Vec<String> {
        lock(&self.events).errors.clone()
    }

    /// Polls the JavaScript boolean expression `js_predicate` every 20 ms
    /// until it is true, or fails after `timeout`. An expression that
    /// throws counts as false; its last error is in the timeout message.
    pub fn wait_for(&self, js_predicate: &str, timeout: Duration) -> Result<(), BrowserError> {
        let end = Instant::now() + timeout;
        let expression = format!("Boolean({js_predicate})");
        loop {
            let last = match self.eval_json(&expression) {
                Ok(Value::Bool(true)) => return Ok(()),
                Ok(other) => format!("it was {other}"),
                Err(BrowserError::Script(e)) => format!("it threw {e}"),
                Err(e) => return Err(e),
            };
            if Instant::now() >= end {
                return Err(BrowserError::Timeout(format!(
                    "`{js_predicate}` did not become true within {timeout:?}; last {last}"
                )));
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// Whether the canvas that the CSS `selector` matches has pixels of
    /// more than one colour. An empty (0×0) canvas is not painted. Fails
    /// when nothing matches, the element is no canvas, or the canvas was
    /// tainted by cross-origin drawing and cannot be read.
    pub fn canvas_is_painted(&self, selector: &str) -> Result<bool, BrowserError> {
        let selector = Value::String(selector.to_string());
        let js = format!(
            r#"(() => {{
                const c = document.querySelector({selector});
                if (c === null) throw new Error("no element matches " + {selector});
                if (!(c instanceof HTMLCanvasElement))
                    throw new Error({selector} + " is a <" + c.localName + ">, not a <canvas>");
                if (c.width === 0 || c.height === 0) return false;
                // A copy reads a WebGL canvas as well as a 2D one.
                const copy = document.createElement("canvas");
                copy.width = c.width;
                copy.height = c.height;
                const ctx = copy.getContext("2d");
                ctx.drawImage(c, 0, 0);
                const px = new Uint32Array(ctx.getImageData(0, 0, c.width, c.height).data.buffer);
                const first = px[0];
                for (let i = 1; i < px.length; i++) if (px[i] !== first) return true;
                return false;
            }})()"#
        );
        match self.eval_json(&js)? {
            Value::Bool(painted) => Ok(painted),
            other => Err(BrowserError::Protocol(format!(
                "the canvas check returned {other}"
            ))),
        }
    }

    /// How many `<img>` elements the document has, and how many of them
    /// are decoded: loaded completely with a natural width above zero.
    pub fn images_decoded(&self) -> Result<(usize, usize), BrowserError> {
        let v = self.eval_json(
            "(() => { const all = Array.from(document.images); \
             return [all.length, all.filter(i => i.complete && i.naturalWidth > 0).length]; })()",
        )?;
        match (v[0].as_u64(), v[1].as_u64()) {
            (Some(total), Some(decoded)) => Ok((total as usize, decoded as usize)),
            _ => Err(BrowserError::Protocol(format!(
                "the image check returned {v}"
            ))),
        }
    }

    /// The `src` of each `<img>` that is not decoded (data URLs cut to
    /// their first 60 characters), for failure messages.
    pub fn undecoded_images(&self) -> Result<Vec<String>, BrowserError> {
        let v = self.eval_json(
            "Array.from(document.images).filter(i => !(i.complete && i.naturalWidth > 0))\
             .map(i => i.src.length > 60 ? i.src.slice(0, 60) + '…' : i.src)",
        )?;
        serde_json::from_value(v.clone())
            .map_err(|_| BrowserError::Protocol(format!("the image check returned {v}")))
    }

    /// The process id of the browser, which also leads the process group
    /// of everything the browser started.
    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// Sends `method` to the attached tab and waits for its result.
    fn command(&self, method: &str, params: Value) -> Result<Value, BrowserError> {
        self.send(method, params, Some(&self.session))
    }

    /// Sends `method` to the browser itself and waits for its result.
    fn browser_command(&self, method: &str, params: Value) -> Result<Value, BrowserError> {
        self.send(method, params, None)
    }

    fn send(
        &self,
        method: &str,
        params: Value,
        session: Option<&str>,
    ) -> Result<Value, BrowserError> {
        let id = {
            let mut next = lock(&self.next_id);
            *next += 1;
            *next
        };
        let mut msg = json!({"id": id, "method": method, "params": params});
        if let Some(session) = session {
            msg["sessionId"] = Value::String(session.to_string());
        }
        let mut bytes = msg.to_string().into_bytes();
        bytes.push(0);
        {
            let mut writer = lock(&self.writer);
            if writer
                .write_all(&bytes)
                .and_then(|()| writer.flush())
                .is_err()
            {
                return Err(self.closed());
            }
        }
        let replies = lock(&self.replies);
        let end = Instant::now() + COMMAND_TIMEOUT;
        loop {
            let left = end.saturating_duration_since(Instant::now());
            match replies.recv_timeout(left) {
                // A reply to an earlier command that timed out.
                Ok((other, _)) if other != id => continue,
                Ok((_, reply)) => {
                    if let Some(error) = reply.get("error") {
                        return Err(BrowserError::Protocol(format!("{method}: {error}")));
                    }
                    return Ok(reply.get("result").cloned().unwrap_or(Value::Null));
                }
                Err(RecvTimeoutError::Timeout) => {
                    return Err(BrowserError::Timeout(format!(
                        "Chromium did not answer {method} within {COMMAND_TIMEOUT:?}"
                    )))
                }
                Err(RecvTimeoutError::Disconnected) => return Err(self.closed()),
            }
        }
    }

    /// The error for a browser that went away, with its last stderr lines.
    fn closed(&self) -> BrowserError {
        let text = std::fs::read_to_string(&self.stderr_path).unwrap_or_default();
        let lines: Vec<&str> = text.lines().collect();
        let tail = lines[lines.len().saturating_sub(20)..].join("\n");
        BrowserError::Closed { stderr: tail }
    }
}

impl Drop for Page {
    fn drop(&mut self) {
        // Ask the browser to close, and give it a moment: a browser that
        // shuts down by itself also ends its helper processes.
        let id = {
            let mut next = lock(&self.next_id);
            *next += 1;
            *next
        };
        let close = format!("{{\"id\":{id},\"method\":\"Browser.close\",\"params\":{{}}}}\0");
        let _ = lock(&self.writer).write_all(close.as_bytes());
        let pgid = self.child.id();
        let end = Instant::now() + CLOSE_GRACE;
        loop {
            match self.child.try_wait() {
                Ok(None) if Instant::now() < end => {
                    std::thread::sleep(Duration::from_millis(10));
                }
                Ok(None) => {
                    // Still there: kill its whole process group. The leader
                    // is not reaped yet, so the group id is still its own.
                    kill_group(pgid);
                    let _ = self.child.wait();
                    break;
                }
                Ok(Some(_)) | Err(_) => break,
            }
        }
        // Helpers that outlive the browser by a moment are orphans that
        // init reaps; wait for that, so that a test that checks for leftover
        // processes right after a drop sees none. Any that still run are
        // killed: while they are in the group, the group id is still ours.
        let end = Instant::now() + CLOSE_GRACE;
        loop {
            let members = group_members(pgid);
            if members.is_empty() || Instant::now() >= end {
                break;
            }
            if members.iter().any(|&(_, state)| state != 'Z') {
                kill_group(pgid);
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }
}

/// Sends SIGKILL to every process in the group `pgid`.
fn kill_group(pgid: u32) {
    if let Ok(pgid) = libc::pid_t::try_from(pgid) {
        // SAFETY: kill has no memory-safety preconditions.
        unsafe {
            libc::kill(-pgid, libc::SIGKILL);
        }
    }
}

/// The processes in the group `pgid`, with their state letter (`Z` for a
/// zombie that no one has reaped yet), read from /proc.
fn group_members(pgid: u32) -> Vec<(u32, char)> {
    let Ok(dir) = std::fs::read_dir("/proc") else {
        return Vec::new();
    };
    dir.flatten()
        .filter_map(|entry| {
            let pid = entry.file_name().to_str()?.parse::<u32>().ok()?;
            let stat = std::fs::read_to_string(entry.path().join("stat")).ok()?;
            // "pid (comm) state ppid pgrp ...", where comm may hold anything.
            let mut fields = stat.rsplit_once(')')?.1.split_whitespace();
            let state = fields.next()?.chars().next()?;
            let pgrp = fields.nth(1)?.parse::<u32>().ok()?;
            (pgrp == pgid).then_some((pid, state))
        })
        .collect()
}

/// One line of text for an exception from `Runtime.exceptionThrown` or a
/// failed `Runtime.evaluate`.
fn exception_text(details: &Value) -> String {
    let description = details["exception"]["description"]
        .as_str()
        .or_else(|| details["exception"]["value"].as_str())
        .map(str::to_string)
        .or_else(|| details["exception"].get("value").map(|v| v.to_string()))
        .unwrap_or_default();
    let text = details["text"].as_str().unwrap_or("exception");
    let mut line = if description.is_empty() {
        text.to_string()
    } else {
        format!("{text} {description}")
    };
    // An Error's description is its stack, which already says where.
    let url = details["url"].as_str().unwrap_or_default();
    if !url.is_empty() && !line.contains(url) {
        let row = details["lineNumber"].as_u64().unwrap_or(0) + 1;
        let col = details["columnNumber"].as_u64().unwrap_or(0) + 1;
        line.push_str(&format!(" ({url}:{row}:{col})"));
    }
    line
}

/// Records what an event says about errors and page loads.
fn on_event(msg: &Value, events: &mut Events) {
    let params = &msg["params"];
    match msg["method"].as_str().unwrap_or_default() {
        "Runtime.consoleAPICalled" => {
            let kind = params["type"].as_str().unwrap_or_default();
            if kind == "error" || kind == "assert" {
                let args: Vec<String> = params["args"]
                    .as_array()
                    .map(|args| args.iter().map(remote_object_text).collect())
                    .unwrap_or_default();
                events
                    .errors
                    .push(format!("console.{kind}: {}", args.join(" ")));
            }
        }
        "Runtime.exceptionThrown" => {
            events
                .errors
                .push(exception_text(&params["exceptionDetails"]));
        }
        "Log.entryAdded" => {
            let entry = &params["entry"];
            if entry["level"].as_str() == Some("error") {
                let source = entry["source"].as_str().unwrap_or("browser");
                let text = entry["text"].as_str().unwrap_or_default();
                let mut line = format!("{source}: {text}");
                if let Some(url) = entry["url"].as_str().filter(|u| !u.is_empty()) {
                    line.push_str(&format!(" ({url})"));
                }
                events.errors.push(line);
            }
        }
        "Inspector.targetCrashed" | "Target.targetCrashed" => {
            events.errors.push("the page's renderer crashed".into());
        }
        "Page.lifecycleEvent" if params["name"].as_str() == Some("load") => {
            if let (Some(frame), Some(loader)) =
                (params["frameId"].as_str(), params["loaderId"].as_str())
            {
                events.loaded.push((frame.to_string(), loader.to_string()));
            }
        }
        _ => {}
    }
}

/// A console argument as the console would print it.
fn remote_object_text(obj: &Value) -> String {
    match obj.get("value") {
        Some(Value::String(s)) => s.clone(),
        Some(v) => v.to_string(),
        None => obj["description"]
            .as_str()
            .or_else(|| obj["unserializableValue"].as_str())
            .or_else(|| obj["type"].as_str())
            .unwrap_or_default()
            .to_string(),
    }
}

/// The `file://` URL of an absolute path, with every byte outside
/// `A-Za-z0-9-._~/` percent-encoded.
fn file_url(path: &Path) -> String {
    use std::os::unix::ffi::OsStrExt;
    let mut url = String::from("file://");
    for &b in path.as_os_str().as_bytes() {
        if b.is_ascii_alphanumeric() || b"-._~/".contains(&b) {
            url.push(b as char);
        } else {
            url.push_str(&format!("%{b:02X}"));
        }
    }
    url
}
