//! The bodies a robot check is about: the scene's objects and its USE list ([`Scene`]), a
//! robot's link solids ([`LinkSolids`]) and where they are at q ([`link_poses`]), the bodies and
//! colliding pairs a check reports ([`Body`], [`Collision`]), and why a check cannot run
//! ([`CheckError`]). Shared by the discrete checks ([`crate::robot`]) and the continuous one
//! ([`crate::ccd`]); [`crate::robot`] re-exports all of it, so `robot::Scene` etc. still name it.

use crate::bbox::{exact_box, world_box};
use crate::solid::{ShapeError, Solid};
use nalgebra::{Isometry3, Matrix4, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};
use parry3d_f64::bounding_volume::Aabb as PAabb;
use parry3d_f64::partitioning::Bvh;
use robosim_geometry::Aabb;
use robosim_kinematics::{Convention, JointType, ModelError, Robot, fk};
use std::sync::Arc;

/// Scenes with at least this many objects in use are searched through the BVH; smaller ones
/// by a linear scan of boxes (cheaper below this size).
const BVH_THRESHOLD: usize = 16;

/// The rigid transform of a 4×4 homogeneous matrix (assumed rigid, as `Robot::validate` and
/// the query layer check).
pub fn isometry_from_matrix(m: &Matrix4<f64>) -> Isometry3<f64> {
    let r = Rotation3::from_matrix_unchecked(m.fixed_view::<3, 3>(0, 0).into_owned());
    Isometry3::from_parts(
        Translation3::new(m[(0, 3)], m[(1, 3)], m[(2, 3)]),
        UnitQuaternion::from_rotation_matrix(&r),
    )
}

fn paabb(b: &Aabb) -> PAabb {
    PAabb::new(b.mins(), b.maxs())
}

/// One object of a scene.
#[derive(Debug, Clone)]
pub struct SceneObject {
    pub name: String,
    pub solid: Arc<Solid>,
    pub pose: Isometry3<f64>,
    pub in_use: bool,
    world_box: Aabb,
    /// The world box of [`crate::bbox::exact_box`]: it holds the exact solid (the BVH's box).
    exact_world_box: Aabb,
}

impl SceneObject {
    /// The world box of the faceted form (`Solid::bbox`).
    pub fn world_box(&self) -> &Aabb {
        &self.world_box
    }

    /// A world box that holds the exact solid (the faceted box widened by the tessellation
    /// error), for the exact mode's culling.
    pub fn exact_world_box(&self) -> &Aabb {
        &self.exact_world_box
    }
}

/// The objects of a simulation and the seed's USE list.
#[derive(Debug, Clone, Default)]
pub struct Scene {
    objects: Vec<SceneObject>,
    bvh: Bvh,
    in_use: usize,
}

impl Scene {
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds an object at `pose` and puts it in use (USE); returns its index.
    pub fn add(
        &mut self,
        name: impl Into<String>,
        solid: Arc<Solid>,
        pose: Isometry3<f64>,
    ) -> usize {
        let (world_box, exact_world_box) = (
            world_box(&solid.bbox, &pose),
            world_box(&exact_box(&solid), &pose),
        );
        self.objects.push(SceneObject {
            name: name.into(),
            solid,
            pose,
            in_use: false,
            world_box,
            exact_world_box,
        });
        let id = self.objects.len() - 1;
        self.use_object(id);
        id
    }

    /// USE: the object takes part in collision checks. Out-of-range ids are ignored.
    pub fn use_object(&mut self, id: usize) {
        if let Some(o) = self.objects.get_mut(id)
            && !o.in_use
        {
            o.in_use = true;
            self.in_use += 1;
            self.bvh.insert(paabb(&o.exact_world_box), id as u32);
        }
    }

    /// DONTUSE: the object is skipped by collision checks (it costs nothing).
    pub fn dont_use(&mut self, id: usize) {
        if let Some(o) = self.objects.get_mut(id)
            && o.in_use
        {
            o.in_use = false;
            self.in_use -= 1;
            self.bvh.remove(id as u32);
        }
    }

    /// Moves an object (PRE/POSTTRANSLATE, PRE/POSTROTATE end here).
    pub fn set_pose(&mut self, id: usize, pose: Isometry3<f64>) {
        if let Some(o) = self.objects.get_mut(id) {
            o.pose = pose;
            o.world_box = world_box(&o.solid.bbox, &pose);
            o.exact_world_box = world_box(&exact_box(&o.solid), &pose);
            if o.in_use {
                self.bvh.insert(paabb(&o.exact_world_box), id as u32);
            }
        }
    }

