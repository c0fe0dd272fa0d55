//! ROBOSIM link files (seed §2.3, Table 2): one text file per link, as ROBOSIM's STORE-LINK
//! wrote them and MD and the simulation library read them.
//!
//! Rows of four numbers, whitespace-separated (docs/editor.md, "Link files"):
//!
//! | row | columns |
//! |---|---|
//! | 1 | THETA DZ DA ALPHA — the DH row of AMAT (rad, m), zeros when AMAT is not DH |
//! | 2 | JA1 JA2 JTYPE1 JTYPE2 — joint-defined flags (0/1), joint types (0 none, 1 revolute, 2 prismatic, 3 fixed) |
//! | 3–6 | AINERT, the 4×4 pseudo-inertia `∫ [x xᵀ x; xᵀ 1] dm` (kg·m², kg·m, kg) |
//! | 7–10 | AJNT-I, the input joint frame (4×4, m) |
//! | 11–14 | AJNT-I+1, the output joint frame (4×4, m) |
//! | 15–18 | AMAT = AJNT-I⁻¹ · AJNT-I+1, the link's A-matrix at joint value 0 |
//! | 19 | NVEC 0 0 0 |
//! | 20 … NVEC+19 | X Y Z D — the move (D = 0) / draw (D = 1) vector list, m |
//!
//! Everything is in the link's construction frame (the frame the ROBOSIM program built it in),
//! in SI units. Numbers are written in Rust's shortest round-trip form, so a file read back gives
//! every f64 bit for bit.
//!
//! Polygons are written as MOVE to the first vertex, DRAW to each next one and DRAW back to the
//! first; [`LinkFile::polygons`] reads them back, and [`LinkFile::solids`] groups them into
//! solids by shared vertices.

use nalgebra::{Matrix4, Point3};
use robosim_geometry::readable;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// A joint type code of row 2.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum LinkJoint {
    Revolute,
    Prismatic,
    Fixed,
}

impl LinkJoint {
    pub fn code(self) -> u32 {
        match self {
            LinkJoint::Revolute => 1,
            LinkJoint::Prismatic => 2,
            LinkJoint::Fixed => 3,
        }
    }
    pub fn from_code(c: u32) -> Option<LinkJoint> {
        match c {
            1 => Some(LinkJoint::Revolute),
            2 => Some(LinkJoint::Prismatic),
            3 => Some(LinkJoint::Fixed),
            _ => None,
        }
    }
    pub fn letter(self) -> char {
        match self {
            LinkJoint::Revolute => 'R',
            LinkJoint::Prismatic => 'P',
            LinkJoint::Fixed => 'F',
        }
    }
}

/// The DH row of row 1: standard (distal) convention, `A = Rz(θ) Tz(d) Tx(a) Rx(α)`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DhRow {
    pub theta: f64,
    pub dz: f64,
    pub da: f64,
    pub alpha: f64,
}

impl DhRow {
    /// The matrix `Rz(θ) Tz(d) Tx(a) Rx(α)`.
    pub fn matrix(&self) -> Matrix4<f64> {
        let (st, ct) = self.theta.sin_cos();
        let (sa, ca) = self.alpha.sin_cos();
        Matrix4::new(
            ct,
            -st * ca,
            st * sa,
            self.da * ct,
            st,
            ct * ca,
            -ct * sa,
            self.da * st,
            0.0,
            sa,
            ca,
            self.dz,
            0.0,
            0.0,
            0.0,
            1.0,
        )
    }
}

/// Why a transform is not a DH transform: which parameter the relation breaks.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DhViolation {
    #[error(
        "ALPHA: the I+1 joint's x axis is not perpendicular to the I joint's z axis (x·z = {dot:.3e}); no rotation α about x can produce this frame"
    )]
    XNotPerpendicular { dot: f64 },
    #[error(
        "DA: the I+1 joint's x axis does not meet the I joint's z axis (it misses it by {miss:.3e} m); no offset a along x can place this origin"
    )]
    XMissesZ { miss: f64 },
    #[error("the transform is not rigid (its rotation part is not orthonormal)")]
    NotRigid,
}

