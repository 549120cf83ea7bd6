//! Flight replays, drawn from a [`Recording`]: a static SVG of one flight
//! ([`flight_svg`]) and an animated canvas replay, either as a standalone
//! page ([`flight_html`]) or as a fragment for the experiment report
//! ([`replay_widget`] plus [`REPLAY_JS`] and [`REPLAY_CSS`], inlined once
//! per page).
//!
//! The world is SPEC §1's: y grows upward, a model point `(px, py)` of the
//! hull sits at `x + s·(px·cos rot + py·sin rot)`,
//! `y + s·(−px·sin rot + py·cos rot)` with `s = hull_scale`, and x wraps at
//! the world's edges. SVG and canvas y grow downward, so both drawings flip y.
//!
//! Everything here is self-contained: no fonts, scripts or styles are fetched
//! from anywhere, so a report works from a file on a machine offline.

use std::fmt::Write as _;
use std::ops::Range;

use crate::escape::escape;
use crate::model::{Frame, Recording, Scene};

/// The replay script for [`replay_widget`]s; inline it once per page, after
/// or before the widgets (it waits for the document to load).
pub const REPLAY_JS: &str = include_str!("../assets/replay.js");

/// The widgets' style sheet; inline it once per page.
pub const REPLAY_CSS: &str = include_str!("../assets/replay.css");

/// The class that marks a replay widget; the script finds widgets by it.
const WIDGET_CLASS: &str = "lander-replay";

/// The canvas's width in pixels; its height keeps the world's aspect ratio.
const CANVAS_WIDTH: f64 = 800.0;

/// The number of points in SPEC §1's hull, whose parts [`hull_parts`] knows.
const SPEC_HULL_POINTS: usize = 30;

/// The hull's drawing parts: a class name, the range of `scene.hull` it
/// takes, and whether the outline closes. SPEC §1 lists the 30 points part
/// by part: body box, cabin, left leg, right leg, nozzle. Any other hull is
/// drawn as one closed outline. `replay.js` mirrors this in `hullParts`.
fn hull_parts(points: usize) -> Vec<(&'static str, Range<usize>, bool)> {
    if points == SPEC_HULL_POINTS {
        vec![
            ("body", 0..4, true),
            ("cabin", 4..12, false),
            ("leg-left", 12..19, false),
            ("leg-right", 19..26, false),
            ("nozzle", 26..30, false),
        ]
    } else if points == 0 {
        Vec::new()
    } else {
        vec![("outline", 0..points, true)]
    }
}

/// A model point's world position for a lander at `frame`, by SPEC §1.
fn to_world(scene: &Scene, frame: &Frame, (px, py): (f64, f64)) -> (f64, f64) {
    let (sin, cos) = frame.rot.sin_cos();
    let s = scene.hull_scale;
    (
        frame.x + s * (px * cos + py * sin),
        frame.y + s * (-px * sin + py * cos),
    )
}

/// A coordinate with at most two decimals and no trailing zeros.
fn num(v: f64) -> String {
    let s = format!("{v:.2}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_owned()
    } else {
        s.to_owned()
    }
}

/// The flight's path as polylines of world points: the segment into frame
/// `i` is kept when `keep(frame i)` holds and it does not jump across the
/// world's wrap (|Δx| > width/2). Consecutive kept segments join.
fn trajectory_runs(
    frames: &[Frame],
    width: f64,
    keep: impl Fn(&Frame) -> bool,
) -> Vec<Vec<(f64, f64)>> {
    let mut runs = Vec::new();
    let mut run: Vec<(f64, f64)> = Vec::new();
    for pair in frames.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        if keep(&b) && (b.x - a.x).abs() <= width / 2.0 {
            if run.is_empty() {
                run.push((a.x, a.y));
            }
            run.push((b.x, b.y));
        } else if !run.is_empty() {
            runs.push(std::mem::take(&mut run));
        }
    }
    if !run.is_empty() {
        runs.push(run);
    }
    runs
}

