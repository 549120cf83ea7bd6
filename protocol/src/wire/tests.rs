//! The checks on jobs and results refuse everything they should.

use super::*;
use lander_model::{Outcome, State};

fn header(genomes: u32, length: u32) -> JobHeader {
    JobHeader {
        version: PROTOCOL_VERSION,
        pass: Pass::Guide.code(),
        genomes,
        genome_length: length,
        max_duration: 30,
        ..JobHeader::default()
    }
}

fn gene(action: u8, duration: u8) -> WireGene {
    WireGene { action, duration }
}

#[test]
fn a_good_job_decodes() {
    let job = Job::from_wire(
        &header(2, 2),
        &[gene(0, 1), gene(3, 30), gene(2, 0), gene(1, 5)],
    )
    .unwrap();
    let Job::Evaluate(job) = job else {
        panic!("an evaluation job")
    };
    assert_eq!(job.genes.len(), 4);
    assert_eq!(job.genes[1], Gene::new(Action::Drift, 30));
}

#[test]
fn bad_jobs_are_refused() {
    let genes = [gene(0, 1), gene(1, 1)];
    let mut h = header(1, 2);
    h.version = PROTOCOL_VERSION + 1;
    assert_eq!(
        Job::from_wire(&h, &genes),
        Err(WireError::Version {
            got: PROTOCOL_VERSION + 1
        })
    );
    let mut h = header(1, 2);
    h.pass = 9;
    assert_eq!(Job::from_wire(&h, &genes), Err(WireError::Pass(9)));
    assert!(matches!(
        Job::from_wire(&header(2, 2), &genes),
        Err(WireError::Length { .. })
    ));
    assert!(matches!(
        Job::from_wire(&header(1, 2), &[gene(0, 1), gene(4, 1)]),
        Err(WireError::Action {
            index: 1,
            action: 4
        })
    ));
    assert!(matches!(
        Job::from_wire(&header(1, 2), &[gene(0, 31), gene(1, 1)]),
        Err(WireError::Duration { index: 0, .. })
    ));
}

fn evaluation(fitness: f64) -> Evaluation {
    Evaluation {
        outcome: Outcome {
            state: State {
                x: 1.0,
                y: 60.0,
                vx: 0.1,
                vy: -0.2,
                rot: 0.0,
            },
            ticks: 100,
            n: 90,
            touched_down: true,
            safe: false,
            fitness,
        },
        simulated_ticks: 400,
    }
}

#[test]
fn results_round_trip_and_bad_ones_are_refused() {
    let good = ChunkResult {
        evaluations: vec![evaluation(500.0); 2],
        actions: vec![0, 1, 2, 3],
    };
    let bytes = good.encode();
    assert_eq!(
        ChunkResult::decode(&bytes, Pass::Guide, 2, 2),
        Ok(good.clone())
    );
    assert!(matches!(
        ChunkResult::decode(&bytes, Pass::Guide, 3, 2),
        Err(WireError::Count { .. })
    ));
    assert!(matches!(
        ChunkResult::decode(&bytes, Pass::Fly, 2, 2),
        Err(WireError::Length { .. })
    ));
    assert!(matches!(
        ChunkResult::decode(&bytes[..bytes.len() - 3], Pass::Guide, 2, 2),
        Err(WireError::Decode(_))
    ));
    // A good result with a byte after it is a malformed one.
    let mut longer = bytes.clone();
    longer.push(0);
    assert_eq!(
        ChunkResult::decode(&longer, Pass::Guide, 2, 2),
        Err(WireError::Decode(
            "1 bytes left over after the value".into()
        ))
    );

    let nan = ChunkResult {
        evaluations: vec![evaluation(500.0), evaluation(f64::NAN)],
        actions: vec![0; 4],
    };
    assert_eq!(
        ChunkResult::decode(&nan.encode(), Pass::Guide, 2, 2),
        Err(WireError::Implausible(1))
    );
    let action = ChunkResult {
        evaluations: vec![evaluation(1.0); 2],
        actions: vec![0, 1, 7, 3],
    };
    assert!(matches!(
        ChunkResult::decode(&action.encode(), Pass::Guide, 2, 2),
        Err(WireError::Action { index: 2, .. })
    ));
    let mut last = vec![3; 5000];
    last[4999] = 4;
    let late = ChunkResult {
        evaluations: vec![evaluation(1.0); 100],
        actions: last,
    };
    assert_eq!(
        ChunkResult::decode(&late.encode(), Pass::Guide, 100, 50),
        Err(WireError::Action {
            index: 4999,
            action: 4
        })
    );
}

