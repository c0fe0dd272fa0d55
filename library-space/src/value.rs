//! Run-time values of the evaluator.

use crate::model::{PlacedSolid, Rgb, RobotModel, Surface};
use crate::source::Span;
use crate::units::{Dim, Quantity};
use nalgebra::{Matrix3, Matrix4, Vector3};
use robosim_geometry::MassProperties;
use robosim_kinematics::JointType;
use std::rc::Rc;

#[derive(Debug, Clone)]
pub enum Value {
    Num(Quantity),
    Bool(bool),
    Str(String),
    List(Vec<(Value, Span)>),
    Colour(Rgb),
    Surface(Rc<Surface>),
    Transform(Matrix4<f64>),
    Solid(Rc<SolidVal>),
    Link(Rc<LinkVal>),
    Robot(Rc<RobotModel>),
}

impl Value {
    /// "a length (m, cm, mm)", "a colour", "a solid", … for error messages.
    pub fn describe(&self) -> String {
        match self {
            Value::Num(q) if q.free && q.value == 0.0 => "the unitless number 0".into(),
            Value::Num(q) => format!("{} ({})", q.dim.noun(), q.show()),
            Value::Bool(_) => "a switch (on/off)".into(),
            Value::Str(_) => "a string".into(),
            Value::List(v) => format!("a list of {} item(s)", v.len()),
            Value::Colour(_) => "a colour".into(),
            Value::Surface(_) => "a surface".into(),
            Value::Transform(_) => "a transform".into(),
            Value::Solid(_) => "a solid".into(),
            Value::Link(_) => "a link".into(),
            Value::Robot(_) => "a robot".into(),
        }
    }

    /// The kind of a parameter default, for checking arguments against it.
    pub fn same_kind(&self, other: &Value) -> bool {
        match (self, other) {
            (Value::Num(a), Value::Num(b)) => {
                a.dim == b.dim || (a.free && a.value == 0.0) || (b.free && b.value == 0.0)
            }
            (Value::List(_), Value::List(_)) => true,
            _ => std::mem::discriminant(self) == std::mem::discriminant(other),
        }
    }

    pub fn dim(&self) -> Option<Dim> {
        match self {
            Value::Num(q) => Some(q.dim),
            _ => None,
        }
    }
}

/// A solid as the evaluator passes it around: flattened primitives plus declared mass.
#[derive(Debug, Clone, Default)]
pub struct SolidVal {
    pub parts: Vec<PlacedSolid>,
    pub mass: Option<MassProperties>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JointKind {
    Moving(JointType),
    Fixed,
}

/// A link: joint, DH row, limits, dynamics, solids (in link frame).
#[derive(Debug, Clone)]
pub struct LinkVal {
    pub name: String,
    pub kind: JointKind,
    pub a: f64,
    pub alpha: f64,
    pub d: f64,
    pub theta: f64,
    pub offset: f64,
    pub qlim: [f64; 2],
    pub mass: f64,
    pub com: Vector3<f64>,
    pub inertia: Matrix3<f64>,
    pub motor_inertia: f64,
    pub viscous: f64,
    pub coulomb: f64,
    pub parts: Vec<PlacedSolid>,
}
