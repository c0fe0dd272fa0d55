//! The robots of one daemon see each other where they are simulated.
//!
//! Every robot's pipeline has the other robots' link geometry among its collision obstacles
//! (the compiled scene's objects outside its own subtree). Built from the Instance Space, those
//! obstacles stand at the other robots' *committed* joint values; the daemon, though, simulates
//! the other robots too, and their pipelines may have turned them elsewhere (a solar array
//! tracking the sun or parked for a swap, a robot driven to a `target`). [`Follow`] moves those
//! obstacles to the other robots' *simulated* joints:
//!
//! * **When, in a step:** [`Follow::show`] runs before the pipelines step, so every pipeline's
//!   collision stage checks its robot's new state against the other robots' joints at the
//!   **start of the step** (where the previous step, and the stages after it, left them). The
//!   order of the pipelines in the daemon therefore does not matter: the result is the same
//!   whichever steps first (deterministic).
//! * **Cost:** only a robot whose simulated q changed since it was last shown is moved — one
//!   forward kinematics of that robot and one placement per object of its links in every other
//!   pipeline's scene. Nothing is tessellated or compiled again (the compiled solids are
//!   shared; [`robosim_collision::robot::Scene::set_pose`] moves a placement and its box).
//! * **Other writers:** a committed change from the Instance Space still reaches the other
//!   pipelines: the daemon teleports the changed robot's pipeline to its committed joints and
//!   rebuilds [`Follow`] (every robot is shown again at the next step), and a moved base
//!   rebuilds that robot's pipeline, whose new base the next [`Follow::show`] uses.
//! * **Not followed:** objects a stage owns (the swap stage's ORUs, which it places itself in
//!   the servicer's scene) and objects of a robot mounted on another robot's link (they are
//!   shown with their own robot's joints, on their own robot's committed base).

use crate::Sim;
use nalgebra::Isometry3;
use robosim_collision::robot::isometry_from_matrix;
use robosim_instance_space::Id;
use robosim_scene::CompiledScene;
use std::collections::{HashMap, HashSet};

/// One object of a robot's link: its index among the compiled scene's objects, the link (0 the
/// base, j link j) and its pose in that link's frame.
struct Body {
    object: usize,
    link: usize,
    in_link: Isometry3<f64>,
}

/// Where each robot's link objects are in the other pipelines' obstacle scenes (module docs).
pub(crate) struct Follow {
    /// Per robot (the daemon's `sims` order): its link objects.
    bodies: Vec<Vec<Body>>,
    /// Per pipeline: compiled object index → index in that pipeline's obstacle scene.
    local: Vec<Vec<Option<usize>>>,
    /// Per robot: the q its objects were last placed at in the others' scenes.
    shown: Vec<Option<Vec<f64>>>,
}

impl Follow {
    /// The map for `sims` (one per compiled robot, same order) built from `scene` at its
    /// committed joints, leaving out the objects in `owned` (a stage places them). Every robot
    /// is shown again at the next [`Follow::show`].
    pub(crate) fn build(scene: &CompiledScene, sims: &[Sim], owned: &HashSet<Id>) -> Follow {
        let objects = scene.objects();
        let index: HashMap<Id, usize> =
            objects.iter().enumerate().map(|(g, o)| (o.id, g)).collect();
        let robots = scene.robots();
        let bodies = robots
            .iter()
            .take(sims.len())
            .map(|r| {
                let frames = robosim_kinematics::fk::link_frames(&r.robot, &r.q);
                r.link_bodies
                    .iter()
                    .enumerate()
                    .flat_map(|(link, ids)| ids.iter().map(move |id| (link, id)))
                    .filter(|(_, id)| !owned.contains(id))
                    .filter_map(|(link, id)| {
                        let g = *index.get(id)?;
                        let frame = isometry_from_matrix(frames.get(link)?);
                        Some(Body {
                            object: g,
                            link,
                            in_link: frame.inverse() * objects[g].pose,
                        })
                    })
                    .collect()
            })
            .collect();
        // a pipeline's obstacle scene holds the compiled objects outside its robot's subtree,
        // in order (CompiledScene::obstacles)
        let local = robots
            .iter()
            .take(sims.len())
            .map(|r| {
                let mut next = 0;
                objects
                    .iter()
                    .map(|o| {
                        (!r.subtree.contains(&o.id)).then(|| {
                            next += 1;
                            next - 1
                        })
                    })
                    .collect()
            })
            .collect();
        Follow {
            bodies,
            local,
            shown: vec![None; sims.len()],
        }
    }

    /// Places every robot whose simulated q changed since it was last shown in the other
    /// pipelines' obstacle scenes (module docs: called before the pipelines step). Returns how
    /// many robots were moved.
    pub(crate) fn show(&mut self, sims: &mut [Sim]) -> usize {
        let mut moved = 0;
        for k in 0..sims.len().min(self.bodies.len()) {
            let q = sims[k].pipeline.data().state.q.as_slice();
            if self.shown[k].as_deref() == Some(q) {
                continue;
            }
            let frames = robosim_kinematics::fk::link_frames(&sims[k].pipeline.model().robot, q);
            let poses: Vec<(usize, Isometry3<f64>)> = self.bodies[k]
                .iter()
                .filter_map(|b| {
                    let f = frames.get(b.link)?;
                    Some((b.object, isometry_from_matrix(f) * b.in_link))
                })
                .collect();
            self.shown[k] = Some(q.to_vec());
            moved += 1;
            for (p, sim) in sims.iter_mut().enumerate() {
                if p == k {
                    continue;
                }
                let (Some(local), Some(scene)) = (self.local.get(p), sim.pipeline.obstacles_mut())
                else {
                    continue;
                };
                for (g, pose) in &poses {
                    if let Some(Some(j)) = local.get(*g) {
                        scene.set_pose(*j, *pose);
                    }
                }
            }
        }
        moved
    }
}
