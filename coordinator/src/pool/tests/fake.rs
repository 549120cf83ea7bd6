//! A pool over made-up links: no processes, no transport.

use crate::evaluator::EvalError;
use crate::pool::{
    Answer, Arrival, Chunk, ChunkTiming, Pool, PoolOptions, Transport, WorkerLink, DEPTH,
};
use crate::stop::Stop;
use lander_model::learn::run_training;
use lander_protocol::wire::{encode, Job, JobHeader, WireGene};
use lander_protocol::Farewell;
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Records what it is sent; with an `answer`, answers every chunk with it
/// at the next poll, or, if it `fails_checks`, all but the last, whose
/// answer fails the link's own checks and breaks it (from the look after
/// its first `clean_looks`, which answer as if it did not). One that `flies`
/// evaluates or trains each chunk as a worker does, and answers with the
/// result. One with `looks_per_answer` n above 0 is slow: it answers one
/// chunk at every n-th look, none at the others. One that `spoils` a
/// chunk answers it, the first time it flies it, with bytes that do not
/// decode.
pub struct Recorder {
    pub id: u64,
    pub chunks: Vec<usize>,
    /// Every chunk it was ever sent, in order.
    pub sent: Vec<usize>,
    pub answer: Option<Vec<u8>>,
    pub flies: bool,
    /// The answers of a link that flies, by chunk.
    pub flown: HashMap<usize, Vec<u8>>,
    pub fails_checks: bool,
    pub clean_looks: usize,
    pub broken: bool,
    /// Sends that succeed before every send fails, as to a worker killed
    /// (`None`: every send succeeds).
    pub sends_left: Option<usize>,
    pub pid: u32,
    pub looks_per_answer: usize,
    /// Looks at it so far.
    pub looks: usize,
    /// The most chunks it ever held at once.
    pub most_held: usize,
    pub spoils: Option<usize>,
    /// What it was told as it was sent away, shared so that a test can
    /// read it after the pool is gone.
    pub told: Arc<Mutex<Vec<Farewell>>>,
}

impl Recorder {
    pub fn holding(id: u64, chunks: Vec<usize>) -> Recorder {
        Recorder {
            pid: 0,
            id,
            chunks,
            sent: Vec::new(),
            answer: None,
            flies: false,
            flown: HashMap::new(),
            fails_checks: false,
            clean_looks: 0,
            broken: false,
            sends_left: None,
            looks_per_answer: 0,
            looks: 0,
            most_held: 0,
            spoils: None,
            told: Arc::default(),
        }
    }

    /// Its answer to `chunk`: the same for every chunk, or the chunk's
    /// result if it flies.
    fn body(&mut self, chunk: usize) -> Vec<u8> {
        match &self.answer {
            Some(body) => body.clone(),
            None => self.flown.remove(&chunk).unwrap_or_default(),
        }
    }
}

