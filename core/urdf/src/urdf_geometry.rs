//! URDF geometry (issue #14): each link's `<visual>` and `<collision>` elements — `<origin>`,
//! `<geometry>` (`<box size>`, `<cylinder radius length>`, `<sphere radius>`, `<mesh filename
//! scale>`), and for visuals `<material>` (an inline `<color rgba>` / `<texture filename>`, or a
//! reference by name to a robot-level `<material>`) — read at import into
//! [`crate::urdf_import::ImportedRobot::geometry`], keyed by link name.
//!
//! Meshes are **loaded lazily**: the import records the file name, scale and where it was
//! written; [`MeshRef::load`] resolves it ([`crate::package`]) and reads it only when an
//! operation needs geometry (collision, drawing). A URDF whose meshes are missing still imports,
//! and its FK and dynamics work. STL (binary and ASCII), OBJ and Collada (`.dae`, read by
//! [`crate::dae`]: its `<unit meter>` and `<up_axis>` honoured, so its triangles come out in
//! metres, Z up, before the URDF `scale`) are read; any other extension is
//! [`MeshProblem::UnsupportedFormat`]. The Panda's visual meshes are DAE, its collision meshes
//! STL.
//!
//! Placement: each URDF link is rigid with one robosim body — the root link with body 0, the
//! child link of the chain's movable joint j with body j; a link behind a fixed joint, or off
//! the chain (held at q = 0), is lumped into the body it hangs from. [`LinkGeometry::in_body`]
//! is the URDF link frame in that body's frame (robosim's link frame j is the URDF child link
//! frame of movable joint j, so it is the identity on the chain's movable links).
//!
//! Collision: `robosim_model::Model::from_imported` turns each `<collision>` into a geometry
//! object on its body (placed at [`LinkGeometry::in_body`] times the shape's origin), and
//! `robosim_model::geometry::link_solids` builds the solids — box, cylinder (axis z, centred,
//! as URDF says) and sphere as they are, a mesh as convex parts of its scaled triangles
//! (`robosim_collision::decompose`: the hull when it is close to the mesh) — as the
//! `LinkSolids` every robot is checked with (`robosim_collision::robot::check_robot`).

use crate::dae::{ColouredTriangles, read_dae};
use crate::package::resolve;
use crate::stl::Triangles;
pub use crate::urdf_xml::MeshProblem;

use crate::urdf_xml::{Reader, UrdfError, UrdfErrorKind, child};
use nalgebra::{Matrix4, Point3, Vector3};
use std::collections::{BTreeMap, HashMap};
use std::path::PathBuf;

/// A material: a name, an RGBA colour in [0, 1], a texture file name (not loaded).
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    pub name: Option<String>,
    pub rgba: Option<[f64; 4]>,
    pub texture: Option<String>,
}

/// A mesh as the URDF names it, with what is needed to load it later.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshRef {
    /// The `filename` attribute as written.
    pub uri: String,
    /// Per-axis scale (absent = 1 1 1).
    pub scale: Vector3<f64>,
    /// The URDF file (relative paths and package search start at its directory).
    pub urdf: PathBuf,
    pub line: u32,
    pub element: String,
}

/// One `<geometry>`.
#[derive(Debug, Clone, PartialEq)]
pub enum Geometry {
    /// Full side lengths (m), centred.
    Box {
        size: Vector3<f64>,
    },
    /// Axis z, centred.
    Cylinder {
        radius: f64,
        length: f64,
    },
    Sphere {
        radius: f64,
    },
    Mesh(MeshRef),
}

/// One `<visual>` or `<collision>`.
#[derive(Debug, Clone, PartialEq)]
pub struct Shape {
    pub name: Option<String>,
    /// The geometry's frame in the URDF link's frame.
    pub origin: Matrix4<f64>,
    pub geometry: Geometry,
    /// Visuals only: the material, references resolved (a name the robot does not define stays
    /// a name without colour, as urdfdom leaves it).
    pub material: Option<Material>,
    pub line: u32,
}

