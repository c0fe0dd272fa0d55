//! MJCF import (issue 36 item 5): a MuJoCo model file read into robosim's one joint model, the
//! same [`UrdfRobot`] the URDF reader gives (a robot description read from a file: the
//! [`Robot`], joint and body names, notes, geometry), so every caller of a URDF import takes
//! an MJCF one too. Entry points: [`import_mjcf_tree`] (every joint a coordinate),
//! [`import_mjcf`] (the chain from the world to a tip body), and their `_str` forms.
//!
//! What is read:
//! * `<compiler angle eulerseq meshdir assetdir inertiafromgeom inertiagrouprange
//!   autolimits>` (angle defaults to degrees, as in MuJoCo); `<option gravity>`.
//! * `<default>` classes, nested (a class inherits its parent's values), applied to `joint`,
//!   `geom` and `mesh` by `class`, else by the nearest enclosing body's `childclass`, else the
//!   top-level (`main`) class.
//! * The `<worldbody>` tree: each `<body>`'s `pos` and orientation (`quat`, `axisangle`,
//!   `euler`, `xyaxes`, `zaxis`; frame arithmetic in [`crate::mjcf_frame`]), its joints, its
//!   `<inertial>` (`pos`, orientation, `mass`, `diaginertia` or `fullinertia`) and its geoms.
//! * `<joint>` of type `hinge` and `slide` with `pos` (the anchor, in the body frame), `axis`,
//!   `range` with `limited` (auto: limited when a range is given, MuJoCo's `autolimits`),
//!   `damping` (viscous), `frictionloss` (Coulomb), `armature` (the motor inertia on M's
//!   diagonal, as MuJoCo adds it) and `ref` (q = ref is the body's frame as written). A body
//!   with several joints applies them in order, each about its own anchor.
//! * Inertia from geoms where MuJoCo infers it (`inertiafromgeom="true"`, or `"auto"` and the
//!   body has no `<inertial>`): spheres, capsules, cylinders, boxes and ellipsoids (`size` or
//!   `fromto`), mass from `mass` or `density` × volume, geoms whose `group` is in
//!   `inertiagrouprange`. A mesh geom's inertia is not computed: such a body needs an
//!   `<inertial>` (refused, naming the body and geom).
//! * Geoms as geometry ([`UrdfRobot::geometry`], keyed by body name): a geom that collides
//!   (`contype` or `conaffinity` non-zero) is a collision shape and is drawn; one that does not
//!   is a visual only. Spheres, boxes and cylinders as they are; a capsule as the cylinder that
//!   holds it (length + 2r), an ellipsoid as the sphere of its largest semi-axis (no capsule or
//!   ellipsoid solid yet); meshes from `<asset><mesh file scale>` under `meshdir` (loaded when
//!   geometry is needed). The worldbody's own geoms (a floor) are not part of the robot.
//!
//! Mapping: each MJCF joint is one coordinate, in MuJoCo's order (bodies depth first in file
//! order, joints in a body in file order), so q here is MuJoCo's `qpos`. Robosim's link frame
//! of a body's last joint is the body frame moved to that joint's anchor; the body frame in it
//! is [`crate::urdf_geometry::LinkGeometry::in_body`] (the identity when the anchor is the body
//! origin, as in every URDF-made MJCF). A body without joints is rigid with its parent (its
//! inertia lumped, as URDF fixed joints are). The base frame is the world.
//!
//! A `free` joint (`<freejoint>`) as the one joint of the worldbody's first body is the robot's
//! floating base (`Robot::root`, a free-flyer, docs/dynamics.md "Floating bases"): its q and v
//! are robosim's (Pinocchio's) — `x y z qx qy qz qw`, the velocity on the body's own axes —
//! where MuJoCo's qpos is `x y z qw qx qy qz` and its qvel's linear part is in the world frame.
//! A `ball` joint is a spherical joint (`Joint::spherical`, Pinocchio's `JointModelSpherical`,
//! docs/dynamics.md "Spherical joints"): 4 q, robosim's quaternion order `qx qy qz qw` where
//! MuJoCo's qpos is `qw qx qy qz`, and 3 v, the angular velocity in the body frame as MuJoCo's
//! qvel; so q here is MuJoCo's qpos with each ball's quaternion reordered. Its `range` (a cone
//! limit, `0 max`) is noted in [`UrdfRobot::notes`], not enforced; `axis` and `ref` do not apply.
//! Refused, by name: a `free` joint anywhere but the root (only the root may be floating); `<include>` (import the included file,
//! or merge them); `<frame>` (MuJoCo ≥ 3.2); `<compiler coordinate="global">`; malformed
//! numbers and unknown classes or meshes — each error names the file, line and element.
//! `<equality><joint>` (MuJoCo's mimic, `y − y₀ = a₀ + a₁ (x − x₀)`) is read into
//! [`UrdfRobot::coupling`] as URDF's `<mimic>` is (imposed exactly; a polynomial one is noted,
//! not imposed).
//! Not read, and listed in [`UrdfRobot::notes`]: actuators, tendons, the other equality
//! constraints (connect, weld, tendon, flex),
//! sensors, contact pairs and exclusions, keyframes, sites, cameras, lights, joint stiffness,
//! the other `<option>`s (the scene's options apply).

use crate::mjcf_frame::{
    Primitive, from_axis_angle, from_euler, from_wxyz, from_xyaxes, transform, translation, z_to,
};
use crate::urdf_geometry::{Geometry, LinkGeometry, Material, MeshRef, Shape, UrdfGeometry};
use crate::urdf_import::{UrdfJoint, UrdfMimic, UrdfRobot};
use nalgebra::{Matrix3, Matrix4, SymmetricEigen, UnitQuaternion, Vector3};
use robosim_kinematics::chain::{Inertial, Segment, SegmentKind, build_tree};
use robosim_kinematics::mimic::{Coupling, Mimic, MimicError};
use robosim_kinematics::{ModelError, RootKind};
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

/// What was wrong, without the where (see [`MjcfError`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MjcfErrorKind {
    #[error("cannot read the file: {0}")]
    Io(String),
    #[error("malformed XML: {0}")]
    Xml(String),
    #[error("{0}")]
    TooDeep(robosim_input::XmlTooDeep),
    #[error("the root element is <{0}>, not <mujoco>")]
    NotMujoco(String),
    #[error("attribute `{attribute}` = {value:?}: expected {expected}")]
    BadValue {
        attribute: String,
        value: String,
        expected: &'static str,
    },
    /// A free joint elsewhere than the root (see the module docs).
    #[error(
        "joint {joint:?} is a {kind} joint where robosim takes none (hinge, slide and ball joints are imported; a free joint only as the one joint of the first body of the worldbody: a floating base)"
    )]
    UnsupportedJoint { joint: String, kind: String },
    #[error("{0}")]
    Unsupported(&'static str),
    #[error("a nested <default> has no class name")]
    MissingClassName,
    #[error("default class {0:?} is not defined")]
    UnknownClass(String),
    #[error("mesh {0:?} is not an <asset><mesh> of this model")]
    UnknownMesh(String),
    #[error("mass {0} kg is negative")]
    NegativeMass(f64),
    #[error("inertia is not positive semi-definite (principal moment {0:e} kg·m²)")]
    InertiaNotPsd(f64),
    #[error(
        "body {body:?} has no <inertial> and its inertia would come from mesh geom {geom:?}, which robosim does not compute: give the body an <inertial>"
    )]
    MeshInertia { body: String, geom: String },
    #[error("two bodies are named {0:?}")]
    DuplicateBody(String),
    #[error("tip {0:?} is not a <body> of this model")]
    TipNotABody(String),
    #[error("no tip given and the model has {0} leaf bodies ({1}); name the tip body")]
    AmbiguousTip(usize, String),
    #[error("the imported robot is not valid: {0}")]
    Model(ModelError),
    /// An `<equality><joint>` naming no joint of the model.
    #[error("joint {0:?} is not a <joint> of this model")]
    UnknownJoint(String),
    /// The `<equality><joint>` couplings cannot be imposed (a cycle, a joint coupled twice).
    #[error("the <equality><joint> constraints cannot be imposed: {0}")]
    Mimic(robosim_kinematics::mimic::MimicError),
}

