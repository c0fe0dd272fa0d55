//! A set of link files becomes a robot (seed §2.3–2.4: "the simulation package … operate[s] on
//! the files created by ROBOSIM"): the kinematics model (standard DH, from each link's AMAT)
//! and the one Instance Space transaction that creates it — geometry, DH rows, masses — so the
//! simulator, IK and display use it like a library robot.
//!
//! The chain: link 0 is the base — its I joint is fixed or absent; its I+1 joint is joint 1.
//! Link i (i ≥ 1) moves with its I joint (revolute or prismatic), whose frame is the DH frame
//! i−1; its AMAT = AJNT-I⁻¹ · AJNT-I+1 is the DH transform A_i at q = 0 (the check refuses
//! anything else). The robot's base is the base link's AMAT (its I joint at the world origin).
//! Link i's geometry and inertia, given in its construction frame, sit in DH frame i through
//! AJNT-I+1⁻¹.

use crate::shape::rigid_inverse;
use nalgebra::{Matrix3, Matrix4};
use robosim_file_io::linkfile::{self, LinkFile, LinkJoint, from_pseudo_inertia};
use robosim_instance_space::{
    DhConvention, GeometryInput, JointKind, Kind, Kinematics, Transaction,
};
use robosim_kinematics::{Convention, Joint, JointType, Robot};
use std::path::{Path, PathBuf};

/// Joint limits given to loaded joints (link files carry none: seed §2.4 lists limits among the
/// fields "not currently used").
pub const REVOLUTE_LIMITS: [f64; 2] = [-std::f64::consts::PI, std::f64::consts::PI];
pub const PRISMATIC_LIMITS: [f64; 2] = [-1.0, 1.0];

/// Why link files do not make a robot. A variant that wraps the file system's or the link
/// file's error keeps it (`source()`); the others are the message itself (the files and links
/// named).
#[derive(Debug, thiserror::Error)]
pub enum RobotError {
    /// The links do not make a chain (the message names the links and what is wrong).
    #[error("{0}")]
    Refused(String),
    /// The directory of link files could not be listed.
    #[error("{}: {source}", dir.display())]
    Dir {
        dir: PathBuf,
        source: std::io::Error,
    },
    /// A link file could not be read, or its vectors make no solid.
    #[error(transparent)]
    LinkFile(#[from] linkfile::LinkFileError),
    /// A link's AMAT is not a DH transform.
    #[error("{link}: AMAT is not a DH transform: {source}")]
    NotDh {
        link: String,
        source: linkfile::DhViolation,
    },
}

impl From<String> for RobotError {
    fn from(what: String) -> Self {
        RobotError::Refused(what)
    }
}

/// A robot read from link files.
#[derive(Debug, Clone)]
pub struct LoadedRobot {
    /// (link name, its file), base first.
    pub links: Vec<(String, LinkFile)>,
    pub robot: Robot,
}

/// The link files of robot `prefix` in `dir` (`PREFIX.EXT`): the base `PREFIX.LOC` first (or
/// the one link whose I joint is fixed or absent), then the others in natural order of their
/// extensions (L1, L2, …, L10).
pub fn link_paths(dir: &Path, prefix: Option<&str>) -> Result<(String, Vec<PathBuf>), RobotError> {
    let rd = std::fs::read_dir(dir).map_err(|source| RobotError::Dir {
        dir: dir.to_path_buf(),
        source,
    })?;
    let mut by_prefix: std::collections::BTreeMap<String, Vec<(String, PathBuf)>> =
        Default::default();
    for e in rd.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if name.starts_with('.') || !e.path().is_file() || !looks_like_link_file(&e.path()) {
            continue;
        }
        if let Some((p, ext)) = name.split_once('.')
            && !p.is_empty()
            && !ext.is_empty()
        {
            {
                by_prefix
                    .entry(p.to_owned())
                    .or_default()
                    .push((ext.to_owned(), e.path()));
            }
        }
    }
    let prefix = match prefix {
        Some(p) => p.to_owned(),
        None if by_prefix.len() == 1 => by_prefix.keys().next().cloned().unwrap_or_default(),
        None if by_prefix.is_empty() => {
            return Err(format!("{}: no link files (NAME.EXT) in it", dir.display()).into());
        }
        None => {
            return Err(format!(
                "{}: link files of several robots ({}); say which with --robot",
                dir.display(),
                by_prefix.keys().cloned().collect::<Vec<_>>().join(", ")
            )
            .into());
        }
    };
    let Some(mut files) = by_prefix.remove(&prefix) else {
        return Err(format!("{}: no link files {prefix}.*", dir.display()).into());
    };
    files.sort_by(|a, b| {
        let base = |e: &str| !e.eq_ignore_ascii_case("LOC");
        base(&a.0)
            .cmp(&base(&b.0))
            .then_with(|| natural(&a.0).cmp(&natural(&b.0)))
    });
    Ok((prefix, files.into_iter().map(|f| f.1).collect()))
}

