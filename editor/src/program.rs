//! The ROBOSIM language's meaning (seed §2.3, Table 1): an interpreter with ROBOSIM's working
//! object (the accumulator), its registers, the MOVE/DRAW polyline, and STORE-LINK, which turns
//! the working object into a link file (Table 2).
//!
//! * The working object is a list of placed objects (a shape and its transform) and at most one
//!   I and one I+1 joint. A primitive or a joint command adds one at the origin; ROTATE and
//!   TRANSLATE move everything in it about the fixed axes (`M ← R·M`); CLEAR empties it.
//! * `STORE r` copies it to register r (A–Z), `LOAD r` replaces it with r, `ADD r` adds r to it.
//! * MOVE / DRAW collect a polygon for EXTRUDE-SURFACE (in XY, Z = 0) or REV-SURFACE (X = ρ,
//!   Y = 0, Z = z); a last point equal to the first closes it and is dropped; either winding is
//!   accepted (the generators orient faces outward themselves).
//! * UNITS sets the length unit (M, CM, MM, IN, FT; default CM, the seed's) or the angle unit
//!   (DEG, RAD; default DEG) for the lines after it; a number may carry its own unit.
//! * DENSITY RHO = v (kg/m³; default 2700, aluminium) is used for AINERT.
//!
//! [`run`] interprets a whole program and returns every link it stored; nothing is written. A
//! program with an error returns the error and no link at all.

use crate::lang::{Arg, Command, LangError, LinkError, Span, Unit, parse, unit};
use crate::shape::{Shape, axis_rotation, facets_for, rigid_inverse};
use nalgebra::{Matrix4, Point3, Vector3};
use robosim_file_io::linkfile::{self, DhRow, LinkFile, LinkJoint, pseudo_inertia};
use robosim_geometry::readable;
use std::collections::BTreeMap;

/// The default density, kg/m³ (aluminium).
pub const DEFAULT_DENSITY: f64 = 2700.0;
/// Tolerance of the DH check (unitless on axes, metres on offsets).
pub const DH_TOL: f64 = 1e-9;
/// The most polygons the working object and each register may hold (every placed object counts
/// at least one): `ADD A` doubles the working object, so 40 of them in a 600-byte program
/// would otherwise ask for terabytes. The environment variable [`POLYGON_BUDGET_ENV`] raises it.
pub const POLYGON_BUDGET: usize = 5_000_000;
/// The environment variable that sets another polygon budget for `lang run` / `lang load`.
pub const POLYGON_BUDGET_ENV: &str = "ROBOSIM_LANG_MAX_POLYGONS";

/// The polygon budget of a run: [`POLYGON_BUDGET_ENV`] when set to a whole number, else
/// [`POLYGON_BUDGET`].
pub fn polygon_budget() -> usize {
    std::env::var(POLYGON_BUDGET_ENV)
        .ok()
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or(POLYGON_BUDGET)
}

/// A shape and where the program put it (construction frame of the link).
#[derive(Debug, Clone, PartialEq)]
pub struct Placed {
    pub shape: Shape,
    pub m: Matrix4<f64>,
    /// The line that made it.
    pub span: Span,
}

/// The working object or a register.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Work {
    pub objects: Vec<Placed>,
}

/// A link the program stored.
#[derive(Debug, Clone, PartialEq)]
pub struct StoredLink {
    /// The STORE-LINK name, e.g. `C.LOC`.
    pub name: String,
    pub objects: Vec<Placed>,
    pub file: LinkFile,
    pub span: Span,
}

/// What a run produced.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Output {
    pub links: Vec<StoredLink>,
    /// LOOK-FROM and LOOK-AT (m), when given.
    pub look_from: Option<[f64; 3]>,
    pub look_at: Option<[f64; 3]>,
    /// One line per VIEW.
    pub views: Vec<String>,
}

