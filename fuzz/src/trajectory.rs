//! Target `trajectory`: the display's joint trajectory files (MD's file mode, seed §2.2;
//! `display/src/trajectory.rs`): one sample per line, `#` comments, `# units:` and `# dt:`.
//!
//! Whatever the bytes: `Trajectory::parse` returns a trajectory or an error naming a line;
//! a trajectory has at least one sample, every sample as wide as the first, every value and
//! `dt` finite, and its samples convert to SI at any index.
//!
//! The includer provides `super::traj::{Trajectory, to_si}` (the display's, or the same file
//! compiled into the fuzz crate).

use super::traj::{Trajectory, to_si};
use std::path::Path;

pub fn run(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let path = Path::new("fuzz.traj");
    match Trajectory::parse(text, path) {
        Ok(t) => {
            assert!(!t.samples.is_empty(), "a trajectory without samples");
            assert!(t.dt.is_finite() && t.dt > 0.0, "dt {} accepted", t.dt);
            let n = t.columns();
            for s in &t.samples {
                assert_eq!(s.len(), n, "samples of different widths accepted");
                assert!(s.iter().all(|v| v.is_finite()), "non-finite value accepted");
            }
            // Prismatic flags shorter, as long and longer than a sample; past the last sample.
            for prismatic in [vec![], vec![true; n], vec![false; n + 1]] {
                for k in [0, t.samples.len() - 1, t.samples.len(), usize::MAX] {
                    let q = t.sample_si(k, &prismatic);
                    assert_eq!(q.len(), n);
                }
            }
            let _ = to_si(&t.samples[0], &[true], t.radians);
        }
        Err(e) => {
            let msg = e.to_string();
            assert!(
                msg.starts_with("fuzz.traj:"),
                "error without the file: {msg}"
            );
        }
    }
}