/// Link files held in memory (a program's STORE-LINKs, `PREFIX.EXT` names) ordered as
/// [`link_paths`] orders files: the base `LOC` first, then the others in natural order. All must
/// belong to one robot (one prefix). The prefix and the ordered links.
pub fn order_links(
    mut links: Vec<(String, LinkFile)>,
) -> Result<(String, Vec<(String, LinkFile)>), RobotError> {
    let prefix_of = |n: &str| n.split_once('.').map_or(n, |(p, _)| p).to_owned();
    let Some(first) = links.first().map(|l| prefix_of(&l.0)) else {
        return Err(RobotError::Refused("no links".into()));
    };
    let mut others: Vec<String> = links
        .iter()
        .map(|l| prefix_of(&l.0))
        .filter(|p| *p != first)
        .collect();
    if !others.is_empty() {
        others.dedup();
        return Err(format!(
            "links of several robots ({first}, {}); write them with --out and load one with `robosim lang load DIR --robot NAME`",
            others.join(", ")
        )
        .into());
    }
    let ext = |n: &str| n.split_once('.').map_or("", |(_, e)| e).to_owned();
    links.sort_by(|a, b| {
        let (ea, eb) = (ext(&a.0), ext(&b.0));
        let base = |e: &str| !e.eq_ignore_ascii_case("LOC");
        base(&ea)
            .cmp(&base(&eb))
            .then_with(|| natural(&ea).cmp(&natural(&eb)))
    });
    Ok((first, links))
}

/// Whether a file starts like a link file (a first row of four numbers); other files in the
/// directory (a program, notes) are not links.
fn looks_like_link_file(p: &Path) -> bool {
    use std::io::BufRead;
    // Only a regular file is opened: a FIFO in the folder would block the open.
    let Ok((f, _)) = robosim_input::open_regular(p, "a link file") else {
        return false;
    };
    let mut first = String::new();
    if std::io::BufReader::new(f).read_line(&mut first).is_err() {
        return false;
    }
    let toks: Vec<&str> = first.split_whitespace().collect();
    toks.len() == 4 && toks.iter().all(|t| t.parse::<f64>().is_ok())
}

fn natural(s: &str) -> (String, u64, String) {
    let head: String = s.chars().take_while(|c| !c.is_ascii_digit()).collect();
    let digits: String = s[head.len()..]
        .chars()
        .take_while(|c| c.is_ascii_digit())
        .collect();
    let tail = s[head.len() + digits.len()..].to_owned();
    (head, digits.parse().unwrap_or(0), tail)
}

/// Reads the files and checks them as one chain.
pub fn load_links(paths: &[PathBuf], name: &str) -> Result<LoadedRobot, RobotError> {
    let mut links = Vec::new();
    for p in paths {
        let f = LinkFile::read(p)?;
        let lname = p
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        links.push((lname, f));
    }
    from_links(links, name)
}

/// The robot of `links` (base first).
pub fn from_links(links: Vec<(String, LinkFile)>, name: &str) -> Result<LoadedRobot, RobotError> {
    let Some((bname, base)) = links.first() else {
        return Err(RobotError::Refused("no links".into()));
    };
    if matches!(
        base.joint_i,
        Some(LinkJoint::Revolute | LinkJoint::Prismatic)
    ) {
        return Err(format!(
            "{bname}: the base link's I joint is {}; a base has a fixed I joint or none",
            joint_words(base.joint_i)
        )
        .into());
    }
    if links.len() < 2 {
        return Err(
            format!("{bname}: a robot needs the base link and at least one moving link").into(),
        );
    }
    let mut joints = Vec::new();
    for (k, (lname, l)) in links.iter().enumerate().skip(1) {
        let joint_type = match l.joint_i {
            Some(LinkJoint::Revolute) => JointType::Revolute,
            Some(LinkJoint::Prismatic) => JointType::Prismatic,
            other => {
                return Err(format!(
                    "{lname}: link {k}'s I joint is {}; links after the base move with a revolute or prismatic I joint",
                    joint_words(other)
                )
                .into());
            }
        };
        let (prev_name, prev) = &links[k - 1];
        if prev.joint_i1.is_some() && prev.joint_i1 != l.joint_i {
            return Err(format!(
                "{lname}: its I joint ({}) is not the joint {prev_name} ends with ({})",
                joint_words(l.joint_i),
                joint_words(prev.joint_i1)
            )
            .into());
        }
        let row = linkfile::dh_decompose(&l.amat, crate::program::DH_TOL).map_err(|source| {
            RobotError::NotDh {
                link: lname.clone(),
                source,
            }
        })?;
        // The file's AMAT must agree with its joint frames.
        let amat = rigid_inverse(&l.ajnt_i) * l.ajnt_i1;
        if (amat - l.amat).amax() > 1e-9 {
            return Err(format!("{lname}: AMAT is not AJNT-I⁻¹ · AJNT-I+1").into());
        }
        let (mass, com_c, inertia_c) = from_pseudo_inertia(&l.ainert);
        // into DH frame k: x_k = AJNT-I+1⁻¹ x_c
        let to_k = rigid_inverse(&l.ajnt_i1);
        let r = to_k.fixed_view::<3, 3>(0, 0).into_owned();
        let com = (to_k * com_c.push(1.0)).xyz();
        let inertia: Matrix3<f64> = r * inertia_c * r.transpose();
        let (theta, d, offset, qlim) = match joint_type {
            JointType::Revolute => (row.theta, row.dz, row.theta, REVOLUTE_LIMITS),
            JointType::Prismatic => (row.theta, row.dz, row.dz, PRISMATIC_LIMITS),
        };
        joints.push(Joint {
            joint_type,
            a: row.da,
            d,
            alpha: row.alpha,
            theta,
            offset,
            qlim,
            mass,
            com,
            inertia,
            ..Joint::default()
        });
    }
    let robot = Robot {
        name: name.to_owned(),
        convention: Convention::Standard,
        joints,
        base: rigid_inverse(&base.ajnt_i) * base.ajnt_i1,
        tool: Matrix4::identity(),
        ..Robot::default()
    };
    Ok(LoadedRobot { links, robot })
}

