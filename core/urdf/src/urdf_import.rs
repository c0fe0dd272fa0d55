//! URDF import (issue #14, first part): a URDF file read into robosim's one joint model
//! (`robosim_kinematics`, module `model`: `A_j = P_j · M_j(q_j) · T_j`) as a serial chain from
//! the URDF's root link to a chosen tip link. Entry points: [`import_urdf`] (a file),
//! [`import_urdf_str`] (text with a name to report it under).
//!
//! What is read: `<link>` with its `<inertial>` (`<origin xyz rpy>`, `<mass value>`,
//! `<inertia ixx ixy ixz iyy iyz izz>`: the tensor about the centre of mass in the axes the
//! inertial origin's rpy names; a slightly negative principal moment is a warning, see
//! [`NEGATIVE_INERTIA_TOLERANCE`]); `<joint>` of type revolute, continuous, prismatic or fixed with
//! `<origin xyz rpy>` (URDF's fixed-axis roll–pitch–yaw, `R = Rz(y) Ry(p) Rx(r)`; absent =
//! identity), `<axis xyz>` (absent = x, normalised as urdfdom does; not read on a fixed joint,
//! as urdfdom does not), `<limit lower upper effort
//! velocity>` (required for revolute and prismatic joints, as the URDF spec says),
//! `<dynamics damping friction>` (viscous, Coulomb) and `<mimic joint multiplier offset>` (below).
//!
//! The chain: q is the movable joints from the root to `tip`, in order; a continuous joint is
//! one angle with limits ±∞; fixed joints on the chain are folded
//! ([`robosim_kinematics::chain`]). Every joint **off** the chain is held at q = 0 and what it
//! carries is rigid with the link it hangs from: its inertial is lumped into that link. The
//! robot's base frame is the root link's frame (base = identity), link frame j is the child
//! link frame of movable joint j, the tool is the tip link's frame; gravity (0, 0, −9.81).
//!
//! Mimic joints: [`ImportedRobot::robot`] is the **full** model, every movable joint a coordinate
//! (Pinocchio's `buildModel(…, mimic=False)`), so everything that takes a `Robot` works on it
//! unchanged; [`ImportedRobot::coupling`] binds each follower to its leader
//! (`q_f = multiplier · q_leader + offset`, one coordinate for both: Pinocchio's
//! `mimic=True`), for the algorithms over the reduced coordinates
//! (`robosim_kinematics::mimic`, `robosim_dynamics::mimic`). On a chain import, a follower on
//! the chain whose leader is off it (held at 0) is fixed at its offset in the coupling; a
//! follower off the chain is held at 0 with its subtree like every off-chain joint, even when
//! its leader is on the chain (noted). [`import_urdf_with_followers`] (the query protocol's
//! `{"urdf", "tip", "mimic": true}`) makes such followers move: the chain plus branches for
//! them, a tree whose reduced coordinates are the chain's.
//!
//! Geometry: `<visual>`, `<collision>` and `<material>` are read into [`ImportedRobot::geometry`]
//! by [`crate::urdf_geometry`]; meshes are only named there and loaded when an operation needs
//! them (FK and dynamics do not). Not read: `<transmission>`, `<gazebo>`, safety controllers,
//! calibration. Floating bases: a `floating` (free-flyer) or `planar` joint as the root link's
//! one joint becomes [`Robot::root`] (its origin the robot's `base`; a planar joint's axis is
//! not read: Pinocchio's moves in its frame's x–y plane), elsewhere it is refused;
//! [`import_urdf_tree_floating`] gives a file's root link a free base (`--floating`). Refused:
//! xacro files, and every
//! malformed input (see [`UrdfErrorKind`]); each error names the file, the line (roxmltree's
//! positions) and the element.

pub use crate::urdf_xml::{Reader, UrdfError, UrdfErrorKind, child, rpy_matrix};

use nalgebra::{Matrix3, Matrix4, SymmetricEigen, Vector3};
use robosim_kinematics::chain::{Inertial, Segment, SegmentKind, build_chain, build_tree};
use robosim_kinematics::mimic::{Coupling, Mimic, MimicError};
use robosim_kinematics::{Robot, RootKind};
use std::collections::{HashMap, HashSet};
use std::path::Path;

/// Per movable joint of the chain: the URDF's names and the limits robosim's model does not
/// hold (effort and velocity; 0 or absent in the file = unknown, given as ∞).
#[derive(Debug, Clone, PartialEq)]
pub struct UrdfJoint {
    pub name: String,
    /// The child link (link frame j).
    pub link: String,
    /// `continuous` in the file (q unbounded).
    pub continuous: bool,
    /// Maximum effort, N·m or N.
    pub effort: f64,
    /// Maximum velocity, rad/s or m/s.
    pub velocity: f64,
}

/// An imported robot, chain or tree (see the module docs), as the URDF and the MJCF readers
/// return it; `robosim_model::Model::from_imported` turns it into the one robot model, its
/// geometry converted once.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportedRobot {
    /// The chain in the one joint model, validated.
    pub robot: Robot,
    pub root: String,
    pub tip: String,
    /// The movable joints, in q order.
    pub joints: Vec<UrdfJoint>,
    /// The fixed joints folded into the chain, root to tip.
    pub folded: Vec<String>,
    /// Joints off the chain (held at 0, their links lumped).
    pub held: Vec<String>,
    /// What was read but not used (a mimic joint held off the chain, …), one sentence each.
    pub notes: Vec<String>,
    /// The movable joints' parent links, in q order (for a chain, the previous joint's child
    /// link; for a tree, [`Robot::parents`] by link name).
    pub parent_links: Vec<String>,
    /// The `<mimic>` joints among the movable joints of the robot (a tree's finger joint): each
    /// is a coordinate of [`ImportedRobot::robot`], as in Pinocchio's default model
    /// (`buildModel(…, mimic=False)`); [`ImportedRobot::coupling`] imposes the relations.
    pub mimics: Vec<UrdfMimic>,
    /// The mimic relations as a map from the reduced coordinates (leaders and every other free
    /// joint) to the robot's q — Pinocchio's `mimic=True` model over the same robot
    /// (`robosim_kinematics::mimic`). `None`: no movable joint mimics another.
    pub coupling: Option<robosim_kinematics::mimic::Coupling>,
    /// Visual and collision geometry of every link, keyed by link name (meshes not loaded:
    /// [`crate::urdf_geometry`]).
    pub geometry: crate::urdf_geometry::UrdfGeometry,
}

/// The importer's robot under its first name (it is the MJCF reader's too).
pub type UrdfRobot = ImportedRobot;

/// A `<mimic>` relation `q[joint] = multiplier · q[mimicked] + offset` (imposed by
/// [`ImportedRobot::coupling`]).
#[derive(Debug, Clone, PartialEq)]
pub struct UrdfMimic {
    /// The mimicking joint's name and its index in q.
    pub joint: String,
    pub index: usize,
    /// The joint it follows (its name as in the file) and its index in q (`None`: not a
    /// coordinate of this import — a fixed joint, or off the chain and held at 0 — so the
    /// follower is fixed at `offset`).
    pub mimicked: String,
    pub mimicked_index: Option<usize>,
    pub multiplier: f64,
    pub offset: f64,
}

/// Reads the URDF at `path` and builds the chain from its root link to `tip` (`None`: the only
/// leaf link, when there is exactly one).
pub fn import_urdf(path: &Path, tip: Option<&str>) -> Result<ImportedRobot, UrdfError> {
    let text = read_urdf_file(path)?;
    import_urdf_str(&text, path, tip)
}

/// Reads the URDF at `path` as a kinematic **tree**: every movable joint of the file is a
/// coordinate (depth first from the root link, children in file order), [`Robot::parents`]
/// says which link each hangs from, fixed joints are folded into the movable joint (or root)
/// above them, inertia rigid with the root is dropped (it cannot move). `<mimic>` joints are
/// coordinates of the robot, bound to their leaders by [`ImportedRobot::coupling`]. The robot's
/// tool is the identity
/// on the last joint's child link, which [`ImportedRobot::tip`] names; [`ImportedRobot::held`] is
/// empty.
pub fn import_urdf_tree(path: &Path) -> Result<ImportedRobot, UrdfError> {
    let text = read_urdf_file(path)?;
    import_urdf_tree_str(&text, path)
}

/// The URDF file's text, read by [`robosim_input::read_to_string`]: a regular file of at most
/// [`robosim_input::Limit::TEXT`] (a FIFO, a device or a larger file is refused by name).
fn read_urdf_file(path: &Path) -> Result<String, UrdfError> {
    robosim_input::read_to_string(path, "a URDF file", robosim_input::Limit::TEXT).map_err(|e| {
        UrdfError {
            file: path.to_path_buf(),
            line: 0,
            element: "file".into(),
            kind: UrdfErrorKind::Io(e.reason()),
        }
    })
}

