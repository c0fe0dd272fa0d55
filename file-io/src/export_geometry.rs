//! A robot's geometry for the URDF and MJCF exports (issue 36 item 4): each shape with the
//! robosim link frame it is rigid with, its placement in that frame, what it is (box, cylinder,
//! sphere, or a triangle mesh) and whether it is drawn (visual), collided (collision) or both.
//!
//! Two sources:
//! * a Library Space robot's solids ([`ExportGeometry::from_frames`], `RobotModel::frames`):
//!   each solid is both visual and collision (robosim draws and collides the same solids). A
//!   solid declared as a box, cylinder or sphere whose polyhedron **is** that primitive (every
//!   vertex on its surface; a `from_urdf` mesh hull is labelled a box of its bounding size and
//!   is not one) is written as the primitive — URDF and MJCF primitives are exact, robosim's
//!   cylinder and sphere are the inscribed faceted forms, within their tessellation error
//!   (docs/file-io.md); anything else (cones, extrusions, revolutions, hulls) is its
//!   polyhedron triangulated, written as a binary STL mesh.
//! * an imported URDF's own `<visual>` and `<collision>` elements ([`ExportGeometry::from_urdf`]):
//!   primitives as they are, meshes loaded (STL, OBJ, Collada) and written as STL.
//!
//! Frames: `origin` is the shape's frame in **robosim's** link frame `frame` (0 the base, j the
//! link after joint j, as `robosim_kinematics::fk::link_frames` gives them). The writers move
//! it into their own link frames ([`exported_frames`]).

use nalgebra::{Matrix3, Matrix4, Rotation3, Vector3};
use robosim_kinematics::{Convention, Joint, Robot};

/// What a shape is.
#[derive(Debug, Clone, PartialEq)]
pub enum ShapeKind {
    /// Full side lengths (m), centred.
    Box {
        size: [f64; 3],
    },
    /// Axis z, centred.
    Cylinder {
        radius: f64,
        length: f64,
    },
    Sphere {
        radius: f64,
    },
    /// Triangles in the shape's frame (m), counter-clockwise seen from outside.
    Mesh {
        triangles: Vec<[[f64; 3]; 3]>,
    },
}

/// One shape of the robot.
#[derive(Debug, Clone, PartialEq)]
pub struct ExportShape {
    /// A name for the file (unique within the robot after [`ExportGeometry::unique_names`]).
    pub name: String,
    /// Robosim's link frame it is rigid with (0 the base).
    pub frame: usize,
    /// The shape's frame in that link frame.
    pub origin: Matrix4<f64>,
    pub kind: ShapeKind,
    pub rgba: Option<[f64; 4]>,
    pub visual: bool,
    pub collision: bool,
}

/// Every shape of one robot.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ExportGeometry {
    pub shapes: Vec<ExportShape>,
    /// What could not be exported (a mesh file missing, …), one sentence each.
    pub notes: Vec<String>,
}

/// A mesh file the export writes beside the robot's file.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshFile {
    /// The file name, relative to the robot's file (no directory: MuJoCo's URDF reader keeps
    /// only a mesh's file name).
    pub file: String,
    /// Binary STL.
    pub bytes: Vec<u8>,
}

/// Tolerance (relative to the primitive's size) for a polyhedron's vertices to lie on a
/// primitive's surface.
const ON_SURFACE: f64 = 1e-9;

/// Whether `poly` is the primitive: every vertex on its surface within [`ON_SURFACE`] and, for
/// a box, exactly its 8 corners.
fn is_primitive(kind: &ShapeKind, poly: &robosim_geometry::Polyhedron) -> bool {
    let v = &poly.vertices;
    match kind {
        ShapeKind::Box { size } => {
            let h = Vector3::new(size[0], size[1], size[2]) / 2.0;
            let tol = ON_SURFACE * h.max();
            v.len() == 8
                && v.iter()
                    .all(|p| (0..3).all(|i| (p[i].abs() - h[i]).abs() <= tol))
                && {
                    // all 8 sign patterns present
                    let mut seen = [false; 8];
                    for p in v {
                        let k = (0..3).fold(0, |k, i| k | (usize::from(p[i] > 0.0) << i));
                        seen[k] = true;
                    }
                    seen.iter().all(|&s| s)
                }
        }
        ShapeKind::Cylinder { radius, length } => {
            let tol = ON_SURFACE * radius.max(*length);
            !v.is_empty()
                && v.iter().all(|p| {
                    let r = (p.x * p.x + p.y * p.y).sqrt();
                    ((r - radius).abs() <= tol || r <= tol)
                        && (p.z.abs() - length / 2.0).abs() <= tol
                })
        }
        ShapeKind::Sphere { radius } => {
            let tol = ON_SURFACE * radius;
            !v.is_empty() && v.iter().all(|p| (p.coords.norm() - radius).abs() <= tol)
        }
        ShapeKind::Mesh { .. } => false,
    }
}

