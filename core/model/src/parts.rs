//! The box parts of a compiled scene, as the scene-level plans read them: the solar arrays
//! (boxes named `panel…`/`blanket…` on a robot's links, `robosim_simulator::power`) and the ORU
//! swap (boxes named `oru…`, `robosim_simulator::swap`). Plain values, filled by whoever
//! compiles the scene (the Library Space: `SceneModel::parts`), so the simulator needs no
//! library types.
//!
//! Frames as in the library: a part's `transform` maps its box's own frame (centred on the
//! box) into the frame it rides in — a robot's link frame j (0 = base) or a placed solid's
//! frame.

use nalgebra::Matrix4;
use robosim_kinematics::Robot;

/// One box part, placed.
#[derive(Debug, Clone, PartialEq)]
pub struct BoxPart {
    /// Path of part names from the declaration down, e.g. `mast/oru0`; plans match the last
    /// component (the leaf).
    pub name: String,
    /// Box sizes along its own x, y, z, m.
    pub size: [f64; 3],
    pub transform: Matrix4<f64>,
}

impl BoxPart {
    /// The last component of the part's path.
    pub fn leaf(&self) -> &str {
        self.name.rsplit('/').next().unwrap_or(&self.name)
    }
}

/// A placed robot: its kinematics (base placed), initial q and box parts per frame.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotParts {
    /// The place name.
    pub name: String,
    pub robot: Robot,
    /// Link names, one per joint.
    pub link_names: Vec<String>,
    /// Initial joint values (rad / m), `dof` entries.
    pub q: Vec<f64>,
    /// `frames[0]`: boxes on the base; `frames[j]`: boxes of link j. Length `dof + 1`.
    pub frames: Vec<Vec<BoxPart>>,
}

/// A solid placed in the world: its place name, placement and box parts.
#[derive(Debug, Clone, PartialEq)]
pub struct SolidParts {
    pub name: String,
    pub placement: Matrix4<f64>,
    pub parts: Vec<BoxPart>,
}

/// A scene's robots and solids, by their box parts.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SceneParts {
    pub name: String,
    pub robots: Vec<RobotParts>,
    pub solids: Vec<SolidParts>,
}