/// [`import_urdf_tree`] on text already read; `file` names it in errors.
pub fn import_urdf_tree_str(text: &str, file: &Path) -> Result<ImportedRobot, UrdfError> {
    import_impl(text, file, None, Shape::Tree, None)
}

/// [`import_urdf_tree`] with a floating base (`robosim import urdf --floating`): a root joint
/// of `kind` between the world and the root link, which becomes link frame 0 and carries the
/// root link's inertial with everything fixed to it (Pinocchio's
/// `buildModel(urdf, JointModelFreeFlyer())`). A file whose root link already hangs from a
/// `floating` or `planar` joint keeps that one.
pub fn import_urdf_tree_floating(path: &Path, kind: RootKind) -> Result<ImportedRobot, UrdfError> {
    let text = read_urdf_file(path)?;
    import_urdf_tree_floating_str(&text, path, kind)
}

/// [`import_urdf_tree_floating`] on text already read; `file` names it in errors.
pub fn import_urdf_tree_floating_str(
    text: &str,
    file: &Path,
    kind: RootKind,
) -> Result<ImportedRobot, UrdfError> {
    import_impl(text, file, None, Shape::Tree, Some(kind))
}

/// A `floating` or `planar` joint must be the root link's one child (robosim's floating base
/// is the root joint of the tree; Pinocchio allows one anywhere).
fn check_root_joint(rd: &Reader, root: &str, joints: &[JointRec]) -> Result<(), UrdfError> {
    for j in joints {
        if !matches!(j.kind, SegmentKind::Root(_)) {
            continue;
        }
        let siblings = joints.iter().filter(|o| o.parent == root).count();
        if j.parent != root || siblings != 1 {
            let kind = match j.kind {
                SegmentKind::Root(RootKind::Planar) => "planar",
                _ => "floating",
            };
            return Err(UrdfError {
                file: rd.file.to_path_buf(),
                line: j.line,
                element: format!("<joint name={:?}>", j.name),
                kind: UrdfErrorKind::UnsupportedJointType(format!(
                    "{kind} (only as the one joint of the root link {root:?}: a floating base)"
                )),
            });
        }
    }
    Ok(())
}

struct LinkRec {
    line: u32,
    inertial: Inertial,
}

/// How far below zero a link's smallest principal moment may be, relative to the largest
/// principal moment of any link of the robot, and still be taken as rounding in the published
/// file: accepted as written with a warning (Pinocchio and urdfdom check nothing). 1e-6 of the
/// robot's scale is below the 4–6 significant digits published inertias carry, so it changes
/// no torque beyond the file's own precision; TIAGo's 1 mg antenna links (−3.5e-8 kg·m²
/// against the robot's 0.55 kg·m², 6.4e-8) pass, romeo_laas_small's trunk (−0.021 kg·m²
/// against 0.099, 0.22: not a rigid body) does not. docs/file-io.md, URDF section.
pub const NEGATIVE_INERTIA_TOLERANCE: f64 = 1e-6;

/// A link's `<inertial>` as read, with what [`check_inertias`] needs.
struct LinkInertial {
    inertial: Inertial,
    /// The largest principal moment of the file's `<inertia>` (kg·m²; 0 without one).
    largest: f64,
    /// A negative smallest principal moment beyond round-off of its own entries.
    negative: Option<NegativeMoment>,
}

/// A negative principal moment: where (the `<inertia>` element) and how much (kg·m²).
struct NegativeMoment {
    line: u32,
    element: String,
    min: f64,
}

/// Accepts each negative principal moment within [`NEGATIVE_INERTIA_TOLERANCE`] of the robot's
/// largest (a warning naming the link and the value, for [`ImportedRobot::notes`]) and refuses the
/// first beyond it ([`UrdfErrorKind::InertiaNotPsd`] at its `<inertia>` element).
fn check_inertias(
    file: &Path,
    negative: &[(String, NegativeMoment)],
    largest: f64,
) -> Result<Vec<String>, UrdfError> {
    let mut warnings = Vec::new();
    for (link, n) in negative {
        if n.min < -NEGATIVE_INERTIA_TOLERANCE * largest || largest == 0.0 {
            return Err(UrdfError {
                file: file.to_path_buf(),
                line: n.line,
                element: n.element.clone(),
                kind: UrdfErrorKind::InertiaNotPsd(n.min),
            });
        }
        warnings.push(format!(
            "warning: link {link:?}: inertia has a negative principal moment {:e} kg·m², within {NEGATIVE_INERTIA_TOLERANCE:e} of the robot's largest ({largest:e} kg·m²): taken as rounding in the file and used as written",
            n.min
        ));
    }
    Ok(warnings)
}

#[derive(Clone)]
struct JointRec {
    name: String,
    line: u32,
    kind: SegmentKind,
    parent: String,
    child: String,
    placement: Matrix4<f64>,
    axis: Vector3<f64>,
    qlim: [f64; 2],
    effort: f64,
    velocity: f64,
    viscous: f64,
    coulomb: f64,
    mimic: bool,
    /// `<mimic joint multiplier offset>`: (joint, multiplier, offset).
    mimic_of: Option<(String, f64, f64)>,
}

impl JointRec {
    /// The joint as a chain or tree segment carrying `child`, the inertial of what it moves
    /// (its child link, with whatever is lumped into it): the one place every import (chain,
    /// chain with followers, whole tree) fills a [`Segment`] from a `<joint>`.
    fn segment(&self, child: Inertial) -> Segment {
        Segment {
            kind: self.kind,
            placement: self.placement,
            axis: self.axis,
            qlim: self.qlim,
            viscous: self.viscous,
            coulomb: self.coulomb,
            child,
        }
    }
}

/// The readers of a link's `<inertial>` and of a `<joint>` (the rest of [`Reader`] is in
/// urdf_xml.rs).
impl Reader<'_, '_> {
    /// A link's `<inertial>`; a negative principal moment is not judged here but returned
    /// ([`LinkInertial::negative`]): whether it is rounding depends on the whole robot's scale
    /// ([`check_inertias`]).
    fn inertial(&self, link: roxmltree::Node, element: &str) -> Result<LinkInertial, UrdfError> {
        let (mut largest, mut negative) = (0.0, None);
        let Some(node) = child(link, "inertial") else {
            return Ok(LinkInertial {
                inertial: Inertial::default(),
                largest,
                negative,
            });
        };
        let element = format!("{element}/<inertial>");
        let o = self.origin(node, &element)?;
        let mass_node = child(node, "mass")
            .ok_or_else(|| self.err(node, &element, UrdfErrorKind::MissingElement("mass")))?;
        let mass_el = format!("{element}/<mass>");
        let mass = self.number(mass_node, &mass_el, "value", None)?;
        if mass < 0.0 {
            return Err(self.err(mass_node, &mass_el, UrdfErrorKind::NegativeMass(mass)));
        }
        let inertia = match child(node, "inertia") {
            None => Matrix3::zeros(),
            Some(i) => {
                let el = format!("{element}/<inertia>");
                let g = |n| self.number(i, &el, n, Some(0.0));
                let (ixx, ixy, ixz, iyy, iyz, izz) = (
                    g("ixx")?,
                    g("ixy")?,
                    g("ixz")?,
                    g("iyy")?,
                    g("iyz")?,
                    g("izz")?,
                );
                let m = Matrix3::new(ixx, ixy, ixz, ixy, iyy, iyz, ixz, iyz, izz);
                let eig = SymmetricEigen::new(m).eigenvalues;
                let min = eig.min();
                if min < -1e-12 * (1.0 + m.abs().max()) {
                    negative = Some(NegativeMoment {
                        line: self.line(i),
                        element: el,
                        min,
                    });
                }
                largest = eig.max().max(0.0);
                m
            }
        };
        let r = o.fixed_view::<3, 3>(0, 0).into_owned();
        Ok(LinkInertial {
            inertial: Inertial {
                mass,
                com: o.fixed_view::<3, 1>(0, 3).into_owned(),
                inertia: r * inertia * r.transpose(),
            },
            largest,
            negative,
        })
    }

