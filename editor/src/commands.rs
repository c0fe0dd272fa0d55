//! The editor's commands (R2's menus as typed commands, seed §2.3; docs/editor.md lists them):
//! one line each, `verb [NAME …] [KEY = VALUE [UNIT] …]`. Numbers take the session's units
//! (`units cm`, `units deg`: the defaults) unless they carry their own (`R = 10 cm`). The same
//! lines come from the prompt of `robosim edit` or from `--script FILE`.

use crate::codegen::{self, CodeUnits};
use crate::lang::{Unit, unit};
use crate::program;
use crate::session::{Editor, Space};
use crate::shape::{Shape, facets_for};
use crate::structure::{Design, EditError};
use robosim_file_io::linkfile::LinkJoint;
use robosim_geometry::shapes::ShapeError;
use robosim_instance_space::{Id, Snapshot};
use std::rc::Rc;

/// Every verb, for completion and help.
pub const VERBS: &[&str] = &[
    "units",
    "box",
    "cylinder",
    "cone",
    "truncated-cone",
    "sphere",
    "move",
    "draw",
    "extrude",
    "revolve",
    "clone",
    "translate",
    "home",
    "rotate",
    "rotate-rel",
    "delete",
    "attach",
    "resize",
    "r-joint-i",
    "p-joint-i",
    "f-joint-i",
    "r-joint-i+1",
    "p-joint-i+1",
    "f-joint-i+1",
    "check",
    "link",
    "undo",
    "redo",
    "save",
    "load",
    "restart",
    "code",
    "read-code",
    "run",
    "faces",
    "picked",
    "list",
    "help",
    "quit",
];

/// The prompt's state besides the design: units, the polygon being drawn, and what the editor
/// last read of the session (its model and the display's pick).
pub struct Prompt {
    pub length: (f64, String),
    pub angle: (f64, String),
    pub profile: Vec<[f64; 3]>,
    /// The session's selection as last read: `.` (or `selected`) names this object, and as a
    /// polygon word this polygon.
    pub picked: Option<Picked>,
    /// The session's model as last read: objects outside the design (a library scene's
    /// modules) are found here by path for `translate` and `rotate-rel`.
    pub model: Option<Rc<Snapshot>>,
}

impl Default for Prompt {
    fn default() -> Self {
        Prompt {
            length: (0.01, "cm".into()),
            angle: (std::f64::consts::PI / 180.0, "deg".into()),
            profile: Vec::new(),
            picked: None,
            model: None,
        }
    }
}

/// The display's pick, as the editor reads it from the session's selection.
#[derive(Debug, Clone, PartialEq)]
pub struct Picked {
    pub id: Id,
    pub polygon: Option<u32>,
    /// The design object it is (in the current link), if it is one.
    pub name: Option<String>,
    /// Its path in the session's model (`scene/item/object`).
    pub path: String,
}

impl Picked {
    /// The selection of `snap`, named against the editor's design.
    pub fn read<S: Space>(snap: &Snapshot, ed: &Editor<S>) -> Option<Picked> {
        let sel = snap.selection()?;
        let i = snap.index_of(sel.object)?;
        Some(Picked {
            id: sel.object,
            polygon: sel.polygon,
            name: ed.name_of(sel.object),
            path: snap.path(i),
        })
    }
    /// "cyl (polygon 3)" or "station/truss/m1 (not in the design)".
    pub fn describe(&self) -> String {
        let poly = self
            .polygon
            .map(|k| format!(", polygon {k}"))
            .unwrap_or_default();
        match &self.name {
            Some(n) => format!("{n}{poly}"),
            None => format!(
                "{} (not in the design: translate and rotate-rel move it){poly}",
                self.path
            ),
        }
    }
}

/// The words that name the picked object (and, as a polygon word, the picked polygon).
fn is_pick(w: &str) -> bool {
    w == "." || w.eq_ignore_ascii_case("selected")
}

/// What an object word names: a design object, or an object of the session's model outside the
/// design (by its path, or the pick).
enum Target {
    Design(String),
    Model { id: Id, path: String },
}

fn pick(p: &Prompt) -> Result<&Picked, String> {
    p.picked
        .as_ref()
        .ok_or_else(|| "nothing is picked: click an object in the display first".to_owned())
}

