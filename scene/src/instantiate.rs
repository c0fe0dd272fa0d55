//! Instantiation: a Library Space declaration, evaluated with parameter values, becomes
//! Instance Space objects through one validated transaction (seed §3.2: "structural
//! declarations … instantiated with the desired parameters whenever a new entity has to be
//! generated in the Instance Space").
//!
//! Every aspect goes in: polygons (the keeper derives planes, penalty planes, edges and boxes),
//! part-whole structure (scene → robots / items → links → solids), colours and surfaces, joint
//! types with DH rows and limits, robot IK family and tool, link masses, centres of mass and
//! inertias.
//!
//! **Live parameters.** The instance's top object records its declaration and parameter values
//! (`origin`). [`reinstantiate`] evaluates the declaration again with changed values and
//! writes only the differences, object by object, matched by their path in the part tree: a
//! longer link re-sends that link's kinematics, its solids' geometry and the poses that moved,
//! and nothing of any other instance.

use crate::SceneError;
use crate::pose::from_matrix as pose;
use nalgebra::Matrix4;
use robosim_instance_space::{
    Appearance, Client, Committed, DhConvention, GeometryInput, IDENTITY, Id, JointKind, Kind,
    Kinematics, MassProps, ObjRef, Pose, Reader, Session, Snapshot, Transaction,
};

type Result<T> = std::result::Result<T, SceneError>;
use robosim_kinematics::{Convention, JointType};
use robosim_library::{Evaluated, Library, Params, PlacedSolid, RobotModel};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Where an instance came from: stored on its top object as JSON.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Origin {
    pub declaration: String,
    /// Parameter values as expressions of the library language (`"431.8 mm"`, `"0.5"`), by
    /// name; only those set explicitly (the rest take their declared defaults).
    pub params: BTreeMap<String, String>,
}

impl Origin {
    /// The origin of an instance of `declaration` with its defaults.
    pub fn defaults(declaration: &str) -> Origin {
        Origin {
            declaration: declaration.to_owned(),
            params: BTreeMap::new(),
        }
    }

    /// The record stored on the instance's top object (JSON).
    pub fn to_record(&self) -> String {
        // A struct of strings and a string map always serialises.
        serde_json::to_string(self).unwrap_or_default()
    }

    /// Reads an origin record back.
    pub fn from_record(text: &str) -> std::result::Result<Origin, serde_json::Error> {
        serde_json::from_str(text)
    }

    /// The declaration evaluated with these parameter values.
    pub fn evaluate(&self, lib: &Library) -> Result<Evaluated> {
        evaluate(lib, self)
    }
}

/// One object to be, addressed by its path in the instance.
#[derive(Debug, Clone, PartialEq)]
struct Spec {
    path: String,
    parent: Option<String>,
    kind: Kind,
    name: String,
    pose: Pose,
    joint: f64,
    appearance: Appearance,
    kinematics: Option<Kinematics>,
    dynamics: Option<MassProps>,
    geometry: Option<GeometryInput>,
}

/// Mass, centre of mass and the inertia tensor's six distinct entries (xx yy zz xy xz yz).
pub fn mass_props(
    mass: f64,
    com: &nalgebra::Vector3<f64>,
    i: &nalgebra::Matrix3<f64>,
) -> MassProps {
    MassProps {
        mass,
        com: [com.x, com.y, com.z],
        inertia: [
            i[(0, 0)],
            i[(1, 1)],
            i[(2, 2)],
            i[(0, 1)],
            i[(0, 2)],
            i[(1, 2)],
        ],
    }
}

fn appearance(s: &PlacedSolid) -> Appearance {
    let mut a = Appearance::default();
    if let Some(sf) = &s.surface {
        a.color = [
            sf.colour[0] as f32,
            sf.colour[1] as f32,
            sf.colour[2] as f32,
            sf.opacity as f32,
        ];
        a.specular = sf.specular as f32;
        a.shininess = sf.shininess as f32;
    }
    if let Some(c) = s.colour {
        a.color = [c[0] as f32, c[1] as f32, c[2] as f32, a.color[3]];
    }
    a
}

