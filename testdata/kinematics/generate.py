#!/usr/bin/env python3
"""Generates the kinematics reference data from Robotics Toolbox for Python (roboticstoolbox-python).

Run (from the repository root):
    python3 -m venv /tmp/rtbenv && /tmp/rtbenv/bin/pip install roboticstoolbox-python==1.5.0
    /tmp/rtbenv/bin/python testdata/kinematics/generate.py

Writes, next to this script:
  puma560.json, stanford.json, panda.json   the robots in robosim's inline robot format (DESIGN.md)
  reference_fk_jacobian.json                FK pose, link frames and Jacobians (base and tool frame)
  reference_puma_ikine_a.json               Puma560.ikine_a for all 8 configurations
The Rust tests read these files; they never run Python.
"""
import json
import math
import os

import numpy as np
import roboticstoolbox as rtb
from roboticstoolbox import __version__ as rtb_version

HERE = os.path.dirname(os.path.abspath(__file__))
RNG = np.random.default_rng(20261122)


def mat(m):
    return [[float(x) for x in row] for row in np.asarray(m)]


def robot_json(robot, name, source):
    joints = []
    raw = []
    for link in robot.links:
        j = {
            "type": "prismatic" if link.isprismatic else "revolute",
            "a": float(link.a),
            "d": float(link.d),
            "alpha": float(link.alpha),
            "theta": float(link.theta),
            "offset": float(link.offset),
            "qlim": [float(link.qlim[0]), float(link.qlim[1])],
            "mass": float(link.m),
            "com": [float(x) for x in np.asarray(link.r).reshape(3)],
            "inertia": mat(np.asarray(link.I).reshape(3, 3)),
        }
        G = float(link.G) if link.G is not None else 1.0
        Jm = float(link.Jm) if link.Jm is not None else 0.0
        B = float(link.B) if link.B is not None else 0.0
        Tc = [float(x) for x in np.asarray(link.Tc).reshape(-1)] if link.Tc is not None else [0.0, 0.0]
        # Reflected to the joint side as RTB's Link.friction and inertia do: Jm G^2, B G^2, |G| Tc.
        j["motor_inertia"] = Jm * G * G
        j["viscous"] = B * G * G
        j["coulomb"] = abs(G) * (abs(Tc[0]) + abs(Tc[-1])) / 2.0
        joints.append(j)
        raw.append({"G": G, "Jm": Jm, "B": B, "Tc": Tc})
    return {
        "name": name,
        "convention": "modified" if robot.mdh else "standard",
        "joints": joints,
        "gravity": [0.0, 0.0, -9.81],
        "base": mat(robot.base.A),
        "tool": mat(robot.tool.A),
        "source": {
            "generator": f"testdata/kinematics/generate.py, roboticstoolbox-python {rtb_version}",
            "reference": source,
            "motor_side_parameters": raw,
            "note": "motor_inertia = Jm G^2, viscous = B G^2, coulomb = |G| (|Tc+| + |Tc-|)/2 "
            "(the model holds one symmetric Coulomb magnitude; the raw asymmetric Tc is kept here)",
        },
    }


def random_q(robot, k):
    lo = robot.qlim[0]
    hi = robot.qlim[1]
    return [lo + (hi - lo) * RNG.random(robot.n) for _ in range(k)]


def main():
    robots = [
        ("puma560", rtb.models.DH.Puma560(),
         "rtb.models.DH.Puma560: Corke & Armstrong-Helouvry, 'A search for consensus among model "
         "parameters reported for the PUMA 560 robot', ICRA 1994 (kinematics and dynamics); joint "
         "limits from Wang & Chen, IEEE Trans. RA 7(4) 1991. Includes the 26.45 in pedestal as d1."),
        ("stanford", rtb.models.DH.Stanford(),
         "rtb.models.DH.Stanford: Stanford arm (Scheinman), kinematic and dynamic parameters as in "
         "Paul, 'Robot Manipulators' (1981) and Corke's Robotics Toolbox."),
        ("panda", rtb.models.DH.Panda(),
         "rtb.models.DH.Panda: Franka Emika Panda, modified DH from Franka's published control "
         "parameters (frankaemika.github.io/docs/control_parameters.html); inertial parameters as "
         "shipped in roboticstoolbox-python (identified values of Gaz, Cognetti, Oliva, Robuffo "
         "Giordano, De Luca, IEEE RA-L 4(4) 2019); tool = 0.103 m along z, rotated -45 deg about z."),
    ]
    ref = {"generator": f"roboticstoolbox-python {rtb_version}", "robots": {}}
    for name, robot, source in robots:
        description = robot_json(robot, name, source)
        if name == "puma560":
            # d1 is 26.45 in, exactly 0.67183 m; RTB's float product 26.45 * 0.0254 is one unit
            # in the last place low (0.6718299999999999). The file carries the published value,
            # as library-space/stdlib/puma560.rsl does (library-space/tests/builtin_tables.rs).
            description["joints"][0]["d"] = 0.67183
        with open(os.path.join(HERE, f"{name}.json"), "w") as f:
            json.dump(description, f, indent=1)
            f.write("\n")
        samples = []
        qs = [np.zeros(robot.n)] + random_q(robot, 40)
        for q in qs:
            frames = robot.fkine_all(q)
            samples.append({
                "q": [float(x) for x in q],
                "pose": mat(robot.fkine(q).A),
                # fkine_all: base frame, then the frame at the end of each A_j (no tool)
                "frames": [mat(T.A) for T in frames],
                "jacobian_base": mat(robot.jacob0(q)),
                "jacobian_tool": mat(robot.jacobe(q)),
            })
        ref["robots"][name] = samples
    with open(os.path.join(HERE, "reference_fk_jacobian.json"), "w") as f:
        json.dump(ref, f)
        f.write("\n")

    puma = rtb.models.DH.Puma560()
    cases = []
    for q in random_q(puma, 30):
        T = puma.fkine(q)
        sols = {}
        for cfg in ["lun", "luf", "ldn", "ldf", "run", "ruf", "rdn", "rdf"]:
            s = puma.ikine_a(T, config=cfg)
            sols[cfg] = {"success": bool(s.success),
                         "q": [float(x) for x in s.q] if s.success else None}
        cases.append({"q": [float(x) for x in q], "pose": mat(T.A), "solutions": sols})
    with open(os.path.join(HERE, "reference_puma_ikine_a.json"), "w") as f:
        json.dump({"generator": f"roboticstoolbox-python {rtb_version}, Puma560.ikine_a",
                   "cases": cases}, f)
        f.write("\n")


if __name__ == "__main__":
    main()
