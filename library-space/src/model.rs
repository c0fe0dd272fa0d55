//! The plain data a declaration evaluates to. No shared memory, no source text: the lead's
//! instantiation copies this into the Instance Space, the simulator reads robots and effects,
//! the display reads solids, colours and surfaces.
//!
//! Frames: a [`PlacedSolid`]'s `transform` maps its polyhedron's own frame (centred on its
//! bounding box) into the frame it belongs to: the solid declaration's frame, a robot's link
//! frame j (the frame at the end of `A_j`, DESIGN.md), or the world for scene items.

use nalgebra::Matrix4;
use robosim_geometry::{MassProperties, Polyhedron};
use robosim_kinematics::Robot;
use serde::{Deserialize, Serialize};

/// Red, green, blue in [0, 1].
pub type Rgb = [f64; 3];

/// A surface finish (rlib.h `Surface`): diffuse colour plus specular highlight.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Surface {
    pub name: String,
    pub colour: Rgb,
    /// Specular reflectance in [0, 1].
    pub specular: f64,
    /// Phong exponent ≥ 0.
    pub shininess: f64,
    /// Opacity in [0, 1] (1: opaque).
    pub opacity: f64,
}

/// Which generator made a primitive and with what parameters (SI), so the higher-level
/// concept survives evaluation (seed §3.3: the Library Space knows a box is a box).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
/// Serialized externally tagged (`{"cylinder": {...}}`) so non-self-describing formats
/// (bincode) carry it; the query protocol writes it as `{"shape": "cylinder", ...}`.
#[serde(rename_all = "snake_case")]
pub enum Primitive {
    Box {
        size: [f64; 3],
    },
    Cylinder {
        radius: f64,
        height: f64,
        facets: usize,
    },
    Cone {
        radius: f64,
        height: f64,
        facets: usize,
    },
    TruncatedCone {
        bottom: f64,
        top: f64,
        height: f64,
        facets: usize,
    },
    Sphere {
        radius: f64,
        facets: usize,
    },
    Extrusion {
        points: Vec<[f64; 2]>,
        height: f64,
    },
    Revolution {
        points: Vec<[f64; 2]>,
        angle: f64,
        facets: Option<usize>,
    },
}

/// One convex-faced primitive, placed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlacedSolid {
    /// Path of part names from the declaration down, e.g. `upper_arm/web`.
    pub name: String,
    pub primitive: Primitive,
    pub polyhedron: Polyhedron,
    pub transform: Matrix4<f64>,
    pub colour: Option<Rgb>,
    pub surface: Option<Surface>,
}

/// A solid declaration evaluated: its primitives (flattened part tree) and, where a density or
/// mass was declared, its mass properties in the solid's frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SolidModel {
    pub name: String,
    pub parts: Vec<PlacedSolid>,
    pub mass: Option<MassProperties>,
}

/// A robot: the kinematic/dynamic model plus the solids drawn and collided per frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RobotModel {
    pub robot: Robot,
    /// Link names, one per joint of `robot`.
    pub link_names: Vec<String>,
    /// `frames[0]`: solids fixed to the base frame; `frames[j]`: solids of link j, in link
    /// frame j. Length `robot.dof() + 1`.
    pub frames: Vec<Vec<PlacedSolid>>,
    /// The analytic inverse-kinematics family the robot declares (`puma`, `stanford`, …), if any.
    pub ik: Option<String>,
    /// The file's `<mimic>` relations over `robot`'s joints (a `from_urdf` or `from_mjcf`
    /// robot's; empty: no joint follows another): the robot stays the full model, every joint a
    /// coordinate, and [`RobotModel::coupling`] binds the followers to their leaders.
    ///
    /// Added after the other fields with a serde default: a robot serialised (JSON) before it
    /// existed reads back with no relations. (Nothing in the repository keeps a `RobotModel` in
    /// bincode, whose positional encoding a new field always changes.)
    #[serde(default)]
    pub mimics: Vec<MimicJoint>,
}

/// One mimic relation of a robot by joint index (0-based, a floating root's coordinates not
/// counted): `q[follower] = multiplier · q[leader] + offset`; `leader: None` — the leader is
/// not a joint of the robot (a fixed joint, or off the imported chain), so the follower is
/// fixed at `offset`. The serialisable form of `robosim_kinematics::mimic::Mimic`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MimicJoint {
    pub follower: usize,
    pub leader: Option<usize>,
    pub multiplier: f64,
    pub offset: f64,
}

