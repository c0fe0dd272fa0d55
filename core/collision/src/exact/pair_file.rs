//! The separated pairs of `testdata/collision/tolerance_pairs.csv` (written by
//! `tools/peers/collision_tolerance_coal.py`: 4 classes × 40 pairs, gaps 1 mm – 0.3 m): one
//! reader for the distance-tolerance report, the `tolerance` bench and the `peer_distance`
//! example. A row: `class,index`, then per body `kind,p0,p1,p2,R (row-major, 9),t (3)`; a
//! cylinder or cone is `radius,height,0`, a box its three side lengths, a convex mesh
//! `hull,n,radius,seed`: the hull of [`hull_points`] (the convex-mesh class of
//! `testdata/collision/tolerance_hull_pairs.csv`, written by the same script's `hulls`).

use crate::{ShapeError, Solid};
use nalgebra::{Isometry3, Matrix3, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};

/// One row: its class and the two bodies where they stand.
pub struct Pair {
    pub class: String,
    pub a: Solid,
    pub pa: Isometry3<f64>,
    pub b: Solid,
    pub pb: Isometry3<f64>,
}

/// The points of a `hull` row: n points of a golden-angle spiral on an ellipsoid of semi-axes
/// radius × (1, 0.8, 0.6), each point's distance jittered by 15 % (the formula of
/// `tools/peers/collision_tolerance_coal.py`'s `hull_points`; glibc's sin, cos and sqrt on
/// both sides, so coal builds its hull from the same points).
pub fn hull_points(n: usize, radius: f64, seed: f64) -> Vec<Point3<f64>> {
    (0..n)
        .map(|k| {
            let k = k as f64;
            let z = 1.0 - (2.0 * k + 1.0) / n as f64;
            let r = (1.0 - z * z).sqrt();
            let phi = 2.399963229728653 * k + seed;
            let rho = radius * (1.0 + 0.15 * (1.7 * k + 3.1 * seed).sin());
            Point3::new(
                rho * r * phi.cos(),
                rho * 0.8 * r * phi.sin(),
                rho * 0.6 * z,
            )
        })
        .collect()
}

/// Why a row of a pairs file was refused: the file, the line (1-based, blank lines not
/// counted) and what is wrong with the row.
#[derive(Debug, thiserror::Error)]
#[error("{file} line {line}: {problem}")]
pub struct PairFileError {
    pub file: String,
    pub line: usize,
    #[source]
    pub problem: RowError,
}