/// An MJCF problem: the file, the 1-based line (0 when there is no element), the element
/// (`<body name="link2">/<joint name="j2">`, …) and what.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}:{line}: {element}: {kind}", file.display())]
pub struct MjcfError {
    pub file: PathBuf,
    pub line: u32,
    pub element: String,
    pub kind: MjcfErrorKind,
}

/// Reads the MJCF file at `path` as a tree (see the module docs): every hinge and slide joint a
/// coordinate, in MuJoCo's qpos order; the tool is the identity on the last joint's link.
pub fn import_mjcf_tree(path: &Path) -> Result<UrdfRobot, MjcfError> {
    let text = read_file(path)?;
    import_mjcf_tree_str(&text, path)
}

/// Reads the MJCF file at `path` as the chain from the world to the body `tip` (`None`: the
/// only leaf body): the joints of the bodies on that path are q, in order; every other joint is
/// held at its reference position (`ref`, 0 by default) and what it carries is lumped into the
/// body it hangs from. The tool is the tip body's frame.
pub fn import_mjcf(path: &Path, tip: Option<&str>) -> Result<UrdfRobot, MjcfError> {
    let text = read_file(path)?;
    import_mjcf_str(&text, path, tip)
}

/// [`import_mjcf_tree`] on text already read; `file` names it in errors and is where
/// `meshdir` starts.
pub fn import_mjcf_tree_str(text: &str, file: &Path) -> Result<UrdfRobot, MjcfError> {
    let doc = parse(text, file)?;
    let model = Model::read(&doc, file)?;
    model.build(None)
}

/// [`import_mjcf`] on text already read.
pub fn import_mjcf_str(text: &str, file: &Path, tip: Option<&str>) -> Result<UrdfRobot, MjcfError> {
    let doc = parse(text, file)?;
    let model = Model::read(&doc, file)?;
    let tip = match tip {
        Some(t) => {
            if !model.bodies.iter().any(|b| b.name == t) {
                return Err(model.at_root(MjcfErrorKind::TipNotABody(t.to_string())));
            }
            t.to_string()
        }
        None => {
            let leaves: Vec<&str> = model
                .bodies
                .iter()
                .enumerate()
                .filter(|(i, _)| !model.bodies.iter().any(|b| b.parent == Some(*i)))
                .map(|(_, b)| b.name.as_str())
                .collect();
            match leaves.as_slice() {
                [one] => (*one).to_string(),
                _ => {
                    return Err(
                        model.at_root(MjcfErrorKind::AmbiguousTip(leaves.len(), leaves.join(", ")))
                    );
                }
            }
        }
    };
    model.build(Some(&tip))
}

fn read_file(path: &Path) -> Result<String, MjcfError> {
    robosim_input::read_to_string(path, "an MJCF file", robosim_input::Limit::TEXT).map_err(|e| {
        MjcfError {
            file: path.to_path_buf(),
            line: 0,
            element: "file".into(),
            kind: MjcfErrorKind::Io(e.reason()),
        }
    })
}

fn parse<'i>(text: &'i str, file: &Path) -> Result<roxmltree::Document<'i>, MjcfError> {
    let at = |line, element: &str, kind| MjcfError {
        file: file.to_path_buf(),
        line,
        element: element.to_string(),
        kind,
    };
    robosim_input::xml_depth(text, robosim_input::MAX_XML_DEPTH)
        .map_err(|e| at(e.line, "XML", MjcfErrorKind::TooDeep(e)))?;
    roxmltree::Document::parse(text).map_err(|e| {
        let pos = e.pos();
        at(
            pos.row,
            &format!("column {}", pos.col),
            MjcfErrorKind::Xml(e.to_string()),
        )
    })
}

/// The compiler settings the import uses.
struct Compiler {
    /// Radians per unit of the file's angles (π/180 for `angle="degree"`, the default).
    angle: f64,
    eulerseq: String,
    meshdir: PathBuf,
    /// `inertiafromgeom`: "true", "false" or "auto".
    inertia_from_geom: String,
    inertia_groups: [i64; 2],
    autolimits: bool,
}

/// One body of the worldbody tree (index 0 is not stored: the world is `parent: None`).
struct Body<'a, 'i> {
    node: roxmltree::Node<'a, 'i>,
    name: String,
    parent: Option<usize>,
    /// The class its child elements take when they name none.
    class: String,
}

/// One default class: per element tag, its attributes.
type ClassDefaults = HashMap<String, HashMap<String, String>>;

/// The document read into what the build needs.
struct Model<'a, 'i> {
    file: &'a Path,
    doc: &'a roxmltree::Document<'i>,
    root: roxmltree::Node<'a, 'i>,
    name: String,
    compiler: Compiler,
    gravity: Vector3<f64>,
    defaults: HashMap<String, ClassDefaults>,
    /// `<asset><mesh>` by name: file (resolved) and scale.
    meshes: HashMap<String, (PathBuf, Vector3<f64>)>,
    /// `<asset><material>` by name: rgba.
    materials: HashMap<String, [f64; 4]>,
    /// Bodies depth first in file order (MuJoCo's body ids minus one).
    bodies: Vec<Body<'a, 'i>>,
    notes: Vec<String>,
}

/// The top-level elements read; every other one is listed as not read.
const READ_SECTIONS: &[&str] = &[
    "compiler",
    "option",
    "size",
    "default",
    "asset",
    "worldbody",
    "visual",
    "statistic",
    "equality",
];

/// Body children that are not read (counted in the notes).
const NOT_READ_IN_BODY: &[&str] = &["site", "camera", "light", "composite", "flexcomp", "plugin"];

impl<'a, 'i> Model<'a, 'i> {
    fn err(&self, node: roxmltree::Node, element: &str, kind: MjcfErrorKind) -> MjcfError {
        MjcfError {
            file: self.file.to_path_buf(),
            line: self.doc.text_pos_at(node.range().start).row,
            element: element.to_string(),
            kind,
        }
    }

    fn at_root(&self, kind: MjcfErrorKind) -> MjcfError {
        self.err(self.root, &format!("<mujoco model={:?}>", self.name), kind)
    }

    fn read(doc: &'a roxmltree::Document<'i>, file: &'a Path) -> Result<Self, MjcfError> {
        let root = doc.root_element();
        let mut m = Model {
            file,
            doc,
            root,
            name: root.attribute("model").unwrap_or("mjcf").to_string(),
            compiler: Compiler {
                angle: std::f64::consts::PI / 180.0,
                eulerseq: "xyz".into(),
                meshdir: file.parent().map(Path::to_path_buf).unwrap_or_default(),
                inertia_from_geom: "auto".into(),
                inertia_groups: [0, 5],
                autolimits: true,
            },
            gravity: Vector3::new(0.0, 0.0, -9.81),
            defaults: HashMap::new(),
            meshes: HashMap::new(),
            materials: HashMap::new(),
            bodies: Vec::new(),
            notes: Vec::new(),
        };
        if root.tag_name().name() != "mujoco" {
            return Err(m.err(
                root,
                "root element",
                MjcfErrorKind::NotMujoco(root.tag_name().name().to_string()),
            ));
        }
        let sections: Vec<_> = root.children().filter(|c| c.is_element()).collect();
        for &s in &sections {
            match s.tag_name().name() {
                "include" => {
                    return Err(m.err(
                        s,
                        "<include>",
                        MjcfErrorKind::Unsupported(
                            "<include> is not followed: import the included file itself, or merge the files",
                        ),
                    ));
                }
                "compiler" => m.compiler(s)?,
                "option" => m.option(s)?,
                _ => {}
            }
        }
        m.defaults.insert("main".into(), ClassDefaults::default());
        for &s in &sections {
            if s.tag_name().name() == "default" {
                m.default_class(s, "main")?;
            }
        }
        for &s in &sections {
            if s.tag_name().name() == "asset" {
                m.assets(s)?;
            }
        }
        for &s in &sections {
            if s.tag_name().name() == "worldbody" {
                m.worldbody(s)?;
            }
        }
        m.note_not_read(&sections);
        Ok(m)
    }