/// The geometry of an imported URDF: the file it came from and each link's shapes.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct UrdfGeometry {
    pub file: PathBuf,
    /// Keyed by link name; every `<link>` of the file has an entry.
    pub links: BTreeMap<String, LinkGeometry>,
}

impl UrdfGeometry {
    /// How many `<visual>` and `<collision>` elements, and how many of them are meshes.
    pub fn counts(&self) -> (usize, usize, usize) {
        let (mut v, mut c, mut m) = (0, 0, 0);
        for g in self.links.values() {
            v += g.visual.len();
            c += g.collision.len();
            m += g
                .visual
                .iter()
                .chain(&g.collision)
                .filter(|s| matches!(s.geometry, Geometry::Mesh(_)))
                .count();
        }
        (v, c, m)
    }
}

/// The geometry of one URDF link.
#[derive(Debug, Clone, PartialEq)]
pub struct LinkGeometry {
    /// The robosim body it is rigid with: 0 the base (root link), j the link of movable joint j.
    pub body: usize,
    /// The URDF link frame in the body's frame.
    pub in_body: Matrix4<f64>,
    pub visual: Vec<Shape>,
    pub collision: Vec<Shape>,
}

impl MeshRef {
    pub fn err(&self, p: MeshProblem) -> UrdfError {
        UrdfError {
            file: self.urdf.clone(),
            line: self.line,
            element: self.element.clone(),
            kind: UrdfErrorKind::Mesh(p),
        }
    }

    /// The file this mesh names, resolved with the process's `ROS_PACKAGE_PATH`.
    pub fn path(&self) -> Result<PathBuf, UrdfError> {
        let rpp = std::env::var_os("ROS_PACKAGE_PATH");
        resolve(&self.uri, &self.urdf, rpp.as_deref()).map_err(|e| self.err(e.into()))
    }

    /// The mesh's triangles in the geometry frame, scaled (m).
    pub fn load(&self) -> Result<Triangles, UrdfError> {
        Ok(self
            .load_coloured()?
            .into_iter()
            .flat_map(|p| p.triangles)
            .collect())
    }

    /// The mesh's triangles in the geometry frame, scaled (m), grouped by colour: a Collada
    /// file's parts carry the diffuse colour of their material; STL and OBJ are one part
    /// without colour.
    pub fn load_coloured(&self) -> Result<Vec<ColouredTriangles>, UrdfError> {
        let path = self.path()?;
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        if !matches!(ext.as_str(), "stl" | "obj" | "dae") {
            return Err(self.err(MeshProblem::UnsupportedFormat { path, format: ext }));
        }
        let bytes = robosim_input::read_file(&path, "a mesh file", robosim_input::Limit::MESH)
            .map_err(|e| match &e.problem {
                robosim_input::InputProblem::Io(io)
                    if io.kind() == std::io::ErrorKind::NotFound =>
                {
                    self.err(MeshProblem::NotFound(path.clone()))
                }
                _ => self.err(MeshProblem::Read(e.to_string())),
            })?;
        let mut parts = match ext.as_str() {
            "dae" => {
                read_dae(&bytes, &path).map_err(|e| self.err(MeshProblem::Dae(Box::new(e))))?
            }
            "stl" => vec![ColouredTriangles {
                triangles: crate::stl::read_stl(&bytes, &path)
                    .map_err(|e| self.err(MeshProblem::File(e)))?,
                rgba: None,
            }],
            _ => vec![ColouredTriangles {
                triangles: crate::obj::read_obj(&bytes, &path)
                    .map_err(|e| self.err(MeshProblem::File(e)))?,
                rgba: None,
            }],
        };
        parts.retain(|p| !p.triangles.is_empty());
        if parts.is_empty() {
            return Err(self.err(MeshProblem::Empty(path)));
        }
        // Scaled, every coordinate must be finite: a NaN or an infinity in the file (or one
        // that the `scale` attribute overflows) would reach the display and the collision
        // solids as a silent wrong shape.
        for (i, t) in parts
            .iter_mut()
            .flat_map(|p| p.triangles.iter_mut())
            .enumerate()
        {
            for (j, v) in t.iter_mut().enumerate() {
                for (c, s) in v.iter_mut().zip(self.scale.iter()) {
                    *c *= s;
                }
                if let Some(bad) = v.iter().find(|c| !c.is_finite()) {
                    return Err(self.err(MeshProblem::Read(format!(
                        "{}: triangle {i}, vertex {j}: coordinate {bad} is not a finite number{}",
                        path.display(),
                        if self.scale == Vector3::new(1.0, 1.0, 1.0) {
                            String::new()
                        } else {
                            let k = self.scale;
                            format!(" (after the scale {} {} {})", k.x, k.y, k.z)
                        }
                    ))));
                }
            }
        }
        Ok(parts)
    }
}

