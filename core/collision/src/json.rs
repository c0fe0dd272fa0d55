//! DESIGN.md's shape form ("The query protocol") read into a [`Solid`], and rigid poses as 4×4
//! row-major nested arrays: the one reader of them, used by the query protocol's `collide` and
//! `check` and by this crate's tests (their checked-in fixtures are in this form).
//!
//! Shapes: `box` size, `sphere` radius, `cylinder`/`cone` radius + height, `convex` points,
//! `mesh` vertices + polygons, plus `facets` on round shapes and `compound` (`parts`: shapes
//! each with a `pose`). A sphere's `facets` is at most [`MAX_SPHERE_FACETS`].
//!
//! Entry points: [`solid_from_json`], [`pose_from_json`]. Errors ([`ShapeJsonError`]) name the
//! field path.

use crate::{ShapeError, Solid};
use nalgebra::{Isometry3, Point3, Vector3};
use robosim_kinematics::json::{JsonError, matrix4_from_json, number, number_array};
use serde_json::{Map, Value};

/// The most meridians a sphere may have: the geometry's largest default
/// ([`robosim_geometry::shapes::MAX_FACETS`], for radii above about 13 m). A sphere of n
/// meridians has about n²/2 faces and as many vertices, and building its collision solid tests
/// every vertex against every face: the explicit maximum of the geometry
/// (`SPHERE_FACET_LIMIT`, 1024) took hours for one `collide` (found by the `protocol` fuzz
/// target; docs/fuzzing.md).
pub const MAX_SPHERE_FACETS: usize = robosim_geometry::shapes::MAX_FACETS;

/// A shape or pose that could not be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ShapeJsonError {
    /// A field is missing, of the wrong type, unknown, or out of range (the protocol's
    /// `bad_request`).
    #[error(transparent)]
    Field(#[from] JsonError),
    /// The fields were read but make no solid (degenerate, non-convex, ...; the protocol's
    /// `bad_shape`).
    #[error("{path}: {source}")]
    Shape {
        path: String,
        #[source]
        source: ShapeError,
    },
}

fn bad(path: impl Into<String>, reason: impl Into<String>) -> ShapeJsonError {
    ShapeJsonError::Field(JsonError::new(path, reason))
}

fn field<'a>(v: &'a Value, key: &str, path: &str) -> Result<&'a Value, ShapeJsonError> {
    v.get(key)
        .ok_or_else(|| bad(format!("{path}.{key}"), "missing"))
}

fn num(v: &Value, key: &str, path: &str) -> Result<f64, ShapeJsonError> {
    Ok(number(field(v, key, path)?, &format!("{path}.{key}"))?)
}

fn point_list(v: &Value, path: &str) -> Result<Vec<Point3<f64>>, ShapeJsonError> {
    let arr = v
        .as_array()
        .ok_or_else(|| bad(path, "expected an array of [x, y, z]"))?;
    arr.iter()
        .enumerate()
        .map(|(i, p)| {
            let c = number_array(p, &format!("{path}[{i}]"))?;
            if c.len() != 3 {
                return Err(bad(
                    format!("{path}[{i}]"),
                    format!("expected 3 numbers, got {}", c.len()),
                ));
            }
            Ok(Point3::new(c[0], c[1], c[2]))
        })
        .collect()
}

fn check_keys(
    obj: &Map<String, Value>,
    allowed: &[&str],
    extra: &[&str],
    path: &str,
) -> Result<(), ShapeJsonError> {
    for k in obj.keys() {
        if !allowed.contains(&k.as_str()) && !extra.contains(&k.as_str()) {
            return Err(bad(
                format!("{path}.{k}"),
                format!(
                    "unknown field (expected one of {:?})",
                    [allowed, extra].concat()
                ),
            ));
        }
    }
    Ok(())
}

