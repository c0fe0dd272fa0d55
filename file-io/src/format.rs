//! The model file: one format, two encodings of the same content.
//!
//! **Binary** (any name not ending in `.json`), all integers little-endian:
//!
//! | bytes | field |
//! |---|---|
//! | 8 | magic `\x89RSMODEL` (the high first byte catches 7-bit transfers) |
//! | 4 | format version (u32; this build writes [`FORMAT_VERSION`]) |
//! | 4 | flags (u32; 0, reserved) |
//! | 8 | body length in bytes (u64) |
//! | 4 | CRC-32 (IEEE) of the format version, flags, length and body |
//! | n | body: bincode 2 (standard configuration, serde) of [`Body`] |
//!
//! **JSON** (`.json`, or asked for): one object, `{"format": "robosim-model",
//! "format_version": 1, "version": …, "objects": [...], "library": [...]}` — the same fields as
//! the binary body, readable and editable by hand (no checksum: editing is what it is for).
//!
//! Reading checks, in order: magic (or a JSON object), length (truncated), checksum, format
//! version (0 does not exist; newer than [`FORMAT_VERSION`] is refused with a message saying
//! so — the 28-byte header keeps its layout in every version, so a newer file's checksum checks
//! out and its version is read), trailing bytes, decoding (with a memory limit in proportion to the file size, as the
//! keeper's checkpoints are read), then the model's structure ([`SavedModel::plan`]).
//!
//! **Versions.** Version 1's body is [`Body`] over the keeper's [`ObjectData`]. Version 2 adds
//! one thing, general joints (`Kinematics::Axis`, an enum variant appended after version 1's,
//! so a version-1 body decodes with today's types unchanged and one decoder reads both). A
//! model without general joints is still written as version 1, so an older build reads it; a
//! model with them is written as version 2, which an older build refuses as a newer format.
//! Version 3 adds floating robots (`Kinematics::FloatingRobot`, again an appended variant, so
//! versions 1 and 2 decode unchanged); a model without one is written as before. Version 4 adds
//! mimic joints (`Kinematics::Mimic`, appended after `FloatingRobot`: versions 1–3 decode
//! unchanged; a model without one is written as before). Any other change makes version 5, and the older readers then keep a frozen copy of today's types. The file `testdata/file-io/station-v1.rsm`, written by version 1, is loaded by a test
//! forever.

use crate::error::FileError;
use crate::model::{LibrarySource, SavedModel};
use robosim_instance_space::{Kinematics, ObjectData};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The magic that starts a binary model file.
pub const MAGIC: [u8; 8] = *b"\x89RSMODEL";
/// The format version this build writes (and the newest it reads).
pub const FORMAT_VERSION: u32 = 4;

/// The oldest version that can hold `model`: 4 when it has a mimic joint, 3 when it has a
/// floating robot, 2 when it has a general joint, else 1.
fn version_for(model: &SavedModel) -> u32 {
    if model
        .objects
        .iter()
        .any(|o| matches!(o.kinematics, Some(Kinematics::Mimic { .. })))
    {
        4
    } else if model
        .objects
        .iter()
        .any(|o| matches!(o.kinematics, Some(Kinematics::FloatingRobot { .. })))
    {
        3
    } else if model
        .objects
        .iter()
        .any(|o| matches!(o.kinematics, Some(Kinematics::Axis { .. })))
    {
        2
    } else {
        1
    }
}
/// The `"format"` value of the JSON encoding.
pub const JSON_FORMAT: &str = "robosim-model";
const HEADER: usize = 28;

/// The content of a model file, format versions 1 and 2.
#[derive(Debug, Serialize, Deserialize)]
pub struct Body {
    /// The Instance Space version the model was saved at.
    pub version: u64,
    pub objects: Vec<ObjectData>,
    pub library: Vec<LibrarySource>,
}

#[derive(Serialize)]
struct JsonOut<'a> {
    format: &'a str,
    format_version: u32,
    version: u64,
    objects: &'a [ObjectData],
    library: &'a [LibrarySource],
}

#[derive(Deserialize)]
struct JsonHead {
    format: Option<String>,
    format_version: Option<u32>,
}

#[derive(Deserialize)]
struct JsonIn {
    version: u64,
    objects: Vec<ObjectData>,
    library: Vec<LibrarySource>,
}

/// Which encoding.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoding {
    Binary,
    Json,
}