#[test]
fn a_job_larger_than_a_chunk_may_be_is_refused_before_it_is_read() {
    // A genome of no genes is named as such, not as a count of genes.
    assert_eq!(Job::from_wire(&header(5, 0), &[]), Err(WireError::NoGenes));
    // One genome more than a chunk carries, every gene well-formed: the
    // worker would allocate and fly without bound.
    let most = most_genomes_per_chunk(1);
    let genes = vec![gene(0, 1); most + 1];
    assert_eq!(
        Job::from_wire(&header(most as u32 + 1, 1), &genes),
        Err(WireError::TooManyGenomes {
            genomes: most as u32 + 1,
            length: 1,
            most
        })
    );
    assert!(Job::from_wire(&header(most as u32, 1), &genes[..most]).is_ok());
    // A leg of one episode more than a chunk's records may hold, from the
    // trial's start; from one episode in, the same end fits.
    let mut h = header(0, 0);
    h.kind = KIND_TRAIN;
    h.learn = LearnParams {
        episodes: MOST_EPISODES_PER_CHUNK + 1,
        ..LearnParams::default()
    };
    h.until = h.learn.episodes;
    assert_eq!(
        Job::from_wire(&h, &[]),
        Err(WireError::LegTooLong {
            episodes: MOST_EPISODES_PER_CHUNK + 1,
            most: MOST_EPISODES_PER_CHUNK
        })
    );
    let state = LearnState {
        episodes: 1,
        rng_word: 0,
        first_safe: None,
        recent: vec![false],
        weights: Vec::new(),
    };
    let (genes, len) = pack_state(Some(&state));
    h.state_len = len;
    assert!(matches!(
        Job::from_wire(&h, &genes),
        Ok(Job::Train(TrainJob { from: Some(_), .. }))
    ));
}

#[test]
fn training_jobs_carry_their_state_and_sane_parameters() {
    let mut h = header(0, 0);
    h.kind = KIND_TRAIN;
    h.learn = LearnParams::default();
    h.until = h.learn.episodes;
    assert!(matches!(
        Job::from_wire(&h, &[]),
        Ok(Job::Train(TrainJob { from: None, .. }))
    ));
    assert_eq!(
        Job::from_wire(&h, &[gene(0, 1)]),
        Err(WireError::StateLength {
            len: 0,
            expected: 0,
            got: 1
        })
    );
    // A leg's state, of an odd number of bytes and of an even one, comes
    // through whole.
    let mut odd = 0;
    for weights in [vec![(3, 0.5)], vec![(3, 0.5), (70_000, -1.25e-3)]] {
        let state = LearnState {
            episodes: 40,
            rng_word: 123_456_789,
            first_safe: Some(12),
            recent: vec![true, false, true],
            weights,
        };
        let (genes, len) = pack_state(Some(&state));
        let mut leg = h;
        leg.state_len = len;
        leg.until = 100;
        let Ok(Job::Train(job)) = Job::from_wire(&leg, &genes) else {
            panic!("the leg was refused");
        };
        assert_eq!((job.from, job.until), (Some(state), 100));
        if len % 2 == 1 {
            // The byte that pads the last gene is 0.
            let mut padded = genes.clone();
            if let Some(last) = padded.last_mut() {
                last.duration = 7;
            }
            assert_eq!(
                Job::from_wire(&leg, &padded),
                Err(WireError::StatePadding { len, got: 7 })
            );
            odd += 1;
        }
        leg.state_len = len + 2;
        assert!(matches!(
            Job::from_wire(&leg, &genes),
            Err(WireError::StateLength { .. })
        ));
    }
    assert_eq!(odd, 1, "one of the states takes an odd number of bytes");
    let mut garbage = h;
    garbage.state_len = 4;
    assert!(matches!(
        Job::from_wire(&garbage, &[gene(0xff, 0xff), gene(0xff, 0xff)]),
        Err(WireError::State(_))
    ));
    let mut beyond = h;
    beyond.until = h.learn.episodes + 1;
    assert!(matches!(
        Job::from_wire(&beyond, &[]),
        Err(WireError::Until { .. })
    ));
    h.learn.memory_bits = 60;
    assert!(
        matches!(Job::from_wire(&h, &[]), Err(WireError::Learning(e)) if e.field == "qlearning.memory_bits")
    );
    h.learn.memory_bits = 18;
    h.learn.gamma = f64::NAN;
    assert!(
        matches!(Job::from_wire(&h, &[]), Err(WireError::Learning(e)) if e.field == "qlearning.gamma")
    );
    h.kind = 7;
    assert_eq!(Job::from_wire(&h, &[]), Err(WireError::Kind(7)));
}