fn spec(path: String, parent: Option<String>, kind: Kind, name: &str, pose: Pose) -> Spec {
    Spec {
        path,
        parent,
        kind,
        name: name.to_owned(),
        pose,
        joint: 0.0,
        appearance: Appearance::default(),
        kinematics: None,
        dynamics: None,
        geometry: None,
    }
}

fn solid_specs(out: &mut Vec<Spec>, parent: &str, solids: &[PlacedSolid]) {
    for s in solids {
        let mut sp = spec(
            format!("{parent}/{}", s.name),
            Some(parent.to_owned()),
            Kind::Solid,
            &s.name,
            pose(&s.transform),
        );
        sp.appearance = appearance(s);
        sp.geometry = Some(GeometryInput::from_polyhedron(&s.polyhedron));
        out.push(sp);
    }
}

/// The analytic IK family as the Instance Space's code (0: numeric only). Names are the
/// kinematics crate's `Family::name()`s, which the library checks against the geometry.
fn ik_family(name: Option<&str>) -> u32 {
    match name {
        None | Some("general") => 0,
        Some("spherical_wrist") => 1,
        Some("rrp_spherical_wrist") => 2,
        Some("offset_wrist") => 3,
        Some("three_parallel") => 4,
        Some(_) => 99,
    }
}

/// A robot under `parent` (or as a root), with its base placement `placement`.
fn robot_specs(
    out: &mut Vec<Spec>,
    parent: Option<&str>,
    name: &str,
    model: &RobotModel,
    q: &[f64],
) -> Result<()> {
    let robot = &model.robot;
    if robot.check_q(q).is_err() {
        return Err(SceneError::Instantiate(format!(
            "robot {name}: {} initial joint values for {} joints",
            q.len(),
            robot.dof()
        )));
    }
    let path = match parent {
        Some(p) => format!("{p}/{name}"),
        None => name.to_owned(),
    };
    let mut r = spec(
        path.clone(),
        parent.map(str::to_owned),
        Kind::Robot,
        name,
        pose(&robot.base),
    );
    let convention = match robot.convention {
        Convention::Standard => DhConvention::Standard,
        Convention::Modified => DhConvention::Modified,
    };
    r.kinematics = Some(Kinematics::Robot {
        convention,
        ik_family: ik_family(model.ik.as_deref()),
        tool: pose(&robot.tool),
    });
    out.push(r);
    if let Some(base_solids) = model.frames.first() {
        solid_specs(out, &path, base_solids);
    }
    // Link frames relative to the robot object (whose pose is the robot's base).
    let local = robosim_kinematics::Robot {
        base: Matrix4::identity(),
        tool: Matrix4::identity(),
        ..robot.clone()
    };
    let frames = robosim_kinematics::fk::link_frames(&local, q);
    for (j, joint) in robot.joints.iter().enumerate() {
        let lname = model
            .link_names
            .get(j)
            .cloned()
            .unwrap_or_else(|| format!("link{}", j + 1));
        let lpath = format!("{path}/{lname}");
        let mut l = spec(
            lpath.clone(),
            Some(path.clone()),
            Kind::Link,
            &lname,
            pose(&frames[j + 1]),
        );
        l.joint = q[j];
        let kind = match joint.joint_type {
            JointType::Revolute => JointKind::Revolute,
            JointType::Prismatic => JointKind::Prismatic,
        };
        // A general joint (placement and axis) keeps its form and its place in a tree; a DH
        // row stays a DH row.
        l.kinematics = Some(match &joint.origin {
            Some(o) => Kinematics::Axis {
                index: j as u32,
                parent: robot.parents.get(j).copied().unwrap_or(j) as u32,
                joint: kind,
                placement: pose(&o.placement),
                axis: [o.axis.x, o.axis.y, o.axis.z],
                offset: joint.offset,
                qlim: joint.qlim,
            },
            None => Kinematics::Joint {
                index: j as u32,
                joint: kind,
                convention,
                a: joint.a,
                d: joint.d,
                alpha: joint.alpha,
                theta: joint.theta,
                offset: joint.offset,
                qlim: joint.qlim,
            },
        });
        l.dynamics = Some(mass_props(joint.mass, &joint.com, &joint.inertia));
        out.push(l);
        if let Some(solids) = model.frames.get(j + 1) {
            solid_specs(out, &lpath, solids);
        }
    }
    Ok(())
}

