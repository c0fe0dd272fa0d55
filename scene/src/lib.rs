//! The seam between the spaces and the simulator cores (DESIGN.md, "The shape"): what every
//! component that *uses* a model — the simulator daemon, the session ops of the query protocol,
//! the display's collision highlight, the demo and studies, the editor, file-io and the Python
//! client — needs between the Library Space, the Instance Space and the numeric cores.
//!
//! * [`instantiate`] — Library Space → Instance Space: a declaration evaluated with parameter
//!   values becomes one validated transaction; [`reinstantiate`] writes only what changed.
//! * [`load`] — the scenes a keeper can start with ([`load_from`]).
//! * [`robot`] — an Instance Space robot as the kinematics core's [`Robot`] model, and the
//!   joint transaction that moves it ([`joint_tx`]).
//! * [`solids`] — Instance Space geometry as collision solids.
//! * [`compiled`] — [`CompiledScene`]: the robot and obstacle models of a snapshot, compiled once
//!   per structure version and updated in place when only poses and joint values change (a
//!   30-step MOVEJI compiles its robot once).
//! * [`pose`] — the one conversion between the Instance Space's 3×4 poses and nalgebra.
//!
//! Nothing here talks to a transport: it reads [`Snapshot`]s (shared or process-local) and
//! returns transactions and plain models; the callers decide how to send them.
//!
//! [`Robot`]: robosim_kinematics::Robot
//! [`Snapshot`]: robosim_instance_space::Snapshot

#![forbid(unsafe_code)]

pub mod cli;
pub mod compiled;
mod error;
pub mod instantiate;
pub mod load;
pub mod pose;
pub mod robot;
pub mod solids;

pub use compiled::{CacheStats, CompiledRobot, CompiledScene, Obstacles, Sync};
pub use error::{SceneError, SessionFailure};
pub use instantiate::{
    LibraryFrom, Origin, build_library, find_instance, instantiate, instantiate_in_session,
    library_from_publication, parse_params, reinstantiate, session_library, session_library_from,
    set_in_session,
};
pub use load::{box_geometry, load_from};
pub use robot::{joint_tx, link_poses, robot_coupling, robot_model};