/// Drops points closer than `min` to the last one kept, always keeping both
/// ends, so a 100,000-tick flight does not become a 100,000-point polyline.
fn thin(run: &[(f64, f64)], min: f64) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, f64)> = Vec::with_capacity(run.len());
    for (i, &p) in run.iter().enumerate() {
        let far = out
            .last()
            .is_none_or(|&(x, y)| (p.0 - x).hypot(p.1 - y) >= min);
        if far || i + 1 == run.len() {
            out.push(p);
        }
    }
    out
}

/// One line of the outcome: safe or crashed, ticks flown, and the distance
/// from the pad at touchdown.
fn outcome_text(recording: &Recording) -> String {
    let verdict = if recording.safe {
        "safe landing"
    } else {
        "crashed"
    };
    match recording.frames.last() {
        Some(last) => format!(
            "{verdict} · {} ticks · {:.1} px from the pad",
            recording.frames.len() - 1,
            (last.x - recording.scene.pad_x).abs()
        ),
        None => verdict.to_owned(),
    }
}

/// A static SVG of the recorded flight: sky, ground, pad, the trajectory (thrust in
/// orange), a marker at the start and the lander at touchdown, with the
/// title and the outcome. The view box is the world, with y flipped.
pub fn flight_svg(recording: &Recording) -> String {
    let scene = &recording.scene;
    let (w, h) = (scene.width, scene.height);
    // SVG y grows downward.
    let fy = |y: f64| h - y;
    let pt = |(x, y): (f64, f64)| format!("{},{}", num(x), num(fy(y)));
    let mut svg = String::new();
    let title = escape(&recording.title);
    let _ = writeln!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" class="lander-flight" viewBox="0 0 {} {}" width="{}" height="{}" role="img" font-family="system-ui, sans-serif">"#,
        num(w),
        num(h),
        num(2.0 * w),
        num(2.0 * h)
    );
    let _ = writeln!(svg, "<title>{title}</title>");

    // Sky, a faint glow over the horizon, and ground below the touchdown line.
    let _ = writeln!(
        svg,
        r##"<rect class="sky" x="0" y="0" width="{}" height="{}" fill="#070b18"/>"##,
        num(w),
        num(h)
    );
    // Bands of growing opacity fake a gradient without a <defs> id, which
    // would clash between several SVGs inlined in one page.
    for band in 1..=16 {
        let top = scene.ground_y + 85.0 - 5.0 * f64::from(band);
        let _ = writeln!(
            svg,
            r##"<rect class="horizon" x="0" y="{}" width="{}" height="5" fill="#1d2a4a" opacity="{}"/>"##,
            num(fy(top)),
            num(w),
            num(0.05 * f64::from(band))
        );
    }
    let _ = writeln!(
        svg,
        r##"<rect class="ground" x="0" y="{}" width="{}" height="{}" fill="#5d5f68"/>"##,
        num(fy(scene.ground_y)),
        num(w),
        num(scene.ground_y.max(0.0))
    );
    let _ = writeln!(
        svg,
        r##"<line class="ground-line" x1="0" y1="{y}" x2="{}" y2="{y}" stroke="#9a9ca6" stroke-width="0.8"/>"##,
        num(w),
        y = num(fy(scene.ground_y))
    );

    // The pad: a platform on the ground line, with a beacon at each end.
    let (left, right) = (
        scene.pad_x - scene.pad_half_width,
        scene.pad_x + scene.pad_half_width,
    );
    let _ = writeln!(
        svg,
        r##"<g class="pad"><rect x="{}" y="{}" width="{}" height="4" fill="#f2c14e" stroke="#fff3c4" stroke-width="0.5"/><circle cx="{}" cy="{b}" r="1.3" fill="#ff5b5b"/><circle cx="{}" cy="{b}" r="1.3" fill="#5bff8a"/></g>"##,
        num(left),
        num(fy(scene.ground_y)),
        num(2.0 * scene.pad_half_width),
        num(left),
        num(right),
        b = num(fy(scene.ground_y) - 1.5)
    );

    // The trajectory, then the thrusting stretches over it.
    let layers: [(&str, &str, f64, bool); 2] = [
        ("trajectory", "#9fc3ff", 0.8, false),
        ("trajectory-thrust", "#ff9d3a", 1.4, true),
    ];
    for (class, colour, width, thrust_only) in layers {
        for run in trajectory_runs(&recording.frames, w, |f| !thrust_only || f.thrust) {
            let points: Vec<String> = thin(&run, 0.75).into_iter().map(pt).collect();
            let _ = writeln!(
                svg,
                r#"<polyline class="{class}" points="{}" fill="none" stroke="{colour}" stroke-width="{width}" stroke-linejoin="round" stroke-linecap="round"/>"#,
                points.join(" ")
            );
        }
    }

    if let Some(first) = recording.frames.first() {
        let _ = writeln!(
            svg,
            r##"<circle class="start" cx="{}" cy="{}" r="2" fill="none" stroke="#9fc3ff" stroke-width="0.8"/>"##,
            num(first.x),
            num(fy(first.y))
        );
    }

    // The lander at touchdown, drawn again across the edge when it straddles
    // the wrap.
    if let Some(last) = recording.frames.last() {
        let reach = 2.0 * scene.hull_scale;
        let mut shifts = vec![0.0];
        if last.x < reach {
            shifts.push(w);
        }
        if last.x > w - reach {
            shifts.push(-w);
        }
        for shift in shifts {
            let frame = Frame {
                x: last.x + shift,
                ..*last
            };
            svg.push_str(&lander_svg(scene, &frame, &pt));
        }
    }

    // Title and outcome, top left, with a dark halo so a trajectory under
    // them does not cut through the letters.
    let halo =
        r##"stroke="#070b18" stroke-width="2.5" stroke-linejoin="round" paint-order="stroke""##;
    let outcome_colour = if recording.safe { "#5bff8a" } else { "#ff6b6b" };
    let _ = writeln!(
        svg,
        r##"<text class="title" x="6" y="14" font-size="11" fill="#e8eef8" {halo}>{title}</text>"##
    );
    let _ = writeln!(
        svg,
        r#"<text class="outcome" x="6" y="27" font-size="9" fill="{outcome_colour}" {halo}>{}</text>"#,
        escape(&outcome_text(recording))
    );
    svg.push_str("</svg>\n");
    svg
}