/// A rigid 4×4 pose (row-major nested arrays); refuses non-rigid matrices.
pub fn pose_from_json(v: &Value, path: &str) -> Result<Isometry3<f64>, ShapeJsonError> {
    let m = matrix4_from_json(v, path)?;
    let r = m.fixed_view::<3, 3>(0, 0);
    let err = (r.transpose() * r - nalgebra::Matrix3::identity())
        .abs()
        .max();
    if !(err < 1e-9
        && (r.determinant() - 1.0).abs() < 1e-9
        && m[(3, 0)] == 0.0
        && m[(3, 1)] == 0.0
        && m[(3, 2)] == 0.0
        && m[(3, 3)] == 1.0)
    {
        return Err(bad(
            path,
            "not a rigid transform (orthonormal rotation, det +1, last row 0 0 0 1)",
        ));
    }
    Ok(crate::robot::isometry_from_matrix(&m))
}

/// A solid from DESIGN.md's shape JSON. `extra` lists keys the caller handles (name, pose…).
pub fn solid_from_json(v: &Value, path: &str, extra: &[&str]) -> Result<Solid, ShapeJsonError> {
    shape_from_json(v, path, extra, true)
}

/// [`solid_from_json`] for exact mode alone: a cylinder or cone is built without its faceted
/// form ([`Solid::round_exact`]: same fields read, same refusals, same exact shape and
/// tessellation error); every other shape whole. The bbox and polygon modes must not be given
/// what it returns ([`Solid::has_faceted_form`]).
pub fn exact_solid_from_json(
    v: &Value,
    path: &str,
    extra: &[&str],
) -> Result<Solid, ShapeJsonError> {
    shape_from_json(v, path, extra, false)
}

