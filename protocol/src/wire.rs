//! How jobs and results are laid out between processes, and the checks a
//! receiver makes before it believes them.
//!
//! A job travels zero-copy through shared memory: a [`JobHeader`] with the
//! environment, method, parameters and stream key, and the genomes as one
//! flat slice of [`WireGene`]. A result is a [`ResultHeader`] and a
//! postcard-encoded [`ChunkResult`]: each genome's evaluation plus, for the
//! guided GA, the rewritten actions. That is two variable-length parts, which
//! one plain slice cannot hold; postcard is also what crosses hosts.
//!
//! A job of kind [`KIND_TRAIN`] is a Q(λ) trial instead, or a leg of one
//! (`TrainJob`): a leg that starts after the trial's start carries the
//! trial's state, postcard-encoded and packed two bytes to a [`WireGene`]
//! in the genes' place (`pack_state`), and a postcard [`TrainResult`]
//! comes back.

use iceoryx2::prelude::ZeroCopySend;
use lander_model::learn::LearnState;
use lander_model::stream::streams;
use lander_model::{
    evaluate, Action, Env, Evaluation, Gene, GuideParams, LearnParams, Pass, StreamKey, TrainJob,
    TrainResult,
};
use serde::{Deserialize, Serialize};

/// Bumped whenever any layout here changes, or the shape of a run's
/// iceoryx2 services (`iox`): a worker of another build is then refused
/// by its version, before its services are opened.
pub const PROTOCOL_VERSION: u32 = 8;

/// Job kinds.
pub const KIND_EVALUATE: u32 = 0;
pub const KIND_TRAIN: u32 = 1;

/// A gene as raw bytes: another process may write any value, so the action
/// is checked before it becomes an [`Action`].
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ZeroCopySend)]
#[type_name("lander::WireGene")]
pub struct WireGene {
    pub action: u8,
    pub duration: u8,
}

impl From<Gene> for WireGene {
    fn from(g: Gene) -> WireGene {
        WireGene {
            action: g.action.index(),
            duration: g.duration,
        }
    }
}

/// A chunk of genomes to evaluate: genome `i` of the chunk is individual
/// `first_index + i` of its generation and uses that guided-pass stream.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, ZeroCopySend)]
#[type_name("lander::JobHeader")]
pub struct JobHeader {
    pub version: u32,
    pub kind: u32,
    /// The [`Pass`]'s code.
    pub pass: u32,
    pub job_id: u64,
    pub key: StreamKey,
    pub first_index: u64,
    pub genomes: u32,
    pub genome_length: u32,
    pub max_duration: u32,
    pub env: Env,
    pub guide: GuideParams,
    pub learn: LearnParams,
    /// A training job: the episode its leg ends after.
    pub until: u32,
    /// A training job: the bytes of the state its leg starts from, packed
    /// in the genes' place; 0 at the trial's start.
    pub state_len: u32,
}

/// What became of a job.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    Done = 0,
    /// The worker speaks another protocol version.
    WrongVersion = 1,
    /// The job failed the worker's checks.
    BadJob = 2,
}

impl Status {
    pub fn from_code(code: u32) -> Option<Status> {
        [Status::Done, Status::WrongVersion, Status::BadJob]
            .into_iter()
            .find(|s| *s as u32 == code)
    }
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, ZeroCopySend)]
#[type_name("lander::ResultHeader")]
pub struct ResultHeader {
    pub version: u32,
    pub status: u32,
    pub job_id: u64,
    pub worker_id: u64,
    /// When the worker started and finished the job, in nanoseconds of
    /// its host's monotonic clock. Their difference is the job's compute
    /// time wherever the worker runs; on one host the coordinator can also
    /// place them on its own clock, and tell transport overhead from
    /// computation chunk by chunk (`lander bench`).
    pub started_ns: u64,
    pub finished_ns: u64,
}

/// A worker's announcement that it is ready to serve a run.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ZeroCopySend)]
#[type_name("lander::WorkerAnnounce")]
pub struct WorkerAnnounce {
    pub version: u32,
    pub pid: u32,
    pub worker_id: u64,
}

