//! Target `journal`: Instance Space recovery (`instance-space/src/journal.rs` `recover`): the
//! newest checkpoint (magic, CRC, bincode model), then the journal's records
//! `[len u32][crc32 u32][version u64][transaction]`, each decoded and applied; a torn or
//! corrupt tail is cut off.
//!
//! Input envelope (so the fuzzer can reach past the checksums):
//! * byte 0, flags: bit 0 — a checkpoint file comes first, its length in the next 4 bytes
//!   (little-endian, clamped to what is there); bit 1 — rewrite every checksum (the checkpoint's
//!   and each record's) to match, so mutations reach the decoders and `Store::apply`;
//! * then the checkpoint bytes (bit 0), then the journal file's bytes.
//!
//! Whatever the bytes: `recover` returns a store or an error, never panics; recovering a
//! second time from what the first left behind finds the same version and no new problem
//! (the first cut every bad tail), which is the journal's promise to the keeper.

use robosim_instance_space::journal::recover;
use std::path::Path;

const CHECKPOINT_FILE: &str = "checkpoint-00000000000000000000.bin";
const JOURNAL_FILE: &str = "journal-00000000000000000001.log";

/// Splits the envelope into (checkpoint, journal); checksums fixed when asked.
pub fn unpack(data: &[u8]) -> (Option<Vec<u8>>, Vec<u8>) {
    let Some((&flags, rest)) = data.split_first() else {
        return (None, Vec::new());
    };
    let (ck, journal) = if flags & 1 != 0 && rest.len() >= 4 {
        let n = u32::from_le_bytes([rest[0], rest[1], rest[2], rest[3]]) as usize;
        let rest = &rest[4..];
        let n = n.min(rest.len());
        (Some(rest[..n].to_vec()), rest[n..].to_vec())
    } else {
        (None, rest.to_vec())
    };
    if flags & 2 == 0 {
        return (ck, journal);
    }
    let ck = ck.map(|mut c| {
        if c.len() >= 12 {
            let crc = crc32(&[&c[12..]]);
            c[8..12].copy_from_slice(&crc.to_le_bytes());
        }
        c
    });
    let mut j = journal;
    let mut pos = 8;
    while pos + 16 <= j.len() {
        let len = u32::from_le_bytes([j[pos], j[pos + 1], j[pos + 2], j[pos + 3]]) as usize;
        let end = match (pos + 16).checked_add(len) {
            Some(e) if e <= j.len() => e,
            _ => break,
        };
        let crc = crc32(&[&j[pos + 8..pos + 16], &j[pos + 16..end]]);
        j[pos + 4..pos + 8].copy_from_slice(&crc.to_le_bytes());
        pos = end;
    }
    (ck, j)
}

/// Packs a checkpoint and a journal into the envelope (the seed generator's inverse of
/// [`unpack`]).
pub fn pack(checkpoint: Option<&[u8]>, journal: &[u8], fix_checksums: bool) -> Vec<u8> {
    let mut out = vec![u8::from(checkpoint.is_some()) | (u8::from(fix_checksums) << 1)];
    if let Some(c) = checkpoint {
        out.extend_from_slice(&(c.len() as u32).to_le_bytes());
        out.extend_from_slice(c);
    }
    out.extend_from_slice(journal);
    out
}

fn crc32(parts: &[&[u8]]) -> u32 {
    // CRC-32 (IEEE), as crc32fast computes it; bitwise, the inputs are small.
    let mut crc = !0u32;
    for p in parts {
        for &b in *p {
            crc ^= u32::from(b);
            for _ in 0..8 {
                crc = if crc & 1 != 0 {
                    (crc >> 1) ^ 0xEDB8_8320
                } else {
                    crc >> 1
                };
            }
        }
    }
    !crc
}

/// A scratch directory on tmpfs when there is one: recovery syncs files and directories, and
/// an fsync per execution would bound the fuzzer to disk speed.
fn scratch() -> std::io::Result<tempfile::TempDir> {
    let shm = Path::new("/dev/shm");
    if shm.is_dir()
        && let Ok(d) = tempfile::Builder::new()
            .prefix("robosim-fuzz")
            .tempdir_in(shm)
    {
        return Ok(d);
    }
    tempfile::Builder::new().prefix("robosim-fuzz").tempdir()
}

pub fn run(data: &[u8]) {
    let (ck, journal) = unpack(data);
    let Ok(dir) = scratch() else {
        return;
    };
    if let Some(ck) = &ck
        && std::fs::write(dir.path().join(CHECKPOINT_FILE), ck).is_err()
    {
        return;
    }
    if std::fs::write(dir.path().join(JOURNAL_FILE), &journal).is_err() {
        return;
    }
    let first = match recover(dir.path()) {
        Ok((store, journal, report)) => {
            drop(journal);
            (store.version, store.len(), report)
        }
        Err(e) => {
            let _ = e.to_string();
            return;
        }
    };
    let (version, len, report) = match recover(dir.path()) {
        Ok((store, journal, report)) => {
            drop(journal);
            (store.version, store.len(), report)
        }
        Err(e) => panic!("second recovery failed after the first succeeded: {e}"),
    };
    assert_eq!(
        (version, len),
        (first.0, first.1),
        "second recovery found another model (first: {:?})",
        first.2.problems
    );
    let new: Vec<&String> = report
        .problems
        .iter()
        .filter(|p| !p.starts_with("skipped checkpoint"))
        .collect();
    assert!(
        new.is_empty(),
        "second recovery found problems the first left: {new:?} (first: {:?})",
        first.2.problems
    );
}
