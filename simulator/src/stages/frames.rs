//! Link frames: `base, A_1, …, A_n, tool` composed into world frames, written into
//! `Data::frames` without allocating. Depends only on q.

use crate::model::Model;
use robosim_model::Data;

pub const NAME: &str = "link_frames";
pub const DEPENDS_ON: &str = "q";

pub fn describe() -> String {
    "forward kinematics: every link frame and the tool".into()
}

/// Fills `d.frames` (allocated, `dof + 2` entries, whenever the pipeline declares this stage)
/// from the robot compiled once with the pipeline (`Model::kinematics`, built whenever this
/// stage is): the frames of `robosim_kinematics::fk::link_frames_into`, bit for bit.
pub fn run(m: &Model, d: &mut Data) {
    if let (Some(frames), Some(k)) = (d.frames.as_mut(), m.kinematics.as_ref()) {
        k.link_frames_into(d.state.q.as_slice(), frames);
    }
}
