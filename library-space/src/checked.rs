//! The checked library as bytes: what a session's keeper publishes beside the source text so
//! that every other process reads the Library Space instead of parsing and checking it again
//! (the check evaluates every declaration at its defaults: tens of milliseconds for the
//! standard library; reading the encoding takes a few).
//!
//! Layout (little-endian): the magic `RSLCHKD1`, the format ([`CHECKED_FORMAT`], u32), a
//! fingerprint of this build's syntax-tree types (u64), the digest of the sources the library
//! was built from ([`sources_digest`], u64), the payload's length and FNV-1a checksum (u64
//! each), then the payload: the declarations' syntax trees (bincode). The source text is not
//! in it: the reader has it already (it is published beside the encoding), rebuilds the
//! source map from it, and only accepts the encoding if the digest matches it.
//!
//! [`Library::decode_checked`] refuses, with the reason ([`StaleEncoding`]), an encoding of
//! another format or another build's syntax tree, made from other sources, damaged, or not
//! decodable; the caller then parses the sources as before.

use crate::ast::Decl;
use crate::library::Library;
use crate::source::SourceMap;
use std::collections::HashMap;

/// The encoding's format; bumped when the header changes.
pub const CHECKED_FORMAT: u32 = 1;

const MAGIC: &[u8; 8] = b"RSLCHKD1";
const HEADER: usize = 8 + 4 + 8 * 4;
/// The largest payload decoded (the standard library's is a few hundred KiB).
const MAX_PAYLOAD: usize = 256 << 20;

const fn fnv1a(mut h: u64, bytes: &[u8]) -> u64 {
    let mut i = 0;
    while i < bytes.len() {
        h ^= bytes[i] as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
        i += 1;
    }
    h
}

const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;

/// A fingerprint of the source of the types the payload holds: a build whose syntax tree is
/// declared differently reads another build's encoding as stale instead of misreading it.
const LAYOUT: u64 = fnv1a(
    fnv1a(
        fnv1a(FNV_OFFSET, include_bytes!("ast.rs")),
        include_bytes!("source.rs"),
    ),
    include_bytes!("units.rs"),
);

/// FNV-1a over every (name, text), each length-prefixed: what [`Library::encode_checked`]
/// records and [`Library::decode_checked`] compares. Not a cryptographic hash: it tells a
/// stale encoding from a current one, it does not authenticate one (the session's shared
/// memory is the user's own).
pub fn sources_digest<S: AsRef<str>, T: AsRef<str>>(files: &[(S, T)]) -> u64 {
    let mut h = FNV_OFFSET;
    for (name, text) in files {
        for part in [name.as_ref(), text.as_ref()] {
            h = fnv1a(h, &(part.len() as u64).to_le_bytes());
            h = fnv1a(h, part.as_bytes());
        }
    }
    h
}

/// Why an encoding of the checked library was not used.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum StaleEncoding {
    #[error("it is {0} bytes, shorter than its header")]
    Short(usize),
    #[error("it does not begin with the checked-library magic")]
    Magic,
    #[error("it is in format {found}; this build reads format {expected}")]
    Format { found: u32, expected: u32 },
    #[error(
        "it was written by a build with another syntax tree (layout {found:016x}; this build's is {expected:016x})"
    )]
    Layout { found: u64, expected: u64 },
    #[error(
        "it was made from other sources (digest {found:016x}; the published sources' is {expected:016x})"
    )]
    Digest { found: u64, expected: u64 },
    #[error("its payload is {found} bytes, the header says {expected}")]
    Length { found: usize, expected: u64 },
    #[error("its payload's checksum does not match (damaged)")]
    Checksum,
    /// bincode refused the payload (its error, kept: [`DecodeFailure::error`]).
    #[error("its payload cannot be decoded: {0}")]
    Decode(#[source] DecodeFailure),
    /// The declarations were decoded but bytes are left after them.
    #[error("its payload cannot be decoded: {0} bytes left over after the declarations")]
    LeftOver(usize),
    #[error("it is not consistent with its sources: {0}")]
    Inconsistent(String),
}

/// bincode's decoding error, shared so that [`StaleEncoding`] stays `Clone` and comparable
/// (two failures are equal when they say the same: bincode's error has no equality).
#[derive(Debug, Clone)]
pub struct DecodeFailure(std::sync::Arc<bincode::error::DecodeError>);