    pub fn objects(&self) -> &[SceneObject] {
        &self.objects
    }

    /// Indices of the in-use objects whose exact world boxes ([`SceneObject::exact_world_box`],
    /// which hold the faceted boxes too) meet `b` (appended to `out`).
    pub fn candidates(&self, b: &Aabb, out: &mut Vec<usize>) {
        if self.in_use < BVH_THRESHOLD {
            out.extend(
                self.objects
                    .iter()
                    .enumerate()
                    .filter(|(_, o)| o.in_use && o.exact_world_box.overlaps(b))
                    .map(|(i, _)| i),
            );
        } else {
            let q = paabb(b);
            out.extend(self.bvh.intersect_aabb(&q).map(|i| i as usize));
        }
    }
}

/// The solid of one link, placed in its link frame.
#[derive(Debug, Clone)]
pub struct LinkSolid {
    pub solid: Arc<Solid>,
    /// Solid frame → link frame.
    pub offset: Isometry3<f64>,
}

/// A robot's collision geometry: `links[0]` the base, `links[j]` link j (1..=n), `None` for a
/// link without a solid; `allowed` lists link pairs never checked against each other.
#[derive(Debug, Clone, Default)]
pub struct LinkSolids {
    pub links: Vec<Option<LinkSolid>>,
    pub allowed: Vec<(usize, usize)>,
}

/// Why a check could not run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CheckError {
    /// q is the wrong length or not finite.
    #[error("{0}")]
    Model(#[from] ModelError),
    /// The link solids do not match the robot: there must be `dof + 1` entries (base first).
    #[error(
        "link solids: {got} entries for a robot with {dof} joints (expected {expected}: the base, then one per joint)"
    )]
    LinkCount {
        dof: usize,
        got: usize,
        expected: usize,
    },
    /// A solid could not be built.
    #[error("{0}")]
    Shape(#[from] ShapeError),
    /// `steps` of a MOVEJI is zero.
    #[error("steps must be at least 1")]
    ZeroSteps,
}