    fn joint(&self, node: roxmltree::Node) -> Result<JointRec, UrdfError> {
        let name = self.attr(node, "<joint>", "name")?.to_string();
        let element = format!("<joint name={name:?}>");
        let type_name = self.attr(node, &element, "type")?;
        let kind = match type_name {
            "revolute" => SegmentKind::Revolute,
            "continuous" => SegmentKind::Continuous,
            "prismatic" => SegmentKind::Prismatic,
            "fixed" => SegmentKind::Fixed,
            // a floating base: only on the root link (check_root_joint)
            "floating" => SegmentKind::Root(RootKind::FreeFlyer),
            "planar" => SegmentKind::Root(RootKind::Planar),
            other => {
                return Err(self.err(
                    node,
                    &element,
                    UrdfErrorKind::UnsupportedJointType(other.to_string()),
                ));
            }
        };
        let link_of = |tag: &'static str| -> Result<String, UrdfError> {
            let n = child(node, tag)
                .ok_or_else(|| self.err(node, &element, UrdfErrorKind::MissingElement(tag)))?;
            Ok(self
                .attr(n, &format!("{element}/<{tag}>"), "link")?
                .to_string())
        };
        let parent = link_of("parent")?;
        let child_link = link_of("child")?;
        let placement = self.origin(node, &element)?;
        // A fixed joint's axis is not read (urdfdom skips it, so Pinocchio and ROS do): Kinova's
        // and TALOS's files write `<axis xyz="0 0 0"/>` on fixed joints.
        // Nor a floating or planar joint's: Pinocchio's planar joint moves in its frame's x–y
        // plane whatever the axis says.
        let axis = match child(node, "axis")
            .filter(|_| !matches!(kind, SegmentKind::Fixed | SegmentKind::Root(_)))
        {
            None => Vector3::x(),
            Some(a) => {
                let el = format!("{element}/<axis>");
                let v = self.triple(a, &el, "xyz", [1.0, 0.0, 0.0])?;
                // Normalised without overflow or underflow: `[1e200, 0, 0]` is the x axis.
                if v.norm() == 1.0 {
                    v
                } else {
                    robosim_geometry::unit_axis(v)
                        .ok_or_else(|| self.err(a, &el, UrdfErrorKind::ZeroAxis))?
                        .into_inner()
                }
            }
        };
        let limit = child(node, "limit");
        let el = format!("{element}/<limit>");
        let (mut qlim, mut effort, mut velocity) = ([f64::NEG_INFINITY, f64::INFINITY], 0.0, 0.0);
        if let Some(l) = limit {
            effort = self.number(l, &el, "effort", Some(0.0))?;
            velocity = self.number(l, &el, "velocity", Some(0.0))?;
            if matches!(kind, SegmentKind::Revolute | SegmentKind::Prismatic) {
                qlim = [
                    self.number(l, &el, "lower", Some(0.0))?,
                    self.number(l, &el, "upper", Some(0.0))?,
                ];
                if qlim[0] > qlim[1] {
                    return Err(self.err(l, &el, UrdfErrorKind::ReversedLimits(qlim[0], qlim[1])));
                }
            }
        } else if matches!(kind, SegmentKind::Revolute | SegmentKind::Prismatic) {
            return Err(self.err(node, &element, UrdfErrorKind::MissingElement("limit")));
        }
        let unknown = |x: f64| if x > 0.0 { x } else { f64::INFINITY };
        let (viscous, coulomb) = match child(node, "dynamics") {
            None => (0.0, 0.0),
            Some(d) => {
                let el = format!("{element}/<dynamics>");
                (
                    self.number(d, &el, "damping", Some(0.0))?,
                    self.number(d, &el, "friction", Some(0.0))?,
                )
            }
        };
        Ok(JointRec {
            line: self.line(node),
            kind,
            parent,
            child: child_link,
            placement,
            axis,
            qlim,
            effort: unknown(effort),
            velocity: unknown(velocity),
            viscous,
            coulomb,
            mimic: child(node, "mimic").is_some(),
            mimic_of: match child(node, "mimic") {
                None => None,
                Some(m) => {
                    let el = format!("{element}/<mimic>");
                    Some((
                        self.attr(m, &el, "joint")?.to_string(),
                        self.number(m, &el, "multiplier", Some(1.0))?,
                        self.number(m, &el, "offset", Some(0.0))?,
                    ))
                }
            },
            name,
        })
    }
}

/// A parse error of the XML itself: the line and column where the parser stopped, and the tag
/// when the parser names one (a close tag that does not match). A file that ends inside its
/// root element is reported at its last line (roxmltree says 1:1 for that).
fn xml_error(text: &str, file: &Path, e: roxmltree::Error) -> UrdfError {
    let pos = e.pos();
    let (line, element) = match &e {
        roxmltree::Error::UnexpectedCloseTag(_, actual, _) => {
            (pos.row, format!("</{actual}> (column {})", pos.col))
        }
        roxmltree::Error::UnclosedRootNode => (
            u32::try_from(text.lines().count().max(1)).unwrap_or(u32::MAX),
            "end of file".to_string(),
        ),
        _ => (pos.row, format!("column {}", pos.col)),
    };
    UrdfError {
        file: file.to_path_buf(),
        line,
        element,
        kind: UrdfErrorKind::Xml(e.to_string()),
    }
}

/// Refuses XML nested deeper than [`robosim_input::MAX_XML_DEPTH`] before roxmltree, which
/// recurses once per level, sees it.
fn check_depth(text: &str, file: &Path) -> Result<(), UrdfError> {
    robosim_input::xml_depth(text, robosim_input::MAX_XML_DEPTH).map_err(|e| UrdfError {
        file: file.to_path_buf(),
        line: e.line,
        element: "XML".into(),
        kind: UrdfErrorKind::TooDeep(e),
    })
}

/// [`import_urdf`] on text already read; `file` names it in errors.
pub fn import_urdf_str(
    text: &str,
    file: &Path,
    tip: Option<&str>,
) -> Result<ImportedRobot, UrdfError> {
    import_impl(text, file, tip, Shape::Chain, None)
}

/// [`import_urdf`] with the chain's **off-chain mimic followers moving**: the chain from the
/// root link to `tip`, plus — as branches of a tree ([`Robot::parents`]) — every joint off the
/// chain that `<mimic>`s a movable chain joint (directly or through other followers) and hangs
/// from the chain through fixed joints or other such followers: a gripper's second finger on a
/// chain to the first. Each such follower is a coordinate of the full model, bound to its
/// leader by [`ImportedRobot::coupling`], so over the coupling's reduced coordinates (the
/// chain's free joints, the same q as [`import_urdf`]'s without the chain's own followers) its
/// link frames move with the leader and its mass moves in the dynamics, where [`import_urdf`]
/// holds it at 0, lumped into the link it hangs from. Everything else off the chain is held at
/// 0 as there, and so is a follower hanging beyond the chain's last movable joint (its link
/// frame would have to come after the tool's; noted). Without any follower to move, the robot
/// is [`import_urdf`]'s, bit for bit.
pub fn import_urdf_with_followers(
    path: &Path,
    tip: Option<&str>,
) -> Result<ImportedRobot, UrdfError> {
    let text = read_urdf_file(path)?;
    import_impl(&text, path, tip, Shape::ChainWithFollowers, None)
}

/// What an import builds: the chain to the tip (its off-chain joints held at 0), the chain with
/// its off-chain mimic followers as moving branches, or the whole tree.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Shape {
    Chain,
    ChainWithFollowers,
    Tree,
}

/// The import, as named steps: read and check the document, read its links and joints, check
/// they form one tree, then build either the whole tree or the chain to the tip.
fn import_impl(
    text: &str,
    file: &Path,
    tip: Option<&str>,
    shape: Shape,
    floating: Option<RootKind>,
) -> Result<ImportedRobot, UrdfError> {
    check_depth(text, file)?;
    let doc = roxmltree::Document::parse(text).map_err(|e| xml_error(text, file, e))?;
    let rd = Reader { file, doc: &doc };
    let root_el = doc.root_element();
    let robot_name = robot_name(&rd, root_el)?;
    let at_robot = RobotElement {
        rd: &rd,
        node: root_el,
        name: &robot_name,
    };
    let geometry = crate::urdf_geometry::read_all(&rd, root_el)?;
    let parts = read_links_and_joints(&rd, root_el)?;
    let links_tree = LinkTree::check(&at_robot, &parts)?;
    check_root_joint(&rd, &links_tree.root, &parts.joints)?;
    let mut robot = if shape == Shape::Tree {
        build_whole_tree(
            file,
            &rd,
            root_el,
            &robot_name,
            &links_tree.root,
            &parts.links,
            &parts.joints,
            &links_tree.children,
            geometry,
            floating,
        )?
    } else {
        let tip = find_tip(&at_robot, tip, &parts, &links_tree)?;
        let followers = shape == Shape::ChainWithFollowers;
        build_chain_to_tip(&at_robot, &parts, &links_tree, tip, geometry, followers)?
    };
    robot.notes.splice(0..0, parts.warnings.iter().cloned());
    Ok(robot)
}