/// The body of a result: one evaluation per genome and, for the guided GA,
/// every genome's actions after the evolve pass (`genomes × length` bytes).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ChunkResult {
    pub evaluations: Vec<Evaluation>,
    /// Encoded as one byte string rather than a sequence of numbers.
    #[serde(with = "serde_bytes")]
    pub actions: Vec<u8>,
}

/// The most bytes a chunk's job or answer may take: a quarter of a
/// network frame ([`crate::envelope::MAX_FRAME`]), which no chunk a pool
/// cuts may outgrow, however few workers share a large generation.
pub const MAX_CHUNK_BYTES: usize = crate::envelope::MAX_FRAME / 4;

/// More than one genome's evaluation takes on the wire.
const EVALUATION_BYTES: usize = 160;

/// More than one Q(λ) episode's record takes on the wire (32 bytes at
/// the most), leaving room for the answer's summary and header.
const EPISODE_BYTES: usize = 40;

/// The most episodes one training chunk flies: its records stay within
/// [`MAX_CHUNK_BYTES`]. A longer trial goes out in legs of this many, each
/// from where the last left the trial.
pub const MOST_EPISODES_PER_CHUNK: u32 = (MAX_CHUNK_BYTES / EPISODE_BYTES) as u32;

/// More than a weight of a Q(λ) state takes on the wire: its index, a
/// varint of 5 bytes at the most, and its value.
const WEIGHT_BYTES: usize = 13;

/// More than the rest of a Q(λ) state takes: its counters, the stream's
/// position and the last 100 landings.
const STATE_BYTES: usize = 256;

/// The most bytes the state of a Q(λ) trial whose agent has
/// `2^memory_bits` weights takes on the wire: every weight set.
pub fn most_state_bytes(memory_bits: u32) -> usize {
    state_bytes(1 << memory_bits)
}

/// The most bytes a Q(λ) state of `weights` weights set takes on the wire.
pub fn state_bytes(weights: usize) -> usize {
    weights
        .saturating_mul(WEIGHT_BYTES)
        .saturating_add(STATE_BYTES)
}

/// Whether a leg's job, carrying a state of `bytes` bytes, fits a network
/// frame.
pub fn state_fits(bytes: usize) -> bool {
    bytes.saturating_add(STATE_BYTES) <= crate::envelope::MAX_FRAME
}

/// The most episodes one training chunk flies where the trial's state
/// travels with it (a leg after the first, or before the last): its
/// records and the state fit one network frame together, and the records
/// [`MAX_CHUNK_BYTES`] still. `None` where the state alone may not fit:
/// such a trial cannot go out in legs.
pub fn most_episodes_beside_state(memory_bits: u32) -> Option<u32> {
    let room =
        crate::envelope::MAX_FRAME.checked_sub(most_state_bytes(memory_bits) + STATE_BYTES)?;
    let episodes = (room / EPISODE_BYTES).min(MOST_EPISODES_PER_CHUNK as usize) as u32;
    (episodes > 0).then_some(episodes)
}

/// The most genomes of `length` genes one chunk may carry: its job takes
/// two bytes a gene, its answer a byte a gene (the guided pass's actions)
/// and an evaluation a genome.
pub fn most_genomes_per_chunk(length: usize) -> usize {
    (MAX_CHUNK_BYTES / (2 * length + EVALUATION_BYTES)).max(1)
}

