//! Collada (DAE) reading for URDF visual meshes: the few elements URDF meshes use.
//!
//! Read: `<asset>/<unit meter>` (scale to metres) and `<up_axis>` (Y_UP and X_UP are turned to
//! Z_UP); `<library_geometries>/<geometry>/<mesh>` with its `<source>`s (`<float_array>` and
//! `<technique_common>/<accessor stride>`), `<vertices>/<input semantic="POSITION">` and the
//! primitives `<triangles>`, `<polylist>` (`<vcount>`; polygons fan-triangulated) and
//! `<polygons>` (one `<p>` per polygon), each with `<input semantic="VERTEX" offset>` and `<p>`;
//! `<library_visual_scenes>/<visual_scene>/<node>` trees with `<matrix>`, `<translate>`,
//! `<rotate>` and `<scale>` and their `<instance_geometry url>` (a file without a visual scene:
//! every geometry once, untransformed); the diffuse colour of the material bound to each
//! primitive (`<bind_material>` → `<material>/<instance_effect>` → `<effect>`'s
//! `<phong|lambert|blinn|constant>/<diffuse>/<color>`). Not read: textures, normals, UVs,
//! `<instance_node>`, controllers, animations, lines.
//!
//! Errors name the file, the line and the element ([`DaeError`]).

use crate::stl::Triangles;
use nalgebra::{Matrix4, Rotation3, Vector3};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// The most triangles one Collada file may expand to (every instance of every geometry
/// counted): a geometry instanced by many nodes multiplies its triangles, so a few megabytes of
/// file could otherwise ask for tens of gigabytes. 10⁷ triangles are 720 MB as `f64`; the
/// panda's visual meshes hold 10⁴–10⁵ each.
pub const MAX_TRIANGLES: usize = 10_000_000;

/// Inputs (offsets) of one primitive, at most.
const MAX_INPUT_OFFSET: usize = 1024;

/// A malformed or unsupported Collada file: the file, the 1-based line, the element, what.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}:{line}: {element}: {reason}", file.display())]
pub struct DaeError {
    pub file: PathBuf,
    pub line: u32,
    pub element: String,
    pub reason: String,
}

/// Triangles sharing one colour (the diffuse colour of their material, when it has one).
#[derive(Debug, Clone, PartialEq)]
pub struct ColouredTriangles {
    pub triangles: Triangles,
    pub rgba: Option<[f64; 4]>,
}

struct Ctx<'a, 'i> {
    file: &'a Path,
    doc: &'a roxmltree::Document<'i>,
    ids: HashMap<&'a str, roxmltree::Node<'a, 'i>>,
    /// Triangles the file may expand to ([`MAX_TRIANGLES`]).
    budget: usize,
}

fn elem_name(n: roxmltree::Node) -> String {
    match n.attribute("id").or_else(|| n.attribute("name")) {
        Some(id) => format!("<{} id={id:?}>", n.tag_name().name()),
        None => format!("<{}>", n.tag_name().name()),
    }
}

fn kids<'a, 'i>(
    n: roxmltree::Node<'a, 'i>,
    tag: &'static str,
) -> impl Iterator<Item = roxmltree::Node<'a, 'i>> {
    n.children()
        .filter(move |c| c.is_element() && c.tag_name().name() == tag)
}

fn kid<'a, 'i>(n: roxmltree::Node<'a, 'i>, tag: &'static str) -> Option<roxmltree::Node<'a, 'i>> {
    kids(n, tag).next()
}

impl<'a, 'i> Ctx<'a, 'i> {
    fn err(&self, n: roxmltree::Node, reason: impl Into<String>) -> DaeError {
        DaeError {
            file: self.file.to_path_buf(),
            line: self.doc.text_pos_at(n.range().start).row,
            element: elem_name(n),
            reason: reason.into(),
        }
    }

    fn need(
        &self,
        n: roxmltree::Node<'a, 'i>,
        tag: &'static str,
    ) -> Result<roxmltree::Node<'a, 'i>, DaeError> {
        kid(n, tag).ok_or_else(|| self.err(n, format!("<{tag}> is missing")))
    }

