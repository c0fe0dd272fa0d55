//! Target `dae`: Collada visual meshes (`core/urdf/src/dae.rs` `read_dae`, what a URDF's
//! `<mesh filename="….dae">` is read with).
//!
//! Whatever the bytes: coloured triangles or a [`DaeError`] naming the file given (`fuzz.dae`)
//! and a line inside it; never a panic, a stack overflow or unbounded time or memory. The
//! reader's triangle budget ([`robosim_urdf::dae::MAX_TRIANGLES`]) bounds what one file may
//! expand to (a geometry instanced by many nodes multiplies its triangles).

use robosim_urdf::dae::{DaeError, MAX_TRIANGLES, read_dae};
use std::path::Path;

pub fn run(data: &[u8]) {
    let file = Path::new("fuzz.dae");
    let lines = data.iter().filter(|&&b| b == b'\n').count() + 1;
    match read_dae(data, file) {
        Ok(parts) => {
            let n: usize = parts.iter().map(|p| p.triangles.len()).sum();
            assert!(n <= MAX_TRIANGLES, "{n} triangles, over the budget");
        }
        Err(e) => check(&e, file, lines),
    }
}

fn check(e: &DaeError, file: &Path, lines: usize) {
    assert_eq!(e.file, file, "error names another file: {e}");
    assert!(
        (e.line as usize) <= lines,
        "error at line {} of a {lines}-line file: {e}",
        e.line
    );
    let _ = e.to_string();
}