fn pose(m: &Matrix4<f64>) -> [f64; 12] {
    let mut p = [0.0; 12];
    for r in 0..3 {
        for c in 0..4 {
            p[r * 4 + c] = m[(r, c)];
        }
    }
    p
}

/// The transaction that creates the robot as a top-level Instance Space robot called `name`:
/// the robot object (pose = base), the base link's solids under it, one link object per moving
/// link (pose = its DH frame at q = 0, DH row, limits, mass) with its solids.
pub fn robot_transaction(r: &LoadedRobot, name: &str) -> Result<Transaction, RobotError> {
    let mut tx = Transaction::new();
    let top = tx.create(Kind::Robot, name, None);
    tx.set_pose(top, pose(&r.robot.base));
    tx.set_kinematics(
        top,
        Some(Kinematics::Robot {
            convention: DhConvention::Standard,
            ik_family: 0,
            tool: pose(&Matrix4::identity()),
        }),
    );
    let frames = robosim_kinematics::fk::link_frames(
        &Robot {
            base: Matrix4::identity(),
            ..r.robot.clone()
        },
        &vec![0.0; r.robot.joints.len()],
    );
    for (k, (lname, l)) in r.links.iter().enumerate() {
        let parent = if k == 0 {
            top
        } else {
            let j = &r.robot.joints[k - 1];
            let link = tx.create(Kind::Link, lname, Some(top));
            tx.set_pose(link, pose(&frames[k]));
            tx.set_joint(link, 0.0);
            tx.set_kinematics(
                link,
                Some(Kinematics::Joint {
                    index: (k - 1) as u32,
                    joint: match j.joint_type {
                        JointType::Revolute => JointKind::Revolute,
                        JointType::Prismatic => JointKind::Prismatic,
                    },
                    convention: DhConvention::Standard,
                    a: j.a,
                    d: j.d,
                    alpha: j.alpha,
                    theta: j.theta,
                    offset: j.offset,
                    qlim: j.qlim,
                }),
            );
            tx.set_dynamics(
                link,
                Some(robosim_scene::instantiate::mass_props(
                    j.mass, &j.com, &j.inertia,
                )),
            );
            link
        };
        let solids = l.solids(Path::new(lname))?;
        let place = pose(&rigid_inverse(&l.ajnt_i1));
        for (s, (verts, faces)) in solids.into_iter().enumerate() {
            let sid = tx.create(Kind::Solid, &format!("s{}", s + 1), Some(parent));
            tx.set_pose(sid, place);
            tx.set_geometry(
                sid,
                Some(GeometryInput {
                    vertices: verts.iter().map(|v| [v.x, v.y, v.z]).collect(),
                    polygons: faces,
                }),
            );
        }
    }
    Ok(tx)
}

/// A link file's joint for a message: "revolute", "prismatic", "fixed", or "absent" (was
/// printed as Rust's `Some(Revolute)`).
fn joint_words(j: Option<LinkJoint>) -> &'static str {
    match j {
        Some(LinkJoint::Revolute) => "revolute",
        Some(LinkJoint::Prismatic) => "prismatic",
        Some(LinkJoint::Fixed) => "fixed",
        None => "absent",
    }
}