impl WorkerLink for Recorder {
    fn id(&self) -> u64 {
        self.id
    }
    fn pid(&self) -> u32 {
        self.pid
    }
    fn has_room(&self) -> bool {
        self.chunks.len() < DEPTH && !self.broken
    }
    fn is_broken(&self) -> bool {
        self.broken
    }
    fn deadline(&self) -> Option<Instant> {
        None
    }
    fn abandon(&mut self) -> Vec<usize> {
        std::mem::take(&mut self.chunks)
    }
    fn in_flight(&self) -> usize {
        self.chunks.len()
    }
    fn take_back(&mut self) -> Option<usize> {
        self.chunks.pop()
    }
    fn send(
        &mut self,
        header: JobHeader,
        genes: &[WireGene],
        chunk: usize,
        _: Option<Duration>,
    ) -> Result<(), String> {
        if self.sends_left == Some(0) {
            self.broken = true;
            return Err("the worker is gone".into());
        }
        self.sends_left = self.sends_left.map(|n| n - 1);
        if self.flies {
            let body = match Job::from_wire(&header, genes).map_err(|e| e.to_string())? {
                _ if self.spoils.take_if(|&mut c| c == chunk).is_some() => b"spoilt".to_vec(),
                Job::Evaluate(job) => job.run().encode(),
                Job::Train(job) => encode(&run_training(&job)?),
            };
            self.flown.insert(chunk, body);
        }
        self.chunks.push(chunk);
        self.most_held = self.most_held.max(self.chunks.len());
        self.sent.push(chunk);
        Ok(())
    }
    fn poll(&mut self) -> (Vec<Answer>, Option<String>) {
        if self.answer.is_none() && !self.flies {
            return (Vec::new(), None);
        }
        let timing = ChunkTiming {
            worker: self.id,
            sent_ns: 0,
            read_ns: 0,
            started_ns: 0,
            finished_ns: 0,
        };
        self.looks += 1;
        let fails = self.fails_checks && self.looks > self.clean_looks;
        let keep = usize::from(fails && !self.chunks.is_empty());
        let mut good = self.chunks.len() - keep;
        if self.looks_per_answer > 0 {
            good = good.min(usize::from(
                self.looks.is_multiple_of(self.looks_per_answer),
            ));
        }
        let answered: Vec<usize> = self.chunks.drain(..good).collect();
        let answers = answered
            .into_iter()
            .map(|chunk| Answer {
                chunk,
                body: self.body(chunk),
                timing,
            })
            .collect();
        if keep == 0 {
            return (answers, None);
        }
        // As a real link: the refused chunk stays in flight, to be put
        // back when the broken link is dropped.
        self.broken = true;
        (answers, Some("answer to the wrong job".into()))
    }
    fn break_off(&mut self) {
        self.broken = true;
    }
    fn shut_down(&self, why: Farewell) {
        if let Ok(mut told) = self.told.lock() {
            told.push(why);
        }
    }
}

/// No transport: no worker ever arrives, and a sleep returns at once,
/// counted; with `stops`, the first sleep asks it, as a Ctrl-C while the
/// pool waits for an answer would.
#[derive(Default)]
pub struct Nowhere {
    pub sleeps: usize,
    pub stops: Option<Stop>,
}

impl Transport for Nowhere {
    type Link = Recorder;
    fn name(&self) -> &'static str {
        "nowhere"
    }
    fn arrivals(&mut self) -> Result<Vec<Arrival>, EvalError> {
        Ok(Vec::new())
    }
    fn connect(&mut self, _: &Arrival) -> Result<Recorder, String> {
        Err("no".into())
    }
    fn departures(&mut self) -> Vec<u64> {
        Vec::new()
    }
    fn sleep(&mut self, _: Duration) -> Result<(), EvalError> {
        self.sleeps += 1;
        if let Some(stop) = self.stops.take() {
            stop.ask();
        }
        Ok(())
    }
    /// The fakes answer from memory, as iceoryx2 workers do.
    fn answers_in_shared_memory(&self) -> bool {
        true
    }
    fn worker_args(&self) -> Vec<String> {
        Vec::new()
    }
    fn close(&mut self) {}
}

/// The options of a pool that spawns nothing, for the tests to change.
pub fn options() -> PoolOptions {
    PoolOptions {
        run_id: "t".into(),
        spawn: 0,
        worker_exe: PathBuf::new(),
        chunks_per_worker: 1,
        deadline: Duration::from_secs(1),
        max_respawns: 0,
        pin: false,
        min_workers: 0,
        spin: Duration::ZERO,
        verify: 0.0,
        share: false,
        stand_in: false,
        stop: Stop::new(),
    }
}

pub fn pool(links: Vec<Recorder>, telemetry: lander_telemetry::Telemetry) -> Pool<Nowhere> {
    let mut pool = Pool::with_transport(Nowhere::default(), options(), telemetry).unwrap();
    pool.links = links;
    pool
}

/// A pool over `n` links that fly or train each chunk as a worker does.
pub fn flying(n: u64) -> Pool<Nowhere> {
    let links = (0..n)
        .map(|id| Recorder {
            flies: true,
            ..Recorder::holding(id, Vec::new())
        })
        .collect();
    pool(links, Default::default())
}

