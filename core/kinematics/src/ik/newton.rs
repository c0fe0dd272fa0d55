//! Newton–Raphson with LU solves: the seed's default method (§2.5). From `q0` (the "current
//! joint angles"; zeros if absent) it solves `J Δq = e` for the pose error `e` by LU
//! decomposition — not by inverting J, the seed's speed-up — and iterates until the per-axis
//! tolerances hold. One start, no damping, no limits: it shares the seed's weaknesses (it can
//! stall at singularities and finds one solution), which the report measures.
//!
//! Square systems (6 constrained axes, 6 joints) use J directly; otherwise the LU solve is of
//! the normal equations (J Jᵀ for redundant arms: the minimum-norm step; Jᵀ J for
//! under-actuated tasks). Axes with an infinite tolerance are dropped from the system.
//!
//! Entry point: [`Newton`].

use super::{IkError, IkOptions, IkResult, IkSolver, Method, finish};
use crate::data::Data;
use crate::kinematic_model::KinematicModel;
use crate::model::Robot;
use crate::pose::{pose_error, rotation, to_target_frame};
use nalgebra::{DMatrix, DVector, Matrix4};

/// The Newton–Raphson solver.
#[derive(Debug, Clone, Copy, Default)]
pub struct Newton;

impl IkSolver for Newton {
    fn method(&self) -> Method {
        Method::Newton
    }

    fn solve(
        &self,
        robot: &Robot,
        target: &Matrix4<f64>,
        options: &IkOptions,
    ) -> Result<IkResult, IkError> {
        let n = robot.dof();
        if n == 0 {
            return Err(IkError::NotApplicable {
                method: "newton",
                reason: "the robot has no joints".into(),
            });
        }
        let tol = options.tolerances.as_array();
        let rows: Vec<usize> = (0..6).filter(|&i| tol[i].is_finite()).collect();
        let m = rows.len();
        let rt = rotation(target).transpose();
        let mut q = options.q0.clone().unwrap_or_else(|| vec![0.0; n]);
        let mut iterations = 0;
        let mut converged = false;
        // frames and Jacobian computed into one buffer for the whole solve; the m × n system
        // is rebuilt in place (its LU factorisation still takes its own copy)
        let mut data = Data::new(robot);
        let model = KinematicModel::new(robot);
        let mut jm = DMatrix::zeros(m, n);
        while iterations < options.max_iterations {
            let (t, jac) = data.fk_and_jacobian_compiled(&model, &q);
            let e = to_target_frame(&pose_error(t, target), target);
            if options.tolerances.accept(&e) {
                converged = true;
                break;
            }
            iterations += 1;
            // Jacobian in target-frame axes, constrained rows only.
            for c in 0..n {
                let v = rt * jac.fixed_view::<3, 1>(0, c);
                let w = rt * jac.fixed_view::<3, 1>(3, c);
                for (r, &i) in rows.iter().enumerate() {
                    jm[(r, c)] = if i < 3 { v[i] } else { w[i - 3] };
                }
            }
            let em = DVector::from_iterator(m, rows.iter().map(|&i| e[i]));
            let dq = if m == n {
                jm.clone().lu().solve(&em)
            } else if n > m {
                (&jm * jm.transpose())
                    .lu()
                    .solve(&em)
                    .map(|y| jm.transpose() * y)
            } else {
                (jm.transpose() * &jm).lu().solve(&(jm.transpose() * em))
            };
            let Some(dq) = dq else { break }; // singular J: the seed's method stops here
            for (qj, d) in q.iter_mut().zip(dq.iter()) {
                *qj += d;
            }
            if !q.iter().all(|v| v.is_finite()) {
                break;
            }
        }
        if !q.iter().all(|v| v.is_finite()) {
            q = options.q0.clone().unwrap_or_else(|| vec![0.0; n]);
        }
        let mut sol = finish(
            robot,
            &model,
            target,
            options,
            q,
            None,
            iterations,
            Vec::new(),
        );
        // `finish` judges by the tolerances too; a stalled run is reported as such.
        sol.converged = converged && sol.converged;
        if !sol.converged {
            return Err(IkError::NotConverged {
                method: "newton",
                starts: 1,
                best: Box::new(sol),
            });
        }
        Ok(IkResult {
            method: Method::Newton,
            solutions: vec![sol],
        })
    }
}
