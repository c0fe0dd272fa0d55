//! Time integration of `q̈ = ABA(q, q̇, τ)` with τ held constant over a step (zero-order hold).
//!
//! Integrators ([`Integrator`]):
//! * `Euler` — explicit Euler, order 1: `q += h q̇ₙ, q̇ += h q̈ₙ`.
//! * `SemiImplicitEuler` — symplectic Euler, order 1, in the canonical variables (q, p = M q̇)
//!   (see [`Stepper::step`]; for a constant mass matrix it is `q̇ += h q̈ₙ; q += h q̇ₙ₊₁`). For a
//!   conservative system its energy error stays bounded (it conserves a nearby Hamiltonian;
//!   Hairer, Lubich & Wanner, *Geometric Numerical Integration*, §VI.3, §IX.8) instead of growing.
//! * `Rk4` — classical Runge–Kutta, order 4.
//! * `Dopri5` — Dormand & Prince (1980) 5(4) embedded pair, FSAL within a call. With
//!   [`StepSize::Adaptive`] the step is controlled on the mixed error
//!   `sqrt(mean((errᵢ / (atol + rtol·max(|yᵢ|, |ŷᵢ|)))²))` over all of (q, q̇), the step factor
//!   `0.9·err^(−1/5)` clamped to [0.2, 5] (Hairer, Nørsett & Wanner, *Solving ODEs I*, §II.4), the
//!   first step by their starting-step heuristic. With [`StepSize::Fixed`] it takes plain
//!   fifth-order steps.
//!
//! Fixed-step runs are deterministic: the same model, state, torques and steps give bit-identical
//! results ([`state_hash`] — no parallelism, no time-dependent choices, no fused or reordered
//! arithmetic between runs).
//!
//! Joint limits: with `joint_stops` on, after each accepted step a joint past a limit is put back
//! on it and its velocity into the limit is zeroed — an inelastic stop (coefficient of
//! restitution 0); the stop's impulse is implicit and the energy it removes is dissipated.
//! See [`apply_joint_stops`].
//!
//! Entry points: [`Stepper`], [`simulate`], [`state_hash`], [`apply_joint_stops`].

use crate::aba::aba_unchecked;
use crate::crba::{cholesky_in_place, cholesky_solve_in_place, crba_pass};
use crate::data::Data;
use crate::energy::energy_unchecked;
use crate::energy::kinetic_gradient_pass;
use crate::friction::{JointFriction, friction_torque_unchecked};
use crate::model::{DynamicsError, Model};
use crate::rnea::{Terms, rnea_pass};
use nalgebra::DVector;
use robosim_kinematics::State;

/// The integration scheme.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Integrator {
    Euler,
    SemiImplicitEuler,
    Rk4,
    Dopri5,
}

impl Integrator {
    pub const ALL: [Integrator; 4] = [
        Integrator::Euler,
        Integrator::SemiImplicitEuler,
        Integrator::Rk4,
        Integrator::Dopri5,
    ];

    /// The protocol name: `euler`, `semi_implicit_euler`, `rk4`, `dopri5`.
    pub fn name(self) -> &'static str {
        match self {
            Integrator::Euler => "euler",
            Integrator::SemiImplicitEuler => "semi_implicit_euler",
            Integrator::Rk4 => "rk4",
            Integrator::Dopri5 => "dopri5",
        }
    }

    /// Inverse of [`Integrator::name`].
    pub fn from_name(name: &str) -> Option<Integrator> {
        Integrator::ALL.into_iter().find(|i| i.name() == name)
    }

    /// Global order of accuracy in the step size.
    pub fn order(self) -> u32 {
        match self {
            Integrator::Euler | Integrator::SemiImplicitEuler => 1,
            Integrator::Rk4 => 4,
            Integrator::Dopri5 => 5,
        }
    }
}

/// How the step size is chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StepSize {
    /// A fixed step (s). Any integrator.
    Fixed(f64),
    /// Error-controlled steps; only for [`Integrator::Dopri5`].
    Adaptive { rtol: f64, atol: f64 },
}

/// Everything that decides how a run integrates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IntegratorConfig {
    pub integrator: Integrator,
    pub step: StepSize,
    /// Inelastic stops at the joint limits (see the module docs).
    pub joint_stops: bool,
    /// Step budget per [`Stepper::advance_to`] call (accepted + rejected).
    pub max_steps: u64,
}

impl IntegratorConfig {
    /// Fixed step `dt` (s), no joint stops, a budget of 10⁸ steps.
    pub fn fixed(integrator: Integrator, dt: f64) -> Self {
        IntegratorConfig {
            integrator,
            step: StepSize::Fixed(dt),
            joint_stops: false,
            max_steps: 100_000_000,
        }
    }

    /// Dormand–Prince with tolerances.
    pub fn adaptive(rtol: f64, atol: f64) -> Self {
        IntegratorConfig {
            integrator: Integrator::Dopri5,
            step: StepSize::Adaptive { rtol, atol },
            joint_stops: false,
            max_steps: 100_000_000,
        }
    }

