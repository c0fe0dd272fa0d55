//! [`CompiledScene`]: the robot and obstacle models of a snapshot, compiled once per structure
//! version and updated in place when only poses and joint values change.
//!
//! Compiling is the expensive part of using a model — decoding every robot's records, building
//! convex hulls and compounds for every solid, and probing each robot at q = 0 for the link
//! pairs that touch by construction (its allowed pairs). None of that depends on poses or joint
//! values, so the cache keys it by `(epoch, structure version)` of the snapshot
//! ([`Snapshot::structure_version`]): a joint or pose transaction (MOVEJ, MOVEJI, a planner's
//! set_joints, a knob in the display) keeps the key, and [`CompiledScene::sync`] only re-reads
//! the robots' joint values and base poses and the obstacles' world poses — O(objects), no
//! allocation beyond the obstacle list, no hull, no collision query. A structure change
//! (geometry, kinematics, dynamics, appearance, objects created or deleted) or a restarted keeper
//! (new epoch) compiles again.
//!
//! Entry points: [`CompiledScene::sync`], [`CompiledScene::robot`], [`CompiledScene::obstacles`],
//! [`CompiledScene::colliding_ids`], [`CompiledScene::stats`].

use crate::SceneError;
use crate::pose;
use crate::robot::robot_model;
use crate::solids::{bodies_under, geometry_under, solid_of, subtree};
use nalgebra::Isometry3;
use robosim_collision::Solid;
use robosim_collision::robot::{
    Body, CheckResult, CollisionSettings, LinkSolids, Scene, check_robot,
};
use robosim_instance_space::{Id, Kind, Snapshot};
use robosim_model::geometry::link_solids;
use robosim_model::{GeometryModel, Model};
use std::collections::HashSet;
use std::sync::Arc;

/// A robot of the snapshot, compiled: its kinematic/dynamic model placed where it stands, its
/// links, its collision solids and the pairs of them allowed to touch.
#[derive(Clone)]
pub struct CompiledRobot {
    /// Index of the robot object in the snapshot (stable while the structure version is).
    pub index: usize,
    pub id: Id,
    /// base = the robot object's world pose, tool = its tool record (kept current by `sync`).
    pub robot: robosim_kinematics::Robot,
    /// Link ids in chain order.
    pub links: Vec<Id>,
    /// Link object indices in chain order.
    pub link_index: Vec<usize>,
    /// The committed joint values (rad or m), kept current by `sync`: `robot.nq()` of them —
    /// a floating robot's root coordinates first, always the identity (its base is where the
    /// robot object stands: `robot.base`).
    pub q: Vec<f64>,
    /// The robot object and everything under it.
    pub subtree: HashSet<Id>,
    /// The collision objects of the base (frame 0) and each link (frame j), from the robot's
    /// Instance Space records, placed in their frame ([`CompiledRobot::model`]).
    pub geometry: GeometryModel,
    /// Collision solids, base first, built from `geometry` by
    /// [`robosim_model::geometry::link_solids`]; `allowed`: a tree's joint pairs and the link
    /// pairs that overlap at q = 0 (structural contacts of the model, e.g. a housing around a
    /// joint — MoveIt's "default" collisions).
    pub solids: LinkSolids,
    /// The objects with geometry that make up the base (0) and each link (1..=n).
    pub link_bodies: Vec<Vec<Id>>,
}

impl CompiledRobot {
    pub fn name(&self) -> &str {
        &self.robot.name
    }

    /// The robot as the one robot model: its `robot` (placed where it stands), the link
    /// objects' names as link and joint names, its collision geometry (no visuals, no
    /// coupling: the Instance Space records hold neither).
    pub fn model(&self, snap: &Snapshot) -> Model {
        let names: Vec<String> = (self.link_index.iter())
            .map(|&k| snap.name(k).to_owned())
            .collect();
        Model {
            robot: self.robot.clone(),
            joint_names: names.clone(),
            link_names: names,
            coupling: None,
            geometry: self.geometry.clone(),
            ik: Model::recognised_ik(&self.robot),
        }
    }
}

/// An object with geometry, as a collision solid at its world pose.
#[derive(Clone)]
pub struct SolidObject {
    pub index: usize,
    pub id: Id,
    /// Path from its top object (`head/cylinder1`), as the seed's collision structure names it.
    pub path: String,
    pub solid: Arc<Solid>,
    pub pose: Isometry3<f64>,
}

/// The obstacles around one robot, as the collision core's scene: every object with geometry
/// outside the robot's subtree and not in the caller's DONTUSE set; `names[k]` and `ids[k]`
/// name the scene's object `k`.
pub struct Obstacles {
    pub scene: Scene,
    pub names: Vec<String>,
    pub ids: Vec<Id>,
    /// Obstacles (outside the robot, not unused) whose geometry makes no collision solid,
    /// with why: a check against this scene cannot say "clear" while this is not empty.
    pub refused: Vec<String>,
}

/// What [`CompiledScene::sync`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sync {
    /// The structure changed (or the first snapshot): everything compiled.
    Compiled,
    /// Only poses and joint values changed: updated in place.
    Posed,
    /// The snapshot is the one already applied.
    Unchanged,
}