/// Reads every link's `<visual>` and `<collision>` (placement not yet known: body 0, identity;
/// [`place`] sets it). Called once by the importer.
pub fn read_all(rd: &Reader, robot: roxmltree::Node) -> Result<UrdfGeometry, UrdfError> {
    let mut named: HashMap<String, Material> = HashMap::new();
    for m in robot
        .children()
        .filter(|n| n.is_element() && n.tag_name().name() == "material")
    {
        let name = rd.attr(m, "<material>", "name")?;
        let el = format!("<material name={name:?}>");
        named.insert(name.to_string(), material(rd, m, &el, &HashMap::new())?);
    }
    let mut out = BTreeMap::new();
    for link in robot
        .children()
        .filter(|n| n.is_element() && n.tag_name().name() == "link")
    {
        let name = rd.attr(link, "<link>", "name")?;
        let lel = format!("<link name={name:?}>");
        let mut g = LinkGeometry {
            body: 0,
            in_body: Matrix4::identity(),
            visual: Vec::new(),
            collision: Vec::new(),
        };
        for (k, node) in link.children().filter(|n| n.is_element()).enumerate() {
            let tag = node.tag_name().name();
            if !matches!(tag, "visual" | "collision") {
                continue;
            }
            let el = match node.attribute("name") {
                Some(n) => format!("{lel}/<{tag} name={n:?}>"),
                None => format!("{lel}/<{tag}>[{k}]"),
            };
            let origin = rd.origin(node, &el)?;
            let gnode = child(node, "geometry")
                .ok_or_else(|| rd.err(node, &el, UrdfErrorKind::MissingElement("geometry")))?;
            let geometry = geometry(rd, gnode, &format!("{el}/<geometry>"))?;
            let material = match (tag, child(node, "material")) {
                ("visual", Some(m)) => Some(material(rd, m, &format!("{el}/<material>"), &named)?),
                _ => None,
            };
            let shape = Shape {
                name: node.attribute("name").map(str::to_string),
                origin,
                geometry,
                material,
                line: rd.line(node),
            };
            if tag == "visual" {
                g.visual.push(shape);
            } else {
                g.collision.push(shape);
            }
        }
        out.insert(name.to_string(), g);
    }
    Ok(UrdfGeometry {
        file: rd.file.to_path_buf(),
        links: out,
    })
}

fn material(
    rd: &Reader,
    m: roxmltree::Node,
    el: &str,
    named: &HashMap<String, Material>,
) -> Result<Material, UrdfError> {
    let name = m.attribute("name").map(str::to_string);
    let rgba = match child(m, "color") {
        Some(c) => {
            let cel = format!("{el}/<color>");
            let text = rd.attr(c, &cel, "rgba")?;
            let parts: Vec<f64> = text
                .split_whitespace()
                .map(|w| w.parse::<f64>())
                .collect::<Result<_, _>>()
                .ok()
                .filter(|v: &Vec<f64>| v.len() == 4 && v.iter().all(|x| x.is_finite()))
                .ok_or_else(|| {
                    rd.err(
                        c,
                        &cel,
                        UrdfErrorKind::BadNumber {
                            attribute: "rgba",
                            value: text.to_string(),
                            reason: "not four finite numbers",
                        },
                    )
                })?;
            Some([parts[0], parts[1], parts[2], parts[3]])
        }
        None => None,
    };
    let texture = child(m, "texture")
        .and_then(|t| t.attribute("filename"))
        .map(str::to_string);
    if rgba.is_none()
        && texture.is_none()
        && let Some(n) = &name
        && let Some(global) = named.get(n)
    {
        return Ok(global.clone());
    }
    Ok(Material {
        name,
        rgba,
        texture,
    })
}

