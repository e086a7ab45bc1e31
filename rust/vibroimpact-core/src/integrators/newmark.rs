//! The Newmark family with Newton–Raphson on the gap forces (paper eqs. 14–27), written in
//! the α-form of Chung & Hulbert (1993, J. Appl. Mech. 60:371) so that Newmark-β
//! (`α_m = α_f = 0`), HHT-α (`α_m = 0`) and generalized-α share one algorithm:
//!
//! `(1−α_m) M a₁ + α_m M a₀ + (1−α_f)(C v₁ + K x₁ − F₁ − f₁) + α_f (C v₀ + K x₀ − F₀ − f₀) = 0`
//!
//! with the Newmark relations (eqs. 14–15) between `x₁, v₁, a₁`. The unknown is `Δx = x₁ − x₀`;
//! dividing by `(1−α_f)` gives `K̃ Δx = R + f₁(Δx)` with `K̃ = K + c_m a₀ M + a₁ C` (eq. 21),
//! `c_m = (1−α_m)/(1−α_f)`, factorised once per step size.

use nalgebra::DMatrix;

use super::newton::{GapNewton, GapProblem, NewtonSettings, RateMap};
use super::{StepFailure, Stepper, ANY_LEVEL};
use crate::error::{invalid, SimError};
use crate::linalg::{axpy, inverse_permutation, BandedCholesky, StackedRows};
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
///
/// The linear predictor is `Δx_lin = Pₓ x₀ + P_v v₀ + P_a a₀ + Σ_l (g_l(t₁) + c_f g_l(t₀)) L_l
/// − c_f Σ_g φ_g(t₀) G_g` with `c_f = α_f/(1−α_f)`, `L_l = K̃⁻¹ b_l` (load shapes) and
/// `G_g = K̃⁻¹ b_gᵀ` (gap shapes): the factorisation is applied once here, so a step costs
/// three dense mat-vecs and no solve.
struct StepOperator {
    /// Newmark coefficients `a₀ … a₅`.
    a: [f64; 6],
    predictor: Predictor,
    /// `K̃⁻¹ b_gᵀ`, one per gap.
    gaps: Vec<Vec<f64>>,
    /// `W = B K̃⁻¹ Bᵀ`, row-major, gaps × gaps.
    w: Vec<f64>,
}

/// How the linear predictor `Δx_lin` is formed.
enum Predictor {
    /// Small or dense models: `Pₓ`, `P_v`, `P_a` (row-major n×n) and the load shapes
    /// `L_l = K̃⁻¹ b_l`: three dense mat-vecs, no solve.
    Dense {
        p_x: Vec<f64>,
        p_v: Vec<f64>,
        p_a: Vec<f64>,
        loads: Vec<Vec<f64>>,
    },
    /// Large sparse models (beams, imported FE matrices): the right-hand side `R` from
    /// sparse rows in the order of the banded Cholesky factor of `K̃` (reverse
    /// Cuthill–McKee), then one banded solve.
    Banded {
        factor: BandedCholesky,
        rhs: BandedRhs,
        /// Each load's DOFs in the factor's order.
        load_rows: Vec<Vec<usize>>,
    },
}

/// The banded predictor's right-hand side in terms of Newmark's predictors (Hughes 1987,
/// *The Finite Element Method*, §9.1) `x̃ = x₀ + d̃`, `d̃ = h v₀ + h²(½ − β) a₀`,
/// `ṽ = v₀ + (1 − γ) h a₀`: with `x₁ = x̃ + e`, `v₁ = ṽ + a₁ e`, `a₁ = a₀ e` (Newmark's
/// coefficients) the α-form becomes `K̃ e = F₁ + c_f F₀ − R` and `Δx = d̃ + e`, so Newmark-β
/// needs only `K x̃` (and `C ṽ`) where the displacement form needs `M`, `C` and `K` products.
/// (Equilibrium at t₀ could even replace `K x̃` by an `M` product, but then the round-off of
/// `x` accumulates as an unbalanced force: 5e-4 energy drift in 10⁶ steps of a free beam.)
enum BandedRhs {
    /// Newmark-β without damping: `R = K x̃`.
    Stiffness(StackedRows<1>),
    /// Newmark-β: `R = K x̃ + C ṽ`.
    StiffnessDamping(StackedRows<2>),
    /// The α-form: `R = K (x̃ + c_f x₀) + C (ṽ + c_f v₀) + α_m/(1 − α_f) M a₀`.
    Alpha(StackedRows<3>),
}

