"""Reference mass properties (density 1) of extruded and revolved solids, computed with trimesh
5.2.0 (its own extrusion/revolution generators and mass-property code), for
core/geometry/tests/mass_reference.rs.

    /tmp/rtbenv/bin/pip install trimesh==5.2.0 shapely mapbox_earcut
    /tmp/rtbenv/bin/python testdata/library/gen_mass_reference.py > testdata/library/mass_reference.json

The centre of mass is given relative to the solid's bounding-box centre (our generators centre
solids on their bounding box); the inertia is about the centre of mass. A full revolution with
n sections is a regular-n-gon sweep in both libraries, whose second moments do not depend on
where the first section starts.
"""
import json
import numpy as np
import trimesh
from shapely.geometry import Polygon

cases = []

def add(name, kind, points, mesh, **extra):
    assert mesh.is_watertight, name
    c = mesh.bounds.mean(axis=0)
    cases.append(dict(name=name, kind=kind, points=points, volume=float(mesh.volume),
                      com_rel_bbox=(mesh.center_mass - c).tolist(),
                      inertia=np.asarray(mesh.moment_inertia).tolist(), **extra))

for name, pts, n in [
    ("revolved_cup", [[0, 0], [1, 0], [1, 1], [0.5, 1.5], [0, 1.5]], 16),
    ("revolved_l", [[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]], 24),
    ("revolved_cone_tip", [[0, -0.5], [0.3, 0.2], [0, 0.9]], 12),
]:
    add(name, "revolve", pts, trimesh.creation.revolve(np.array(pts, dtype=float), sections=n), facets=n)

for name, pts, h in [
    ("extruded_u", [[0, 0], [3, 0], [3, 2], [2, 2], [2, 1], [1, 1], [1, 2], [0, 2]], 0.5),
    ("extruded_r2_pentagon", [[-10, -10], [-10, 10], [15, 10], [25, 0], [15, -10]], 10.0),
    ("extruded_star", [[np.cos(a) * r, np.sin(a) * r] for a, r in
                       zip(np.linspace(0, 2 * np.pi, 10, endpoint=False), [1, 0.4] * 5)], 0.3),
]:
    pts = [[float(x), float(y)] for x, y in pts]
    add(name, "extrude", pts, trimesh.creation.extrude_polygon(Polygon(pts), h), height=h)

print(json.dumps({"source": "trimesh " + trimesh.__version__, "cases": cases}, indent=1))