/// The link file of `objects` (construction frame, m) with uniform `density` (kg/m³).
pub fn build_link(objects: &[Placed], density: f64) -> Result<LinkFile, LinkError> {
    let mut joint_i = None;
    let mut joint_i1 = None;
    let mut polygons: Vec<Vec<[f64; 3]>> = Vec::new();
    let mut ainert = Matrix4::zeros();
    for o in objects {
        match &o.shape {
            Shape::Joint { kind, output } => {
                let slot = if *output { &mut joint_i1 } else { &mut joint_i };
                if slot.is_some() {
                    return Err(LinkError::Refused(format!(
                        "two {} joints in one link (the second made on line {})",
                        if *output { "I+1" } else { "I" },
                        o.span.line
                    )));
                }
                *slot = Some((*kind, o.m));
            }
            shape => {
                let Some(p) = shape.polyhedron()? else {
                    continue;
                };
                let iso = isometry(&o.m);
                let placed = p.transformed(&iso);
                for k in 0..placed.polygons.len() {
                    polygons.push(
                        placed
                            .polygon_indices(k)
                            .iter()
                            .map(|&i| {
                                let v = placed.vertices[i as usize];
                                [v.x, v.y, v.z]
                            })
                            .collect(),
                    );
                }
                let mp = p.mass_properties(density)?;
                let mp = mp.transformed(&iso);
                ainert += pseudo_inertia(mp.mass, &mp.center_of_mass.coords, &mp.inertia);
            }
        }
    }
    let ajnt_i = joint_i.map_or(Matrix4::identity(), |j| j.1);
    let ajnt_i1 = joint_i1.map_or(ajnt_i, |j| j.1);
    let amat = rigid_inverse(&ajnt_i) * ajnt_i1;
    let moving = matches!(
        joint_i,
        Some((LinkJoint::Revolute | LinkJoint::Prismatic, _))
    );
    let dh = match linkfile::dh_decompose(&amat, DH_TOL) {
        Ok(row) => row,
        Err(e) if moving => return Err(LinkError::NotDh(e)),
        Err(_) => DhRow::default(),
    };
    Ok(LinkFile {
        dh,
        joint_i: joint_i.map(|j| j.0),
        joint_i1: joint_i1.map(|j| j.0),
        ainert,
        ajnt_i,
        ajnt_i1,
        amat,
        vectors: LinkFile::vectors_of(&polygons),
    })
}

/// A 4×4 rigid transform as an isometry.
pub fn isometry(m: &Matrix4<f64>) -> nalgebra::Isometry3<f64> {
    let r = nalgebra::Rotation3::from_matrix_unchecked(m.fixed_view::<3, 3>(0, 0).into_owned());
    nalgebra::Isometry3::from_parts(
        nalgebra::Translation3::new(m[(0, 3)], m[(1, 3)], m[(2, 3)]),
        nalgebra::UnitQuaternion::from_rotation_matrix(&r),
    )
}

/// Vertices of a placed shape, transformed by its matrix directly (no quaternion round trip).
pub fn placed_vertices(p: &Placed) -> Vec<Point3<f64>> {
    match p.shape.polyhedron() {
        Ok(Some(poly)) => poly
            .vertices
            .iter()
            .map(|v| Point3::from((p.m * v.to_homogeneous()).xyz()))
            .collect(),
        _ => Vec::new(),
    }
}

struct Interp<'a> {
    file: &'a str,
    /// [`polygon_budget`] of this run.
    budget: usize,
    /// Polygons (at least one per object) of the working object and of each register.
    work_polygons: usize,
    reg_polygons: BTreeMap<char, usize>,
    length: f64,
    angle: f64,
    density: f64,
    work: Work,
    regs: BTreeMap<char, Work>,
    profile: Vec<([f64; 3], Span)>,
    out: Output,
    ended: Option<Span>,
}

/// Runs a program (its text, `file` naming it in errors).
pub fn run(text: &str, file: &str) -> Result<Output, LangError> {
    let cmds = parse(text, file)?;
    run_commands(&cmds, file)
}

/// Runs parsed commands, within [`polygon_budget`].
pub fn run_commands(cmds: &[Command], file: &str) -> Result<Output, LangError> {
    run_with_budget(cmds, file, polygon_budget())
}

