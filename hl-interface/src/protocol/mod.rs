//! The ops of the query protocol, one module per area (DESIGN.md, "The query protocol"). Each
//! module's `dispatch(op, request, robots)` answers its own ops (`None` for any other) with the
//! answer object or a [`ProtocolError`](crate::ProtocolError); the crate root frames the
//! answers and chains the areas.
//!
//! * [`kinematics`] — `fk`, `jacobian`, `ik`, `encoder_error`;
//! * [`dynamics`] — `id`, `mass_matrix`, `gravity`, `fd`, `simulate`;
//! * [`collision`] — `collide`, `check`;
//! * [`library`] — `lib_list`, `lib_params`, `lib_evaluate`;
//! * [`automation`] — `diag_check`, `diag_simulate`, `diag_diagnose`.
//!
//! The robot ops of kinematics, dynamics and collision also take the robot typed
//! ([`RobotArg::Given`], through each module's `dispatch_with`): a session's compiled robot is
//! handed over as it is, not written to the inline form and read back on every request.
//!
//! Every numeric answer passes [`finite::check`] before it is serialised: a result that left
//! f64's range is an `overflow` refusal, never `null` inside `"ok": true`.

pub mod automation;
pub mod collision;
pub mod dynamics;
pub mod finite;
pub mod kinematics;
pub mod library;
pub mod mimic;

use robosim_kinematics::Robot;

/// Where a robot op's robot comes from.
#[derive(Clone, Copy)]
pub enum RobotArg<'a> {
    /// The request's `robot` field: a name (resolved by the closure, then the built-in tables)
    /// or an inline robot object (read by [`crate::robot_json::robot_from_json`]).
    Request(&'a dyn Fn(&str) -> Option<Robot>),
    /// A robot the caller already holds (a session's compiled robot); the request's `robot`
    /// field is not read.
    Given(&'a Robot),
}