/// The DH row of `a` (standard convention), or which parameter it breaks. `tol` is the
/// tolerance on the two conditions (unitless for the axis dot product, metres for the miss).
pub fn dh_decompose(a: &Matrix4<f64>, tol: f64) -> Result<DhRow, DhViolation> {
    let r = a.fixed_view::<3, 3>(0, 0);
    if (r.transpose() * r - nalgebra::Matrix3::identity()).amax() > 1e-9 || r.determinant() <= 0.0 {
        return Err(DhViolation::NotRigid);
    }
    // x_{i} = column 0 = (cθ, sθ, 0): its z component must vanish.
    let dot = a[(2, 0)];
    if dot.abs() > tol {
        return Err(DhViolation::XNotPerpendicular { dot });
    }
    let theta = a[(1, 0)].atan2(a[(0, 0)]);
    let (st, ct) = theta.sin_cos();
    // origin = (a cθ, a sθ, d): its xy part must lie along x.
    let (px, py, pz) = (a[(0, 3)], a[(1, 3)], a[(2, 3)]);
    let miss = -px * st + py * ct;
    if miss.abs() > tol {
        return Err(DhViolation::XMissesZ { miss });
    }
    let da = px * ct + py * st;
    // column 2 = (sθ sα, −cθ sα, cα); column 1 z = sα.
    let alpha = a[(2, 1)].atan2(a[(2, 2)]);
    Ok(DhRow {
        theta,
        dz: pz,
        da,
        alpha,
    })
}

/// One link file's content.
#[derive(Debug, Clone, PartialEq)]
pub struct LinkFile {
    pub dh: DhRow,
    /// The I (input) and I+1 (output) joints, when defined.
    pub joint_i: Option<LinkJoint>,
    pub joint_i1: Option<LinkJoint>,
    pub ainert: Matrix4<f64>,
    pub ajnt_i: Matrix4<f64>,
    pub ajnt_i1: Matrix4<f64>,
    pub amat: Matrix4<f64>,
    /// (point, draw): `false` = move, `true` = draw.
    pub vectors: Vec<([f64; 3], bool)>,
}

