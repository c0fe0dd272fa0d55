//! `robot NAME from_urdf "FILE" { tip: …, base: … }`: a robot read from a URDF file with the
//! `robosim-urdf` reader. The chain from the root link to `tip` (`import_urdf`), or without
//! `tip` the whole tree (`import_urdf_tree`), in the one joint model (general joints: origin
//! and axis); link names are the URDF child links of the movable joints; each body's solids
//! are its links' `<collision>` shapes (box, cylinder and sphere through the geometry crate's
//! generators, a mesh as its convex hull), coloured by the link's first `<visual>` colour.
//!
//! `robot NAME from_mjcf "FILE" { … }` is the same with MuJoCo's MJCF (`import_mjcf`,
//! `import_mjcf_tree`): `tip` names a `<body>`, link names are the bodies of the joints, the
//! solids are the geoms that collide (the reader's geometry, as for a URDF).

use super::robots::validated;
use super::*;
use crate::ast::{RobotFileFormat, UrdfSource};
use robosim_urdf::urdf_geometry::{Geometry, LinkGeometry, MeshProblem, Shape, hull_points};
use robosim_urdf::urdf_import::{UrdfError, UrdfErrorKind, UrdfRobot};
use robosim_urdf::{MjcfError, MjcfErrorKind};

const PROPS: &[&str] = &[
    "tip", "base", "tool", "gravity", "colour", "surface", "facets",
];