/// The objects an evaluated declaration becomes, parents before children. `name` is the
/// instance's name (its top object's).
fn specs(ev: &Evaluated, name: &str) -> Result<Vec<Spec>> {
    let mut out = Vec::new();
    match ev {
        Evaluated::Scene(scene) => {
            out.push(spec(name.to_owned(), None, Kind::Scene, name, IDENTITY));
            for it in &scene.solids {
                let path = format!("{name}/{}", it.name);
                out.push(spec(
                    path.clone(),
                    Some(name.to_owned()),
                    Kind::Item,
                    &it.name,
                    pose(&it.placement),
                ));
                solid_specs(&mut out, &path, &it.solid.parts);
            }
            for r in &scene.robots {
                robot_specs(&mut out, Some(name), &r.name, &r.model, &r.q)?;
            }
        }
        Evaluated::Robot(model) | Evaluated::Link(model) => {
            let q = vec![0.0; model.robot.dof()];
            robot_specs(&mut out, None, name, model, &q)?;
        }
        Evaluated::Solid(solid) => {
            out.push(spec(name.to_owned(), None, Kind::Item, name, IDENTITY));
            solid_specs(&mut out, name, &solid.parts);
            if let (Some(m), Some(top)) = (&solid.mass, out.first_mut()) {
                top.dynamics = Some(mass_props(m.mass, &m.center_of_mass.coords, &m.inertia));
            }
        }
        other => {
            return Err(SceneError::Instantiate(format!(
                "{name}: a {} cannot be instantiated (only scenes, robots, links and solids)",
                kind_name(other)
            )));
        }
    }
    Ok(out)
}

fn kind_name(ev: &Evaluated) -> &'static str {
    match ev {
        Evaluated::Constant { .. } => "constant",
        Evaluated::Colour { .. } => "colour",
        Evaluated::Surface(_) => "surface",
        Evaluated::Solid(_) => "solid",
        Evaluated::Link(_) => "link",
        Evaluated::Robot(_) => "robot",
        Evaluated::Scene(_) => "scene",
    }
}

fn evaluate(lib: &Library, origin: &Origin) -> Result<Evaluated> {
    let mut params = Params::new();
    for (k, v) in &origin.params {
        params = params.expr(k, v);
    }
    lib.evaluate(&origin.declaration, &params)
        .map_err(SceneError::from)
}

/// The transaction that creates instance `name` of `origin.declaration` with its parameters.
pub fn instantiate(lib: &Library, origin: &Origin, name: &str) -> Result<Transaction> {
    let ev = evaluate(lib, origin)?;
    let specs = specs(&ev, name)?;
    let mut tx = Transaction::new();
    let mut refs: BTreeMap<String, ObjRef> = BTreeMap::new();
    for (k, s) in specs.iter().enumerate() {
        let parent = s.parent.as_ref().and_then(|p| refs.get(p).copied());
        let r = tx.create(s.kind, &s.name, parent);
        refs.insert(s.path.clone(), r);
        write_aspects(&mut tx, r, s, None);
        if k == 0 {
            tx.set_origin(r, &origin.to_record());
        }
    }
    Ok(tx)
}

/// Writes the aspects of `s` that differ from `old` (all of them when `old` is None).
fn write_aspects(tx: &mut Transaction, r: ObjRef, s: &Spec, old: Option<&Spec>) {
    let differs = |f: &dyn Fn(&Spec) -> bool| old.is_none_or(|o| !f(o));
    if differs(&|o| o.pose == s.pose) {
        tx.set_pose(r, s.pose);
    }
    if s.kind == Kind::Link && differs(&|o| o.joint == s.joint) {
        tx.set_joint(r, s.joint);
    }
    if differs(&|o| o.appearance == s.appearance) {
        tx.set_appearance(r, s.appearance);
    }
    if s.kinematics.is_some() && differs(&|o| o.kinematics == s.kinematics) {
        tx.set_kinematics(r, s.kinematics);
    }
    if s.dynamics.is_some() && differs(&|o| o.dynamics == s.dynamics) {
        tx.set_dynamics(r, s.dynamics);
    }
    if s.geometry.is_some() && differs(&|o| o.geometry == s.geometry) {
        tx.set_geometry(r, s.geometry.clone());
    }
}

