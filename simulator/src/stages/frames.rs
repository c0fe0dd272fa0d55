//! Link frames: `base, A_1, …, A_n, tool` composed into world frames, written into
//! `Data::frames` without allocating. Depends only on q.

use crate::pipeline::{Data, Model, Stage, StepError};
use robosim_kinematics::fk::link_frames_into;

pub struct LinkFrames;

impl Stage for LinkFrames {
    fn name(&self) -> &'static str {
        "link_frames"
    }
    fn depends_on(&self) -> &'static str {
        "q"
    }
    fn describe(&self) -> String {
        "forward kinematics: every link frame and the tool".into()
    }
    fn run(&mut self, m: &Model, d: &mut Data) -> Result<(), StepError> {
        // the builder allocates `frames` (n + 2 entries) whenever it adds this stage
        if let Some(frames) = d.frames.as_mut() {
            link_frames_into(&m.robot, d.state.q.as_slice(), frames);
        }
        Ok(())
    }
}
