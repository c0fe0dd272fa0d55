#!/usr/bin/env python3
"""Reference values for robosim's URDF export, computed by Pinocchio (pip package `pin`).

Reads the URDF files robosim wrote (`robosim export NAME.urdf --scene NAME`, checked in beside
this script) and writes pinocchio_reference.json: for each robot, 20 random joint vectors within
the limits (seed 15), the pose of the `NAME_tool` frame in the world (4x4, row-major) and the
gravity torques g(q) (pin.computeGeneralizedGravity, gravity (0, 0, -9.81)). file-io's test
`exported_urdf_read_by_pinocchio_matches_robosim` checks robosim's own FK and gravity against them.

Usage, from the repository root: python3 testdata/file-io/urdf/pinocchio_reference.py
"""
import json
import os

import numpy as np
import pinocchio as pin

HERE = os.path.dirname(os.path.abspath(__file__))
out = {"pinocchio": pin.__version__, "robots": {}}
rng = np.random.default_rng(15)
for name in ["puma560", "stanford", "panda"]:
    model = pin.buildModelFromUrdf(os.path.join(HERE, f"{name}.urdf"))
    data = model.createData()
    tool = model.getFrameId(f"{name}_tool")
    samples = []
    for _ in range(20):
        q = rng.uniform(model.lowerPositionLimit, model.upperPositionLimit)
        pin.framesForwardKinematics(model, data, q)
        pose = data.oMf[tool].homogeneous
        g = pin.computeGeneralizedGravity(model, data, q)
        samples.append({"q": q.tolist(), "tool": pose.tolist(), "gravity": g.tolist()})
    out["robots"][name] = samples
with open(os.path.join(HERE, "pinocchio_reference.json"), "w") as f:
    json.dump(out, f, indent=1)
    f.write("\n")
print("wrote pinocchio_reference.json with Pinocchio", pin.__version__)
