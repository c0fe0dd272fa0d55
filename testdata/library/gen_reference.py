"""Reference forward kinematics and dynamic parameters for the standard library's robots,
computed with Peter Corke's Robotics Toolbox for Python (roboticstoolbox-python 1.5.0).

    python3 -m venv /tmp/rtbenv && /tmp/rtbenv/bin/pip install roboticstoolbox-python==1.5.0
    /tmp/rtbenv/bin/python testdata/library/gen_reference.py > testdata/library/rtb_reference.json

The tests (library-space/tests/stdlib.rs) read the JSON; they never run Python.
"""
import json
import numpy as np
import roboticstoolbox as rtb

rng = np.random.default_rng(20261122)
out = {"source": "roboticstoolbox-python " + rtb.__version__, "robots": {}}
for ours, model in [("puma560", rtb.models.DH.Puma560()), ("stanford", rtb.models.DH.Stanford()),
                    ("panda", rtb.models.DH.Panda())]:
    links = []
    for l in model.links:
        links.append({
            "prismatic": bool(l.isprismatic), "a": float(l.a), "d": float(l.d) if not l.isprismatic else 0.0,
            "alpha": float(l.alpha), "theta": float(l.theta), "offset": float(l.offset),
            "qlim": [float(x) for x in l.qlim], "mass": float(l.m), "com": [float(x) for x in l.r],
            "inertia": np.asarray(l.I).tolist(),
            "motor_inertia": float(l.Jm * l.G * l.G), "viscous": float(l.B * l.G * l.G),
        })
    samples = []
    for _ in range(25):
        q = np.array([rng.uniform(lo, hi) for lo, hi in model.qlim.T])
        samples.append({"q": q.tolist(), "pose": model.fkine(q).A.tolist()})
    out["robots"][ours] = {"name": model.name, "modified": bool(model.mdh), "links": links,
                           "tool": model.tool.A.tolist(), "base": model.base.A.tolist(), "fk": samples}
print(json.dumps(out, indent=1))