impl Encoding {
    /// JSON for a name ending in `.json` (any case), binary otherwise.
    pub fn from_path(path: &Path) -> Encoding {
        match path.extension().and_then(|e| e.to_str()) {
            Some(e) if e.eq_ignore_ascii_case("json") => Encoding::Json,
            _ => Encoding::Binary,
        }
    }
}

/// The binary encoding of `model`.
pub fn encode_binary(model: &SavedModel) -> Vec<u8> {
    #[derive(Serialize)]
    struct BodyRef<'a> {
        version: u64,
        objects: &'a [ObjectData],
        library: &'a [LibrarySource],
    }
    let body = BodyRef {
        version: model.version,
        objects: &model.objects,
        library: &model.library,
    };
    // Plain data into a Vec: encoding cannot fail.
    let body =
        bincode::serde::encode_to_vec(&body, bincode::config::standard()).unwrap_or_default();
    let mut out = Vec::with_capacity(HEADER + body.len());
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&version_for(model).to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes());
    out.extend_from_slice(&(body.len() as u64).to_le_bytes());
    let crc = checksum(&out[8..HEADER - 4], &body);
    out.extend_from_slice(&crc.to_le_bytes());
    out.extend_from_slice(&body);
    out
}

fn checksum(head: &[u8], body: &[u8]) -> u32 {
    let mut h = crc32fast::Hasher::new();
    h.update(head);
    h.update(body);
    h.finalize()
}

/// The JSON encoding of `model`. `path` names the file in errors: JSON has no ±∞, so a joint
/// limit of ±∞ is refused (the binary form holds it).
pub fn encode_json(model: &SavedModel, path: &Path) -> Result<Vec<u8>, FileError> {
    for o in &model.objects {
        if let Some(
            Kinematics::Joint { qlim, .. }
            | Kinematics::Axis { qlim, .. }
            | Kinematics::Mimic { qlim, .. },
        ) = o.kinematics
        {
            for (k, v) in qlim.iter().enumerate() {
                if !v.is_finite() {
                    return Err(FileError::NotJsonable {
                        path: path.to_owned(),
                        what: format!("object {} ({:?})", o.id, o.name),
                        field: format!("qlim[{k}]"),
                        value: *v,
                    });
                }
            }
        }
    }
    let out = JsonOut {
        format: JSON_FORMAT,
        format_version: version_for(model),
        version: model.version,
        objects: &model.objects,
        library: &model.library,
    };
    serde_json::to_vec_pretty(&out).map_err(|e| FileError::Decode {
        path: path.to_owned(),
        reason: format!("cannot encode as JSON: {e}"),
    })
}

/// Decodes a model file of either encoding (told apart by the content, not the name) and
/// checks its structure. `path` names the file in errors.
pub fn decode(bytes: &[u8], path: &Path) -> Result<SavedModel, FileError> {
    let model = if bytes.starts_with(&MAGIC) {
        decode_binary(bytes, path)?
    } else if bytes
        .iter()
        .find(|b| !b.is_ascii_whitespace())
        .is_some_and(|&b| b == b'{')
    {
        decode_json(bytes, path)?
    } else {
        return Err(FileError::Magic {
            path: path.to_owned(),
        });
    };
    model.plan().map_err(|problem| FileError::Model {
        path: path.to_owned(),
        problem,
    })?;
    Ok(model)
}

/// Reads and decodes the model file at `path`: a regular file of at most
/// [`robosim_input::Limit::MODEL`] bytes ([`FileError::Input`] otherwise).
pub fn read(path: &Path) -> Result<SavedModel, FileError> {
    let bytes = robosim_input::read_file(path, "a model file", robosim_input::Limit::MODEL)?;
    decode(&bytes, path)
}

/// Writes `model` to `path` in the encoding its name asks for (or `encoding`): to a temporary
/// file beside it, synced, then renamed, so a crash leaves the old file or the new one, never
/// half of one. Returns the bytes written.
pub fn write(model: &SavedModel, path: &Path, encoding: Encoding) -> Result<u64, FileError> {
    let bytes = match encoding {
        Encoding::Binary => encode_binary(model),
        Encoding::Json => encode_json(model, path)?,
    };
    write_atomic(path, &bytes)?;
    Ok(bytes.len() as u64)
}

/// Every output file of this crate (models, exports): [`robosim_input::write_file_atomic`] —
/// temporary file, sync, rename, directory sync; never onto a link, a FIFO or a device.
pub(crate) fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), FileError> {
    Ok(robosim_input::write_file_atomic(path, bytes)?)
}

