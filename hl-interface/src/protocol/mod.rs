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
//! Every numeric answer passes [`finite::check`] before it is serialised: a result that left
//! f64's range is an `overflow` refusal, never `null` inside `"ok": true`.

pub mod automation;
pub mod collision;
pub mod dynamics;
pub mod finite;
pub mod kinematics;
pub mod library;
