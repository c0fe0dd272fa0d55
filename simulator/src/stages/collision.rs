//! The collision stage (robosim-collision): the robot at the new q against the scene's in-use
//! obstacles and, if declared, itself — in the declared mode (bbox, the seed's polygon algorithm,
//! exact); with `continuous`, the whole motion of the step is swept instead (conservative
//! advancement with exact distances, `robosim_collision::ccd`). A doubtful answer (`Unknown`)
//! counts as a contact. On contact the robot is put back at its last collision-free q
//! (`Data::q_safe`), at rest (`on_contact: stop`), or the contact is only recorded (`report`).
//! Depends only on q.

use crate::model::{CollisionModel, Model, SceneGeometry, StepError};
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
) -> Result<CollisionModel, OptionsError> {
    let links = match geometry.link_solids {
        Some(l) => l,
        None => LinkSolids::from_dh(robot, c.link_radius).map_err(|e| OptionsError {
            field: "collision.link_radius".into(),
            reason: e.to_string(),
        })?,
    };
    if links.links.len() != robot.dof() + 1 {
        return Err(OptionsError {
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
    // the builder allocates `q_safe` and compiles the robot whenever it declares this stage
    let (Some(q_safe), Some(kin)) = (d.q_safe.as_mut(), m.kinematics.as_ref()) else {
        return Ok(());
    };
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