fn geometry(rd: &Reader, g: roxmltree::Node, el: &str) -> Result<Geometry, UrdfError> {
    let Some(s) = g.children().find(|n| n.is_element()) else {
        return Err(rd.err(
            g,
            el,
            UrdfErrorKind::MissingElement("box, cylinder, sphere or mesh"),
        ));
    };
    let tag = s.tag_name().name();
    let sel = format!("{el}/<{tag}>");
    let positive = |v: f64, attribute: &'static str| {
        if v > 0.0 {
            Ok(v)
        } else {
            Err(rd.err(
                s,
                &sel,
                UrdfErrorKind::BadNumber {
                    attribute,
                    value: v.to_string(),
                    reason: "not positive",
                },
            ))
        }
    };
    Ok(match tag {
        "box" => {
            let size = rd.triple(s, &sel, "size", [f64::NAN; 3]);
            if s.attribute("size").is_none() {
                return Err(rd.err(s, &sel, UrdfErrorKind::MissingAttribute("size")));
            }
            let size = size?;
            for c in size.iter() {
                positive(*c, "size")?;
            }
            Geometry::Box { size }
        }
        "cylinder" => Geometry::Cylinder {
            radius: positive(rd.number(s, &sel, "radius", None)?, "radius")?,
            length: positive(rd.number(s, &sel, "length", None)?, "length")?,
        },
        "sphere" => Geometry::Sphere {
            radius: positive(rd.number(s, &sel, "radius", None)?, "radius")?,
        },
        "mesh" => Geometry::Mesh(MeshRef {
            uri: rd.attr(s, &sel, "filename")?.to_string(),
            scale: rd.triple(s, &sel, "scale", [1.0; 3])?,
            urdf: rd.file.to_path_buf(),
            line: rd.line(s),
            element: sel.clone(),
        }),
        _ => {
            return Err(rd.err(
                s,
                &sel,
                UrdfErrorKind::MissingElement("box, cylinder, sphere or mesh"),
            ));
        }
    })
}

/// One joint of the URDF tree for [`place`]: `body` is `Some(j)` for the chain's movable joint
/// j (1-based body index), `None` for a joint rigid at q = 0 (fixed, or held off the chain).
pub struct TreeJoint<'a> {
    pub parent: &'a str,
    pub child: &'a str,
    pub placement: Matrix4<f64>,
    pub body: Option<usize>,
}

/// Sets each link's body and `in_body` from the root outward.
pub fn place(geometry: &mut UrdfGeometry, root: &str, joints: &[TreeJoint]) {
    let mut stack = vec![(root.to_string(), 0usize, Matrix4::identity())];
    while let Some((link, body, in_body)) = stack.pop() {
        if let Some(g) = geometry.links.get_mut(&link) {
            g.body = body;
            g.in_body = in_body;
        }
        for j in joints.iter().filter(|j| j.parent == link) {
            stack.push(match j.body {
                Some(b) => (j.child.to_string(), b, Matrix4::identity()),
                None => (j.child.to_string(), body, in_body * j.placement),
            });
        }
    }
}

/// The distinct vertices of `tris` (exact duplicates dropped), as points.
pub fn hull_points(tris: &Triangles) -> Vec<Point3<f64>> {
    let mut seen = std::collections::HashSet::new();
    let mut out = Vec::new();
    for t in tris {
        for v in t {
            if seen.insert([v[0].to_bits(), v[1].to_bits(), v[2].to_bits()]) {
                out.push(Point3::new(v[0], v[1], v[2]));
            }
        }
    }
    out
}
