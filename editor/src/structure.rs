//! The editor's structures (seed §2.3, R2's internals): a design is a robot's links; a link is
//! a list of objects, each with its shape, its `ref` (home) and `amat` (current move)
//! transforms and, when attached, its parent and the two polygons of the attachment.
//!
//! Every operation is a pure function `&Design → Result<Design, EditError>`: a refused edit
//! returns an error and the caller keeps the design it had (nothing changes). The session
//! ([`crate::session`]) commits each accepted design as one keeper transaction.
//!
//! Choices where the seed is silent or R2 had a limit (docs/editor.md):
//! * **delete** keeps the children where they are in the world and unattaches them — the seed's
//!   own choice (§2.3, "a virtual object … provides invisible support to the child objects");
//! * **translate** is relative, along the axes of the frame the object hangs in (its parent's,
//!   or the link's); **rotate** (absolute) replaces
//!   the rotation of `amat` by `Rz·Ry·Rx` from home, keeping its translation; **rotate-rel**
//!   turns about the object's current axes (`amat · Rz·Ry·Rx`);
//! * **attach** refuses an object that is already attached (the seed: "Once an object is
//!   attached it can not be unattached"), a cycle, and facets of curved surfaces;
//! * a **clone** appears where its original is, unattached.

use crate::program::{DH_TOL, Placed};
use crate::shape::{Shape, axis_rotation, face_frame, joint_face, rigid_inverse};
use nalgebra::{Matrix4, Vector3};
use robosim_file_io::linkfile::{self, DhRow, DhViolation, LinkJoint};
use serde::{Deserialize, Serialize};

/// One editor object.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EdObject {
    pub name: String,
    pub shape: Shape,
    /// The object it is attached to (in the same link).
    pub parent: Option<String>,
    /// (parent's polygon, own polygon) of the attachment.
    pub faces: Option<[usize; 2]>,
    /// Home transform, relative to the parent (or the link).
    #[serde(rename = "ref")]
    pub ref_: Matrix4<f64>,
    /// Current move from home.
    pub amat: Matrix4<f64>,
}

/// One link being designed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct LinkDesign {
    /// The link's name, e.g. `LOC`, `L1`; its file is `ROBOT.NAME`.
    pub name: String,
    pub objects: Vec<EdObject>,
}

/// A robot being designed: its links in chain order (the base first).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Design {
    pub robot: String,
    pub links: Vec<LinkDesign>,
    /// Index of the link being edited.
    pub current: usize,
}

/// Why an edit was refused. Each names the object, polygon or parameter.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EditError {
    #[error("no object {name:?} in link {link} (objects: {known})")]
    NoObject {
        name: String,
        link: String,
        known: String,
    },
    #[error("an object {name:?} already exists in link {link}")]
    Exists { name: String, link: String },
    #[error("{0:?} is not an object name (letters, digits, _ - +; not starting with a digit)")]
    BadName(String),
    /// A shape's dimensions were refused (the message names them).
    #[error("{object}: {what}")]
    Shape { object: String, what: String },
    /// A shape's solid could not be generated (the geometry's error, kept).
    #[error("{object}: {source}")]
    Solid {
        object: String,
        source: robosim_geometry::shapes::ShapeError,
    },
    /// The keeper (or the store) refused the edit's transaction (its error, kept).
    #[error("the keeper refused the edit: {source}")]
    Refused { source: Cause },
    /// An object's editor record in the space is not readable (`at`: the design or the
    /// object's path; serde's error, kept).
    #[error("{at}: its editor record: {source}")]
    Record { at: String, source: Cause },
    #[error("{object}: polygon {polygon} does not exist (it has polygons 0 to {last})")]
    NoPolygon {
        object: String,
        polygon: usize,
        last: usize,
    },
    #[error(
        "{object}: polygon {polygon} is a facet of the {shape}'s curved surface, not a planar face; attach to a flat face (a cap, a box side, an extrusion side)"
    )]
    NotPlanar {
        object: String,
        polygon: usize,
        shape: String,
    },
    #[error("{child} is already attached to {parent}; delete it and make it again (seed §2.3)")]
    AlreadyAttached { child: String, parent: String },
    #[error("{child} cannot be attached to {base}: {base} is {child} or hangs from it")]
    Cycle { child: String, base: String },
    #[error("{0}")]
    Invalid(String),
    /// The session's edit history file (undo across editor processes) could not be read (the
    /// I/O error, kept).
    #[error("the session's edit history {path}: {source}")]
    HistoryRead { path: String, source: Cause },
    /// The history file is not an edit history (serde's error, kept).
    #[error(
        "the session's edit history {path}: not an edit history ({source}); remove it to start a new one"
    )]
    HistoryFormat { path: String, source: Cause },
    /// The history could not be written after edit `version` was committed (the error, kept).
    #[error(
        "the session's edit history {path}: {source} (the edit itself was committed at version {version}; a later editor cannot undo it)"
    )]
    HistoryWrite {
        path: String,
        version: u64,
        source: Cause,
    },
    #[error("link {link}: {what}")]
    Joints { link: String, what: String },
    #[error("the I→I+1 relation of link {link} is not a DH transform: {violation}")]
    NotDh {
        link: String,
        violation: DhViolation,
    },
}

