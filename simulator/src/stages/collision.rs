//! The collision stage (robosim-collision): the robot at the new q against the scene's in-use
//! obstacles and, if declared, itself — in the declared mode (bbox, the seed's polygon algorithm,
//! exact); with `continuous`, the whole motion of the step is swept instead (conservative
//! advancement with exact distances, `robosim_collision::ccd`). A doubtful answer (`Unknown`)
//! counts as a contact. On contact the robot is put back at its last collision-free q, at rest
//! (`on_contact: stop`), or the contact is only recorded (`report`). Depends only on q.

use crate::effects::{CollisionEffect, EffectsError, OnContact};
use crate::pipeline::{Data, Model, SceneGeometry, Stage, StepError};
use nalgebra::DVector;
use robosim_collision::ccd::{Sweep, SweepOptions, sweep_robot};
use robosim_collision::robot::{CheckResult, CollisionSettings, LinkSolids, Scene, check_robot};
use robosim_kinematics::Robot;

pub struct CollisionStage {
    links: LinkSolids,
    scene: Scene,
    settings: CollisionSettings,
    on_contact: OnContact,
    q_safe: DVector<f64>,
    sweep: SweepOptions,
}

impl CollisionStage {
    pub fn new(
        robot: &Robot,
        q0: &[f64],
        c: &CollisionEffect,
        geometry: SceneGeometry,
    ) -> Result<Self, EffectsError> {
        let links = match geometry.link_solids {
            Some(l) => l,
            None => LinkSolids::from_dh(robot, c.link_radius).map_err(|e| EffectsError {
                field: "collision.link_radius".into(),
                reason: e.to_string(),
            })?,
        };
        if links.links.len() != robot.dof() + 1 {
            return Err(EffectsError {
                field: "collision".into(),
                reason: format!(
                    "{} link solids for a robot with {} joints (base first: expected {})",
                    links.links.len(),
                    robot.dof(),
                    robot.dof() + 1
                ),
            });
        }
        let settings = CollisionSettings {
            enabled: true,
            self_collision: c.self_collision,
            mode: c.mode,
            all_contacts: false,
            continuous: c.continuous,
        };
        Ok(CollisionStage {
            links,
            scene: geometry.obstacles,
            settings,
            on_contact: c.on_contact,
            q_safe: DVector::from_column_slice(q0),
            sweep: SweepOptions::default(),
        })
    }
}

impl Stage for CollisionStage {
    fn name(&self) -> &'static str {
        "collision"
    }
    fn depends_on(&self) -> &'static str {
        "q"
    }
    fn describe(&self) -> String {
        let used = self.scene.objects().iter().filter(|o| o.in_use).count();
        format!(
            "{}{}, self {}, {} obstacle(s), on contact {}",
            self.settings.mode.name(),
            if self.settings.continuous {
                " + continuous sweep"
            } else {
                ""
            },
            if self.settings.self_collision {
                "on"
            } else {
                "off"
            },
            used,
            match self.on_contact {
                OnContact::Stop => "stop",
                OnContact::Report => "report",
            }
        )
    }
    fn run(&mut self, m: &Model, d: &mut Data) -> Result<(), StepError> {
        let q = d.state.q.as_slice();
        let contact = if self.settings.continuous {
            let s = sweep_robot(
                &m.robot,
                &self.links,
                self.q_safe.as_slice(),
                q,
                &self.scene,
                self.settings.self_collision,
                &self.sweep,
            )
            .map_err(|e| StepError::Collision(e.to_string()))?;
            !matches!(s, Sweep::Clear)
        } else {
            let r = check_robot(&m.robot, &self.links, q, &self.scene, &self.settings)
                .map_err(|e| StepError::Collision(e.to_string()))?;
            !matches!(r, CheckResult::Clear)
        };
        if contact {
            d.contact_steps += 1;
            if self.on_contact == OnContact::Stop {
                d.state.q.copy_from(&self.q_safe);
                d.state.qd.fill(0.0);
            }
        } else {
            self.q_safe.copy_from(&d.state.q);
        }
        d.contact = Some(contact);
        Ok(())
    }
    fn teleported(&mut self, q: &DVector<f64>) {
        self.q_safe.copy_from(q);
    }
    fn obstacles_mut(&mut self) -> Option<&mut Scene> {
        Some(&mut self.scene)
    }
}