/// Runs parsed commands; a working object or register of more than `budget` polygons is
/// refused at the command that would make it.
pub fn run_with_budget(cmds: &[Command], file: &str, budget: usize) -> Result<Output, LangError> {
    let mut it = Interp {
        file,
        budget,
        work_polygons: 0,
        reg_polygons: BTreeMap::new(),
        length: 0.01,
        angle: std::f64::consts::PI / 180.0,
        density: DEFAULT_DENSITY,
        work: Work::default(),
        regs: BTreeMap::new(),
        profile: Vec::new(),
        out: Output::default(),
        ended: None,
    };
    for c in cmds {
        if let Some(end) = it.ended {
            return Err(it.err(
                c,
                c.span,
                format!("a command after END (line {})", end.line),
            ));
        }
        it.command(c)?;
    }
    if let Some((_, s)) = it.profile.first() {
        return Err(LangError {
            file: file.to_owned(),
            span: *s,
            command: "MOVE".into(),
            what: "this MOVE/DRAW polygon is never used by EXTRUDE-SURFACE or REV-SURFACE".into(),
            source: None,
        });
    }
    Ok(it.out)
}

/// The commands the language knows, for completion and documentation.
pub const COMMANDS: &[&str] = &[
    "UNITS",
    "DENSITY",
    "LOOK-FROM",
    "LOOK-AT",
    "CLEAR",
    "STORE",
    "LOAD",
    "ADD",
    "MOVE",
    "DRAW",
    "EXTRUDE-SURFACE",
    "REV-SURFACE",
    "BOX",
    "CYLINDER",
    "CONE",
    "TRUNCATED-CONE",
    "SPHERE",
    "R-JOINT-I",
    "P-JOINT-I",
    "F-JOINT-I",
    "R-JOINT-I+1",
    "P-JOINT-I+1",
    "F-JOINT-I+1",
    "ROTATE",
    "TRANSLATE",
    "STORE-LINK",
    "VIEW",
    "END",
];