/// The lander at `frame` as SVG: one polyline or polygon per hull part. It
/// shows no flame: at touchdown the flight is over, and the trajectory
/// already shows where the engine fired.
fn lander_svg(scene: &Scene, frame: &Frame, pt: &impl Fn((f64, f64)) -> String) -> String {
    let mut g = String::from("<g class=\"lander\">");
    for (name, range, closed) in hull_parts(scene.hull.len()) {
        let points: Vec<String> = scene.hull[range]
            .iter()
            .map(|&p| pt(to_world(scene, frame, p)))
            .collect();
        let (tag, fill) = match (name, closed) {
            ("body", _) => ("polygon", "#b9c3d3"),
            ("cabin", _) => ("polyline", "#3d5a8a"),
            ("nozzle", _) => ("polyline", "#8a93a3"),
            (_, true) => ("polygon", "#b9c3d3"),
            (_, false) => ("polyline", "none"),
        };
        let _ = write!(
            g,
            r##"<{tag} class="hull-part {name}" points="{}" fill="{fill}" stroke="#f4f7fc" stroke-width="0.8" stroke-linejoin="round"/>"##,
            points.join(" ")
        );
    }
    g.push_str("</g>\n");
    g
}

/// The recording as JSON that is safe inside a `<script>` element: `</`
/// becomes `<\/` so no string can close the element, and `<!--` becomes
/// `\u003c!--` so none can switch the HTML parser into its script-escape
/// state. Both are valid JSON escapes, so the text parses back to the same
/// recording.
fn script_json(recording: &Recording) -> String {
    // A Recording is plain data and always serialises.
    let json = serde_json::to_string(recording).unwrap_or_else(|_| "null".to_owned());
    json.replace("</", "<\\/").replace("<!--", "\\u003c!--")
}

