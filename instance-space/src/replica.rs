//! What a keeper tells a process that keeps a copy of its space elsewhere (a network bridge,
//! `robosim bridge`): the whole model once ([`SpaceSnapshot`]), then every committed
//! transaction in order ([`LogAnswer`]), both asked for over the keeper's ordinary request
//! service; and the replica side of a keeper ([`crate::KeeperOptions::replica`]), which applies
//! those transactions instead of its own writers' and hands its writers' transactions to the
//! bridge to forward.
//!
//! The keeper keeps the last committed transactions in memory ([`LOG_MAX_BYTES`],
//! [`LOG_MAX_ENTRIES`]), so a bridge that lost its link — or was restarted — catches up from
//! the version it has; one that fell further behind than the log holds gets
//! [`LogAnswer::Gone`] and takes a new snapshot.

use serde::{Deserialize, Serialize};

/// A snapshot request: `SNAPSHOT_MAGIC` alone. Like [`crate::keeper`]'s continuation request,
/// it starts with 0xFF, which no transaction's encoding does.
pub(crate) const SNAPSHOT_MAGIC: [u8; 5] = [0xFF, b'S', b'N', b'A', b'P'];
/// A log request: `LOG_MAGIC`, the version the asker has (u64 LE), the library generation it
/// has (u64 LE).
pub(crate) const LOG_MAGIC: [u8; 5] = [0xFF, b'L', b'O', b'G', b'S'];

/// The most bytes of transactions the keeper keeps for catching up.
pub const LOG_MAX_BYTES: usize = 64 << 20;
/// The most transactions the keeper keeps for catching up.
pub const LOG_MAX_ENTRIES: usize = 1 << 20;
/// The most bytes of transactions in one [`LogAnswer::Entries`] (the asker asks again).
pub const LOG_ANSWER_BYTES: usize = 1 << 20;

/// The whole space at one version.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpaceSnapshot {
    /// [`crate::journal::encode_store`] of the model (its version inside).
    pub model: Vec<u8>,
    /// The Library Space as the keeper publishes it.
    pub library: PublishedLibrary,
    /// Counts the keeper's library publications (0: none yet).
    pub library_gen: u64,
}

/// The Library Space as a keeper publishes it (`Keeper::publish_library_checked`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct PublishedLibrary {
    /// The source files (name, text).
    pub files: Vec<(String, String)>,
    /// The checked library's encoding (`robosim_library::Library::encode_checked`), when the
    /// publisher gave it: readers decode it instead of parsing the sources.
    pub checked: Option<Vec<u8>>,
}

/// The transactions after a version.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum LogAnswer {
    /// `entries` are (version, encoded transaction), consecutive from the asked version + 1;
    /// `version` is the keeper's version now (more may follow: ask again from the last one).
    /// `library` is there when the library generation differs from the asker's.
    Entries {
        version: u64,
        entries: Vec<(u64, Vec<u8>)>,
        library: Option<(u64, PublishedLibrary)>,
    },
    /// The keeper no longer holds the transaction after the asked version (its log starts at
    /// `oldest`), or the asker is ahead of it (`version`, a different history): take a snapshot.
    Gone { oldest: u64, version: u64 },
}

/// The keeper's in-memory log of committed transactions, bounded in bytes and entries. It
/// keeps nothing until someone first asks for a snapshot or the log ([`Log::start`]): a
/// session nobody bridges does not copy its commits.
#[derive(Debug, Default)]
pub(crate) struct Log {
    entries: std::collections::VecDeque<(u64, Vec<u8>)>,
    bytes: usize,
    on: bool,
}

impl Log {
    /// Keeps the transactions committed from now on. Whoever asked has the version it asked
    /// at; what came before is answered [`LogAnswer::Gone`] (a snapshot mends it).
    pub fn start(&mut self) {
        self.on = true;
    }

    pub fn push(&mut self, version: u64, tx: &[u8]) {
        if !self.on {
            return;
        }
        self.entries.push_back((version, tx.to_vec()));
        self.bytes += tx.len();
        while self.bytes > LOG_MAX_BYTES || self.entries.len() > LOG_MAX_ENTRIES {
            match self.entries.pop_front() {
                Some((_, t)) => self.bytes -= t.len(),
                None => break,
            }
        }
    }

    /// Forgets everything (the model was replaced: the old history no longer leads to it).
    pub fn clear(&mut self) {
        self.entries.clear();
        self.bytes = 0;
    }

    /// The answer to "what came after `since`", for a keeper now at `version`.
    pub fn after(&self, since: u64, version: u64) -> Result<Vec<(u64, Vec<u8>)>, LogAnswer> {
        if since == version {
            return Ok(Vec::new());
        }
        let oldest = self.entries.front().map_or(version + 1, |e| e.0);
        if since > version || since + 1 < oldest {
            return Err(LogAnswer::Gone { oldest, version });
        }
        let skip = (since + 1 - oldest) as usize;
        let mut out = Vec::new();
        let mut bytes = 0;
        for (v, t) in self.entries.iter().skip(skip) {
            if !out.is_empty() && bytes + t.len() > LOG_ANSWER_BYTES {
                break;
            }
            bytes += t.len();
            out.push((*v, t.clone()));
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_log_answers_from_the_version_after_the_asked_one_or_says_it_is_gone() {
        let mut log = Log::default();
        log.start();
        for v in 5..=9 {
            log.push(v, &[v as u8]);
        }
        let got = log.after(6, 9).expect("entries");
        assert_eq!(got.iter().map(|e| e.0).collect::<Vec<_>>(), vec![7, 8, 9]);
        assert_eq!(got[0].1, vec![7]);
        assert_eq!(log.after(4, 9).expect("entries").len(), 5);
        assert_eq!(log.after(9, 9).expect("entries"), Vec::new());
        assert_eq!(
            log.after(3, 9),
            Err(LogAnswer::Gone {
                oldest: 5,
                version: 9
            })
        );
        // An asker ahead of the keeper has another history.
        assert!(matches!(log.after(12, 9), Err(LogAnswer::Gone { .. })));
    }

    #[test]
    fn the_log_keeps_nothing_until_it_is_started() {
        let mut log = Log::default();
        log.push(1, &[1]);
        assert_eq!(log.bytes, 0);
        assert!(matches!(
            log.after(0, 1),
            Err(LogAnswer::Gone {
                oldest: 2,
                version: 1
            })
        ));
        log.start();
        log.push(2, &[2]);
        assert_eq!(log.after(1, 2).expect("entries"), vec![(2, vec![2])]);
    }

    #[test]
    fn the_log_drops_its_oldest_entries_past_its_byte_bound() {
        let mut log = Log::default();
        log.start();
        let big = vec![0u8; LOG_MAX_BYTES / 2 + 1];
        log.push(1, &big);
        log.push(2, &big);
        log.push(3, &[1]);
        assert_eq!(log.entries.front().map(|e| e.0), Some(2));
        assert!(matches!(
            log.after(0, 3),
            Err(LogAnswer::Gone { oldest: 2, .. })
        ));
        // One answer is bounded too, but never empty while something is due.
        let got = log.after(1, 3).expect("entries");
        assert_eq!(got.len(), 1);
    }
}