/// Counters, for benches and tests: how often the cache compiled, and how often it updated.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CacheStats {
    pub compiles: u64,
    pub pose_updates: u64,
}

/// The compiled models of one session's snapshots (see the module docs).
#[derive(Default)]
pub struct CompiledScene {
    /// (epoch, structure version) compiled; `None` before the first sync.
    key: Option<(u64, u64)>,
    version: u64,
    robots: Vec<CompiledRobot>,
    /// Robots that could not be compiled, with why (asked for by name, they say so).
    failed: Vec<(String, SceneError)>,
    objects: Vec<SolidObject>,
    /// Objects whose geometry makes no collision solid, with why: a check that would need
    /// them says so instead of treating them as absent.
    refused: Vec<(Id, String)>,
    stats: CacheStats,
}

impl CompiledScene {
    pub fn new() -> Self {
        Self::default()
    }

    /// Compiles `snap` once and returns the cache (for one-shot users: render, demo).
    pub fn of(snap: &Snapshot) -> Self {
        let mut c = Self::new();
        c.sync(snap);
        c
    }

    /// Brings the cache to `snap`: compiles on a new structure version or keeper epoch,
    /// else updates joint values and poses in place.
    pub fn sync(&mut self, snap: &Snapshot) -> Sync {
        let key = (snap.epoch(), snap.structure_version());
        if self.key != Some(key) {
            self.compile(snap);
            self.key = Some(key);
            self.version = snap.version();
            self.stats.compiles += 1;
            return Sync::Compiled;
        }
        if self.version == snap.version() {
            return Sync::Unchanged;
        }
        let poses = snap.poses();
        for r in &mut self.robots {
            r.robot.base = pose::to_matrix(&snap.world_pose(r.index));
            let root_nq = r.robot.root_nq();
            for (qj, &k) in r.q.iter_mut().skip(root_nq).zip(&r.link_index) {
                *qj = poses[k].joint;
            }
        }
        for o in &mut self.objects {
            o.pose = pose::to_isometry(&snap.world_pose(o.index));
        }
        self.version = snap.version();
        self.stats.pose_updates += 1;
        Sync::Posed
    }

    fn compile(&mut self, snap: &Snapshot) {
        self.objects.clear();
        self.refused.clear();
        for i in 0..snap.len() {
            match solid_of(snap, i) {
                Ok(None) => {}
                Ok(Some(solid)) => self.objects.push(SolidObject {
                    index: i,
                    id: snap.rec(i).id,
                    path: snap.path(i),
                    solid: Arc::new(solid),
                    pose: pose::to_isometry(&snap.world_pose(i)),
                }),
                Err(reason) => self.refused.push((snap.rec(i).id, reason)),
            }
        }
        self.robots.clear();
        self.failed.clear();
        for view in snap.robots() {
            match compile_robot(snap, &view) {
                Ok(r) => self.robots.push(r),
                Err(e) => self.failed.push((view.name.to_owned(), e)),
            }
        }
    }

    /// The snapshot version last applied.
    pub fn version(&self) -> u64 {
        self.version
    }

    /// The structure version compiled.
    pub fn structure_version(&self) -> Option<u64> {
        self.key.map(|k| k.1)
    }

    pub fn stats(&self) -> CacheStats {
        self.stats
    }

    /// The compiled robots, in id order.
    pub fn robots(&self) -> &[CompiledRobot] {
        &self.robots
    }

    /// Robots that could not be compiled, with the reason.
    pub fn failed(&self) -> &[(String, SceneError)] {
        &self.failed
    }

    /// Every object with geometry as a solid at its world pose.
    pub fn objects(&self) -> &[SolidObject] {
        &self.objects
    }

    /// Objects whose geometry makes no collision solid: (id, why).
    pub fn refused(&self) -> &[(Id, String)] {
        &self.refused
    }

    /// The robot called `name`: compiled, or why not.
    pub fn robot(&self, name: &str) -> Result<&CompiledRobot, SceneError> {
        if let Some(r) = self.robots.iter().find(|r| r.robot.name == name) {
            return Ok(r);
        }
        if let Some((_, e)) = self.failed.iter().find(|(n, _)| n == name) {
            return Err(e.clone());
        }
        let known: Vec<&str> = self
            .robots
            .iter()
            .map(|r| r.robot.name.as_str())
            .chain(self.failed.iter().map(|(n, _)| n.as_str()))
            .collect();
        Err(SceneError::UnknownRobot {
            name: name.to_owned(),
            known: known.join(", "),
        })
    }

