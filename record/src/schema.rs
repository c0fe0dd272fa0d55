//! The channels' JSON schemas (MCAP schema encoding `jsonschema`, message encoding `json`).
//! Names Foxglove knows (`foxglove.FrameTransforms`, `foxglove.Log`) are drawn by its panels;
//! the joint states follow ROS `sensor_msgs/JointState`, so plots and URDF joint-state inputs
//! read them as they are. Time values are Foxglove's JSON time: `{"sec", "nsec"}`.

use serde_json::{Value, json};

/// Schema encoding of every channel.
pub const SCHEMA_ENCODING: &str = "jsonschema";
/// Message encoding of every channel.
pub const MESSAGE_ENCODING: &str = "json";

/// Schema name of the joint-state channels.
pub const JOINT_STATE: &str = "sensor_msgs/msg/JointState";
/// Schema name of the link-pose channel.
pub const FRAME_TRANSFORMS: &str = "foxglove.FrameTransforms";
/// Schema name of the contact channel.
pub const CONTACTS: &str = "robosim.Contacts";
/// Schema name of the log channel (events and alarms of the run).
pub const LOG: &str = "foxglove.Log";

fn time() -> Value {
    json!({
        "type": "object",
        "title": "time",
        "description": "Simulation time",
        "properties": {
            "sec": {"type": "integer", "minimum": 0},
            "nsec": {"type": "integer", "minimum": 0, "maximum": 999_999_999}
        }
    })
}

fn numbers(description: &str) -> Value {
    json!({"type": "array", "items": {"type": "number"}, "description": description})
}

fn vector3() -> Value {
    json!({
        "type": "object",
        "title": "foxglove.Vector3",
        "properties": {"x": {"type": "number"}, "y": {"type": "number"}, "z": {"type": "number"}}
    })
}

fn quaternion() -> Value {
    json!({
        "type": "object",
        "title": "foxglove.Quaternion",
        "properties": {
            "x": {"type": "number"}, "y": {"type": "number"},
            "z": {"type": "number"}, "w": {"type": "number"}
        }
    })
}

/// `sensor_msgs/msg/JointState` in JSON.
pub fn joint_state() -> Value {
    json!({
        "title": JOINT_STATE,
        "description": "One robot's joint states, as ROS sensor_msgs/JointState. An empty array: not recorded.",
        "type": "object",
        "properties": {
            "header": {
                "type": "object",
                "properties": {"stamp": time(), "frame_id": {"type": "string"}}
            },
            "name": {"type": "array", "items": {"type": "string"}, "description": "Joint (link) names, chain order"},
            "position": numbers("rad (revolute) or m (prismatic)"),
            "velocity": numbers("rad/s or m/s"),
            "effort": numbers("N·m or N")
        }
    })
}

/// `foxglove.FrameTransforms`.
pub fn frame_transforms() -> Value {
    json!({
        "title": FRAME_TRANSFORMS,
        "description": "Link poses: world → robot (its base), robot → robot/link (chain-relative). Translation in m.",
        "type": "object",
        "properties": {
            "transforms": {
                "type": "array",
                "items": {
                    "type": "object",
                    "title": "foxglove.FrameTransform",
                    "properties": {
                        "timestamp": time(),
                        "parent_frame_id": {"type": "string"},
                        "child_frame_id": {"type": "string"},
                        "translation": vector3(),
                        "rotation": quaternion()
                    }
                }
            }
        }
    })
}

/// `robosim.Contacts`: the collision stage's verdict per robot.
pub fn contacts() -> Value {
    json!({
        "title": CONTACTS,
        "description": "Collision verdict of the step, per robot whose pipeline checks collisions",
        "type": "object",
        "properties": {
            "timestamp": time(),
            "robots": {
                "type": "array",
                "items": {
                    "type": "object",
                    "properties": {
                        "robot": {"type": "string"},
                        "contact": {"type": "boolean", "description": "The last check found a contact (or could not certify clearance)"},
                        "contact_steps": {"type": "integer", "minimum": 0, "description": "Steps with a contact since the pipeline was built"}
                    }
                }
            }
        }
    })
}

/// `foxglove.Log`.
pub fn log() -> Value {
    json!({
        "title": LOG,
        "description": "Events of the run: commands, refusals, resets, contacts beginning and ending, step failures",
        "type": "object",
        "properties": {
            "timestamp": time(),
            "level": {
                "type": "integer",
                "description": "0 unknown, 1 debug, 2 info, 3 warning, 4 error, 5 fatal",
                "oneOf": [
                    {"title": "UNKNOWN", "const": 0}, {"title": "DEBUG", "const": 1},
                    {"title": "INFO", "const": 2}, {"title": "WARNING", "const": 3},
                    {"title": "ERROR", "const": 4}, {"title": "FATAL", "const": 5}
                ]
            },
            "message": {"type": "string"},
            "name": {"type": "string", "description": "Who says it (robot name, or simulator)"},
            "file": {"type": "string"},
            "line": {"type": "integer", "minimum": 0}
        }
    })
}

/// A Foxglove JSON time from nanoseconds.
pub fn stamp(t_ns: u64) -> Value {
    json!({"sec": t_ns / 1_000_000_000, "nsec": t_ns % 1_000_000_000})
}
