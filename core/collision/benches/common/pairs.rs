//! The pairs of `testdata/collision/tolerance_pairs.csv` for the `tolerance` bench and the
//! `peer_distance` example, read by the crate's own reader ([`pair_file`]).

pub use robosim_collision::exact::pair_file::{self, Pair};

/// Every pair of the file, in file order.
pub fn load() -> Result<Vec<Pair>, String> {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../testdata/collision/tolerance_pairs.csv"
    );
    let text = std::fs::read_to_string(path).map_err(|e| format!("{path}: {e}"))?;
    pair_file::parse(&text, path)
}
