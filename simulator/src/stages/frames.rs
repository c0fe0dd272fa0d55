//! Link frames: `base, A_1, …, A_n, tool` composed into world frames, written into
//! `World::frames` without allocating. Depends only on q.

use crate::pipeline::{Stage, StepError, World};
use robosim_kinematics::fk::link_transform;

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
    fn run(&mut self, w: &mut World) -> Result<(), StepError> {
        // the builder allocates `frames` (n + 2 entries) whenever it adds this stage
        let Some(frames) = w.frames.as_mut() else {
            return Ok(());
        };
        let mut t = w.robot.base;
        frames[0] = t;
        for (j, (joint, &q)) in w.robot.joints.iter().zip(w.state.q.iter()).enumerate() {
            t *= link_transform(w.robot.convention, joint, q);
            frames[j + 1] = t;
        }
        frames[w.robot.joints.len() + 1] = t * w.robot.tool;
        Ok(())
    }
}
