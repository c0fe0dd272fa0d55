//! The separated pairs of `testdata/collision/tolerance_pairs.csv` (written by
//! `tools/peers/collision_tolerance_coal.py`: 4 classes × 40 pairs, gaps 1 mm – 0.3 m), shared by
//! the `tolerance` bench and the `peer_distance` example. A row: `class,index`, then per body
//! `kind,p0,p1,p2,R (row-major, 9),t (3)`; a cylinder or cone is `radius,height,0`, a box its
//! three side lengths.

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};
use robosim_collision::Solid;

pub struct Pair {
    pub class: String,
    pub a: Solid,
    pub pa: Isometry3<f64>,
    pub b: Solid,
    pub pb: Isometry3<f64>,
}

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
    Ok((
        s,
        Isometry3::from_parts(Translation3::new(v[12], v[13], v[14]), q),
    ))
}

/// Every pair of the file, in file order.
pub fn load() -> Result<Vec<Pair>, String> {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../testdata/collision/tolerance_pairs.csv"
    );
    let text = std::fs::read_to_string(path).map_err(|e| format!("{path}: {e}"))?;
    text.lines()
        .filter(|l| !l.trim().is_empty())
        .enumerate()
        .map(|(n, l)| {
            let c: Vec<&str> = l.split(',').collect();
            if c.len() != 34 {
                return Err(format!("{path} line {}: {} cells", n + 1, c.len()));
            }
            let (a, pa) = body(&c[2..18]).map_err(|e| format!("line {}: {e}", n + 1))?;
            let (b, pb) = body(&c[18..34]).map_err(|e| format!("line {}: {e}", n + 1))?;
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
