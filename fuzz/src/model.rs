//! Target `model`: model files, both encodings (`file-io/src/format.rs` `decode`: the binary
//! `.rsm` — magic, header, CRC-32, bincode body with a memory limit — and the JSON form, told
//! apart by content), then what `robosim load` does with a decoded model
//! (`file-io/src/model.rs`: `plan`, `to_transaction`) against the keeper's own checks (an
//! in-memory `Store`).
//!
//! Whatever the bytes: a model or a `FileError` whose message starts with the file given
//! (`fuzz.rsm:`); never a panic, unbounded time or memory. A decoded model plans, turns into
//! one transaction, and the store answers it with success or a typed refusal (no panic). What
//! was read writes and reads back (binary encoding) to the same digest.
//!
//! Byte 0 of the input chooses what the rest is (so mutations get past the checksum): bit 0
//! set — the rest is a binary body and the target writes the header around it (magic, version
//! 1 or 2 from bit 1, its length, its CRC); otherwise the rest is a whole file as on disk.

use robosim_file_io::digest;
use robosim_file_io::format::{MAGIC, decode, encode_binary};
use robosim_instance_space::Store;
use std::path::Path;

pub fn run(data: &[u8]) {
    let Some((&flags, rest)) = data.split_first() else {
        return;
    };
    let file = Path::new("fuzz.rsm");
    let bytes = if flags & 1 == 1 {
        with_header(rest, if flags & 2 == 2 { 2 } else { 1 })
    } else {
        rest.to_vec()
    };
    let model = match decode(&bytes, file) {
        Ok(m) => m,
        Err(e) => {
            let s = e.to_string();
            assert!(
                s.starts_with("fuzz.rsm:"),
                "error does not name the file: {s}"
            );
            return;
        }
    };
    let plan = match model.to_transaction(&[]) {
        Ok(p) => p,
        Err(e) => panic!("a decoded model does not plan: {e}"),
    };
    let _ = Store::new().apply(&plan.tx).map_err(|e| e.to_string());
    let again = match decode(&encode_binary(&model), file) {
        Ok(m) => m,
        Err(e) => panic!("a model read from the file does not read back after writing: {e}"),
    };
    assert_eq!(
        digest(&model),
        digest(&again),
        "the model changed on a write and read"
    );
}

/// A binary model file around `body` (the layout of `format.rs`).
fn with_header(body: &[u8], version: u32) -> Vec<u8> {
    let mut head = Vec::with_capacity(16);
    head.extend_from_slice(&version.to_le_bytes());
    head.extend_from_slice(&0u32.to_le_bytes());
    head.extend_from_slice(&(body.len() as u64).to_le_bytes());
    let mut h = crc32fast::Hasher::new();
    h.update(&head);
    h.update(body);
    let mut out = Vec::with_capacity(28 + body.len());
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&head);
    out.extend_from_slice(&h.finalize().to_le_bytes());
    out.extend_from_slice(body);
    out
}