    /// Refuses non-positive or non-finite steps and tolerances, and tolerances for a fixed-step
    /// integrator.
    pub fn validate(&self) -> Result<(), DynamicsError> {
        match self.step {
            StepSize::Fixed(dt) if !(dt > 0.0 && dt.is_finite()) => Err(DynamicsError::BadOption {
                field: "dt",
                reason: format!("must be a positive number of seconds, got {dt}"),
            }),
            StepSize::Adaptive { .. } if self.integrator != Integrator::Dopri5 => {
                Err(DynamicsError::BadOption {
                    field: "rtol",
                    reason: format!(
                        "tolerances need integrator dopri5; {} takes a fixed dt",
                        self.integrator.name()
                    ),
                })
            }
            StepSize::Adaptive { rtol, atol }
                if !(rtol >= 0.0
                    && atol >= 0.0
                    && rtol.is_finite()
                    && atol.is_finite()
                    && rtol + atol > 0.0) =>
            {
                Err(DynamicsError::BadOption {
                    field: "rtol",
                    reason: format!(
                        "rtol and atol must be finite, non-negative and not both zero (got {rtol}, {atol})"
                    ),
                })
            }
            _ => Ok(()),
        }
    }
}

/// Counters of a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Stats {
    pub accepted: u64,
    pub rejected: u64,
    /// Forward-dynamics (ABA) evaluations.
    pub evaluations: u64,
}

// Dormand–Prince 5(4) tableau (Hairer, Nørsett & Wanner I, Table II.5.2).
/// Iteration cap of the implicit momentum update of the symplectic Euler step.
const MAX_FIXED_POINT: usize = 60;

const C: [f64; 7] = [0.0, 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0, 1.0, 1.0];
const A: [[f64; 6]; 7] = [
    [0.0; 6],
    [1.0 / 5.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0, 0.0],
    [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0, 0.0, 0.0, 0.0],
    [
        19372.0 / 6561.0,
        -25360.0 / 2187.0,
        64448.0 / 6561.0,
        -212.0 / 729.0,
        0.0,
        0.0,
    ],
    [
        9017.0 / 3168.0,
        -355.0 / 33.0,
        46732.0 / 5247.0,
        49.0 / 176.0,
        -5103.0 / 18656.0,
        0.0,
    ],
    [
        35.0 / 384.0,
        0.0,
        500.0 / 1113.0,
        125.0 / 192.0,
        -2187.0 / 6784.0,
        11.0 / 84.0,
    ],
];
/// b − b̂: fifth-order weights (= row 7 of A) minus the embedded fourth-order ones.
const E: [f64; 7] = [
    71.0 / 57600.0,
    0.0,
    -71.0 / 16695.0,
    71.0 / 1920.0,
    -17253.0 / 339200.0,
    22.0 / 525.0,
    -1.0 / 40.0,
];

/// An integrator with its preallocated workspace: stepping allocates nothing.
#[derive(Debug, Clone)]
pub struct Stepper {
    pub config: IntegratorConfig,
    data: Data,
    /// Stage derivatives: `kq[s]` = q̇ (nq: a floating root's in its embedding, see
    /// `robosim_kinematics::root`) and `kv[s]` = q̈ (nv) at stage s.
    kq: [DVector<f64>; 7],
    kv: [DVector<f64>; 7],
    yq: DVector<f64>,
    yv: DVector<f64>,
    /// Current adaptive step proposal (s); 0 until the first step.
    h: f64,
    /// Start time of the step being taken (s): what a divergence inside it is reported at.
    t_step: f64,
    /// Joint friction, when a scene declares it ([`Stepper::with_friction`]); `None`: the
    /// rigid-body equations alone, at no cost.
    friction: Option<JointFriction>,
    /// τ + τ_friction (scratch, used only with friction).
    tau_total: DVector<f64>,
    /// The symplectic step's momentum p = M q̇ (nv; `yq` is nq long for a floating robot).
    momentum: DVector<f64>,
    pub stats: Stats,
}

impl Stepper {
    /// A stepper for `model`; fails on an invalid config.
    pub fn new(model: &Model, config: IntegratorConfig) -> Result<Stepper, DynamicsError> {
        config.validate()?;
        let (nq, nv) = (model.nq(), model.nv());
        let z = || DVector::zeros(nv);
        Ok(Stepper {
            config,
            data: Data::new(model),
            kq: std::array::from_fn(|_| DVector::zeros(nq)),
            kv: std::array::from_fn(|_| z()),
            yq: DVector::zeros(nq),
            yv: z(),
            t_step: 0.0,
            h: 0.0,
            friction: None,
            tau_total: z(),
            momentum: z(),
            stats: Stats::default(),
        })
    }

