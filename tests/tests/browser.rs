//! The headless-browser harness (`lander_tests::browser`) on small pages
//! written to a temporary folder: each check must see what is really there.
//! These tests need Chromium and fail, saying so, without it.

use lander_tests::browser::{self, BrowserError, Page};
use std::path::Path;
use std::time::{Duration, Instant};

/// A 1×1 red PNG.
const PNG: &str = "data:image/png;base64,\
    iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mP8z8BQDwAEhQGAhKmMIQAAAABJRU5ErkJggg==";

/// Writes `body` as `page.html` in a new temporary folder and opens it.
fn open(body: &str) -> (tempfile::TempDir, Page) {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let file = dir.path().join("page.html");
    let html = format!(
        "<!doctype html>\n<html><head><meta charset=\"utf-8\"><title>t</title></head>\n\
         <body>\n{body}\n</body></html>\n"
    );
    std::fs::write(&file, html).expect("the page is written");
    let page = browser::open(&file).unwrap_or_else(|e| panic!("opening {}: {e}", file.display()));
    (dir, page)
}

/// Processes whose process group is `pgid`, from /proc.
fn group_members(pgid: u32) -> Vec<u32> {
    let mut members = Vec::new();
    for entry in std::fs::read_dir("/proc").expect("/proc").flatten() {
        let Ok(pid) = entry.file_name().to_string_lossy().parse::<u32>() else {
            continue;
        };
        let Ok(stat) = std::fs::read_to_string(entry.path().join("stat")) else {
            continue;
        };
        // pid (comm) state ppid pgrp ...; comm may hold spaces.
        let after_comm = stat.rsplit_once(')').map_or("", |(_, rest)| rest);
        let pgrp = after_comm.split_whitespace().nth(2);
        if pgrp.and_then(|g| g.parse::<u32>().ok()) == Some(pgid) {
            members.push(pid);
        }
    }
    members
}

#[test]
fn a_browser_is_installed() {
    assert!(browser::chromium().is_some(), "{}", BrowserError::NotFound);
}

#[test]
fn a_clean_page_has_no_errors_a_painted_canvas_and_decoded_images() {
    let (_dir, page) = open(&format!(
        r##"<canvas id="replay" width="200" height="100"></canvas>
        <img id="plot" src="{PNG}" alt="plot">
        <script>
          window.frames_drawn = 0;
          const ctx = document.getElementById("replay").getContext("2d");
          function frame(t) {{
            ctx.fillStyle = "#fff";
            ctx.fillRect(0, 0, 200, 100);
            ctx.fillStyle = "#06c";
            ctx.fillRect((t / 10) % 180, 40, 20, 20);
            window.frames_drawn++;
            requestAnimationFrame(frame);
          }}
          requestAnimationFrame(frame);
        </script>"##
    ));
    page.wait_for("window.frames_drawn > 3", Duration::from_secs(20))
        .expect("requestAnimationFrame runs in the headless page");
    assert!(page.canvas_is_painted("#replay").unwrap());
    assert_eq!(page.images_decoded().unwrap(), (1, 1));
    assert!(page.undecoded_images().unwrap().is_empty());
    assert_eq!(page.console_errors(), Vec::<String>::new());
    assert_eq!(
        page.eval_json("document.getElementById('plot').naturalWidth")
            .unwrap(),
        1
    );
}

#[test]
fn console_error_calls_are_reported_during_and_after_load() {
    let (_dir, page) = open(
        r##"<script>
          console.log("fine");
          console.warn("only a warning");
          console.error("x", 42, {a: 1});
          setTimeout(() => console.error("later"), 50);
        </script>"##,
    );
    page.wait_for("true", Duration::from_secs(1)).unwrap();
    let end = Instant::now() + Duration::from_secs(10);
    while page.console_errors().len() < 2 && Instant::now() < end {
        std::thread::sleep(Duration::from_millis(20));
    }
    let errors = page.console_errors();
    assert_eq!(errors.len(), 2, "{errors:?}");
    assert!(errors[0].contains("x 42"), "{errors:?}");
    assert!(errors[0].starts_with("console.error"), "{errors:?}");
    assert!(errors[1].contains("later"), "{errors:?}");
}

#[test]
fn uncaught_exceptions_and_rejections_are_reported() {
    let (_dir, page) = open(
        r##"<script>
          Promise.reject(new Error("nobody caught me"));
        </script>
        <script>
          throw new TypeError("boom");
        </script>
        <script>window.after = true;</script>"##,
    );
    // A script that throws stops only itself.
    assert_eq!(page.eval_json("window.after").unwrap(), true);
    page.wait_for("true", Duration::from_secs(1)).unwrap();
    let errors = page.console_errors();
    assert!(
        errors.iter().any(|e| e.contains("TypeError: boom")),
        "{errors:?}"
    );
    assert!(
        errors.iter().any(|e| e.contains("nobody caught me")),
        "{errors:?}"
    );
    assert!(
        errors.iter().any(|e| e.contains("page.html")),
        "the location is given: {errors:?}"
    );
}