fn decode_binary(bytes: &[u8], path: &Path) -> Result<SavedModel, FileError> {
    let truncated = |expected: u64| FileError::Truncated {
        path: path.to_owned(),
        expected,
        found: bytes.len() as u64,
    };
    if bytes.len() < HEADER {
        return Err(truncated(HEADER as u64));
    }
    let u32_at =
        |k: usize| u32::from_le_bytes([bytes[k], bytes[k + 1], bytes[k + 2], bytes[k + 3]]);
    let mut len = [0u8; 8];
    len.copy_from_slice(&bytes[16..24]);
    let expected = (HEADER as u64).saturating_add(u64::from_le_bytes(len));
    if (bytes.len() as u64) < expected {
        return Err(truncated(expected));
    }
    // `expected` ≤ the file's length, which fits in usize.
    let body = &bytes[HEADER..expected as usize];
    // The header keeps this layout in every format version, so the checksum is checked before
    // the version: a flipped version byte is damage, a newer writer's file checks out.
    let stored = u32_at(24);
    let computed = checksum(&bytes[8..HEADER - 4], body);
    if computed != stored {
        return Err(FileError::Checksum {
            path: path.to_owned(),
            stored,
            computed,
        });
    }
    check_version(u32_at(8), path)?;
    let flags = u32_at(12);
    if flags != 0 {
        return Err(FileError::Decode {
            path: path.to_owned(),
            reason: format!("header flags {flags:#x} are not known to this build"),
        });
    }
    if bytes.len() as u64 > expected {
        return Err(FileError::Decode {
            path: path.to_owned(),
            reason: format!(
                "{} bytes after the end the header announces (two files concatenated?)",
                bytes.len() as u64 - expected
            ),
        });
    }
    let body: Body = decode_limited(body).map_err(|e| FileError::Decode {
        path: path.to_owned(),
        reason: format!("the body does not decode: {e}"),
    })?;
    Ok(SavedModel {
        version: body.version,
        objects: body.objects,
        library: body.library,
    })
}

fn check_version(found: u32, path: &Path) -> Result<(), FileError> {
    if found == 0 {
        return Err(FileError::UnknownFormat {
            path: path.to_owned(),
            found,
        });
    }
    if found > FORMAT_VERSION {
        return Err(FileError::FutureFormat {
            path: path.to_owned(),
            found,
            supported: FORMAT_VERSION,
        });
    }
    Ok(())
}

/// bincode with a memory limit in proportion to the body (as the keeper reads checkpoints): a
/// length prefix that claims more than the body could describe is refused before anything is
/// allocated for it. Decoded size is at most ~32× the encoded size for these types.
fn decode_limited(body: &[u8]) -> Result<Body, bincode::error::DecodeError> {
    use bincode::config::standard;
    let limit = body.len().saturating_mul(32).saturating_add(4096);
    macro_rules! within {
        ($($n:literal),*) => {
            $( if limit <= (1usize << $n) {
                let (b, used) = bincode::serde::decode_from_slice(body, standard().with_limit::<{ 1usize << $n }>())?;
                return trailing(b, used, body.len());
            } )*
        };
    }
    within!(16, 20, 24, 28, 30, 32, 34);
    let (b, used) =
        bincode::serde::decode_from_slice(body, standard().with_limit::<{ 1usize << 36 }>())?;
    trailing(b, used, body.len())
}

fn trailing(b: Body, used: usize, len: usize) -> Result<Body, bincode::error::DecodeError> {
    if used == len {
        Ok(b)
    } else {
        Err(bincode::error::DecodeError::OtherString(format!(
            "{} bytes left over after the model",
            len - used
        )))
    }
}

fn decode_json(bytes: &[u8], path: &Path) -> Result<SavedModel, FileError> {
    let bad = |e: serde_json::Error| FileError::Decode {
        path: path.to_owned(),
        reason: format!("JSON line {} column {}: {e}", e.line(), e.column()),
    };
    let head: JsonHead = serde_json::from_slice(bytes).map_err(bad)?;
    if head.format.as_deref() != Some(JSON_FORMAT) {
        return Err(FileError::Magic {
            path: path.to_owned(),
        });
    }
    let Some(version) = head.format_version else {
        return Err(FileError::Decode {
            path: path.to_owned(),
            reason: "no \"format_version\"".into(),
        });
    };
    check_version(version, path)?;
    let body: JsonIn = serde_json::from_slice(bytes).map_err(bad)?;
    Ok(SavedModel {
        version: body.version,
        objects: body.objects,
        library: body.library,
    })
}
