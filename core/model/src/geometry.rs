//! [`GeometryModel`]: a robot's solids as descriptions (Pinocchio's `GeometryModel`), and the one
//! function that builds its collision solids from them, [`link_solids`].
//!
//! A [`GeometryObject`] rides on one frame of the robot — 0 the base, j the link frame of
//! joint j (`robosim_kinematics::fk::link_frames`) — at a constant `placement` in that frame,
//! and says what it is ([`Shape`]: a primitive as a primitive, a mesh file by its name and
//! scale, explicit polygons) and what it is for ([`Role`]: drawn or collided). Every reader
//! fills it once: the URDF/MJCF importer ([`crate::Model::from_imported`]), the Library Space
//! (`robosim_library::RobotModel::model`) and the scene compiler (a robot's Instance Space
//! records, `robosim_scene::CompiledRobot::model`). Whoever needs collision solids calls
//! [`link_solids`] (or [`GeometryObject::collision_parts`] for one object); nothing else turns
//! a description into a [`Solid`].
//!
//! Building ([`Shape::collision_parts`]): a box, cylinder (axis z, centred), cone and sphere are
//! the collision crate's exact primitives (with the description's facet count for their
//! faceted form, or the crate's default); a mesh file is loaded now (STL, OBJ, Collada, by
//! `robosim_urdf`'s readers, `package://` names resolved) and split into convex parts
//! (`robosim_collision::decompose`, its hull when that is close to the mesh); polygons are their
//! convex hull when the description says they bound a convex body, else (or when the hull
//! has no volume) a mesh. A frame with one part has that solid at its placement, several make
//! one compound (`LinkSolids::from_parts`).

use nalgebra::{Isometry3, Matrix4, Point3, Vector3};
use robosim_collision::robot::{LinkSolids, isometry_from_matrix};
use robosim_collision::{ShapeError, Solid, SolidKind};
use robosim_urdf::urdf_geometry::MeshRef;
use std::path::PathBuf;

/// What a geometry object is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Role {
    /// Drawn, never collided.
    Visual,
    /// Collided (and drawn where a reader has no visual of its own).
    Collision,
}

/// A mesh file as a description names it; read only when a solid is built.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshFile {
    /// The name as written (`package://…`, relative to `source`'s folder, or absolute).
    pub uri: String,
    /// Per-axis scale.
    pub scale: [f64; 3],
    /// The description file that names the mesh (where relative names and the package search
    /// start).
    pub source: PathBuf,
    /// Where in `source`: the line and the element, for errors.
    pub line: u32,
    pub element: String,
}

impl MeshFile {
    /// The reader's mesh reference (which loads and resolves it).
    pub fn mesh_ref(&self) -> MeshRef {
        MeshRef {
            uri: self.uri.clone(),
            scale: Vector3::from(self.scale),
            urdf: self.source.clone(),
            line: self.line,
            element: self.element.clone(),
        }
    }
}

/// The shape of a geometry object, in the object's own frame.
#[derive(Debug, Clone, PartialEq)]
pub enum Shape {
    /// Full side lengths (m), centred.
    Box {
        size: [f64; 3],
    },
    /// Axis z, centred; `facets` around for the faceted form (`None`: the collision crate's
    /// default).
    Cylinder {
        radius: f64,
        length: f64,
        facets: Option<usize>,
    },
    /// Axis z, base at −height/2, apex at +height/2 (the collision crate's cone).
    Cone {
        radius: f64,
        height: f64,
        facets: Option<usize>,
    },
    Sphere {
        radius: f64,
        facets: Option<usize>,
    },
    /// Polygons over vertices (m): an extrusion, a revolution, an Instance Space record. With
    /// `convex`, the description says they bound a convex body: the solid is their hull (the
    /// polygons as a mesh when the hull has no volume); without, a mesh (a closed non-convex
    /// solid, or an open surface that collides as a surface).
    Polygons {
        vertices: Vec<Point3<f64>>,
        polygons: Vec<Vec<u32>>,
        convex: bool,
    },
    /// A mesh file, loaded when a solid is built.
    Mesh(MeshFile),
}

/// One solid of a robot (Pinocchio's `GeometryObject`).
#[derive(Debug, Clone, PartialEq)]
pub struct GeometryObject {
    /// Unique within the model: `link/part` (`panda_link4/collision0`, `upper_arm/web`).
    pub name: String,
    /// The frame it rides on: 0 the base, j the link frame of joint j.
    pub frame: usize,
    /// The shape's frame in that frame (rigid).
    pub placement: Matrix4<f64>,
    pub shape: Shape,
    pub role: Role,
    /// Red, green, blue, alpha in [0, 1], when the description gives one.
    pub rgba: Option<[f64; 4]>,
}