/// A convex-faced polyhedron as triangles (each polygon fanned from its first vertex).
pub fn polyhedron_triangles(poly: &robosim_geometry::Polyhedron) -> Vec<[[f64; 3]; 3]> {
    let mut out = Vec::new();
    for g in &poly.polygons {
        let idx = &poly.indices[g.start as usize..(g.start + g.len) as usize];
        let p = |i: u32| {
            let v = poly.vertices[i as usize];
            [v.x, v.y, v.z]
        };
        for k in 1..idx.len().saturating_sub(1) {
            out.push([p(idx[0]), p(idx[k]), p(idx[k + 1])]);
        }
    }
    out
}

impl ExportGeometry {
    /// The shapes of a Library Space robot (`RobotModel::frames`: `[0]` the base, `[j]` link
    /// j), each both visual and collision (see the module docs).
    pub fn from_frames(frames: &[Vec<robosim_library::PlacedSolid>]) -> Self {
        use robosim_library::Primitive;
        let mut shapes = Vec::new();
        for (frame, solids) in frames.iter().enumerate() {
            for s in solids {
                let declared = match &s.primitive {
                    Primitive::Box { size } => Some(ShapeKind::Box { size: *size }),
                    Primitive::Cylinder { radius, height, .. } => Some(ShapeKind::Cylinder {
                        radius: *radius,
                        length: *height,
                    }),
                    Primitive::Sphere { radius, .. } => Some(ShapeKind::Sphere { radius: *radius }),
                    _ => None,
                };
                let kind = match declared {
                    Some(k) if is_primitive(&k, &s.polyhedron) => k,
                    _ => ShapeKind::Mesh {
                        triangles: polyhedron_triangles(&s.polyhedron),
                    },
                };
                shapes.push(ExportShape {
                    name: format!("link{frame}_{}", s.name),
                    frame,
                    origin: s.transform,
                    kind,
                    rgba: s.colour.map(|c| [c[0], c[1], c[2], 1.0]),
                    visual: true,
                    collision: true,
                });
            }
        }
        let mut g = ExportGeometry {
            shapes,
            notes: Vec::new(),
        };
        g.unique_names();
        g
    }

    /// The `<visual>` and `<collision>` elements of an imported URDF robot, in its link
    /// frames (each URDF link's shapes placed in the body it is rigid with). Meshes are loaded
    /// now; one that cannot be read is left out with a note.
    pub fn from_urdf(u: &robosim_urdf::urdf_import::UrdfRobot) -> Self {
        use robosim_urdf::urdf_geometry::Geometry;
        let mut g = ExportGeometry::default();
        for (link, lg) in &u.geometry.links {
            for (role, list) in [("visual", &lg.visual), ("collision", &lg.collision)] {
                for (k, s) in list.iter().enumerate() {
                    let kind = match &s.geometry {
                        Geometry::Box { size } => ShapeKind::Box {
                            size: [size.x, size.y, size.z],
                        },
                        Geometry::Cylinder { radius, length } => ShapeKind::Cylinder {
                            radius: *radius,
                            length: *length,
                        },
                        Geometry::Sphere { radius } => ShapeKind::Sphere { radius: *radius },
                        Geometry::Mesh(m) => match m.load() {
                            Ok(t) => ShapeKind::Mesh { triangles: t },
                            Err(e) => {
                                g.notes.push(format!(
                                    "link {link:?}: {role} mesh {:?} not exported: {e}",
                                    m.uri
                                ));
                                continue;
                            }
                        },
                    };
                    g.shapes.push(ExportShape {
                        name: format!("{link}_{role}{k}"),
                        frame: lg.body,
                        origin: lg.in_body * s.origin,
                        kind,
                        rgba: s.material.as_ref().and_then(|m| m.rgba),
                        visual: role == "visual",
                        collision: role == "collision",
                    });
                }
            }
        }
        g.unique_names();
        g
    }

    /// Names made file-safe (`[A-Za-z0-9_-]`) and unique (a suffix `_2`, `_3`, … on repeats).
    pub fn unique_names(&mut self) {
        let mut seen = std::collections::HashSet::new();
        for s in &mut self.shapes {
            let base: String = s
                .name
                .chars()
                .map(|c| {
                    if c.is_ascii_alphanumeric() || c == '_' || c == '-' {
                        c
                    } else {
                        '_'
                    }
                })
                .collect();
            let mut name = base.clone();
            let mut k = 2;
            while !seen.insert(name.clone()) {
                name = format!("{base}_{k}");
                k += 1;
            }
            s.name = name;
        }
    }

    /// The shapes on link frame `frame`.
    pub fn on(&self, frame: usize) -> impl Iterator<Item = &ExportShape> {
        self.shapes.iter().filter(move |s| s.frame == frame)
    }
}