/// The `<robot>` element, for errors that concern the whole robot.
struct RobotElement<'r, 'a, 'input, 'n> {
    rd: &'r Reader<'a, 'input>,
    node: roxmltree::Node<'n, 'input>,
    name: &'r str,
}

impl RobotElement<'_, '_, '_, '_> {
    fn err(&self, kind: UrdfErrorKind) -> UrdfError {
        UrdfError {
            file: self.rd.file.to_path_buf(),
            line: self.rd.line(self.node),
            element: format!("<robot name={:?}>", self.name),
            kind,
        }
    }
}

/// The robot's name, after refusing an unprocessed xacro file and a root that is not `<robot>`.
fn robot_name(rd: &Reader, root_el: roxmltree::Node) -> Result<String, UrdfError> {
    // Processed URDFs often still declare xmlns:xacro (the UR files do): only elements in the
    // xacro namespace mark an unprocessed file.
    let is_xacro = root_el.descendants().any(|n| {
        n.is_element()
            && n.tag_name()
                .namespace()
                .is_some_and(|u| u.contains("xacro"))
    });
    if is_xacro {
        return Err(rd.err(root_el, "<robot>", UrdfErrorKind::Xacro));
    }
    if root_el.tag_name().name() != "robot" {
        return Err(rd.err(
            root_el,
            &format!("<{}>", root_el.tag_name().name()),
            UrdfErrorKind::NotARobot(root_el.tag_name().name().to_string()),
        ));
    }
    Ok(root_el.attribute("name").unwrap_or("urdf").to_string())
}

/// The `<link>` and `<joint>` elements of a robot, in file order.
struct Parts {
    links: HashMap<String, LinkRec>,
    link_order: Vec<String>,
    joints: Vec<JointRec>,
    /// Accepted oddities of the file, one sentence each (for [`ImportedRobot::notes`]).
    warnings: Vec<String>,
}

/// Reads every `<link>` (its inertial) and `<joint>`; a name used twice is refused.
fn read_links_and_joints(rd: &Reader, root_el: roxmltree::Node) -> Result<Parts, UrdfError> {
    let mut links: HashMap<String, LinkRec> = HashMap::new();
    let mut link_order: Vec<String> = Vec::new();
    let mut joints: Vec<JointRec> = Vec::new();
    let mut joint_names: HashSet<String> = HashSet::new();
    let (mut largest, mut negative) = (0.0_f64, Vec::new());
    for node in root_el.children().filter(|n| n.is_element()) {
        match node.tag_name().name() {
            "link" => {
                let name = rd.attr(node, "<link>", "name")?.to_string();
                let element = format!("<link name={name:?}>");
                if links.contains_key(&name) {
                    return Err(rd.err(node, &element, UrdfErrorKind::DuplicateName(name)));
                }
                let LinkInertial {
                    inertial,
                    largest: l,
                    negative: neg,
                } = rd.inertial(node, &element)?;
                largest = largest.max(l);
                if let Some(n) = neg {
                    negative.push((name.clone(), n));
                }
                links.insert(
                    name.clone(),
                    LinkRec {
                        line: rd.line(node),
                        inertial,
                    },
                );
                link_order.push(name);
            }
            "joint" => {
                let j = rd.joint(node)?;
                if !joint_names.insert(j.name.clone()) {
                    let el = format!("<joint name={:?}>", j.name);
                    return Err(rd.err(node, &el, UrdfErrorKind::DuplicateName(j.name)));
                }
                joints.push(j);
            }
            _ => {}
        }
    }
    let warnings = check_inertias(rd.file, &negative, largest)?;
    Ok(Parts {
        links,
        link_order,
        joints,
        warnings,
    })
}

/// An error at joint `j`'s element.
fn joint_err(file: &Path, j: &JointRec, kind: UrdfErrorKind) -> UrdfError {
    UrdfError {
        file: file.to_path_buf(),
        line: j.line,
        element: format!("<joint name={:?}>", j.name),
        kind,
    }
}

/// The links as a tree: each link's parent joint, each link's child joints (file order), and
/// the one root.
struct LinkTree<'p> {
    parent_joint: HashMap<&'p str, usize>,
    children: HashMap<&'p str, Vec<usize>>,
    root: String,
}

impl<'p> LinkTree<'p> {
    /// Checks that every joint's links exist, no link has two parents, there is one root, and
    /// every link is reached from it (one that is not sits on a cycle).
    fn check(at_robot: &RobotElement, parts: &'p Parts) -> Result<Self, UrdfError> {
        let file = at_robot.rd.file;
        let (links, joints) = (&parts.links, &parts.joints);
        let mut parent_joint: HashMap<&str, usize> = HashMap::new();
        let mut children: HashMap<&str, Vec<usize>> = HashMap::new();
        for (k, j) in joints.iter().enumerate() {
            for (role, link) in [("parent", &j.parent), ("child", &j.child)] {
                if !links.contains_key(link) {
                    return Err(joint_err(
                        file,
                        j,
                        UrdfErrorKind::MissingLink {
                            role,
                            link: link.clone(),
                        },
                    ));
                }
            }
            if let Some(&first) = parent_joint.get(j.child.as_str()) {
                return Err(joint_err(
                    file,
                    j,
                    UrdfErrorKind::TwoParents {
                        link: j.child.clone(),
                        first: joints[first].name.clone(),
                    },
                ));
            }
            parent_joint.insert(&j.child, k);
            children.entry(&j.parent).or_default().push(k);
        }
        let roots: Vec<&String> = parts
            .link_order
            .iter()
            .filter(|l| !parent_joint.contains_key(l.as_str()))
            .collect();
        let root = match roots.as_slice() {
            [] => return Err(at_robot.err(UrdfErrorKind::NoRoot)),
            [r] => (*r).clone(),
            [a, b, ..] => {
                return Err(UrdfError {
                    file: file.to_path_buf(),
                    line: links[b.as_str()].line,
                    element: format!("<link name={b:?}>"),
                    kind: UrdfErrorKind::TwoRoots((*a).clone(), (*b).clone()),
                });
            }
        };
        let mut reached: HashSet<&str> = HashSet::new();
        let mut stack = vec![root.as_str()];
        while let Some(l) = stack.pop() {
            reached.insert(l);
            for &k in children.get(l).map_or(&[][..], |v| v.as_slice()) {
                stack.push(&joints[k].child);
            }
        }
        if let Some(l) = parts
            .link_order
            .iter()
            .find(|l| !reached.contains(l.as_str()))
        {
            let j = &joints[parent_joint[l.as_str()]];
            return Err(joint_err(file, j, UrdfErrorKind::Cycle(l.clone())));
        }
        Ok(LinkTree {
            parent_joint,
            children,
            root,
        })
    }
}

/// The tip link: the one asked for (it must be a link), else the only leaf.
fn find_tip(
    at_robot: &RobotElement,
    tip: Option<&str>,
    parts: &Parts,
    tree: &LinkTree,
) -> Result<String, UrdfError> {
    match tip {
        Some(t) => {
            if !parts.links.contains_key(t) {
                return Err(at_robot.err(UrdfErrorKind::TipNotALink(t.to_string())));
            }
            Ok(t.to_string())
        }
        None => {
            let leaves: Vec<&String> = parts
                .link_order
                .iter()
                .filter(|l| !tree.children.contains_key(l.as_str()))
                .collect();
            if leaves.len() != 1 {
                return Err(at_robot.err(UrdfErrorKind::AmbiguousTip(
                    leaves.len(),
                    leaves
                        .iter()
                        .map(|s| s.as_str())
                        .collect::<Vec<_>>()
                        .join(", "),
                )));
            }
            Ok(leaves[0].clone())
        }
    }
}

/// The joints from the root to `tip`, root first.
fn chain_to(tip: &str, tree: &LinkTree, joints: &[JointRec]) -> Vec<usize> {
    let mut chain: Vec<usize> = Vec::new();
    let mut l = tip;
    while let Some(&k) = tree.parent_joint.get(l) {
        chain.push(k);
        l = joints[k].parent.as_str();
    }
    chain.reverse();
    chain
}