/// Why a link file could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum LinkFileError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}:{line}:{column}: {what}")]
    Syntax {
        path: PathBuf,
        line: usize,
        column: usize,
        what: String,
    },
    #[error("{path}: {what}")]
    Content { path: PathBuf, what: String },
    /// Not a regular file, larger than the limit, or unreadable.
    #[error(transparent)]
    Input(#[from] robosim_input::InputError),
    /// Not written: a link, FIFO or device at the path, or a failed step.
    #[error(transparent)]
    Output(#[from] robosim_input::OutputError),
}

/// One solid of a link: its distinct vertices and its polygons as index lists.
pub type Solid = (Vec<Point3<f64>>, Vec<Vec<u32>>);

/// The polygons of a vector list, and where each came from.
pub type Polygons = Vec<Vec<[f64; 3]>>;

impl LinkFile {
    /// The file's text (Table 2's rows).
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        let row = |s: &mut String, v: [f64; 4]| {
            let _ = writeln!(s, "{} {} {} {}", v[0], v[1], v[2], v[3]);
        };
        let m4 = |s: &mut String, m: &Matrix4<f64>| {
            for r in 0..4 {
                let _ = writeln!(s, "{} {} {} {}", m[(r, 0)], m[(r, 1)], m[(r, 2)], m[(r, 3)]);
            }
        };
        row(
            &mut s,
            [self.dh.theta, self.dh.dz, self.dh.da, self.dh.alpha],
        );
        let flag = |j: Option<LinkJoint>| if j.is_some() { 1 } else { 0 };
        let code = |j: Option<LinkJoint>| j.map_or(0, LinkJoint::code);
        let _ = writeln!(
            s,
            "{} {} {} {}",
            flag(self.joint_i),
            flag(self.joint_i1),
            code(self.joint_i),
            code(self.joint_i1)
        );
        m4(&mut s, &self.ainert);
        m4(&mut s, &self.ajnt_i);
        m4(&mut s, &self.ajnt_i1);
        m4(&mut s, &self.amat);
        let _ = writeln!(s, "{} 0 0 0", self.vectors.len());
        for (p, d) in &self.vectors {
            let _ = writeln!(s, "{} {} {} {}", p[0], p[1], p[2], u8::from(*d));
        }
        s
    }

    /// Writes the file by [`robosim_input::write_file_atomic`] (a temporary file, synced,
    /// renamed: a reader never sees half a file; a link, FIFO or device at `path` is refused).
    pub fn write(&self, path: &Path) -> Result<(), LinkFileError> {
        Ok(robosim_input::write_file_atomic(
            path,
            self.to_text().as_bytes(),
        )?)
    }

    /// Reads a link file: a regular file of at most [`robosim_input::Limit::TEXT`] bytes.
    pub fn read(path: &Path) -> Result<LinkFile, LinkFileError> {
        let text = robosim_input::read_to_string(path, "a link file", robosim_input::Limit::TEXT)?;
        LinkFile::parse(&text, path)
    }

    /// Parses a link file's text; `path` names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<LinkFile, LinkFileError> {
        let syntax = |line: usize, column: usize, what: String| LinkFileError::Syntax {
            path: path.to_owned(),
            line,
            column,
            what,
        };
        let mut rows: Vec<(usize, [f64; 4])> = Vec::new();
        for (ln, line) in text.lines().enumerate() {
            if line.trim().is_empty() {
                continue;
            }
            let mut v = [0.0; 4];
            let mut k = 0;
            let mut col = 0;
            for tok in line.split_whitespace() {
                let c = line[col..].find(tok).map_or(col, |i| col + i);
                col = c + tok.len();
                if k == 4 {
                    return Err(syntax(
                        ln + 1,
                        c + 1,
                        format!("a fifth number {tok:?} (rows hold four)"),
                    ));
                }
                v[k] = tok
                    .parse::<f64>()
                    .ok()
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| {
                        syntax(ln + 1, c + 1, format!("{tok:?} is not a finite number"))
                    })?;
                k += 1;
            }
            if k != 4 {
                return Err(syntax(
                    ln + 1,
                    line.len() + 1,
                    format!("{k} numbers (rows hold four)"),
                ));
            }
            rows.push((ln + 1, v));
        }
        if rows.len() < 19 {
            return Err(LinkFileError::Content {
                path: path.to_owned(),
                what: format!(
                    "{} rows; a link file has at least 19 (DH, joints, AINERT, AJNT-I, AJNT-I+1, AMAT, NVEC)",
                    rows.len()
                ),
            });
        }
        let m4 = |at: usize| Matrix4::from_fn(|r, c| rows[at + r].1[c]);
        let r2 = rows[1];
        let joint =
            |flag: f64, code: f64, col: usize| -> Result<Option<LinkJoint>, LinkFileError> {
                if flag == 0.0 {
                    return Ok(None);
                }
                if flag != 1.0 {
                    return Err(syntax(
                        r2.0,
                        col,
                        format!("joint flag {flag} is not 0 or 1"),
                    ));
                }
                LinkJoint::from_code(code as u32)
                    .filter(|_| code.fract() == 0.0)
                    .map(Some)
                    .ok_or_else(|| {
                        syntax(
                            r2.0,
                            col + 2,
                            format!(
                                "joint type {code} is not 1 (revolute), 2 (prismatic) or 3 (fixed)"
                            ),
                        )
                    })
            };
        let joint_i = joint(r2.1[0], r2.1[2], 1)?;
        let joint_i1 = joint(r2.1[1], r2.1[3], 2)?;
        let (nl, nrow) = rows[18];
        let n = nrow[0];
        if n < 0.0 || n.fract() != 0.0 || n as usize != rows.len() - 19 {
            return Err(syntax(
                nl,
                1,
                format!("NVEC = {n}, but {} vector rows follow", rows.len() - 19),
            ));
        }
        let mut vectors = Vec::with_capacity(n as usize);
        for &(l, v) in &rows[19..] {
            let d = match v[3] {
                0.0 => false,
                1.0 => true,
                other => {
                    return Err(syntax(
                        l,
                        4,
                        format!("D = {other} is not 0 (move) or 1 (draw)"),
                    ));
                }
            };
            if !d && vectors.is_empty() {
                // fine: a list starts with a move
            } else if d && vectors.is_empty() {
                return Err(syntax(l, 4, "the vector list starts with a draw".into()));
            }
            vectors.push(([v[0], v[1], v[2]], d));
        }
        check_ainert(&m4(2), rows[2].0, path)?;
        Ok(LinkFile {
            dh: DhRow {
                theta: rows[0].1[0],
                dz: rows[0].1[1],
                da: rows[0].1[2],
                alpha: rows[0].1[3],
            },
            joint_i,
            joint_i1,
            ainert: m4(2),
            ajnt_i: m4(6),
            ajnt_i1: m4(10),
            amat: m4(14),
            vectors,
        })
    }

    /// The vector list of `polygons` (each closed: move to the first vertex, draw to the others
    /// and back to the first).
    pub fn vectors_of(polygons: &[Vec<[f64; 3]>]) -> Vec<([f64; 3], bool)> {
        let mut out = Vec::new();
        for p in polygons {
            let Some(first) = p.first() else { continue };
            out.push((*first, false));
            for v in &p[1..] {
                out.push((*v, true));
            }
            out.push((*first, true));
        }
        out
    }

    /// The polygons of the vector list: each run from a move to the draw that returns to its
    /// start. A run that does not close is refused.
    pub fn polygons(&self, path: &Path) -> Result<Polygons, LinkFileError> {
        let mut out: Polygons = Vec::new();
        let mut cur: Vec<[f64; 3]> = Vec::new();
        let mut closed = true;
        for (k, (p, draw)) in self.vectors.iter().enumerate() {
            if !draw {
                if !closed {
                    return Err(LinkFileError::Content {
                        path: path.to_owned(),
                        what: format!(
                            "vector {} (row {}): a move before the polygon started at the previous move was closed",
                            k + 1,
                            k + 20
                        ),
                    });
                }
                cur = vec![*p];
                closed = false;
            } else if closed {
                return Err(LinkFileError::Content {
                    path: path.to_owned(),
                    what: format!(
                        "vector {} (row {}): a draw after a closed polygon (each polygon starts with a move)",
                        k + 1,
                        k + 20
                    ),
                });
            } else if *p == cur[0] {
                if cur.len() < 3 {
                    return Err(LinkFileError::Content {
                        path: path.to_owned(),
                        what: format!(
                            "vector {} (row {}): a polygon of {} vertices",
                            k + 1,
                            k + 20,
                            cur.len()
                        ),
                    });
                }
                out.push(std::mem::take(&mut cur));
                closed = true;
            } else {
                cur.push(*p);
            }
        }
        if !closed {
            return Err(LinkFileError::Content {
                path: path.to_owned(),
                what: "the last polygon of the vector list does not return to its first vertex"
                    .into(),
            });
        }
        Ok(out)
    }

    /// The polygons grouped into solids: polygons sharing a vertex (bit-equal coordinates) are
    /// one solid. Each solid: its distinct vertices and polygons as index lists.
    pub fn solids(&self, path: &Path) -> Result<Vec<Solid>, LinkFileError> {
        let polys = self.polygons(path)?;
        let key = |v: &[f64; 3]| [v[0].to_bits(), v[1].to_bits(), v[2].to_bits()];
        // union-find over polygons
        let mut parent: Vec<usize> = (0..polys.len()).collect();
        fn find(p: &mut [usize], mut i: usize) -> usize {
            while p[i] != i {
                p[i] = p[p[i]];
                i = p[i];
            }
            i
        }
        let mut owner: std::collections::HashMap<[u64; 3], usize> = Default::default();
        for (i, poly) in polys.iter().enumerate() {
            for v in poly {
                match owner.get(&key(v)) {
                    Some(&j) => {
                        let (a, b) = (find(&mut parent, i), find(&mut parent, j));
                        if a != b {
                            parent[a.max(b)] = a.min(b);
                        }
                    }
                    None => {
                        owner.insert(key(v), i);
                    }
                }
            }
        }
        let mut groups: std::collections::BTreeMap<usize, Vec<usize>> = Default::default();
        for i in 0..polys.len() {
            let r = find(&mut parent, i);
            groups.entry(r).or_default().push(i);
        }
        let mut out = Vec::new();
        for (_, members) in groups {
            let mut index: std::collections::HashMap<[u64; 3], u32> = Default::default();
            let mut verts = Vec::new();
            let mut faces = Vec::new();
            for i in members {
                let f: Vec<u32> = polys[i]
                    .iter()
                    .map(|v| {
                        *index.entry(key(v)).or_insert_with(|| {
                            verts.push(Point3::new(v[0], v[1], v[2]));
                            (verts.len() - 1) as u32
                        })
                    })
                    .collect();
                faces.push(f);
            }
            out.push((verts, faces));
        }
        Ok(out)
    }
}

