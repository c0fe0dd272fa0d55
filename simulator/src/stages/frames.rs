//! Link frames: `base, A_1, …, A_n, tool` composed into world frames, written into
//! `Data::frames` without allocating. Depends only on q.

use crate::model::{Model, StepError};
use robosim_model::Data;

pub const NAME: &str = "link_frames";
pub const DEPENDS_ON: &str = "q";

pub fn describe() -> String {
    "forward kinematics: every link frame and the tool".into()
}

/// Fills `d.frames` (allocated, `dof + 2` entries, whenever the pipeline declares this stage)
/// from the robot compiled once with the pipeline (`Model::kinematics`, built whenever this
/// stage is): the frames of `robosim_kinematics::fk::link_frames_into`, bit for bit.
/// Data without the frames, or a model without the compiled robot, is refused
/// ([`StepError::Missing`]) rather than left unfilled.
pub fn run(m: &Model, d: &mut Data) -> Result<(), StepError> {
    let k = m.kinematics.as_ref().ok_or(StepError::Missing {
        stage: NAME,
        what: "the compiled kinematic model (`Model::kinematics`)",
    })?;
    let frames = d.frames.as_mut().ok_or(StepError::Missing {
        stage: NAME,
        what: "the link frames (`Data::frames`)",
    })?;
    k.link_frames_into(d.state.q.as_slice(), frames);
    Ok(())
}