impl Evaluator<'_> {
    pub(super) fn urdf_robot(
        &mut self,
        decl: &Decl,
        src: &UrdfSource,
        scope: &mut Scope,
    ) -> RResult<RobotModel> {
        let mut seen = Seen::default();
        let mut tip: Option<(String, Span)> = None;
        let (mut base, mut tool, mut gravity) = (None, None, None);
        let (mut colour, mut surface) = (None, None);
        for st in &decl.body {
            match st {
                Stmt::Let {
                    name,
                    name_span,
                    value,
                } => self.let_(name, *name_span, value, scope)?,
                Stmt::Prop {
                    name,
                    name_span,
                    value,
                } => {
                    seen.check(name, *name_span)?;
                    match name.as_str() {
                        "tip" => match self.eval(value, scope)? {
                            Value::Str(s) if !s.is_empty() => tip = Some((s, value.span)),
                            other => {
                                return Err(err(
                                    ErrorKind::Type,
                                    value.span,
                                    format!(
                                        "`tip` must name a URDF link, but this is {}",
                                        other.describe()
                                    ),
                                )
                                .expected(
                                    "the tip link's name in quotes, e.g. tip: \"panda_link8\"",
                                ));
                            }
                        },
                        "base" => base = Some(self.transform(value, scope)?),
                        "tool" => tool = Some(self.transform(value, scope)?),
                        "gravity" => {
                            let g =
                                self.vector(value, scope, Dim::ACCEL, 3, "[gx, gy, gz] in m/s^2")?;
                            gravity = Some(Vector3::new(g[0], g[1], g[2]));
                        }
                        "colour" | "color" => colour = Some(self.colour(value, scope)?),
                        "surface" => surface = Some(self.surface_ref(value, scope)?),
                        "facets" => {}
                        _ => {
                            let what = format!("{} robot", src.format.keyword());
                            return Err(unknown_prop(&what, name, *name_span, PROPS));
                        }
                    }
                }
                other => {
                    return Err(misplaced(
                        other,
                        match src.format {
                            RobotFileFormat::Urdf => {
                                "a `from_urdf` robot (its links and solids come from the URDF file)"
                            }
                            RobotFileFormat::Mjcf => {
                                "a `from_mjcf` robot (its bodies and solids come from the MJCF file)"
                            }
                        },
                        "`let` or a property (tip, base, tool, gravity, colour, surface, facets)",
                    ));
                }
            }
        }
        let path = src.resolved.as_ref().map_err(|why| {
            err(
                ErrorKind::Include,
                src.span,
                format!(
                    "robot `{}`: cannot resolve the {} file: {why}",
                    decl.name,
                    src.format.name()
                ),
            )
            .expected("an absolute path, or a robot declared in your own .rsl file (relative names are read from its folder)")
        })?;
        let u = import(path, src, tip.as_ref().map(|(t, _)| t.as_str()))
            .map_err(|(e, at_tip)| import_error(decl, src, tip.as_ref().filter(|_| at_tip), &e))?;
        let mut robot = u.robot.clone();
        robot.name = decl.name.clone();
        if let Some(b) = base {
            robot.base = b * robot.base;
        }
        if let Some(t) = tool {
            robot.tool *= t;
        }
        if let Some(g) = gravity {
            robot.gravity = g;
        }
        let link_names: Vec<String> = u.joints.iter().map(|j| j.link.clone()).collect();
        let mut frames: Vec<Vec<PlacedSolid>> = vec![Vec::new(); robot.dof() + 1];
        for (link, g) in &u.geometry.links {
            let shade = link_colour(g);
            for (k, s) in g.collision.iter().enumerate() {
                let mut p = self
                    .urdf_solid(s, &u, link, k)
                    .map_err(|e| urdf_error(decl, src, tip.as_ref(), &e))?;
                p.transform = g.in_body * s.origin * p.transform;
                p.colour = shade;
                self.count_polygons(
                    p.polyhedron.polygons.len(),
                    src.span,
                    "fewer facets (`facets:`) or coarser meshes",
                )?;
                if let Some(f) = frames.get_mut(g.body) {
                    f.push(p);
                }
            }
        }
        for f in &mut frames {
            fill_appearance(f, colour, surface.as_ref());
        }
        validated(decl, &robot)?;
        let ik = if robot.parents.is_empty() {
            match robosim_kinematics::ik::family::recognise(&robot) {
                robosim_kinematics::ik::family::Family::General(_) => None,
                f => Some(f.name().to_string()),
            }
        } else {
            None
        };
        // the file's <mimic> relations (checked by the importer: its coupling is built from them)
        let mimics = (u.mimics.iter())
            .map(|m| MimicJoint {
                follower: m.index,
                leader: m.mimicked_index,
                multiplier: m.multiplier,
                offset: m.offset,
            })
            .collect();
        Ok(RobotModel {
            robot,
            link_names,
            frames,
            ik,
            mimics,
        })
    }

    /// One `<collision>` shape as a placed solid in the shape's own frame (`transform`: the
    /// polyhedron's frame, centred on its bounding box, in the geometry frame).
    fn urdf_solid(
        &self,
        s: &Shape,
        u: &UrdfRobot,
        link: &str,
        k: usize,
    ) -> Result<PlacedSolid, UrdfError> {
        let g = &s.geometry;
        let name = format!("{link}/collision{k}");
        let facets = |r: f64| {
            self.opts
                .facets
                .or(self.facets.last().copied().flatten())
                .unwrap_or_else(|| shapes::default_facets(r, shapes::DEFAULT_CHORD_TOL))
        };
        let placed = |primitive, polyhedron, transform| PlacedSolid {
            name: name.clone(),
            primitive,
            polyhedron,
            transform,
            colour: None,
            surface: None,
        };
        let at = |problem: MeshProblem| UrdfError {
            file: u.geometry.file.clone(),
            line: s.line,
            element: format!("<link name={link:?}>/<collision>"),
            kind: UrdfErrorKind::Mesh(problem),
        };
        // A primitive the geometry refuses: its error kept, the element named.
        let solid_err = |e: shapes::ShapeError| at(MeshProblem::Solid(e));
        Ok(match g {
            Geometry::Box { size } => placed(
                Primitive::Box {
                    size: [size.x, size.y, size.z],
                },
                shapes::cuboid(size.x, size.y, size.z).map_err(solid_err)?,
                Matrix4::identity(),
            ),
            Geometry::Cylinder { radius, length } => {
                let n = facets(*radius);
                placed(
                    Primitive::Cylinder {
                        radius: *radius,
                        height: *length,
                        facets: n,
                    },
                    shapes::cylinder(*radius, *length, Some(n)).map_err(solid_err)?,
                    Matrix4::identity(),
                )
            }
            Geometry::Sphere { radius } => {
                let n = facets(*radius).max(4);
                placed(
                    Primitive::Sphere {
                        radius: *radius,
                        facets: n,
                    },
                    shapes::sphere(*radius, Some(n)).map_err(solid_err)?,
                    Matrix4::identity(),
                )
            }
            Geometry::Mesh(m) => {
                // parry's hull as triangles (as `robosim import mesh --hull` makes it): every
                // hull vertex on or behind every face, so the Instance Space's convexity test
                // takes it for the convex solid it is
                let pts = hull_points(&m.load()?);
                if pts.len() < 4 {
                    return Err(m.err(MeshProblem::Shape(format!(
                        "{} distinct points span no volume",
                        pts.len()
                    ))));
                }
                let (verts, tris) =
                    parry3d_f64::transformation::try_convex_hull(&pts).map_err(|e| {
                        m.err(MeshProblem::Shape(format!(
                            "its convex hull cannot be built: {e:?}"
                        )))
                    })?;
                let faces: Vec<Vec<u32>> = tris.iter().map(|t| t.to_vec()).collect();
                let hull = Polyhedron::from_polygons(verts, &faces)
                    .map_err(|e| m.err(MeshProblem::Hull(e)))?;
                // centred on its bounding box, as every PlacedSolid's polyhedron is
                let c = hull.bbox.center.coords;
                let poly = hull.transformed(&Isometry3::translation(-c.x, -c.y, -c.z));
                let h = hull.bbox.half;
                placed(
                    Primitive::Box {
                        size: [2.0 * h.x, 2.0 * h.y, 2.0 * h.z],
                    },
                    poly,
                    Matrix4::new_translation(&c),
                )
            }
        })
    }
}

