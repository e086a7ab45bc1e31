//! The Newmark family with Newton–Raphson on the gap forces (paper eqs. 14–27), written in
//! the α-form of Chung & Hulbert (1993, J. Appl. Mech. 60:371) so that Newmark-β
//! (`α_m = α_f = 0`), HHT-α (`α_m = 0`) and generalized-α share one algorithm:
//!
//! `(1−α_m) M a₁ + α_m M a₀ + (1−α_f)(C v₁ + K x₁ − F₁ − f₁) + α_f (C v₀ + K x₀ − F₀ − f₀) = 0`
//!
//! with the Newmark relations (eqs. 14–15) between `x₁, v₁, a₁`. The unknown is `Δx = x₁ − x₀`;
//! dividing by `(1−α_f)` gives `K̃ Δx = R + f₁(Δx)` with `K̃ = K + c_m a₀ M + a₁ C` (eq. 21),
//! `c_m = (1−α_m)/(1−α_f)`, factorised once per step size.

use nalgebra::{DMatrix, DVector, LU};

use super::newton::{solve_small, NewtonSettings};
use super::{StepFailure, Stepper};
use crate::error::{invalid, SimError};
use crate::structure::external_force;
use crate::system::{State, System};

/// Parameters of a Newmark-family scheme.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewmarkFamily {
    /// Newmark `β`.
    pub beta: f64,
    /// Newmark `γ`.
    pub gamma: f64,
    /// Weight of the old acceleration in the inertia term, `α_m`.
    pub alpha_m: f64,
    /// Weight of the old state in the force terms, `α_f`.
    pub alpha_f: f64,
}

impl NewmarkFamily {
    /// Newmark-β with the given `γ, β` (paper eqs. 14–15; `γ = 1/2, β = 1/4` is the
    /// unconditionally stable average-acceleration rule).
    pub fn newmark(gamma: f64, beta: f64) -> Result<Self, SimError> {
        let s = Self {
            beta,
            gamma,
            alpha_m: 0.0,
            alpha_f: 0.0,
        };
        s.validate()?;
        Ok(s)
    }

    /// Average acceleration (trapezoidal rule): second order, no numerical dissipation.
    pub fn average_acceleration() -> Self {
        Self {
            beta: 0.25,
            gamma: 0.5,
            alpha_m: 0.0,
            alpha_f: 0.0,
        }
    }

    pub fn validate(&self) -> Result<(), SimError> {
        if !(self.gamma.is_finite() && self.gamma >= 0.5) {
            return invalid(format!(
                "solver.gamma: {} is not valid; expected gamma >= 0.5 (paper eq. 16)",
                self.gamma
            ));
        }
        if !(self.beta.is_finite() && self.beta > 0.0) {
            return invalid(format!(
                "solver.beta: {} is not valid; expected beta > 0 (an implicit scheme)",
                self.beta
            ));
        }
        if !(self.alpha_f >= 0.0 && self.alpha_f < 1.0 && self.alpha_m < 1.0) {
            return invalid(format!(
                "solver: alpha_m = {}, alpha_f = {} are not valid; expected alpha_m < 1 and 0 <= alpha_f < 1",
                self.alpha_m, self.alpha_f
            ));
        }
        Ok(())
    }
}

/// What a step of one size needs, computed once per size (never per step).
struct StepOperator {
    /// Newmark coefficients `a₀ … a₅`.
    a: [f64; 6],
    lu: LU<f64, nalgebra::Dyn, nalgebra::Dyn>,
    /// Columns `K̃⁻¹ b_gᵀ`, one per gap.
    g: Vec<DVector<f64>>,
    /// `W = B K̃⁻¹ Bᵀ`, row-major, gaps × gaps.
    w: Vec<f64>,
}

impl StepOperator {
    fn new(sys: &System, scheme: &NewmarkFamily, h: f64) -> Result<Self, SimError> {
        let NewmarkFamily {
            beta,
            gamma,
            alpha_m,
            alpha_f,
        } = *scheme;
        let a = [
            1.0 / (beta * h * h),
            gamma / (beta * h),
            1.0 / (beta * h),
            0.5 / beta - 1.0,
            gamma / beta - 1.0,
            h * (0.5 * gamma / beta - 1.0),
        ];
        let c_m = (1.0 - alpha_m) / (1.0 - alpha_f);
        let st = &sys.structure;
        let k_eff: DMatrix<f64> = &st.stiffness + &st.mass * (c_m * a[0]) + &st.damping * a[1];
        let lu = k_eff.lu();
        if !lu.is_invertible() {
            return Err(SimError::SingularTangent { dt: h });
        }
        let n = sys.n_dof();
        let ng = sys.gaps.len();
        let mut g = Vec::with_capacity(ng);
        for gap in &sys.gaps {
            let mut col = DVector::zeros(n);
            for (&d, &c) in gap.dofs.iter().zip(&gap.coefficients) {
                col[d] += c;
            }
            if !lu.solve_mut(&mut col) {
                return Err(SimError::SingularTangent { dt: h });
            }
            g.push(col);
        }
        let mut w = vec![0.0; ng * ng];
        let mut row = vec![0.0; ng];
        for (h_idx, col) in g.iter().enumerate() {
            sys.gap_coordinates(col, &mut row);
            for (gi, &v) in row.iter().enumerate() {
                w[gi * ng + h_idx] = v;
            }
        }
        Ok(Self { a, lu, g, w })
    }
}