/// Binary STL of triangles (normals from the winding; f32, as the format is).
pub fn stl_bytes(triangles: &[[[f64; 3]; 3]], what: &str) -> Vec<u8> {
    let mut out = Vec::with_capacity(84 + 50 * triangles.len());
    let mut header = format!("robosim export: {what}; metres, shape frame").into_bytes();
    header.resize(80, b' ');
    out.extend_from_slice(&header[..80]);
    out.extend_from_slice(&(triangles.len() as u32).to_le_bytes());
    for [a, b, c] in triangles {
        let n = crate::world::normal(*a, *b, *c);
        for v in [n, *a, *b, *c] {
            for x in v {
                out.extend_from_slice(&(x as f32).to_le_bytes());
            }
        }
        out.extend_from_slice(&0u16.to_le_bytes());
    }
    out
}

/// For each robosim link frame j (0..=n), the constant transform `X_j` that takes a shape's
/// placement in robosim's frame j into the exported link frame j: `E_j⁻¹ · F_j`, with `F_j`
/// robosim's link frame (`fk::link_frames`) and `E_j` the exported one. Both at q = 0 (the
/// difference is constant; q = 0 is the neutral configuration: a floating root at the origin, a
/// ball joint at the identity quaternion).
/// * URDF (`Exported::Urdf`): `E_j = F_j · P_j⁻¹` with `P_j` a DH joint's trailing `Tx(a) Rx(α)`
///   (crate::urdf's module docs), so `X_j = P_j`; link 0 is at the base: `X_0 = I`.
/// * MJCF (`Exported::Mjcf`): the bodies are the general joint model's link frames
///   (`robosim_kinematics::chain::to_general`: a DH frame without its whole trailing part, a
///   standard revolute joint's `Tz(d)` included); the link-0 body is at the world origin (the
///   base placement is in the bodies on it), so `X_0` is the base placement.
pub fn exported_frames(robot: &Robot, format: Exported) -> Vec<Matrix4<f64>> {
    let q: Vec<f64> = robot.neutral_q().iter().copied().collect();
    let f = robosim_kinematics::fk::link_frames(robot, &q);
    let mut out = vec![Matrix4::identity(); robot.dof() + 1];
    match format {
        Exported::Urdf => {
            for (j, joint) in robot.joints.iter().enumerate() {
                if !joint.is_general() {
                    out[j + 1] = post(robot.convention, joint);
                }
            }
        }
        Exported::Mjcf => {
            let g = robosim_kinematics::chain::to_general(robot);
            let e = robosim_kinematics::fk::link_frames(&g, &q);
            out[0] = robot.base;
            for j in 1..=robot.dof() {
                out[j] = rigid_inverse(&e[j]) * f[j];
            }
        }
    }
    out
}

/// The constant transform after the motion, `P_j` (a DH joint's trailing `Tx(a) Rx(α)`, `I` for
/// modified DH): the URDF link frame's offset from robosim's ([`exported_frames`]).
pub(crate) fn post(convention: Convention, j: &Joint) -> Matrix4<f64> {
    match convention {
        Convention::Standard => {
            let mut tx = Matrix4::identity();
            tx[(0, 3)] = j.a;
            let rx = Rotation3::from_axis_angle(&Vector3::x_axis(), j.alpha).to_homogeneous();
            tx * rx
        }
        Convention::Modified => Matrix4::identity(),
    }
}

/// `P⁻¹` of a rigid transform.
pub(crate) fn rigid_inverse(m: &Matrix4<f64>) -> Matrix4<f64> {
    let r: Matrix3<f64> = m.fixed_view::<3, 3>(0, 0).into_owned();
    let t: Vector3<f64> = m.fixed_view::<3, 1>(0, 3).into_owned();
    let mut out = Matrix4::identity();
    out.fixed_view_mut::<3, 3>(0, 0).copy_from(&r.transpose());
    out.fixed_view_mut::<3, 1>(0, 3)
        .copy_from(&(-(r.transpose() * t)));
    out
}

/// Which writer [`exported_frames`] is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Exported {
    Urdf,
    Mjcf,
}

/// The mesh file of `shape` (written once per shape into `meshes`): `<prefix><name>.stl`.
pub(crate) fn mesh_file(
    shape: &ExportShape,
    prefix: &str,
    meshes: &mut Vec<MeshFile>,
) -> Option<String> {
    let ShapeKind::Mesh { triangles } = &shape.kind else {
        return None;
    };
    let file = format!("{prefix}{}.stl", shape.name);
    if !meshes.iter().any(|m| m.file == file) {
        meshes.push(MeshFile {
            file: file.clone(),
            bytes: stl_bytes(triangles, &shape.name),
        });
    }
    Some(file)
}