    fn compiler(&mut self, node: roxmltree::Node) -> Result<(), MjcfError> {
        let el = "<compiler>";
        if let Some(a) = node.attribute("angle") {
            self.compiler.angle = match a {
                "degree" => std::f64::consts::PI / 180.0,
                "radian" => 1.0,
                _ => return Err(self.bad(node, el, "angle", a, "degree or radian")),
            };
        }
        if let Some(s) = node.attribute("eulerseq") {
            if from_euler([0.0; 3], s).is_none() {
                return Err(self.bad(node, el, "eulerseq", s, "three of xyzXYZ"));
            }
            self.compiler.eulerseq = s.to_string();
        }
        let dir = self
            .file
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_default();
        if let Some(d) = node.attribute("assetdir") {
            self.compiler.meshdir = dir.join(d);
        }
        if let Some(d) = node.attribute("meshdir") {
            self.compiler.meshdir = dir.join(d);
        }
        if let Some(v) = node.attribute("inertiafromgeom") {
            if !matches!(v, "true" | "false" | "auto") {
                return Err(self.bad(node, el, "inertiafromgeom", v, "true, false or auto"));
            }
            self.compiler.inertia_from_geom = v.to_string();
        }
        if let Some(v) = node.attribute("inertiagrouprange") {
            let g = self.numbers(node, el, "inertiagrouprange", v, 2)?;
            self.compiler.inertia_groups = [g[0] as i64, g[1] as i64];
        }
        if let Some(v) = node.attribute("autolimits") {
            self.compiler.autolimits = self.boolean(node, el, "autolimits", v)?;
        }
        if node.attribute("coordinate") == Some("global") {
            return Err(self.err(
                node,
                el,
                MjcfErrorKind::Unsupported(
                    "coordinate=\"global\" (removed from MuJoCo 2.3.3) is not read",
                ),
            ));
        }
        for a in node.attributes() {
            if matches!(
                a.name(),
                "boundmass" | "boundinertia" | "settotalmass" | "balanceinertia" | "alignfree"
            ) {
                self.notes.push(format!(
                    "<compiler {}=\"{}\"> is not applied: the masses and inertias are the file's",
                    a.name(),
                    a.value()
                ));
            }
        }
        Ok(())
    }

    fn option(&mut self, node: roxmltree::Node) -> Result<(), MjcfError> {
        if let Some(g) = node.attribute("gravity") {
            let v = self.numbers(node, "<option>", "gravity", g, 3)?;
            self.gravity = Vector3::new(v[0], v[1], v[2]);
        }
        let others: Vec<&str> = node
            .attributes()
            .map(|a| a.name())
            .filter(|n| *n != "gravity")
            .collect();
        if !others.is_empty() {
            self.notes.push(format!(
                "<option> {} not read (the scene's own options apply)",
                others.join(", ")
            ));
        }
        Ok(())
    }

    /// A `<default>` element: its class (`class`, or `main` at the top) inherits `parent`'s
    /// values; its element children set values; its `<default>` children are nested classes.
    fn default_class(&mut self, node: roxmltree::Node, parent: &str) -> Result<(), MjcfError> {
        let class = node.attribute("class").unwrap_or(parent).to_string();
        let mut values = self.defaults.get(parent).cloned().unwrap_or_default();
        for c in node.children().filter(|c| c.is_element()) {
            if c.tag_name().name() == "default" {
                continue;
            }
            let tag = c.tag_name().name().to_string();
            let entry = values.entry(tag).or_default();
            for a in c.attributes() {
                entry.insert(a.name().to_string(), a.value().to_string());
            }
        }
        self.defaults.insert(class.clone(), values);
        for c in node
            .children()
            .filter(|c| c.is_element() && c.tag_name().name() == "default")
        {
            if c.attribute("class").is_none() {
                return Err(self.err(c, "<default>", MjcfErrorKind::MissingClassName));
            }
            self.default_class(c, &class)?;
        }
        Ok(())
    }

    fn assets(&mut self, node: roxmltree::Node) -> Result<(), MjcfError> {
        for c in node.children().filter(|c| c.is_element()) {
            match c.tag_name().name() {
                "mesh" => {
                    let class = c.attribute("class").unwrap_or("main");
                    let el = format!(
                        "<asset>/<mesh name={:?}>",
                        c.attribute("name").unwrap_or("")
                    );
                    let Some(file) = self.value(c, class, "file")? else {
                        self.notes.push(format!(
                            "{el}: a mesh without a file (vertex data in the XML) is not read"
                        ));
                        continue;
                    };
                    let name = match c.attribute("name") {
                        Some(n) => n.to_string(),
                        None => Path::new(&file)
                            .file_stem()
                            .and_then(|s| s.to_str())
                            .unwrap_or("")
                            .to_string(),
                    };
                    let scale = match self.value(c, class, "scale")? {
                        Some(s) => {
                            let v = self.numbers(c, &el, "scale", &s, 3)?;
                            Vector3::new(v[0], v[1], v[2])
                        }
                        None => Vector3::repeat(1.0),
                    };
                    self.meshes
                        .insert(name, (self.compiler.meshdir.join(file), scale));
                }
                "material" => {
                    if let (Some(name), Some(rgba)) = (c.attribute("name"), c.attribute("rgba")) {
                        let v = self.numbers(c, "<asset>/<material>", "rgba", rgba, 4)?;
                        self.materials
                            .insert(name.to_string(), [v[0], v[1], v[2], v[3]]);
                    }
                }
                _ => {}
            }
        }
        Ok(())
    }

    /// The bodies, depth first in file order (an explicit stack: the XML depth is bounded, but
    /// the order must be MuJoCo's preorder).
    fn worldbody(&mut self, node: roxmltree::Node<'a, 'i>) -> Result<(), MjcfError> {
        let mut stack: Vec<(roxmltree::Node<'a, 'i>, Option<usize>, String)> = Vec::new();
        self.check_children(node, "<worldbody>")?;
        let world_geoms = node
            .children()
            .filter(|c| c.is_element() && c.tag_name().name() == "geom")
            .count();
        if world_geoms > 0 {
            self.notes.push(format!(
                "{world_geoms} geoms of the <worldbody> itself (floors, walls) are not part of the robot"
            ));
        }
        let push_children =
            |stack: &mut Vec<_>, n: roxmltree::Node<'a, 'i>, parent: Option<usize>, class: &str| {
                let kids: Vec<_> = n
                    .children()
                    .filter(|c| c.is_element() && c.tag_name().name() == "body")
                    .collect();
                for k in kids.into_iter().rev() {
                    stack.push((k, parent, class.to_string()));
                }
            };
        push_children(&mut stack, node, None, "main");
        while let Some((b, parent, inherited)) = stack.pop() {
            let index = self.bodies.len();
            let name = b
                .attribute("name")
                .map_or_else(|| format!("body{}", index + 1), str::to_string);
            if self.bodies.iter().any(|x| x.name == name) {
                return Err(self.err(
                    b,
                    &format!("<body name={name:?}>"),
                    MjcfErrorKind::DuplicateBody(name),
                ));
            }
            let class = b.attribute("childclass").map_or(inherited, str::to_string);
            self.class(b, &format!("<body name={name:?}>"), &class)?;
            self.check_children(b, &format!("<body name={name:?}>"))?;
            push_children(&mut stack, b, Some(index), &class);
            self.bodies.push(Body {
                node: b,
                name,
                parent,
                class,
            });
        }
        Ok(())
    }

    /// Refuses what would change the kinematics if skipped (`<frame>`, `<include>`).
    fn check_children(&self, node: roxmltree::Node, element: &str) -> Result<(), MjcfError> {
        for c in node.children().filter(|c| c.is_element()) {
            match c.tag_name().name() {
                "frame" => {
                    return Err(self.err(
                        c,
                        &format!("{element}/<frame>"),
                        MjcfErrorKind::Unsupported(
                            "<frame> (MuJoCo 3.2) is not read yet: move its children into the body with the frame's pos and orientation",
                        ),
                    ));
                }
                "include" => {
                    return Err(self.err(
                        c,
                        &format!("{element}/<include>"),
                        MjcfErrorKind::Unsupported(
                            "<include> is not followed: merge the included file into this one",
                        ),
                    ));
                }
                _ => {}
            }
        }
        Ok(())
    }

