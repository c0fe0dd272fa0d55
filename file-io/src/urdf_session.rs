//! A URDF robot as Instance Space objects, in one transaction (`robosim import urdf`).
//!
//! What the Instance Space gets, for a robot imported with [`crate::urdf_import::import_urdf_tree`]
//! (the whole tree: fixed joints folded, every movable joint a coordinate):
//!
//! * a **robot** object, placed where asked, tool = identity; for a floating robot (`--floating`
//!   or a URDF whose root joint is floating/planar) the robot object is the base link: its
//!   record names the root joint (`Kinematics::FloatingRobot`) and its mass properties are the
//!   base link's inertial;
//! * per movable joint, in q order, a **link** object named after the joint's child link, with
//!   a general joint record (`Kinematics::Axis`: the joint's placement in the link frame it
//!   hangs from, its axis, limits, and that parent link frame — a tree is kept as a tree), its
//!   mass properties, and its pose at q = 0 relative to the robot (as for every robot: poses of
//!   links are relative to the robot object); a `<mimic>` follower's record is a mimic joint
//!   (`Kinematics::Mimic`: the same fields and its leader, multiplier and offset), its value
//!   the relation's at rest, so the session robot's coordinates are the reduced ones;
//! * per URDF `<visual>`, a **visual** object (`Kind::Visual`: drawn, never collided) under the
//!   body the URDF link is rigid with (the robot for the root link and what is fixed to it, else
//!   the link of its movable joint), placed by the link's place in that body and the visual's
//!   origin, coloured by its material;
//! * per URDF `<collision>`, a **solid**: boxes, cylinders and spheres as the geometry library
//!   makes them (cylinders and spheres faceted to 1 mm chord error), meshes as their **convex
//!   hull** (what the collision core and the simulator's contacts want) — or, when the mesh is
//!   closed and its hull more than 25 % bigger, as the convex parts of a V-HACD decomposition
//!   (`LINK-collisionK.P`; [`robosim_collision::decompose`]). When the URDF link has visuals its solids are kept
//!   undrawn (alpha 0: the display skips them), else they are what is drawn.
//!
//! Every mesh is loaded here (geometry is what an import is for): a missing or unreadable mesh
//! is an error naming the URDF file, line and element, and nothing enters the Instance Space.

use crate::import::{hull_geometry, mesh_geometry};
use crate::urdf_geometry::{Geometry, MeshProblem, Shape};
use crate::urdf_import::{UrdfError, UrdfErrorKind, UrdfRobot};
use robosim_instance_space::{
    Appearance, DhConvention, FloatingBase, GeometryInput, IDENTITY, JointKind, Kind, Kinematics,
    ObjRef, Pose, Transaction,
};
use robosim_kinematics::{JointType, RootKind};
use robosim_scene::pose::from_matrix;

/// Where the robot goes.
#[derive(Debug, Clone)]
pub struct UrdfPlacement {
    /// The robot object's name.
    pub name: String,
    /// Its pose relative to `parent`.
    pub pose: Pose,
    /// The scene it stands in (`None`: a root object).
    pub parent: Option<u64>,
    /// Import the `<visual>`s (else the collision solids are what is drawn, and visual meshes
    /// are not read: for a URDF whose visual meshes are not at hand).
    pub visuals: bool,
    /// Write each `<mimic>` follower as a mimic joint (`Kinematics::Mimic`), so the session
    /// robot's coordinates are the reduced ones (`robosim import urdf --mimic`; Pinocchio's
    /// `mimic=True`). Off: every movable joint is a coordinate of its own (Pinocchio's default),
    /// which IK to a tip, the encoder ops and the simulator serve; the coupling is then not kept.
    pub mimic: bool,
}

/// The transaction and what it holds.
#[derive(Debug, Clone)]
pub struct UrdfImport {
    pub tx: Transaction,
    /// Movable joints (link objects).
    pub joints: usize,
    /// Visual objects and collision solids created.
    pub visuals: usize,
    pub solids: usize,
    /// Triangles read from mesh files.
    pub triangles: usize,
    /// Collision meshes whose hull was far from them, made of several convex parts.
    pub decomposed: usize,
}