/// The instance's current objects, read back from a snapshot as specs keyed by path.
fn current_specs(snap: &Snapshot, top: usize) -> BTreeMap<String, (Id, Spec)> {
    let mut out = BTreeMap::new();
    let mut stack = vec![(top, snap.name(top).to_owned(), None::<String>)];
    while let Some((i, path, parent)) = stack.pop() {
        let o = snap.object(i);
        let geometry = snap.geometry(i).map(|g| GeometryInput {
            vertices: g.vertices.to_vec(),
            polygons: g
                .polygons
                .iter()
                .map(|p| g.indices[p.start as usize..(p.start + p.len) as usize].to_vec())
                .collect(),
        });
        let r = o.rec;
        let kinematics = r.kinematics();
        let dynamics = r.dynamics();
        let spec = Spec {
            path: path.clone(),
            parent,
            kind: o.kind().unwrap_or(Kind::Solid),
            name: o.name.to_owned(),
            pose: o.pose.pose,
            joint: o.pose.joint,
            appearance: r.appearance(),
            kinematics,
            dynamics,
            geometry,
        };
        out.insert(path.clone(), (r.id, spec));
        for k in snap.children(r.id) {
            stack.push((k, format!("{path}/{}", snap.name(k)), Some(path.clone())));
        }
    }
    out
}

/// The instance called `name` in the snapshot: its index and origin.
pub fn find_instance(snap: &Snapshot, name: &str) -> Result<(usize, Origin)> {
    let Some(i) = (0..snap.len()).find(|&i| snap.name(i) == name && !snap.origin(i).is_empty())
    else {
        let known: Vec<&str> = (0..snap.len())
            .filter(|&i| !snap.origin(i).is_empty())
            .map(|i| snap.name(i))
            .collect();
        return Err(SceneError::UnknownInstance {
            name: name.to_owned(),
            known: if known.is_empty() {
                "none".to_owned()
            } else {
                known.join(", ")
            },
        });
    };
    let origin = Origin::from_record(snap.origin(i)).map_err(|e| SceneError::Origin {
        name: name.to_owned(),
        source: std::sync::Arc::new(e),
    })?;
    Ok((i, origin))
}

/// The transaction that brings instance `name` to `origin` (new parameter values): only the
/// objects and aspects that differ are written; objects that appear or vanish are created or
/// deleted.
pub fn reinstantiate(
    lib: &Library,
    snap: &Snapshot,
    name: &str,
    origin: &Origin,
) -> Result<Transaction> {
    let (top, _) = find_instance(snap, name)?;
    let ev = evaluate(lib, origin)?;
    let mut wanted = specs(&ev, name)?;
    // The top object keeps its place: a robot instance's parent is not in its specs.
    let current = current_specs(snap, top);
    let mut tx = Transaction::new();
    let mut refs: BTreeMap<String, ObjRef> = current
        .iter()
        .map(|(p, (id, _))| (p.clone(), ObjRef::Id(*id)))
        .collect();
    for s in wanted.iter_mut() {
        match current.get(&s.path) {
            Some((id, old)) => write_aspects(&mut tx, ObjRef::Id(*id), s, Some(old)),
            None => {
                let parent = s.parent.as_ref().and_then(|p| refs.get(p).copied());
                let r = tx.create(s.kind, &s.name, parent);
                refs.insert(s.path.clone(), r);
                write_aspects(&mut tx, r, s, None);
            }
        }
    }
    let gone = |path: &str| !wanted.iter().any(|s| s.path == path);
    for (path, (id, old)) in &current {
        // Delete the topmost vanished objects; their subtrees go with them.
        if gone(path) && old.parent.as_deref().is_none_or(|p| !gone(p)) {
            tx.delete(*id, true);
        }
    }
    tx.set_origin(snap.rec(top).id, &origin.to_record());
    Ok(tx)
}

/// `NAME=EXPR` pairs as parameter values.
pub fn parse_params(pairs: &[String]) -> Result<BTreeMap<String, String>> {
    let mut out = BTreeMap::new();
    for p in pairs {
        let Some((k, v)) = p.split_once('=') else {
            return Err(SceneError::Param(p.clone()));
        };
        out.insert(k.trim().to_owned(), v.trim().to_owned());
    }
    Ok(out)
}