/// `faceted`: build the faceted form of round shapes too (compound parts always have it).
fn shape_from_json(
    v: &Value,
    path: &str,
    extra: &[&str],
    faceted: bool,
) -> Result<Solid, ShapeJsonError> {
    let obj = v
        .as_object()
        .ok_or_else(|| bad(path, "expected a shape object"))?;
    let kind = obj
        .get("shape")
        .and_then(Value::as_str)
        .ok_or_else(|| bad(format!("{path}.shape"), "missing or not a string"))?;
    let facets = |o: &Map<String, Value>| -> Result<Option<usize>, ShapeJsonError> {
        match o.get("facets") {
            None | Some(Value::Null) => Ok(None),
            Some(f) => f
                .as_u64()
                .map(|n| Some(n as usize))
                .ok_or_else(|| bad(format!("{path}.facets"), "expected a positive integer")),
        }
    };
    let shape_err = |source: ShapeError| ShapeJsonError::Shape {
        path: path.to_owned(),
        source,
    };
    match kind {
        "box" => {
            check_keys(obj, &["shape", "size"], extra, path)?;
            let s = number_array(field(v, "size", path)?, &format!("{path}.size"))?;
            if s.len() != 3 {
                return Err(bad(format!("{path}.size"), "expected 3 numbers"));
            }
            Solid::cuboid(Vector3::new(s[0], s[1], s[2])).map_err(shape_err)
        }
        "sphere" => {
            check_keys(obj, &["shape", "radius", "facets"], extra, path)?;
            let f = facets(obj)?;
            if let Some(n) = f
                && n > MAX_SPHERE_FACETS
            {
                return Err(bad(
                    format!("{path}.facets"),
                    format!(
                        "at most {MAX_SPHERE_FACETS} for a sphere, got {n} (n meridians make about n²/2 faces)"
                    ),
                ));
            }
            Solid::sphere(num(v, "radius", path)?, f).map_err(shape_err)
        }
        "cylinder" | "cone" => {
            check_keys(obj, &["shape", "radius", "height", "facets"], extra, path)?;
            let (r, h, f) = (
                num(v, "radius", path)?,
                num(v, "height", path)?,
                facets(obj)?,
            );
            match (faceted, kind == "cone") {
                (false, cone) => Solid::round_exact(cone, r, h, f),
                (true, false) => Solid::cylinder(r, h, f),
                (true, true) => Solid::cone(r, h, f),
            }
            .map_err(shape_err)
        }
        "convex" => {
            check_keys(obj, &["shape", "points"], extra, path)?;
            Solid::convex(&point_list(
                field(v, "points", path)?,
                &format!("{path}.points"),
            )?)
            .map_err(shape_err)
        }
        "mesh" => {
            check_keys(obj, &["shape", "vertices", "polygons"], extra, path)?;
            let verts = point_list(field(v, "vertices", path)?, &format!("{path}.vertices"))?;
            let polys = field(v, "polygons", path)?.as_array().ok_or_else(|| {
                bad(
                    format!("{path}.polygons"),
                    "expected an array of index lists",
                )
            })?;
            let mut faces = Vec::with_capacity(polys.len());
            for (i, p) in polys.iter().enumerate() {
                let ids = p.as_array().ok_or_else(|| {
                    bad(
                        format!("{path}.polygons[{i}]"),
                        "expected an array of vertex indices",
                    )
                })?;
                let f: Option<Vec<u32>> = ids
                    .iter()
                    .map(|x| x.as_u64().and_then(|n| u32::try_from(n).ok()))
                    .collect();
                faces.push(f.ok_or_else(|| {
                    bad(
                        format!("{path}.polygons[{i}]"),
                        "indices must be non-negative integers",
                    )
                })?);
            }
            Solid::mesh(verts, &faces).map_err(shape_err)
        }
        "compound" => {
            check_keys(obj, &["shape", "parts"], extra, path)?;
            let parts = field(v, "parts", path)?
                .as_array()
                .ok_or_else(|| bad(format!("{path}.parts"), "expected an array"))?;
            let mut out = Vec::with_capacity(parts.len());
            for (i, p) in parts.iter().enumerate() {
                let pp = format!("{path}.parts[{i}]");
                let pose = pose_from_json(field(p, "pose", &pp)?, &format!("{pp}.pose"))?;
                out.push((pose, solid_from_json(p, &pp, &["pose"])?));
            }
            Solid::compound(out).map_err(shape_err)
        }
        other => Err(bad(
            format!("{path}.shape"),
            format!(
                "unknown shape \"{other}\" (box, sphere, cylinder, cone, convex, mesh, compound)"
            ),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn exact_only_round_shapes_answer_exact_mode_as_the_whole_solids_do() {
        use crate::exact::{self, ExactOptions};
        let other = solid_from_json(&json!({"shape": "box", "size": [0.3, 0.2, 0.4]}), "b", &[])
            .expect("box");
        let shapes = [
            json!({"shape": "cylinder", "radius": 0.2, "height": 0.5}),
            json!({"shape": "cone", "radius": 0.15, "height": 0.4}),
            json!({"shape": "cylinder", "radius": 0.05, "height": 2.0, "facets": 3}),
            json!({"shape": "cone", "radius": 1.5, "height": 0.1, "facets": 40}),
        ];
        for v in &shapes {
            let whole = solid_from_json(v, "a", &[]).expect("whole");
            let lean = exact_solid_from_json(v, "a", &[]).expect("exact only");
            assert!(whole.has_faceted_form() && !lean.has_faceted_form(), "{v}");
            assert_eq!(whole.kind, lean.kind);
            assert_eq!(
                whole.tessellation_error.to_bits(),
                lean.tessellation_error.to_bits(),
                "{v}"
            );
            assert_eq!(whole.exact_volume, lean.exact_volume);
            assert_eq!(whole.exact_offset, lean.exact_offset);
            // The faceted box lies inside the exact one.
            for k in 0..3 {
                assert!(whole.bbox.half[k] <= lean.bbox.half[k] + 1e-15, "{v}");
            }
            // Exact mode answers the same, bit for bit, in contact and apart.
            for i in 0..24 {
                let t = i as f64 / 24.0;
                let pb = Isometry3::new(
                    Vector3::new(0.6 * t - 0.05, 0.1 * (7.0 * t).sin(), 0.2 * t - 0.1),
                    Vector3::new(0.3, 1.1 * t, -0.4),
                );
                let pa = Isometry3::identity();
                for opts in [ExactOptions::default(), ExactOptions::BOOLEAN] {
                    assert_eq!(
                        format!("{:?}", exact::collide(&whole, &pa, &other, &pb, opts)),
                        format!("{:?}", exact::collide(&lean, &pa, &other, &pb, opts)),
                        "{v} at {i}"
                    );
                    assert_eq!(
                        format!("{:?}", exact::collide(&other, &pb, &whole, &pa, opts)),
                        format!("{:?}", exact::collide(&other, &pb, &lean, &pa, opts)),
                        "{v} at {i}, swapped"
                    );
                }
            }
        }
        // Refused alike, with the same message: sizes, facet counts, flat solids (exact form
        // flat; exact form sound but near the bound, where the whole solid decides), fields.
        let refused = [
            json!({"shape": "cylinder", "radius": 0.0, "height": 1.0}),
            json!({"shape": "cone", "radius": 1.0, "height": -1.0}),
            json!({"shape": "cylinder", "radius": 1.0, "height": 1.0, "facets": 2}),
            json!({"shape": "cone", "radius": 1.0, "height": 1.0, "facets": 100000}),
            json!({"shape": "cylinder", "radius": 1.0, "height": 1e-12}),
            json!({"shape": "cylinder", "radius": 1.0, "height": 5e-9, "facets": 3}),
            json!({"shape": "cone", "radius": 1.0, "height": 1.0, "size": 2}),
            json!({"shape": "cone", "radius": "1", "height": 1.0}),
        ];
        for v in &refused {
            let whole = solid_from_json(v, "a", &[]).err().map(|e| e.to_string());
            let lean = exact_solid_from_json(v, "a", &[])
                .err()
                .map(|e| e.to_string());
            assert_eq!(whole, lean, "{v}");
        }
        assert!(
            solid_from_json(&refused[0], "a", &[]).is_err()
                && solid_from_json(&refused[4], "a", &[]).is_err(),
            "the refusals above are refusals"
        );
    }

    #[test]
    fn fields_and_shapes_fail_apart_and_name_the_path() {
        let e = solid_from_json(&json!({"shape": "box", "size": [1, 1]}), "a", &[])
            .expect_err("two numbers");
        assert_eq!(e.to_string(), "a.size: expected 3 numbers");
        assert!(matches!(e, ShapeJsonError::Field(_)));
        let e = solid_from_json(&json!({"shape": "box", "size": [1, 1, 1e-12]}), "b", &[])
            .expect_err("degenerate");
        assert!(matches!(e, ShapeJsonError::Shape { .. }), "{e:?}");
        assert!(e.to_string().starts_with("b: "), "{e}");
        let e = solid_from_json(
            &json!({"shape": "box", "size": [1, 1, 1], "pose": 0}),
            "c",
            &[],
        )
        .expect_err("pose not taken here");
        assert!(e.to_string().starts_with("c.pose: unknown field"), "{e}");
        assert!(
            solid_from_json(
                &json!({"shape": "box", "size": [1, 1, 1], "pose": 0}),
                "c",
                &["pose"]
            )
            .is_ok()
        );
        let skew = json!([[1, 1, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]);
        let e = pose_from_json(&skew, "pose_a").expect_err("not rigid");
        assert!(
            e.to_string().starts_with("pose_a: not a rigid transform"),
            "{e}"
        );
        let shifted = json!([[1, 0, 0, 5], [0, 1, 0, 6], [0, 0, 1, 7], [0, 0, 0, 1]]);
        let p = pose_from_json(&shifted, "p").expect("rigid");
        assert_eq!(p.translation.vector, Vector3::new(5.0, 6.0, 7.0));
    }
}