/// The inertial of `link` with its subtree at q = 0, skipping the joints in `skip`; the joints
/// folded in are appended to `held`.
fn subtree(
    link: &str,
    joints: &[JointRec],
    links: &HashMap<String, LinkRec>,
    children: &HashMap<&str, Vec<usize>>,
    skip: &HashSet<usize>,
    held: &mut Vec<usize>,
) -> Inertial {
    let mut total = links[link].inertial;
    for &k in children.get(link).map_or(&[][..], |v| v.as_slice()) {
        if skip.contains(&k) {
            continue;
        }
        held.push(k);
        let sub = subtree(&joints[k].child, joints, links, children, skip, held);
        total.merge(&sub.transformed(&joints[k].placement));
    }
    total
}

/// The chain's segments, each carrying its off-chain subtrees at q = 0 lumped into the chain
/// link they hang from, and the off-chain joints so held (sorted; the root's included, which
/// cannot move and are not part of the dynamics).
fn chain_segments(parts: &Parts, tree: &LinkTree, chain: &[usize]) -> (Vec<Segment>, Vec<usize>) {
    let (joints, links, children) = (&parts.joints, &parts.links, &tree.children);
    let on_chain: HashSet<usize> = chain.iter().copied().collect();
    let mut held = Vec::new();
    let mut segments = Vec::with_capacity(chain.len());
    for &k in chain {
        let j = &joints[k];
        segments.push(j.segment(subtree(
            &j.child, joints, links, children, &on_chain, &mut held,
        )));
    }
    let mut root_held = Vec::new();
    subtree(
        &tree.root,
        joints,
        links,
        children,
        &on_chain,
        &mut root_held,
    );
    held.extend(root_held);
    held.sort_unstable();
    (segments, held)
}

/// The off-chain joints that move with the chain under [`import_urdf_with_followers`]: the
/// followers of movable chain joints (through other followers) with the fixed joints and other
/// such followers between them and the chain.
#[derive(Debug, Default)]
struct FollowerBranches {
    /// The segments' joints: the chain's, each chain joint followed by the branches hanging
    /// from its child link (depth first, children in file order; the root link's first). Empty:
    /// no follower moves (the plain chain).
    order: Vec<usize>,
    /// The tip link in the last movable chain joint's frame.
    tool: Matrix4<f64>,
    /// Followers of chain joints hanging beyond the last movable chain joint: held.
    beyond_tool: Vec<usize>,
}

impl FollowerBranches {
    fn of(joints: &[JointRec], tree: &LinkTree, chain: &[usize]) -> FollowerBranches {
        let movable = |k: usize| {
            matches!(
                joints[k].kind,
                SegmentKind::Revolute | SegmentKind::Continuous | SegmentKind::Prismatic
            )
        };
        let Some(last) = chain.iter().rposition(|&k| movable(k)) else {
            return FollowerBranches::default();
        };
        let by_name: HashMap<&str, usize> = joints
            .iter()
            .enumerate()
            .map(|(k, j)| (j.name.as_str(), k))
            .collect();
        let on_chain: HashSet<usize> = chain.iter().copied().collect();
        // a follower whose leader, followed through other followers, is a movable chain joint
        let follows_chain = |k: usize| {
            let mut at = k;
            for _ in 0..=joints.len() {
                match &joints[at].mimic_of {
                    None => return at != k && on_chain.contains(&at) && movable(at),
                    Some((leader, _, _)) => match by_name.get(leader.as_str()) {
                        Some(&l) => at = l,
                        None => return false,
                    },
                }
            }
            false // a cycle: refused later by the coupling
        };
        fn collect(
            link: &str,
            joints: &[JointRec],
            tree: &LinkTree,
            on_chain: &HashSet<usize>,
            accept: &dyn Fn(usize) -> bool,
            out: &mut Vec<usize>,
        ) {
            for &k in tree.children.get(link).map_or(&[][..], |v| v.as_slice()) {
                if on_chain.contains(&k) {
                    continue;
                }
                let j = &joints[k];
                if j.kind == SegmentKind::Fixed {
                    let mut sub = Vec::new();
                    collect(&j.child, joints, tree, on_chain, accept, &mut sub);
                    if !sub.is_empty() {
                        out.push(k);
                        out.extend(sub);
                    }
                } else if accept(k) {
                    out.push(k);
                    collect(&j.child, joints, tree, on_chain, accept, out);
                }
            }
        }
        let accept = |k: usize| movable(k) && follows_chain(k);
        let mut order = Vec::new();
        let mut beyond_tool = Vec::new();
        if chain
            .first()
            .is_some_and(|&k| !matches!(joints[k].kind, SegmentKind::Root(_)))
        {
            collect(&tree.root, joints, tree, &on_chain, &accept, &mut order);
        }
        let mut tool = Matrix4::identity();
        for (p, &k) in chain.iter().enumerate() {
            order.push(k);
            let mut branch = Vec::new();
            collect(
                &joints[k].child,
                joints,
                tree,
                &on_chain,
                &accept,
                &mut branch,
            );
            if p < last {
                order.extend(branch);
            } else {
                beyond_tool.extend(branch.into_iter().filter(|&b| movable(b)));
                if p > last {
                    tool *= joints[k].placement;
                }
            }
        }
        if order.len() == chain.len() {
            order.clear();
        }
        FollowerBranches {
            order,
            tool,
            beyond_tool,
        }
    }

    /// The segments of `order` with their parents (segment indices) for [`build_tree`], each
    /// carrying its held subtrees at q = 0 as [`chain_segments`] does, and the held joints.
    fn segments(
        &self,
        parts: &Parts,
        tree: &LinkTree,
        chain: &[usize],
    ) -> (Vec<Segment>, Vec<Option<usize>>, Vec<usize>) {
        let (joints, links, children) = (&parts.joints, &parts.links, &tree.children);
        let moving: HashSet<usize> = self.order.iter().copied().collect();
        let mut segment_of_link: HashMap<&str, usize> = HashMap::new();
        let mut held = Vec::new();
        let mut segments = Vec::with_capacity(self.order.len());
        let mut parents = Vec::with_capacity(self.order.len());
        for (s, &k) in self.order.iter().enumerate() {
            let j = &joints[k];
            parents.push(segment_of_link.get(j.parent.as_str()).copied());
            segment_of_link.insert(j.child.as_str(), s);
            segments.push(j.segment(subtree(
                &j.child, joints, links, children, &moving, &mut held,
            )));
        }
        debug_assert!(chain.iter().all(|k| moving.contains(k)));
        subtree(&tree.root, joints, links, children, &moving, &mut held);
        held.sort_unstable();
        (segments, parents, held)
    }
}

/// The chain root → `tip` as a robot: its segments, the robot checked, the movable joints'
/// names and limits, the folded and held joints, and the geometry placed on its bodies. With
/// `followers`, the off-chain mimic followers of chain joints as moving branches
/// ([`import_urdf_with_followers`]).
fn build_chain_to_tip(
    at_robot: &RobotElement,
    parts: &Parts,
    tree: &LinkTree,
    tip: String,
    mut geometry: crate::urdf_geometry::UrdfGeometry,
    followers: bool,
) -> Result<ImportedRobot, UrdfError> {
    let joints = &parts.joints;
    let chain_joints = chain_to(&tip, tree, joints);
    let branches = if followers {
        FollowerBranches::of(joints, tree, &chain_joints)
    } else {
        FollowerBranches::default()
    };
    // `chain`: the segments' joints in segment order (the chain's, with the branches after the
    // chain link they hang from)
    let (chain, built, held) = if branches.order.is_empty() {
        let (segments, held) = chain_segments(parts, tree, &chain_joints);
        (chain_joints, build_chain(at_robot.name, &segments), held)
    } else {
        let (segments, parents, held) = branches.segments(parts, tree, &chain_joints);
        let mut built = build_tree(at_robot.name, &segments, &parents);
        // the tip link in the last movable joint's frame: the chain's trailing fixed joints
        built.robot.tool = branches.tool;
        (branches.order.clone(), built, held)
    };
    let robot = built.robot;
    robot
        .validate()
        .map_err(|e| at_robot.err(UrdfErrorKind::Model(e)))?;
    let movable: Vec<UrdfJoint> = built
        .segment_of_joint
        .iter()
        .map(|&s| {
            let j = &joints[chain[s]];
            UrdfJoint {
                name: j.name.clone(),
                link: j.child.clone(),
                continuous: j.kind == SegmentKind::Continuous,
                effort: j.effort,
                velocity: j.velocity,
            }
        })
        .collect();
    let folded = chain
        .iter()
        .filter(|&&k| joints[k].kind == SegmentKind::Fixed)
        .map(|&k| joints[k].name.clone())
        .collect();
    let mut notes: Vec<String> = held
        .iter()
        .filter(|&&k| joints[k].mimic && joints[k].kind != SegmentKind::Fixed)
        .map(|&k| {
            let why = if branches.beyond_tool.contains(&k) {
                "it mimics a chain joint but hangs beyond the chain's last movable joint"
            } else if followers {
                "its leader is not a joint of the chain"
            } else {
                "import with the followers (`mimic`) or the tree for it to follow its leader"
            };
            format!(
                "joint {:?} mimics another joint; it is off the chain and held at 0 ({why})",
                joints[k].name
            )
        })
        .collect();
    let coordinates: Vec<usize> = built.segment_of_joint.iter().map(|&s| chain[s]).collect();
    let (mimics, coupling) =
        mimic_coupling(at_robot.rd.file, joints, &coordinates, &robot, &mut notes)?;
    let parent_links = movable
        .iter()
        .map(|m| joints[tree.parent_joint[m.link.as_str()]].parent.clone())
        .collect();
    let placed: Vec<crate::urdf_geometry::TreeJoint> = joints
        .iter()
        .enumerate()
        .map(|(k, j)| crate::urdf_geometry::TreeJoint {
            parent: &j.parent,
            child: &j.child,
            // a root joint's placement is the robot's base, link frame 0 its child's frame
            placement: if matches!(j.kind, SegmentKind::Root(_)) {
                Matrix4::identity()
            } else {
                j.placement
            },
            body: coordinates.iter().position(|&c| c == k).map(|i| i + 1),
        })
        .collect();
    crate::urdf_geometry::place(&mut geometry, &tree.root, &placed);
    Ok(ImportedRobot {
        robot,
        root: tree.root.clone(),
        tip,
        joints: movable,
        folded,
        held: held.iter().map(|&k| joints[k].name.clone()).collect(),
        notes,
        parent_links,
        mimics,
        coupling,
        geometry,
    })
}