impl Interp<'_> {
    fn err(&self, c: &Command, span: Span, what: String) -> LangError {
        LangError {
            file: self.file.to_owned(),
            span,
            command: c.name.clone(),
            what,
            source: None,
        }
    }

    /// The arguments of `c`, each key at most once and from `allowed`; values in SI, each
    /// converted with `kind(key)` (true = a length, false = an angle, None = a plain number).
    fn args(
        &self,
        c: &Command,
        allowed: &[&str],
        kind: impl Fn(&str) -> Option<bool>,
    ) -> Result<BTreeMap<String, (f64, Span)>, LangError> {
        if let Some((w, s)) = &c.word {
            return Err(self.err(
                c,
                *s,
                format!(
                    "takes KEY = VALUE arguments ({}), not the word {w:?}",
                    allowed.join(", ")
                ),
            ));
        }
        let mut out = BTreeMap::new();
        for a in &c.args {
            if !allowed.contains(&a.key.as_str()) {
                return Err(self.err(
                    c,
                    a.span,
                    format!(
                        "unknown argument {} (it takes {})",
                        a.key,
                        if allowed.is_empty() {
                            "none".to_owned()
                        } else {
                            allowed.join(", ")
                        }
                    ),
                ));
            }
            if out.contains_key(&a.key) {
                return Err(self.err(c, a.span, format!("argument {} given twice", a.key)));
            }
            out.insert(a.key.clone(), (self.value(c, a, kind(&a.key))?, a.span));
        }
        Ok(out)
    }

    /// The argument's value in SI units; a value beyond f64's range (`X = 1e309`, or a unit
    /// conversion that overflows) is refused naming the argument.
    fn value(&self, c: &Command, a: &Arg, length: Option<bool>) -> Result<f64, LangError> {
        let v = self.value_si(c, a, length)?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.err(
                c,
                a.span,
                format!(
                    "argument {} is not a finite number in SI units (overflows ±1.8e308)",
                    a.key
                ),
            ))
        }
    }

    fn value_si(&self, c: &Command, a: &Arg, length: Option<bool>) -> Result<f64, LangError> {
        match (length, &a.unit) {
            (None, None) => Ok(a.value),
            (None, Some((w, _))) => Err(self.err(
                c,
                a.span,
                format!(
                    "argument {} is a plain number; it takes no unit ({w})",
                    a.key
                ),
            )),
            (Some(true), None) => Ok(a.value * self.length),
            (Some(false), None) => Ok(a.value * self.angle),
            (Some(true), Some((_, Unit::Length(f)))) => Ok(a.value * f),
            (Some(false), Some((_, Unit::Angle(f)))) => Ok(a.value * f),
            (Some(l), Some((w, _))) => Err(self.err(
                c,
                a.span,
                format!(
                    "argument {} is {}; {w} is not a unit of that",
                    a.key,
                    if l { "a length" } else { "an angle" }
                ),
            )),
        }
    }

    fn word(&self, c: &Command, what: &str) -> Result<(String, Span), LangError> {
        if let Some(a) = c.args.first() {
            return Err(self.err(
                c,
                a.span,
                format!("takes {what}, not KEY = VALUE arguments"),
            ));
        }
        c.word
            .clone()
            .ok_or_else(|| self.err(c, c.span, format!("needs {what}")))
    }

    fn no_args(&self, c: &Command) -> Result<(), LangError> {
        if let Some((w, s)) = &c.word {
            return Err(self.err(c, *s, format!("takes no argument, found {w:?}")));
        }
        if let Some(a) = c.args.first() {
            return Err(self.err(c, a.span, format!("takes no argument, found {}", a.key)));
        }
        Ok(())
    }

    fn register(&self, c: &Command) -> Result<char, LangError> {
        let (w, s) = self.word(c, "a register name (one letter A–Z)")?;
        let mut ch = w.chars();
        match (ch.next(), ch.next()) {
            (Some(r), None) if r.is_ascii_alphabetic() => Ok(r.to_ascii_uppercase()),
            _ => Err(self.err(c, s, format!("{w:?} is not a register (one letter A–Z)"))),
        }
    }

    fn positive(
        &self,
        c: &Command,
        args: &BTreeMap<String, (f64, Span)>,
        k: &str,
    ) -> Result<f64, LangError> {
        let Some(&(v, s)) = args.get(k) else {
            return Err(self.err(c, c.span, format!("argument {k} is missing")));
        };
        if v > 0.0 {
            Ok(v)
        } else {
            Err(self.err(
                c,
                s,
                format!(
                    "argument {k} must be positive, got {}",
                    readable(v / self.length)
                ),
            ))
        }
    }

    fn facets(
        &self,
        c: &Command,
        args: &BTreeMap<String, (f64, Span)>,
        r: f64,
    ) -> Result<usize, LangError> {
        match args.get("N") {
            None => Ok(facets_for(r)),
            Some(&(n, s)) => {
                if n.fract() == 0.0 && (3.0..=16384.0).contains(&n) {
                    Ok(n as usize)
                } else {
                    Err(self.err(
                        c,
                        s,
                        format!(
                            "argument N: {} facets (an integer from 3 to 16384)",
                            readable(n)
                        ),
                    ))
                }
            }
        }
    }

    /// Refuses a working object of `polygons` polygons when that is over the budget.
    fn within_budget(&self, c: &Command, polygons: usize) -> Result<(), LangError> {
        if polygons <= self.budget {
            return Ok(());
        }
        Err(self.err(
            c,
            c.span,
            format!(
                "the working object would hold {polygons} polygons, over the budget of {} \
                 (set {POLYGON_BUDGET_ENV} to raise it)",
                self.budget
            ),
        ))
    }

    fn add_shape(&mut self, c: &Command, shape: Shape) -> Result<(), LangError> {
        let polygons = shape
            .polyhedron()
            .map_err(|e| LangError {
                source: Some(LinkError::Solid(e)),
                ..self.err(c, c.span, String::new())
            })?
            .map_or(0, |p| p.polygons.len())
            .max(1);
        let total = self.work_polygons.saturating_add(polygons);
        self.within_budget(c, total)?;
        self.work_polygons = total;
        self.work.objects.push(Placed {
            shape,
            m: Matrix4::identity(),
            span: c.span,
        });
        Ok(())
    }

    /// Moves the working object by `t`. A placement that leaves f64's range (two
    /// `TRANSLATE X=1e308` in metres) is refused here, naming the object's line, and the
    /// working object is left as it was: nothing non-finite reaches a link file.
    fn transform(&mut self, c: &Command, t: &Matrix4<f64>) -> Result<(), LangError> {
        let moved: Vec<Matrix4<f64>> = self.work.objects.iter().map(|o| t * o.m).collect();
        if let Some((o, _)) = self
            .work
            .objects
            .iter()
            .zip(&moved)
            .find(|(_, m)| m.iter().any(|x| !x.is_finite()))
        {
            return Err(self.err(
                c,
                c.span,
                format!(
                    "this would place the object made on line {} outside f64's range \
                     (a coordinate overflows ±1.8e308 m)",
                    o.span.line
                ),
            ));
        }
        for (o, m) in self.work.objects.iter_mut().zip(moved) {
            o.m = m;
        }
        Ok(())
    }

    /// One command of the program: the name picks its handler (the longer ones are methods
    /// below; the short ones stay here).
    fn command(&mut self, c: &Command) -> Result<(), LangError> {
        let len = |_: &str| Some(true);
        let name = c.name.as_str();
        match name {
            "UNITS" => self.set_units(c)?,
            "DENSITY" => self.set_density(c)?,
            "LOOK-FROM" | "LOOK-AT" => self.set_view_point(c, name)?,
            "CLEAR" => {
                self.no_args(c)?;
                self.work = Work::default();
                self.work_polygons = 0;
            }
            "STORE" => {
                let r = self.register(c)?;
                self.regs.insert(r, self.work.clone());
                self.reg_polygons.insert(r, self.work_polygons);
            }
            "LOAD" | "ADD" => self.load_or_add(c, name)?,
            "MOVE" | "DRAW" => self.profile_point(c, name)?,
            "EXTRUDE-SURFACE" | "REV-SURFACE" => self.extrude_or_revolve(c, name)?,
            "BOX" => {
                let a = self.args(c, &["X", "Y", "Z"], len)?;
                let s = Shape::Box {
                    x: self.positive(c, &a, "X")?,
                    y: self.positive(c, &a, "Y")?,
                    z: self.positive(c, &a, "Z")?,
                };
                self.add_shape(c, s)?;
            }
            "CYLINDER" | "CONE" => self.cylinder_or_cone(c, name)?,
            "TRUNCATED-CONE" => {
                let a = self.args(c, &["R1", "R2", "H", "N"], |k| (k != "N").then_some(true))?;
                let upper = self.positive(c, &a, "R1")?;
                let lower = self.positive(c, &a, "R2")?;
                let h = self.positive(c, &a, "H")?;
                let n = self.facets(c, &a, upper.max(lower))?;
                self.add_shape(c, Shape::TruncatedCone { upper, lower, h, n })?;
            }
            "SPHERE" => {
                let a = self.args(c, &["R", "N"], |k| (k != "N").then_some(true))?;
                let r = self.positive(c, &a, "R")?;
                let n = self.facets(c, &a, r)?;
                self.add_shape(c, Shape::Sphere { r, n })?;
            }
            "R-JOINT-I" | "P-JOINT-I" | "F-JOINT-I" | "R-JOINT-I+1" | "P-JOINT-I+1"
            | "F-JOINT-I+1" => self.joint_marker(c, name)?,
            "ROTATE" => self.rotate(c)?,
            "TRANSLATE" => {
                let a = self.args(c, &["X", "Y", "Z"], len)?;
                let t = Vector3::from(["X", "Y", "Z"].map(|k| a.get(k).map_or(0.0, |v| v.0)));
                self.transform(c, &Matrix4::new_translation(&t))?;
            }
            "STORE-LINK" => self.store_link(c)?,
            "VIEW" => self.view(c)?,
            "END" => {
                self.no_args(c)?;
                self.ended = Some(c.span);
            }
            other => self.unknown_command(c, other)?,
        }
        Ok(())
    }

    /// `UNITS U`: the unit of lengths or of angles from now on.
    fn set_units(&mut self, c: &Command) -> Result<(), LangError> {
        let (w, s) = self.word(c, "a unit (M, CM, MM, IN, FT, DEG or RAD)")?;
        match unit(&w) {
            Some(Unit::Length(f)) => self.length = f,
            Some(Unit::Angle(f)) => self.angle = f,
            None => {
                return Err(self.err(
                    c,
                    s,
                    format!("unknown unit {w:?} (M, CM, MM, IN, FT, DEG or RAD)"),
                ));
            }
        }
        Ok(())
    }

    /// `DENSITY RHO=…`: the density of the solids made from now on (kg/m³).
    fn set_density(&mut self, c: &Command) -> Result<(), LangError> {
        let a = self.args(c, &["RHO"], |_| None)?;
        let Some(&(v, s)) = a.get("RHO") else {
            return Err(self.err(c, c.span, "argument RHO (kg/m³) is missing".into()));
        };
        if v.is_nan() || v < 0.0 {
            return Err(self.err(
                c,
                s,
                format!("argument RHO must be zero or positive, got {}", readable(v)),
            ));
        }
        self.density = v;
        Ok(())
    }

    /// `LOOK-FROM` / `LOOK-AT X= Y= Z=`: the view's eye or target.
    fn set_view_point(&mut self, c: &Command, name: &str) -> Result<(), LangError> {
        let len = |_: &str| Some(true);
        let a = self.args(c, &["X", "Y", "Z"], len)?;
        let p = ["X", "Y", "Z"].map(|k| a.get(k).map_or(0.0, |v| v.0));
        if name == "LOOK-FROM" {
            if p == [0.0; 3] {
                return Err(self.err(c, c.span, "at least one of X, Y, Z must be non-zero".into()));
            }
            self.out.look_from = Some(p);
        } else {
            self.out.look_at = Some(p);
        }
        Ok(())
    }

    /// `LOAD NAME` / `ADD NAME`: a stored object as the working one, or added to it.
    fn load_or_add(&mut self, c: &Command, name: &str) -> Result<(), LangError> {
        let r = self.register(c)?;
        let Some(w) = self.regs.get(&r).cloned() else {
            return Err(self.err(
                c,
                c.word.as_ref().map_or(c.span, |w| w.1),
                format!("register {r} was never stored"),
            ));
        };
        let reg_polygons = self.reg_polygons.get(&r).copied().unwrap_or(0);
        if name == "LOAD" {
            self.work = w;
            self.work_polygons = reg_polygons;
        } else {
            let total = self.work_polygons.saturating_add(reg_polygons);
            self.within_budget(c, total)?;
            self.work_polygons = total;
            // the register's objects first: CLEAR, make, ADD B, STORE B keeps the
            // order the objects were made in
            let mine = std::mem::replace(&mut self.work.objects, w.objects);
            self.work.objects.extend(mine);
        }
        Ok(())
    }

    /// `MOVE` starts the profile, `DRAW` adds a point to it.
    fn profile_point(&mut self, c: &Command, name: &str) -> Result<(), LangError> {
        let len = |_: &str| Some(true);
        let a = self.args(c, &["X", "Y", "Z"], len)?;
        let p = ["X", "Y", "Z"].map(|k| a.get(k).map_or(0.0, |v| v.0));
        if name == "MOVE" && !self.profile.is_empty() {
            return Err(self.err(c, c.span, format!(
                    "a second MOVE: the polygon started on line {} was not used by EXTRUDE-SURFACE or REV-SURFACE",
                    self.profile[0].1.line
                )));
        }
        if name == "DRAW" && self.profile.is_empty() {
            return Err(self.err(
                c,
                c.span,
                "DRAW before MOVE (a polygon starts with MOVE)".into(),
            ));
        }
        self.profile.push((p, c.span));
        Ok(())
    }

    /// `EXTRUDE-SURFACE` / `REV-SURFACE`: the profile drawn so far as a solid.
    fn extrude_or_revolve(&mut self, c: &Command, name: &str) -> Result<(), LangError> {
        let extrude = name == "EXTRUDE-SURFACE";
        let allowed: &[&str] = if extrude { &["Z"] } else { &["A", "N"] };
        let a = self.args(c, allowed, |k| match k {
            "Z" => Some(true),
            "A" => Some(false),
            _ => None,
        })?;
        let mut pts: Vec<([f64; 3], Span)> = std::mem::take(&mut self.profile);
        if pts.len() > 1 && pts.first().map(|p| p.0) == pts.last().map(|p| p.0) {
            pts.pop();
        }
        if pts.len() < 3 {
            return Err(self.err(
                c,
                c.span,
                format!(
                    "needs a MOVE/DRAW polygon of at least 3 points before it, has {}",
                    pts.len()
                ),
            ));
        }
        let shape = if extrude {
            if let Some((_, s)) = pts.iter().find(|p| p.0[2] != 0.0) {
                return Err(LangError {
                    file: self.file.to_owned(),
                    span: *s,
                    command: "MOVE/DRAW".into(),
                    what: "an EXTRUDE-SURFACE polygon lies in the XY plane: Z must be 0".into(),
                    source: None,
                });
            }
            let h = self.positive(c, &a, "Z")?;
            Shape::Extrude {
                profile: pts.iter().map(|p| [p.0[0], p.0[1]]).collect(),
                h,
            }
        } else {
            if let Some((_, s)) = pts.iter().find(|p| p.0[1] != 0.0 || p.0[0] < 0.0) {
                return Err(LangError {
                        file: self.file.to_owned(),
                        span: *s,
                        command: "MOVE/DRAW".into(),
                        what: "a REV-SURFACE profile lies in the XZ half-plane: Y = 0 and X (the radius) ≥ 0".into(),
                        source: None,
                    });
            }
            let angle = a.get("A").map_or(std::f64::consts::TAU, |v| v.0);
            let rmax = pts.iter().map(|p| p.0[0]).fold(0.0, f64::max);
            let full_n = self.facets(c, &a, rmax)?;
            let n = if a.contains_key("N") {
                full_n
            } else {
                ((full_n as f64 * angle / std::f64::consts::TAU).ceil() as usize).max(1)
            };
            Shape::Revolve {
                profile: pts.iter().map(|p| [p.0[0], p.0[2]]).collect(),
                angle,
                n,
            }
        };
        self.add_shape(c, shape)?;
        Ok(())
    }

    /// `CYLINDER` / `CONE R= H= [N=]`.
    fn cylinder_or_cone(&mut self, c: &Command, name: &str) -> Result<(), LangError> {
        let a = self.args(c, &["R", "H", "N"], |k| (k != "N").then_some(true))?;
        let r = self.positive(c, &a, "R")?;
        let h = self.positive(c, &a, "H")?;
        let n = self.facets(c, &a, r)?;
        let s = if name == "CONE" {
            Shape::Cone { r, h, n }
        } else {
            Shape::Cylinder { r, h, n }
        };
        self.add_shape(c, s)?;
        Ok(())
    }

    /// `R-JOINT-I` and the like: a joint marker on the working object.
    fn joint_marker(&mut self, c: &Command, name: &str) -> Result<(), LangError> {
        self.no_args(c)?;
        let kind = match &name[..1] {
            "R" => LinkJoint::Revolute,
            "P" => LinkJoint::Prismatic,
            _ => LinkJoint::Fixed,
        };
        let output = name.ends_with("I+1");
        if let Some(o) = self
            .work
            .objects
            .iter()
            .find(|o| matches!(o.shape, Shape::Joint { output: out, .. } if out == output))
        {
            return Err(self.err(
                c,
                c.span,
                format!(
                    "the working object already has an {} joint (made on line {})",
                    if output { "I+1" } else { "I" },
                    o.span.line
                ),
            ));
        }
        self.add_shape(c, Shape::Joint { kind, output })?;
        Ok(())
    }

    /// `ROTATE X= | Y= | Z=`: the working object turned.
    fn rotate(&mut self, c: &Command) -> Result<(), LangError> {
        if c.args.is_empty() {
            return Err(self.err(c, c.span, "needs at least one of X, Y, Z (angles)".into()));
        }
        // applied in the order written
        self.args(c, &["X", "Y", "Z"], |_| Some(false))?;
        for a in &c.args {
            let v = self.value(c, a, Some(false))?;
            let axis = match a.key.as_str() {
                "X" => 0,
                "Y" => 1,
                _ => 2,
            };
            self.transform(c, &axis_rotation(axis, v))?;
        }
        Ok(())
    }

    /// `STORE-LINK NAME`: the working object as a link of the output.
    fn store_link(&mut self, c: &Command) -> Result<(), LangError> {
        let (w, s) = self.word(c, "a link name such as C.LOC")?;
        if w.is_empty()
            || w.starts_with('.')
            || !w
                .chars()
                .all(|ch| ch.is_ascii_alphanumeric() || matches!(ch, '.' | '_' | '-' | '+'))
        {
            return Err(self.err(
                c,
                s,
                format!("{w:?} is not a link name (letters, digits, . _ - +)"),
            ));
        }
        if self
            .out
            .links
            .iter()
            .any(|l| l.name.eq_ignore_ascii_case(&w))
        {
            return Err(self.err(c, s, format!("link {w} is stored twice")));
        }
        if self.work.objects.is_empty() {
            return Err(self.err(
                c,
                c.span,
                "the working object is empty (LOAD a register first?)".into(),
            ));
        }
        let file = build_link(&self.work.objects, self.density).map_err(|e| LangError {
            source: Some(e),
            ..self.err(c, s, format!("link {w}"))
        })?;
        // what `lang run` writes, `lang load` must read back: the stored text is
        // read here by the same reader, and a refusal names this line
        LinkFile::parse(&file.to_text(), std::path::Path::new(&w))
            .map_err(|e| self.err(c, s, format!("link {w} would not read back: {e}")))?;
        self.out.links.push(StoredLink {
            name: w,
            objects: self.work.objects.clone(),
            file,
            span: c.span,
        });
        Ok(())
    }

    /// `VIEW`: the views asked for.
    fn view(&mut self, c: &Command) -> Result<(), LangError> {
        self.no_args(c)?;
        let joints = self
            .work
            .objects
            .iter()
            .filter(|o| o.shape.is_joint())
            .count();
        self.out.views.push(format!(
            "line {}: {} objects, {} joints in the working object; {} links stored",
            c.span.line,
            self.work.objects.len() - joints,
            joints,
            self.out.links.len()
        ));
        Ok(())
    }

    /// A command that is none of the above, with the one it may have meant.
    fn unknown_command(&self, c: &Command, other: &str) -> Result<(), LangError> {
        let near = COMMANDS
            .iter()
            .find(|k| k.starts_with(&other[..other.len().min(3)]))
            .map(|k| format!(" (did you mean {k}?)"))
            .unwrap_or_default();
        Err(self.err(c, c.span, format!("unknown command{near}")))
    }
}

