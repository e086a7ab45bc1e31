//! Bathe's composite scheme (Bathe & Baig 2005, Comput. Struct. 83:2513; Bathe 2007, Comput.
//! Struct. 85:437): each step `Δt` is a trapezoidal-rule sub-step to `t + γΔt` followed by
//! the three-point Euler backward formula on `t, t + γΔt, t + Δt`:
//!
//! `v₁ = c₁ x₀ + c₂ x_γ + c₃ x₁`, `a₁ = c₁ v₀ + c₂ v_γ + c₃ v₁`, with
//! `c₁ = (1−γ)/(γΔt)`, `c₂ = −1/((1−γ)γΔt)`, `c₃ = (2−γ)/((1−γ)Δt)` (`1/Δt, −4/Δt, 3/Δt` for
//! `γ = 1/2`).
//!
//! Second order, unconditionally stable, and strongly dissipative at high frequency (spectral
//! radius → 0 as `ωΔt → ∞` for `γ = 1/2`) while nearly undamped at the resolved frequencies:
//! what structural users reach for when a stiff contact excites spurious high modes.
//! `γ = 2 − √2` makes both sub-steps' effective stiffness equal.
//!
//! The trapezoidal sub-step is the average-acceleration Newmark stepper on `γΔt`; the backward
//! sub-step factorises `K̃ = K + c₃ C + c₃² M` once per step size and, like Newmark, solves
//! Newton on the gap coordinates only, with `u̇₁ = c₂ (u_γ − u₀) + c₃ Δu` (since
//! `c₁ + c₂ + c₃ = 0`).

use nalgebra::DMatrix;

use super::newmark::{NewmarkFamily, NewmarkStepper};
use super::newton::{GapNewton, GapProblem, NewtonSettings, RateMap};
use super::{OperatorCache, StepFailure, Stepper};
use crate::error::SimError;
use crate::gap::WallState;
use crate::linalg::axpy;
use crate::system::{Inline, State, System};

/// Parameters of Bathe's composite scheme.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bathe {
    /// Fraction `γ` of the step taken by the trapezoidal sub-step, `0 < γ < 1`.
    pub gamma: f64,
}

impl Bathe {
    /// `c₁, c₂, c₃` of the three-point backward formula for a step `h`.
    fn coefficients(&self, h: f64) -> [f64; 3] {
        let g = self.gamma;
        [
            (1.0 - g) / (g * h),
            -1.0 / ((1.0 - g) * g * h),
            (2.0 - g) / ((1.0 - g) * h),
        ]
    }
}

/// The backward sub-step for one step size:
/// `Δx_lin = Qₓ x₀ + Q_d (x_γ − x₀) + P_m (c₁ v₀ + c₂ v_γ) + Σ_l g_l(t₁) K̃⁻¹ b_l`, with
/// `Qₓ = −K̃⁻¹K`, `Q_d = −c₂ K̃⁻¹(C + c₃ M)`, `P_m = −K̃⁻¹M`; and the gap shapes `K̃⁻¹ b_gᵀ`,
/// `W = B K̃⁻¹ Bᵀ`.
struct BackwardOperator {
    c: [f64; 3],
    q_x: Vec<f64>,
    q_d: Vec<f64>,
    p_m: Vec<f64>,
    loads: Vec<Vec<f64>>,
    gaps: Vec<Vec<f64>>,
    w: Vec<f64>,
}

impl BackwardOperator {
    fn new(sys: &System, scheme: &Bathe, h: f64) -> Result<Self, SimError> {
        let c = scheme.coefficients(h);
        let st = sys.structure.dense("bathe")?;
        let (m, cd, k) = (&st.mass, &st.damping, &st.stiffness);
        let lu = (k + cd * c[2] + m * (c[2] * c[2])).lu();
        if !lu.is_invertible() {
            return Err(SimError::SingularTangent { t: 0.0, dt: h });
        }
        let solve = |rhs: DMatrix<f64>| -> Result<DMatrix<f64>, SimError> {
            let sol = lu
                .solve(&rhs)
                .ok_or(SimError::SingularTangent { t: 0.0, dt: h })?;
            if sol.iter().any(|v| !v.is_finite()) {
                return Err(SimError::SingularTangent { t: 0.0, dt: h });
            }
            Ok(sol)
        };
        let row_major = |a: DMatrix<f64>| a.transpose().as_slice().to_vec();
        let q_x = row_major(solve(-k)?);
        let q_d = row_major(solve((cd + m * c[2]) * (-c[1]))?);
        let p_m = row_major(solve(-m)?);
        let n = sys.n_dof();
        let shape = |entries: &mut dyn Iterator<Item = (usize, f64)>| {
            let mut col = DMatrix::zeros(n, 1);
            for (d, v) in entries {
                col[d] += v;
            }
            solve(col).map(|s| s.as_slice().to_vec())
        };
        let loads = sys
            .loads
            .iter()
            .map(|l| shape(&mut l.dofs.iter().map(|&d| (d, 1.0))))
            .collect::<Result<Vec<_>, _>>()?;
        let gaps = sys
            .gaps
            .iter()
            .map(|g| shape(&mut g.dofs.iter().copied().zip(g.coefficients.iter().copied())))
            .collect::<Result<Vec<_>, _>>()?;
        let w = sys.gap_flexibility(&gaps);
        Ok(Self {
            c,
            q_x,
            q_d,
            p_m,
            loads,
            gaps,
            w,
        })
    }
}