/// The replay widget for `recording`: a canvas, its controls (play/pause,
/// restart, speed, a seek bar, the tick and the outcome) and the recording
/// as embedded JSON in `<script type="application/json" id="{id}-data">`.
/// `id` names the widget's element and should be unique on the page. The
/// page must also inline [`REPLAY_JS`] and [`REPLAY_CSS`] once.
pub fn replay_widget(recording: &Recording, id: &str) -> String {
    let scene = &recording.scene;
    let aspect = if scene.width > 0.0 && scene.height > 0.0 {
        scene.height / scene.width
    } else {
        0.75
    };
    let canvas_height = (CANVAS_WIDTH * aspect).round();
    let id = escape(id);
    let title = escape(&recording.title);
    let last = recording.frames.len().saturating_sub(1);
    let speeds = [
        (0.25, "0.25×"),
        (0.5, "0.5×"),
        (1.0, "1×"),
        (2.0, "2×"),
        (4.0, "4×"),
        (8.0, "8×"),
    ];
    let options: String = speeds
        .iter()
        .map(|(v, label)| {
            let selected = if *v == 1.0 { " selected" } else { "" };
            format!(r#"<option value="{v}"{selected}>{label}</option>"#)
        })
        .collect();
    format!(
        r#"<figure class="{WIDGET_CLASS}" id="{id}" data-lander-replay="{id}-data">
<canvas class="lander-replay-canvas" width="{CANVAS_WIDTH}" height="{canvas_height}" role="img" aria-label="Animated replay: {title}"></canvas>
<div class="lander-replay-controls">
<button type="button" data-role="play">Pause</button>
<button type="button" data-role="restart">Restart</button>
<label>Speed <select data-role="speed">{options}</select></label>
<input type="range" data-role="seek" min="0" max="{last}" value="0" step="1" aria-label="Tick">
<span class="lander-replay-status" data-role="status">tick 0 / {last}</span>
<span class="lander-replay-outcome" data-role="outcome"></span>
</div>
<figcaption>{title}</figcaption>
<script type="application/json" class="lander-replay-data" id="{id}-data">{json}</script>
</figure>
"#,
        json = script_json(recording),
    )
}

/// A standalone HTML page that animates the recorded flight: the replay widget with
/// the script and style sheet inlined, so it needs no network.
pub fn flight_html(recording: &Recording) -> String {
    let title = escape(&recording.title);
    format!(
        r#"<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{title}</title>
<style>
body {{ margin: 0; padding: 1rem; background: #10131c; color: #e8eef8; font-family: system-ui, sans-serif; }}
h1 {{ font-size: 1.2rem; font-weight: 600; margin: 0 0 0.75rem; }}
{css}</style>
</head>
<body>
<h1>{title}</h1>
{widget}<script>
{js}</script>
</body>
</html>
"#,
        css = REPLAY_CSS,
        widget = replay_widget(recording, "flight"),
        js = REPLAY_JS,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// SPEC §1's hull, one part a line.
    #[rustfmt::skip]
    fn spec_hull() -> Vec<(f64, f64)> {
        vec![
            (-1.0, 0.0), (1.0, 0.0), (1.0, -0.5), (-1.0, -0.5),
            (-0.5, 0.0), (-1.0, 0.3), (-1.0, 0.7), (-0.5, 1.0), (0.5, 1.0), (1.0, 0.7), (1.0, 0.3), (0.5, 0.0),
            (-1.0, -0.4), (-1.3, -0.8), (-1.3, -1.2), (-1.5, -1.2), (-1.1, -1.2), (-0.9, -0.5), (-1.3, -0.8),
            (1.0, -0.4), (1.3, -0.8), (1.3, -1.2), (1.5, -1.2), (1.1, -1.2), (0.9, -0.5), (1.3, -0.8),
            (-0.2, -0.5), (-0.3, -0.8), (0.3, -0.8), (0.2, -0.5),
        ]
    }

    fn scene(pad_x: f64) -> Scene {
        Scene {
            width: 400.0,
            height: 300.0,
            ground_y: 55.0,
            pad_x,
            pad_half_width: 10.0,
            hull: spec_hull(),
            hull_scale: 10.0,
        }
    }

    fn any_hull_below(scene: &Scene, frame: &Frame) -> bool {
        scene
            .hull
            .iter()
            .any(|&p| to_world(scene, frame, p).1 < scene.ground_y)
    }

    /// A lander that starts upside down at (200, 250), turns upright while it
    /// falls, and brakes with the engine, steering towards a pad at 235, by
    /// SPEC §1's physics.
    fn sample_recording() -> Recording {
        let scene = scene(235.0);
        let (mut x, mut y, mut vx, mut vy, mut rot) =
            (200.0_f64, 250.0_f64, 0.0_f64, 0.0_f64, std::f64::consts::PI);
        let accel = (350.0 / 60.0) / 100.0;
        let mut frames = vec![Frame {
            x,
            y,
            rot,
            thrust: false,
        }];
        let mut upright = false;
        for _ in 0..5000 {
            let alt = y - 67.0;
            let mut thrust = false;
            if !upright {
                rot += 0.05;
                if rot > 2.0 * std::f64::consts::PI {
                    rot -= 2.0 * std::f64::consts::PI;
                    upright = true;
                }
            } else {
                // Lean towards the pad while high, then stand up straight.
                let dx = scene.pad_x - x;
                let want_rot = if alt > 30.0 {
                    (0.01 * dx - 0.8 * vx).clamp(-0.3, 0.3)
                } else {
                    (-0.5 * vx).clamp(-0.1, 0.1)
                };
                let want_vy = -(0.3 + alt / 90.0);
                if vy < want_vy {
                    thrust = true;
                    vx += accel * rot.sin();
                    vy += accel * rot.cos();
                } else if rot < want_rot - 0.025 {
                    rot += 0.05;
                } else if rot > want_rot + 0.025 {
                    rot -= 0.05;
                }
            }
            vy -= 1.63 / 60.0;
            x += vx;
            y += vy;
            if x > scene.width {
                x = 0.0;
            } else if x < 0.0 {
                x = scene.width;
            }
            let frame = Frame { x, y, rot, thrust };
            frames.push(frame);
            if any_hull_below(&scene, &frame) {
                break;
            }
        }
        let last = *frames.last().unwrap();
        let speed = vx.hypot(vy);
        let safe = (last.x - scene.pad_x).abs() < 10.0
            && speed < 0.5
            && last.rot.abs() < std::f64::consts::PI / 16.0;
        Recording {
            title: format!(
                "sample flight: {}",
                if safe { "landed safely" } else { "crashed" }
            ),
            scene,
            frames,
            safe,
        }
    }

    /// A recording of a flight drifting right across the world's right edge.
    fn wrapping_recording() -> Recording {
        let xs = [380.0, 390.0, 398.0, 2.0, 10.0, 20.0];
        let frames = xs
            .iter()
            .enumerate()
            .map(|(i, &x)| Frame {
                x,
                y: 200.0 - 10.0 * i as f64,
                rot: 0.0,
                thrust: i == 4,
            })
            .collect();
        Recording {
            title: "wrap".into(),
            scene: scene(100.0),
            frames,
            safe: false,
        }
    }

    /// The text of the embedded JSON script element.
    fn embedded_json(html: &str) -> &str {
        let open = r#"<script type="application/json" class="lander-replay-data""#;
        let start = html.find(open).expect("the JSON script element");
        let body = start + html[start..].find('>').unwrap() + 1;
        let end = body
            + html[body..]
                .find("</script>")
                .expect("the JSON script closes");
        &html[body..end]
    }

    fn polylines<'a>(svg: &'a str, class: &str) -> Vec<&'a str> {
        let marker = format!(r#"<polyline class="{class}" points=""#);
        svg.match_indices(&marker)
            .map(|(i, _)| {
                let rest = &svg[i + marker.len()..];
                &rest[..rest.find('"').unwrap()]
            })
            .collect()
    }

    #[test]
    fn sample_flight_lands_safely() {
        let recording = sample_recording();
        assert!(recording.safe, "{:?}", recording.frames.last());
        assert!(recording.frames.iter().any(|f| f.thrust));
    }

    #[test]
    fn svg_draws_scene_trajectory_and_lander() {
        let recording = sample_recording();
        let svg = flight_svg(&recording);
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        assert!(svg.contains(r#"class="ground""#));
        // The pad spans pad_x ± pad_half_width on the ground line (y = 300 − 55).
        assert!(
            svg.contains(r#"<g class="pad"><rect x="225" y="245" width="20""#),
            "{svg}"
        );
        assert_eq!(polylines(&svg, "trajectory").len(), 1);
        assert!(!polylines(&svg, "trajectory-thrust").is_empty());
        for part in ["body", "cabin", "leg-left", "leg-right", "nozzle"] {
            assert_eq!(
                svg.matches(&format!(r#"class="hull-part {part}""#)).count(),
                1,
                "{part}"
            );
        }
        assert!(svg.contains("sample flight") && svg.contains("safe landing"));
    }

    #[test]
    fn svg_lander_sits_on_the_ground_at_touchdown() {
        let recording = sample_recording();
        let svg = flight_svg(&recording);
        let lander = &svg[svg.find(r#"<g class="lander">"#).unwrap()..];
        let lander = &lander[..lander.find("</g>").unwrap()];
        // The lowest hull point (largest SVG y) is just under the ground line.
        let max_y = lander
            .split("points=\"")
            .skip(1)
            .flat_map(|s| {
                s[..s.find('"').unwrap()]
                    .split(' ')
                    .map(|p| p.split(',').nth(1).unwrap().parse::<f64>().unwrap())
            })
            .fold(f64::MIN, f64::max);
        assert!((245.0..248.0).contains(&max_y), "{max_y}");
    }

    #[test]
    fn svg_breaks_the_trajectory_at_the_wrap() {
        let svg = flight_svg(&wrapping_recording());
        let runs = polylines(&svg, "trajectory");
        // y = 200 − 10·i flips to 300 − y.
        assert_eq!(runs, ["380,100 390,110 398,120", "2,130 10,140 20,150"]);
        // The thrust stretch is the one segment into frame 4, after the wrap.
        assert_eq!(polylines(&svg, "trajectory-thrust"), ["2,130 10,140"]);
    }

    #[test]
    fn svg_draws_any_hull_and_escapes_the_title() {
        let mut recording = wrapping_recording();
        recording.scene.hull = vec![(-1.0, 0.0), (0.0, 1.0), (1.0, 0.0)];
        recording.title = "a < b & \"c\"".into();
        recording.frames.last_mut().unwrap().x = 5.0;
        let svg = flight_svg(&recording);
        assert!(svg.contains(r#"class="hull-part outline""#));
        assert!(svg.contains("a &lt; b &amp; &quot;c&quot;"));
        assert!(!svg.contains("a < b"));
        // At x = 5 the lander straddles the left edge, so it is drawn twice.
        assert_eq!(svg.matches(r#"<g class="lander">"#).count(), 2);
    }

    #[test]
    fn svg_survives_an_empty_flight() {
        let recording = Recording {
            title: "empty".into(),
            scene: scene(100.0),
            frames: Vec::new(),
            safe: false,
        };
        let svg = flight_svg(&recording);
        assert!(!svg.contains("<polyline") && !svg.contains("class=\"lander\""));
        assert!(flight_html(&recording).contains("tick 0 / 0"));
    }

    #[test]
    fn thin_keeps_ends_and_drops_close_points() {
        let run: Vec<(f64, f64)> = (0..=100).map(|i| (i as f64 * 0.1, 0.0)).collect();
        let thinned = thin(&run, 1.0);
        assert_eq!(thinned.first(), Some(&(0.0, 0.0)));
        assert_eq!(thinned.last(), Some(&(10.0, 0.0)));
        assert!(thinned.len() <= 12, "{}", thinned.len());
    }

    /// serde_json's default float parser may be one ulp off, so frames
    /// compare to within a nanopixel.
    fn assert_same_recording(back: &Recording, recording: &Recording) {
        assert_eq!(back.title, recording.title);
        assert_eq!(back.scene, recording.scene);
        assert_eq!(back.safe, recording.safe);
        assert_eq!(back.frames.len(), recording.frames.len());
        for (b, f) in back.frames.iter().zip(&recording.frames) {
            let close = (b.x - f.x).abs() < 1e-9
                && (b.y - f.y).abs() < 1e-9
                && (b.rot - f.rot).abs() < 1e-9;
            assert!(close && b.thrust == f.thrust, "{b:?} vs {f:?}");
        }
    }

    #[test]
    fn html_embeds_the_flight_as_json() {
        let recording = sample_recording();
        let html = flight_html(&recording);
        let back: Recording = serde_json::from_str(embedded_json(&html)).unwrap();
        assert_same_recording(&back, &recording);
        assert!(html.contains(r#"id="flight-data""#));
    }

    #[test]
    fn html_json_cannot_close_its_script() {
        let mut recording = wrapping_recording();
        recording.title = "evil </script><script>alert(1)</script> <!-- x".into();
        let html = flight_html(&recording);
        let json = embedded_json(&html);
        assert!(json.contains(r"<\/script>"));
        assert!(!json.contains("</") && !json.contains("<!--"));
        let back: Recording = serde_json::from_str(json).unwrap();
        assert_same_recording(&back, &recording);
        // The title shows escaped everywhere else.
        assert!(html.contains("evil &lt;/script&gt;"));
        let inner = REPLAY_JS.matches("<script").count() + json.matches("<script").count();
        let tags = html.matches("<script").count() - inner;
        assert_eq!(tags, 2, "the JSON, the replay script and nothing else");
    }

    #[test]
    fn html_is_self_contained() {
        let html = flight_html(&sample_recording());
        assert!(!html.contains("http://") && !html.contains("https://"));
        assert!(!html.contains("src=") && !html.contains("<link"));
        assert!(html.contains(REPLAY_JS) && html.contains(REPLAY_CSS));
        // The inlined assets cannot end their own elements early.
        assert!(!REPLAY_JS.contains("</script"));
        assert!(!REPLAY_CSS.contains("</style"));
    }

    #[test]
    fn widget_has_controls_and_is_found_by_class() {
        let recording = sample_recording();
        let widget = replay_widget(&recording, "best-guided");
        assert!(widget.starts_with(r#"<figure class="lander-replay" id="best-guided""#));
        for role in ["play", "restart", "speed", "seek", "status", "outcome"] {
            assert!(widget.contains(&format!(r#"data-role="{role}""#)), "{role}");
        }
        for speed in ["0.25", "1", "2", "4", "8"] {
            assert!(
                widget.contains(&format!(r#"<option value="{speed}""#)),
                "{speed}"
            );
        }
        assert!(widget.contains(r#"id="best-guided-data""#));
        assert!(widget.contains(r#"width="800" height="600""#));
        // The script looks widgets up by class, never by one fixed id.
        assert!(REPLAY_JS.contains(".lander-replay"));
        assert!(REPLAY_JS.contains("requestAnimationFrame"));
    }
}