fn target<S: Space>(ed: &Editor<S>, p: &Prompt, w: &str) -> Result<Target, CommandError> {
    if is_pick(w) {
        let k = pick(p)?;
        return Ok(match &k.name {
            Some(n) => Target::Design(n.clone()),
            None => Target::Model {
                id: k.id,
                path: k.path.clone(),
            },
        });
    }
    let not_found = match ed.design().object(w) {
        Ok(_) => return Ok(Target::Design(w.to_owned())),
        Err(e) => e,
    };
    if let Some(snap) = &p.model {
        let path = w.trim_start_matches('/');
        let last = path.rsplit('/').next().unwrap_or(path);
        if let Some(i) = (0..snap.len()).find(|&i| snap.name(i) == last && snap.path(i) == path) {
            if snap.origin(i).contains("\"editor\"") {
                return Err(format!(
                    "{w}: an object of an editor design; edit it in that design (robosim edit --robot …)"
                )
                .into());
            }
            return Ok(Target::Model {
                id: snap.rec(i).id,
                path: path.to_owned(),
            });
        }
    }
    Err(not_found.into())
}

/// The design object a word names (`.`: the pick, which must be a design object).
fn design_name<S: Space>(ed: &Editor<S>, p: &Prompt, w: &str) -> Result<String, String> {
    if is_pick(w) {
        let k = pick(p)?;
        return k.name.clone().ok_or_else(|| {
            format!(
                "the picked object {} is not part of design {}: only translate and rotate-rel act on the model's other objects",
                k.path,
                ed.design().robot
            )
        });
    }
    Ok(w.to_owned())
}

/// The picked object's local pose in the last-read model, and the pose `f` makes of it.
fn move_model<S: Space>(
    ed: &mut Editor<S>,
    p: &Prompt,
    id: Id,
    path: &str,
    f: impl FnOnce(nalgebra::Matrix4<f64>) -> nalgebra::Matrix4<f64>,
) -> Result<crate::session::Done, CommandError> {
    let snap = p
        .model
        .as_ref()
        .ok_or("the session's model has not been read")?;
    let i = snap
        .index_of(id)
        .ok_or_else(|| format!("{path}: no longer in the session"))?;
    let before = snap.pose(i).pose;
    let after = robosim_scene::pose::from_matrix(&f(robosim_scene::pose::to_matrix(&before)));
    ed.move_model_object(id, before, after, snap.version())
        .map_err(|source| CommandError::Model {
            path: path.to_owned(),
            source,
        })
}

