//! Flights to replay: one genome flown tick by tick into a
//! [`lander_report::model::Recording`], and the best landing of an
//! experiment.

use crate::experiment::Experiment;
use lander_model::score::fitness;
use lander_model::{fly_traced, Outcome, HULL};
use lander_model::{parse_genome, Action, Env, Gene};
use lander_report::model::{Frame, Recording, Scene, TrialRecord};

/// The most frames a replay keeps; a longer flight keeps every k-th tick.
pub const MAX_FRAMES: usize = 20_000;

/// The scene of an environment.
pub fn scene(env: &Env) -> Scene {
    Scene {
        width: env.world.width,
        height: env.world.height,
        ground_y: env.world.ground_y,
        pad_x: env.pad_x,
        pad_half_width: env.scoring.safe_distance,
        hull: HULL.to_vec(),
        hull_scale: env.world.hull_scale,
    }
}

/// Flies `genes` in `env`, keeping a frame per tick.
pub fn trace(env: &Env, genes: &[Gene], title: String) -> (Recording, Outcome) {
    let start = Frame {
        x: env.x0,
        y: env.world.height - env.world.start_drop,
        rot: std::f64::consts::PI,
        thrust: false,
    };
    let mut frames = vec![start];
    let outcome = fly_traced(env, genes, |_, action, s| {
        frames.push(Frame {
            x: s.x,
            y: s.y,
            rot: s.rot,
            thrust: action == Action::Thrust,
        })
    });
    let recording = Recording {
        title,
        scene: scene(env),
        frames: thin(frames),
        safe: outcome.safe,
    };
    (recording, outcome)
}

/// Keeps at most [`MAX_FRAMES`] frames, always the first and the last.
fn thin(frames: Vec<Frame>) -> Vec<Frame> {
    if frames.len() <= MAX_FRAMES {
        return frames;
    }
    let step = frames.len().div_ceil(MAX_FRAMES - 1);
    let last = frames[frames.len() - 1];
    let mut kept: Vec<Frame> = frames.into_iter().step_by(step).collect();
    kept.push(last);
    kept
}

/// The best landing of any GA trial: of the safe landings, the one eq. 1
/// scores highest without the safe-landing bonus (nearest the pad centre,
/// slowest, most upright). Without a safe landing, the fittest flight.
pub fn best_landing(exp: &Experiment, records: &[TrialRecord]) -> Option<Recording> {
    let mut best: Option<(bool, f64, Recording)> = None;
    for r in records {
        let Some(lander) = &r.best else { continue };
        let cfg = exp.config(r.method, r.trial);
        // Records are checked as they are read (`Store::finished`): a
        // genome that does not read is not among them.
        let Ok(genes) = parse_genome(&lander.genome, cfg.ga.max_duration) else {
            continue;
        };
        let env = Env {
            world: cfg.world,
            scoring: cfg.scoring,
            x0: r.x0,
            pad_x: lander.pad_x,
        };
        let label = r.method.label();
        let (mut recording, outcome) = trace(&env, &genes, String::new());
        let ending = if outcome.safe {
            "landed safely"
        } else {
            "crashed"
        };
        recording.title = format!("{label}, trial {}: {ending}", r.trial);
        let score = fitness(&env, &outcome.state, outcome.n, false);
        let better = best
            .as_ref()
            .is_none_or(|(safe, s, _)| (outcome.safe, score) > (*safe, *s));
        if better {
            best = Some((outcome.safe, score, recording));
        }
    }
    best.map(|(_, _, recording)| recording)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::RunConfig;

    #[test]
    fn a_trace_starts_at_the_start_and_ends_at_touchdown() {
        let cfg = RunConfig::default();
        let env = cfg.env(0);
        let genes = parse_genome("2:10,3:5", 30).unwrap();
        let (recording, outcome) = trace(&env, &genes, "t".into());
        assert_eq!(recording.frames.len(), outcome.ticks as usize + 1);
        assert_eq!(recording.frames[0].y, 250.0);
        assert!(recording.frames[1..=10].iter().all(|f| f.thrust));
        assert!(!recording.frames[11].thrust);
        let last = recording.frames.last().unwrap();
        assert_eq!((last.x, last.y), (outcome.state.x, outcome.state.y));
    }

    #[test]
    fn long_flights_are_thinned_keeping_both_ends() {
        let frames: Vec<Frame> = (0..50_001)
            .map(|i| Frame {
                x: i as f64,
                y: 0.0,
                rot: 0.0,
                thrust: false,
            })
            .collect();
        let kept = thin(frames);
        assert!(kept.len() <= MAX_FRAMES);
        assert_eq!(kept[0].x, 0.0);
        assert_eq!(kept.last().unwrap().x, 50_000.0);
    }
}