/// What is wrong with one row of a pairs file.
#[derive(Debug, thiserror::Error)]
pub enum RowError {
    /// Not the 34 cells of a row.
    #[error("{0} cells")]
    Cells(usize),
    /// A dimension or pose cell that is not a number.
    #[error("{cell}: {source}")]
    Number {
        cell: String,
        #[source]
        source: std::num::ParseFloatError,
    },
    /// A `hull` row whose point count is not a whole number in 4..=1e6.
    #[error("hull of {0} points")]
    HullPoints(f64),
    #[error("unknown kind {0}")]
    UnknownKind(String),
    /// The dimensions do not make a solid.
    #[error("{0}")]
    Shape(#[source] ShapeError),
}

/// One side of a row: kind, three dimensions, R row-major, t.
fn body(cells: &[&str]) -> Result<(Solid, Isometry3<f64>), RowError> {
    let v = cells[1..16]
        .iter()
        .map(|c| {
            c.parse::<f64>().map_err(|source| RowError::Number {
                cell: (*c).to_owned(),
                source,
            })
        })
        .collect::<Result<Vec<f64>, RowError>>()?;
    let s = match cells[0] {
        "box" => Solid::cuboid(Vector3::new(v[0], v[1], v[2])),
        "cylinder" => Solid::cylinder(v[0], v[1], None),
        "cone" => Solid::cone(v[0], v[1], None),
        "hull" if v[0] >= 4.0 && v[0] <= 1e6 && v[0].fract() == 0.0 => {
            Solid::convex(&hull_points(v[0] as usize, v[1], v[2]))
        }
        "hull" => return Err(RowError::HullPoints(v[0])),
        k => return Err(RowError::UnknownKind(k.to_owned())),
    }
    .map_err(RowError::Shape)?;
    let r = Matrix3::from_row_slice(&v[3..12]);
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
    let pose = Isometry3::from_parts(Translation3::new(v[12], v[13], v[14]), q);
    Ok((s, pose))
}

/// Every pair of `text` (the file's content), in file order; an error names `file` and the line.
pub fn parse(text: &str, file: &str) -> Result<Vec<Pair>, PairFileError> {
    text.lines()
        .filter(|l| !l.trim().is_empty())
        .enumerate()
        .map(|(n, l)| {
            let at = |problem| PairFileError {
                file: file.to_owned(),
                line: n + 1,
                problem,
            };
            let c: Vec<&str> = l.split(',').collect();
            if c.len() != 34 {
                return Err(at(RowError::Cells(c.len())));
            }
            let (a, pa) = body(&c[2..18]).map_err(at)?;
            let (b, pb) = body(&c[18..34]).map_err(at)?;
            Ok(Pair {
                class: c[0].to_owned(),
                a,
                pa,
                b,
                pb,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_row_becomes_its_two_bodies_and_a_bad_row_names_its_line() {
        let id = "1,0,0,0,1,0,0,0,1";
        let row = format!("c,0,box,1,2,3,{id},0,0,0,cone,0.5,2,0,{id},4,0,0");
        let p = parse(&row, "f.csv").expect("parses");
        assert_eq!(p.len(), 1);
        assert_eq!(p[0].class, "c");
        assert_eq!(p[0].pb.translation.vector.x, 4.0);
        let e = parse(&format!("{row}\nc,1,box"), "f.csv")
            .err()
            .expect("refused");
        assert!(e.to_string().contains("f.csv line 2"), "{e}");
        assert!(matches!(e.problem, RowError::Cells(3)), "{e:?}");
        let e = parse(&row.replace("cone", "torus"), "f.csv")
            .err()
            .expect("refused");
        let text = e.to_string();
        assert!(text.contains("line 1") && text.contains("torus"), "{e}");
        // a convex mesh: the hull of its formula's points, every vertex one of them
        let h = parse(&row.replace("box,1,2,3", "hull,64,0.2,7"), "f.csv").expect("hull");
        let pts = hull_points(64, 0.2, 7.0);
        let cp = h[0]
            .a
            .exact
            .as_convex_polyhedron()
            .expect("a convex polyhedron");
        assert!(cp.points().len() >= 30, "{} vertices", cp.points().len());
        for q in cp.points() {
            assert!(pts.iter().any(|p| (p - q).norm() < 1e-15), "{q}");
        }
        assert!(parse(&row.replace("box,1,2,3", "hull,2.5,0.2,7"), "f.csv").is_err());
        // a bad number or a bad solid keeps its cause
        let e = parse(&row.replace("box,1,2,3", "box,1,x,3"), "f.csv")
            .err()
            .expect("refused");
        assert_eq!(
            e.to_string(),
            format!("f.csv line 1: x: {}", "x".parse::<f64>().unwrap_err())
        );
        let cause = std::error::Error::source(&e).and_then(|p| p.source());
        assert!(
            cause.is_some_and(|c| c.is::<std::num::ParseFloatError>()),
            "{e:?}"
        );
        let e = parse(&row.replace("box,1,2,3", "box,1,-2,3"), "f.csv")
            .err()
            .expect("refused");
        assert!(matches!(e.problem, RowError::Shape(_)), "{e:?}");
        let cause = std::error::Error::source(&e).and_then(|p| p.source());
        assert!(cause.is_some_and(|c| c.is::<ShapeError>()), "{e:?}");
    }
}
