//! The collision stage (robosim-collision): the robot at the new q against the scene's in-use
//! obstacles and, if declared, itself — in the declared mode (bbox, the seed's polygon algorithm,
//! exact); with `continuous`, the whole motion of the step is swept instead (conservative
//! advancement with exact distances, `robosim_collision::ccd`). A doubtful answer (`Unknown`)
//! counts as a contact. On contact the robot is put back at its last collision-free q
//! (`Data::q_safe`), at rest (`on_contact: stop`), or the contact is only recorded (`report`).
//! Depends only on q.

use crate::model::{BuildError, CollisionModel, Model, SceneGeometry, StepError};
use robosim_collision::ccd::{Sweep, SweepOptions, sweep_robot_compiled};
use robosim_collision::robot::{CheckResult, CollisionSettings, LinkSolids, check_robot_compiled};
use robosim_kinematics::Robot;
use robosim_model::{CollisionEffect, Data, OnContact, OptionsError};

pub const NAME: &str = "collision";
pub const DEPENDS_ON: &str = "q";

pub fn build(
    robot: &Robot,
    c: &CollisionEffect,
    geometry: SceneGeometry,
) -> Result<CollisionModel, BuildError> {
    let links = match geometry.link_solids {
        Some(l) => l,
        None => LinkSolids::from_dh(robot, c.link_radius)
            .map_err(|source| BuildError::LinkSolids { source })?,
    };
    if links.links.len() != robot.dof() + 1 {
        return Err(BuildError::Options(OptionsError {
            field: "collision".into(),
            reason: format!(
                "{} link solids for a robot with {} joints (base first: expected {})",
                links.links.len(),
                robot.dof(),
                robot.dof() + 1
            ),
        }));
    }
    let settings = CollisionSettings {
        enabled: true,
        self_collision: c.self_collision,
        mode: c.mode,
        all_contacts: false,
        continuous: c.continuous,
        // The stage keeps a yes/no per step (`Data::contact`): the certified boolean alone.
        depth: None,
    };
    Ok(CollisionModel {
        links,
        scene: geometry.obstacles,
        settings,
        on_contact: c.on_contact,
        sweep: SweepOptions {
            distance: c.tolerance,
            ..SweepOptions::default()
        },
    })
}

pub fn describe(c: &CollisionModel) -> String {
    let used = c.scene.objects().iter().filter(|o| o.in_use).count();
    format!(
        "{}{}, self {}, {} obstacle(s), on contact {}",
        c.settings.mode.name(),
        if c.settings.continuous {
            " + continuous sweep"
        } else {
            ""
        },
        if c.settings.self_collision {
            "on"
        } else {
            "off"
        },
        used,
        c.on_contact.name()
    )
}

/// Checks the step's q (or sweeps from `d.q_safe` to it), sets `d.contact`, counts contact
/// steps, and on contact under `stop` puts the robot back at `d.q_safe`, at rest; a clear q
/// becomes the new `d.q_safe`.
pub fn run(m: &Model, c: &CollisionModel, d: &mut Data) -> Result<(), StepError> {
    // the builder allocates `q_safe` and compiles the robot whenever it declares this stage;
    // data without them was not made for this model, and is refused rather than left unchecked
    let kin = m.kinematics.as_ref().ok_or(StepError::Missing {
        stage: NAME,
        what: "the compiled kinematic model (`Model::kinematics`)",
    })?;
    let q_safe = d.q_safe.as_mut().ok_or(StepError::Missing {
        stage: NAME,
        what: "the last collision-free q (`Data::q_safe`)",
    })?;
    let q = d.state.q.as_slice();
    let contact = if c.settings.continuous {
        let s = sweep_robot_compiled(
            kin,
            &m.robot,
            &c.links,
            q_safe.as_slice(),
            q,
            &c.scene,
            c.settings.self_collision,
            &c.sweep,
        )
        .map_err(StepError::Collision)?;
        !matches!(s, Sweep::Clear)
    } else {
        let r = check_robot_compiled(kin, &m.robot, &c.links, q, &c.scene, &c.settings)
            .map_err(StepError::Collision)?;
        !matches!(r, CheckResult::Clear)
    };
    if contact {
        d.contact_steps += 1;
        if c.on_contact == OnContact::Stop {
            d.state.q.copy_from(q_safe);
            d.state.qd.fill(0.0);
        }
    } else {
        q_safe.copy_from(&d.state.q);
    }
    d.contact = Some(contact);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Pipeline;
    use robosim_dynamics::fixture_robot;
    use robosim_model::Options;

    /// A PUMA with the collision effect declared (DH-segment solids, no obstacles), at a q
    /// clear of itself.
    fn declared() -> Pipeline {
        let robot = fixture_robot("puma560").expect("fixture compiled in");
        let effects = Options {
            collision: Some(CollisionEffect {
                self_collision: false,
                ..CollisionEffect::default()
            }),
            ..Options::default()
        };
        Pipeline::build(
            &robot,
            &[0.0, 0.4, -0.6, 0.0, 0.5, 0.0],
            &effects,
            SceneGeometry::default(),
        )
        .expect("builds")
    }

    #[test]
    fn the_stage_refuses_data_without_its_last_safe_q_instead_of_skipping_the_check() {
        let p = declared();
        let (m, c) = (p.model(), p.model().collision.as_ref().expect("declared"));
        let mut d = p.data().clone();
        run(m, c, &mut d).expect("the pipeline's own data steps");
        assert_eq!(d.contact, Some(false));
        d.contact = None;
        d.q_safe = None;
        let e = run(m, c, &mut d).expect_err("refused");
        assert!(
            matches!(e, StepError::Missing { stage: NAME, what } if what.contains("Data::q_safe")),
            "{e}"
        );
        assert_eq!(d.contact, None, "nothing was recorded");
        assert!(e.to_string().starts_with("collision: "), "{e}");
    }

    #[test]
    fn the_stage_refuses_a_model_without_the_compiled_robot() {
        let p = declared();
        let mut m = p.model().clone();
        m.kinematics = None;
        let c = p.model().collision.as_ref().expect("declared");
        let e = run(&m, c, &mut p.data().clone()).expect_err("refused");
        assert!(
            matches!(e, StepError::Missing { stage: NAME, what } if what.contains("Model::kinematics")),
            "{e}"
        );
    }
}
