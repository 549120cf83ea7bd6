//! `check`: the checks an answer passes before the pool decodes it.

use crate::pool::link::check;
use lander_model::{Evaluation, Outcome, State};
use lander_protocol::wire::{ChunkResult, ResultHeader, Status, PROTOCOL_VERSION};

fn header(version: u32, status: Status, job_id: u64) -> ResultHeader {
    ResultHeader {
        version,
        status: status as u32,
        job_id,
        ..ResultHeader::default()
    }
}

fn body() -> Vec<u8> {
    let e = Evaluation {
        outcome: Outcome {
            state: State {
                x: 1.0,
                y: 60.0,
                vx: 0.0,
                vy: -0.1,
                rot: 0.0,
            },
            ticks: 10,
            n: 10,
            touched_down: true,
            safe: false,
            fitness: 700.0,
        },
        simulated_ticks: 10,
    };
    ChunkResult {
        evaluations: vec![e],
        actions: Vec::new(),
    }
    .encode()
}

#[test]
fn a_good_answer_passes() {
    let h = header(PROTOCOL_VERSION, Status::Done, 7);
    assert_eq!(check(7, &h, &body()), Ok(body()));
}

#[test]
fn answers_it_cannot_check_are_refused_with_the_reason() {
    let other = header(PROTOCOL_VERSION + 1, Status::Done, 7);
    let e = check(7, &other, &body()).unwrap_err();
    assert!(e.contains("protocol version"), "{e}");
    let wrong_job = header(PROTOCOL_VERSION, Status::Done, 8);
    assert!(check(7, &wrong_job, &body()).unwrap_err().contains("job 8"));
    let refused = header(PROTOCOL_VERSION, Status::WrongVersion, 7);
    let e = check(7, &refused, b"speaks version 9").unwrap_err();
    assert!(
        e.contains("refused") && e.contains("speaks version 9"),
        "{e}"
    );
}
