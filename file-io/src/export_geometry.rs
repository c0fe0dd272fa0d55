//! A robot's geometry as the URDF and MJCF exports write it (issue 36 item 4, issue 35 item 2):
//! the robot model's [`GeometryModel`] (`robosim_model`, the solids the simulator collides),
//! each object seen as the file writes it ([`ExportShapes::of`]): a name for the file, whether
//! it is drawn (`<visual>`, MJCF class `visual`) and collided (`<collision>`, class
//! `collision`), and its shape as a primitive of the format or a triangle mesh.
//!
//! * Drawn: a [`Role::Visual`] object; a [`Role::Collision`] object too when the model has no
//!   visual object at all ([`GeometryModel::draws_collisions`]: the Library Space's robots,
//!   which draw what they collide). Collided: a [`Role::Collision`] object.
//! * Shape: a box, cylinder (axis z) and sphere are the format's exact primitives (robosim's
//!   faceted forms are within their tessellation error of them, docs/file-io.md); a cone is
//!   the geometry library's faceted cone at the object's facet count, polygons are fanned into
//!   triangles, and a mesh file is read now (STL, OBJ, Collada): each written as a binary STL
//!   beside the file. A mesh file that cannot be read is left out with a note.
//! * Names: the object's name made file-safe (`[A-Za-z0-9_-]`) and unique (a suffix `_2`,
//!   `_3`, … on repeats): an import's `link/visualK` is `link_visualK`; the Library Space names
//!   parts per link, so its objects come here as `link<j>_<part>` (`crate::library_geometry`).
//!
//! Frames: an object's `placement` is in **robosim's** link frame `frame` (0 the base, j the
//! link after joint j, as `robosim_kinematics::fk::link_frames` gives them). The writers move
//! it into their own link frames ([`exported_frames`]).

use nalgebra::{Matrix3, Matrix4, Rotation3, Vector3};
use robosim_kinematics::{Convention, Joint, Robot};
use robosim_model::{GeometryModel, GeometryObject, Role, Shape};

/// What a shape is written as.
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

/// One object of the robot's geometry model as the file writes it.
#[derive(Debug, Clone, PartialEq)]
pub struct ExportShape<'a> {
    /// Its name in the file (file-safe, unique within the robot).
    pub name: String,
    /// The model's object (its frame, placement and colour are written as they are).
    pub object: &'a GeometryObject,
    pub kind: ShapeKind,
    /// Written as a `<visual>` (MJCF: a geom of class `visual`).
    pub visual: bool,
    /// Written as a `<collision>` (MJCF: a geom of class `collision`).
    pub collision: bool,
}

/// Every object of a robot's geometry model as the file writes it (see the module docs).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ExportShapes<'a> {
    pub shapes: Vec<ExportShape<'a>>,
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

/// A convex-faced polyhedron as triangles (each polygon fanned from its first vertex).
pub fn polyhedron_triangles(poly: &robosim_geometry::Polyhedron) -> Vec<[[f64; 3]; 3]> {
    let polygons: Vec<&[u32]> = (0..poly.polygons.len())
        .map(|i| poly.polygon_indices(i))
        .collect();
    fan(&poly.vertices, &polygons)
}

/// Polygons over `vertices` as triangles, each fanned from its first vertex.
fn fan(vertices: &[nalgebra::Point3<f64>], polygons: &[&[u32]]) -> Vec<[[f64; 3]; 3]> {
    let mut out = Vec::new();
    for idx in polygons {
        let p = |i: u32| {
            let v = vertices[i as usize];
            [v.x, v.y, v.z]
        };
        for k in 1..idx.len().saturating_sub(1) {
            out.push([p(idx[0]), p(idx[k]), p(idx[k + 1])]);
        }
    }
    out
}

/// The link an object's name says (`link/part`: the part before the last `/`).
fn link_of(object: &GeometryObject) -> &str {
    object
        .name
        .rsplit_once('/')
        .map_or(object.name.as_str(), |(link, _)| link)
}

/// How the file writes `object`'s shape; `Err` a note when it cannot (a mesh file not read).
fn kind_of(object: &GeometryObject) -> Result<ShapeKind, String> {
    let faceted = |p: Result<robosim_geometry::Polyhedron, _>| match p {
        Ok(p) => Ok(ShapeKind::Mesh {
            triangles: polyhedron_triangles(&p),
        }),
        Err(e) => Err(format!("{:?}: not exported: {e}", object.name)),
    };
    Ok(match &object.shape {
        Shape::Box { size } => ShapeKind::Box { size: *size },
        Shape::Cylinder { radius, length, .. } => ShapeKind::Cylinder {
            radius: *radius,
            length: *length,
        },
        Shape::Sphere { radius, .. } => ShapeKind::Sphere { radius: *radius },
        Shape::Cone {
            radius,
            height,
            facets,
        } => faceted(robosim_geometry::shapes::cone(*radius, *height, *facets))?,
        Shape::Polygons {
            vertices, polygons, ..
        } => {
            let polygons: Vec<&[u32]> = polygons.iter().map(Vec::as_slice).collect();
            ShapeKind::Mesh {
                triangles: fan(vertices, &polygons),
            }
        }
        Shape::Mesh(m) => match m.mesh_ref().load() {
            Ok(triangles) => ShapeKind::Mesh { triangles },
            Err(e) => {
                let role = match object.role {
                    Role::Visual => "visual",
                    Role::Collision => "collision",
                };
                return Err(format!(
                    "link {:?}: {role} mesh {:?} not exported: {e}",
                    link_of(object),
                    m.uri
                ));
            }
        },
    })
}

impl<'a> ExportShapes<'a> {
    /// The objects of `geometry` as the file writes them, in the model's order (see the module
    /// docs); mesh files are read now.
    pub fn of(geometry: &'a GeometryModel) -> Self {
        let draws_collisions = geometry.draws_collisions();
        let mut out = ExportShapes::default();
        for object in &geometry.objects {
            match kind_of(object) {
                Ok(kind) => out.shapes.push(ExportShape {
                    name: object.name.clone(),
                    object,
                    kind,
                    visual: object.role == Role::Visual || draws_collisions,
                    collision: object.role == Role::Collision,
                }),
                Err(note) => out.notes.push(note),
            }
        }
        out.unique_names();
        out
    }

    /// Names made file-safe (`[A-Za-z0-9_-]`) and unique (a suffix `_2`, `_3`, … on repeats).
    fn unique_names(&mut self) {
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

    /// The shapes on link frame `frame`, in the order the file writes them: the model's, but
    /// each link's drawn-only shapes before its collided ones (as URDF files list `<visual>`
    /// before `<collision>`; the model lists an import's collisions first).
    pub fn on(&self, frame: usize) -> impl Iterator<Item = &ExportShape<'a>> {
        let here: Vec<&ExportShape<'a>> = self
            .shapes
            .iter()
            .filter(|s| s.object.frame == frame)
            .collect();
        let mut ordered = Vec::with_capacity(here.len());
        let mut i = 0;
        while i < here.len() {
            let link = link_of(here[i].object);
            let run = here[i..]
                .iter()
                .take_while(|s| link_of(s.object) == link)
                .count();
            let group = &here[i..i + run];
            ordered.extend(group.iter().filter(|s| !s.collision));
            ordered.extend(group.iter().filter(|s| s.collision));
            i += run;
        }
        ordered.into_iter()
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
    shape: &ExportShape<'_>,
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