/// A robot's solids (Pinocchio's `GeometryModel`): visual and collision objects, in the order
/// the reader met them (a frame's compound keeps that order).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct GeometryModel {
    pub objects: Vec<GeometryObject>,
}

impl GeometryModel {
    /// The objects of one role, in order.
    pub fn of(&self, role: Role) -> impl Iterator<Item = &GeometryObject> {
        self.objects.iter().filter(move |o| o.role == role)
    }

    /// The objects on frame `frame`, in order.
    pub fn on(&self, frame: usize) -> impl Iterator<Item = &GeometryObject> {
        self.objects.iter().filter(move |o| o.frame == frame)
    }

    /// Whether the [`Role::Collision`] objects are also what is drawn: the model has no
    /// [`Role::Visual`] object (its reader has no visuals of its own — the Library Space draws
    /// what it collides). A drawing or an export shows the visual objects, or else these.
    pub fn draws_collisions(&self) -> bool {
        self.of(Role::Visual).next().is_none()
    }
}

/// Why a geometry model makes no collision solids: which object, on which frame, and what.
#[derive(Debug, Clone, thiserror::Error)]
pub enum GeometryError {
    /// The shape's dimensions or points make no solid (a non-positive size, a hull without
    /// volume, a mesh's polygons that index no vertex…).
    #[error("geometry object {object:?} (frame {frame}): {source}")]
    Shape {
        object: String,
        frame: usize,
        #[source]
        source: ShapeError,
    },
    /// A mesh file could not be read, or its triangles make no solid; the error names the
    /// description file, line and element that name the mesh.
    #[error("geometry object {object:?} (frame {frame}): {source}")]
    Mesh {
        object: String,
        frame: usize,
        #[source]
        source: Box<robosim_urdf::UrdfError>,
    },
    /// The object rides on a frame the robot does not have.
    #[error("geometry object {object:?} is on frame {frame}, but the robot has frames 0..={last}")]
    Frame {
        object: String,
        frame: usize,
        last: usize,
    },
    /// A frame's parts make no compound (a part that is not convex).
    #[error("the solids of frame {frame} make no compound: {source}")]
    Compound {
        frame: usize,
        #[source]
        source: robosim_collision::robot::CheckError,
    },
}

impl GeometryError {
    /// The mesh reader's error, when a mesh file failed (its file, line, element and problem).
    pub fn mesh(&self) -> Option<&robosim_urdf::UrdfError> {
        match self {
            GeometryError::Mesh { source, .. } => Some(source),
            _ => None,
        }
    }
}

impl GeometryObject {
    /// The object's collision parts in its own frame (its placement not applied): one solid
    /// for a primitive or polygons, a mesh file's convex parts (read now); see the module
    /// docs. For callers that collide objects one by one (a scene's obstacles, the studies'
    /// culled parts); a robot's solids come from [`link_solids`].
    pub fn collision_parts(&self) -> Result<Vec<Solid>, GeometryError> {
        self.shape.collision_parts().map_err(|f| match f {
            Failure::Shape(source) => GeometryError::Shape {
                object: self.name.clone(),
                frame: self.frame,
                source,
            },
            Failure::Mesh(source) => GeometryError::Mesh {
                object: self.name.clone(),
                frame: self.frame,
                source: Box::new(source),
            },
        })
    }
}

/// How a shape fails to build, before the object is named.
enum Failure {
    Shape(ShapeError),
    Mesh(robosim_urdf::UrdfError),
}

impl From<ShapeError> for Failure {
    fn from(e: ShapeError) -> Self {
        Failure::Shape(e)
    }
}

impl Shape {
    /// The shape's convex (or mesh) collision parts in its own frame: one for a primitive or
    /// polygons, a mesh file's convex parts (see the module docs).
    fn collision_parts(&self) -> Result<Vec<Solid>, Failure> {
        Ok(match self {
            Shape::Box { size } => vec![Solid::cuboid(Vector3::from(*size))?],
            Shape::Cylinder {
                radius,
                length,
                facets,
            } => vec![Solid::cylinder(*radius, *length, *facets)?],
            Shape::Cone {
                radius,
                height,
                facets,
            } => vec![Solid::cone(*radius, *height, *facets)?],
            Shape::Sphere { radius, facets } => vec![Solid::sphere(*radius, *facets)?],
            Shape::Polygons {
                vertices,
                polygons,
                convex,
            } => {
                if *convex && let Ok(s) = Solid::convex(vertices) {
                    return Ok(vec![s]);
                }
                vec![Solid::mesh(vertices.clone(), polygons)?]
            }
            Shape::Mesh(m) => {
                let r = m.mesh_ref();
                let shape = |e: ShapeError| {
                    Failure::Mesh(r.err(robosim_urdf::urdf_geometry::MeshProblem::Parts(e)))
                };
                let tris = r.load().map_err(Failure::Mesh)?;
                let d = robosim_collision::decompose::convex_parts(
                    &tris,
                    robosim_collision::decompose::DEFAULT_EXCESS,
                )
                .map_err(shape)?;
                d.parts
                    .iter()
                    .map(|p| Solid::convex(p).map_err(shape))
                    .collect::<Result<_, _>>()?
            }
        })
    }
}