/// Newmark-family stepper with its per-step-size operators and preallocated work space.
pub struct NewmarkStepper {
    scheme: NewmarkFamily,
    newton: NewtonSettings,
    operators: Vec<Option<StepOperator>>,
    rhs: DVector<f64>,
    tmp: DVector<f64>,
    du_lin: Vec<f64>,
    du: Vec<f64>,
    u1: Vec<f64>,
    u1_rate: Vec<f64>,
    residual: Vec<f64>,
    d_phi_du: Vec<f64>,
    d_phi_drate: Vec<f64>,
    stiffness: Vec<f64>,
    jacobian: Vec<f64>,
    step: Vec<f64>,
    active: Vec<usize>,
}

impl NewmarkStepper {
    pub fn new(
        sys: &System,
        scheme: NewmarkFamily,
        newton: NewtonSettings,
    ) -> Result<Self, SimError> {
        scheme.validate()?;
        let n = sys.n_dof();
        let ng = sys.gaps.len();
        Ok(Self {
            scheme,
            newton,
            operators: (0..=newton.max_step_cuts).map(|_| None).collect(),
            rhs: DVector::zeros(n),
            tmp: DVector::zeros(n),
            du_lin: vec![0.0; ng],
            du: vec![0.0; ng],
            u1: vec![0.0; ng],
            u1_rate: vec![0.0; ng],
            residual: vec![0.0; ng],
            d_phi_du: vec![0.0; ng],
            d_phi_drate: vec![0.0; ng],
            stiffness: vec![0.0; ng],
            jacobian: vec![0.0; ng * ng],
            step: vec![0.0; ng],
            active: Vec::with_capacity(ng),
        })
    }

    /// Builds the operator of the largest step now, so that a singular tangent is reported
    /// before the run starts.
    pub fn prepare(&mut self, sys: &System, h: f64) -> Result<(), SimError> {
        self.operators[0] = Some(StepOperator::new(sys, &self.scheme, h)?);
        Ok(())
    }
}