#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum WireError {
    #[error("{0} is not a finite number")]
    NotFinite(&'static str),
    #[error("protocol version {got}, but this side speaks version {PROTOCOL_VERSION}")]
    Version { got: u32 },
    #[error("unknown pass code {0}")]
    Pass(u32),
    #[error("{genomes} genomes of {length} genes need {expected} genes, but {got} arrived")]
    Length {
        genomes: u32,
        length: u32,
        expected: usize,
        got: usize,
    },
    #[error("gene {index}: action {action} is not 0..=3")]
    Action { index: usize, action: u8 },
    #[error("gene {index}: duration {duration} exceeds {max}")]
    Duration {
        index: usize,
        duration: u8,
        max: u32,
    },
    #[error("result does not decode: {0}")]
    Decode(String),
    #[error("result has {got} evaluations for {expected} genomes")]
    Count { expected: usize, got: usize },
    #[error("evaluation {0} is not a possible flight (non-finite or inconsistent)")]
    Implausible(usize),
    #[error("unknown job kind {0}")]
    Kind(u32),
    #[error("a training job's state of {len} bytes needs {expected} genes, but {got} arrived")]
    StateLength {
        len: u32,
        expected: usize,
        got: usize,
    },
    #[error("a training job's state does not decode: {0}")]
    State(String),
    #[error("a training job's leg ends after episode {until}, beyond its {episodes} episodes")]
    Until { until: u32, episodes: u32 },
    #[error("training parameters out of range: {0}")]
    Learning(lander_model::check::ParamError),
    #[error("job parameters out of range: {0}")]
    Params(lander_model::check::ParamError),
    #[error("genomes {first} to {first} + {genomes} are past the last a generation may number")]
    Index { first: u64, genomes: u32 },
    #[error("training result is not a possible leg to episode {0}")]
    ImplausibleTraining(u32),
    #[error("genome_length is 0: a genome has at least one gene")]
    NoGenes,
    #[error("{genomes} genomes of {length} genes: a chunk carries {most} at the most")]
    TooManyGenomes {
        genomes: u32,
        length: u32,
        most: usize,
    },
    #[error("a training job's leg of {episodes} episodes: a leg flies {most} at the most")]
    LegTooLong { episodes: u32, most: u32 },
    #[error("a training job's state of {len} bytes ends in a padding byte of {got}, not 0")]
    StatePadding { len: u32, got: u8 },
}

/// A job as the worker sees it once checked.
#[derive(Clone, Debug, PartialEq)]
pub enum Job {
    Evaluate(EvalJob),
    Train(TrainJob),
}

/// A chunk of genomes to evaluate.
#[derive(Clone, Debug, PartialEq)]
pub struct EvalJob {
    pub pass: Pass,
    pub key: StreamKey,
    pub first_index: u64,
    pub genome_length: usize,
    pub env: Env,
    pub guide: GuideParams,
    /// `genomes × genome_length` genes, genome after genome.
    pub genes: Vec<Gene>,
}

impl Job {
    /// Checks a job header and its genes.
    pub fn from_wire(h: &JobHeader, genes: &[WireGene]) -> Result<Job, WireError> {
        if h.version != PROTOCOL_VERSION {
            return Err(WireError::Version { got: h.version });
        }
        check_numbers(h)?;
        // The same checks as a run configuration's: they bound a flight's
        // ticks and keep fitness and R finite, whoever sent the job.
        h.env.world.check().map_err(WireError::Params)?;
        h.env.scoring.check().map_err(WireError::Params)?;
        h.guide.check().map_err(WireError::Params)?;
        match h.kind {
            KIND_EVALUATE => EvalJob::from_wire(h, genes).map(Job::Evaluate),
            KIND_TRAIN => train_from_wire(h, genes).map(Job::Train),
            other => Err(WireError::Kind(other)),
        }
    }
}

fn train_from_wire(h: &JobHeader, genes: &[WireGene]) -> Result<TrainJob, WireError> {
    let expected = (h.state_len as usize).div_ceil(2);
    if genes.len() != expected {
        return Err(WireError::StateLength {
            len: h.state_len,
            expected,
            got: genes.len(),
        });
    }
    // The same check as the run configuration's: among other things
    // it bounds the 2^memory_bits weights the worker allocates.
    h.learn.check().map_err(WireError::Learning)?;
    if h.until > h.learn.episodes {
        return Err(WireError::Until {
            until: h.until,
            episodes: h.learn.episodes,
        });
    }
    // Whether the state fits the trial is `run_training`'s check.
    let from: Option<LearnState> = match h.state_len {
        0 => None,
        len => {
            let bytes = unpack_state(genes, len)?;
            Some(decode_all(&bytes).map_err(|e| WireError::State(e.to_string()))?)
        }
    };
    // The coordinator sends no longer leg; a longer one would have this
    // worker keep records without bound, for an answer no frame carries.
    let episodes = h
        .until
        .saturating_sub(from.as_ref().map_or(0, |s| s.episodes));
    if episodes > MOST_EPISODES_PER_CHUNK {
        return Err(WireError::LegTooLong {
            episodes,
            most: MOST_EPISODES_PER_CHUNK,
        });
    }
    Ok(TrainJob {
        env: h.env,
        guide: h.guide,
        learn: h.learn,
        key: h.key,
        from,
        until: h.until,
    })
}