/// The collision solids of `geometry` for a robot with `dof` joints: `links[0]` the base,
/// `links[j]` link j, from the [`Role::Collision`] objects (see the module docs); pairs of
/// links separated only by links without solids are allowed (`LinkSolids::from_parts`). Meshes
/// are loaded now. The one place a robot's collision solids are made from its description.
pub fn link_solids(geometry: &GeometryModel, dof: usize) -> Result<LinkSolids, GeometryError> {
    let mut parts: Vec<Vec<(Isometry3<f64>, Solid)>> = vec![Vec::new(); dof + 1];
    for o in geometry.of(Role::Collision) {
        let Some(frame) = parts.get_mut(o.frame) else {
            return Err(GeometryError::Frame {
                object: o.name.clone(),
                frame: o.frame,
                last: dof,
            });
        };
        let solids = o.collision_parts()?;
        let at = isometry_from_matrix(&o.placement);
        frame.extend(solids.into_iter().map(|s| (at, s)));
    }
    // Where a compound would fail: a frame of several parts, one of them not convex.
    let bad_frame = parts.iter().position(|f| {
        f.len() > 1
            && f.iter()
                .any(|(_, s)| matches!(s.kind, SolidKind::Mesh | SolidKind::Compound))
    });
    LinkSolids::from_parts(parts).map_err(|source| GeometryError::Compound {
        frame: bad_frame.unwrap_or(0),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn object(name: &str, frame: usize, x: f64, shape: Shape) -> GeometryObject {
        GeometryObject {
            name: name.into(),
            frame,
            placement: Matrix4::new_translation(&Vector3::new(x, 0.0, 0.0)),
            shape,
            role: Role::Collision,
            rgba: None,
        }
    }

    /// The unit cube's corners and its six faces (outward).
    fn cube() -> (Vec<Point3<f64>>, Vec<Vec<u32>>) {
        let v = (0..8)
            .map(|i| {
                Point3::new(
                    (i & 1) as f64 - 0.5,
                    ((i >> 1) & 1) as f64 - 0.5,
                    ((i >> 2) & 1) as f64 - 0.5,
                )
            })
            .collect();
        let f = vec![
            vec![0, 2, 3, 1],
            vec![4, 5, 7, 6],
            vec![0, 1, 5, 4],
            vec![2, 6, 7, 3],
            vec![0, 4, 6, 2],
            vec![1, 3, 7, 5],
        ];
        (v, f)
    }

    #[test]
    fn one_part_keeps_its_placement_several_make_a_compound_and_visuals_are_left_out() {
        let mut g = GeometryModel {
            objects: vec![
                object(
                    "base/b",
                    0,
                    0.1,
                    Shape::Box {
                        size: [0.2, 0.2, 0.1],
                    },
                ),
                object(
                    "l2/c",
                    2,
                    0.0,
                    Shape::Cylinder {
                        radius: 0.05,
                        length: 0.3,
                        facets: Some(12),
                    },
                ),
                object(
                    "l2/s",
                    2,
                    0.4,
                    Shape::Sphere {
                        radius: 0.05,
                        facets: None,
                    },
                ),
            ],
        };
        g.objects.push(GeometryObject {
            role: Role::Visual,
            ..object("l1/v", 1, 0.0, Shape::Box { size: [1.0; 3] })
        });
        let ls = link_solids(&g, 2).expect("solids");
        assert_eq!(ls.links.len(), 3);
        let base = ls.links[0].as_ref().expect("base");
        assert_eq!(base.solid.kind, SolidKind::Cuboid);
        assert!((base.offset.translation.vector - Vector3::new(0.1, 0.0, 0.0)).norm() < 1e-15);
        // Link 1 has only a visual: no collision solid; links 0 and 2 meet through it.
        assert!(ls.links[1].is_none());
        assert_eq!(ls.allowed, vec![(0, 2)]);
        let l2 = ls.links[2].as_ref().expect("link 2");
        assert_eq!(l2.solid.kind, SolidKind::Compound);
        // The compound holds the sphere at x = 0.4: its box reaches x = 0.45.
        assert!(
            (l2.solid.bbox.maxs().x - 0.45).abs() < 1e-9,
            "{:?}",
            l2.solid.bbox
        );
    }

    fn base_kind(shape: Shape) -> SolidKind {
        let g = GeometryModel {
            objects: vec![object("p", 0, 0.0, shape)],
        };
        link_solids(&g, 0).expect("solid").links[0]
            .as_ref()
            .expect("base")
            .solid
            .kind
    }

    #[test]
    fn collisions_are_drawn_only_when_the_model_has_no_visual() {
        let mut g = GeometryModel {
            objects: vec![object("l1/c", 1, 0.0, Shape::Box { size: [0.1; 3] })],
        };
        assert!(g.draws_collisions());
        g.objects.push(GeometryObject {
            role: Role::Visual,
            ..object("l2/v", 2, 0.0, Shape::Box { size: [0.1; 3] })
        });
        assert!(!g.draws_collisions());
    }

    #[test]
    fn polygons_are_a_hull_when_convex_and_a_mesh_otherwise() {
        let (v, f) = cube();
        let polygons = |f: &[Vec<u32>], convex| Shape::Polygons {
            vertices: v.clone(),
            polygons: f.to_vec(),
            convex,
        };
        assert_eq!(base_kind(polygons(&f, true)), SolidKind::Convex);
        // The cube without its top face: as polygons, an open surface (a mesh); said to be
        // convex, its hull (the closed cube).
        let open = &f[..5];
        assert_eq!(base_kind(polygons(open, false)), SolidKind::Mesh);
        assert_eq!(base_kind(polygons(open, true)), SolidKind::Convex);
        // A flat square said to be convex: no hull (no volume), so the polygons as a surface.
        let plate = Shape::Polygons {
            vertices: v[..4].to_vec(),
            polygons: vec![vec![0, 1, 3, 2]],
            convex: true,
        };
        assert_eq!(base_kind(plate), SolidKind::Mesh);
    }

    #[test]
    fn errors_name_the_object_and_its_frame() {
        let g = GeometryModel {
            objects: vec![object(
                "arm/bad",
                1,
                0.0,
                Shape::Box {
                    size: [0.1, -1.0, 0.1],
                },
            )],
        };
        match link_solids(&g, 1) {
            Err(GeometryError::Shape { object, frame, .. }) => {
                assert_eq!((object.as_str(), frame), ("arm/bad", 1));
            }
            other => panic!("{other:?}"),
        }
        let g = GeometryModel {
            objects: vec![object("tool/x", 3, 0.0, Shape::Box { size: [0.1; 3] })],
        };
        let e = link_solids(&g, 2).expect_err("no frame 3");
        assert!(
            matches!(
                e,
                GeometryError::Frame {
                    frame: 3,
                    last: 2,
                    ..
                }
            ),
            "{e}"
        );
        // A surface (a mesh) cannot join a compound: the error says which frame.
        let (v, f) = cube();
        let g = GeometryModel {
            objects: vec![
                object("l1/a", 1, 0.0, Shape::Box { size: [0.1; 3] }),
                object(
                    "l1/m",
                    1,
                    1.0,
                    Shape::Polygons {
                        vertices: v,
                        polygons: f[..5].to_vec(),
                        convex: false,
                    },
                ),
            ],
        };
        let e = link_solids(&g, 1).expect_err("mesh in a compound");
        assert!(matches!(e, GeometryError::Compound { frame: 1, .. }), "{e}");
    }

    #[test]
    fn a_missing_mesh_file_is_named_with_the_description_that_names_it() {
        let g = GeometryModel {
            objects: vec![object(
                "l1/collision0",
                1,
                0.0,
                Shape::Mesh(MeshFile {
                    uri: "meshes/none.stl".into(),
                    scale: [1.0; 3],
                    source: std::env::temp_dir().join("robosim-model-test-nowhere/r.urdf"),
                    line: 7,
                    element: "<mesh>".into(),
                }),
            )],
        };
        let e = link_solids(&g, 1).expect_err("no such file");
        let m = e.mesh().expect("a mesh error");
        assert_eq!(m.line, 7);
        assert!(
            matches!(
                &m.kind,
                robosim_urdf::UrdfErrorKind::Mesh(robosim_urdf::urdf_geometry::MeshProblem::NotFound(p))
                    if p.ends_with("meshes/none.stl")
            ),
            "{e}"
        );
        assert!(e.to_string().contains("l1/collision0"), "{e}");
    }
}