impl MimicJoint {
    /// The kinematics core's relation.
    pub fn relation(&self) -> robosim_kinematics::mimic::Mimic {
        robosim_kinematics::mimic::Mimic {
            follower: self.follower,
            leader: self.leader,
            multiplier: self.multiplier,
            offset: self.offset,
        }
    }
}

/// A solid at its place in the world (or in a robot's base frame): a path name, the solid, and
/// the transform from the polyhedron's frame to the world.
#[derive(Debug, Clone, Copy)]
pub struct Posed<'a> {
    /// `robot/link/part` or `item/part`.
    pub path: (&'a str, &'a str, &'a str),
    pub solid: &'a PlacedSolid,
    pub world: Matrix4<f64>,
}

impl RobotModel {
    /// Every solid of the robot at joint values `q` (rad / m, `dof` entries; check with
    /// `Robot::check_q`), with its world transform `T_frame(q) · transform`. Frame 0 is the
    /// robot's base. Pure: no side effects.
    pub fn posed_solids<'a>(&'a self, name: &'a str, q: &[f64]) -> Vec<Posed<'a>> {
        let frames = robosim_kinematics::fk::link_frames(&self.robot, q);
        let mut out = Vec::new();
        for (j, solids) in self.frames.iter().enumerate() {
            let link = if j == 0 {
                "base"
            } else {
                self.link_names[j - 1].as_str()
            };
            for p in solids {
                out.push(Posed {
                    path: (name, link, p.name.as_str()),
                    solid: p,
                    world: frames[j] * p.transform,
                });
            }
        }
        out
    }
}

impl RobotModel {
    /// The coupling of [`RobotModel::mimics`] over the robot's coordinates (a floating root's
    /// first, passed through); `Ok(None)` when no joint mimics another. Refused (a follower or
    /// leader past the robot's joints, two leaders, a cycle, a non-finite factor) only for
    /// relations the evaluator did not write — it checks them when it reads the file.
    pub fn coupling(
        &self,
    ) -> Result<Option<robosim_kinematics::mimic::Coupling>, robosim_kinematics::mimic::MimicError>
    {
        if self.mimics.is_empty() {
            return Ok(None);
        }
        let relations: Vec<_> = self.mimics.iter().map(MimicJoint::relation).collect();
        let c = robosim_kinematics::mimic::Coupling::new(self.robot.dof(), &relations)?;
        Ok(Some(
            c.with_root(self.robot.root_nq(), self.robot.root_nv()),
        ))
    }

    /// The robot as the one robot model ([`robosim_model::Model`]), its solids converted once
    /// into geometry objects: each placed solid on its frame at its `transform`, role
    /// collision (the library draws what it collides), colour with alpha 1; a box, cylinder,
    /// cone or sphere as that primitive with the library's facet count, any other primitive
    /// (truncated cone, extrusion, revolution) as its polygons; a `from_urdf` mesh (a hull the
    /// evaluator labels by its bounding box) as its hull. Joint names are the link names (a
    /// library robot names its links). The coupling is [`RobotModel::coupling`]'s (`None` also
    /// for relations it refuses, which only a hand-edited serialised model can hold: the
    /// evaluator checks every relation it writes). Collision solids:
    /// [`robosim_model::Model::collision_solids`].
    pub fn model(&self) -> robosim_model::Model {
        let mut objects = Vec::new();
        for (frame, solids) in self.frames.iter().enumerate() {
            for p in solids {
                objects.push(robosim_model::GeometryObject {
                    name: p.name.clone(),
                    frame,
                    placement: p.transform,
                    shape: shape_of(p),
                    role: robosim_model::Role::Collision,
                    rgba: p.colour.map(|c| [c[0], c[1], c[2], 1.0]),
                });
            }
        }
        robosim_model::Model {
            robot: self.robot.clone(),
            joint_names: self.link_names.clone(),
            link_names: self.link_names.clone(),
            coupling: self.coupling().ok().flatten(),
            geometry: robosim_model::GeometryModel { objects },
            ik: self.ik.clone(),
        }
    }
}

