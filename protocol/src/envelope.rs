//! The envelope jobs and results travel in between hosts: magic, protocol
//! version and kind, then the body, all postcard. Shared memory needs none
//! of this (both ends are this build on one host); a network frame may come
//! from anything, so [`decode_job`] and [`decode_result`] reject every
//! malformed frame with a reason and never panic.

use crate::wire::{
    decode_all, encode, JobHeader, ResultHeader, Undecodable, WireGene, PROTOCOL_VERSION,
};
use serde::{Deserialize, Serialize};

/// The first bytes of every frame.
pub const MAGIC: [u8; 4] = *b"LNDR";
/// The largest frame either side accepts: far above any real chunk (a
/// population of a million 50-gene genomes is 100 MB of genes).
pub const MAX_FRAME: usize = 128 << 20;

/// Frame kinds.
pub const FRAME_JOB: u8 = 1;
pub const FRAME_RESULT: u8 = 2;

#[derive(Serialize, Deserialize)]
struct Frame<'a> {
    magic: [u8; 4],
    version: u32,
    kind: u8,
    #[serde(borrow, with = "serde_bytes")]
    body: &'a [u8],
}

#[derive(Serialize, Deserialize)]
struct JobBody<'a> {
    header: JobHeader,
    /// Action and duration byte pairs, genome after genome.
    #[serde(borrow, with = "serde_bytes")]
    genes: &'a [u8],
}

#[derive(Serialize, Deserialize)]
struct ResultBody<'a> {
    header: ResultHeader,
    /// A postcard `ChunkResult` or `TrainResult`, or the reason for a
    /// refusal.
    #[serde(borrow, with = "serde_bytes")]
    body: &'a [u8],
}

#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum FrameError {
    #[error("frame of {0} bytes is larger than the {MAX_FRAME} allowed")]
    TooLarge(usize),
    #[error("not a lander frame (bad magic)")]
    Magic,
    #[error("frame of protocol version {got}, but this side speaks version {PROTOCOL_VERSION}")]
    Version { got: u32 },
    #[error("frame of kind {got} where kind {expected} was expected")]
    Kind { got: u8, expected: u8 },
    #[error("malformed frame: {0}")]
    Malformed(String),
    #[error("{0} bytes after the end of the frame")]
    Trailing(usize),
    #[error("genes take two bytes each, but the frame holds {0} bytes")]
    OddGenes(usize),
}

impl From<Undecodable> for FrameError {
    fn from(e: Undecodable) -> FrameError {
        match e {
            Undecodable::Malformed(why) => FrameError::Malformed(why),
            Undecodable::Trailing(n) => FrameError::Trailing(n),
        }
    }
}

fn wrap(kind: u8, body: &[u8]) -> Vec<u8> {
    encode(&Frame {
        magic: MAGIC,
        version: PROTOCOL_VERSION,
        kind,
        body,
    })
}

fn unwrap(bytes: &[u8], kind: u8) -> Result<&[u8], FrameError> {
    if bytes.len() > MAX_FRAME {
        return Err(FrameError::TooLarge(bytes.len()));
    }
    if !bytes.starts_with(&MAGIC) {
        return Err(FrameError::Magic);
    }
    let frame: Frame = decode_all(bytes)?;
    if frame.version != PROTOCOL_VERSION {
        return Err(FrameError::Version { got: frame.version });
    }
    if frame.kind != kind {
        return Err(FrameError::Kind {
            got: frame.kind,
            expected: kind,
        });
    }
    Ok(frame.body)
}

pub fn encode_job(header: &JobHeader, genes: &[WireGene]) -> Vec<u8> {
    let pairs: Vec<u8> = genes.iter().flat_map(|g| [g.action, g.duration]).collect();
    wrap(
        FRAME_JOB,
        &encode(&JobBody {
            header: *header,
            genes: &pairs,
        }),
    )
}

/// The header and genes of a job frame. The caller still checks them with
/// [`crate::wire::Job::from_wire`], as it does for shared memory.
pub fn decode_job(bytes: &[u8]) -> Result<(JobHeader, Vec<WireGene>), FrameError> {
    let body: JobBody = decode_all(unwrap(bytes, FRAME_JOB)?)?;
    if !body.genes.len().is_multiple_of(2) {
        return Err(FrameError::OddGenes(body.genes.len()));
    }
    let genes = body
        .genes
        .chunks_exact(2)
        .map(|p| WireGene {
            action: p[0],
            duration: p[1],
        })
        .collect();
    Ok((body.header, genes))
}

pub fn encode_result(header: &ResultHeader, body: &[u8]) -> Vec<u8> {
    wrap(
        FRAME_RESULT,
        &encode(&ResultBody {
            header: *header,
            body,
        }),
    )
}

/// The header and body of a result frame; the body is checked by the
/// decoder of the job it answers.
pub fn decode_result(bytes: &[u8]) -> Result<(ResultHeader, Vec<u8>), FrameError> {
    let r: ResultBody = decode_all(unwrap(bytes, FRAME_RESULT)?)?;
    Ok((r.header, r.body.to_vec()))
}

#[cfg(test)]
mod tests;