#[test]
fn blank_and_uniform_canvases_are_not_painted() {
    let (_dir, page) = open(
        r##"<canvas id="blank" width="50" height="50"></canvas>
        <canvas id="grey" width="50" height="50"></canvas>
        <canvas id="empty" width="0" height="0"></canvas>
        <canvas id="dot" width="50" height="50"></canvas>
        <div id="not-a-canvas"></div>
        <script>
          const g = document.getElementById("grey").getContext("2d");
          g.fillStyle = "#888";
          g.fillRect(0, 0, 50, 50);
          const d = document.getElementById("dot").getContext("2d");
          d.fillStyle = "#000";
          d.fillRect(49, 49, 1, 1);
        </script>"##,
    );
    assert!(!page.canvas_is_painted("#blank").unwrap());
    assert!(!page.canvas_is_painted("#grey").unwrap());
    assert!(!page.canvas_is_painted("#empty").unwrap());
    // One pixel that differs, in the last place looked at, is enough.
    assert!(page.canvas_is_painted("#dot").unwrap());
    let missing = page.canvas_is_painted("#nowhere").unwrap_err().to_string();
    assert!(missing.contains("no element matches #nowhere"), "{missing}");
    let wrong = page
        .canvas_is_painted("#not-a-canvas")
        .unwrap_err()
        .to_string();
    assert!(wrong.contains("not a <canvas>"), "{wrong}");
    assert_eq!(page.console_errors(), Vec::<String>::new());
}

#[test]
fn a_missing_image_is_not_decoded_and_its_failed_load_is_reported() {
    let (_dir, page) = open(&format!(
        r##"<img src="{PNG}" alt="good"><img src="missing.png" alt="missing">"##
    ));
    assert_eq!(page.images_decoded().unwrap(), (2, 1));
    let undecoded = page.undecoded_images().unwrap();
    assert_eq!(undecoded.len(), 1, "{undecoded:?}");
    assert!(undecoded[0].ends_with("/missing.png"), "{undecoded:?}");
    let errors = page.console_errors();
    assert!(
        errors
            .iter()
            .any(|e| e.contains("missing.png") || e.contains("ERR_FILE_NOT_FOUND")),
        "{errors:?}"
    );
}

#[test]
fn eval_json_returns_values_awaits_promises_and_reports_throws() {
    let (_dir, page) = open("<p id=\"p\">hello</p>");
    assert_eq!(
        page.eval_json("({n: 1.5, s: document.getElementById('p').textContent, a: [true, null]})")
            .unwrap(),
        serde_json::json!({"n": 1.5, "s": "hello", "a": [true, null]})
    );
    assert_eq!(
        page.eval_json("undefined").unwrap(),
        serde_json::Value::Null
    );
    assert_eq!(
        page.eval_json("new Promise(r => setTimeout(() => r(42), 20))")
            .unwrap(),
        42
    );
    match page.eval_json("no_such_name + 1") {
        Err(BrowserError::Script(m)) => assert!(m.contains("no_such_name"), "{m}"),
        other => panic!("expected a script error, got {other:?}"),
    }
    match page.eval_json("Promise.reject(new Error('rejected'))") {
        Err(BrowserError::Script(m)) => assert!(m.contains("rejected"), "{m}"),
        other => panic!("expected a script error, got {other:?}"),
    }
    // What the test itself evaluates is no console error of the page.
    assert_eq!(page.console_errors(), Vec::<String>::new());
}

#[test]
fn wait_for_times_out_with_the_last_value() {
    let (_dir, page) = open("<script>setTimeout(() => window.ready = 1, 100)</script>");
    page.wait_for("window.ready === 1", Duration::from_secs(10))
        .unwrap();
    let start = Instant::now();
    let err = page
        .wait_for("window.never === 1", Duration::from_millis(300))
        .unwrap_err();
    assert!(start.elapsed() < Duration::from_secs(5));
    assert!(matches!(err, BrowserError::Timeout(_)), "{err}");
    assert!(err.to_string().contains("window.never === 1"), "{err}");
}

#[test]
fn a_missing_file_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let err = browser::open(&dir.path().join("nope.html"))
        .err()
        .expect("no page for a missing file");
    assert!(matches!(err, BrowserError::Navigation(_)), "{err}");
    assert!(err.to_string().contains("nope.html"), "{err}");
}

#[test]
fn dropping_the_page_ends_every_browser_process() {
    let (_dir, page) = open("<p>bye</p>");
    let pid = page.pid();
    assert!(
        group_members(pid).len() > 1,
        "the browser runs in its own process group with its helpers"
    );
    let start = Instant::now();
    drop(page);
    let took = start.elapsed();
    assert_eq!(group_members(pid), Vec::<u32>::new());
    assert!(!Path::new(&format!("/proc/{pid}")).exists());
    // Two graces at most (the browser's, then its orphans'), and a margin
    // for a loaded host: what counts is that dropping ends.
    let most = 2 * browser::CLOSE_GRACE + Duration::from_secs(2);
    assert!(took < most, "closing took {took:?}");
}