pub use crate::error::UrdfTxError;

/// The one transaction that creates robot `u` as [`UrdfPlacement`] says (see the module docs).
///
/// Steps: the robot object ([`robot_object`]), per movable joint its link object
/// ([`link_object`], at the joints' rest values [`rest_q`]), then per URDF link its visual
/// objects and collision solids ([`shape_objects`]).
pub fn urdf_tx(u: &UrdfRobot, place: &UrdfPlacement) -> Result<UrdfImport, UrdfTxError> {
    let robot = &u.robot;
    let mut tx = Transaction::new();
    let r = robot_object(&mut tx, robot, place);
    let q0 = rest_q(u, place);
    let poses = robosim_scene::link_poses(robot, &q0);
    let mut bodies = vec![r];
    for j in 0..robot.dof() {
        let l = link_object(&mut tx, u, place, j, r)?;
        tx.set_pose(l, poses[j]);
        tx.set_joint(l, q0.get(robot.root_nq() + j).copied().unwrap_or(0.0));
        bodies.push(l);
    }
    let mut imp = UrdfImport {
        tx,
        joints: robot.dof(),
        visuals: 0,
        solids: 0,
        triangles: 0,
        decomposed: 0,
    };
    for (link, g) in &u.geometry.links {
        if let Some(&body) = bodies.get(g.body) {
            shape_objects(&mut imp, &u.geometry.file, link, g, body, place.visuals)?;
        }
    }
    Ok(imp)
}

/// The robot object, placed and named as asked: its record a fixed-base robot, or for a
/// floating robot the root joint (`Kinematics::FloatingRobot`) with the base link's mass
/// properties (the robot object is its base link).
fn robot_object(
    tx: &mut Transaction,
    robot: &robosim_kinematics::Robot,
    place: &UrdfPlacement,
) -> ObjRef {
    let r = tx.create(Kind::Robot, &place.name, place.parent.map(ObjRef::Id));
    tx.set_pose(r, place.pose);
    tx.set_kinematics(
        r,
        Some(match &robot.root {
            None => Kinematics::Robot {
                convention: DhConvention::Standard,
                ik_family: 0,
                tool: IDENTITY,
            },
            Some(root) => Kinematics::FloatingRobot {
                convention: DhConvention::Standard,
                ik_family: 0,
                tool: IDENTITY,
                root: match root.kind {
                    RootKind::FreeFlyer => FloatingBase::FreeFlyer,
                    RootKind::Planar => FloatingBase::Planar,
                },
            },
        }),
    );
    if let Some(root) = &robot.root {
        tx.set_dynamics(
            r,
            Some(robosim_scene::instantiate::mass_props(
                root.mass,
                &root.com,
                &root.inertia,
            )),
        );
    }
    r
}

/// The joints at rest (the robot's neutral q); with `--mimic`, a follower (URDF `<mimic>`) at
/// its relation's value there.
fn rest_q(u: &UrdfRobot, place: &UrdfPlacement) -> Vec<f64> {
    let mut q0: Vec<f64> = u.robot.neutral_q().iter().copied().collect();
    if let Some(c) = u.coupling.as_ref().filter(|_| place.mimic)
        && let Ok(q) = c.restrict(&q0).and_then(|qr| c.expand_q(&qr))
    {
        q0 = q;
    }
    q0
}