#[test]
fn training_results_are_checked() {
    use lander_model::{EpisodeRecord, Training};
    let record = |episode, safe| EpisodeRecord {
        episode,
        reward: 1.0,
        ticks: 90,
        decisions: 18,
        safe,
        epsilon: 0.05,
    };
    let good = TrainResult {
        training: Training {
            episodes: 2,
            first_safe: Some(2),
            landing_rate_last_100: 0.5,
        },
        episodes: vec![record(1, false), record(2, true)],
        state: None,
    };
    let trial = |episodes| {
        TrainJob::whole(
            Env::default(),
            GuideParams::default(),
            LearnParams {
                episodes,
                ..LearnParams::default()
            },
            StreamKey::default(),
        )
    };
    assert_eq!(decode_training(&encode(&good), &trial(2)), Ok(good.clone()));
    let mut longer = encode(&good);
    longer.extend([0, 0]);
    assert_eq!(
        decode_training(&longer, &trial(2)),
        Err(WireError::Decode(
            "2 bytes left over after the value".into()
        ))
    );
    assert!(decode_training(&encode(&good), &trial(3)).is_err());
    let mut lying = good.clone();
    lying.training.first_safe = Some(1);
    assert!(decode_training(&encode(&lying), &trial(2)).is_err());
    let mut nan = good.clone();
    nan.episodes[0].reward = f64::NAN;
    assert!(decode_training(&encode(&nan), &trial(2)).is_err());
    // A leg short of the trial's end must bring the trial's state.
    let leg = TrainJob {
        until: 2,
        ..trial(5)
    };
    assert!(decode_training(&encode(&good), &leg).is_err());
    let mut with_state = good;
    with_state.state = Some(LearnState {
        episodes: 2,
        rng_word: 0,
        first_safe: Some(2),
        recent: vec![false, true],
        weights: Vec::new(),
    });
    assert!(decode_training(&encode(&with_state), &leg).is_ok());
    // A state the next leg could not start from is refused here, before
    // it reaches a checkpoint or another worker.
    let weights = 1u32 << LearnParams::default().memory_bits;
    for weight in [(weights, 1.0), (3, f64::INFINITY)] {
        let mut poisoned = with_state.clone();
        if let Some(state) = &mut poisoned.state {
            state.weights.push(weight);
        }
        assert_eq!(
            decode_training(&encode(&poisoned), &leg),
            Err(WireError::ImplausibleTraining(2)),
            "{weight:?}"
        );
    }
}

#[test]
fn jobs_out_of_a_runs_ranges_are_refused() {
    let genes = [gene(0, 1), gene(1, 1)];
    // A world that flies for 2^32 ticks a genome, and scoring weights
    // that overflow R: refused as a run's configuration would be.
    let mut h = header(1, 2);
    h.env.world.max_ticks = u32::MAX;
    let err = Job::from_wire(&h, &genes).unwrap_err();
    assert!(matches!(err, WireError::Params(_)), "{err}");
    assert!(err.to_string().contains("world.max_ticks"), "{err}");
    let mut h = header(1, 2);
    h.env.scoring.w1 = 1e300;
    let err = Job::from_wire(&h, &genes).unwrap_err();
    assert!(err.to_string().contains("scoring.w1"), "{err}");
    let mut h = header(1, 2);
    h.guide.epsilon = 2.0;
    let err = Job::from_wire(&h, &genes).unwrap_err();
    assert!(err.to_string().contains("guided.epsilon"), "{err}");
    // Genome indices that would draw from the trial's start, pads or
    // learning stream, or overflow.
    for first in [streams::LEARN - 1, u64::MAX] {
        let mut h = header(1, 2);
        h.first_index = first;
        assert_eq!(
            Job::from_wire(&h, &genes),
            Err(WireError::Index { first, genomes: 1 })
        );
    }
    // The last index whose stream is a guided pass's.
    let mut h = header(1, 2);
    h.first_index = streams::LEARN - 2;
    assert!(Job::from_wire(&h, &genes).is_ok());
}

use proptest::prelude::*;