impl DecodeFailure {
    /// bincode's error.
    pub fn error(&self) -> &bincode::error::DecodeError {
        &self.0
    }
}

impl std::fmt::Display for DecodeFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.0.fmt(f)
    }
}

impl std::error::Error for DecodeFailure {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        Some(&*self.0)
    }
}

impl PartialEq for DecodeFailure {
    fn eq(&self, other: &Self) -> bool {
        self.to_string() == other.to_string()
    }
}

impl Eq for DecodeFailure {}

fn u64_at(b: &[u8], at: usize) -> u64 {
    let mut w = [0u8; 8];
    w.copy_from_slice(&b[at..at + 8]);
    u64::from_le_bytes(w)
}

impl Library {
    /// This (checked) library as bytes for [`Library::decode_checked`].
    pub fn encode_checked(&self) -> Vec<u8> {
        let payload = bincode::serde::encode_to_vec(&self.decls, bincode::config::standard())
            // Serializing plain owned data into a Vec does not fail.
            .unwrap_or_default();
        let files: Vec<(&str, &str)> = self
            .map
            .files
            .iter()
            .map(|f| (f.path.as_str(), f.text.as_str()))
            .collect();
        let mut out = Vec::with_capacity(HEADER + payload.len());
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&CHECKED_FORMAT.to_le_bytes());
        out.extend_from_slice(&LAYOUT.to_le_bytes());
        out.extend_from_slice(&sources_digest(&files).to_le_bytes());
        out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
        out.extend_from_slice(&fnv1a(FNV_OFFSET, &payload).to_le_bytes());
        out.extend_from_slice(&payload);
        out
    }

    /// The library `bytes` encode ([`Library::encode_checked`]), built from `sources` — the
    /// (name, text) list of [`Library::sources`] it was made from. Nothing is parsed or
    /// evaluated again: the library was checked when it was encoded. Refused with the reason
    /// when it is of another format or build, of other sources, damaged or undecodable.
    pub fn decode_checked(
        bytes: &[u8],
        sources: &[(String, String)],
    ) -> Result<Library, StaleEncoding> {
        if bytes.len() < HEADER {
            return Err(StaleEncoding::Short(bytes.len()));
        }
        if &bytes[..8] != MAGIC {
            return Err(StaleEncoding::Magic);
        }
        let mut f = [0u8; 4];
        f.copy_from_slice(&bytes[8..12]);
        let format = u32::from_le_bytes(f);
        if format != CHECKED_FORMAT {
            return Err(StaleEncoding::Format {
                found: format,
                expected: CHECKED_FORMAT,
            });
        }
        let layout = u64_at(bytes, 12);
        if layout != LAYOUT {
            return Err(StaleEncoding::Layout {
                found: layout,
                expected: LAYOUT,
            });
        }
        let digest = u64_at(bytes, 20);
        let expected = sources_digest(sources);
        if digest != expected {
            return Err(StaleEncoding::Digest {
                found: digest,
                expected,
            });
        }
        let len = u64_at(bytes, 28);
        let payload = &bytes[HEADER..];
        if payload.len() as u64 != len {
            return Err(StaleEncoding::Length {
                found: payload.len(),
                expected: len,
            });
        }
        if u64_at(bytes, 36) != fnv1a(FNV_OFFSET, payload) {
            return Err(StaleEncoding::Checksum);
        }
        let (decls, read): (Vec<Decl>, usize) = bincode::serde::decode_from_slice(
            payload,
            bincode::config::standard().with_limit::<MAX_PAYLOAD>(),
        )
        .map_err(|e| StaleEncoding::Decode(DecodeFailure(std::sync::Arc::new(e))))?;
        if read != payload.len() {
            return Err(StaleEncoding::LeftOver(payload.len() - read));
        }
        let mut map = SourceMap::default();
        for (name, text) in sources {
            map.add(name.clone(), text.clone());
        }
        let mut index = HashMap::with_capacity(decls.len());
        for (k, d) in decls.iter().enumerate() {
            if d.name_span.file as usize >= map.files.len() {
                return Err(StaleEncoding::Inconsistent(format!(
                    "`{}` is declared in file {} of {}",
                    d.name,
                    d.name_span.file,
                    map.files.len()
                )));
            }
            if index.insert(d.name.clone(), k).is_some() {
                return Err(StaleEncoding::Inconsistent(format!(
                    "`{}` is declared twice",
                    d.name
                )));
            }
        }
        Ok(Library { map, decls, index })
    }
}