    fn note_not_read(&mut self, sections: &[roxmltree::Node]) {
        let mut counts: BTreeMap<String, usize> = BTreeMap::new();
        for s in sections {
            let tag = s.tag_name().name();
            if !READ_SECTIONS.contains(&tag) {
                let n = s.children().filter(|c| c.is_element()).count();
                *counts.entry(format!("<{tag}>")).or_default() += n.max(1);
            }
            if tag == "equality" {
                // <joint> constraints are read (equality_joints); the others are not
                for c in s.children().filter(|c| c.is_element()) {
                    let name = c.tag_name().name();
                    if name != "joint" {
                        *counts.entry(format!("<equality><{name}>")).or_default() += 1;
                    }
                }
            }
        }
        for b in &self.bodies {
            for c in b.node.children().filter(|c| c.is_element()) {
                let tag = c.tag_name().name();
                if NOT_READ_IN_BODY.contains(&tag) {
                    *counts.entry(format!("<{tag}> in bodies")).or_default() += 1;
                }
            }
        }
        if !counts.is_empty() {
            let list: Vec<String> = counts
                .iter()
                .map(|(k, n)| format!("{k} ({n} element{})", if *n == 1 { "" } else { "s" }))
                .collect();
            self.notes.push(format!(
                "not read (no robosim counterpart yet): {}",
                list.join(", ")
            ));
        }
    }

    /// Checks that `class` is defined.
    fn class(&self, node: roxmltree::Node, element: &str, class: &str) -> Result<(), MjcfError> {
        if self.defaults.contains_key(class) {
            Ok(())
        } else {
            Err(self.err(
                node,
                element,
                MjcfErrorKind::UnknownClass(class.to_string()),
            ))
        }
    }

    /// An attribute of `node` or, when absent, of its class's defaults for its tag.
    fn value(
        &self,
        node: roxmltree::Node,
        class: &str,
        name: &str,
    ) -> Result<Option<String>, MjcfError> {
        if let Some(v) = node.attribute(name) {
            return Ok(Some(v.to_string()));
        }
        let class = node.attribute("class").unwrap_or(class);
        let defaults = self.defaults.get(class).ok_or_else(|| {
            self.err(
                node,
                &format!("<{}>", node.tag_name().name()),
                MjcfErrorKind::UnknownClass(class.to_string()),
            )
        })?;
        Ok(defaults
            .get(node.tag_name().name())
            .and_then(|d| d.get(name))
            .cloned())
    }

    fn bad(
        &self,
        node: roxmltree::Node,
        element: &str,
        attribute: &str,
        value: &str,
        expected: &'static str,
    ) -> MjcfError {
        self.err(
            node,
            element,
            MjcfErrorKind::BadValue {
                attribute: attribute.to_string(),
                value: value.to_string(),
                expected,
            },
        )
    }

    fn boolean(
        &self,
        node: roxmltree::Node,
        element: &str,
        attribute: &str,
        value: &str,
    ) -> Result<bool, MjcfError> {
        match value {
            "true" => Ok(true),
            "false" => Ok(false),
            _ => Err(self.bad(node, element, attribute, value, "true or false")),
        }
    }

    /// Exactly `n` finite numbers.
    fn numbers(
        &self,
        node: roxmltree::Node,
        element: &str,
        attribute: &str,
        text: &str,
        n: usize,
    ) -> Result<Vec<f64>, MjcfError> {
        let v = self.some_numbers(node, element, attribute, text)?;
        if v.len() == n {
            Ok(v)
        } else {
            Err(self.bad(node, element, attribute, text, number_count(n)))
        }
    }

    /// One or more finite numbers.
    fn some_numbers(
        &self,
        node: roxmltree::Node,
        element: &str,
        attribute: &str,
        text: &str,
    ) -> Result<Vec<f64>, MjcfError> {
        let v: Option<Vec<f64>> = text
            .split_whitespace()
            .map(|p| p.parse::<f64>().ok().filter(|x| x.is_finite()))
            .collect();
        v.filter(|v| !v.is_empty())
            .ok_or_else(|| self.bad(node, element, attribute, text, "finite numbers"))
    }

    /// `n` numbers of an attribute (with defaults), or `None` when absent.
    fn attr_numbers(
        &self,
        node: roxmltree::Node,
        class: &str,
        element: &str,
        attribute: &str,
        n: usize,
    ) -> Result<Option<Vec<f64>>, MjcfError> {
        match self.value(node, class, attribute)? {
            None => Ok(None),
            Some(t) => self.numbers(node, element, attribute, &t, n).map(Some),
        }
    }

    fn attr_number(
        &self,
        node: roxmltree::Node,
        class: &str,
        element: &str,
        attribute: &str,
        default: f64,
    ) -> Result<f64, MjcfError> {
        Ok(self
            .attr_numbers(node, class, element, attribute, 1)?
            .map_or(default, |v| v[0]))
    }

    /// `pos` and the orientation of a body, inertial, geom (MuJoCo's frame alternatives; only
    /// one may be given).
    fn frame(
        &self,
        node: roxmltree::Node,
        class: &str,
        element: &str,
    ) -> Result<Matrix4<f64>, MjcfError> {
        let pos = self
            .attr_numbers(node, class, element, "pos", 3)?
            .map_or_else(Vector3::zeros, |v| Vector3::new(v[0], v[1], v[2]));
        let quat = self.orientation(node, class, element)?;
        Ok(transform(&pos, &quat))
    }

    fn orientation(
        &self,
        node: roxmltree::Node,
        class: &str,
        element: &str,
    ) -> Result<UnitQuaternion<f64>, MjcfError> {
        let mut given = Vec::new();
        for (name, n) in [
            ("quat", 4),
            ("axisangle", 4),
            ("euler", 3),
            ("xyaxes", 6),
            ("zaxis", 3),
        ] {
            if let Some(v) = self.attr_numbers(node, class, element, name, n)? {
                given.push((name, v));
            }
        }
        let (name, v) = match given.as_slice() {
            [] => return Ok(UnitQuaternion::identity()),
            [one] => one,
            [a, b, ..] => {
                return Err(self.bad(
                    node,
                    element,
                    b.0,
                    &format!("{:?} with {} also given", b.1, a.0),
                    "one orientation (quat, axisangle, euler, xyaxes or zaxis)",
                ));
            }
        };
        let text = format!("{v:?}");
        let q = match *name {
            "quat" => from_wxyz([v[0], v[1], v[2], v[3]]),
            "axisangle" => {
                from_axis_angle(Vector3::new(v[0], v[1], v[2]), v[3] * self.compiler.angle)
            }
            "euler" => from_euler(
                [v[0], v[1], v[2]].map(|a| a * self.compiler.angle),
                &self.compiler.eulerseq,
            ),
            "xyaxes" => from_xyaxes(
                Vector3::new(v[0], v[1], v[2]),
                Vector3::new(v[3], v[4], v[5]),
            ),
            _ => z_to(Vector3::new(v[0], v[1], v[2])),
        };
        q.ok_or_else(|| self.bad(node, element, name, &text, "a non-degenerate orientation"))
    }
}

fn number_count(n: usize) -> &'static str {
    match n {
        1 => "one finite number",
        2 => "two finite numbers",
        3 => "three finite numbers",
        4 => "four finite numbers",
        6 => "six finite numbers",
        _ => "finite numbers",
    }
}

/// One MJCF joint as read.
struct JointRead {
    name: String,
    kind: SegmentKind,
    anchor: Vector3<f64>,
    axis: Vector3<f64>,
    qlim: [f64; 2],
    viscous: f64,
    coulomb: f64,
    armature: f64,
    reference: f64,
    /// A limited ball joint's cone limit (rad): noted, not enforced.
    cone: Option<f64>,
}

