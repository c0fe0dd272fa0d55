"""Plan collision-free MOVEJIs of the surgical positioner (seed §2.7) to targets on the head.

    robosim up surgical_positioner_cell --with display --session lab   # the display watches
    python3 python/examples/surgical_planner.py --session lab

Targets: the tool tip 20.1 cm from the head's axis (1 mm off its surface), pointing at the
axis, at several angles above the horizontal on the robot's side and along the axis (the
seed's get_location). For each target: KINV gives every IK solution; they are tried nearest
first, each as a MOVEJI whose every step is collision-checked by the session (it stops at the
last safe step and names the colliding pair); a stopped move is planned again from where it
stopped with the next solution. Every step is one transaction, so a display attached to the
session shows the motion as it happens.
"""

import argparse
import sys

import numpy as np

import robosim

TIP_FROM_AXIS = 0.201  # m
ROBOT = "positioner"


def location(head, base, angle_deg, along):
    """The tool pose (4x4, world) for one target on the head."""
    axis = head[:3, 2] if head[:3, 2].sum() >= 0 else -head[:3, 2]
    centre = head[:3, 3]
    to_robot = base[:3, 3] - centre
    horiz = to_robot - axis * axis.dot(to_robot)
    horiz[2] = 0.0
    horiz /= np.linalg.norm(horiz)
    up = np.cross(axis, horiz)
    up = up if up[2] >= 0 else -up
    up /= np.linalg.norm(up)
    a = np.radians(angle_deg)
    radial = horiz * np.cos(a) + up * np.sin(a)
    tip = centre + axis * along + radial * TIP_FROM_AXIS
    z = -radial
    x = axis
    y = np.cross(z, x)
    t = np.eye(4)
    t[:3, 0], t[:3, 1], t[:3, 2], t[:3, 3] = x, y, z, tip
    return t


def reach(s, target, steps):
    """MOVEJI to some IK solution of target without collision; the answer of the last move."""
    try:
        sols = s.query({"op": "kinv", "robot": ROBOT, "pose": target, "all": True})["solutions"]
    except robosim.RobosimError as e:
        return f"no IK ({e.kind}: {e.message})"
    q_now = s.joints(ROBOT)
    sols = [x for x in sols if x["within_limits"]]
    sols.sort(key=lambda x: float(np.abs(np.asarray(x["q"]) - q_now).max()))
    tried = []
    for sol in sols:
        r = s.query({"op": "moveji", "robot": ROBOT, "q": sol["q"], "steps": steps})
        if r["completed"]:
            return f"reached at version {r['version']} ({len(tried)} solution(s) stopped first)"
        tried.append(r["stopped_by"])
    return f"not reached: every solution's path collides ({len(sols)} tried)"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--session", default="lab")
    ap.add_argument("--steps", type=int, default=30, help="MOVEJI steps per move")
    args = ap.parse_args()
    s = robosim.Session(args.session)
    snap = s.snapshot()
    head, base = snap.pose("head"), snap.pose(ROBOT)
    home = snap.joints(ROBOT)
    results = []
    for angle in (30.0, 45.0, 60.0):
        for along in (-0.05, 0.0, 0.05):
            t = location(head, base, angle, along)
            outcome = reach(s, t, args.steps)
            results.append(outcome.startswith("reached"))
            print(f"target {angle:4.0f} deg, {along:+.2f} m along the axis: {outcome}")
    r = s.query({"op": "moveji", "robot": ROBOT, "q": home, "steps": args.steps})
    print(f"back home: {'done' if r['completed'] else 'stopped'}; {sum(results)}/{len(results)} targets reached")
    return 0 if any(results) else 1


if __name__ == "__main__":
    sys.exit(main())
