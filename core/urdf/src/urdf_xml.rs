//! What the URDF reader's two halves share: the errors ([`UrdfError`], [`UrdfErrorKind`],
//! [`MeshProblem`]) and the element reader ([`Reader`]: lines, attributes, numbers, triples,
//! origins; [`child`], [`rpy_matrix`]). urdf_import.rs (the tree and the chain) and
//! urdf_geometry.rs (visuals and collisions) both use it; neither imports the other's reader.
//! Re-exported under their old paths (`urdf_import::UrdfError`, `urdf_geometry::MeshProblem`, …).

use crate::package::ResolveError;
use nalgebra::{Matrix3, Matrix4, Vector3};
use robosim_kinematics::ModelError;
use std::path::{Path, PathBuf};

/// What was wrong, without the where (see [`UrdfError`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum UrdfErrorKind {
    #[error("cannot read the file: {0}")]
    Io(String),
    #[error("malformed XML: {0}")]
    Xml(String),
    /// Elements nested deeper than [`robosim_input::MAX_XML_DEPTH`]: refused before parsing,
    /// whose recursion would overflow the stack.
    #[error("{0}")]
    TooDeep(robosim_input::XmlTooDeep),
    #[error("the root element is <{0}>, not <robot>")]
    NotARobot(String),
    #[error(
        "a xacro file (it has <xacro:…> elements): run `xacro` on it first and import the URDF it writes"
    )]
    Xacro,
    #[error("attribute `{0}` is missing")]
    MissingAttribute(&'static str),
    #[error("attribute `{attribute}` = {value:?}: {reason}")]
    BadNumber {
        attribute: &'static str,
        value: String,
        reason: &'static str,
    },
    #[error("joint type {0:?} is not supported (revolute, continuous, prismatic and fixed are)")]
    UnsupportedJointType(String),
    #[error("two elements are named {0:?}")]
    DuplicateName(String),
    #[error("<{0}> is missing")]
    MissingElement(&'static str),
    #[error("{role} link {link:?} is not a <link> of this robot")]
    MissingLink { role: &'static str, link: String },
    #[error("link {link:?} is the child of two joints ({first:?} and this one)")]
    TwoParents { link: String, first: String },
    #[error("the joints form a cycle through link {0:?}")]
    Cycle(String),
    #[error("two root links (links no joint moves): {0:?} and {1:?}")]
    TwoRoots(String, String),
    #[error("no root link (every link is some joint's child: the joints form a cycle)")]
    NoRoot,
    #[error("mass {0} kg is negative")]
    NegativeMass(f64),
    #[error("inertia is not positive semi-definite (principal moment {0:e} kg·m²)")]
    InertiaNotPsd(f64),
    #[error("axis is the zero vector")]
    ZeroAxis,
    #[error("lower limit {0} is above the upper limit {1}")]
    ReversedLimits(f64, f64),
    #[error("tip {0:?} is not a <link> of this robot")]
    TipNotALink(String),
    #[error("no tip given and the robot has {0} leaf links ({1}); name the tip link")]
    AmbiguousTip(usize, String),
    /// A `<mimic joint="…">` naming no joint of the file.
    #[error("<mimic> names joint {0:?}, which is not a joint of this robot")]
    MimicUnknownJoint(String),
    /// The `<mimic>` relations cannot be imposed (a cycle of mimic joints).
    #[error("the <mimic> joints cannot be imposed: {0}")]
    Mimic(robosim_kinematics::mimic::MimicError),
    #[error("the imported chain is not a valid robot: {0}")]
    Model(ModelError),
    /// A `<mesh>` (or a collision solid) that cannot be used; found when geometry is needed.
    #[error("{0}")]
    Mesh(MeshProblem),
}

/// A URDF problem: the file, the 1-based line (0 when there is no element, as for an unreadable
/// file), the element (`<joint name="j1">`, `<link name="l2">/<inertial>/<mass>`, …) and what.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}:{line}: {element}: {kind}", file.display())]
pub struct UrdfError {
    pub file: PathBuf,
    pub line: u32,
    pub element: String,
    pub kind: UrdfErrorKind,
}

/// What is wrong with a `<mesh>` (or a geometry built from one), found when it is loaded.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeshProblem {
    #[error("{0}")]
    Resolve(#[from] ResolveError),
    #[error("mesh file {0} does not exist")]
    NotFound(PathBuf),
    #[error("mesh file {path}: format {format:?} is not read (STL, OBJ and Collada .dae are)")]
    UnsupportedFormat { path: PathBuf, format: String },
    #[error("{0}")]
    Read(String),
    /// A malformed or unsupported Collada file: its own file, line and element (boxed: it
    /// would double the size of every `UrdfError`).
    #[error("{0}")]
    Dae(Box<crate::dae::DaeError>),
    #[error("mesh file {0} has no triangles")]
    Empty(PathBuf),
    /// A mesh file's text or numbers are wrong (its file and line, kept).
    #[error(transparent)]
    File(#[from] crate::stl::MeshFileError),
    /// The solid could not be made (the message says why: too few points, …).
    #[error("collision solid: {0}")]
    Shape(String),
    /// The geometry refused the solid (a primitive's dimensions, a mesh's convex parts): its
    /// error, kept.
    #[error("collision solid: {0}")]
    Solid(#[source] robosim_geometry::shapes::ShapeError),
    /// A mesh's convex parts could not be made into solids (the collision crate's error, kept).
    #[error("collision solid: {0}")]
    Parts(#[source] robosim_collision::ShapeError),
    /// A mesh's convex hull is not a valid polyhedron (the geometry's error, kept).
    #[error("collision solid: its convex hull: {0}")]
    Hull(#[source] robosim_geometry::GeometryError),
}

pub struct Reader<'a, 'input> {
    pub file: &'a Path,
    pub(crate) doc: &'a roxmltree::Document<'input>,
}

impl Reader<'_, '_> {
    pub fn line(&self, node: roxmltree::Node) -> u32 {
        self.doc.text_pos_at(node.range().start).row
    }

    pub fn err(&self, node: roxmltree::Node, element: &str, kind: UrdfErrorKind) -> UrdfError {
        UrdfError {
            file: self.file.to_path_buf(),
            line: self.line(node),
            element: element.to_string(),
            kind,
        }
    }

    pub fn attr<'n>(
        &self,
        node: roxmltree::Node<'n, '_>,
        element: &str,
        name: &'static str,
    ) -> Result<&'n str, UrdfError> {
        node.attribute(name)
            .ok_or_else(|| self.err(node, element, UrdfErrorKind::MissingAttribute(name)))
    }

    /// A finite number attribute; `default` when absent (`None`: required).
    pub fn number(
        &self,
        node: roxmltree::Node,
        element: &str,
        name: &'static str,
        default: Option<f64>,
    ) -> Result<f64, UrdfError> {
        let Some(text) = node.attribute(name) else {
            return default
                .ok_or_else(|| self.err(node, element, UrdfErrorKind::MissingAttribute(name)));
        };
        let bad = |reason| {
            self.err(
                node,
                element,
                UrdfErrorKind::BadNumber {
                    attribute: name,
                    value: text.to_string(),
                    reason,
                },
            )
        };
        let v: f64 = text.trim().parse().map_err(|_| bad("not a number"))?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(bad("not finite"))
        }
    }

    /// Three finite numbers separated by white space; `default` when the attribute is absent.
    pub fn triple(
        &self,
        node: roxmltree::Node,
        element: &str,
        name: &'static str,
        default: [f64; 3],
    ) -> Result<Vector3<f64>, UrdfError> {
        let Some(text) = node.attribute(name) else {
            return Ok(Vector3::from(default));
        };
        let bad = |reason| {
            self.err(
                node,
                element,
                UrdfErrorKind::BadNumber {
                    attribute: name,
                    value: text.to_string(),
                    reason,
                },
            )
        };
        let parts: Vec<&str> = text.split_whitespace().collect();
        if parts.len() != 3 {
            return Err(bad("not three numbers"));
        }
        let mut v = Vector3::zeros();
        for (i, p) in parts.iter().enumerate() {
            v[i] = p.parse::<f64>().map_err(|_| bad("not a number"))?;
            if !v[i].is_finite() {
                return Err(bad("not finite"));
            }
        }
        Ok(v)
    }

    /// `<origin xyz rpy>` under `parent` as a rigid transform (identity when absent).
    pub fn origin(
        &self,
        parent: roxmltree::Node,
        element: &str,
    ) -> Result<Matrix4<f64>, UrdfError> {
        let Some(o) = child(parent, "origin") else {
            return Ok(Matrix4::identity());
        };
        let element = format!("{element}/<origin>");
        let xyz = self.triple(o, &element, "xyz", [0.0; 3])?;
        let rpy = self.triple(o, &element, "rpy", [0.0; 3])?;
        let mut m = Matrix4::identity();
        m.fixed_view_mut::<3, 3>(0, 0).copy_from(&rpy_matrix(&rpy));
        m.fixed_view_mut::<3, 1>(0, 3).copy_from(&xyz);
        Ok(m)
    }
}

pub fn child<'a, 'i>(node: roxmltree::Node<'a, 'i>, tag: &str) -> Option<roxmltree::Node<'a, 'i>> {
    node.children()
        .find(|c| c.is_element() && c.tag_name().name() == tag)
}

/// URDF's roll–pitch–yaw: `R = Rz(yaw) Ry(pitch) Rx(roll)`.
pub fn rpy_matrix(rpy: &Vector3<f64>) -> Matrix3<f64> {
    let (sr, cr) = rpy.x.sin_cos();
    let (sp, cp) = rpy.y.sin_cos();
    let (sy, cy) = rpy.z.sin_cos();
    Matrix3::new(
        cy * cp,
        cy * sp * sr - sy * cr,
        cy * sp * cr + sy * sr,
        sy * cp,
        sy * sp * sr + cy * cr,
        sy * sp * cr - cy * sr,
        -sp,
        cp * sr,
        cp * cr,
    )
}