/// Models with fewer DOFs always use the dense predictor.
const BANDED_MIN_DOFS: usize = 24;

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
        let (m, c, k) = (&st.mass, &st.damping, &st.stiffness);
        let n = sys.n_dof();
        let singular = SimError::SingularTangent { t: 0.0, dt: h };
        // A banded factor when the reordered band is narrow enough to beat 3 n² per step.
        let banded = (n >= BANDED_MIN_DOFS)
            .then(|| {
                let sp = &sys.sparse;
                let (perm, bw) =
                    BandedCholesky::ordering(n, &[&sp.mass, &sp.damping, &sp.stiffness]);
                let cost = sp.mass.nnz() + sp.damping.nnz() + sp.stiffness.nnz() + 2 * n * (bw + 1);
                if cost * 2 > 3 * n * n {
                    return None;
                }
                let terms = [
                    (1.0, &sp.stiffness),
                    (c_m * a[0], &sp.mass),
                    (a[1], &sp.damping),
                ];
                BandedCholesky::factor(&terms, perm, bw)
            })
            .flatten();
        type Solve = Box<dyn FnMut(DMatrix<f64>) -> Result<Vec<f64>, SimError>>;
        let (predictor, mut solve): (Predictor, Solve) = match banded {
            Some(factor) => {
                let f = factor.clone();
                let mut work = vec![0.0; f.work_len()];
                let solve = move |rhs: DMatrix<f64>| -> Result<Vec<f64>, SimError> {
                    let mut col = rhs.column(0).iter().copied().collect::<Vec<_>>();
                    f.solve_in_place(&mut col, &mut work);
                    if col.iter().any(|v| !v.is_finite()) {
                        return Err(SimError::SingularTangent { t: 0.0, dt: h });
                    }
                    Ok(col)
                };
                let sp = &sys.sparse;
                let order = factor.permutation();
                let rhs = if alpha_m != 0.0 || alpha_f != 0.0 {
                    let inertia = alpha_m / (1.0 - alpha_f);
                    BandedRhs::Alpha(StackedRows::new(
                        [
                            &[(1.0, &sp.stiffness)],
                            &[(1.0, &sp.damping)],
                            &[(inertia, &sp.mass)],
                        ],
                        order,
                    ))
                } else if sys.has_damping {
                    let (k, c) = (&[(1.0, &sp.stiffness)], &[(1.0, &sp.damping)]);
                    BandedRhs::StiffnessDamping(StackedRows::new([k, c], order))
                } else {
                    BandedRhs::Stiffness(StackedRows::new([&[(1.0, &sp.stiffness)]], order))
                };
                let inv = inverse_permutation(factor.permutation());
                let load_rows = sys
                    .loads
                    .iter()
                    .map(|l| l.dofs.iter().map(|&d| inv[d]).collect())
                    .collect();
                let predictor = Predictor::Banded {
                    factor,
                    rhs,
                    load_rows,
                };
                (predictor, Box::new(solve))
            }
            _ => {
                let lu = (k + m * (c_m * a[0]) + c * a[1]).lu();
                if !lu.is_invertible() {
                    return Err(singular);
                }
                let solve = move |rhs: DMatrix<f64>| -> Result<Vec<f64>, SimError> {
                    let sol = lu
                        .solve(&rhs)
                        .ok_or(SimError::SingularTangent { t: 0.0, dt: h })?;
                    if sol.iter().any(|v| !v.is_finite()) {
                        return Err(SimError::SingularTangent { t: 0.0, dt: h });
                    }
                    Ok(sol.transpose().as_slice().to_vec()) // row-major
                };
                // The right-hand side's operators divided by 1 − α_f: −K, and those of the
                // old velocity and acceleration from the Newmark relations.
                let scale = -1.0 / (1.0 - alpha_f);
                let (m_v, c_v) = (-(1.0 - alpha_m) * a[2], alpha_f - (1.0 - alpha_f) * a[4]);
                let (m_a, c_a) = (alpha_m - (1.0 - alpha_m) * a[3], -(1.0 - alpha_f) * a[5]);
                let p_x = solve(k * scale)?;
                let p_v = solve((m * m_v + c * c_v) * scale)?;
                let p_a = solve((m * m_a + c * c_a) * scale)?;
                let mut loads = Vec::with_capacity(sys.loads.len());
                for l in &sys.loads {
                    let mut col = DMatrix::zeros(n, 1);
                    for &d in &l.dofs {
                        col[d] += 1.0;
                    }
                    loads.push(solve(col)?);
                }
                (
                    Predictor::Dense {
                        p_x,
                        p_v,
                        p_a,
                        loads,
                    },
                    Box::new(solve),
                )
            }
        };
        let mut gaps = Vec::with_capacity(sys.gaps.len());
        for g in &sys.gaps {
            let mut col = DMatrix::zeros(n, 1);
            for (&d, &c) in g.dofs.iter().zip(&g.coefficients) {
                col[d] += c;
            }
            gaps.push(solve(col)?);
        }
        let w = sys.gap_flexibility(&gaps);
        Ok(Self {
            a,
            predictor,
            gaps,
            w,
        })
    }
}

