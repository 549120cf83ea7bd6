//! `run_chunks` over links that answer at once, one of them with answers
//! that fail to decode.

use super::fake::{assert_refused_alone, no_chunks, pool, recorded, Recorder};

#[test]
fn a_refused_answer_costs_its_worker_and_the_chunk_runs_elsewhere() {
    let (dir, telemetry) = recorded();
    let links = [(7, b"garbage"), (8, b"fine!!!")]
        .into_iter()
        .map(|(id, body)| Recorder {
            answer: Some(body.to_vec()),
            ..Recorder::holding(id, Vec::new())
        })
        .collect();
    let mut pool = pool(links, telemetry.clone());
    let decode = |i: usize, body: &[u8]| match body {
        b"fine!!!" => Ok(i * 10),
        _ => Err("does not decode".to_string()),
    };
    let mut seen = Vec::new();
    let results = pool
        .run_chunks(&no_chunks(6), decode, |i, _| seen.push(i))
        .unwrap();
    assert_eq!(results, [0, 10, 20, 30, 40, 50]);
    seen.sort_unstable();
    assert_eq!(seen, [0, 1, 2, 3, 4, 5], "each chunk finished once");
    assert_refused_alone(&pool, dir.path(), 7, "does not decode", &[8]);
    let metrics = String::from_utf8(telemetry.metrics().unwrap().encode()).unwrap();
    assert!(
        metrics.contains("lander_chunks_refused_total 1"),
        "{metrics}"
    );
    assert!(
        metrics.contains("lander_workers_lost_total{cause=\"refused\"} 1"),
        "{metrics}"
    );
}

/// Answers of worker `id`, telling which worker gave them: `(chunk, id)`.
fn by_worker(i: usize, body: &[u8]) -> Result<(usize, u8), String> {
    Ok((i, body[0]))
}

#[test]
fn a_link_that_fails_its_checks_has_its_other_answers_flown_again() {
    let links = [(7, true), (8, false)]
        .into_iter()
        .map(|(id, fails_checks)| Recorder {
            answer: Some(vec![id as u8]),
            fails_checks,
            ..Recorder::holding(id, Vec::new())
        })
        .collect();
    let mut pool = pool(links, Default::default());
    pool.record_timings();
    let mut seen = Vec::new();
    let results = pool
        .run_chunks(&no_chunks(8), by_worker, |i, _| seen.push(i))
        .unwrap();
    // Worker 7 was dealt four chunks and answered three well before the
    // fourth failed: those three are not believed either, and 8 flies them.
    assert_eq!(results, (0..8).map(|c| (c, 8)).collect::<Vec<_>>());
    let answers = pool.take_timings();
    assert_eq!(answers.iter().filter(|t| t.worker == 7).count(), 3);
    assert_eq!(answers.iter().filter(|t| t.worker == 8).count(), 8);
    seen.sort_unstable();
    assert_eq!(seen, (0..8).collect::<Vec<_>>(), "each chunk finished once");
    let ids: Vec<u64> = pool.links.iter().map(|l| l.id).collect();
    assert_eq!(ids, [8]);
}

#[test]
fn a_link_that_fails_its_checks_has_the_answers_taken_before_flown_again() {
    let links = [(7, true, 1), (8, false, 3)]
        .into_iter()
        .map(|(id, fails_checks, looks_per_answer)| Recorder {
            answer: Some(vec![id as u8]),
            fails_checks,
            clean_looks: 2,
            looks_per_answer,
            ..Recorder::holding(id, Vec::new())
        })
        .collect();
    let mut pool = pool(links, Default::default());
    let mut taken_from_7 = 0;
    let results = pool
        .run_chunks(&no_chunks(8), by_worker, |_, &(_, by)| {
            taken_from_7 += usize::from(by == 7)
        })
        .unwrap();
    assert!(taken_from_7 > 0, "no answer of 7's taken before it failed");
    assert_eq!(results, (0..8).map(|c| (c, 8)).collect::<Vec<_>>());
    let ids: Vec<u64> = pool.links.iter().map(|l| l.id).collect();
    assert_eq!(ids, [8]);
}