/// The standard library plus `files` (each may `include "std"`), checked as one library.
pub fn build_library(files: &[std::path::PathBuf]) -> Result<Library> {
    build_library_from(files, &[])
}

/// [`build_library`] plus source files already in memory as (name, text) — a model file's
/// Library Space additions; a name already present is not added twice.
pub fn build_library_from(
    files: &[std::path::PathBuf],
    extra: &[(String, String)],
) -> Result<Library> {
    let std = Library::standard().map_err(SceneError::from)?;
    let mut sources = std.sources();
    let mut add = |name: String, text: String| {
        if !sources.iter().any(|(n, _)| *n == name) {
            sources.push((name, text));
        }
    };
    for f in files {
        // A user's file sees the standard library (its scenes may place `puma560()`).
        let lib = Library::load_with_standard(f).map_err(SceneError::from)?;
        for (name, text) in lib.sources() {
            add(name, text);
        }
    }
    for (name, text) in extra {
        add(name.clone(), text.clone());
    }
    Library::from_sources(&sources).map_err(SceneError::from)
}

/// How [`session_library_from`] got the library.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LibraryFrom {
    /// Decoded from the checked encoding the keeper published: nothing parsed or evaluated.
    Checked,
    /// Parsed and checked from the published source text, and why the encoding was not used.
    Parsed { reason: String },
}

/// `robosim instantiate DECL --as NAME`: the declaration instantiated in the running session's
/// own library, committed as one transaction.
pub fn instantiate_in_session(session: &Session, origin: &Origin, name: &str) -> Result<Committed> {
    let mut reader = Reader::attach(session, "instantiate")?;
    let lib = session_library(&mut reader)?;
    let tx = instantiate(&lib, origin, name)?;
    Ok(Client::connect(session, "instantiate")?.transact(&tx)?)
}

/// `robosim set INSTANCE K=V…`: the instance re-instantiated with `params` over its recorded
/// ones; only what the new values change is written (one transaction).
pub fn set_in_session(
    session: &Session,
    instance: &str,
    params: BTreeMap<String, String>,
) -> Result<Committed> {
    let mut reader = Reader::attach(session, "set")?;
    let snap = reader.snapshot().ok_or(SceneError::NoSnapshot)?;
    let (_, mut origin) = find_instance(&snap, instance)?;
    origin.params.extend(params);
    let lib = session_library(&mut reader)?;
    let tx = reinstantiate(&lib, &snap, instance, &origin)?;
    Ok(Client::connect(session, "set")?.transact(&tx)?)
}

/// A running session's Library Space: the checked library the keeper published, read without
/// parsing; else (a keeper that published only the source text, or an encoding that is
/// stale — another build's, other sources' — or damaged) rebuilt from the source text.
pub fn session_library(reader: &mut robosim_instance_space::Reader) -> Result<Library> {
    Ok(session_library_from(reader)?.0)
}

/// [`session_library`], saying how the library was obtained. An encoding that is present but
/// not usable is also reported on stderr (it should not happen: keeper and readers are the
/// same program); its absence is not (an older keeper publishes none).
pub fn session_library_from(
    reader: &mut robosim_instance_space::Reader,
) -> Result<(Library, LibraryFrom)> {
    let published = reader.library()?;
    library_from_publication(&published)
}

/// The library of a publication ([`session_library_from`] without the reader).
pub fn library_from_publication(
    published: &robosim_instance_space::LibraryPublication,
) -> Result<(Library, LibraryFrom)> {
    let reason = match &published.checked {
        Some(bytes) => match Library::decode_checked(bytes, &published.files) {
            Ok(lib) => return Ok((lib, LibraryFrom::Checked)),
            Err(e) => {
                let reason = format!("the published checked library is not usable: {e}");
                eprintln!("library: {reason}; parsing the session's library source instead");
                reason
            }
        },
        None => "the keeper published no checked library (only its source)".to_owned(),
    };
    let lib = Library::from_sources(&published.files).map_err(SceneError::SessionLibrary)?;
    Ok((lib, LibraryFrom::Parsed { reason }))
}