/// What the build keeps per body.
struct Placed {
    /// The last segment of the body (None: the world).
    segment: Option<usize>,
    /// The body frame in that segment's child frame.
    in_segment: Matrix4<f64>,
}

/// The segments of the bodies read so far, as `build` collects them (one entry per segment in
/// `segments`, `parents` and `joint_of_segment`; one per body in `placed` and `geoms_of`).
#[derive(Default)]
struct Chain<'a, 'i> {
    segments: Vec<Segment>,
    parents: Vec<Option<usize>>,
    /// Per movable segment: the joint it came from (name, armature, ref, body).
    joint_of_segment: Vec<Option<(String, f64, f64, usize)>>,
    placed: Vec<Placed>,
    geoms_of: Vec<Vec<GeomRead<'a, 'i>>>,
    /// Joints held fixed (off the path to the tip).
    held: Vec<String>,
    /// Every joint's reference position (qpos0), moving or held, by name.
    refs: HashMap<String, f64>,
}

impl Chain<'_, '_> {
    fn push(
        &mut self,
        segment: Segment,
        parent: Option<usize>,
        joint: Option<(String, f64, f64, usize)>,
    ) {
        self.segments.push(segment);
        self.parents.push(parent);
        self.joint_of_segment.push(joint);
    }
}

/// With a tip body, which bodies lie on the path from the world to it (an unknown tip: none).
fn path_to(bodies: &[Body], tip: Option<&str>) -> Option<Vec<bool>> {
    tip.map(|t| {
        let mut on = vec![false; bodies.len()];
        let mut at = bodies.iter().position(|b| b.name == t);
        while let Some(i) = at {
            on[i] = true;
            at = bodies[i].parent;
        }
        on
    })
}

/// Per segment: the robosim body its child frame is rigid with (0 = the base, k = joint
/// k−1's link) and the child frame in that body.
fn segment_frames(chain: &Chain, segment_of_joint: &[usize]) -> Vec<(usize, Matrix4<f64>)> {
    let mut seg_frame: Vec<(usize, Matrix4<f64>)> = Vec::with_capacity(chain.segments.len());
    for (s, seg) in chain.segments.iter().enumerate() {
        let joint = segment_of_joint.iter().position(|&x| x == s);
        seg_frame.push(match joint {
            Some(j) => (j + 1, Matrix4::identity()),
            // a free joint's body is link frame 0 itself
            None if matches!(seg.kind, SegmentKind::Root(_)) => (0, Matrix4::identity()),
            None => match chain.parents[s] {
                Some(p) => (seg_frame[p].0, seg_frame[p].1 * seg.placement),
                None => (0, seg.placement),
            },
        });
    }
    seg_frame
}

/// The moving joints in the robot's order (name, body, continuous), with each one's parent
/// body ("world" at the root); sets each robot joint's motor inertia (armature) and offset
/// (−ref, so that q = 0 is the reference pose).
fn joint_records(
    robot: &mut robosim_kinematics::Robot,
    chain: &Chain,
    segment_of_joint: &[usize],
    bodies: &[Body],
) -> (Vec<UrdfJoint>, Vec<String>) {
    let mut joints = Vec::new();
    let mut parent_links = Vec::new();
    for (j, &s) in segment_of_joint.iter().enumerate() {
        let Some((name, armature, reference, bi)) = chain.joint_of_segment[s].clone() else {
            continue;
        };
        robot.joints[j].motor_inertia = armature;
        robot.joints[j].offset = -reference;
        let b = &bodies[bi];
        joints.push(UrdfJoint {
            name,
            link: b.name.clone(),
            continuous: chain.segments[s].kind == SegmentKind::Continuous,
            effort: f64::INFINITY,
            velocity: f64::INFINITY,
        });
        parent_links.push(
            b.parent
                .map_or_else(|| "world".to_string(), |p| bodies[p].name.clone()),
        );
    }
    (joints, parent_links)
}

impl Model<'_, '_> {
    fn joints(&self, b: &Body) -> Result<Vec<JointRead>, MjcfError> {
        let mut out = Vec::new();
        let body_el = format!("<body name={:?}>", b.name);
        for (k, j) in b
            .node
            .children()
            .filter(|c| c.is_element() && matches!(c.tag_name().name(), "joint" | "freejoint"))
            .enumerate()
        {
            let name = j
                .attribute("name")
                .map_or_else(|| format!("{}_joint{k}", b.name), str::to_string);
            let el = format!("{body_el}/<{} name={name:?}>", j.tag_name().name());
            let type_name = if j.tag_name().name() == "freejoint" {
                "free".to_string()
            } else {
                self.value(j, &b.class, "type")?
                    .unwrap_or_else(|| "hinge".into())
            };
            let kind = match type_name.as_str() {
                "hinge" => SegmentKind::Revolute,
                "slide" => SegmentKind::Prismatic,
                // a floating base: only the first body's one joint (checked where segments are
                // built)
                "free" => SegmentKind::Root(RootKind::FreeFlyer),
                "ball" => SegmentKind::Spherical,
                other => return Err(self.bad(j, &el, "type", other, "hinge, slide, ball or free")),
            };
            let v3 = |name, d: [f64; 3]| -> Result<Vector3<f64>, MjcfError> {
                Ok(self
                    .attr_numbers(j, &b.class, &el, name, 3)?
                    .map_or(Vector3::from(d), |v| Vector3::new(v[0], v[1], v[2])))
            };
            let anchor = v3("pos", [0.0; 3])?;
            let axis = v3("axis", [0.0, 0.0, 1.0])?;
            let axis = robosim_geometry::unit_axis(axis)
                .ok_or_else(|| self.bad(j, &el, "axis", &format!("{axis:?}"), "a non-zero axis"))?
                .into_inner();
            let angle = if matches!(kind, SegmentKind::Revolute | SegmentKind::Spherical) {
                self.compiler.angle
            } else {
                1.0
            };
            let range = self.attr_numbers(j, &b.class, &el, "range", 2)?;
            let limited = match self.value(j, &b.class, "limited")?.as_deref() {
                None | Some("auto") => range.is_some() && self.compiler.autolimits,
                Some(v) => self.boolean(j, &el, "limited", v)?,
            };
            let qlim = match (&range, limited) {
                (Some(r), true) => {
                    let q = [r[0] * angle, r[1] * angle];
                    if q[0] > q[1] {
                        return Err(self.bad(j, &el, "range", &format!("{r:?}"), "lower ≤ upper"));
                    }
                    q
                }
                _ => [f64::NEG_INFINITY, f64::INFINITY],
            };
            // a ball's range is `0 max`, the cone of the child's z axis: kept for a note only
            let (qlim, cone) = if kind == SegmentKind::Spherical {
                (
                    [f64::NEG_INFINITY, f64::INFINITY],
                    (limited && range.is_some()).then_some(qlim[1]),
                )
            } else {
                (qlim, None)
            };
            let kind = if kind == SegmentKind::Revolute && !limited {
                SegmentKind::Continuous
            } else {
                kind
            };
            let stiffness = self.attr_number(j, &b.class, &el, "stiffness", 0.0)?;
            if stiffness != 0.0 {
                return Err(self.err(
                    j,
                    &el,
                    MjcfErrorKind::Unsupported(
                        "joint stiffness (a spring) has no robosim counterpart: remove it or set it to 0",
                    ),
                ));
            }
            out.push(JointRead {
                viscous: self.attr_number(j, &b.class, &el, "damping", 0.0)?,
                coulomb: self.attr_number(j, &b.class, &el, "frictionloss", 0.0)?,
                armature: self.attr_number(j, &b.class, &el, "armature", 0.0)?,
                reference: self.attr_number(j, &b.class, &el, "ref", 0.0)? * angle,
                name,
                kind,
                anchor,
                axis,
                qlim,
                cone,
            });
        }
        Ok(out)
    }