/// The whole tree (see [`import_urdf_tree`]), after the checks every import makes.
#[allow(clippy::too_many_arguments)]
fn build_whole_tree(
    file: &Path,
    rd: &Reader,
    root_el: roxmltree::Node,
    robot_name: &str,
    root: &str,
    links: &HashMap<String, LinkRec>,
    joints: &[JointRec],
    children: &HashMap<&str, Vec<usize>>,
    mut geometry: crate::urdf_geometry::UrdfGeometry,
    floating: Option<RootKind>,
) -> Result<ImportedRobot, UrdfError> {
    // Depth first from the root, children in file order: parents come first.
    let mut dfs: Vec<usize> = Vec::with_capacity(joints.len());
    fn visit(
        link: &str,
        joints: &[JointRec],
        children: &HashMap<&str, Vec<usize>>,
        out: &mut Vec<usize>,
    ) {
        for &k in children.get(link).map_or(&[][..], |v| v.as_slice()) {
            out.push(k);
            visit(&joints[k].child, joints, children, out);
        }
    }
    visit(root, joints, children, &mut dfs);
    let mut seg_of_joint: HashMap<usize, usize> = HashMap::new();
    let mut segments = Vec::with_capacity(dfs.len());
    let mut parents = Vec::with_capacity(dfs.len());
    let parent_joint_of = |link: &str| joints.iter().position(|j| j.child == link);
    for (s, &k) in dfs.iter().enumerate() {
        let j = &joints[k];
        seg_of_joint.insert(k, s);
        parents.push(parent_joint_of(&j.parent).map(|pk| seg_of_joint[&pk]));
        segments.push(j.segment(links[&j.child].inertial));
    }
    let built = build_tree(robot_name, &segments, &parents);
    let mut robot = built.robot;
    if let (Some(kind), None) = (floating, &robot.root) {
        let mut inertial = links[root].inertial;
        inertial.merge(&built.root_inertial);
        robot.root = Some(robosim_kinematics::chain::root_joint(kind, &inertial));
    }
    robot.validate().map_err(|e| UrdfError {
        file: file.to_path_buf(),
        line: rd.line(root_el),
        element: format!("<robot name={robot_name:?}>"),
        kind: UrdfErrorKind::Model(e),
    })?;
    let mut movable = Vec::new();
    let mut parent_links = Vec::new();
    let coordinates: Vec<usize> = built.segment_of_joint.iter().map(|&s| dfs[s]).collect();
    for &s in &built.segment_of_joint {
        let j = &joints[dfs[s]];
        movable.push(UrdfJoint {
            name: j.name.clone(),
            link: j.child.clone(),
            continuous: j.kind == SegmentKind::Continuous,
            effort: j.effort,
            velocity: j.velocity,
        });
        parent_links.push(j.parent.clone());
    }
    let mut notes = Vec::new();
    let (mimics, coupling) = mimic_coupling(file, joints, &coordinates, &robot, &mut notes)?;
    let folded = dfs
        .iter()
        .filter(|&&k| joints[k].kind == SegmentKind::Fixed)
        .map(|&k| joints[k].name.clone())
        .collect();
    // geometry: a joint's child link moves with its body (1-based, q order); fixed joints'
    // children are rigid with their parent's body
    let tree: Vec<crate::urdf_geometry::TreeJoint> = joints
        .iter()
        .enumerate()
        .map(|(k, j)| crate::urdf_geometry::TreeJoint {
            parent: &j.parent,
            child: &j.child,
            // a root joint's placement is the robot's base, link frame 0 its child's frame
            placement: if matches!(j.kind, SegmentKind::Root(_)) {
                Matrix4::identity()
            } else {
                j.placement
            },
            body: seg_of_joint
                .get(&k)
                .and_then(|s| built.segment_of_joint.iter().position(|x| x == s))
                .map(|i| i + 1),
        })
        .collect();
    crate::urdf_geometry::place(&mut geometry, root, &tree);
    let tip = movable
        .last()
        .map_or_else(|| root.to_string(), |m| m.link.clone());
    Ok(ImportedRobot {
        robot,
        root: root.to_string(),
        tip,
        joints: movable,
        folded,
        held: Vec::new(),
        notes,
        parent_links,
        mimics,
        coupling,
        geometry,
    })
}

