//! `robosim rules` (issue 16): a CLIPS rule base reacting to a change within one notification.
//! A planner sets the positioner's waist past joint_guard.clp's soft limit; the very next
//! commit is the rule's transaction setting it back to the limit, and it is journaled (a
//! restarted keeper has it).

use robosim_hl_interface::planner::Planner;
use std::time::Duration;

mod common;

use common::{Procs, wait_for};

const RULES: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/hl-interface/rules/rulebases/joint_guard.clp"
);

#[test]
fn a_rule_sets_a_joint_back_in_the_next_commit_and_it_is_journaled() {
    let mut k = Procs::new("rules");
    let keeper = k.start_keeper(&["--scene", "surgical_positioner_cell"]);
    let rules = k.spawn(&["rules", RULES]);
    let session = k.session();
    wait_for("the rules process", || {
        session
            .processes()
            .iter()
            .any(|p| p.role == "rules")
            .then_some(())
    });
    let mut p = Planner::attach_to(&session).expect("attach");
    // The rules mirror the session when they start; let that settle (no commit expected:
    // the waist starts inside its soft limit).
    while p
        .wait_change(Duration::from_millis(300))
        .expect("wait")
        .is_some()
    {}
    let mut q = p.joints("positioner").expect("joints");
    q[0] = 1.0;
    let v = p
        .set_joints("positioner", &q)
        .expect("set past the soft limit");
    let mut seen = Vec::new();
    while seen
        .last()
        .is_none_or(|c: &robosim_hl_interface::planner::ChangeInfo| c.version <= v)
    {
        let c = p
            .wait_change(Duration::from_secs(20))
            .expect("wait")
            .expect("the rule's transaction within 20 s");
        seen.extend(c.changes);
    }
    let versions: Vec<u64> = seen.iter().map(|c| c.version).collect();
    assert_eq!(
        versions,
        vec![v, v + 1],
        "ours, then the rule's, nothing between"
    );
    assert_eq!(seen[1].names[0], "waist");
    let after = p.snapshot().expect("snapshot");
    assert_eq!(after.version(), v + 1);
    let q_after = robosim_hl_interface::planner::joints_of(&after, "positioner").expect("joints");
    assert_eq!(q_after[0], 0.8, "set back to the soft limit");
    assert_eq!(q_after[1..], q[1..], "the other joints untouched");
    // No further commit: the rule does not fire again on its own write.
    assert!(
        p.wait_change(Duration::from_millis(500))
            .expect("wait")
            .is_none()
    );
    drop(after);
    drop(p);
    k.stop(rules);
    k.stop(keeper);
    k.start_keeper(&[]);
    let mut p = Planner::attach_to(&k.session()).expect("attach again");
    let snap = p.snapshot().expect("snapshot");
    assert_eq!(
        snap.version(),
        v + 1,
        "the rule's transaction was journaled"
    );
    assert_eq!(p.joints("positioner").expect("joints")[0], 0.8);
}