/// Whether `poly` is the centred box of `size`: 8 vertices, each at ± half the size.
fn is_box(poly: &Polyhedron, size: &[f64; 3]) -> bool {
    poly.vertices.len() == 8
        && poly.vertices.iter().all(|v| {
            (0..3).all(|k| ((v[k].abs() - size[k] / 2.0).abs()) <= 1e-12 * size[k].max(1.0))
        })
}

impl PlacedSolid {
    /// The solid's shape as the model describes it ([`RobotModel::model`] gives each placed
    /// solid of a robot this shape): the studies build a scene's fixed solids from it through
    /// [`robosim_model::GeometryObject::collision_parts`], the one builder.
    pub fn shape(&self) -> robosim_model::Shape {
        shape_of(self)
    }
}

/// A placed solid's shape for the robot model (see [`RobotModel::model`]).
fn shape_of(p: &PlacedSolid) -> robosim_model::Shape {
    use robosim_model::Shape;
    let polygons = |convex| {
        let poly = &p.polyhedron;
        Shape::Polygons {
            vertices: poly.vertices.clone(),
            polygons: (0..poly.polygons.len())
                .map(|i| poly.polygon_indices(i).to_vec())
                .collect(),
            convex,
        }
    };
    match &p.primitive {
        // A box's polyhedron is its 8 corners (centred); a `from_urdf` mesh's hull is
        // labelled a box of its bounding box but has its own vertices.
        Primitive::Box { size } if is_box(&p.polyhedron, size) => Shape::Box { size: *size },
        Primitive::Box { .. } => polygons(true),
        Primitive::Cylinder {
            radius,
            height,
            facets,
        } => Shape::Cylinder {
            radius: *radius,
            length: *height,
            facets: Some(*facets),
        },
        Primitive::Cone {
            radius,
            height,
            facets,
        } => Shape::Cone {
            radius: *radius,
            height: *height,
            facets: Some(*facets),
        },
        Primitive::Sphere { radius, facets } => Shape::Sphere {
            radius: *radius,
            facets: Some(*facets),
        },
        Primitive::TruncatedCone { .. }
        | Primitive::Extrusion { .. }
        | Primitive::Revolution { .. } => polygons(false),
    }
}

impl RobotModel {
    /// The robot's box parts per frame (`[0]`: base, `[j]`: link j), as the scene-level plans
    /// read them ([`robosim_model::parts`]: solar panels, ORUs).
    pub fn box_parts(&self) -> Vec<Vec<robosim_model::parts::BoxPart>> {
        self.frames.iter().map(|f| box_parts(f)).collect()
    }
}

/// The box primitives among `solids`, as plain box parts.
fn box_parts(solids: &[PlacedSolid]) -> Vec<robosim_model::parts::BoxPart> {
    solids
        .iter()
        .filter_map(|s| match s.primitive {
            Primitive::Box { size } => Some(robosim_model::parts::BoxPart {
                name: s.name.clone(),
                size,
                transform: s.transform,
            }),
            _ => None,
        })
        .collect()
}

impl SceneModel {
    /// The scene by its box parts ([`robosim_model::parts::SceneParts`]): what the simulator's
    /// scene-level plans (the ORU swap, the solar arrays) read, without library types.
    pub fn parts(&self) -> robosim_model::parts::SceneParts {
        use robosim_model::parts::{RobotParts, SceneParts, SolidParts};
        SceneParts {
            name: self.name.clone(),
            robots: self
                .robots
                .iter()
                .map(|r| RobotParts {
                    name: r.name.clone(),
                    robot: r.model.robot.clone(),
                    link_names: r.model.link_names.clone(),
                    q: r.q.clone(),
                    frames: r.model.box_parts(),
                })
                .collect(),
            solids: self
                .solids
                .iter()
                .map(|i| SolidParts {
                    name: i.name.clone(),
                    placement: i.placement,
                    parts: box_parts(&i.solid.parts),
                })
                .collect(),
        }
    }

