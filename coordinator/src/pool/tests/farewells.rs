//! What a pool tells its workers as it goes: that the run is over only
//! where its command said so (`Evaluator::run_over`), else that it
//! stopped, which a `lander-worker --rejoin` waits out for a resume.

use super::fake::{no_chunks, pool, Recorder};
use crate::evaluator::Evaluator;
use lander_protocol::Farewell;

/// What a worker that answered a few chunks is told as the pool goes,
/// `over` or not.
fn told_as_the_pool_goes(over: bool) -> Vec<Farewell> {
    let link = Recorder {
        answer: Some(b"fine".to_vec()),
        ..Recorder::holding(7, Vec::new())
    };
    let told = link.told.clone();
    let mut pool = pool(vec![link], Default::default());
    let results = pool
        .run_chunks(&no_chunks(3), |i, _| Ok::<_, String>(i), |_, _| ())
        .unwrap();
    assert_eq!(results, [0, 1, 2]);
    if over {
        pool.run_over();
    }
    drop(pool);
    let told = told.lock().unwrap().clone();
    told
}

#[test]
fn workers_are_told_the_run_is_over_only_where_it_is() {
    assert_eq!(told_as_the_pool_goes(true), [Farewell::RunOver]);
    assert_eq!(told_as_the_pool_goes(false), [Farewell::Stopped]);
}