/// A leg's starting state as genes, two bytes to a gene, and its length in
/// bytes (`None`: no genes, length 0).
pub fn pack_state(state: Option<&LearnState>) -> (Vec<WireGene>, u32) {
    let Some(state) = state else {
        return (Vec::new(), 0);
    };
    let bytes = encode(state);
    let genes = bytes
        .chunks(2)
        .map(|pair| WireGene {
            action: pair[0],
            duration: pair.get(1).copied().unwrap_or(0),
        })
        .collect();
    (genes, bytes.len() as u32)
}

/// The first `len` bytes packed in `genes` (checked to be enough); the
/// byte after an odd length pads the last gene, and is 0.
fn unpack_state(genes: &[WireGene], len: u32) -> Result<Vec<u8>, WireError> {
    let mut bytes: Vec<u8> = genes.iter().flat_map(|g| [g.action, g.duration]).collect();
    match bytes.get(len as usize) {
        Some(&got) if got != 0 => return Err(WireError::StatePadding { len, got }),
        _ => {}
    }
    bytes.truncate(len as usize);
    Ok(bytes)
}

impl EvalJob {
    /// Evaluates every genome of the job, writing back the actions the
    /// guided pass chose: what a worker answers, and what the coordinator
    /// checks a sampled answer against.
    pub fn run(self) -> ChunkResult {
        let mut genes = self.genes;
        let evaluations = genes
            .chunks_mut(self.genome_length)
            .enumerate()
            .map(|(i, g)| {
                let index = self.first_index + i as u64;
                evaluate(&self.env, self.pass, &self.guide, self.key, index, g)
            })
            .collect();
        let actions = match self.pass {
            Pass::Guide => genes.iter().map(|g| g.action.index()).collect(),
            Pass::Fly => Vec::new(),
        };
        ChunkResult {
            evaluations,
            actions,
        }
    }

    pub fn from_wire(h: &JobHeader, genes: &[WireGene]) -> Result<EvalJob, WireError> {
        let pass = Pass::from_code(h.pass).ok_or(WireError::Pass(h.pass))?;
        // Genome i flies the guided stream `guide(i)`, i + 1: the last
        // one's, `end`, may not run into the streams kept for a trial's
        // start, pads and learning.
        let end = h.first_index.checked_add(u64::from(h.genomes));
        if end.is_none_or(|end| end >= streams::LEARN) {
            return Err(WireError::Index {
                first: h.first_index,
                genomes: h.genomes,
            });
        }
        if h.genome_length == 0 {
            return Err(WireError::NoGenes);
        }
        // The coordinator cuts no larger chunk; a larger one would have
        // this worker allocate and fly without bound.
        let most = most_genomes_per_chunk(h.genome_length as usize);
        if h.genomes as usize > most {
            return Err(WireError::TooManyGenomes {
                genomes: h.genomes,
                length: h.genome_length,
                most,
            });
        }
        let expected = h.genomes as usize * h.genome_length as usize;
        if genes.len() != expected {
            return Err(WireError::Length {
                genomes: h.genomes,
                length: h.genome_length,
                expected,
                got: genes.len(),
            });
        }
        let genes = genes
            .iter()
            .enumerate()
            .map(|(index, g)| check_gene(index, *g, h.max_duration))
            .collect::<Result<_, _>>()?;
        Ok(EvalJob {
            pass,
            key: h.key,
            first_index: h.first_index,
            genome_length: h.genome_length as usize,
            env: h.env,
            guide: h.guide,
            genes,
        })
    }
}