/// The link object of movable joint `j` under the robot object `r`, named after the joint's
/// child link: its general joint record (`Kinematics::Axis`, or with `--mimic` a follower's
/// `Kinematics::Mimic`) and mass properties. Refused: a joint without its origin (a DH row,
/// which `import_urdf_tree` never writes).
fn link_object(
    tx: &mut Transaction,
    u: &UrdfRobot,
    place: &UrdfPlacement,
    j: usize,
    r: ObjRef,
) -> Result<ObjRef, UrdfError> {
    let joint = &u.robot.joints[j];
    let Some(origin) = &joint.origin else {
        // import_urdf_tree writes every joint with its origin; a DH row here is a bug.
        return Err(UrdfError {
            file: u.geometry.file.clone(),
            line: 0,
            element: format!("joint {j}"),
            kind: UrdfErrorKind::Model(robosim_kinematics::ModelError::NonFinite {
                joint: j,
                field: "origin (a DH row, not a URDF joint)",
                value: f64::NAN,
            }),
        });
    };
    let name = u
        .joints
        .get(j)
        .map_or_else(|| format!("link{}", j + 1), |uj| uj.link.clone());
    let l = tx.create(Kind::Link, &name, Some(r));
    let (index, parent) = (
        j as u32,
        u.robot.parents.get(j).copied().unwrap_or(j) as u32,
    );
    let kind = match joint.joint_type {
        JointType::Revolute => JointKind::Revolute,
        JointType::Prismatic => JointKind::Prismatic,
    };
    let (placement, axis) = (
        from_matrix(&origin.placement),
        [origin.axis.x, origin.axis.y, origin.axis.z],
    );
    // A follower (URDF `<mimic>`) is a mimic joint: the session robot's coordinates are
    // the reduced ones (a URDF joint has no offset of its own: `joint.offset` is 0).
    let follows = u
        .mimics
        .iter()
        .find(|m| m.index == j)
        .filter(|_| place.mimic);
    let kinematics = match follows {
        Some(m) if joint.offset == 0.0 => Kinematics::Mimic {
            index,
            parent,
            joint: kind,
            placement,
            axis,
            qlim: joint.qlim,
            leader: m.mimicked_index.map(|l| l as u32),
            multiplier: m.multiplier,
            offset: m.offset,
        },
        _ => Kinematics::Axis {
            index,
            parent,
            joint: kind,
            placement,
            axis,
            offset: joint.offset,
            qlim: joint.qlim,
        },
    };
    tx.set_kinematics(l, Some(kinematics));
    tx.set_dynamics(
        l,
        Some(robosim_scene::instantiate::mass_props(
            joint.mass,
            &joint.com,
            &joint.inertia,
        )),
    );
    Ok(l)
}

/// URDF link `link`'s shapes under `body` (the object it is rigid with): with `visuals`, a
/// visual object per `<visual>` (a piece each), and a solid per `<collision>` (a decomposed
/// mesh's parts `LINK-collisionK.P`), undrawn when the link has visuals; counted in `imp`.
fn shape_objects(
    imp: &mut UrdfImport,
    file: &std::path::Path,
    link: &str,
    g: &crate::urdf_geometry::LinkGeometry,
    body: ObjRef,
    visuals: bool,
) -> Result<(), UrdfTxError> {
    let tx = &mut imp.tx;
    let shown = if visuals { &g.visual[..] } else { &[] };
    for (k, s) in shown.iter().enumerate() {
        let (pieces, tris, _) = shape_geometry(s, false, file, link, "visual")?;
        imp.triangles += tris;
        for geometry in pieces {
            let v = tx.create(Kind::Visual, &format!("{link}-visual{k}"), Some(body));
            tx.set_pose(v, from_matrix(&(g.in_body * s.origin)));
            tx.set_geometry(v, Some(geometry));
            tx.set_appearance(v, appearance(s, 1.0));
            imp.visuals += 1;
        }
    }
    let hidden = !shown.is_empty();
    for (k, s) in g.collision.iter().enumerate() {
        let (parts, tris, split) = shape_geometry(s, true, file, link, "collision")?;
        imp.triangles += tris;
        imp.decomposed += usize::from(split);
        let many = parts.len() > 1;
        for (p, geometry) in parts.into_iter().enumerate() {
            // A decomposed mesh's parts are `LINK-collisionK.P`.
            let name = if many {
                format!("{link}-collision{k}.{p}")
            } else {
                format!("{link}-collision{k}")
            };
            let c = tx.create(Kind::Solid, &name, Some(body));
            tx.set_pose(c, from_matrix(&(g.in_body * s.origin)));
            tx.set_geometry(c, Some(geometry));
            tx.set_appearance(c, appearance(s, if hidden { 0.0 } else { 1.0 }));
            imp.solids += 1;
        }
    }
    Ok(())
}

