//! The separated pairs of `testdata/collision/tolerance_pairs.csv` (written by
//! `tools/peers/collision_tolerance_coal.py`: 4 classes × 40 pairs, gaps 1 mm – 0.3 m): one
//! reader for the distance-tolerance report, the `tolerance` bench and the `peer_distance`
//! example. A row: `class,index`, then per body `kind,p0,p1,p2,R (row-major, 9),t (3)`; a
//! cylinder or cone is `radius,height,0`, a box its three side lengths.

use crate::Solid;
use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};

/// One row: its class and the two bodies where they stand.
pub struct Pair {
    pub class: String,
    pub a: Solid,
    pub pa: Isometry3<f64>,
    pub b: Solid,
    pub pb: Isometry3<f64>,
}

/// One side of a row: kind, three dimensions, R row-major, t.
fn body(cells: &[&str]) -> Result<(Solid, Isometry3<f64>), String> {
    let v = cells[1..16]
        .iter()
        .map(|c| c.parse::<f64>().map_err(|e| format!("{c}: {e}")))
        .collect::<Result<Vec<f64>, String>>()?;
    let s = match cells[0] {
        "box" => Solid::cuboid(Vector3::new(v[0], v[1], v[2])),
        "cylinder" => Solid::cylinder(v[0], v[1], None),
        "cone" => Solid::cone(v[0], v[1], None),
        k => return Err(format!("unknown kind {k}")),
    }
    .map_err(|e| e.to_string())?;
    let r = Matrix3::from_row_slice(&v[3..12]);
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
    let pose = Isometry3::from_parts(Translation3::new(v[12], v[13], v[14]), q);
    Ok((s, pose))
}

/// Every pair of `text` (the file's content), in file order; an error names `file` and the line.
pub fn parse(text: &str, file: &str) -> Result<Vec<Pair>, String> {
    text.lines()
        .filter(|l| !l.trim().is_empty())
        .enumerate()
        .map(|(n, l)| {
            let c: Vec<&str> = l.split(',').collect();
            if c.len() != 34 {
                return Err(format!("{file} line {}: {} cells", n + 1, c.len()));
            }
            let side = |cells| body(cells).map_err(|e| format!("{file} line {}: {e}", n + 1));
            let (a, pa) = side(&c[2..18])?;
            let (b, pb) = side(&c[18..34])?;
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
        assert!(e.contains("f.csv line 2"), "{e}");
        let e = parse(&row.replace("cone", "torus"), "f.csv")
            .err()
            .expect("refused");
        assert!(e.contains("line 1") && e.contains("torus"), "{e}");
    }
}