/// A lower error kept inside an [`EditError`] (the keeper's, serde's, the file system's): shared,
/// so that the edit error stays `Clone`. Its message is the error's; `source()` is the error
/// itself (downcast it to match on it); two are equal when they say the same.
#[derive(Debug, Clone)]
pub struct Cause(std::sync::Arc<dyn std::error::Error + Send + Sync>);

impl Cause {
    pub fn new(e: impl std::error::Error + Send + Sync + 'static) -> Cause {
        Cause(std::sync::Arc::new(e))
    }

    /// The error, to downcast.
    pub fn error(&self) -> &(dyn std::error::Error + Send + Sync + 'static) {
        &*self.0
    }
}

impl std::fmt::Display for Cause {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.0.fmt(f)
    }
}

impl std::error::Error for Cause {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        Some(self.error())
    }
}

impl PartialEq for Cause {
    fn eq(&self, other: &Self) -> bool {
        self.to_string() == other.to_string()
    }
}

fn valid_name(n: &str) -> bool {
    !n.is_empty()
        && !n.starts_with(|c: char| c.is_ascii_digit())
        && n.chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '+'))
}

impl Design {
    pub fn new(robot: &str) -> Design {
        Design {
            robot: robot.to_owned(),
            links: vec![LinkDesign {
                name: "LOC".into(),
                objects: Vec::new(),
            }],
            current: 0,
        }
    }

    pub fn link(&self) -> &LinkDesign {
        &self.links[self.current]
    }

    fn link_mut(&mut self) -> &mut LinkDesign {
        &mut self.links[self.current]
    }

