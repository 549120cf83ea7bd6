//! The envelope's tests: jobs and results round-trip; every kind of bad
//! frame is refused; arbitrary or mutated bytes never panic the decoder
//! and are refused or read as a wholly valid frame.

use super::*;
use crate::wire::{Job, KIND_EVALUATE};
use lander_model::{Env, GuideParams, Pass, StreamKey};
use proptest::prelude::*;

fn job() -> (JobHeader, Vec<WireGene>) {
    let header = JobHeader {
        version: PROTOCOL_VERSION,
        kind: KIND_EVALUATE,
        pass: Pass::Guide.code(),
        job_id: 7,
        key: StreamKey::new(1, 2, 0, 3),
        first_index: 10,
        genomes: 2,
        genome_length: 3,
        max_duration: 30,
        env: Env {
            x0: 20.0,
            pad_x: 200.0,
            ..Env::default()
        },
        guide: GuideParams::default(),
        ..JobHeader::default()
    };
    let genes = (0..6)
        .map(|i| WireGene {
            action: i % 4,
            duration: 5 + i,
        })
        .collect();
    (header, genes)
}

/// The frame decodes, and the job inside passes the worker's checks.
fn accepted(bytes: &[u8]) -> Result<Job, String> {
    let (h, genes) = decode_job(bytes).map_err(|e| e.to_string())?;
    Job::from_wire(&h, &genes).map_err(|e| e.to_string())
}

#[test]
fn jobs_and_results_round_trip() {
    let (h, genes) = job();
    assert_eq!(decode_job(&encode_job(&h, &genes)), Ok((h, genes)));
    let r = ResultHeader {
        version: PROTOCOL_VERSION,
        job_id: 7,
        worker_id: 9,
        ..ResultHeader::default()
    };
    assert_eq!(
        decode_result(&encode_result(&r, b"body")),
        Ok((r, b"body".to_vec()))
    );
}

#[test]
fn every_kind_of_bad_frame_is_refused() {
    let (h, genes) = job();
    let good = encode_job(&h, &genes);
    assert!(accepted(&good).is_ok());

    for cut in 0..good.len() {
        assert!(decode_job(&good[..cut]).is_err(), "truncated at {cut}");
    }
    let mut magic = good.clone();
    magic[0] = b'X';
    assert_eq!(decode_job(&magic), Err(FrameError::Magic));
    let mut longer = good.clone();
    longer.push(0);
    assert_eq!(decode_job(&longer), Err(FrameError::Trailing(1)));
    assert_eq!(
        decode_job(&vec![b'L'; MAX_FRAME + 1]),
        Err(FrameError::TooLarge(MAX_FRAME + 1))
    );
    // A result is not a job.
    let result = encode_result(&ResultHeader::default(), b"");
    assert!(matches!(decode_job(&result), Err(FrameError::Kind { .. })));

    let version = encode(&Frame {
        magic: MAGIC,
        version: PROTOCOL_VERSION + 1,
        kind: FRAME_JOB,
        body: &[],
    });
    assert_eq!(
        decode_job(&version),
        Err(FrameError::Version {
            got: PROTOCOL_VERSION + 1
        })
    );
    // A length prefix far beyond the frame.
    let mut oversize = MAGIC.to_vec();
    oversize.extend([
        PROTOCOL_VERSION as u8,
        FRAME_JOB,
        0xff,
        0xff,
        0xff,
        0xff,
        0x0f,
    ]);
    assert!(matches!(
        decode_job(&oversize),
        Err(FrameError::Malformed(_))
    ));

    let mut bad_action = genes.clone();
    bad_action[4].action = 4;
    let e = accepted(&encode_job(&h, &bad_action)).unwrap_err();
    assert!(e.contains("action"), "{e}");

    let mut nan = h;
    nan.env.world.gravity = f64::NAN;
    let e = accepted(&encode_job(&nan, &genes)).unwrap_err();
    assert!(e.contains("world.gravity"), "{e}");
    let mut inf = h;
    inf.guide.epsilon = f64::INFINITY;
    assert!(accepted(&encode_job(&inf, &genes)).is_err());

    let mut short = genes.clone();
    short.pop();
    assert!(accepted(&encode_job(&h, &short)).is_err());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn arbitrary_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..256)) {
        let _ = accepted(&bytes);
        let _ = decode_result(&bytes);
    }

    #[test]
    fn arbitrary_bytes_behind_the_magic_never_panic(
        bytes in prop::collection::vec(any::<u8>(), 0..256)
    ) {
        let mut frame = MAGIC.to_vec();
        frame.extend(bytes);
        let _ = accepted(&frame);
        let _ = decode_result(&frame);
    }

    /// Flipping, cutting or inserting bytes of a good frame gives either a
    /// refusal or a job that passes every check; never a panic, and never
    /// a job with a bad action or a non-finite number.
    #[test]
    fn mutated_frames_are_refused_or_fully_valid(
        at in any::<prop::sample::Index>(),
        byte in any::<u8>(),
        how in 0..3u8,
    ) {
        let (h, genes) = job();
        let mut frame = encode_job(&h, &genes);
        let i = at.index(frame.len());
        match how {
            0 => frame[i] ^= byte.max(1),
            1 => frame.truncate(i),
            _ => frame.insert(i, byte),
        }
        if let Ok(Job::Evaluate(job)) = accepted(&frame) {
            let numbers = [job.env.x0, job.env.pad_x, job.env.world.gravity, job.guide.epsilon];
            prop_assert!(numbers.iter().all(|v| v.is_finite()));
        }
    }
}