    /// What changed from `self` (the old evaluation) to `new`, item by item, by name.
    pub fn changes_to(&self, new: &SceneModel) -> SceneChanges {
        let mut c = SceneChanges {
            effects: self.effects != new.effects,
            ..SceneChanges::default()
        };
        for r in &new.robots {
            match self.robots.iter().find(|o| o.name == r.name) {
                Some(o) if o != r => c.robots.push(r.name.clone()),
                Some(_) => {}
                None => c.added.push(r.name.clone()),
            }
        }
        for i in &new.solids {
            match self.solids.iter().find(|o| o.name == i.name) {
                Some(o) if o != i => c.solids.push(i.name.clone()),
                Some(_) => {}
                None => c.added.push(i.name.clone()),
            }
        }
        for o in self
            .robots
            .iter()
            .map(|r| &r.name)
            .chain(self.solids.iter().map(|i| &i.name))
        {
            let still =
                new.robots.iter().any(|r| &r.name == o) || new.solids.iter().any(|i| &i.name == o);
            if !still {
                c.removed.push(o.clone());
            }
        }
        c
    }

    /// Every solid of the scene in the world: the placed solids, and the robots' solids at their
    /// initial joint values.
    pub fn posed_solids(&self) -> Vec<Posed<'_>> {
        let mut out = Vec::new();
        for it in &self.solids {
            for p in &it.solid.parts {
                out.push(Posed {
                    path: (it.name.as_str(), "", p.name.as_str()),
                    solid: p,
                    world: it.placement * p.transform,
                });
            }
        }
        for r in &self.robots {
            out.extend(r.model.posed_solids(&r.name, &r.q));
        }
        out
    }
}

/// A robot placed in a scene. Its `model.robot.base` already includes `placement`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlacedRobot {
    pub name: String,
    /// The robot (or link) declaration it was made from, when placed by calling one.
    pub declaration: Option<String>,
    pub model: RobotModel,
    pub placement: Matrix4<f64>,
    /// Initial joint values (rad / m), `dof` entries.
    pub q: Vec<f64>,
}

/// A solid placed in a scene, in the world frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlacedItem {
    pub name: String,
    pub solid: SolidModel,
    pub placement: Matrix4<f64>,
}

/// The effects a scene calls for (DESIGN.md, "Scenes declare their effects"): the one typed
/// set, `robosim_model`'s [`robosim_model::Options`] (the simulator reads the same types),
/// here under the names the library has always used. What is not declared is off and costs
/// nothing — except kinematics, on unless the scene says `off` (the evaluator starts from
/// it). The effects block is read by `eval::effects`.
pub use robosim_model::{
    AttitudeEffect, AttitudeHold, AutomationEffect, CollisionEffect, CollisionMode, DynamicsEffect,
    EncoderEffect, Integrator, LoggingEffect, OnContact, Options as Effects, OrbitEffect,
    OruSwapEffect, PowerEffect, Signal,
};

/// Which placed items differ between two evaluations of a scene (see
/// [`SceneModel::changes_to`]): what a live parameter change must re-instantiate.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct SceneChanges {
    /// Robots present in both whose model, placement or initial q differ.
    pub robots: Vec<String>,
    /// Solids present in both whose geometry or placement differ.
    pub solids: Vec<String>,
    /// Names placed only in the new evaluation.
    pub added: Vec<String>,
    /// Names placed only in the old evaluation.
    pub removed: Vec<String>,
    /// The effects changed.
    pub effects: bool,
}

impl SceneChanges {
    /// Nothing changed.
    pub fn is_empty(&self) -> bool {
        self.robots.is_empty()
            && self.solids.is_empty()
            && self.added.is_empty()
            && self.removed.is_empty()
            && !self.effects
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SceneModel {
    pub name: String,
    pub robots: Vec<PlacedRobot>,
    pub solids: Vec<PlacedItem>,
    pub effects: Effects,
}

/// What [`crate::Library::evaluate`] returns, by declaration kind.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
/// Serialized externally tagged (`{"robot": {...}}`), which bincode supports.
#[serde(rename_all = "lowercase")]
pub enum Evaluated {
    Constant {
        value: f64,
        unit: String,
    },
    Colour {
        rgb: Rgb,
    },
    Surface(Surface),
    Solid(SolidModel),
    /// A link declaration on its own: a one-joint robot.
    Link(RobotModel),
    Robot(RobotModel),
    Scene(SceneModel),
}