    /// The body's inertial in its own frame: its `<inertial>`, or its geoms' (see the module
    /// docs).
    fn inertial(&self, b: &Body, geoms: &[GeomRead]) -> Result<Inertial, MjcfError> {
        let body_el = format!("<body name={:?}>", b.name);
        let given = b
            .node
            .children()
            .find(|c| c.is_element() && c.tag_name().name() == "inertial");
        let from_geoms = match self.compiler.inertia_from_geom.as_str() {
            "true" => true,
            "false" => false,
            _ => given.is_none(),
        };
        if !from_geoms {
            return match given {
                Some(i) => self.given_inertial(i, &format!("{body_el}/<inertial>")),
                None => Ok(Inertial::default()),
            };
        }
        let mut total = Inertial::default();
        for g in geoms {
            if g.group < self.compiler.inertia_groups[0]
                || g.group > self.compiler.inertia_groups[1]
            {
                continue;
            }
            let Some(shape) = g.primitive else {
                if g.is_mesh {
                    return Err(self.err(
                        g.node,
                        &g.element,
                        MjcfErrorKind::MeshInertia {
                            body: b.name.clone(),
                            geom: g.name.clone(),
                        },
                    ));
                }
                continue;
            };
            let mass = match g.mass {
                Some(m) => m,
                None => g.density * shape.volume(),
            };
            if mass < 0.0 {
                return Err(self.err(g.node, &g.element, MjcfErrorKind::NegativeMass(mass)));
            }
            let part = shape.inertial(mass, &g.frame);
            if total.mass == 0.0 {
                total = part;
            } else {
                total.merge(&part);
            }
        }
        Ok(total)
    }

    fn given_inertial(&self, i: roxmltree::Node, el: &str) -> Result<Inertial, MjcfError> {
        let frame = self.frame(i, "main", el)?;
        let mass = self.attr_number(i, "main", el, "mass", 0.0)?;
        if mass < 0.0 {
            return Err(self.err(i, el, MjcfErrorKind::NegativeMass(mass)));
        }
        let inertia = if let Some(d) = self.attr_numbers(i, "main", el, "diaginertia", 3)? {
            Matrix3::from_diagonal(&Vector3::new(d[0], d[1], d[2]))
        } else if let Some(f) = self.attr_numbers(i, "main", el, "fullinertia", 6)? {
            // MuJoCo's order: M(1,1), M(2,2), M(3,3), M(1,2), M(1,3), M(2,3).
            Matrix3::new(f[0], f[3], f[4], f[3], f[1], f[5], f[4], f[5], f[2])
        } else {
            Matrix3::zeros()
        };
        let min = SymmetricEigen::new(inertia).eigenvalues.min();
        if min < -1e-12 * (1.0 + inertia.abs().max()) {
            return Err(self.err(i, el, MjcfErrorKind::InertiaNotPsd(min)));
        }
        Ok(Inertial {
            mass,
            com: Vector3::zeros(),
            inertia,
        }
        .transformed(&frame))
    }
}

/// One geom as read.
struct GeomRead<'a, 'i> {
    node: roxmltree::Node<'a, 'i>,
    element: String,
    name: String,
    /// The geom frame in the body frame.
    frame: Matrix4<f64>,
    primitive: Option<Primitive>,
    is_mesh: bool,
    geometry: Option<Geometry>,
    mass: Option<f64>,
    density: f64,
    group: i64,
    collides: bool,
    rgba: Option<[f64; 4]>,
}

impl<'a, 'i> Model<'a, 'i> {
    fn geoms(&mut self, b: &Body<'a, 'i>) -> Result<Vec<GeomRead<'a, 'i>>, MjcfError> {
        let mut out = Vec::new();
        let body_el = format!("<body name={:?}>", b.name);
        let nodes: Vec<_> = b
            .node
            .children()
            .filter(|c| c.is_element() && c.tag_name().name() == "geom")
            .collect();
        for (k, g) in nodes.into_iter().enumerate() {
            let name = g
                .attribute("name")
                .map_or_else(|| format!("{}_geom{k}", b.name), str::to_string);
            let el = format!("{body_el}/<geom name={name:?}>");
            let c = b.class.as_str();
            let mesh = self.value(g, c, "mesh")?;
            let type_name = self.value(g, c, "type")?.unwrap_or_else(|| {
                if mesh.is_some() {
                    "mesh".into()
                } else {
                    "sphere".into()
                }
            });
            let size = match self.value(g, c, "size")? {
                Some(t) => self.some_numbers(g, &el, "size", &t)?,
                None => Vec::new(),
            };
            let s = |i: usize| size.get(i).copied().unwrap_or(0.0);
            let fromto = self.attr_numbers(g, c, &el, "fromto", 6)?;
            let (frame, half_length) = match &fromto {
                Some(v) => {
                    let (a, b2) = (
                        Vector3::new(v[0], v[1], v[2]),
                        Vector3::new(v[3], v[4], v[5]),
                    );
                    let q = z_to(b2 - a).ok_or_else(|| {
                        self.bad(g, &el, "fromto", &format!("{v:?}"), "two different points")
                    })?;
                    (
                        transform(&((a + b2) / 2.0), &q),
                        Some((b2 - a).norm() / 2.0),
                    )
                }
                None => (self.frame(g, c, &el)?, None),
            };
            let primitive = match type_name.as_str() {
                "sphere" => Some(Primitive::Sphere { r: s(0) }),
                "capsule" => Some(Primitive::Capsule {
                    r: s(0),
                    h: half_length.unwrap_or(s(1)),
                }),
                "cylinder" => Some(Primitive::Cylinder {
                    r: s(0),
                    h: half_length.unwrap_or(s(1)),
                }),
                "box" => Some(Primitive::Box {
                    half: Vector3::new(s(0), s(1), half_length.unwrap_or(s(2))),
                }),
                "ellipsoid" => Some(Primitive::Ellipsoid {
                    abc: Vector3::new(s(0), s(1), half_length.unwrap_or(s(2))),
                }),
                "mesh" | "plane" | "hfield" | "sdf" => None,
                other => {
                    return Err(self.bad(
                        g,
                        &el,
                        "type",
                        other,
                        "plane, hfield, sphere, capsule, ellipsoid, cylinder, box, mesh or sdf",
                    ));
                }
            };
            let geometry = match (type_name.as_str(), primitive) {
                (_, Some(Primitive::Sphere { r })) => Some(Geometry::Sphere { radius: r }),
                (_, Some(Primitive::Box { half })) => Some(Geometry::Box { size: half * 2.0 }),
                (_, Some(Primitive::Cylinder { r, h })) => Some(Geometry::Cylinder {
                    radius: r,
                    length: 2.0 * h,
                }),
                (_, Some(Primitive::Capsule { r, h })) => Some(Geometry::Cylinder {
                    radius: r,
                    length: 2.0 * (h + r),
                }),
                (_, Some(Primitive::Ellipsoid { abc })) => {
                    Some(Geometry::Sphere { radius: abc.max() })
                }
                ("mesh", None) => {
                    let m = mesh.clone().unwrap_or_default();
                    let (file, scale) =
                        self.meshes.get(&m).cloned().ok_or_else(|| {
                            self.err(g, &el, MjcfErrorKind::UnknownMesh(m.clone()))
                        })?;
                    Some(Geometry::Mesh(MeshRef {
                        uri: file.to_string_lossy().into_owned(),
                        scale,
                        urdf: self.file.to_path_buf(),
                        line: self.doc.text_pos_at(g.range().start).row,
                        element: el.clone(),
                    }))
                }
                (other, None) => {
                    self.notes.push(format!(
                        "{el}: a {other} geom in a body is not part of the robot's geometry"
                    ));
                    None
                }
            };
            let int = |name, d: f64| self.attr_number(g, c, &el, name, d);
            let rgba = match self.attr_numbers(g, c, &el, "rgba", 4)? {
                Some(v) => Some([v[0], v[1], v[2], v[3]]),
                None => self
                    .value(g, c, "material")?
                    .and_then(|m| self.materials.get(&m).copied()),
            };
            out.push(GeomRead {
                node: g,
                name,
                frame,
                primitive,
                is_mesh: type_name == "mesh",
                geometry,
                mass: self.attr_numbers(g, c, &el, "mass", 1)?.map(|v| v[0]),
                density: int("density", 1000.0)?,
                group: int("group", 0.0)? as i64,
                collides: int("contype", 1.0)? != 0.0 || int("conaffinity", 1.0)? != 0.0,
                rgba,
                element: el,
            });
        }
        Ok(out)
    }