    fn floats(&self, n: roxmltree::Node) -> Result<Vec<f64>, DaeError> {
        n.text()
            .unwrap_or("")
            .split_whitespace()
            .map(|w| {
                w.parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| self.err(n, format!("{w:?} is not a finite number")))
            })
            .collect()
    }

    fn ints(&self, n: roxmltree::Node) -> Result<Vec<usize>, DaeError> {
        n.text()
            .unwrap_or("")
            .split_whitespace()
            .map(|w| {
                w.parse::<usize>()
                    .map_err(|_| self.err(n, format!("{w:?} is not an index")))
            })
            .collect()
    }

    /// The element a `#id` URL names.
    fn by_url(
        &self,
        at: roxmltree::Node<'a, 'i>,
        url: &str,
    ) -> Result<roxmltree::Node<'a, 'i>, DaeError> {
        let id = url
            .strip_prefix('#')
            .ok_or_else(|| self.err(at, format!("reference {url:?} is not a local #id")))?;
        self.ids
            .get(id)
            .copied()
            .ok_or_else(|| self.err(at, format!("reference {url:?} names no element")))
    }

    /// A `<source>`'s points (stride ≥ 3; the first three values of each).
    fn positions(&self, source: roxmltree::Node<'a, 'i>) -> Result<Vec<[f64; 3]>, DaeError> {
        let fa = self.need(source, "float_array")?;
        let values = self.floats(fa)?;
        let (stride, count) = match kid(source, "technique_common").and_then(|t| kid(t, "accessor"))
        {
            Some(acc) => {
                let stride: usize = acc
                    .attribute("stride")
                    .unwrap_or("1")
                    .parse()
                    .map_err(|_| self.err(acc, "attribute `stride` is not a number"))?;
                let count: usize = acc
                    .attribute("count")
                    .ok_or_else(|| self.err(acc, "attribute `count` is missing"))?
                    .parse()
                    .map_err(|_| self.err(acc, "attribute `count` is not a number"))?;
                (stride, count)
            }
            None => (3, values.len() / 3),
        };
        if stride < 3 {
            return Err(self.err(
                source,
                format!("positions have stride {stride}; 3 or more needed"),
            ));
        }
        if count.checked_mul(stride).is_none_or(|n| n > values.len()) {
            return Err(self.err(
                fa,
                format!(
                    "{} values, but the accessor announces {count} × {stride}",
                    values.len()
                ),
            ));
        }
        Ok((0..count)
            .map(|k| {
                [
                    values[k * stride],
                    values[k * stride + 1],
                    values[k * stride + 2],
                ]
            })
            .collect())
    }

    /// The triangles of one primitive element, in the geometry's frame, by material symbol;
    /// more than `room` is refused (the file's triangle budget, [`MAX_TRIANGLES`]).
    fn primitive(
        &self,
        prim: roxmltree::Node<'a, 'i>,
        out: &mut Triangles,
        room: usize,
    ) -> Result<(), DaeError> {
        let inputs: Vec<roxmltree::Node> = kids(prim, "input").collect();
        let mut vertex_input = None;
        let mut n_offsets = 0usize;
        for inp in &inputs {
            let off: usize = inp
                .attribute("offset")
                .unwrap_or("0")
                .parse()
                .map_err(|_| self.err(*inp, "attribute `offset` is not a number"))?;
            // An offset past every index a `<p>` could hold is refused before it is used as a
            // stride (`off + 1` would overflow at usize::MAX).
            if off >= MAX_INPUT_OFFSET {
                return Err(self.err(
                    *inp,
                    format!(
                        "attribute `offset` = {off}: at most {} inputs",
                        MAX_INPUT_OFFSET
                    ),
                ));
            }
            n_offsets = n_offsets.max(off + 1);
            if inp.attribute("semantic") == Some("VERTEX") {
                vertex_input = Some((*inp, off));
            }
        }
        let (vin, voff) =
            vertex_input.ok_or_else(|| self.err(prim, "no <input semantic=\"VERTEX\">"))?;
        let url = vin
            .attribute("source")
            .ok_or_else(|| self.err(vin, "attribute `source` is missing"))?;
        let verts = self.by_url(vin, url)?;
        let pos_input = kids(verts, "input")
            .find(|i| i.attribute("semantic") == Some("POSITION"))
            .ok_or_else(|| self.err(verts, "no <input semantic=\"POSITION\">"))?;
        let src_url = pos_input
            .attribute("source")
            .ok_or_else(|| self.err(pos_input, "attribute `source` is missing"))?;
        let src = self.by_url(pos_input, src_url)?;
        if src.tag_name().name() != "source" {
            return Err(self.err(pos_input, format!("{src_url:?} is not a <source>")));
        }
        let points = self.positions(src)?;
        let point = |p: roxmltree::Node, i: usize| {
            points.get(i).copied().ok_or_else(|| {
                self.err(
                    p,
                    format!(
                        "vertex index {i} is out of range ({} positions)",
                        points.len()
                    ),
                )
            })
        };
        // Polygons as lists of position indices.
        let mut polys: Vec<(roxmltree::Node, Vec<usize>)> = Vec::new();
        let stride = n_offsets.max(1);
        let take = |p: roxmltree::Node<'a, 'i>| -> Result<Vec<usize>, DaeError> {
            let idx = self.ints(p)?;
            if idx.len() % stride != 0 {
                return Err(self.err(
                    p,
                    format!(
                        "{} indices is not a multiple of the {stride} inputs",
                        idx.len()
                    ),
                ));
            }
            Ok(idx.chunks(stride).map(|c| c[voff]).collect())
        };
        match prim.tag_name().name() {
            "triangles" => {
                let Some(p) = kid(prim, "p") else {
                    return Ok(()); // an empty primitive
                };
                let v = take(p)?;
                if v.len() % 3 != 0 {
                    return Err(self.err(p, format!("{} vertices is not whole triangles", v.len())));
                }
                for t in v.chunks(3) {
                    polys.push((p, t.to_vec()));
                }
            }
            "polylist" => {
                let Some(p) = kid(prim, "p") else {
                    return Ok(());
                };
                let vc = self.need(prim, "vcount")?;
                let counts = self.ints(vc)?;
                let v = take(p)?;
                let total = counts
                    .iter()
                    .try_fold(0usize, |a, &c| a.checked_add(c))
                    .filter(|&t| t == v.len());
                if total.is_none() {
                    return Err(self.err(
                        vc,
                        format!(
                            "vertex counts sum to {}, <p> holds {} vertices",
                            counts.iter().map(|&c| c as u128).sum::<u128>(),
                            v.len()
                        ),
                    ));
                }
                let mut at = 0;
                for c in counts {
                    polys.push((p, v[at..at + c].to_vec()));
                    at += c;
                }
            }
            "polygons" => {
                for p in kids(prim, "p") {
                    polys.push((p, take(p)?));
                }
            }
            _ => return Ok(()),
        }
        for (p, poly) in polys {
            if poly.len() < 3 {
                return Err(self.err(
                    p,
                    format!("a polygon has {} vertices; 3 or more needed", poly.len()),
                ));
            }
            if poly.len() - 2 > room.saturating_sub(out.len()) {
                return Err(self.err(
                    p,
                    format!(
                        "the file expands to more than {} triangles (every instance of every geometry counted)",
                        self.budget
                    ),
                ));
            }
            let a = point(p, poly[0])?;
            for k in 1..poly.len() - 1 {
                out.push([a, point(p, poly[k])?, point(p, poly[k + 1])?]);
            }
        }
        Ok(())
    }

    /// The diffuse colour of a `<material>`, when its effect has a `<color>`.
    fn material_colour(&self, material: roxmltree::Node<'a, 'i>) -> Option<[f64; 4]> {
        let ie = kid(material, "instance_effect")?;
        let effect = self.by_url(ie, ie.attribute("url")?).ok()?;
        let diffuse = effect
            .descendants()
            .find(|d| d.is_element() && d.tag_name().name() == "diffuse")?;
        let c = kid(diffuse, "color")?;
        let v = self.floats(c).ok()?;
        match v.as_slice() {
            [r, g, b, a] => Some([*r, *g, *b, *a]),
            [r, g, b] => Some([*r, *g, *b, 1.0]),
            _ => None,
        }
    }

    /// A geometry's primitives grouped by the colour `binding` (symbol → material) gives them.
    fn geometry(
        &self,
        geom: roxmltree::Node<'a, 'i>,
        binding: &HashMap<String, roxmltree::Node<'a, 'i>>,
        transform: &Matrix4<f64>,
        out: &mut Vec<ColouredTriangles>,
    ) -> Result<(), DaeError> {
        let Some(mesh) = kid(geom, "mesh") else {
            return Ok(()); // a spline or convex_mesh: nothing URDFs use
        };
        for prim in mesh.children().filter(|c| {
            c.is_element() && matches!(c.tag_name().name(), "triangles" | "polylist" | "polygons")
        }) {
            let used: usize = out.iter().map(|p| p.triangles.len()).sum();
            let mut tris = Vec::new();
            self.primitive(prim, &mut tris, self.budget.saturating_sub(used))?;
            let rgba = prim
                .attribute("material")
                .and_then(|s| binding.get(s))
                .and_then(|m| self.material_colour(*m));
            let tf = |p: [f64; 3]| {
                let v = transform * nalgebra::Vector4::new(p[0], p[1], p[2], 1.0);
                [v.x, v.y, v.z]
            };
            let tris: Triangles = tris
                .into_iter()
                .map(|[a, b, c]| [tf(a), tf(b), tf(c)])
                .collect();
            match out.iter_mut().find(|p| p.rgba == rgba) {
                Some(part) => part.triangles.extend(tris),
                None => out.push(ColouredTriangles {
                    triangles: tris,
                    rgba,
                }),
            }
        }
        Ok(())
    }

    fn node_transform(&self, node: roxmltree::Node) -> Result<Matrix4<f64>, DaeError> {
        let mut m = Matrix4::identity();
        for t in node.children().filter(|c| c.is_element()) {
            let want = match t.tag_name().name() {
                "matrix" => 16,
                "translate" | "scale" => 3,
                "rotate" => 4,
                _ => continue,
            };
            let v = self.floats(t)?;
            if v.len() != want {
                return Err(self.err(t, format!("{} numbers, {want} expected", v.len())));
            }
            let step = match t.tag_name().name() {
                "matrix" => Matrix4::from_row_slice(&v),
                "translate" => Matrix4::new_translation(&Vector3::new(v[0], v[1], v[2])),
                "scale" => Matrix4::new_nonuniform_scaling(&Vector3::new(v[0], v[1], v[2])),
                _ => {
                    // Normalised without overflow or underflow: `1e200 0 0` is the x axis.
                    let axis = robosim_geometry::unit_axis(Vector3::new(v[0], v[1], v[2]))
                        .ok_or_else(|| self.err(t, "rotation axis is zero or not finite"))?;
                    Rotation3::from_axis_angle(&axis, v[3].to_radians()).to_homogeneous()
                }
            };
            m *= step;
        }
        Ok(m)
    }

    fn node(
        &self,
        node: roxmltree::Node<'a, 'i>,
        parent: &Matrix4<f64>,
        out: &mut Vec<ColouredTriangles>,
        depth: usize,
    ) -> Result<(), DaeError> {
        if depth > 256 {
            return Err(self.err(node, "nodes nested more than 256 deep"));
        }
        let m = parent * self.node_transform(node)?;
        for ig in kids(node, "instance_geometry") {
            let url = ig
                .attribute("url")
                .ok_or_else(|| self.err(ig, "attribute `url` is missing"))?;
            let geom = self.by_url(ig, url)?;
            let mut binding = HashMap::new();
            if let Some(tc) = kid(ig, "bind_material").and_then(|b| kid(b, "technique_common")) {
                for im in kids(tc, "instance_material") {
                    if let (Some(sym), Some(target)) =
                        (im.attribute("symbol"), im.attribute("target"))
                        && let Ok(mat) = self.by_url(im, target)
                    {
                        binding.insert(sym.to_string(), mat);
                    }
                }
            }
            self.geometry(geom, &binding, &m, out)?;
        }
        for c in kids(node, "node") {
            self.node(c, &m, out, depth + 1)?;
        }
        Ok(())
    }
}