proptest! {
    /// Whatever a flight can produce comes back bit for bit.
    #[test]
    fn every_plausible_result_round_trips(
        state in proptest::array::uniform5(-1e12f64..1e12),
        fitness in -1e12f64..1e12,
        (ticks, n) in (0u32..u32::MAX).prop_flat_map(|t| (Just(t), 0..=t)),
        extra in 0u64..1 << 40,
        (touched_down, safe) in any::<(bool, bool)>(),
        actions in proptest::collection::vec(0u8..4, 7),
    ) {
        let [x, y, vx, vy, rot] = state;
        let e = Evaluation {
            outcome: Outcome {
                state: State { x, y, vx, vy, rot },
                ticks,
                n,
                touched_down,
                safe: safe && touched_down,
                fitness,
            },
            simulated_ticks: u64::from(ticks - n) + extra,
        };
        let r = ChunkResult { evaluations: vec![e], actions };
        prop_assert_eq!(ChunkResult::decode(&r.encode(), Pass::Guide, 1, 7), Ok(r));
    }
}

#[test]
fn the_largest_chunk_and_its_answer_fit_their_bound() {
    use crate::envelope::{encode_job, encode_result};
    for length in [1, 50, 1_000] {
        let n = most_genomes_per_chunk(length);
        let job = encode_job(
            &header(n as u32, length as u32),
            &vec![gene(3, 30); n * length],
        );
        // Every evaluation as long as postcard writes one: the widest
        // varints, and every action sent back.
        let mut widest = evaluation(-f64::MAX);
        widest.outcome.ticks = u32::MAX;
        widest.outcome.n = u32::MAX;
        widest.simulated_ticks = u64::MAX;
        let answer = ChunkResult {
            evaluations: vec![widest; n],
            actions: vec![3; n * length],
        };
        let result = encode_result(&ResultHeader::default(), &answer.encode());
        for (what, bytes) in [("job", job.len()), ("answer", result.len())] {
            assert!(
                bytes <= MAX_CHUNK_BYTES,
                "{length} genes: a {what} of {bytes} bytes"
            );
        }
    }
    // The records of the longest leg a training chunk flies.
    let leg = widest_leg(MOST_EPISODES_PER_CHUNK, None);
    let bytes = encode_result(&ResultHeader::default(), &encode(&leg)).len();
    assert!(bytes <= MAX_CHUNK_BYTES, "a leg's answer of {bytes} bytes");
}

/// The widest record postcard writes for an episode.
fn widest_episode() -> lander_model::EpisodeRecord {
    lander_model::EpisodeRecord {
        episode: u32::MAX,
        reward: -f64::MAX,
        ticks: u32::MAX,
        decisions: u32::MAX,
        safe: true,
        epsilon: f64::MAX,
    }
}

/// The widest answer of a leg of `episodes` episodes that carries `state`.
fn widest_leg(episodes: u32, state: Option<LearnState>) -> TrainResult {
    TrainResult {
        training: lander_model::Training {
            episodes: u32::MAX,
            first_safe: Some(u32::MAX),
            landing_rate_last_100: 1.0,
        },
        episodes: vec![widest_episode(); episodes as usize],
        state,
    }
}

/// The widest state of an agent of `2^memory_bits` weights: every
/// weight set, every number as wide as postcard writes it.
fn widest_state(memory_bits: u32) -> LearnState {
    LearnState {
        episodes: u32::MAX,
        rng_word: u128::MAX,
        first_safe: Some(u32::MAX),
        recent: vec![true; 100],
        weights: vec![(u32::MAX, -f64::MAX); 1 << memory_bits],
    }
}

#[test]
fn a_state_takes_at_most_its_bound() {
    for bits in [4, 12, 18] {
        let bytes = encode(&widest_state(bits)).len();
        assert!(
            bytes <= most_state_bytes(bits),
            "{bits} bits: {bytes} bytes"
        );
    }
}

#[test]
fn a_leg_with_the_largest_state_that_travels_fits_a_frame() {
    use crate::envelope::{encode_job, encode_result, MAX_FRAME};
    use lander_model::params::MAX_MEMORY_BITS;
    assert_eq!(most_episodes_beside_state(MAX_MEMORY_BITS), None);
    let bits = MAX_MEMORY_BITS - 1;
    let most = most_episodes_beside_state(bits).expect("the state travels");
    assert!(most > 100_000, "{most} episodes a leg");
    let state = widest_state(bits);
    let (genes, len) = pack_state(Some(&state));
    let job = encode_job(
        &JobHeader {
            state_len: len,
            ..header(0, 0)
        },
        &genes,
    );
    assert!(job.len() <= MAX_FRAME, "a job of {} bytes", job.len());
    drop(genes);
    let leg = widest_leg(most, Some(state));
    let answer = encode_result(&ResultHeader::default(), &encode(&leg)).len();
    assert!(answer <= MAX_FRAME, "an answer of {answer} bytes");
}