/// AINERT (the pseudo-inertia, first on file line `line`) is a body's: symmetric, its mass
/// (row 4, column 4) finite and ≥ 0, and the inertia it gives about the centre of mass one a
/// rigid body has ([`robosim_instance_space::mass_props`]). A negative mass used to be read as
/// 0 kg without a word.
fn check_ainert(j: &Matrix4<f64>, line: usize, path: &Path) -> Result<(), LinkFileError> {
    let content = |what: String| LinkFileError::Content {
        path: path.to_owned(),
        what,
    };
    let scale = j.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    for r in 0..4 {
        for c in r + 1..4 {
            if (j[(r, c)] - j[(c, r)]).abs() > 1e-9 * scale.max(1.0) {
                return Err(content(format!(
                    "AINERT (lines {line}-{}) is not symmetric: row {} column {} is {} but row {} column {} is {}",
                    line + 3,
                    r + 1,
                    c + 1,
                    readable(j[(r, c)]),
                    c + 1,
                    r + 1,
                    readable(j[(c, r)])
                )));
            }
        }
    }
    let mass = j[(3, 3)];
    if mass < 0.0 {
        return Err(content(format!(
            "AINERT mass (line {}, column 4) is {} kg: a link's mass is zero or positive",
            line + 3,
            readable(mass)
        )));
    }
    if mass == 0.0 {
        return Ok(());
    }
    let (m, com, i) = from_pseudo_inertia(j);
    let props = robosim_scene::instantiate::mass_props(m, &com, &i);
    robosim_instance_space::mass_props(&props).map_err(|(field, reason)| {
        content(format!(
            "AINERT (lines {line}-{}): the link's {field} {reason}",
            line + 3
        ))
    })
}