    /// The obstacles around `robot`: every solid outside its subtree and not in `unused`, at
    /// its current world pose. Shares the compiled solids (no hull is rebuilt).
    pub fn obstacles(&self, robot: &CompiledRobot, unused: &HashSet<Id>) -> Obstacles {
        let mut out = Obstacles {
            scene: Scene::new(),
            names: Vec::new(),
            ids: Vec::new(),
            refused: self
                .refused
                .iter()
                .filter(|(id, _)| !robot.subtree.contains(id) && !unused.contains(id))
                .map(|(_, why)| why.clone())
                .collect(),
        };
        for o in &self.objects {
            if robot.subtree.contains(&o.id) || unused.contains(&o.id) {
                continue;
            }
            out.scene.add(o.path.as_str(), o.solid.clone(), o.pose);
            out.names.push(o.path.clone());
            out.ids.push(o.id);
        }
        out
    }

    /// Puts the compiled robots' joints at `joints` (link object id, joint value in rad or m),
    /// e.g. a running simulator's published state; links not named keep their values. Only
    /// the robots' `q` changes: a later [`CompiledScene::sync`] to a new version puts them back
    /// at the snapshot's values, one to the same version leaves them.
    pub fn set_joints(&mut self, joints: &[(Id, f64)]) {
        for r in &mut self.robots {
            let root_nq = r.robot.root_nq();
            for (qj, id) in r.q.iter_mut().skip(root_nq).zip(&r.links) {
                if let Some((_, q)) = joints.iter().find(|(link, _)| link == id) {
                    *qj = *q;
                }
            }
        }
    }

    /// Every object with geometry in contact, for the display's collision highlight: each
    /// robot at its current q against itself (allowed pairs excepted) and the objects outside
    /// it (exact mode, all contacts).
    pub fn colliding_ids(&self) -> HashSet<Id> {
        let settings = CollisionSettings {
            all_contacts: true,
            ..CollisionSettings::default()
        };
        let mut hit = HashSet::new();
        for r in &self.robots {
            let obs = self.obstacles(r, &HashSet::new());
            let Ok(CheckResult::Contact(cs)) =
                check_robot(&r.robot, &r.solids, &r.q, &obs.scene, &settings)
            else {
                continue;
            };
            for c in cs {
                for b in [&c.a, &c.b] {
                    match b {
                        Body::Link(j) => {
                            hit.extend(r.link_bodies.get(*j).into_iter().flatten().copied())
                        }
                        Body::Object { index, .. } => hit.extend(obs.ids.get(*index).copied()),
                        Body::RobotLink { .. } => {}
                    }
                }
            }
        }
        hit
    }
}

/// Compiles one robot (see [`CompiledRobot`]).
fn compile_robot(
    snap: &Snapshot,
    view: &robosim_instance_space::RobotView<'_>,
) -> Result<CompiledRobot, SceneError> {
    // Validated by `robot_model`.
    let robot = robot_model(snap, view)?;
    let mut objects = geometry_under(snap, view.id, 0, true);
    for (j, joint) in view.joints.iter().enumerate() {
        objects.extend(geometry_under(snap, joint.id, j + 1, false));
    }
    let geometry = GeometryModel { objects };
    let mut solids =
        link_solids(&geometry, robot.dof()).map_err(|source| SceneError::Geometry {
            robot: view.name.to_owned(),
            source,
        })?;
    let mut link_bodies = vec![
        snap.children(view.id)
            .filter(|&k| snap.object(k).kind() != Some(Kind::Link))
            .flat_map(|k| bodies_under(snap, snap.rec(k).id))
            .collect::<Vec<Id>>(),
    ];
    link_bodies.extend(view.joints.iter().map(|j| bodies_under(snap, j.id)));
    // In a tree, a joint's link meets the link it hangs from at the joint, as adjacent links of
    // a chain do (which the checker skips by index): declared allowed. These replace
    // `link_solids`' own (links separated only by links without solids): the scene allows
    // what touches at q = 0 below instead, so a solid two links away is still checked.
    solids.allowed = (robot.parents.iter().enumerate())
        .filter(|&(j, &p)| p != j)
        .map(|(j, &p)| (p, j + 1))
        .collect();
    // Allowed pairs (the seed's robot-declared exceptions): link solids that already overlap
    // at the DH zero configuration are structural contacts of the model, not events. Adjacent
    // links are skipped by the checker itself. Done once per structure version.
    // q = 0 for the joints (a floating robot's root at the identity)
    let zero: Vec<f64> = robot.neutral_q().iter().copied().collect();
    let self_only = CollisionSettings {
        all_contacts: true,
        ..CollisionSettings::default()
    };
    if let Ok(CheckResult::Contact(cs)) =
        check_robot(&robot, &solids, &zero, &Scene::new(), &self_only)
    {
        for c in cs {
            if let (Body::Link(a), Body::Link(b)) = (&c.a, &c.b) {
                solids.allowed.push(((*a).min(*b), (*a).max(*b)));
            }
        }
    }
    let mut q: Vec<f64> = robot.neutral_q().as_slice()[..robot.root_nq()].to_vec();
    q.extend(view.joints.iter().map(|j| j.q));
    Ok(CompiledRobot {
        index: view.index,
        id: view.id,
        robot,
        links: view.joints.iter().map(|j| j.id).collect(),
        link_index: view.joints.iter().map(|j| j.index).collect(),
        q,
        subtree: subtree(snap, view.id),
        geometry,
        solids,
        link_bodies,
    })
}