/// Why a program's link files were not written: the path and the file system's error, kept.
#[derive(Debug, thiserror::Error)]
pub enum WriteLinksError {
    /// The directory could not be made, a link file not written or not renamed into place.
    #[error("{}: {source}", path.display())]
    Io {
        path: std::path::PathBuf,
        source: std::io::Error,
    },
    /// A link, FIFO or device is where a link file goes (nothing was written).
    #[error(transparent)]
    Target(#[from] robosim_input::OutputError),
}

/// Writes every link of `out` into `dir` (created if missing): all files are first written
/// under temporary names and renamed only when all were written, so a failed write leaves no
/// link file of this run behind.
pub fn write_links(
    out: &Output,
    dir: &std::path::Path,
) -> Result<Vec<std::path::PathBuf>, WriteLinksError> {
    let io = |path: &std::path::Path| {
        let path = path.to_path_buf();
        move |source| WriteLinksError::Io { path, source }
    };
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    // A link, FIFO or device where a link file goes is refused before anything is written
    // (the rename below would replace it).
    for l in &out.links {
        robosim_input::check_output_path(&dir.join(&l.name))?;
    }
    let mut tmps = Vec::new();
    for l in &out.links {
        let tmp = dir.join(format!(".{}.tmp", l.name));
        if let Err(e) = std::fs::write(&tmp, l.file.to_text()) {
            for t in &tmps {
                let _ = std::fs::remove_file(t);
            }
            let _ = std::fs::remove_file(&tmp);
            return Err(io(&tmp)(e));
        }
        tmps.push(tmp);
    }
    let mut paths = Vec::new();
    for (l, tmp) in out.links.iter().zip(&tmps) {
        let p = dir.join(&l.name);
        std::fs::rename(tmp, &p).map_err(io(&p))?;
        paths.push(p);
    }
    Ok(paths)
}