/// Pseudo-inertia `∫ [x xᵀ x; xᵀ 1] dm` from mass, centre of mass and the inertia tensor about
/// the centre of mass (all in one frame).
pub fn pseudo_inertia(
    mass: f64,
    com: &nalgebra::Vector3<f64>,
    inertia: &nalgebra::Matrix3<f64>,
) -> Matrix4<f64> {
    // Σc = tr(I)/2 · 1 − I is the second moment about the centre of mass.
    let sc = nalgebra::Matrix3::identity() * (inertia.trace() / 2.0) - inertia;
    let s = sc + com * com.transpose() * mass;
    let mut j = Matrix4::zeros();
    j.fixed_view_mut::<3, 3>(0, 0).copy_from(&s);
    for i in 0..3 {
        j[(i, 3)] = mass * com[i];
        j[(3, i)] = mass * com[i];
    }
    j[(3, 3)] = mass;
    j
}

/// Mass, centre of mass and inertia about the centre of mass from a pseudo-inertia matrix.
pub fn from_pseudo_inertia(
    j: &Matrix4<f64>,
) -> (f64, nalgebra::Vector3<f64>, nalgebra::Matrix3<f64>) {
    let m = j[(3, 3)];
    if m <= 0.0 {
        return (0.0, nalgebra::Vector3::zeros(), nalgebra::Matrix3::zeros());
    }
    let c = nalgebra::Vector3::new(j[(0, 3)], j[(1, 3)], j[(2, 3)]) / m;
    let s: nalgebra::Matrix3<f64> = j.fixed_view::<3, 3>(0, 0).into_owned();
    let sc = s - c * c.transpose() * m;
    let i = nalgebra::Matrix3::identity() * sc.trace() - sc;
    (m, c, i)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> LinkFile {
        let polys = vec![
            vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            vec![[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            vec![[5.0, 0.0, 0.0], [6.0, 0.1, 0.0], [5.0, 1.0, 0.3]],
        ];
        LinkFile {
            dh: DhRow {
                theta: 0.1,
                dz: 0.2,
                da: 0.3,
                alpha: 1.0 / 3.0,
            },
            joint_i: Some(LinkJoint::Fixed),
            joint_i1: Some(LinkJoint::Revolute),
            ainert: Matrix4::identity() * 0.7,
            ajnt_i: Matrix4::identity(),
            ajnt_i1: Matrix4::new_translation(&nalgebra::Vector3::new(0.1, 0.2, 1.0 / 7.0)),
            amat: Matrix4::identity(),
            vectors: LinkFile::vectors_of(&polys),
        }
    }

    #[test]
    fn text_round_trip_is_bit_exact_and_groups_solids_by_shared_vertices() {
        let l = sample();
        let p = Path::new("X.L1");
        let back = LinkFile::parse(&l.to_text(), p).expect("reads back");
        assert_eq!(back, l);
        assert_eq!(back.polygons(p).expect("closed").len(), 3);
        let solids = back.solids(p).expect("solids");
        assert_eq!(solids.len(), 2);
        assert_eq!(solids[0].1.len(), 2);
        assert_eq!(solids[0].0.len(), 4);
    }

    #[test]
    fn errors_name_line_and_column() {
        let l = sample();
        let text = l.to_text().replacen("0.2 0.3", "0.2 zz", 1);
        let e = LinkFile::parse(&text, Path::new("X.L1")).expect_err("bad number");
        assert_eq!(e.to_string(), "X.L1:1:9: \"zz\" is not a finite number");
        let short: String = l.to_text().lines().take(10).collect::<Vec<_>>().join("\n");
        assert!(LinkFile::parse(&short, Path::new("X")).is_err());
        let bad_n = l.to_text().replacen("\n12 0 0 0\n", "\n11 0 0 0\n", 1);
        let e = LinkFile::parse(&bad_n, Path::new("X")).expect_err("nvec");
        assert!(e.to_string().contains("NVEC = 11, but 12"), "{e}");
    }

    #[test]
    fn dh_decomposition_recovers_rows_and_names_the_broken_parameter() {
        let row = DhRow {
            theta: 0.4,
            dz: 0.25,
            da: -0.3,
            alpha: -1.2,
        };
        let back = dh_decompose(&row.matrix(), 1e-9).expect("DH");
        assert!((back.matrix() - row.matrix()).amax() < 1e-14);
        let off = Matrix4::new_translation(&nalgebra::Vector3::new(0.0, 0.0, 0.1))
            * Matrix4::new_rotation(nalgebra::Vector3::new(0.0, 0.3, 0.0));
        assert!(matches!(
            dh_decompose(&off, 1e-9),
            Err(DhViolation::XNotPerpendicular { .. })
        ));
        let miss = Matrix4::new_translation(&nalgebra::Vector3::new(0.0, 0.2, 0.1));
        assert!(matches!(
            dh_decompose(&miss, 1e-9),
            Err(DhViolation::XMissesZ { miss }) if (miss - 0.2).abs() < 1e-15
        ));
    }

    #[test]
    fn pseudo_inertia_round_trips() {
        let c = nalgebra::Vector3::new(0.1, -0.2, 0.3);
        let i = nalgebra::Matrix3::new(2.0, 0.1, 0.2, 0.1, 3.0, 0.3, 0.2, 0.3, 4.0);
        let j = pseudo_inertia(5.0, &c, &i);
        let (m, c2, i2) = from_pseudo_inertia(&j);
        assert_eq!(m, 5.0);
        assert!((c2 - c).amax() < 1e-15);
        assert!((i2 - i).amax() < 1e-14);
    }
}