/// The `<mimic>` relations of the coordinates (`coordinates[i]`: the index in `joints` of q's
/// joint i): each follower's leader found by name (refused when it names no joint), its index
/// in q (`None` when the leader is not a coordinate: fixed, or held off the chain — the
/// follower is then fixed at its offset), a note per relation, and the coupling (`None`
/// without any; with `robot`'s root joint passed through).
fn mimic_coupling(
    file: &Path,
    joints: &[JointRec],
    coordinates: &[usize],
    robot: &Robot,
    notes: &mut Vec<String>,
) -> Result<(Vec<UrdfMimic>, Option<Coupling>), UrdfError> {
    let mut mimics = Vec::new();
    let mut relations = Vec::new();
    for (index, &k) in coordinates.iter().enumerate() {
        let j = &joints[k];
        let Some((mimicked, multiplier, offset)) = &j.mimic_of else {
            continue;
        };
        let Some(leader) = joints.iter().position(|l| &l.name == mimicked) else {
            return Err(joint_err(
                file,
                j,
                UrdfErrorKind::MimicUnknownJoint(mimicked.clone()),
            ));
        };
        let mimicked_index = coordinates.iter().position(|&c| c == leader);
        notes.push(match mimicked_index {
            Some(_) => format!(
                "joint {:?} mimics {mimicked:?} (×{multiplier} + {offset}): a coordinate of the robot, one coordinate with its leader in the coupling",
                j.name
            ),
            None => format!(
                "joint {:?} mimics {mimicked:?} (×{multiplier} + {offset}), which is not a coordinate of this import (fixed, or held at 0 off the chain): fixed at {offset} in the coupling",
                j.name
            ),
        });
        relations.push(Mimic {
            follower: index,
            leader: mimicked_index,
            multiplier: *multiplier,
            offset: *offset,
        });
        mimics.push(UrdfMimic {
            joint: j.name.clone(),
            index,
            mimicked: mimicked.clone(),
            mimicked_index,
            multiplier: *multiplier,
            offset: *offset,
        });
    }
    if relations.is_empty() {
        return Ok((mimics, None));
    }
    let coupling = Coupling::new(coordinates.len(), &relations).map_err(|e| {
        let at = match &e {
            MimicError::Cycle(i) | MimicError::TwoLeaders(i) => *i,
            _ => relations[0].follower,
        };
        joint_err(file, &joints[coordinates[at]], UrdfErrorKind::Mimic(e))
    })?;
    Ok((
        mimics,
        Some(coupling.with_root(robot.root_nq(), robot.root_nv())),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use robosim_kinematics::fk::forward;
    use robosim_kinematics::pose::{rot_z, trans};

    const TWO_LINK: &str = r#"<?xml version="1.0"?>
<robot name="two">
  <link name="base"/>
  <link name="l1">
    <inertial><origin xyz="0.1 0 0" rpy="0 0 0"/><mass value="2"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.03"/></inertial>
    <visual><geometry><mesh filename="package://nowhere/l1.stl"/></geometry></visual>
  </link>
  <link name="l2"/>
  <link name="tip"/>
  <joint name="j1" type="continuous">
    <parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.5" rpy="0 0 0"/><axis xyz="0 0 1"/>
  </joint>
  <joint name="j2" type="revolute">
    <parent link="l1"/><child link="l2"/>
    <origin xyz="1 0 0"/><axis xyz="0 0 2"/>
    <limit lower="-2" upper="2" effort="10" velocity="3"/>
  </joint>
  <joint name="j3" type="fixed">
    <parent link="l2"/><child link="tip"/><origin xyz="0.5 0 0"/>
  </joint>
</robot>"#;

    fn import(text: &str, tip: Option<&str>) -> Result<ImportedRobot, UrdfError> {
        import_urdf_str(text, Path::new("t.urdf"), tip)
    }

    /// `<joint type="floating">` / `"planar"` on the root link: the robot's root joint, its
    /// origin the base, the child's inertial the base link's; `--floating`
    /// ([`import_urdf_tree_floating_str`]) puts a free-flyer on the file's root link.
    #[test]
    fn floating_and_planar_root_joints_become_the_robots_root() {
        for (ty, kind) in [
            ("floating", RootKind::FreeFlyer),
            ("planar", RootKind::Planar),
        ] {
            let text = TWO_LINK.replace(r#"type="continuous""#, &format!("type={ty:?}"));
            let r = import(&text, None).expect("imports");
            let root = r.robot.root.as_ref().expect("a root joint");
            assert_eq!(root.kind, kind);
            assert_eq!(root.mass, 2.0);
            assert_eq!(root.com, Vector3::new(0.1, 0.0, 0.0));
            assert_eq!(r.robot.dof(), 1);
            assert_eq!(r.robot.nq(), kind.nq() + 1);
            assert_eq!(r.robot.base, robosim_kinematics::pose::trans(0.0, 0.0, 0.5));
            let mut q = r.robot.neutral_q();
            q[0] = 0.3;
            q[1] = -0.2;
            let n = kind.nq();
            q[n] = 0.4;
            let t = robosim_kinematics::fk::forward(&r.robot, q.as_slice());
            // tip = base · (x, y) · Rz(0.4) about j2 at (1, 0, 0) · (0.5, 0, 0)
            let expected = Vector3::new(
                0.3 + 1.0 + 0.5 * 0.4f64.cos(),
                -0.2 + 0.5 * 0.4f64.sin(),
                0.5,
            );
            assert!(
                (t.fixed_view::<3, 1>(0, 3) - expected).norm() < 1e-15,
                "{ty}: {t}"
            );
        }
        let tree =
            import_urdf_tree_floating_str(TWO_LINK, Path::new("t.urdf"), RootKind::FreeFlyer)
                .expect("imports");
        let root = tree.robot.root.as_ref().expect("a free base");
        assert_eq!((root.kind, root.mass), (RootKind::FreeFlyer, 0.0));
        assert_eq!(tree.robot.dof(), 2);
        assert_eq!(tree.robot.nv(), 8);
    }

    #[test]
    fn planar_chain_with_fixed_tip_has_the_expected_forward_kinematics() {
        let r = import(TWO_LINK, None).expect("imports");
        assert_eq!(r.tip, "tip");
        assert_eq!(r.robot.dof(), 2);
        assert_eq!(r.folded, vec!["j3".to_string()]);
        assert!(r.joints[0].continuous && r.joints[0].effort.is_infinite());
        assert_eq!((r.joints[1].effort, r.joints[1].velocity), (10.0, 3.0));
        assert_eq!(r.robot.joints[0].qlim, [f64::NEG_INFINITY, f64::INFINITY]);
        assert_eq!(r.robot.joints[1].qlim, [-2.0, 2.0]);
        assert!(r.notes.is_empty(), "{:?}", r.notes);
        let g = &r.geometry.links["l1"];
        assert_eq!((g.body, g.visual.len()), (1, 1));
        let q = [0.3, -0.8];
        let expected = trans(0.0, 0.0, 0.5)
            * rot_z(q[0])
            * trans(1.0, 0.0, 0.0)
            * rot_z(q[1])
            * trans(0.5, 0.0, 0.0);
        assert!((forward(&r.robot, &q) - expected).abs().max() < 1e-15);
        assert_eq!(r.robot.joints[0].mass, 2.0);
    }

    fn kind_of(text: &str, tip: Option<&str>) -> (u32, String, UrdfErrorKind) {
        let e = import(text, tip).expect_err("refused");
        assert!(e.to_string().starts_with("t.urdf:"), "{e}");
        (e.line, e.element, e.kind)
    }

    /// An axis of any finite non-zero length is its direction (issue 34 item 9): `0 0 1e200`
    /// overflowed the norm (the axis became zero) and `0 0 1e-200` underflowed it (refused as
    /// zero); the robot is the one with `0 0 2`.
    #[test]
    fn a_huge_or_tiny_axis_is_its_direction() {
        let want = import(TWO_LINK, None).expect("imports");
        let q = [0.3, -0.7];
        for xyz in ["0 0 1e200", "0 0 1e-200", "0 0 5e-324"] {
            let text =
                TWO_LINK.replace(r#"<axis xyz="0 0 2"/>"#, &format!(r#"<axis xyz="{xyz}"/>"#));
            let r = import(&text, None).unwrap_or_else(|e| panic!("axis {xyz}: {e}"));
            let (a, b) = (forward(&r.robot, &q), forward(&want.robot, &q));
            assert!((a - b).abs().max() < 1e-15, "axis {xyz}: {a} vs {b}");
        }
        let zero = TWO_LINK.replace(r#"<axis xyz="0 0 2"/>"#, r#"<axis xyz="0 0 0"/>"#);
        assert!(matches!(kind_of(&zero, None).2, UrdfErrorKind::ZeroAxis));
    }

    /// Issue 36: Kinova's and TALOS's files write `<axis xyz="0 0 0"/>` on fixed joints, which
    /// urdfdom never reads; they were refused ("axis is the zero vector"). A fixed joint's axis
    /// is ignored, whatever it says; a movable joint's zero axis is still refused (above).
    #[test]
    fn issue_36_a_fixed_joints_zero_axis_is_ignored() {
        let want = import(TWO_LINK, None).expect("imports");
        for axis in [r#"<axis xyz="0 0 0"/>"#, r#"<axis xyz="0 nan 0"/>"#] {
            let text = TWO_LINK.replace(
                r#"<child link="tip"/><origin xyz="0.5 0 0"/>"#,
                &format!(r#"<child link="tip"/><origin xyz="0.5 0 0"/>{axis}"#),
            );
            assert_ne!(text, TWO_LINK);
            let r = import(&text, None).unwrap_or_else(|e| panic!("{axis}: {e}"));
            assert_eq!(r.robot, want.robot, "{axis}");
        }
    }

    /// Issue 36: TIAGo's antenna links have a −3.5e-8 kg·m² principal moment (a 1 mg dummy
    /// link); within NEGATIVE_INERTIA_TOLERANCE of the robot's largest moment it is accepted as
    /// written with a warning naming the link and the value; beyond it, refused.
    #[test]
    fn issue_36_a_slightly_negative_inertia_is_a_warning() {
        // l1's moments are 0.01..0.03; the finger's eigenvalues are −1e-9, 1e-9, 0 (±1e-9 off
        // the diagonal): −1e-9 / 0.03 = 3.3e-8 of the robot's largest.
        let finger = |ixy: &str| {
            TWO_LINK.replace(
                "</robot>",
                &format!(
                    r#"<link name="finger"><inertial><mass value="0.001"/>
                   <inertia ixx="0" ixy="{ixy}" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link>
                 <joint name="f" type="fixed"><parent link="l2"/><child link="finger"/></joint>
                 </robot>"#
                ),
            )
        };
        let r = import(&finger("1e-9"), Some("tip")).expect("imports with a warning");
        assert_eq!(r.notes.len(), 1, "{:?}", r.notes);
        let note = &r.notes[0];
        assert!(
            note.starts_with("warning: link \"finger\"") && note.contains("-1e-9"),
            "{note}"
        );
        // used as written: l2 carries the finger's inertia, off-diagonal 1e-9
        assert_eq!(r.robot.joints[1].inertia[(0, 1)], 1e-9);
        let (line, element, kind) = kind_of(&finger("1e-3"), Some("tip"));
        assert_eq!(kind, UrdfErrorKind::InertiaNotPsd(-1e-3));
        assert_eq!(
            (line, element.as_str()),
            (24, r#"<link name="finger">/<inertial>/<inertia>"#)
        );
    }

    #[test]
    fn bad_input_is_refused_with_file_line_and_element() {
        let (line, _, kind) = kind_of("<robot name='x'>\n<link name='a'>\n</robot>", None);
        assert!(
            matches!(kind, UrdfErrorKind::Xml(_)) && line == 3,
            "{line} {kind:?}"
        );

        let missing_parent = TWO_LINK.replace(r#"<parent link="l1"/>"#, r#"<parent link="lx"/>"#);
        let (line, element, kind) = kind_of(&missing_parent, None);
        assert_eq!(element, r#"<joint name="j2">"#);
        assert_eq!(line, 15);
        assert!(matches!(
            kind,
            UrdfErrorKind::MissingLink { role: "parent", .. }
        ));

        let nan = TWO_LINK.replace(r#"<origin xyz="1 0 0"/>"#, r#"<origin xyz="1 nan 0"/>"#);
        let (line, element, kind) = kind_of(&nan, None);
        assert_eq!(
            (line, element.as_str()),
            (17, r#"<joint name="j2">/<origin>"#)
        );
        assert!(matches!(
            kind,
            UrdfErrorKind::BadNumber {
                attribute: "xyz",
                ..
            }
        ));

        let neg = TWO_LINK.replace(r#"<mass value="2"/>"#, r#"<mass value="-2"/>"#);
        let (line, element, kind) = kind_of(&neg, None);
        assert_eq!(line, 5);
        assert_eq!(element, r#"<link name="l1">/<inertial>/<mass>"#);
        assert_eq!(kind, UrdfErrorKind::NegativeMass(-2.0));

        let npd = TWO_LINK.replace(r#"izz="0.03""#, r#"izz="-0.03""#);
        assert!(matches!(
            kind_of(&npd, None).2,
            UrdfErrorKind::InertiaNotPsd(_)
        ));

        let (_, _, kind) = kind_of(TWO_LINK, Some("nope"));
        assert_eq!(kind, UrdfErrorKind::TipNotALink("nope".into()));

        let two_roots = TWO_LINK.replace(
            r#"<link name="tip"/>"#,
            "<link name=\"tip\"/><link name=\"stray\"/>",
        );
        assert!(matches!(
            kind_of(&two_roots, None).2,
            UrdfErrorKind::TwoRoots(..)
        ));

        // A cycle: base → l1 → l2 → tip and tip → l1 would give l1 two parents; a detached ring
        // l2 ⇄ tip (l1 → l2 replaced by tip → l2) leaves no second root but a cycle.
        let ring = TWO_LINK.replace(
            r#"<parent link="l1"/><child link="l2"/>"#,
            r#"<parent link="tip"/><child link="l2"/>"#,
        );
        assert!(matches!(
            kind_of(&ring, Some("l1")).2,
            UrdfErrorKind::Cycle(_)
        ));

        let two_parents = TWO_LINK.replace(
            r#"<parent link="l2"/><child link="tip"/>"#,
            r#"<parent link="l2"/><child link="l1"/>"#,
        );
        assert!(matches!(
            kind_of(&two_parents, None).2,
            UrdfErrorKind::TwoParents { .. }
        ));

        // a floating joint below the root link: robosim's floating base is the root joint
        let floating = TWO_LINK.replace(
            r#"name="j2" type="revolute""#,
            r#"name="j2" type="floating""#,
        );
        assert!(matches!(
            kind_of(&floating, None).2,
            UrdfErrorKind::UnsupportedJointType(_)
        ));

        let xacro = "<robot name='x' xmlns:xacro='http://www.ros.org/wiki/xacro'><xacro:macro name='m'/><link name='a'/></robot>";
        assert_eq!(kind_of(xacro, None).2, UrdfErrorKind::Xacro);

        let no_limit = TWO_LINK.replace(
            r#"<limit lower="-2" upper="2" effort="10" velocity="3"/>"#,
            "",
        );
        assert_eq!(
            kind_of(&no_limit, None).2,
            UrdfErrorKind::MissingElement("limit")
        );

        let mimic = TWO_LINK.replace(
            r#"<axis xyz="0 0 2"/>"#,
            r#"<axis xyz="0 0 2"/><mimic joint="jx"/>"#,
        );
        let (line, element, kind) = kind_of(&mimic, None);
        assert_eq!(kind, UrdfErrorKind::MimicUnknownJoint("jx".into()));
        assert_eq!((line, element.as_str()), (15, r#"<joint name="j2">"#));
        // j1 mimics j2 and j2 mimics j1: no coordinate is free
        let cycle = TWO_LINK
            .replace(
                r#"<axis xyz="0 0 2"/>"#,
                r#"<axis xyz="0 0 2"/><mimic joint="j1"/>"#,
            )
            .replace(
                r#"<axis xyz="0 0 1"/>"#,
                r#"<axis xyz="0 0 1"/><mimic joint="j2"/>"#,
            );
        assert!(matches!(
            kind_of(&cycle, None).2,
            UrdfErrorKind::Mimic(robosim_kinematics::mimic::MimicError::Cycle(_))
        ));

        let e = import_urdf(Path::new("/nonexistent/robot.urdf"), None).expect_err("no file");
        assert!(matches!(e.kind, UrdfErrorKind::Io(_)));
        assert!(e.to_string().contains("/nonexistent/robot.urdf"));
    }

    /// Issue 36 item 1: a mimic joint on the chain (refused before) is a coordinate of the full
    /// robot and follows its leader in the coupling: j2 = −2·j1 + 0.1, so the tool at the
    /// reduced q = [a] is the full robot's at [a, −2a + 0.1], and the Jacobian is J·G.
    #[test]
    fn issue_36_a_mimic_joint_on_the_chain_is_one_coordinate_with_its_leader() {
        let text = TWO_LINK.replace(
            r#"<axis xyz="0 0 2"/>"#,
            r#"<axis xyz="0 0 2"/><mimic joint="j1" multiplier="-2" offset="0.1"/>"#,
        );
        let r = import(&text, None).expect("imports");
        assert_eq!(r.robot.dof(), 2);
        let c = r.coupling.as_ref().expect("a coupling");
        assert_eq!((c.full_dof(), c.reduced_dof()), (2, 1));
        assert_eq!(r.mimics.len(), 1);
        assert_eq!(
            (r.mimics[0].index, r.mimics[0].mimicked_index),
            (1, Some(0))
        );
        assert!(
            r.notes.iter().any(|n| n.contains("one coordinate")),
            "{:?}",
            r.notes
        );
        let a = 0.4;
        let full = [a, -2.0 * a + 0.1];
        let got = robosim_kinematics::mimic::forward(&r.robot, c, &[a]).expect("fk");
        assert_eq!(got, forward(&r.robot, &full));
        let jr = robosim_kinematics::mimic::jacobian(
            &r.robot,
            c,
            &[a],
            robosim_kinematics::jacobian::Frame::Base,
        )
        .expect("jacobian");
        let jf = robosim_kinematics::jacobian::jacobian(
            &r.robot,
            &full,
            robosim_kinematics::jacobian::Frame::Base,
        );
        for row in 0..6 {
            let want = jf[(row, 0)] - 2.0 * jf[(row, 1)];
            assert!((jr[(row, 0)] - want).abs() < 1e-15, "row {row}");
        }
        // a robot without <mimic> has no coupling
        assert!(import(TWO_LINK, None).expect("imports").coupling.is_none());
    }

    #[test]
    fn an_off_chain_branch_is_held_at_zero_and_lumped() {
        // A finger on l1, off the chain to `tip`: its mass joins l1's.
        let text = TWO_LINK.replace(
            "</robot>",
            r#"<link name="finger"><inertial><origin xyz="0 0.1 0"/><mass value="1"/>
               <inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link>
             <joint name="f" type="prismatic"><parent link="l1"/><child link="finger"/>
               <origin xyz="0.2 0 0"/><limit lower="0" upper="0.04" effort="1" velocity="1"/>
               <mimic joint="j2"/></joint>
             </robot>"#,
        );
        let r = import(&text, Some("tip")).expect("imports");
        assert_eq!(r.held, vec!["f".to_string()]);
        assert!(r.notes.iter().any(|n| n.contains("mimics")));
        let j = &r.robot.joints[0];
        assert_eq!(j.mass, 3.0);
        assert!((j.com - Vector3::new((0.2 + 0.2) / 3.0, 0.1 / 3.0, 0.0)).norm() < 1e-15);
    }
}