/// Reads a Collada file's triangles in metres, Z up, grouped by colour. `file` names it in
/// errors.
pub fn read_dae(bytes: &[u8], file: &Path) -> Result<Vec<ColouredTriangles>, DaeError> {
    read_dae_within(bytes, file, MAX_TRIANGLES)
}

/// [`read_dae`] with a triangle budget of `budget` instead of [`MAX_TRIANGLES`].
fn read_dae_within(
    bytes: &[u8],
    file: &Path,
    budget: usize,
) -> Result<Vec<ColouredTriangles>, DaeError> {
    let whole = |reason: String| DaeError {
        file: file.to_path_buf(),
        line: 0,
        element: "file".into(),
        reason,
    };
    let text = std::str::from_utf8(bytes).map_err(|e| {
        whole(format!(
            "not UTF-8 text (byte {}): not a Collada file",
            e.valid_up_to()
        ))
    })?;
    // roxmltree recurses once per nesting level: a deep file would overflow the stack.
    robosim_input::xml_depth(text, robosim_input::MAX_XML_DEPTH).map_err(|e| DaeError {
        file: file.to_path_buf(),
        line: e.line,
        element: "XML".into(),
        reason: e.to_string(),
    })?;
    let doc = roxmltree::Document::parse(text).map_err(|e| DaeError {
        file: file.to_path_buf(),
        line: e.pos().row,
        element: format!("column {}", e.pos().col),
        reason: format!("malformed XML: {e}"),
    })?;
    let root = doc.root_element();
    let mut ctx = Ctx {
        file,
        doc: &doc,
        ids: HashMap::new(),
        budget,
    };
    if root.tag_name().name() != "COLLADA" {
        return Err(ctx.err(root, "the root element is not <COLLADA>"));
    }
    for n in doc.descendants().filter(|n| n.is_element()) {
        if let Some(id) = n.attribute("id") {
            ctx.ids.insert(id, n);
        }
    }
    // Unit and up axis.
    let mut fix = Matrix4::identity();
    if let Some(asset) = kid(root, "asset") {
        if let Some(unit) = kid(asset, "unit") {
            let meter = unit.attribute("meter").unwrap_or("1");
            let s: f64 = meter
                .trim()
                .parse()
                .ok()
                .filter(|s: &f64| s.is_finite() && *s > 0.0)
                .ok_or_else(|| {
                    ctx.err(
                        unit,
                        format!("attribute `meter` = {meter:?} is not a positive number"),
                    )
                })?;
            fix = Matrix4::new_scaling(s);
        }
        if let Some(up) = kid(asset, "up_axis") {
            let r = match up.text().unwrap_or("").trim() {
                "Z_UP" => Matrix4::identity(),
                // Y up → Z up: (x, y, z) ↦ (x, −z, y).
                "Y_UP" => Matrix4::new(
                    1.0, 0.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0,
                ),
                // X up → Z up: (x, y, z) ↦ (−z, y, x).
                "X_UP" => Matrix4::new(
                    0.0, 0.0, -1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0,
                ),
                other => {
                    return Err(ctx.err(up, format!("up axis {other:?} is not X_UP, Y_UP or Z_UP")));
                }
            };
            fix = r * fix;
        }
    }
    let ctx = ctx;
    let mut out = Vec::new();
    // The scene the file instantiates, else its first visual scene, else every geometry.
    let scene = kid(root, "scene")
        .and_then(|s| kid(s, "instance_visual_scene"))
        .and_then(|i| i.attribute("url").map(|u| (i, u)));
    let visual_scene = match scene {
        Some((at, url)) => Some(ctx.by_url(at, url)?),
        None => kid(root, "library_visual_scenes").and_then(|l| kid(l, "visual_scene")),
    };
    match visual_scene {
        Some(vs) => {
            for n in kids(vs, "node") {
                ctx.node(n, &fix, &mut out, 0)?;
            }
        }
        None => {
            for lib in kids(root, "library_geometries") {
                for g in kids(lib, "geometry") {
                    ctx.geometry(g, &HashMap::new(), &fix, &mut out)?;
                }
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    const QUAD: &str = r##"<?xml version="1.0"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><unit name="millimetre" meter="0.001"/><up_axis>Y_UP</up_axis></asset>
  <library_effects><effect id="red-fx"><profile_COMMON><technique sid="c"><phong>
    <diffuse><color>1 0 0 1</color></diffuse></phong></technique></profile_COMMON></effect>
  </library_effects>
  <library_materials><material id="red"><instance_effect url="#red-fx"/></material></library_materials>
  <library_geometries>
    <geometry id="g"><mesh>
      <source id="g-pos"><float_array id="g-pos-a" count="12">0 0 0 1000 0 0 1000 1000 0 0 1000 0</float_array>
        <technique_common><accessor source="#g-pos-a" count="4" stride="3"/></technique_common></source>
      <vertices id="g-v"><input semantic="POSITION" source="#g-pos"/></vertices>
      <polylist count="1" material="m"><input semantic="VERTEX" source="#g-v" offset="0"/>
        <input semantic="NORMAL" source="#g-n" offset="1"/>
        <vcount>4</vcount><p>0 0 1 0 2 0 3 0</p></polylist>
      <triangles count="1"><input semantic="VERTEX" source="#g-v" offset="0"/><p>0 1 2</p></triangles>
    </mesh></geometry>
  </library_geometries>
  <library_visual_scenes><visual_scene id="s">
    <node id="n"><translate>0 0 2000</translate>
      <instance_geometry url="#g"><bind_material><technique_common>
        <instance_material symbol="m" target="#red"/></technique_common></bind_material>
      </instance_geometry></node>
  </visual_scene></library_visual_scenes>
  <scene><instance_visual_scene url="#s"/></scene>
</COLLADA>"##;

    #[test]
    fn units_up_axis_node_transforms_and_colours_are_applied() {
        let parts = read_dae(QUAD.as_bytes(), Path::new("q.dae")).expect("reads");
        assert_eq!(parts.len(), 2);
        let red = parts.iter().find(|p| p.rgba.is_some()).expect("present");
        assert_eq!(red.rgba, Some([1.0, 0.0, 0.0, 1.0]));
        assert_eq!(red.triangles.len(), 2);
        // (1000, 1000, 0) mm, translated by (0, 0, 2000) mm in Y-up → (1, 0, 1)·… in Z-up:
        // (x, y, z) ↦ (x, −z, y) gives (1, −2, 1) m.
        let p = red.triangles[0][2];
        let want = [1.0, -2.0, 1.0];
        for k in 0..3 {
            assert!((p[k] - want[k]).abs() < 1e-12, "{p:?}");
        }
        let plain = parts.iter().find(|p| p.rgba.is_none()).expect("present");
        assert_eq!(plain.triangles.len(), 1);
    }

    #[test]
    fn malformed_collada_names_file_line_and_element() {
        let bad_index = QUAD.replace("<p>0 1 2</p>", "<p>0 1 9</p>");
        let e = read_dae(bad_index.as_bytes(), Path::new("q.dae")).expect_err("an error");
        assert_eq!(e.element, "<p>");
        assert_eq!(e.line, 16);
        assert!(e.reason.contains("index 9"), "{e}");
        assert!(e.to_string().starts_with("q.dae:16: <p>:"), "{e}");

        let bad_float = QUAD.replace("1000 1000 0 0", "1000 x 0 0");
        let e = read_dae(bad_float.as_bytes(), Path::new("q.dae")).expect_err("an error");
        assert_eq!(e.element, "<float_array id=\"g-pos-a\">");

        let bad_ref = QUAD.replace("url=\"#g\"", "url=\"#nothing\"");
        let e = read_dae(bad_ref.as_bytes(), Path::new("q.dae")).expect_err("an error");
        assert_eq!(e.element, "<instance_geometry>");

        let bad_count = QUAD.replace("<vcount>4</vcount>", "<vcount>3</vcount>");
        let e = read_dae(bad_count.as_bytes(), Path::new("q.dae")).expect_err("an error");
        assert_eq!(e.element, "<vcount>");

        let e = read_dae(b"<COLLADA><asset>", Path::new("q.dae")).expect_err("an error");
        assert!(e.reason.contains("malformed XML"), "{e}");
        let e = read_dae(b"<robot/>", Path::new("q.dae")).expect_err("an error");
        assert!(e.reason.contains("not <COLLADA>"), "{e}");
    }
    // Issue 34 (fuzzing): sizes and offsets from the file are checked without overflow (a
    // debug build panicked on the multiplication or addition; a release build wrapped and
    // indexed out of bounds).
    #[test]
    fn collada_accessor_count_times_stride_overflowing_is_an_error_not_a_panic() {
        let huge = QUAD.replace(
            r#"count="4" stride="3""#,
            r#"count="4294967296" stride="4294967296""#,
        );
        let e = read_dae(huge.as_bytes(), Path::new("q.dae")).expect_err("an error");
        assert_eq!(e.element, "<float_array id=\"g-pos-a\">", "{e}");
        assert!(e.reason.contains("accessor announces"), "{e}");
    }

    #[test]
    fn collada_input_offset_of_usize_max_is_an_error_not_a_panic() {
        let huge = QUAD.replace(
            r##"source="#g-n" offset="1""##,
            &format!(r##"source="#g-n" offset="{}""##, usize::MAX),
        );
        let e = read_dae(huge.as_bytes(), Path::new("q.dae")).expect_err("an error");
        assert_eq!(e.line, 14, "{e}");
        assert!(e.reason.contains("attribute `offset`"), "{e}");
    }

    #[test]
    fn collada_polylist_vertex_counts_overflowing_their_sum_are_an_error_not_a_panic() {
        let huge = QUAD.replace(
            "<vcount>4</vcount>",
            &format!("<vcount>{} 5</vcount>", usize::MAX),
        );
        let e = read_dae(huge.as_bytes(), Path::new("q.dae")).expect_err("an error");
        assert_eq!(e.element, "<vcount>", "{e}");
    }

    /// A geometry instanced by many nodes multiplies its triangles: the file's expansion is
    /// bounded (here with a budget of 100 triangles; `read_dae` uses [`MAX_TRIANGLES`]).
    #[test]
    fn collada_instancing_past_the_triangle_budget_is_refused_not_an_allocation() {
        let one = r##"<node><instance_geometry url="#g"/></node>"##;
        let many = QUAD.replace(
            r#"<node id="n">"#,
            &format!(r#"{}<node id="n">"#, one.repeat(40)),
        );
        // 41 instances of 3 triangles: 123.
        let all = read_dae_within(many.as_bytes(), Path::new("q.dae"), 123).expect("within");
        assert_eq!(all.iter().map(|p| p.triangles.len()).sum::<usize>(), 123);
        let e = read_dae_within(many.as_bytes(), Path::new("q.dae"), 100).expect_err("over");
        assert!(e.reason.contains("more than 100 triangles"), "{e}");
        assert!(e.to_string().starts_with("q.dae:"), "{e}");
    }
}