    /// The stepper with joint friction acting (a scene's `joint_friction` effect; see
    /// [`crate::friction`]). Friction settings that act on no joint of `model` are dropped, so
    /// a robot without friction data steps exactly as without the effect.
    pub fn with_friction(
        mut self,
        model: &Model,
        friction: JointFriction,
    ) -> Result<Stepper, DynamicsError> {
        friction.validate()?;
        if friction.acts_on(model) {
            model.robot.refuse_spherical("joint friction")?;
        }
        self.friction = friction.acts_on(model).then_some(friction);
        Ok(self)
    }

    /// The friction this stepper applies (`None`: none).
    pub fn friction(&self) -> Option<&JointFriction> {
        self.friction.as_ref()
    }

    /// `tau`, plus the friction torque at (q, q̇) when friction acts (into `tau_total`).
    fn applied<'a>(
        friction: &Option<JointFriction>,
        model: &Model,
        data: &mut Data,
        tau_total: &'a mut DVector<f64>,
        q: &[f64],
        qd: &[f64],
        tau: &'a [f64],
    ) -> Result<&'a [f64], DynamicsError> {
        let Some(f) = friction else {
            return Ok(tau);
        };
        let passive = friction_torque_unchecked(model, data, q, qd, tau, f)?;
        for j in 0..tau.len() {
            tau_total[j] = tau[j] + passive[j];
        }
        Ok(tau_total.as_slice())
    }

    /// The dynamics workspace (e.g. `qdd` of the last evaluation).
    pub fn data(&self) -> &Data {
        &self.data
    }

    /// The step the adaptive integrator proposes next (s; 0 before its first step): the one
    /// thing a stepper carries from a step to the next besides [`Stepper::stats`] (the rest of
    /// it is workspace, overwritten before it is read).
    pub fn step_proposal(&self) -> f64 {
        self.h
    }

    /// Evaluates f at (yq, yv) into stage `s`.
    /// Stage `s`'s derivative at (`yq`, `yv`). A non-finite stage state, or a non-finite q̈ at a
    /// later stage, is the step diverging ([`DynamicsError::Diverged`]); a non-finite q̈ at
    /// stage 0 — a state that was given or accepted, finite — is an overflow of f(state)
    /// itself ([`DynamicsError::Overflow`]), which no smaller step cures.
    fn eval(&mut self, model: &Model, s: usize, tau: &[f64]) -> Result<(), DynamicsError> {
        self.stats.evaluations += 1;
        let t = self.t_step;
        let bad = |v: &DVector<f64>| v.iter().position(|x| !x.is_finite());
        if let Some(joint) = bad(&self.yq).or_else(|| bad(&self.yv)) {
            return Err(DynamicsError::Diverged { t, joint });
        }
        let tau = Self::applied(
            &self.friction,
            model,
            &mut self.data,
            &mut self.tau_total,
            self.yq.as_slice(),
            self.yv.as_slice(),
            tau,
        )?;
        aba_unchecked(
            model,
            &mut self.data,
            self.yq.as_slice(),
            self.yv.as_slice(),
            tau,
        )?;
        if let Some(index) = bad(&self.data.qdd) {
            return Err(if s == 0 {
                DynamicsError::Overflow {
                    field: "qdd",
                    index,
                    value: self.data.qdd[index],
                }
            } else {
                DynamicsError::Diverged { t, joint: index }
            });
        }
        q_dot(model, &self.yq, &self.yv, &mut self.kq[s]);
        self.kv[s].copy_from(&self.data.qdd);
        Ok(())
    }

    /// One step of size `h` (s) with the configured integrator, no error control. Updates
    /// `state.q`, `state.qd`, `state.qdd` (at the start of the step) and `state.t`. `tau` must
    /// have `dof` entries and the state must match the model (checked).
    pub fn step(
        &mut self,
        model: &Model,
        state: &mut State,
        tau: &[f64],
        h: f64,
    ) -> Result<(), DynamicsError> {
        model.check_vector("q", state.q.as_slice())?;
        model.check_vector("qd", state.qd.as_slice())?;
        model.check_vector("tau", tau)?;
        if state.qdd.len() != model.nv() {
            // a hand-made State may carry no accelerations; give it room once
            state.qdd = DVector::zeros(model.nv());
        }
        self.step_unchecked(model, state, tau, h)?;
        finish_step(model, state, self.config.joint_stops).map(|_| ())
    }

    /// The fixed step body; lengths are the caller's invariant.
    fn step_unchecked(
        &mut self,
        model: &Model,
        state: &mut State,
        tau: &[f64],
        h: f64,
    ) -> Result<(), DynamicsError> {
        self.t_step = state.t;
        if self.config.integrator == Integrator::SemiImplicitEuler {
            if model.spherical {
                model
                    .robot
                    .refuse_spherical("the symplectic Euler integrator")?;
            }
            self.symplectic_euler(model, state, tau, h)?;
            state.t += h;
            self.stats.accepted += 1;
            return Ok(());
        }
        self.yq.copy_from(&state.q);
        self.yv.copy_from(&state.qd);
        self.eval(model, 0, tau)?;
        state.qdd.copy_from(&self.kv[0]);
        match self.config.integrator {
            Integrator::Euler => {
                if model.root.is_some() || model.spherical {
                    // q ⊕ h q̇ on the manifold
                    integrate_q(model, &mut state.q, &self.yv, h);
                } else {
                    state.q.axpy(h, &self.kq[0], 1.0);
                }
                state.qd.axpy(h, &self.kv[0], 1.0);
            }
            Integrator::Rk4 => {
                for (s, c) in [(1, 0.5), (2, 0.5), (3, 1.0)] {
                    self.yq.copy_from(&state.q);
                    self.yq.axpy(c * h, &self.kq[s - 1], 1.0);
                    self.yv.copy_from(&state.qd);
                    self.yv.axpy(c * h, &self.kv[s - 1], 1.0);
                    self.eval(model, s, tau)?;
                }
                for (s, w) in [
                    (0, 1.0 / 6.0),
                    (1, 1.0 / 3.0),
                    (2, 1.0 / 3.0),
                    (3, 1.0 / 6.0),
                ] {
                    state.q.axpy(w * h, &self.kq[s], 1.0);
                    state.qd.axpy(w * h, &self.kv[s], 1.0);
                }
                normalize_root(model, &mut state.q);
            }
            Integrator::Dopri5 => {
                self.dopri_stages(model, state, tau, h)?;
                state.q.copy_from(&self.yq);
                state.qd.copy_from(&self.yv);
                normalize_root(model, &mut state.q);
            }
            Integrator::SemiImplicitEuler => unreachable!("handled above"),
        }
        state.t += h;
        self.stats.accepted += 1;
        Ok(())
    }

    /// Symplectic Euler in the canonical variables (q, p = M(q) q̇) (Hairer, Lubich & Wanner,
    /// *Geometric Numerical Integration*, Thm. VI.3.3): `pₙ₊₁ = pₙ + h (τ − g(qₙ) − τ_f(q̇ₙ) +
    /// ∂T/∂q(qₙ, q̇))` with `q̇ = M(qₙ)⁻¹ pₙ₊₁` (implicit in pₙ₊₁ because T is not separable: solved
    /// by fixed-point iteration to round-off), then `qₙ₊₁ = qₙ + h M(qₙ)⁻¹ pₙ₊₁` and
    /// `q̇ₙ₊₁ = M(qₙ₊₁)⁻¹ pₙ₊₁`. With a constant mass matrix this is the familiar
    /// `q̇ += h q̈; q += h q̇`; with a configuration-dependent one that velocity form is *not*
    /// symplectic (it dissipates a double pendulum's energy steadily), this one is. Friction, if
    /// any, enters explicitly at q̇ₙ. `state.qdd` gets the mean acceleration `(q̇ₙ₊₁ − q̇ₙ)/h`.
    fn symplectic_euler(
        &mut self,
        model: &Model,
        state: &mut State,
        tau: &[f64],
        h: f64,
    ) -> Result<(), DynamicsError> {
        let Stepper {
            data,
            kq,
            kv,
            momentum: p,
            yv: v,
            friction,
            tau_total,
            ..
        } = self;
        let n = model.nv();
        self.stats.evaluations += 1;
        // friction at the start of the step (explicit in it), before M and g fill `data`
        let tau = Self::applied(
            friction,
            model,
            data,
            tau_total,
            state.q.as_slice(),
            state.qd.as_slice(),
            tau,
        )?;
        data.update_transforms(model, state.q.as_slice());
        crba_pass(model, data);
        cholesky_in_place(&data.mass_matrix, &mut data.chol)?;
        rnea_pass(
            model,
            data,
            &[],
            None,
            Terms {
                gravity: true,
                motor: false,
            },
        );
        kv[1].copy_from(&data.tau); // g(qₙ)
        kinetic_gradient_pass(model, data, state.qd.as_slice()); // tau = ∂T/∂q(qₙ, q̇ₙ), rhs = pₙ
        // At the given (finite) state: a non-finite gradient or momentum is f(state) overflowing.
        for (field, x) in [("dT/dq", &data.tau), ("p", &data.rhs)] {
            if let Some(index) = x.iter().position(|v| !v.is_finite()) {
                return Err(DynamicsError::Overflow {
                    field,
                    index,
                    value: x[index],
                });
            }
        }
        for j in 0..n {
            kq[2][j] = data.rhs[j] + h * (tau[j] - kv[1][j]); // the part that does not change
            p[j] = kq[2][j] + h * data.tau[j]; // explicit first guess of pₙ₊₁
        }
        let mut converged = false;
        for _ in 0..MAX_FIXED_POINT {
            v.copy_from(p);
            cholesky_solve_in_place(&data.chol, v); // q̇ = M(qₙ)⁻¹ p
            kinetic_gradient_pass(model, data, v.as_slice());
            let (mut diff, mut scale) = (0.0_f64, f64::MIN_POSITIVE);
            for j in 0..n {
                let p_new = kq[2][j] + h * data.tau[j];
                diff = diff.max((p_new - p[j]).abs());
                scale = scale.max(p_new.abs());
                p[j] = p_new;
            }
            if diff <= 1e-14 * scale {
                converged = true;
                break;
            }
        }
        if !converged {
            return Err(DynamicsError::NoConvergence { t: state.t, h });
        }
        v.copy_from(p);
        cholesky_solve_in_place(&data.chol, v);
        kv[0].copy_from(&state.qd);
        if model.root.is_some() {
            integrate_q(model, &mut state.q, v, h);
        } else {
            state.q.axpy(h, v, 1.0);
        }
        data.update_transforms(model, state.q.as_slice());
        crba_pass(model, data);
        cholesky_in_place(&data.mass_matrix, &mut data.chol)?;
        state.qd.copy_from(p);
        cholesky_solve_in_place(&data.chol, &mut state.qd);
        for j in 0..n {
            state.qdd[j] = (state.qd[j] - kv[0][j]) / h;
        }
        Ok(())
    }

    /// Stages 2..7 of Dormand–Prince from stage 1 in `k*[0]`; leaves the fifth-order solution in
    /// (yq, yv) and its derivative in stage 7.
    fn dopri_stages(
        &mut self,
        model: &Model,
        state: &State,
        tau: &[f64],
        h: f64,
    ) -> Result<(), DynamicsError> {
        for s in 1..7 {
            self.yq.copy_from(&state.q);
            self.yv.copy_from(&state.qd);
            for (k, &a) in A[s].iter().enumerate().take(s) {
                if a != 0.0 {
                    self.yq.axpy(a * h, &self.kq[k], 1.0);
                    self.yv.axpy(a * h, &self.kv[k], 1.0);
                }
            }
            debug_assert!(C[s] >= 0.0);
            self.eval(model, s, tau)?;
        }
        // stage 7 was evaluated at the fifth-order solution, which (yq, yv) still hold
        Ok(())
    }

    /// The scaled RMS error estimate of the last Dormand–Prince step from `state` to (yq, yv).
    /// Over q's nq and q̇'s nv components (equal for a fixed base; a floating root's q is in
    /// its embedding, one more component than its velocity's).
    fn dopri_error(&self, state: &State, h: f64, rtol: f64, atol: f64) -> f64 {
        let (nq, nv) = (state.q.len(), state.qd.len());
        let mut sum = 0.0;
        for i in 0..nq.max(nv) {
            let (mut eq, mut ev) = (0.0, 0.0);
            for s in 0..7 {
                if i < nq {
                    eq += E[s] * self.kq[s][i];
                }
                if i < nv {
                    ev += E[s] * self.kv[s][i];
                }
            }
            if i < nq {
                let sq = atol + rtol * state.q[i].abs().max(self.yq[i].abs());
                sum += (h * eq / sq).powi(2);
            }
            if i < nv {
                let sv = atol + rtol * state.qd[i].abs().max(self.yv[i].abs());
                sum += (h * ev / sv).powi(2);
            }
        }
        (sum / (nq + nv).max(1) as f64).sqrt()
    }

    /// Integrates from `state.t` to `t_target` (s) with torques `tau` held constant. Fixed
    /// steps: whole steps of `dt`, then one shorter step to land on `t_target` exactly when it is
    /// not a multiple. Adaptive: controlled steps, the last one clipped to `t_target`; the step
    /// proposal carries over to the next call.
    pub fn advance_to(
        &mut self,
        model: &Model,
        state: &mut State,
        tau: &[f64],
        t_target: f64,
    ) -> Result<(), DynamicsError> {
        model.check_vector("q", state.q.as_slice())?;
        model.check_vector("qd", state.qd.as_slice())?;
        model.check_vector("tau", tau)?;
        if state.qdd.len() != model.nv() {
            // a hand-made State may carry no accelerations; give it room once
            state.qdd = DVector::zeros(model.nv());
        }
        if !t_target.is_finite() || t_target < state.t {
            return Err(DynamicsError::BadOption {
                field: "t",
                reason: format!(
                    "target time {t_target} s is before the current time {} s",
                    state.t
                ),
            });
        }
        let budget = self.stats.accepted + self.stats.rejected + self.config.max_steps;
        match self.config.step {
            StepSize::Fixed(dt) => {
                // times are t0 + k·dt, not a running sum, so that 2 s at 1e-4 s is 20 000 steps
                let t0 = state.t;
                let mut k: u64 = 0;
                loop {
                    let remaining = t_target - state.t;
                    // Done when what is left is rounding of t0 + k·dt (a few ulps of the
                    // time), never a fraction of dt: with dt ≫ t_end that used to label the
                    // initial state t_end with no step taken (issue #20 item 5).
                    if remaining <= 4.0 * f64::EPSILON * t_target.abs() {
                        state.t = t_target;
                        return Ok(());
                    }
                    if self.stats.accepted + self.stats.rejected >= budget {
                        return Err(DynamicsError::TooManySteps {
                            max_steps: self.config.max_steps,
                            t_end: t_target,
                        });
                    }
                    let last = remaining <= dt * (1.0 + 1e-9);
                    let h = if last { remaining } else { dt };
                    self.step_unchecked(model, state, tau, h)?;
                    k += 1;
                    state.t = if last { t_target } else { t0 + k as f64 * dt };
                    finish_step(model, state, self.config.joint_stops)?;
                }
            }
            StepSize::Adaptive { rtol, atol } => {
                self.advance_adaptive(model, state, tau, t_target, rtol, atol, budget)
            }
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn advance_adaptive(
        &mut self,
        model: &Model,
        state: &mut State,
        tau: &[f64],
        t_target: f64,
        rtol: f64,
        atol: f64,
        budget: u64,
    ) -> Result<(), DynamicsError> {
        if t_target <= state.t {
            return Ok(());
        }
        self.t_step = state.t;
        self.yq.copy_from(&state.q);
        self.yv.copy_from(&state.qd);
        self.eval(model, 0, tau)?;
        if self.h <= 0.0 {
            self.h = self.initial_step(model, state, tau, rtol, atol, t_target - state.t)?;
        }
        loop {
            let remaining = t_target - state.t;
            if remaining <= 0.0 {
                return Ok(());
            }
            if self.stats.accepted + self.stats.rejected >= budget {
                return Err(DynamicsError::TooManySteps {
                    max_steps: self.config.max_steps,
                    t_end: t_target,
                });
            }
            let last = self.h >= remaining;
            let h = if last { remaining } else { self.h };
            let floor = 1e-14 * state.t.abs().max(1.0);
            if h < floor && !last {
                return Err(DynamicsError::StepUnderflow { t: state.t, h });
            }
            self.t_step = state.t;
            self.dopri_stages(model, state, tau, h)?;
            let err = self.dopri_error(state, h, rtol, atol);
            if err <= 1.0 {
                state.qdd.copy_from(&self.kv[0]);
                normalize_root(model, &mut self.yq);
                state.q.copy_from(&self.yq);
                state.qd.copy_from(&self.yv);
                state.t = if last { t_target } else { state.t + h };
                self.stats.accepted += 1;
                let fac = if err == 0.0 {
                    5.0
                } else {
                    (0.9 * err.powf(-0.2)).clamp(0.2, 5.0)
                };
                // keep the proposal when the last step was clipped short
                self.h = if last { self.h.max(h * fac) } else { h * fac };
                let stopped = finish_step(model, state, self.config.joint_stops)?;
                if stopped {
                    // the state jumped: the FSAL derivative is stale
                    self.yq.copy_from(&state.q);
                    self.yv.copy_from(&state.qd);
                    self.eval(model, 0, tau)?;
                } else {
                    // FSAL: stage 7 is f at the new point; stage 7's slot is overwritten next step
                    self.kq.swap(0, 6);
                    self.kv.swap(0, 6);
                }
            } else if err.is_finite() {
                self.stats.rejected += 1;
                self.h = h * (0.9 * err.powf(-0.2)).clamp(0.2, 1.0);
            } else {
                self.stats.rejected += 1;
                self.h = h * 0.2;
            }
        }
    }

    /// Hairer–Nørsett–Wanner's starting step (Solving ODEs I, §II.4) for a fifth-order method;
    /// stage 1 already holds f(t, y).
    fn initial_step(
        &mut self,
        model: &Model,
        state: &State,
        tau: &[f64],
        rtol: f64,
        atol: f64,
        span: f64,
    ) -> Result<f64, DynamicsError> {
        let (nq, nv) = (state.q.len(), state.qd.len());
        let norm = |a: &DVector<f64>, b: &DVector<f64>, sa: &DVector<f64>, sb: &DVector<f64>| {
            let mut s = 0.0;
            for i in 0..nq.max(nv) {
                if i < nq && i < nv {
                    s += (a[i] / (atol + rtol * sa[i].abs())).powi(2)
                        + (b[i] / (atol + rtol * sb[i].abs())).powi(2);
                } else if i < nq {
                    s += (a[i] / (atol + rtol * sa[i].abs())).powi(2);
                } else {
                    s += (b[i] / (atol + rtol * sb[i].abs())).powi(2);
                }
            }
            (s / (nq + nv).max(1) as f64).sqrt()
        };
        let d0 = norm(&state.q, &state.qd, &state.q, &state.qd);
        let d1 = norm(&self.kq[0], &self.kv[0], &state.q, &state.qd);
        let h0 = if d0 < 1e-5 || d1 < 1e-5 {
            1e-6
        } else {
            0.01 * d0 / d1
        }
        .min(span);
        self.yq.copy_from(&state.q);
        self.yq.axpy(h0, &self.kq[0], 1.0);
        self.yv.copy_from(&state.qd);
        self.yv.axpy(h0, &self.kv[0], 1.0);
        self.eval(model, 1, tau)?;
        let mut dq = self.kq[1].clone_owned();
        dq -= &self.kq[0];
        let mut dv = self.kv[1].clone_owned();
        dv -= &self.kv[0];
        let d2 = norm(&dq, &dv, &state.q, &state.qd) / h0;
        let h1 = if d1.max(d2) <= 1e-15 {
            (h0 * 1e-3).max(1e-6)
        } else {
            (0.01 / d1.max(d2)).powf(0.2)
        };
        Ok((100.0 * h0).min(h1).min(span))
    }
}

/// Joint stops (if on) and the divergence check after a step; returns whether a stop acted.
fn finish_step(model: &Model, state: &mut State, joint_stops: bool) -> Result<bool, DynamicsError> {
    let stopped = joint_stops && apply_joint_stops(model, state);
    // `joint`: the index in q, or in q̇ when q is finite
    let bad = |x: &DVector<f64>| x.iter().position(|v| !v.is_finite());
    if let Some(joint) = bad(&state.q).or_else(|| bad(&state.qd)) {
        return Err(DynamicsError::Diverged { t: state.t, joint });
    }
    Ok(stopped)
}

/// `q̇` in q's coordinates at (q, v) (`out` has nq entries): `v` itself for a fixed base, a
/// floating root's embedding derivative ([`robosim_kinematics::RootKind::q_dot`]) otherwise.
fn q_dot(model: &Model, q: &DVector<f64>, v: &DVector<f64>, out: &mut DVector<f64>) {
    if model.spherical {
        return spherical_q(model, q.as_slice(), v.as_slice(), out.as_mut_slice());
    }
    let Some(root) = &model.root else {
        out.copy_from(v);
        return;
    };
    let (nqr, nvr) = (root.kind.nq(), root.kind.nv());
    root.kind.q_dot(
        &q.as_slice()[..nqr],
        &v.as_slice()[..nvr],
        &mut out.as_mut_slice()[..nqr],
    );
    out.as_mut_slice()[nqr..].copy_from_slice(&v.as_slice()[nvr..]);
}

/// `q ← q ⊕ h v`: a floating root moved on its manifold ([`robosim_kinematics::RootKind::integrate`]),
/// the joints by `h v`.
fn integrate_q(model: &Model, q: &mut DVector<f64>, v: &DVector<f64>, h: f64) {
    if model.spherical {
        return spherical_integrate(model, q.as_mut_slice(), v.as_slice(), h);
    }
    let Some(root) = &model.root else {
        q.axpy(h, v, 1.0);
        return;
    };
    let (nqr, nvr) = (root.kind.nq(), root.kind.nv());
    let mut qr = [0.0; 7];
    qr[..nqr].copy_from_slice(&q.as_slice()[..nqr]);
    root.kind.integrate(
        &qr[..nqr],
        &v.as_slice()[..nvr],
        h,
        &mut q.as_mut_slice()[..nqr],
    );
    for (qj, vj) in q.as_mut_slice()[nqr..].iter_mut().zip(&v.as_slice()[nvr..]) {
        *qj += h * vj;
    }
}

/// Puts a floating root's quaternion (or cos/sin pair) back to unit norm after a Runge–Kutta
/// step taken in its embedding.
fn normalize_root(model: &Model, q: &mut DVector<f64>) {
    if let Some(root) = &model.root {
        root.kind.normalize(&mut q.as_mut_slice()[..root.kind.nq()]);
    }
    if model.spherical {
        for link in model.links.iter().filter(|l| l.spherical) {
            robosim_kinematics::spherical::quat_normalize(&mut q.as_mut_slice()[link.iq..]);
        }
    }
}

/// [`q_dot`] for a robot with spherical joints: `out` = dq/dt in q's embedding, the root's and
/// each quaternion's ([`robosim_kinematics::spherical::quat_dot`]) from their velocities, the
/// other joints' `v`.
fn spherical_q(model: &Model, q: &[f64], v: &[f64], out: &mut [f64]) {
    use robosim_kinematics::spherical::quat_dot;
    if let Some(root) = &model.root {
        let (nqr, nvr) = (root.kind.nq(), root.kind.nv());
        root.kind.q_dot(&q[..nqr], &v[..nvr], &mut out[..nqr]);
    }
    for link in &model.links {
        let (iq, iv) = (link.iq, link.iv);
        if link.spherical {
            quat_dot(&q[iq..iq + 4], &v[iv..iv + 3], &mut out[iq..iq + 4]);
        } else {
            out[iq] = v[iv];
        }
    }
}

/// [`integrate_q`] for a robot with spherical joints: `q ← q ⊕ h v`, the root and each
/// quaternion on its manifold ([`robosim_kinematics::spherical::quat_integrate`], `q ⊗ exp(h ω)`,
/// renormalised), the other joints `q + h v`. Allocates nothing.
fn spherical_integrate(model: &Model, q: &mut [f64], v: &[f64], h: f64) {
    use robosim_kinematics::spherical::quat_integrate;
    if let Some(root) = &model.root {
        let (nqr, nvr) = (root.kind.nq(), root.kind.nv());
        let mut qr = [0.0; 7];
        qr[..nqr].copy_from_slice(&q[..nqr]);
        root.kind.integrate(&qr[..nqr], &v[..nvr], h, &mut q[..nqr]);
    }
    for link in &model.links {
        let (iq, iv) = (link.iq, link.iv);
        if link.spherical {
            let mut from = [0.0; 4];
            from.copy_from_slice(&q[iq..iq + 4]);
            quat_integrate(&from, &v[iv..iv + 3], h, &mut q[iq..iq + 4]);
        } else {
            q[iq] += h * v[iv];
        }
    }
}

/// The inelastic joint stop: a joint below `qlim[0]` (above `qlim[1]`) is set to the limit and a
/// velocity pointing further out is zeroed; a velocity pointing back in is kept, so the joint
/// leaves the limit as soon as the net torque pulls it away. Returns whether any joint was
/// stopped. Rad or m.
pub fn apply_joint_stops(model: &Model, state: &mut State) -> bool {
    let mut any = false;
    let (nqr, nvr) = model.root_dims();
    for (j, link) in model.links.iter().enumerate() {
        // a spherical joint's cone limit is not enforced
        if link.spherical {
            continue;
        }
        let (j, jv) = if model.spherical {
            (link.iq, link.iv)
        } else {
            (nqr + j, nvr + j)
        };
        let [lo, hi] = link.joint.qlim;
        if state.q[j] < lo {
            state.q[j] = lo;
            state.qd[jv] = state.qd[jv].max(0.0);
            any = true;
        } else if state.q[j] > hi {
            state.q[j] = hi;
            state.qd[jv] = state.qd[jv].min(0.0);
            any = true;
        }
    }
    any
}

/// A 64-bit FNV-1a hash of the bit patterns of `t`, `q` and `q̇`: equal hashes for bit-identical
/// states (used to show fixed-step runs are deterministic).
pub fn state_hash(state: &State) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |x: f64| {
        for b in x.to_bits().to_le_bytes() {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
    eat(state.t);
    state.q.iter().for_each(|&x| eat(x));
    state.qd.iter().for_each(|&x| eat(x));
    h
}

/// One output of [`simulate`].
#[derive(Debug, Clone, PartialEq)]
pub struct Sample {
    /// s
    pub t: f64,
    pub q: Vec<f64>,
    pub qd: Vec<f64>,
    /// Total mechanical energy (J), see [`crate::energy`].
    pub energy: f64,
}

/// Simulates from rest time 0 at (q0, q̇0) under constant torques `tau` and returns a sample at
/// each of `outputs` (s; finite, non-negative, non-decreasing). Checks all inputs.
pub fn simulate(
    model: &Model,
    config: IntegratorConfig,
    q0: &[f64],
    qd0: &[f64],
    tau: &[f64],
    outputs: &[f64],
) -> Result<(Vec<Sample>, Stats), DynamicsError> {
    simulate_with_friction(model, config, None, q0, qd0, tau, outputs)
}

/// [`simulate`] with joint friction acting when `friction` is `Some` ([`Stepper::with_friction`]).
pub fn simulate_with_friction(
    model: &Model,
    config: IntegratorConfig,
    friction: Option<JointFriction>,
    q0: &[f64],
    qd0: &[f64],
    tau: &[f64],
    outputs: &[f64],
) -> Result<(Vec<Sample>, Stats), DynamicsError> {
    model.check_q(q0)?;
    model.check_vector("qd0", qd0)?;
    model.check_vector("tau", tau)?;
    let mut prev = 0.0;
    for (i, &t) in outputs.iter().enumerate() {
        if !(t.is_finite() && t >= prev) {
            return Err(DynamicsError::BadOption {
                field: "outputs",
                reason: format!(
                    "outputs[{i}] = {t}: times must be finite, non-negative and non-decreasing"
                ),
            });
        }
        prev = t;
    }
    let mut stepper = Stepper::new(model, config)?;
    if let Some(f) = friction {
        stepper = stepper.with_friction(model, f)?;
    }
    let mut state = State {
        q: DVector::from_column_slice(q0),
        qd: DVector::from_column_slice(qd0),
        qdd: DVector::zeros(model.nv()),
        t: 0.0,
    };
    if config.joint_stops {
        apply_joint_stops(model, &mut state);
    }
    let mut data = Data::new(model);
    let mut samples = Vec::with_capacity(outputs.len());
    for &t in outputs {
        stepper.advance_to(model, &mut state, tau, t)?;
        let e = energy_unchecked(model, &mut data, state.q.as_slice(), state.qd.as_slice());
        samples.push(Sample {
            t: state.t,
            q: state.q.as_slice().to_vec(),
            qd: state.qd.as_slice().to_vec(),
            energy: e.total(),
        });
    }
    Ok((samples, stepper.stats))
}