    /// The index of object `name` in the current link.
    pub fn index(&self, name: &str) -> Result<usize, EditError> {
        let l = self.link();
        l.objects
            .iter()
            .position(|o| o.name == name)
            .ok_or_else(|| EditError::NoObject {
                name: name.to_owned(),
                link: l.name.clone(),
                known: if l.objects.is_empty() {
                    "none".into()
                } else {
                    l.objects
                        .iter()
                        .map(|o| o.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                },
            })
    }

    pub fn object(&self, name: &str) -> Result<&EdObject, EditError> {
        Ok(&self.link().objects[self.index(name)?])
    }

    /// The object's transform in the link's construction frame: W(parent) · ref · amat.
    pub fn world(&self, name: &str) -> Result<Matrix4<f64>, EditError> {
        world_in(self.link(), name)
    }

    /// Switches to link `name`, making it (empty, after the last) when new.
    pub fn switch_link(&self, name: &str) -> Result<Design, EditError> {
        if !valid_name(name) {
            return Err(EditError::BadName(name.to_owned()));
        }
        let mut d = self.clone();
        match d.links.iter().position(|l| l.name == name) {
            Some(i) => d.current = i,
            None => {
                d.links.push(LinkDesign {
                    name: name.to_owned(),
                    objects: Vec::new(),
                });
                d.current = d.links.len() - 1;
            }
        }
        Ok(d)
    }

    /// Makes an object at the link's origin.
    pub fn make(&self, name: &str, shape: Shape) -> Result<Design, EditError> {
        if !valid_name(name) {
            return Err(EditError::BadName(name.to_owned()));
        }
        if self.index(name).is_ok() {
            return Err(EditError::Exists {
                name: name.to_owned(),
                link: self.link().name.clone(),
            });
        }
        shape.polyhedron().map_err(|source| EditError::Solid {
            object: name.to_owned(),
            source,
        })?;
        if let Shape::Joint { output, .. } = &shape
            && let Some(o) = self
                .link()
                .objects
                .iter()
                .find(|o| matches!(o.shape, Shape::Joint { output: x, .. } if x == *output))
        {
            return Err(EditError::Joints {
                link: self.link().name.clone(),
                what: format!(
                    "it already has an {} joint ({}); delete it first",
                    if *output { "I+1" } else { "I" },
                    o.name
                ),
            });
        }
        let mut d = self.clone();
        d.link_mut().objects.push(EdObject {
            name: name.to_owned(),
            shape,
            parent: None,
            faces: None,
            ref_: Matrix4::identity(),
            amat: Matrix4::identity(),
        });
        Ok(d)
    }

    /// A copy of `src` called `name`, where `src` is, unattached.
    pub fn clone_object(&self, src: &str, name: &str) -> Result<Design, EditError> {
        let o = self.object(src)?.clone();
        let w = self.world(src)?;
        let mut d = self.make(name, o.shape)?;
        let k = d.index(name)?;
        d.link_mut().objects[k].ref_ = w;
        Ok(d)
    }

    fn with_object(
        &self,
        name: &str,
        f: impl FnOnce(&mut EdObject) -> Result<(), EditError>,
    ) -> Result<Design, EditError> {
        let k = self.index(name)?;
        let mut d = self.clone();
        f(&mut d.link_mut().objects[k])?;
        Ok(d)
    }

    /// Relative translation (m) along the axes of the frame the object hangs in — its parent
    /// object's, or the link's when unattached: the local pose `ref · amat` becomes
    /// `T(v) · ref · amat` (`amat ← R⁻¹ · T(v) · R · amat` with R the rotation of `ref`).
    pub fn translate(&self, name: &str, v: [f64; 3]) -> Result<Design, EditError> {
        finite(&v, "translation")?;
        self.with_object(name, |o| {
            let t = Matrix4::new_translation(&Vector3::from(v));
            let r = strip_translation(&o.ref_);
            o.amat = rigid_inverse(&r) * t * r * o.amat;
            Ok(())
        })
    }

    /// Back to the home position (amat = identity).
    pub fn home(&self, name: &str) -> Result<Design, EditError> {
        self.with_object(name, |o| {
            o.amat = Matrix4::identity();
            Ok(())
        })
    }

    /// Absolute rotation from home: X, then Y, then Z about the home axes (rad).
    pub fn rotate(&self, name: &str, xyz: [f64; 3], relative: bool) -> Result<Design, EditError> {
        finite(&xyz, "rotation")?;
        let r = axis_rotation(2, xyz[2]) * axis_rotation(1, xyz[1]) * axis_rotation(0, xyz[0]);
        self.with_object(name, |o| {
            if relative {
                o.amat *= r;
            } else {
                let mut m = r;
                for i in 0..3 {
                    m[(i, 3)] = o.amat[(i, 3)];
                }
                o.amat = m;
            }
            Ok(())
        })
    }

    /// Deletes an object; its children stay where they are in the world, unattached.
    pub fn delete(&self, name: &str) -> Result<Design, EditError> {
        let k = self.index(name)?;
        let w = self.world(name)?;
        let mut d = self.clone();
        let l = d.link_mut();
        l.objects.remove(k);
        for c in &mut l.objects {
            if c.parent.as_deref() == Some(name) {
                c.ref_ = w * c.ref_;
                c.parent = None;
                c.faces = None;
            }
        }
        Ok(d)
    }

    fn face(&self, name: &str, polygon: usize) -> Result<Matrix4<f64>, EditError> {
        let o = self.object(name)?;
        face_of(o, polygon)
    }

    /// Attaches `child`'s polygon `cface` to `base`'s polygon `bface` (seed §2.3): the child's
    /// face is turned to oppose the base's (normals opposite, centres coincident), its `ref`
    /// becomes `F_b · Flip · F_c⁻¹` — the base face frame's inverse times the child's, read
    /// the other way round — and its `amat` identity: the new home.
    pub fn attach(
        &self,
        child: &str,
        cface: usize,
        base: &str,
        bface: usize,
    ) -> Result<Design, EditError> {
        let ci = self.index(child)?;
        self.index(base)?;
        let c = &self.link().objects[ci];
        if let Some(p) = &c.parent {
            return Err(EditError::AlreadyAttached {
                child: child.to_owned(),
                parent: p.clone(),
            });
        }
        // base must not be the child or hang from it
        let mut at = Some(base.to_owned());
        while let Some(n) = at {
            if n == child {
                return Err(EditError::Cycle {
                    child: child.to_owned(),
                    base: base.to_owned(),
                });
            }
            at = self.object(&n)?.parent.clone();
        }
        if self.object(base)?.shape.is_joint() {
            return Err(EditError::Invalid(format!(
                "{base} is a joint marker; attach joints to objects, not objects to joints"
            )));
        }
        let fb = self.face(base, bface)?;
        let fc = self.face(child, cface)?;
        let flip = axis_rotation(0, std::f64::consts::PI);
        let r = fb * flip * rigid_inverse(&fc);
        let mut d = self.clone();
        let o = &mut d.link_mut().objects[ci];
        o.ref_ = orthonormalize(&r);
        o.amat = Matrix4::identity();
        o.parent = Some(base.to_owned());
        o.faces = Some([bface, cface]);
        Ok(d)
    }

    /// New dimensions for `name` (the list [`Shape::dims`] gives, m / rad). Attachments are
    /// kept: an attached object is placed again on the same polygon of its parent, and its
    /// children on the same polygons of the resized object.
    pub fn resize(&self, name: &str, dims: &[f64]) -> Result<Design, EditError> {
        let k = self.index(name)?;
        let o = &self.link().objects[k];
        let shape = o.shape.resized(dims).map_err(|what| EditError::Shape {
            object: name.to_owned(),
            what,
        })?;
        shape.polyhedron().map_err(|source| EditError::Solid {
            object: name.to_owned(),
            source,
        })?;
        let mut d = self.clone();
        d.link_mut().objects[k].shape = shape;
        let flip = axis_rotation(0, std::f64::consts::PI);
        // re-place the object on its parent, and its children on it
        let mut todo: Vec<usize> = vec![k];
        todo.extend(
            d.link()
                .objects
                .iter()
                .enumerate()
                .filter(|(_, c)| c.parent.as_deref() == Some(name))
                .map(|(i, _)| i),
        );
        for i in todo {
            let c = d.link().objects[i].clone();
            if let (Some(p), Some([bf, cf])) = (&c.parent, c.faces) {
                let fb = d.face(p, bf)?;
                let fc = face_of(&c, cf)?;
                d.link_mut().objects[i].ref_ = orthonormalize(&(fb * flip * rigid_inverse(&fc)));
            }
        }
        Ok(d)
    }

    /// Checks the current link's joints (seed §2.3, "check joints for validity"): the I→I+1
    /// relation must be a DH transform; returns its row.
    pub fn check_joints(&self) -> Result<DhRow, EditError> {
        let l = self.link();
        let find = |out: bool| {
            l.objects
                .iter()
                .find(|o| matches!(o.shape, Shape::Joint { output, .. } if output == out))
        };
        let (Some(i), Some(i1)) = (find(false), find(true)) else {
            return Err(EditError::Joints {
                link: l.name.clone(),
                what: "needs an I joint and an I+1 joint to check".into(),
            });
        };
        let a = rigid_inverse(&self.world(&i.name)?) * self.world(&i1.name)?;
        linkfile::dh_decompose(&a, DH_TOL).map_err(|violation| EditError::NotDh {
            link: l.name.clone(),
            violation,
        })
    }

    /// The current link's objects placed in its construction frame (what the code generator
    /// and the link-file writer use).
    pub fn placed(&self, link: usize) -> Result<Vec<Placed>, EditError> {
        let l = &self.links[link];
        l.objects
            .iter()
            .map(|o| {
                Ok(Placed {
                    shape: o.shape.clone(),
                    m: world_in(l, &o.name)?,
                    span: Default::default(),
                })
            })
            .collect()
    }

    /// The joint types of the current link, for messages.
    pub fn joint_kinds(&self) -> (Option<LinkJoint>, Option<LinkJoint>) {
        let mut out = (None, None);
        for o in &self.link().objects {
            if let Shape::Joint { kind, output } = o.shape {
                if output {
                    out.1 = Some(kind);
                } else {
                    out.0 = Some(kind);
                }
            }
        }
        out
    }
}

fn face_of(o: &EdObject, polygon: usize) -> Result<Matrix4<f64>, EditError> {
    if let Shape::Joint { output, .. } = o.shape {
        if polygon != 0 {
            return Err(EditError::NoPolygon {
                object: o.name.clone(),
                polygon,
                last: 0,
            });
        }
        return Ok(joint_face(output));
    }
    let poly = o
        .shape
        .polyhedron()
        .map_err(|source| EditError::Solid {
            object: o.name.clone(),
            source,
        })?
        .ok_or_else(|| EditError::Invalid(format!("{} has no polygons", o.name)))?;
    if polygon >= poly.polygons.len() {
        return Err(EditError::NoPolygon {
            object: o.name.clone(),
            polygon,
            last: poly.polygons.len() - 1,
        });
    }
    if !o.shape.planar_face(&poly, polygon) {
        return Err(EditError::NotPlanar {
            object: o.name.clone(),
            polygon,
            shape: o.shape.command().to_ascii_lowercase(),
        });
    }
    Ok(face_frame(&poly, polygon))
}

/// Object `name`'s transform in link `l`'s frame.
pub fn world_in(l: &LinkDesign, name: &str) -> Result<Matrix4<f64>, EditError> {
    let mut m = Matrix4::identity();
    let mut at = Some(name.to_owned());
    let mut guard = l.objects.len() + 1;
    while let Some(n) = at {
        let Some(o) = l.objects.iter().find(|o| o.name == n) else {
            return Err(EditError::NoObject {
                name: n,
                link: l.name.clone(),
                known: String::new(),
            });
        };
        m = o.ref_ * o.amat * m;
        at = o.parent.clone();
        guard -= 1;
        if guard == 0 {
            return Err(EditError::Invalid(format!(
                "{name}: the attachments form a cycle"
            )));
        }
    }
    Ok(m)
}

fn strip_translation(m: &Matrix4<f64>) -> Matrix4<f64> {
    let mut r = *m;
    for i in 0..3 {
        r[(i, 3)] = 0.0;
    }
    r
}

fn finite(v: &[f64; 3], what: &str) -> Result<(), EditError> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(EditError::Invalid(format!(
            "the {what} {v:?} is not finite"
        )))
    }
}

/// Re-orthonormalises the rotation part (Gram–Schmidt on x, then y; z = x × y), so products of
/// face frames stay rigid to the last bit the keeper checks.
fn orthonormalize(m: &Matrix4<f64>) -> Matrix4<f64> {
    let x = Vector3::new(m[(0, 0)], m[(1, 0)], m[(2, 0)]).normalize();
    let y0 = Vector3::new(m[(0, 1)], m[(1, 1)], m[(2, 1)]);
    let y = (y0 - x * x.dot(&y0)).normalize();
    let z = x.cross(&y);
    let mut out = *m;
    for i in 0..3 {
        out[(i, 0)] = x[i];
        out[(i, 1)] = y[i];
        out[(i, 2)] = z[i];
    }
    out
}