    /// The robot: segments for every body's joints (a body without joints is one fixed
    /// segment), built as a tree; with `tip`, only the joints of the bodies from the world to
    /// `tip` move (the others are fixed at their reference position).
    fn build(mut self, tip: Option<&str>) -> Result<UrdfRobot, MjcfError> {
        let on_path = path_to(&self.bodies, tip);
        let bodies = std::mem::take(&mut self.bodies);
        let mut chain = Chain::default();
        for (bi, b) in bodies.iter().enumerate() {
            let moving = on_path.as_ref().is_none_or(|on| on[bi]);
            self.body_segments(b, bi, moving, &mut chain)?;
        }
        let built = build_tree(&self.name, &chain.segments, &chain.parents);
        let mut robot = built.robot;
        robot.gravity = self.gravity;
        let seg_frame = segment_frames(&chain, &built.segment_of_joint);
        let (joints, parent_links) =
            joint_records(&mut robot, &chain, &built.segment_of_joint, &bodies);
        let geoms_of = std::mem::take(&mut chain.geoms_of);
        let (geometry, folded) = self.link_geometry(&bodies, geoms_of, &chain.placed, &seg_frame);
        let tip_name = match tip {
            Some(t) => {
                if let Some(g) = geometry.links.get(t)
                    && g.body == robot.dof()
                {
                    robot.tool = g.in_body;
                }
                t.to_string()
            }
            None => joints
                .last()
                .map_or_else(|| "world".to_string(), |j| j.link.clone()),
        };
        robot.validate().map_err(|e| {
            self.err(
                self.root,
                &format!("<mujoco model={:?}>", self.name),
                MjcfErrorKind::Model(e),
            )
        })?;
        let (mimics, coupling) = self.equality_joints(&joints, &chain.refs)?;
        let coupling = coupling.map(|c| c.with_root(robot.root_nq(), robot.root_nv()));
        Ok(UrdfRobot {
            robot,
            root: "world".into(),
            tip: tip_name,
            joints,
            folded,
            held: chain.held,
            notes: self.notes,
            parent_links,
            mimics,
            coupling,
            geometry,
        })
    }

    /// Body `bi`'s segments, appended to `chain`: one fixed segment for a body without
    /// joints; else one per joint, placed at the joint's anchor, the body's inertial on the
    /// last. A free joint (only on the first body under the world) is the floating base. Not
    /// `moving`, a body's joints are held fixed at their reference position.
    fn body_segments(
        &mut self,
        b: &Body<'a, 'i>,
        bi: usize,
        moving: bool,
        chain: &mut Chain<'a, 'i>,
    ) -> Result<(), MjcfError> {
        let joints = self.joints(b)?;
        let geoms = self.geoms(b)?;
        let inertial = self.inertial(b, &geoms)?;
        chain.geoms_of.push(geoms);
        let x = self.frame(b.node, "main", &format!("<body name={:?}>", b.name))?;
        let (mut parent_seg, mut pending) = match b.parent {
            Some(p) => (chain.placed[p].segment, chain.placed[p].in_segment * x),
            None => (None, x),
        };
        let mut anchor = Vector3::zeros();
        if joints.is_empty() {
            chain.push(
                Segment {
                    kind: SegmentKind::Fixed,
                    placement: pending,
                    axis: Vector3::z(),
                    qlim: [0.0; 2],
                    viscous: 0.0,
                    coulomb: 0.0,
                    child: inertial,
                },
                parent_seg,
                None,
            );
            chain.placed.push(Placed {
                segment: Some(chain.segments.len() - 1),
                in_segment: Matrix4::identity(),
            });
            return Ok(());
        }
        let n = joints.len();
        if let Some(j) = joints
            .iter()
            .find(|j| matches!(j.kind, SegmentKind::Root(_)))
            .filter(|_| bi != 0 || n != 1 || b.parent.is_some())
        {
            return Err(self.err(
                b.node,
                &format!("<body name={:?}>", b.name),
                MjcfErrorKind::UnsupportedJoint {
                    joint: j.name.clone(),
                    kind: "free".into(),
                },
            ));
        }
        for (k, j) in joints.into_iter().enumerate() {
            if matches!(j.kind, SegmentKind::Root(_)) {
                // the floating base: the body's pose is the robot's base, its frame link
                // frame 0 (a free joint has no anchor or axis)
                chain.push(
                    Segment {
                        kind: j.kind,
                        placement: pending,
                        axis: Vector3::z(),
                        qlim: [0.0; 2],
                        viscous: 0.0,
                        coulomb: 0.0,
                        child: inertial,
                    },
                    None,
                    None,
                );
                parent_seg = Some(chain.segments.len() - 1);
                pending = Matrix4::identity();
                continue;
            }
            chain.refs.insert(j.name.clone(), j.reference);
            if let Some(cone) = j.cone {
                self.notes.push(format!(
                    "joint {:?}: a ball joint's range (a cone limit of {cone} rad) is noted, not enforced",
                    j.name
                ));
            }
            let placement = pending * translation(&(j.anchor - anchor));
            anchor = j.anchor;
            let child = if k + 1 == n {
                inertial.transformed(&translation(&(-anchor)))
            } else {
                Inertial::default()
            };
            let kind = if moving {
                j.kind
            } else {
                chain.held.push(j.name.clone());
                SegmentKind::Fixed
            };
            chain.push(
                Segment {
                    kind,
                    placement,
                    axis: j.axis,
                    qlim: j.qlim,
                    viscous: j.viscous,
                    coulomb: j.coulomb,
                    child,
                },
                parent_seg,
                moving.then_some((j.name, j.armature, j.reference, bi)),
            );
            parent_seg = Some(chain.segments.len() - 1);
            pending = Matrix4::identity();
        }
        chain.placed.push(Placed {
            segment: parent_seg,
            in_segment: translation(&(-anchor)),
        });
        Ok(())
    }

    /// Each body's geometry in the robosim body it is rigid with (`seg_frame`), visual and
    /// (for geoms that collide) collision shapes; and the bodies without a joint of their own
    /// (folded into their parent).
    fn link_geometry(
        &self,
        bodies: &[Body],
        geoms_of: Vec<Vec<GeomRead>>,
        placed: &[Placed],
        seg_frame: &[(usize, Matrix4<f64>)],
    ) -> (UrdfGeometry, Vec<String>) {
        let mut geometry = UrdfGeometry {
            file: self.file.to_path_buf(),
            links: BTreeMap::new(),
        };
        let mut folded = Vec::new();
        for ((bi, b), geoms) in bodies.iter().enumerate().zip(geoms_of) {
            let p = &placed[bi];
            let (body, in_body) = match p.segment {
                Some(s) => (seg_frame[s].0, seg_frame[s].1 * p.in_segment),
                None => (0, p.in_segment),
            };
            if !b
                .node
                .children()
                .any(|c| c.is_element() && c.tag_name().name() == "joint")
            {
                folded.push(b.name.clone());
            }
            let mut link = LinkGeometry {
                body,
                in_body,
                visual: Vec::new(),
                collision: Vec::new(),
            };
            for g in geoms {
                let Some(geometry) = g.geometry else { continue };
                let line = self.doc.text_pos_at(g.node.range().start).row;
                let shape = Shape {
                    name: Some(g.name),
                    origin: g.frame,
                    geometry,
                    material: Some(Material {
                        name: None,
                        rgba: Some(g.rgba.unwrap_or([0.5, 0.5, 0.5, 1.0])),
                        texture: None,
                    }),
                    line,
                };
                if g.collides {
                    link.collision.push(Shape {
                        material: None,
                        ..shape.clone()
                    });
                }
                link.visual.push(shape);
            }
            geometry.links.insert(b.name.clone(), link);
        }
        (geometry, folded)
    }

