"""Reference figures for the Panda's visual Collada meshes (file-io/tests/urdf_geometry.rs).

Independent of robosim's reader (file-io/src/dae.rs): Python's ElementTree and numpy. For each
visual .dae that panda.urdf names: the number of triangles (from each <triangles count=...>
attribute, and counted from <p>), and the axis-aligned bounding box of the vertices after each
<node>'s <matrix> chain, the <unit meter> scale and the <up_axis> (all Panda files are Z_UP, metre).
Only what these files use is handled (nested <node> with <matrix>, <instance_geometry>,
<triangles>); anything else is an error here, so the figures cannot silently drop geometry.

Run from the repository root:  python3 testdata/urdf/panda_visual_meshes.py > testdata/urdf/panda_visual_meshes.json
"""

import json
import pathlib
import re
import xml.etree.ElementTree as ET

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
NS = {"c": "http://www.collada.org/2005/11/COLLADASchema"}


def q(tag):
    return "{%s}%s" % (NS["c"], tag)


def mesh_figures(path):
    root = ET.parse(path).getroot()
    ids = {e.get("id"): e for e in root.iter() if e.get("id")}
    unit = root.find("c:asset/c:unit", NS)
    meter = float(unit.get("meter")) if unit is not None else 1.0
    up = root.find("c:asset/c:up_axis", NS)
    assert up is None or up.text.strip() == "Z_UP", path
    scene_url = root.find("c:scene/c:instance_visual_scene", NS).get("url")
    scene = ids[scene_url[1:]]
    tris_declared = 0
    points = []

    def visit(node, m):
        nonlocal tris_declared
        for child in node:
            if child.tag == q("matrix"):
                m = m @ np.array([float(x) for x in child.text.split()]).reshape(4, 4)
            elif child.tag in (q("translate"), q("rotate"), q("scale"), q("instance_node")):
                raise ValueError(f"{path}: {child.tag} not handled")
        for ig in node.findall("c:instance_geometry", NS):
            geom = ids[ig.get("url")[1:]]
            mesh = geom.find("c:mesh", NS)
            for prim in mesh:
                if prim.tag in (q("polylist"), q("polygons")):
                    raise ValueError(f"{path}: {prim.tag} not handled")
                if prim.tag != q("triangles"):
                    continue
                inputs = prim.findall("c:input", NS)
                stride = max(int(i.get("offset")) for i in inputs) + 1
                vin = [i for i in inputs if i.get("semantic") == "VERTEX"][0]
                voff = int(vin.get("offset"))
                verts = ids[vin.get("source")[1:]]
                pos = [i for i in verts.findall("c:input", NS) if i.get("semantic") == "POSITION"][0]
                src = ids[pos.get("source")[1:]]
                acc = src.find("c:technique_common/c:accessor", NS)
                astride = int(acc.get("stride"))
                fa = np.array([float(x) for x in src.find("c:float_array", NS).text.split()])
                xyz = fa.reshape(-1, astride)[:, :3]
                idx = np.array([int(x) for x in prim.find("c:p", NS).text.split()])
                vidx = idx.reshape(-1, stride)[:, voff]
                count = int(prim.get("count"))
                assert len(vidx) == 3 * count, (path, len(vidx), count)
                tris_declared += count
                h = np.hstack([xyz[vidx], np.ones((len(vidx), 1))]) @ m.T
                points.append(h[:, :3] * meter)
        for child in node.findall("c:node", NS):
            visit(child, m)

    for n in scene.findall("c:node", NS):
        visit(n, np.eye(4))
    p = np.vstack(points)
    return {
        "triangles": tris_declared,
        "min": p.min(axis=0).tolist(),
        "max": p.max(axis=0).tolist(),
    }


def main():
    urdf = (HERE / "panda.urdf").read_text()
    names = re.findall(r'filename="package://example-robot-data/([^"]+\.dae)"', urdf)
    out = {}
    for rel in sorted(set(names)):
        out[rel] = mesh_figures(HERE / "example-robot-data" / rel)
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