/// A pool over a link per CPU, each with a stand-in worker process pinned
/// to its CPU behind it (in `dir`): the last shares its CPU with the
/// coordinator's thread. Links that `fly` evaluate and train as workers do.
pub fn on_every_cpu(dir: &std::path::Path, fly: bool) -> Pool<Nowhere> {
    use crate::pool::spawn::{stand_in_worker, Children, Placement};
    let allowed = lander_protocol::host::allowed_cpus();
    let placement = Placement::new(allowed.len(), &allowed, true, Duration::ZERO);
    let mut children = Children::new(stand_in_worker(dir), "t".into(), Vec::new(), 0, placement);
    let links = (0..allowed.len())
        .map(|_| {
            let child = children.spawn().unwrap();
            Recorder {
                pid: child.pid,
                flies: fly,
                ..Recorder::holding(child.id, Vec::new())
            }
        })
        .collect();
    let mut pool = pool(links, Default::default());
    pool.children = children;
    pool
}

pub fn no_chunks(n: usize) -> Vec<Chunk> {
    (0..n)
        .map(|_| Chunk {
            header: JobHeader::default(),
            genes: Vec::new(),
            timed: true,
        })
        .collect()
}

/// Links answering every chunk `c` with `10c + lie`, each `(id, lie)`.
pub fn answering(lies: &[(u64, u8)]) -> Vec<Recorder> {
    lies.iter()
        .map(|&(id, lie)| Recorder {
            answer: Some(vec![lie]),
            ..Recorder::holding(id, Vec::new())
        })
        .collect()
}

/// Runs `n` chunks with every answer checked (`shares`: the coordinator
/// flies a share too), over links whose answer to chunk `c` reads
/// `10c + lie` where this host's reads `10c`; returns the results and the
/// chunks flown here, in the order flown.
pub fn run_all_checked(
    pool: &mut Pool<Nowhere>,
    n: usize,
    shares: bool,
) -> (Vec<usize>, Vec<usize>) {
    let here = std::cell::RefCell::new(Vec::new());
    let check = crate::pool::verify::Check {
        due: &|_, _| true,
        here: &|c| {
            here.borrow_mut().push(c);
            Ok(10 * c)
        },
        differs: &|c, a: &usize, b: &usize| (a != b).then(|| format!("its answer to chunk {c}")),
        shares,
    };
    let decode = |c: usize, body: &[u8]| Ok(10 * c + usize::from(body[0]));
    let results = pool
        .run_checked(&no_chunks(n), decode, &check, |_, _| {})
        .unwrap();
    assert!(
        pool.links.iter().all(|l| l.chunks.is_empty()),
        "a generation leaves nothing in flight"
    );
    (results, here.into_inner())
}

/// Telemetry with metrics, recording events to a new folder.
pub fn recorded() -> (tempfile::TempDir, lander_telemetry::Telemetry) {
    let dir = tempfile::tempdir().unwrap();
    let metrics = std::sync::Arc::new(lander_telemetry::CoordinatorMetrics::new());
    let telemetry = lander_telemetry::Telemetry::new("t", Some(metrics));
    telemetry.record_to(dir.path()).unwrap();
    (dir, telemetry)
}

/// Checks that `worker`, and it alone, was refused, for a reason that
/// says `why`, and dropped for good, leaving the links `kept`.
pub fn assert_refused_alone(
    pool: &Pool<Nowhere>,
    events: &std::path::Path,
    worker: u64,
    why: &str,
    kept: &[u64],
) {
    let ids: Vec<u64> = pool.links.iter().map(|l| l.id).collect();
    assert_eq!(ids, kept, "the refused worker is dropped, the others kept");
    assert!(pool.dropped.contains(&worker));
    let events = lander_telemetry::events::read(events).unwrap();
    let refused: Vec<_> = events
        .iter()
        .filter(|e| e["event"] == "worker_refused")
        .collect();
    assert_eq!(refused.len(), 1, "{events:?}");
    assert_eq!(refused[0]["worker"], format!("{worker:016x}"));
    let said = refused[0]["why"].as_str().unwrap();
    assert!(said.contains(why), "{said}");
}