/// A shape's colour: its material's, else the default grey; alpha forced to `alpha` when 0
/// (undrawn), else the material's.
fn appearance(s: &Shape, alpha: f32) -> Appearance {
    let mut a = Appearance::default();
    if let Some(rgba) = s.material.as_ref().and_then(|m| m.rgba) {
        a.color = rgba.map(|c| c.clamp(0.0, 1.0) as f32);
    }
    if alpha == 0.0 {
        a.color[3] = 0.0;
    } else if a.color[3] <= 0.0 {
        // A material with alpha 0 would vanish; URDF viewers draw it.
        a.color[3] = 1.0;
    }
    a
}

/// A shape as Instance Space geometry: one piece, or for a collision mesh its convex parts
/// (the hull, or a decomposition when the hull is far from the mesh:
/// [`robosim_collision::decompose`]). Also the triangles read, and whether it was decomposed.
fn shape_geometry(
    s: &Shape,
    collision: bool,
    file: &std::path::Path,
    link: &str,
    what: &str,
) -> Result<(Vec<GeometryInput>, usize, bool), UrdfTxError> {
    use robosim_geometry::shapes;
    let bad = |problem: MeshProblem| UrdfError {
        file: file.to_owned(),
        line: s.line,
        element: format!("<link name={link:?}>/<{what}>"),
        kind: UrdfErrorKind::Mesh(problem),
    };
    let poly = match &s.geometry {
        Geometry::Box { size } => shapes::cuboid(size.x, size.y, size.z),
        Geometry::Cylinder { radius, length } => shapes::cylinder(*radius, *length, None),
        Geometry::Sphere { radius } => shapes::sphere(*radius, None),
        Geometry::Mesh(m) => {
            let tris = m.load()?;
            let path = m.path()?;
            let shape = |e: crate::FileError| UrdfTxError::MeshGeometry {
                file: m.urdf.clone(),
                line: m.line,
                element: m.element.clone(),
                role: if collision {
                    "collision solid"
                } else {
                    "visual geometry"
                },
                source: Box::new(e),
            };
            if !collision {
                let g = mesh_geometry(&tris, false, &path).map_err(shape)?;
                return Ok((vec![g.geometry], g.read, false));
            }
            let d = robosim_collision::decompose::convex_parts(
                &tris,
                robosim_collision::decompose::DEFAULT_EXCESS,
            )
            .map_err(|e| m.err(MeshProblem::Parts(e)))?;
            let parts = d
                .parts
                .iter()
                .map(|p| hull_geometry(p, &path).map(|g| g.geometry))
                .collect::<Result<Vec<_>, _>>()
                .map_err(shape)?;
            return Ok((parts, tris.len(), d.decomposed));
        }
    };
    poly.map(|p| (vec![GeometryInput::from_polyhedron(&p)], 0, false))
        .map_err(|e| bad(MeshProblem::Solid(e)).into())
}

/// A process-local model of the robot in the URDF file at `path`: one scene, `urdf`, with the
/// robot at its origin under its `<robot name>` — what `robosim render FILE.urdf` draws.
pub fn urdf_store(
    path: &std::path::Path,
) -> Result<robosim_instance_space::Store, crate::FileError> {
    let u = crate::urdf_import::import_urdf_tree(path)?;
    let mut store = robosim_instance_space::Store::default();
    let mut tx = Transaction::new();
    tx.create(Kind::Scene, "urdf", None);
    store.apply(&tx).map_err(|e| refused(path, &u, e))?;
    let scene = robosim_instance_space::Snapshot::from_store(&store).objects()[0].id;
    let imp = urdf_tx(
        &u,
        &UrdfPlacement {
            name: u.robot.name.clone(),
            mimic: false,
            pose: IDENTITY,
            parent: Some(scene),
            visuals: true,
        },
    )?;
    store.apply(&imp.tx).map_err(|e| refused(path, &u, e))?;
    Ok(store)
}

fn refused(
    path: &std::path::Path,
    u: &UrdfRobot,
    e: robosim_instance_space::TxError,
) -> crate::FileError {
    crate::FileError::Refused {
        path: path.to_owned(),
        session: "(local)".into(),
        id: 0,
        name: u.robot.name.clone(),
        source: Box::new(e),
    }
}
