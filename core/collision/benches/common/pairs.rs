//! The pairs of `testdata/collision/tolerance_pairs.csv` (primitives) and
//! `tolerance_hull_pairs.csv` (convex meshes) for the `tolerance` bench and the `peer_distance`
//! example, read by the crate's own reader ([`pair_file`]).

pub use robosim_collision::exact::pair_file::{self, Pair};

/// Every pair of both files, in file order (primitives first).
pub fn load() -> Result<Vec<Pair>, String> {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../testdata/collision/");
    let mut all = Vec::new();
    for name in ["tolerance_pairs.csv", "tolerance_hull_pairs.csv"] {
        let path = format!("{dir}{name}");
        let text = std::fs::read_to_string(&path).map_err(|e| format!("{path}: {e}"))?;
        all.extend(pair_file::parse(&text, &path).map_err(|e| e.to_string())?);
    }
    Ok(all)
}