impl LinkSolids {
    /// Simple link solids from the DH parameters, for robots whose model carries none: a
    /// square-section box of side `2 × radius` (m) along each non-zero DH segment — the d
    /// segment along z and the a segment along x — attached to the link that carries it
    /// (standard DH: both to link j; modified DH: a_{j−1} to link j−1, d_j to link j), and one
    /// along the tool offset on link n. A prismatic joint's own (sliding) d segment is left out.
    /// Links that end up with no solid are `None`; pairs of links separated only by such empty
    /// links are declared allowed (they meet at a shared joint, like adjacent links).
    pub fn from_dh(robot: &Robot, radius: f64) -> Result<Self, CheckError> {
        if !(radius.is_finite() && radius > 0.0) {
            return Err(ShapeError::BadDimension {
                field: "link_radius",
                value: radius,
            }
            .into());
        }
        let n = robot.dof();
        let mut segs: Vec<Vec<(Point3<f64>, Point3<f64>)>> = vec![Vec::new(); n + 1];
        for (k, j) in robot.joints.iter().enumerate() {
            let link = k + 1;
            let prismatic = j.joint_type == JointType::Prismatic;
            match robot.convention {
                Convention::Standard => {
                    // In frame k: o_{k−1} at Rx(−α)(−a, 0, −d), the elbow point at Rx(−α)(−a, 0, 0).
                    let rx = Rotation3::from_axis_angle(&Vector3::x_axis(), -j.alpha);
                    let elbow = Point3::from(rx * Vector3::new(-j.a, 0.0, 0.0));
                    let prev = Point3::from(rx * Vector3::new(-j.a, 0.0, -j.d));
                    if !prismatic {
                        segs[link].push((prev, elbow));
                    }
                    segs[link].push((elbow, Point3::origin()));
                }
                Convention::Modified => {
                    segs[link - 1].push((Point3::origin(), Point3::new(j.a, 0.0, 0.0)));
                    if !prismatic {
                        segs[link].push((Point3::new(0.0, 0.0, -j.d), Point3::origin()));
                    }
                }
            }
        }
        let tool_t = Point3::new(robot.tool[(0, 3)], robot.tool[(1, 3)], robot.tool[(2, 3)]);
        segs[n].push((Point3::origin(), tool_t));
        let mut parts = Vec::with_capacity(n + 1);
        for s in &segs {
            let mut link = Vec::new();
            for (p, q) in s {
                let v = q - p;
                let len = v.norm();
                if len < 1e-9 {
                    continue;
                }
                let b = Solid::cuboid(Vector3::new(len, 2.0 * radius, 2.0 * radius))?;
                let rot =
                    UnitQuaternion::rotation_between(&Vector3::x(), &v).unwrap_or_else(|| {
                        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), std::f64::consts::PI)
                    });
                link.push((
                    Isometry3::from_parts(Translation3::from(p.coords + v * 0.5), rot),
                    b,
                ));
            }
            parts.push(link);
        }
        Self::from_parts(parts)
    }

    /// Link solids from convex parts placed in each link frame: `parts[0]` the base's, `parts[j]`
    /// link j's (solid frame → link frame), for any joint model (DH rows, URDF origins and
    /// axes). A link with no part is `None`, one part is its solid at its offset, several make
    /// a compound. Pairs of links separated only by links without solids are declared allowed
    /// (they meet at a shared joint, like adjacent links). [`Self::from_dh`] ends here, and so
    /// does the URDF importer's collision geometry.
    pub fn from_parts(parts: Vec<Vec<(Isometry3<f64>, Solid)>>) -> Result<Self, CheckError> {
        let mut links = Vec::with_capacity(parts.len());
        for mut link in parts {
            links.push(match link.len() {
                0 => None,
                1 => link.pop().map(|(offset, s)| LinkSolid {
                    solid: Arc::new(s),
                    offset,
                }),
                _ => Some(LinkSolid {
                    solid: Arc::new(Solid::compound(link)?),
                    offset: Isometry3::identity(),
                }),
            });
        }
        let mut allowed = Vec::new();
        let solid_links: Vec<usize> = (0..links.len()).filter(|&i| links[i].is_some()).collect();
        for w in solid_links.windows(2) {
            if w[1] > w[0] + 1 {
                allowed.push((w[0], w[1]));
            }
        }
        Ok(LinkSolids { links, allowed })
    }

    fn allows(&self, i: usize, j: usize) -> bool {
        self.allowed
            .iter()
            .any(|&(a, b)| (a, b) == (i, j) || (a, b) == (j, i))
    }

    /// The pairs self-collision checks: non-adjacent links with solids, minus allowed pairs.
    pub fn self_pairs(&self) -> Vec<(usize, usize)> {
        self.self_pair_iter().collect()
    }

    /// [`Self::self_pairs`] without collecting them (no allocation per check).
    pub fn self_pair_iter(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        let n = self.links.len();
        (0..n)
            .flat_map(move |i| (i + 2..n).map(move |j| (i, j)))
            .filter(|&(i, j)| {
                self.links[i].is_some() && self.links[j].is_some() && !self.allows(i, j)
            })
    }
}

/// A body taking part in a collision: a scene object, or a link of the checked robot (0 = base).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Body {
    Object {
        index: usize,
        name: String,
    },
    /// A link of the robot being checked ([`crate::robot::check_robot`]).
    Link(usize),
    /// A link of robot `robot` (its index in the slice given to [`crate::robot::check_robots`]).
    RobotLink {
        robot: usize,
        link: usize,
    },
}

/// One colliding pair — the seed's collision structure (S1, L1, S2, L2) with witness points.
#[derive(Debug, Clone, PartialEq)]
pub struct Collision {
    pub a: Body,
    pub b: Body,
    /// Minus the penetration depth, when the mode gives it (m).
    pub signed_distance: Option<f64>,
    /// World points on a and on b (exact), or the piercing point (polygon).
    pub witness: Option<[Point3<f64>; 2]>,
}

/// The world pose of every link solid at q: `poses[j]` for `links[j]` (`None` where no solid).
pub fn link_poses(robot: &Robot, links: &LinkSolids, q: &[f64]) -> Vec<Option<Isometry3<f64>>> {
    let frames = fk::link_frames(robot, q);
    links
        .links
        .iter()
        .enumerate()
        .map(|(j, l)| {
            l.as_ref()
                .map(|l| isometry_from_matrix(&frames[j]) * l.offset)
        })
        .collect()
}

pub(crate) fn check_link_count(robot: &Robot, links: &LinkSolids) -> Result<(), CheckError> {
    if links.links.len() != robot.dof() + 1 {
        return Err(CheckError::LinkCount {
            dof: robot.dof(),
            got: links.links.len(),
            expected: robot.dof() + 1,
        });
    }
    Ok(())
}