/// Why a line was refused (nothing changed). A variant that wraps a lower error keeps it
/// (`source()`, or the variant itself for a transparent one); its message is the line's message,
/// naming the object, file or argument.
#[derive(Debug, thiserror::Error)]
pub enum CommandError {
    /// The line itself is wrong (the message names the verb, argument or object).
    #[error("{0}")]
    Refused(String),
    /// The design refused the edit, or the keeper its transaction.
    #[error(transparent)]
    Edit(#[from] EditError),
    /// An object of the session's model outside the design could not be moved (`path`: its
    /// path).
    #[error("{path}: {source}")]
    Model { path: String, source: EditError },
    /// An object's shape makes no solid.
    #[error(transparent)]
    Shape(#[from] ShapeError),
    /// `save FILE`: the design could not be written.
    #[error("save: {source}")]
    Save { source: SaveError },
    /// `load FILE`: the file could not be read.
    #[error("load: {source}")]
    LoadRead { source: robosim_input::InputError },
    /// `load FILE`: the file is not a design (serde's error).
    #[error("load: {file}: {source}")]
    LoadFormat {
        file: String,
        source: serde_json::Error,
    },
    /// `load FILE`: the design read does not hold together.
    #[error("load: {file}: {source}")]
    LoadInvalid { file: String, source: InvalidDesign },
    /// `code FILE`: the program's directory could not be made.
    #[error("code: {}: {source}", dir.display())]
    CodeDir {
        dir: std::path::PathBuf,
        source: std::io::Error,
    },
    /// `code FILE`: the program could not be written.
    #[error("code: {source}")]
    CodeWrite { source: robosim_input::OutputError },
    /// `read-code FILE`: the program could not be read.
    #[error("read-code: {source}")]
    CodeRead { source: robosim_input::InputError },
    /// A ROBOSIM program (read or generated) has an error (file:line:column).
    #[error(transparent)]
    Program(#[from] crate::lang::LangError),
    /// `run DIR`: the link files could not be written.
    #[error(transparent)]
    WriteLinks(#[from] program::WriteLinksError),
}

/// Why `save` could not write the design.
#[derive(Debug, thiserror::Error)]
pub enum SaveError {
    /// The design did not encode as JSON.
    #[error(transparent)]
    Encode(#[from] serde_json::Error),
    /// The file was not written.
    #[error(transparent)]
    Write(#[from] robosim_input::OutputError),
}

/// Why a loaded design does not hold together (the object named).
#[derive(Debug, thiserror::Error)]
pub enum InvalidDesign {
    #[error("{0}")]
    Refused(String),
    /// An object's shape makes no solid.
    #[error("{object}: {source}")]
    Shape { object: String, source: ShapeError },
    /// An object's parent is not in its link.
    #[error(transparent)]
    Parent(#[from] EditError),
}

impl From<String> for CommandError {
    fn from(what: String) -> Self {
        CommandError::Refused(what)
    }
}

impl From<&str> for CommandError {
    fn from(what: &str) -> Self {
        CommandError::Refused(what.to_owned())
    }
}

/// What a line did.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// A message (the edit's version, or what was asked for).
    Said(String),
    Quit,
}

struct Line {
    verb: String,
    words: Vec<String>,
    args: Vec<(String, f64, Option<Unit>)>,
}

fn split(line: &str) -> Result<Option<Line>, String> {
    let line = line.split(['#', '!']).next().unwrap_or("");
    // glue "K = V" into "K=V"
    let mut s = String::new();
    for part in line.split('=') {
        if !s.is_empty() {
            s = s.trim_end().to_owned();
            s.push('=');
            s.push_str(part.trim_start());
        } else {
            s.push_str(part);
        }
    }
    let toks: Vec<&str> = s
        .split(|c: char| c.is_whitespace() || c == ',')
        .filter(|t| !t.is_empty())
        .collect();
    let Some(verb) = toks.first() else {
        return Ok(None);
    };
    let mut l = Line {
        verb: verb.to_ascii_lowercase(),
        words: Vec::new(),
        args: Vec::new(),
    };
    for t in &toks[1..] {
        if let Some((k, v)) = t.split_once('=') {
            let num_end = v
                .find(|c: char| c.is_ascii_alphabetic() && c != 'e' && c != 'E')
                .unwrap_or(v.len());
            let (n, u) = v.split_at(num_end);
            let x: f64 = n
                .parse()
                .map_err(|_| format!("argument {}: {v:?} is not a number", k.to_uppercase()))?;
            if !x.is_finite() {
                return Err(format!("argument {}: {v} is not finite", k.to_uppercase()));
            }
            let u = if u.is_empty() {
                None
            } else {
                Some(unit(u).ok_or_else(|| {
                    format!(
                        "argument {}: unknown unit {u:?} (m, cm, mm, in, ft, deg, rad)",
                        k.to_uppercase()
                    )
                })?)
            };
            l.args.push((k.to_ascii_uppercase(), x, u));
        } else if let (Some(u), Some(last)) = (unit(t), l.args.last_mut()) {
            if last.2.is_none() {
                last.2 = Some(u);
            } else {
                return Err(format!("a second unit {t:?} after argument {}", last.0));
            }
        } else {
            l.words.push((*t).to_owned());
        }
    }
    Ok(Some(l))
}

impl Prompt {
    fn get(&self, l: &Line, key: &str, length: bool) -> Result<Option<f64>, String> {
        let Some((_, v, u)) = l.args.iter().find(|a| a.0 == key) else {
            return Ok(None);
        };
        Ok(Some(match (u, length) {
            (None, true) => v * self.length.0,
            (None, false) => v * self.angle.0,
            (Some(Unit::Length(f)), true) => v * f,
            (Some(Unit::Angle(f)), false) => v * f,
            _ => {
                return Err(format!(
                    "argument {key} is {}; that unit is not one",
                    if length { "a length" } else { "an angle" }
                ));
            }
        }))
    }

    fn need(&self, l: &Line, key: &str, length: bool) -> Result<f64, String> {
        self.get(l, key, length)?
            .ok_or_else(|| format!("{}: argument {key} is missing", l.verb))
    }

    fn count(l: &Line) -> Result<Option<usize>, String> {
        match l.args.iter().find(|a| a.0 == "N") {
            None => Ok(None),
            Some((_, v, None)) if v.fract() == 0.0 && *v >= 3.0 && *v <= 16384.0 => {
                Ok(Some(*v as usize))
            }
            Some((_, v, _)) => Err(format!(
                "argument N: {v} facets (an integer from 3 to 16384)"
            )),
        }
    }

    fn check_keys(l: &Line, allowed: &[&str]) -> Result<(), String> {
        for a in &l.args {
            if !allowed.contains(&a.0.as_str()) {
                return Err(format!(
                    "{}: unknown argument {} (it takes {})",
                    l.verb,
                    a.0,
                    if allowed.is_empty() {
                        "none".into()
                    } else {
                        allowed.join(", ")
                    }
                ));
            }
        }
        Ok(())
    }

    fn xyz(&self, l: &Line, length: bool) -> Result<[f64; 3], String> {
        Self::check_keys(l, &["X", "Y", "Z"])?;
        Ok([
            self.get(l, "X", length)?.unwrap_or(0.0),
            self.get(l, "Y", length)?.unwrap_or(0.0),
            self.get(l, "Z", length)?.unwrap_or(0.0),
        ])
    }
}

fn word<'a>(l: &'a Line, i: usize, what: &str) -> Result<&'a str, String> {
    l.words
        .get(i)
        .map(String::as_str)
        .ok_or_else(|| format!("{}: needs {what}", l.verb))
}

/// Which polygon a face word names: a number, `top` or `bottom` (the polygon whose outward
/// normal points most along +z / −z of the object's own frame), or `.` / `selected`: the
/// polygon picked in the display (on this object).
fn face(d: &Design, p: &Prompt, obj: &str, w: &str) -> Result<usize, CommandError> {
    if let Ok(k) = w.parse::<usize>() {
        return Ok(k);
    }
    if is_pick(w) {
        let k = pick(p)?;
        return match (&k.name, k.polygon) {
            (Some(n), Some(poly)) if n == obj => Ok(poly as usize),
            (Some(n), None) if n == obj => {
                Err(format!("the pick on {obj} is not on a polygon").into())
            }
            _ => Err(format!(
                "the picked polygon is on {}, not on {obj}",
                k.name.as_deref().unwrap_or(&k.path)
            )
            .into()),
        };
    }
    let o = d.object(obj)?;
    if o.shape.is_joint() {
        return Ok(0);
    }
    let p = o.shape.polyhedron()?.ok_or("no polygons")?;
    let sign = match w {
        "top" => 1.0,
        "bottom" => -1.0,
        other => {
            return Err(format!("{other:?} is not a polygon (a number, top or bottom)").into());
        }
    };
    (0..p.polygons.len())
        .max_by(|&a, &b| {
            (sign * p.polygons[a].plane.normal.z).total_cmp(&(sign * p.polygons[b].plane.normal.z))
        })
        .ok_or_else(|| "no polygons".into())
}

/// Runs one line against the editor: the verb picks its handler (one function per command or
/// family of commands, below).
pub fn execute<S: Space>(
    ed: &mut Editor<S>,
    p: &mut Prompt,
    line: &str,
) -> Result<Outcome, CommandError> {
    let Some(l) = split(line)? else {
        return Ok(Outcome::Said(String::new()));
    };
    let v = l.verb.as_str();
    match v {
        "units" => set_units(p, &l),
        "box" | "cylinder" | "cone" | "truncated-cone" | "sphere" => make_primitive(ed, p, &l, v),
        "move" | "draw" => add_profile_point(p, &l, v),
        "extrude" | "revolve" => sweep_profile(ed, p, &l, v),
        "clone" => {
            let src = design_name(ed, p, word(&l, 0, "the object to clone")?)?;
            let name = word(&l, 1, "the new name")?;
            done(ed.apply(|d| d.clone_object(&src, name)))
        }
        "translate" => translate(ed, p, &l),
        "home" => {
            let o = design_name(ed, p, word(&l, 0, "an object")?)?;
            done(ed.apply(|d| d.home(&o)))
        }
        "rotate" | "rotate-rel" => rotate(ed, p, &l, v),
        "delete" => {
            let o = design_name(ed, p, word(&l, 0, "an object")?)?;
            done(ed.apply(|d| d.delete(&o)))
        }
        "attach" => attach(ed, p, &l),
        "resize" => resize(ed, p, &l),
        "r-joint-i" | "p-joint-i" | "f-joint-i" | "r-joint-i+1" | "p-joint-i+1" | "f-joint-i+1" => {
            make_joint_marker(ed, &l, v)
        }
        "check" => check_link(ed, p),
        "link" => {
            let n = word(&l, 0, "a link name (LOC, L1, …)")?;
            done(ed.apply(|d| d.switch_link(n)))
        }
        "undo" => done(ed.undo()),
        "redo" => done(ed.redo()),
        "save" => save_design(ed, &l),
        "load" => load_design(ed, &l),
        "restart" => {
            let robot = ed.design().robot.clone();
            done(ed.replace(Design::new(&robot)))
        }
        "code" => write_code(ed, p, &l),
        "read-code" => read_code(ed, &l),
        "run" => run_code(ed, p, &l),
        "faces" => list_faces(ed, p, &l),
        "picked" => Ok(Outcome::Said(match &p.picked {
            Some(k) => format!("picked: {}", k.describe()),
            None => "nothing is picked (click an object in the display)".into(),
        })),
        "list" => Ok(list_objects(ed.design())),
        "help" => Ok(Outcome::Said(format!(
            "commands: {} (docs/editor.md)",
            VERBS.join(" ")
        ))),
        "quit" | "exit" => Ok(Outcome::Quit),
        other => Err(unknown_verb(other).into()),
    }
}

/// What an edit that went through says: the new version and its op count.
fn done(r: Result<crate::session::Done, EditError>) -> Result<Outcome, CommandError> {
    let d = r?;
    Ok(Outcome::Said(format!(
        "ok, version {} ({} ops)",
        d.version, d.ops
    )))
}

/// `units U`: the unit of lengths or of angles from now on.
fn set_units(p: &mut Prompt, l: &Line) -> Result<Outcome, CommandError> {
    let w = word(l, 0, "a unit (m, cm, mm, in, ft, deg, rad)")?;
    match unit(w) {
        Some(Unit::Length(f)) => p.length = (f, w.to_owned()),
        Some(Unit::Angle(f)) => p.angle = (f, w.to_owned()),
        None => {
            return Err(format!("units: unknown unit {w:?} (m, cm, mm, in, ft, deg, rad)").into());
        }
    }
    Ok(Outcome::Said(format!(
        "units {} and {}",
        p.length.1, p.angle.1
    )))
}

/// `box|cylinder|cone|truncated-cone|sphere NAME KEY = VALUE …`: a primitive in the design.
fn make_primitive<S: Space>(
    ed: &mut Editor<S>,
    p: &mut Prompt,
    l: &Line,
    v: &str,
) -> Result<Outcome, CommandError> {
    let name = word(l, 0, "an object name")?;
    let shape = match v {
        "box" => {
            Prompt::check_keys(l, &["X", "Y", "Z"])?;
            Shape::Box {
                x: p.need(l, "X", true)?,
                y: p.need(l, "Y", true)?,
                z: p.need(l, "Z", true)?,
            }
        }
        "cylinder" | "cone" => {
            Prompt::check_keys(l, &["R", "H", "N"])?;
            let r = p.need(l, "R", true)?;
            let h = p.need(l, "H", true)?;
            let n = Prompt::count(&l)?.unwrap_or_else(|| facets_for(r));
            if v == "cone" {
                Shape::Cone { r, h, n }
            } else {
                Shape::Cylinder { r, h, n }
            }
        }
        "truncated-cone" => {
            Prompt::check_keys(l, &["R1", "R2", "H", "N"])?;
            let upper = p.need(l, "R1", true)?;
            let lower = p.need(l, "R2", true)?;
            let h = p.need(l, "H", true)?;
            let n = Prompt::count(&l)?.unwrap_or_else(|| facets_for(upper.max(lower)));
            Shape::TruncatedCone { upper, lower, h, n }
        }
        _ => {
            Prompt::check_keys(l, &["R", "N"])?;
            let r = p.need(l, "R", true)?;
            let n = Prompt::count(&l)?.unwrap_or_else(|| facets_for(r));
            Shape::Sphere { r, n }
        }
    };
    done(ed.apply(|d| d.make(name, shape)))
}

/// `move X Y Z` starts the profile, `draw X Y Z` adds a point to it.
fn add_profile_point(p: &mut Prompt, l: &Line, v: &str) -> Result<Outcome, CommandError> {
    let pt = p.xyz(l, true)?;
    if v == "move" {
        p.profile.clear();
    } else if p.profile.is_empty() {
        return Err("draw: start the polygon with move".into());
    }
    p.profile.push(pt);
    Ok(Outcome::Said(format!("{} points", p.profile.len())))
}

/// `extrude NAME Z = H` / `revolve NAME [A = ANGLE] [N = n]`: the profile drawn so far as a
/// solid (the profile is cleared when it went through).
fn sweep_profile<S: Space>(
    ed: &mut Editor<S>,
    p: &mut Prompt,
    l: &Line,
    v: &str,
) -> Result<Outcome, CommandError> {
    let name = word(l, 0, "an object name")?;
    let mut pts = p.profile.clone();
    if pts.len() > 1 && pts.first() == pts.last() {
        pts.pop();
    }
    let shape = if v == "extrude" {
        Prompt::check_keys(l, &["Z"])?;
        Shape::Extrude {
            profile: pts.iter().map(|q| [q[0], q[1]]).collect(),
            h: p.need(l, "Z", true)?,
        }
    } else {
        Prompt::check_keys(l, &["A", "N"])?;
        let angle = p.get(l, "A", false)?.unwrap_or(std::f64::consts::TAU);
        let rmax = pts.iter().map(|q| q[0]).fold(0.0, f64::max);
        let n = Prompt::count(&l)?.unwrap_or_else(|| {
            ((facets_for(rmax) as f64 * angle / std::f64::consts::TAU).ceil() as usize).max(1)
        });
        Shape::Revolve {
            profile: pts.iter().map(|q| [q[0], q[2]]).collect(),
            angle,
            n,
        }
    };
    // The seed asks counter-clockwise for extrude and clockwise for revolve; either is
    // accepted (the faces are oriented outward from the signed area): say when the
    // drawing went the other way.
    let plane: Vec<[f64; 2]> = match &shape {
        Shape::Extrude { profile, .. } | Shape::Revolve { profile, .. } => profile.clone(),
        _ => Vec::new(),
    };
    let area = signed_area(&plane);
    let note = match v {
        "extrude" if area < 0.0 => {
            "; the polygon was drawn clockwise (the seed asks counter-clockwise for extrude): winding fixed, faces oriented outward"
        }
        "revolve" if area > 0.0 => {
            "; the profile was drawn counter-clockwise (the seed asks clockwise for revolve): winding fixed, faces oriented outward"
        }
        _ => "",
    };
    let r = done(ed.apply(|d| d.make(name, shape)));
    if r.is_ok() {
        p.profile.clear();
    }
    r.map(|o| match o {
        Outcome::Said(s) => Outcome::Said(format!("{s}{note}")),
        other => other,
    })
}

/// `translate OBJECT X Y Z`: a design object, or a model object moved in the space.
fn translate<S: Space>(
    ed: &mut Editor<S>,
    p: &mut Prompt,
    l: &Line,
) -> Result<Outcome, CommandError> {
    let t = p.xyz(l, true)?;
    match target(ed, p, word(l, 0, "an object")?)? {
        Target::Design(o) => done(ed.apply(|d| d.translate(&o, t))),
        Target::Model { id, path } => {
            if !t.iter().all(|x| x.is_finite()) {
                return Err("translate: the translation is not finite".into());
            }
            let d = move_model(ed, p, id, &path, |m| {
                nalgebra::Matrix4::new_translation(&nalgebra::Vector3::from(t)) * m
            })?;
            Ok(Outcome::Said(format!(
                "ok, version {} ({} ops): moved {path}",
                d.version, d.ops
            )))
        }
    }
}

/// `rotate OBJECT RX RY RZ` (from its home) / `rotate-rel` (from where it is); a model object
/// only turns relative.
fn rotate<S: Space>(
    ed: &mut Editor<S>,
    p: &mut Prompt,
    l: &Line,
    v: &str,
) -> Result<Outcome, CommandError> {
    let r = p.xyz(l, false)?;
    match target(ed, p, word(l, 0, "an object")?)? {
        Target::Design(o) => done(ed.apply(|d| d.rotate(&o, r, v == "rotate-rel"))),
        Target::Model { id, path } => {
            if v == "rotate" {
                return Err(format!(
                    "rotate: {path} is not in the design and has no home to rotate from; use rotate-rel"
                )
                .into());
            }
            let rot = crate::shape::axis_rotation(2, r[2])
                * crate::shape::axis_rotation(1, r[1])
                * crate::shape::axis_rotation(0, r[0]);
            let d = move_model(ed, p, id, &path, |m| m * rot)?;
            Ok(Outcome::Said(format!(
                "ok, version {} ({} ops): turned {path}",
                d.version, d.ops
            )))
        }
    }
}

/// `attach CHILD FACE [to] BASE FACE`.
fn attach<S: Space>(ed: &mut Editor<S>, p: &mut Prompt, l: &Line) -> Result<Outcome, CommandError> {
    // attach CHILD FACE [to] BASE FACE
    let w: Vec<&str> = l
        .words
        .iter()
        .map(String::as_str)
        .filter(|w| *w != "to")
        .collect();
    if w.len() != 4 {
        return Err("attach: attach CHILD POLYGON to BASE POLYGON (polygon: a number, top, bottom, or . for the picked one)".into());
    }
    let (child, base) = (design_name(ed, p, w[0])?, design_name(ed, p, w[2])?);
    let d0 = ed.design().clone();
    let (cf, bf) = (face(&d0, p, &child, w[1])?, face(&d0, p, &base, w[3])?);
    done(ed.apply(|d| d.attach(&child, cf, &base, bf)))
}

/// `resize OBJECT KEY = VALUE …`: dimensions not given keep their value.
fn resize<S: Space>(ed: &mut Editor<S>, p: &mut Prompt, l: &Line) -> Result<Outcome, CommandError> {
    let o = &design_name(ed, p, word(l, 0, "an object")?)?;
    let obj = ed.design().object(o)?.clone();
    let names = obj.shape.dim_names();
    Prompt::check_keys(l, names)?;
    let cur = obj.shape.dims();
    let mut dims = Vec::new();
    for (k, n) in names.iter().enumerate() {
        let is_angle = matches!(obj.shape, Shape::Revolve { .. });
        dims.push(p.get(l, n, !is_angle)?.unwrap_or(cur[k]));
    }
    done(ed.apply(|d| d.resize(o, &dims)))
}

/// `r-joint-i NAME` and the like: a joint marker (revolute, prismatic or fixed; the link's
/// input joint i or output joint i+1).
fn make_joint_marker<S: Space>(
    ed: &mut Editor<S>,
    l: &Line,
    v: &str,
) -> Result<Outcome, CommandError> {
    let name = word(l, 0, "a name for the joint")?;
    let kind = match &v[..1] {
        "r" => LinkJoint::Revolute,
        "p" => LinkJoint::Prismatic,
        _ => LinkJoint::Fixed,
    };
    let output = v.ends_with("i+1");
    done(ed.apply(|d| d.make(name, Shape::Joint { kind, output })))
}

/// `check`: the link's joint markers as a DH row, in the session's units.
fn check_link<S: Space>(ed: &mut Editor<S>, p: &mut Prompt) -> Result<Outcome, CommandError> {
    let row = ed.design().check_joints()?;
    Ok(Outcome::Said(format!(
        "link {}: valid DH: THETA {:.6} {}, DZ {:.6} {}, DA {:.6} {}, ALPHA {:.6} {}",
        ed.design().link().name,
        row.theta / p.angle.0,
        p.angle.1,
        row.dz / p.length.0,
        p.length.1,
        row.da / p.length.0,
        p.length.1,
        row.alpha / p.angle.0,
        p.angle.1
    )))
}

/// `save FILE`: the design as JSON.
fn save_design<S: Space>(ed: &mut Editor<S>, l: &Line) -> Result<Outcome, CommandError> {
    let f = word(l, 0, "a file name")?;
    let save = |source: SaveError| CommandError::Save { source };
    let text = serde_json::to_string_pretty(ed.design()).map_err(|e| save(e.into()))?;
    robosim_input::write_file_atomic(std::path::Path::new(f), text.as_bytes())
        .map_err(|e| save(e.into()))?;
    Ok(Outcome::Said(format!("saved {f}")))
}

/// `load FILE`: a design saved before, checked, replaces the current one.
fn load_design<S: Space>(ed: &mut Editor<S>, l: &Line) -> Result<Outcome, CommandError> {
    let f = word(l, 0, "a file name")?;
    let text = robosim_input::read_to_string(
        std::path::Path::new(f),
        "an editor design",
        robosim_input::Limit::TEXT,
    )
    .map_err(|source| CommandError::LoadRead { source })?;
    let d: Design = serde_json::from_str(&text).map_err(|source| CommandError::LoadFormat {
        file: f.to_owned(),
        source,
    })?;
    validate(&d).map_err(|source| CommandError::LoadInvalid {
        file: f.to_owned(),
        source,
    })?;
    done(ed.replace(d))
}

/// `code FILE`: the design as a ROBOSIM program.
fn write_code<S: Space>(
    ed: &mut Editor<S>,
    p: &mut Prompt,
    l: &Line,
) -> Result<Outcome, CommandError> {
    let f = word(l, 0, "a file name")?;
    let text = codegen::generate(ed.design(), code_units(p))?;
    if let Some(dir) = std::path::Path::new(f)
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
    {
        std::fs::create_dir_all(dir).map_err(|source| CommandError::CodeDir {
            dir: dir.to_path_buf(),
            source,
        })?;
    }
    robosim_input::write_file_atomic(std::path::Path::new(f), text.as_bytes())
        .map_err(|source| CommandError::CodeWrite { source })?;
    Ok(Outcome::Said(format!("wrote {f}")))
}

/// `read-code FILE`: a ROBOSIM program run and read back as the design.
fn read_code<S: Space>(ed: &mut Editor<S>, l: &Line) -> Result<Outcome, CommandError> {
    let f = word(l, 0, "a ROBOSIM program")?;
    let text = robosim_input::read_to_string(
        std::path::Path::new(f),
        "a ROBOSIM program",
        robosim_input::Limit::TEXT,
    )
    .map_err(|source| CommandError::CodeRead { source })?;
    let out = program::run(&text, f)?;
    let robot = ed.design().robot.clone();
    let d = codegen::design_from_program(&out, &robot)?;
    done(ed.replace(d))
}

/// `run DIR`: the design's program run, its link files written to DIR.
fn run_code<S: Space>(
    ed: &mut Editor<S>,
    p: &mut Prompt,
    l: &Line,
) -> Result<Outcome, CommandError> {
    let dir = word(l, 0, "a directory for the link files")?;
    let text = codegen::generate(ed.design(), code_units(p))?;
    let out = program::run(&text, "(generated)")?;
    let paths = program::write_links(&out, std::path::Path::new(dir))?;
    Ok(Outcome::Said(format!(
        "wrote {}",
        paths
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    )))
}

/// `faces OBJECT`: each polygon's centre and normal.
fn list_faces<S: Space>(
    ed: &mut Editor<S>,
    p: &mut Prompt,
    l: &Line,
) -> Result<Outcome, CommandError> {
    let o = &design_name(ed, p, word(l, 0, "an object")?)?;
    let obj = ed.design().object(o)?;
    let Some(poly) = obj.shape.polyhedron()? else {
        return Ok(Outcome::Said(format!(
            "{o}: a joint marker; polygon 0 is its frame"
        )));
    };
    let mut s = String::new();
    for k in 0..poly.polygons.len() {
        let f = crate::shape::face_frame(&poly, k);
        s.push_str(&format!(
            "{k}: centre ({:.4}, {:.4}, {:.4}) {}, normal ({:.3}, {:.3}, {:.3}){}\n",
            f[(0, 3)] / p.length.0,
            f[(1, 3)] / p.length.0,
            f[(2, 3)] / p.length.0,
            p.length.1,
            f[(0, 2)],
            f[(1, 2)],
            f[(2, 2)],
            if obj.shape.planar_face(&poly, k) {
                ""
            } else {
                " (curved-surface facet)"
            }
        ));
    }
    Ok(Outcome::Said(s.trim_end().to_owned()))
}

/// `list`: the link's objects and what they sit on.
fn list_objects(d: &Design) -> Outcome {
    let mut s = format!(
        "robot {}, link {} of {}:",
        d.robot,
        d.link().name,
        d.links.len()
    );
    for o in &d.link().objects {
        s.push_str(&format!(
            "\n  {} {}{}",
            o.name,
            o.shape.command(),
            o.parent
                .as_ref()
                .map(|p| format!(" on {p}"))
                .unwrap_or_default()
        ));
    }
    Outcome::Said(s)
}

/// An unknown verb, with the command it may have meant.
fn unknown_verb(other: &str) -> String {
    let near = VERBS
        .iter()
        // The first two characters (not bytes: a verb may start with `日本`).
        .find(|k| {
            let two: String = other.chars().take(2).collect();
            k.starts_with(&two)
        })
        .map(|k| format!(" (did you mean {k}?)"))
        .unwrap_or_default();
    format!("unknown command {other:?}{near}")
}

/// Twice the signed area of a closed polygon (shoelace): positive counter-clockwise.
fn signed_area(pts: &[[f64; 2]]) -> f64 {
    (0..pts.len())
        .map(|i| {
            let (a, b) = (pts[i], pts[(i + 1) % pts.len()]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum()
}

fn code_units(p: &Prompt) -> CodeUnits {
    let name = |s: &str| -> &'static str {
        match s.to_ascii_uppercase().as_str() {
            "M" => "M",
            "MM" => "MM",
            "IN" => "IN",
            "FT" => "FT",
            "RAD" => "RAD",
            "DEG" => "DEG",
            _ => "CM",
        }
    };
    CodeUnits {
        length: (p.length.0, name(&p.length.1)),
        angle: (
            p.angle.0,
            if name(&p.angle.1) == "RAD" {
                "RAD"
            } else {
                "DEG"
            },
        ),
    }
}

/// Checks a loaded design: every shape builds, parents exist, transforms are finite.
fn validate(d: &Design) -> Result<(), InvalidDesign> {
    if d.links.is_empty() || d.current >= d.links.len() {
        return Err(InvalidDesign::Refused(
            "no links, or the current link is out of range".into(),
        ));
    }
    for l in &d.links {
        for o in &l.objects {
            o.shape
                .polyhedron()
                .map_err(|source| InvalidDesign::Shape {
                    object: o.name.clone(),
                    source,
                })?;
            if !o.ref_.iter().chain(o.amat.iter()).all(|x| x.is_finite()) {
                return Err(InvalidDesign::Refused(format!(
                    "{}: a transform is not finite",
                    o.name
                )));
            }
            if let Some(p) = &o.parent {
                crate::structure::world_in(l, p)?;
            }
        }
    }
    Ok(())
}