/// Bathe stepper: the trapezoidal sub-step (a Newmark stepper), the backward sub-step's
/// per-size operators, and work space.
pub struct BatheStepper {
    scheme: Bathe,
    newton: NewtonSettings,
    trapezoidal: NewmarkStepper,
    operators: OperatorCache<BackwardOperator>,
    /// State at `t + γΔt`.
    mid: State,
    dx: Vec<f64>,
    dx_mid: Vec<f64>,
    v_comb: Vec<f64>,
    du_lin: Vec<f64>,
    rate_lin: Vec<f64>,
    gap_newton: GapNewton,
}

impl BatheStepper {
    pub fn new(sys: &System, scheme: Bathe, newton: NewtonSettings) -> Result<Self, SimError> {
        scheme.validate()?;
        let n = sys.n_dof();
        let ng = sys.gaps.len();
        let zeros = |k: usize| vec![0.0; k];
        Ok(Self {
            scheme,
            newton,
            trapezoidal: NewmarkStepper::new(sys, NewmarkFamily::average_acceleration(), newton)?,
            operators: OperatorCache::new(newton.max_step_cuts),
            mid: State {
                t: 0.0,
                x: Inline::new(n, 0.0),
                v: Inline::new(n, 0.0),
                a: Inline::new(n, 0.0),
                load: zeros(sys.loads.len()),
                phi: zeros(ng),
                u: zeros(ng),
                u_rate: zeros(ng),
                u_accel: zeros(ng),
                walls: vec![WallState::default(); sys.walls.len()],
            },
            dx: zeros(n),
            dx_mid: zeros(n),
            v_comb: zeros(n),
            du_lin: zeros(ng),
            rate_lin: zeros(ng),
            gap_newton: GapNewton::new(ng),
        })
    }

    /// Builds both sub-steps' operators of the largest step now, so that a singular tangent
    /// is reported before the run starts.
    pub fn prepare(&mut self, sys: &System, h: f64) -> Result<(), SimError> {
        self.trapezoidal.prepare(sys, self.scheme.gamma * h)?;
        let op = BackwardOperator::new(sys, &self.scheme, h)?;
        self.operators.set_largest(op);
        Ok(())
    }
}

impl Stepper for BatheStepper {
    fn attempt(
        &mut self,
        sys: &System,
        s0: &State,
        level: usize,
        h: f64,
        s1: &mut State,
    ) -> Result<usize, StepFailure> {
        let gamma = self.scheme.gamma;
        // Sub-step 1: trapezoidal rule to t + γh.
        let mut iterations = self
            .trapezoidal
            .attempt(sys, s0, level, gamma * h, &mut self.mid)?;

        // Sub-step 2: three-point backward formula to t + h.
        let scheme = &self.scheme;
        self.operators
            .ensure(level, h, || BackwardOperator::new(sys, scheme, h))
            .map_err(|_| StepFailure {
                iterations,
                ..StepFailure::singular_tangent()
            })?;
        let op = self.operators.get(level);
        let [c1, c2, c3] = op.c;
        let mid = &self.mid;
        let n = s0.x.len();
        let ng = sys.gaps.len();

        s1.t = s0.t + h;
        for (g, load) in s1.load.iter_mut().zip(&sys.loads) {
            *g = load.value(s1.t);
        }
        for i in 0..n {
            self.dx_mid[i] = mid.x[i] - s0.x[i];
            self.v_comb[i] = c1 * s0.v[i] + c2 * mid.v[i];
        }
        for i in 0..n {
            let row = i * n..(i + 1) * n;
            let (qx, qd, pm) = (&op.q_x[row.clone()], &op.q_d[row.clone()], &op.p_m[row]);
            let mut acc = 0.0;
            for j in 0..n {
                acc += qx[j] * s0.x[j] + qd[j] * self.dx_mid[j] + pm[j] * self.v_comb[j];
            }
            self.dx[i] = acc;
        }
        for (l, col) in op.loads.iter().enumerate() {
            let g = s1.load[l];
            if g != 0.0 {
                axpy(g, col, &mut self.dx);
            }
        }
        sys.gap_coordinates(&self.dx, &mut self.du_lin);

        // Newton on the gap coordinates from the mid-step contact forces; the crossing and
        // v_imp of a wall closing in this sub-step are located between t + γh and t + h.
        let newton = &mut self.gap_newton;
        newton.start_from(&op.w, &self.du_lin, &mid.phi);
        for gi in 0..ng {
            self.rate_lin[gi] = c2 * (mid.u[gi] - s0.u[gi]);
        }
        let problem = GapProblem {
            w: &op.w,
            u0: &s0.u,
            du_lin: &self.du_lin,
            rate_lin: &self.rate_lin,
            rate: RateMap::Diagonal(c3),
            start: &mid.walls,
            h: (1.0 - gamma) * h,
        };
        iterations += newton
            .solve(sys, &self.newton, &problem, &mut s1.walls, &mut s1.phi)
            .map_err(|f| StepFailure {
                iterations: f.iterations + iterations,
                ..f
            })?;

        for (col, &p) in op.gaps.iter().zip(&s1.phi) {
            if p != 0.0 {
                axpy(-p, col, &mut self.dx);
            }
        }
        for i in 0..n {
            let dx = self.dx[i];
            s1.x[i] = s0.x[i] + dx;
            s1.v[i] = c2 * self.dx_mid[i] + c3 * dx;
            s1.a[i] = self.v_comb[i] + c3 * s1.v[i];
        }
        s1.finish_gaps(sys, &self.gap_newton.u);
        Ok(iterations)
    }
}