impl Stepper for NewmarkStepper {
    fn attempt(
        &mut self,
        sys: &System,
        s0: &State,
        level: usize,
        h: f64,
        s1: &mut State,
    ) -> Result<usize, StepFailure> {
        if self.operators[level].is_none() {
            let op = StepOperator::new(sys, &self.scheme, h).map_err(|_| StepFailure {
                gap: 0,
                penetration: 0.0,
                iterations: 0,
            })?;
            self.operators[level] = Some(op);
        }
        let op = self.operators[level].as_ref().expect("built above");
        let NewmarkFamily {
            gamma,
            alpha_m,
            alpha_f,
            ..
        } = self.scheme;
        let [a0, a1, a2, a3, a4, a5] = op.a;
        let st = &sys.structure;
        let ng = sys.gaps.len();

        // Known part of the right-hand side: R = F₁ + [α_f (F₀ + f₀) − K x₀ − M m − C c]/(1−α_f).
        s1.t = s0.t + h;
        external_force(&sys.loads, s1.t, &mut s1.f_ext);
        let scale = 1.0 / (1.0 - alpha_f);
        // tmp = m = α_m a₀ − (1−α_m)(a₂ v₀ + a₃ a₀)
        self.tmp.copy_from(&s0.a);
        self.tmp.axpy(-(1.0 - alpha_m) * a2, &s0.v, alpha_m - (1.0 - alpha_m) * a3);
        self.rhs.copy_from(&s1.f_ext);
        self.rhs.gemv(-scale, &st.mass, &self.tmp, 1.0);
        self.rhs.gemv(-scale, &st.stiffness, &s0.x, 1.0);
        if sys.has_damping {
            // tmp = c = α_f v₀ − (1−α_f)(a₄ v₀ + a₅ a₀)
            self.tmp.copy_from(&s0.v);
            self.tmp.axpy(
                -(1.0 - alpha_f) * a5,
                &s0.a,
                alpha_f - (1.0 - alpha_f) * a4,
            );
            self.rhs.gemv(-scale, &st.damping, &self.tmp, 1.0);
        }
        if alpha_f != 0.0 {
            self.rhs.axpy(alpha_f * scale, &s0.f_ext, 1.0);
            sys.add_contact_force_scaled(&s0.phi, alpha_f * scale, &mut self.rhs);
        }
        // Linear predictor: Δx_lin = K̃⁻¹ R.
        op.lu.solve_mut(&mut self.rhs);
        sys.gap_coordinates(&self.rhs, &mut self.du_lin);

        // Newton on the gap coordinates, starting from the previous step's contact forces.
        for gi in 0..ng {
            let mut wphi = 0.0;
            for hi in 0..ng {
                wphi += op.w[gi * ng + hi] * s0.phi[hi];
            }
            self.du[gi] = self.du_lin[gi] - wphi;
        }
        let mut iterations = 0;
        let mut increment_small = false;
        loop {
            for gi in 0..ng {
                self.u1[gi] = s0.u[gi] + self.du[gi];
                self.u1_rate[gi] = a1 * self.du[gi] - a4 * s0.u_rate[gi] - a5 * s0.u_accel[gi];
            }
            sys.evaluate_contacts(
                &s0.walls,
                &self.u1,
                &self.u1_rate,
                h,
                &mut s1.walls,
                &mut s1.phi,
                &mut self.d_phi_du,
                &mut self.d_phi_drate,
            );
            let mut residual_small = true;
            let mut worst = (0usize, 0.0f64);
            self.active.clear();
            for gi in 0..ng {
                let mut wphi = 0.0;
                for hi in 0..ng {
                    wphi += op.w[gi * ng + hi] * s1.phi[hi];
                }
                let r = self.du[gi] - self.du_lin[gi] + wphi;
                self.residual[gi] = r;
                self.stiffness[gi] = self.d_phi_du[gi] + a1 * self.d_phi_drate[gi];
                let tol = self.newton.rtol * self.u1[gi].abs() + self.newton.atol;
                if r.abs() > tol {
                    residual_small = false;
                }
                if r.abs() / tol > worst.1 {
                    worst = (gi, r.abs() / tol);
                }
                if r != 0.0 || self.stiffness[gi] != 0.0 {
                    self.active.push(gi);
                }
            }
            if residual_small && (iterations == 0 || increment_small) {
                break;
            }
            if iterations >= self.newton.max_iterations {
                let gi = worst.0;
                let penetration = sys
                    .walls
                    .iter()
                    .zip(s1.walls.iter())
                    .filter(|(w, _)| w.gap == gi)
                    .map(|(_, s)| s.penetration)
                    .fold(f64::NEG_INFINITY, f64::max);
                return Err(StepFailure {
                    gap: gi,
                    penetration,
                    iterations,
                });
            }
            // Solve (I + W_AA K_A) d_A = −r_A; inactive gaps follow: d_N = −W_NA K_A d_A.
            let m = self.active.len();
            for (ia, &gi) in self.active.iter().enumerate() {
                for (ib, &hi) in self.active.iter().enumerate() {
                    self.jacobian[ia * m + ib] = op.w[gi * ng + hi] * self.stiffness[hi]
                        + if ia == ib { 1.0 } else { 0.0 };
                }
                self.step[ia] = -self.residual[gi];
            }
            if !solve_small(&mut self.jacobian[..m * m], &mut self.step[..m], m) {
                return Err(StepFailure {
                    gap: worst.0,
                    penetration: 0.0,
                    iterations,
                });
            }
            iterations += 1;
            increment_small = true;
            for gi in 0..ng {
                let d = match self.active.iter().position(|&a| a == gi) {
                    Some(ia) => self.step[ia],
                    None => -self
                        .active
                        .iter()
                        .enumerate()
                        .map(|(ia, &hi)| op.w[gi * ng + hi] * self.stiffness[hi] * self.step[ia])
                        .sum::<f64>(),
                };
                self.du[gi] += d;
                let tol = self.newton.rtol * (s0.u[gi] + self.du[gi]).abs() + self.newton.atol;
                if d.abs() > tol {
                    increment_small = false;
                }
            }
        }

        // Δx = Δx_lin − Σ_g K̃⁻¹ b_gᵀ φ_g; then the Newmark relations for a₁, v₁.
        let dx = &mut self.rhs;
        for (col, &p) in op.g.iter().zip(&s1.phi) {
            if p != 0.0 {
                dx.axpy(-p, col, 1.0);
            }
        }
        s1.x.copy_from(&s0.x);
        s1.x += &*dx;
        // a₁ = a₀' Δx − a₂ v₀ − a₃ a₀
        s1.a.copy_from(&s0.a);
        s1.a.axpy(-a2, &s0.v, -a3);
        s1.a.axpy(a0, dx, 1.0);
        // v₁ = v₀ + h[(1−γ) a₀ + γ a₁]
        s1.v.copy_from(&s0.v);
        s1.v.axpy(h * (1.0 - gamma), &s0.a, 1.0);
        s1.v.axpy(h * gamma, &s1.a, 1.0);
        s1.u.copy_from_slice(&self.u1);
        s1.u_rate.copy_from_slice(&self.u1_rate);
        sys.gap_coordinates(&s1.a, &mut s1.u_accel);
        Ok(iterations)
    }
}