/// Newmark-family stepper with its per-step-size operators and preallocated work space.
pub struct NewmarkStepper {
    scheme: NewmarkFamily,
    newton: NewtonSettings,
    operators: Vec<Option<StepOperator>>,
    /// Operator of the last step whose size is not `dt / 2^level` ([`ANY_LEVEL`]).
    one_off: Option<(f64, StepOperator)>,
    dx: Vec<f64>,
    /// Work vector of the banded solve (zero padding on both sides).
    padded: Vec<f64>,
    /// `[x̃, ṽ, a₀]` per DOF, the banded predictor's input.
    tilde: Vec<[f64; 3]>,
    du_lin: Vec<f64>,
    rate_lin: Vec<f64>,
    gap_newton: GapNewton,
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
            one_off: None,
            dx: vec![0.0; n],
            padded: Vec::new(),
            tilde: vec![[0.0; 3]; n],
            du_lin: vec![0.0; ng],
            rate_lin: vec![0.0; ng],
            gap_newton: GapNewton::new(ng),
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
        let singular = |_| StepFailure::singular_tangent();
        let op = if level == ANY_LEVEL {
            if self.one_off.as_ref().is_none_or(|(size, _)| *size != h) {
                let op = StepOperator::new(sys, &self.scheme, h).map_err(singular)?;
                self.one_off = Some((h, op));
            }
            &self.one_off.as_ref().expect("built above").1
        } else {
            if self.operators[level].is_none() {
                let op = StepOperator::new(sys, &self.scheme, h).map_err(singular)?;
                self.operators[level] = Some(op);
            }
            self.operators[level].as_ref().expect("built above")
        };
        let NewmarkFamily {
            beta,
            gamma,
            alpha_f,
            ..
        } = self.scheme;
        let [a0, a1, a2, a3, a4, a5] = op.a;
        let n = s0.x.len();
        let ng = sys.gaps.len();
        let c_f = alpha_f / (1.0 - alpha_f);