/// Every number of the environment and the guided pass must be finite: a
/// NaN from another process would otherwise fly as a plausible-looking
/// result.
fn check_numbers(h: &JobHeader) -> Result<(), WireError> {
    let (w, s, g) = (&h.env.world, &h.env.scoring, &h.guide);
    let numbers = [
        ("env.x0", h.env.x0),
        ("env.pad_x", h.env.pad_x),
        ("world.width", w.width),
        ("world.height", w.height),
        ("world.gravity", w.gravity),
        ("world.thrust", w.thrust),
        ("world.mass", w.mass),
        ("world.ticks_per_second", w.ticks_per_second),
        ("world.rotation_step", w.rotation_step),
        ("world.start_drop", w.start_drop),
        ("world.ground_y", w.ground_y),
        ("world.hull_scale", w.hull_scale),
        ("world.pad_margin", w.pad_margin),
        ("scoring.w1", s.w1),
        ("scoring.w2", s.w2),
        ("scoring.w3", s.w3),
        ("scoring.big_number", s.big_number),
        ("scoring.safe_distance", s.safe_distance),
        ("scoring.safe_speed", s.safe_speed),
        ("scoring.safe_rotation", s.safe_rotation),
        ("guided.epsilon", g.epsilon),
        ("guided.w_y", g.w_y),
        ("guided.h1", g.h1),
        ("guided.r", g.r),
        ("guided.h2", g.h2),
        ("guided.w_t", g.w_t),
    ];
    match numbers.iter().find(|(_, v)| !v.is_finite()) {
        Some(&(field, _)) => Err(WireError::NotFinite(field)),
        None => Ok(()),
    }
}

fn check_gene(index: usize, g: WireGene, max: u32) -> Result<Gene, WireError> {
    let action = Action::from_index(g.action).ok_or(WireError::Action {
        index,
        action: g.action,
    })?;
    if u32::from(g.duration) > max {
        return Err(WireError::Duration {
            index,
            duration: g.duration,
            max,
        });
    }
    Ok(Gene::new(action, g.duration))
}

impl ChunkResult {
    pub fn encode(&self) -> Vec<u8> {
        encode(self)
    }

    /// Decodes and checks a result for `genomes` genomes of `length` genes.
    pub fn decode(
        bytes: &[u8],
        pass: Pass,
        genomes: usize,
        length: usize,
    ) -> Result<ChunkResult, WireError> {
        let r: ChunkResult = decode_all(bytes).map_err(|e| WireError::Decode(e.to_string()))?;
        if r.evaluations.len() != genomes {
            return Err(WireError::Count {
                expected: genomes,
                got: r.evaluations.len(),
            });
        }
        if let Some(i) = r.evaluations.iter().position(|e| !e.is_plausible()) {
            return Err(WireError::Implausible(i));
        }
        let expected = if pass == Pass::Guide {
            genomes * length
        } else {
            0
        };
        if r.actions.len() != expected {
            return Err(WireError::Length {
                genomes: genomes as u32,
                length: length as u32,
                expected,
                got: r.actions.len(),
            });
        }
        // One pass that the compiler vectorizes, where a search for the
        // first bad action went byte by byte and took most of a chunk's
        // decoding; the index is looked for only when there is one.
        if r.actions.iter().fold(0, |any, &a| any | a) > 3 {
            let index = r.actions.iter().position(|&a| a > 3).unwrap_or_default();
            return Err(WireError::Action {
                index,
                action: r.actions[index],
            });
        }
        Ok(r)
    }
}

/// Decodes and checks a training result as the answer to `job`.
pub fn decode_training(bytes: &[u8], job: &TrainJob) -> Result<TrainResult, WireError> {
    let r: TrainResult = decode_all(bytes).map_err(|e| WireError::Decode(e.to_string()))?;
    if !r.is_plausible(job) {
        return Err(WireError::ImplausibleTraining(job.until));
    }
    Ok(r)
}

/// Encodes any result for the wire.
pub fn encode(value: &impl Serialize) -> Vec<u8> {
    // Encoding plain structs into a Vec cannot fail.
    postcard::to_allocvec(value).unwrap_or_default()
}

/// Why bytes from another process are not one value.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum Undecodable {
    #[error("{0}")]
    Malformed(String),
    #[error("{0} bytes left over after the value")]
    Trailing(usize),
}

/// Decodes all of `bytes` as one `T`, refusing a value followed by bytes
/// it does not account for: every decoder of another process's bytes
/// goes through here.
pub(crate) fn decode_all<'a, T: Deserialize<'a>>(bytes: &'a [u8]) -> Result<T, Undecodable> {
    let (value, rest) =
        postcard::take_from_bytes(bytes).map_err(|e| Undecodable::Malformed(e.to_string()))?;
    if rest.is_empty() {
        Ok(value)
    } else {
        Err(Undecodable::Trailing(rest.len()))
    }
}

#[cfg(test)]
mod tests;
