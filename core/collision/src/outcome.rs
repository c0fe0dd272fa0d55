//! What a collision query answers. Every answer admits doubt: [`PairResult::Unknown`] carries
//! the reason (an unsupported shape pair, a non-finite result, an iteration limit); no code path
//! turns a failure into a silent clear.

use nalgebra::Point3;
use serde::{Deserialize, Serialize};

/// Which algorithm answers a pair query (DESIGN.md `mode`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    /// Bounding boxes only (seed Eq. 8–9): conservative, says contact whenever the boxes meet.
    #[serde(rename = "bbox")]
    BBox,
    /// The seed's polygon algorithm (POCODA, §2.6) on the faceted solids.
    Polygon,
    /// parry: GJK/EPA on the true primitives, distances and witness points.
    #[default]
    Exact,
}

impl Mode {
    pub fn name(self) -> &'static str {
        match self {
            Mode::BBox => "bbox",
            Mode::Polygon => "polygon",
            Mode::Exact => "exact",
        }
    }
}

/// The answer for one pair of bodies. Points are in the world frame, metres.
#[derive(Debug, Clone, PartialEq)]
pub enum PairResult {
    /// The bodies do not touch. `distance` (> 0) and the closest points (on a, on b) are given
    /// when the mode computes them (exact mode).
    Clear {
        distance: Option<f64>,
        witness: Option<[Point3<f64>; 2]>,
    },
    /// The bodies touch or overlap. `signed_distance` ≤ 0 is minus the penetration depth (exact
    /// mode, when EPA gives it); `witness` are the deepest points (exact) or the point where an
    /// edge pierces a polygon (polygon mode). The bbox mode gives neither.
    Contact {
        signed_distance: Option<f64>,
        witness: Option<[Point3<f64>; 2]>,
    },
    /// The mode could not decide; the reason says why. Treat as "maybe colliding".
    Unknown { reason: String },
}

impl PairResult {
    /// `Some(true)` for contact, `Some(false)` for clear, `None` when unknown.
    pub fn intersects(&self) -> Option<bool> {
        match self {
            PairResult::Clear { .. } => Some(false),
            PairResult::Contact { .. } => Some(true),
            PairResult::Unknown { .. } => None,
        }
    }
    pub fn is_clear(&self) -> bool {
        matches!(self, PairResult::Clear { .. })
    }
    /// Signed distance where known: the separation when clear, minus the depth when in contact.
    pub fn signed_distance(&self) -> Option<f64> {
        match self {
            PairResult::Clear { distance, .. } => *distance,
            PairResult::Contact {
                signed_distance, ..
            } => *signed_distance,
            PairResult::Unknown { .. } => None,
        }
    }
    pub fn witness(&self) -> Option<[Point3<f64>; 2]> {
        match self {
            PairResult::Clear { witness, .. } | PairResult::Contact { witness, .. } => *witness,
            PairResult::Unknown { .. } => None,
        }
    }
    /// The same answer with the roles of a and b exchanged (witness points swapped).
    pub fn swapped(self) -> Self {
        match self {
            PairResult::Clear { distance, witness } => PairResult::Clear {
                distance,
                witness: witness.map(|[a, b]| [b, a]),
            },
            PairResult::Contact {
                signed_distance,
                witness,
            } => PairResult::Contact {
                signed_distance,
                witness: witness.map(|[a, b]| [b, a]),
            },
            u => u,
        }
    }
}