        // Linear predictor (see StepOperator).
        s1.t = s0.t + h;
        for (g, load) in s1.load.iter_mut().zip(&sys.loads) {
            *g = load.value(s1.t);
        }
        match &op.predictor {
            Predictor::Dense {
                p_x,
                p_v,
                p_a,
                loads,
            } => {
                for i in 0..n {
                    let row = i * n..(i + 1) * n;
                    let (px, pv, pa) = (&p_x[row.clone()], &p_v[row.clone()], &p_a[row]);
                    let mut acc = 0.0;
                    for j in 0..n {
                        acc += px[j] * s0.x[j] + pv[j] * s0.v[j] + pa[j] * s0.a[j];
                    }
                    self.dx[i] = acc;
                }
                for (l, col) in loads.iter().enumerate() {
                    let coef = s1.load[l] + c_f * s0.load[l];
                    if coef != 0.0 {
                        axpy(coef, col, &mut self.dx);
                    }
                }
            }
            Predictor::Banded {
                factor,
                rhs,
                load_rows,
            } => {
                let z = &mut self.padded;
                z.resize(factor.work_len(), 0.0);
                let bw = (z.len() - n) / 2;
                let body = &mut z[bw..bw + n];
                body.fill(0.0);
                // d̃ in dx, and the predictors the right-hand side multiplies
                let (x0, v0, a0) = (&s0.x[..n], &s0.v[..n], &s0.a[..n]);
                let (d_a, v_a) = (h * h * (0.5 - beta), (1.0 - gamma) * h);
                let (d, w) = (&mut self.dx[..n], &mut self.tilde[..n]);
                for i in 0..n {
                    d[i] = h * v0[i] + d_a * a0[i];
                    w[i] = [x0[i] + d[i], v0[i] + v_a * a0[i], a0[i]];
                }
                match rhs {
                    BandedRhs::Stiffness(rows) => rows.add_to(|j| [-w[j][0]], body),
                    BandedRhs::StiffnessDamping(rows) => {
                        rows.add_to(|j| [-w[j][0], -w[j][1]], body)
                    }
                    BandedRhs::Alpha(rows) => rows.add_to(
                        |j| {
                            let [xt, vt, a] = w[j];
                            [-(xt + c_f * x0[j]), -(vt + c_f * v0[j]), -a]
                        },
                        body,
                    ),
                }
                for (l, rows) in load_rows.iter().enumerate() {
                    let value = s1.load[l] + c_f * s0.load[l];
                    for &r in rows {
                        body[r] += value;
                    }
                }
                factor.solve_padded(z);
                for (new, &old) in factor.permutation().iter().enumerate() {
                    self.dx[old] += z[bw + new];
                }
            }
        }
        if c_f != 0.0 {
            for (col, &p) in op.gaps.iter().zip(&s0.phi) {
                if p != 0.0 {
                    axpy(-c_f * p, col, &mut self.dx);
                }
            }
        }
        sys.gap_coordinates(&self.dx, &mut self.du_lin);

        // Newton on the gap coordinates, starting from the previous step's contact forces;
        // the gap rates follow the increment through eq. 17: u̇₁ = a₁ Δu − a₄ u̇₀ − a₅ ü₀.
        let newton = &mut self.gap_newton;
        newton.start_from(&op.w, &self.du_lin, &s0.phi);
        for gi in 0..ng {
            self.rate_lin[gi] = -a4 * s0.u_rate[gi] - a5 * s0.u_accel[gi];
        }
        let problem = GapProblem {
            w: &op.w,
            u0: &s0.u,
            du_lin: &self.du_lin,
            rate_lin: &self.rate_lin,
            rate: RateMap::Diagonal(a1),
            start: &s0.walls,
            h,
        };
        let iterations = newton.solve(sys, &self.newton, &problem, &mut s1.walls, &mut s1.phi)?;

        // Δx = Δx_lin − Σ_g G_g φ_g; then the Newmark relations (eqs. 14, 18) for a₁, v₁.
        for (col, &p) in op.gaps.iter().zip(&s1.phi) {
            if p != 0.0 {
                axpy(-p, col, &mut self.dx);
            }
        }
        for i in 0..n {
            let dx = self.dx[i];
            s1.x[i] = s0.x[i] + dx;
            s1.a[i] = a0 * dx - a2 * s0.v[i] - a3 * s0.a[i];
            s1.v[i] = s0.v[i] + h * ((1.0 - gamma) * s0.a[i] + gamma * s1.a[i]);
        }
        s1.finish_gaps(sys, &self.gap_newton.u);
        Ok(iterations)
    }
}