    /// `<equality><joint joint1 joint2 polycoef>` — MuJoCo's form of a mimic joint,
    /// `y − y₀ = a₀ + a₁ (x − x₀)` (y = joint1, x = joint2, y₀ and x₀ their `ref`) — as a
    /// coupling: joint1 follows joint2 with multiplier a₁ and offset `y₀ + a₀ − a₁ x₀`, or is
    /// fixed at `y₀ + a₀` without joint2 or when joint2 is held (not a coordinate of the
    /// import: then x = x₀). Imposed exactly (MuJoCo enforces it softly, through solref and
    /// solimp). Noted and not imposed: an inactive one (`active="false"`), a polynomial
    /// (a₂…a₄ not zero), one whose joint1 is held. A joint name that is not a joint is refused.
    fn equality_joints(
        &mut self,
        joints: &[UrdfJoint],
        refs: &HashMap<String, f64>,
    ) -> Result<(Vec<UrdfMimic>, Option<Coupling>), MjcfError> {
        let (mut mimics, mut relations, mut nodes) = (Vec::new(), Vec::new(), Vec::new());
        let index = |n: &str| joints.iter().position(|j| j.name == n);
        let equalities: Vec<roxmltree::Node> = self
            .root
            .children()
            .filter(|c| c.is_element() && c.tag_name().name() == "equality")
            .flat_map(|e| {
                e.children()
                    .filter(|c| c.is_element() && c.tag_name().name() == "joint")
            })
            .collect();
        for e in equalities {
            let element = format!(
                "<equality>/<joint{}>",
                e.attribute("name")
                    .map_or(String::new(), |n| format!(" name={n:?}"))
            );
            let Some(j1) = e.attribute("joint1") else {
                return Err(self.err(
                    e,
                    &element,
                    MjcfErrorKind::BadValue {
                        attribute: "joint1".into(),
                        value: String::new(),
                        expected: "the name of the joint it constrains",
                    },
                ));
            };
            let j2 = e.attribute("joint2");
            for n in std::iter::once(j1).chain(j2) {
                if !refs.contains_key(n) {
                    return Err(self.err(e, &element, MjcfErrorKind::UnknownJoint(n.to_string())));
                }
            }
            let active = match e.attribute("active") {
                None => true,
                Some(v) => self.boolean(e, &element, "active", v)?,
            };
            let poly = match e.attribute("polycoef") {
                None => vec![0.0, 1.0, 0.0, 0.0, 0.0],
                Some(t) => self.numbers(e, &element, "polycoef", t, 5)?,
            };
            let follower = index(j1);
            let why_not = if !active {
                Some("inactive")
            } else if poly[2..].iter().any(|&a| a != 0.0) {
                Some("a polynomial: only a linear coupling is a mimic joint")
            } else if follower.is_none() {
                Some("joint1 is held (not a coordinate of this import)")
            } else {
                None
            };
            if let Some(why) = why_not {
                self.notes
                    .push(format!("{element} ({j1:?}) not imposed: {why}"));
                continue;
            }
            let Some(follower) = follower else { continue };
            let (y0, a0, a1) = (refs[j1], poly[0], poly[1]);
            let leader = j2.and_then(index);
            let (multiplier, offset) = match (leader, j2) {
                (Some(_), Some(j2)) => (a1, y0 + a0 - a1 * refs[j2]),
                _ => (a1, y0 + a0),
            };
            self.notes.push(match (leader, j2) {
                (Some(_), Some(j2)) => format!(
                    "{element}: joint {j1:?} follows {j2:?} (×{multiplier} + {offset}) in the coupling, exactly (MuJoCo enforces it softly)"
                ),
                _ => format!(
                    "{element}: joint {j1:?} is fixed at {offset} in the coupling (no joint2, or joint2 held at its ref)"
                ),
            });
            relations.push(Mimic {
                follower,
                leader,
                multiplier,
                offset,
            });
            nodes.push((e, element));
            mimics.push(UrdfMimic {
                joint: j1.to_string(),
                index: follower,
                mimicked: j2.unwrap_or_default().to_string(),
                mimicked_index: leader,
                multiplier,
                offset,
            });
        }
        if relations.is_empty() {
            return Ok((mimics, None));
        }
        let coupling = Coupling::new(joints.len(), &relations).map_err(|e| {
            let at = match &e {
                MimicError::Cycle(i) | MimicError::TwoLeaders(i) => {
                    relations.iter().position(|r| r.follower == *i).unwrap_or(0)
                }
                _ => 0,
            };
            let (node, element) = &nodes[at];
            self.err(*node, element, MjcfErrorKind::Mimic(e))
        })?;
        Ok((mimics, Some(coupling)))
    }
}

#[cfg(test)]
mod floating_tests {
    use super::*;

    /// A `<freejoint>` on the worldbody's first body is the robot's free-flyer root, the same
    /// robot as the URDF with a `floating` joint on its root link (base, root inertial, FK); a
    /// free joint deeper down is refused by name.
    #[test]
    fn a_free_joint_on_the_first_body_is_the_floating_base() {
        let mjcf = r#"<mujoco model="m"><worldbody>
  <body name="base" pos="0 0 0.5">
    <freejoint name="root"/>
    <inertial pos="0.1 0 0" mass="2" diaginertia="0.01 0.02 0.03"/>
    <body name="l1" pos="1 0 0">
      <joint name="j2" type="hinge" axis="0 0 1"/>
      <inertial pos="0 0.2 0" mass="1" diaginertia="0.01 0.01 0.01"/>
    </body>
  </body></worldbody></mujoco>"#;
        let urdf = r#"<robot name="m"><link name="world"/>
  <link name="base"><inertial><origin xyz="0.1 0 0"/><mass value="2"/>
    <inertia ixx="0.01" iyy="0.02" izz="0.03" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="l1"><inertial><origin xyz="0 0.2 0"/><mass value="1"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="root" type="floating"><parent link="world"/><child link="base"/>
    <origin xyz="0 0 0.5"/></joint>
  <joint name="j2" type="continuous"><parent link="base"/><child link="l1"/>
    <origin xyz="1 0 0"/><axis xyz="0 0 1"/></joint></robot>"#;
        let m = import_mjcf_tree_str(mjcf, Path::new("m.xml")).expect("mjcf");
        let u = crate::urdf_import::import_urdf_tree_str(urdf, Path::new("m.urdf")).expect("urdf");
        let (rm, ru) = (&m.robot, &u.robot);
        assert_eq!(rm.root.as_ref().map(|r| r.kind), Some(RootKind::FreeFlyer));
        assert_eq!((rm.nq(), rm.nv()), (8, 7));
        let (a, b) = (
            rm.root.as_ref().expect("root"),
            ru.root.as_ref().expect("root"),
        );
        assert!((a.mass - b.mass).abs() < 1e-15 && (a.com - b.com).norm() < 1e-15);
        assert!((a.inertia - b.inertia).abs().max() < 1e-15);
        assert!((rm.base - ru.base).abs().max() < 1e-15);
        let mut q = rm.neutral_q();
        let v = [0.3, -0.2, 0.1, 0.5, -0.4, 0.8];
        let q0 = q.clone();
        RootKind::FreeFlyer.integrate(&q0.as_slice()[..7], &v, 1.0, &mut q.as_mut_slice()[..7]);
        q[7] = 0.7;
        for link in 0..=1 {
            let (pm, pu) = (
                robosim_kinematics::fk::link_pose(rm, q.as_slice(), link),
                robosim_kinematics::fk::link_pose(ru, q.as_slice(), link),
            );
            assert!((pm - pu).abs().max() < 1e-14, "link {link}: {pm} vs {pu}");
        }
        assert!((rm.joints[0].com - ru.joints[0].com).norm() < 1e-15);
        let deeper = mjcf.replace(r#"<freejoint name="root"/>"#, "").replace(
            r#"<joint name="j2" type="hinge" axis="0 0 1"/>"#,
            r#"<freejoint name="j2"/>"#,
        );
        let e = import_mjcf_tree_str(&deeper, Path::new("m.xml")).expect_err("refused");
        assert!(
            matches!(e.kind, MjcfErrorKind::UnsupportedJoint { .. }),
            "{e}"
        );
    }
}