/// The link's colour: its first `<visual>` with an RGBA material (alpha dropped).
fn link_colour(g: &LinkGeometry) -> Option<Rgb> {
    g.visual
        .iter()
        .find_map(|v| v.material.as_ref().and_then(|m| m.rgba))
        .map(|c| [c[0], c[1], c[2]])
}

/// The robot file read by its format's reader: the chain to `tip`, or the whole tree. The error
/// says whether the tip is what is wrong (`true`: it names no link or body of the file).
fn import(
    path: &std::path::Path,
    src: &UrdfSource,
    tip: Option<&str>,
) -> Result<UrdfRobot, (String, bool)> {
    let urdf = |r: Result<UrdfRobot, UrdfError>| {
        r.map_err(|e| {
            let at_tip = matches!(e.kind, UrdfErrorKind::TipNotALink(_));
            (e.to_string(), at_tip)
        })
    };
    let mjcf = |r: Result<UrdfRobot, MjcfError>| {
        r.map_err(|e| {
            let at_tip = matches!(e.kind, MjcfErrorKind::TipNotABody(_));
            (e.to_string(), at_tip)
        })
    };
    match (src.format, tip) {
        (RobotFileFormat::Urdf, Some(t)) => urdf(robosim_urdf::import_urdf(path, Some(t))),
        (RobotFileFormat::Urdf, None) => urdf(robosim_urdf::import_urdf_tree(path)),
        (RobotFileFormat::Mjcf, Some(t)) => mjcf(robosim_urdf::import_mjcf(path, Some(t))),
        (RobotFileFormat::Mjcf, None) => mjcf(robosim_urdf::import_mjcf_tree(path)),
    }
}

/// An import problem as a library error: located at the file name after `from_urdf` or
/// `from_mjcf` (at `tip:` when the tip is what is wrong), the reader's own file:line: element:
/// message inside.
fn import_error(decl: &Decl, src: &UrdfSource, tip: Option<&(String, Span)>, e: &str) -> RawError {
    let span = tip.map_or(src.span, |(_, s)| *s);
    err(
        ErrorKind::Include,
        span,
        format!(
            "robot `{}`: cannot import {} `{}`: {e}",
            decl.name,
            src.format.name(),
            src.path
        ),
    )
    .expected(match src.format {
        RobotFileFormat::Urdf => "a readable URDF file (relative names from the folder of this .rsl file) and, for `tip:`, one of its links",
        RobotFileFormat::Mjcf => "a readable MJCF file (relative names from the folder of this .rsl file) and, for `tip:`, one of its bodies",
    })
}

/// A URDF problem as a library error: located at the `from_urdf` file name (at `tip:` when the
/// tip is what is wrong), the URDF's own file:line: element: message inside.
fn urdf_error(
    decl: &Decl,
    src: &UrdfSource,
    tip: Option<&(String, Span)>,
    e: &UrdfError,
) -> RawError {
    let span = match (&e.kind, tip) {
        (UrdfErrorKind::TipNotALink(_), Some((_, s))) => *s,
        _ => src.span,
    };
    err(
        ErrorKind::Include,
        span,
        format!(
            "robot `{}`: cannot import {} `{}`: {e}",
            decl.name,
            src.format.name(),
            src.path
        ),
    )
    .expected("a readable robot file (relative names from the folder of this .rsl file) and, for `tip:`, one of its links")
}
