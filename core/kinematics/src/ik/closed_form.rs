//! What the closed-form solvers share ([`super::analytic`]'s spherical wrist and
//! [`super::parallel`]'s three parallel axes, and [`super::hybrid`]): the rounding slack at the
//! workspace boundary, the wrist-singularity threshold, the flags a solution carries without
//! allocating, and a raw solution before offsets and the pick. [`super::analytic`] re-exports
//! them under their old paths.

use super::{Branch, Note};

/// How far past ±1 a sine/cosine may be, by rounding, before the branch counts as unreachable.
pub const CLAMP_SLACK: f64 = 1e-10;
/// |sin θ5| below this is treated as the wrist singularity.
pub const WRIST_SINGULAR: f64 = 1e-12;

/// Closed-form flags kept without allocation (see [`Note`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Flags {
    pub wrist_singular: bool,
    pub shoulder_singular: bool,
    pub elbow_clamped: Option<f64>,
    pub shoulder_clamped: Option<f64>,
}

impl Flags {
    pub fn notes(&self) -> Vec<Note> {
        let mut n = Vec::new();
        if self.shoulder_singular {
            n.push(Note::ShoulderSingular);
        }
        if let Some(excess) = self.shoulder_clamped {
            n.push(Note::ShoulderClamped { excess });
        }
        if let Some(excess) = self.elbow_clamped {
            n.push(Note::ElbowClamped { excess });
        }
        if self.wrist_singular {
            n.push(Note::WristSingular);
        }
        n
    }
}

/// A raw closed-form solution: joint values (offsets removed, each wrapped into (−π, π]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RawSolution {
    pub q: [f64; 6],
    pub branch: Branch,
    pub flags: Flags,
}
