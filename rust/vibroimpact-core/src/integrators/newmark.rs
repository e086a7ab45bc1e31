//! The Newmark family with Newton–Raphson on the gap forces (paper eqs. 14–27), written in
//! the α-form of Chung & Hulbert (1993, J. Appl. Mech. 60:371) so that Newmark-β
//! (`α_m = α_f = 0`), HHT-α (`α_m = 0`) and generalized-α share one algorithm:
//!
//! `(1−α_m) M a₁ + α_m M a₀ + (1−α_f)(C v₁ + K x₁ − F₁ − f₁) + α_f (C v₀ + K x₀ − F₀ − f₀) = 0`
//!
//! with the Newmark relations (eqs. 14–15) between `x₁, v₁, a₁`. The unknown is `Δx = x₁ − x₀`;
//! dividing by `(1−α_f)` gives `K̃ Δx = R + f₁(Δx)` with `K̃ = K + c_m a₀ M + a₁ C` (eq. 21),
//! `c_m = (1−α_m)/(1−α_f)`, factorised once per step size.

use std::sync::OnceLock;

use faer::dyn_stack::{MemBuffer, MemStack};
use nalgebra::DMatrix;

use super::free_run::{local_motion, FreeWalls, FREE_RUN_LOADS, FREE_RUN_WALLS};
use super::newton::{GapNewton, GapProblem, NewtonSettings, OneGap, RateMap};
use super::sized::{by_size, dofs, sized_step_path, Inline, MAX_SIZED};
use super::{OperatorCache, StepFailure, Stepper};
use crate::driver::{load_work, FreeRunEnd, Run};
use crate::error::{invalid, SimError};
use crate::factor::{FactorChoice, FactorInfo, FactorPlan, SpdFactor};
use crate::gap::Gap;
use crate::linalg::{axpy, inverse_permutation, DenseMatVec, StackedRows};
use crate::step_control::grid_time;
use crate::structure::MAX_DENSE_DOFS;
use crate::system::{finite_motion, State, System};

/// The schemes the tests run: Newmark-β (average acceleration), HHT-α (`α_f = 0.1`) and
/// generalized-α (`α_m`, `α_f` ≠ 0).
#[cfg(test)]
pub(crate) const TEST_SCHEMES: [NewmarkFamily; 3] = [
    NewmarkFamily {
        beta: 0.25,
        gamma: 0.5,
        alpha_m: 0.0,
        alpha_f: 0.0,
    },
    NewmarkFamily {
        beta: 0.3025,
        gamma: 0.6,
        alpha_m: 0.0,
        alpha_f: 0.1,
    },
    NewmarkFamily {
        beta: 0.3086,
        gamma: 0.6111,
        alpha_m: 0.3333,
        alpha_f: 0.4444,
    },
];

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
}

/// An acceleration below this (in the model's length unit per s²) is set to 0 at the end of
/// each step. With `α_m ≠ 0` and no spring on a DOF, generalized-α's free-flight acceleration
/// decays geometrically (`a₁ = −α_m/(1−α_m) a₀` for a free mass) and then lingers in the
/// subnormal range (below 2.2e-308), where each product costs up to a hundred cycles: on the
/// paper's SDOF case 7,209 of 20,000 steps did, doubling the run's time (benchmarks/per-step.md).
/// At 1e-280 the products with `h²` and the operators stay normal for any step above 1e-13 s,
/// and no displacement or velocity moves by a bit.
const NEGLIGIBLE_ACCELERATION: f64 = 1e-280;

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
    /// The linear solver chosen, and its size.
    info: FactorInfo,
}

/// How the linear predictor `Δx_lin` is formed, from Newmark's predictors (see
/// [`SparseRhs`]): `Δx_lin = d̃ + K̃⁻¹ (F₁ + c_f F₀ − R)`.
enum Predictor {
    /// Small or dense models (at most [`MAX_DENSE_DOFS`] DOFs): `K̃⁻¹` applied once per step size to the operators of `R`
    /// (`K`, and `C`, `M` where the scheme needs them; row-major n×n) and to the load
    /// vectors (`L_l = K̃⁻¹ b_l`): one to three dense mat-vecs, no solve.
    Dense {
        operators: Vec<Vec<f64>>,
        loads: Vec<Vec<f64>>,
    },
    /// Large sparse models (beams, imported FE matrices, 3-D solids): the right-hand side
    /// `R` from sparse rows in the order of the Cholesky factor of `K̃` (banded or general
    /// sparse, see [`FactorPlan`]), then one forward and backward substitution.
    Sparse {
        factor: SpdFactor,
        rhs: SparseRhs,
        /// Each load's DOFs in the factor's order.
        load_rows: Vec<Vec<usize>>,
    },
}

/// The predictor's right-hand side in terms of Newmark's predictors (Hughes 1987,
/// *The Finite Element Method*, §9.1) `x̃ = x₀ + d̃`, `d̃ = h v₀ + h²(½ − β) a₀`,
/// `ṽ = v₀ + (1 − γ) h a₀`: with `x₁ = x̃ + e`, `v₁ = ṽ + a₁ e`, `a₁ = a₀ e` (Newmark's
/// coefficients) the α-form becomes `K̃ e = F₁ + c_f F₀ − R` and `Δx = d̃ + e`, so Newmark-β
/// needs only `K x̃` (and `C ṽ`) where the displacement form needs `M`, `C` and `K` products.
/// (Equilibrium at t₀ could even replace `K x̃` by an `M` product, but then the round-off of
/// `x` accumulates as an unbalanced force: 5e-4 energy drift in 10⁶ steps of a free beam.)
enum SparseRhs {
    /// Newmark-β without damping: `R = K x̃`.
    Stiffness(StackedRows<1>),
    /// Newmark-β: `R = K x̃ + C ṽ`.
    StiffnessDamping(StackedRows<2>),
    /// The α-form: `R = K (x̃ + c_f x₀) + C (ṽ + c_f v₀) + α_m/(1 − α_f) M a₀`.
    Alpha(StackedRows<3>),
}

/// Models with fewer DOFs always use the dense predictor.
const SPARSE_MIN_DOFS: usize = 24;

/// Dense operators up to this size are read from a core's cache (L2) at the speed of its
/// vector lanes; larger ones stream at about one value a cycle (measured: the 1,140-DOF C3D20
/// cantilever of `vibroimpact bench`, 10 MB of `K̃⁻¹K`, 0.44 ms a step, ~1.3 values/ns).
const DENSE_CACHE_BYTES: usize = 2 << 20;

/// Which predictor a stepper builds.
#[derive(Debug, Clone, Copy, PartialEq)]
enum PredictorChoice {
    /// The one with the smaller estimated cost per step.
    Cheapest,
    /// Always dense (tests).
    #[cfg(test)]
    Dense,
    /// Banded whenever the effective stiffness is positive definite (tests).
    #[cfg(test)]
    Banded,
    /// The general sparse factor whenever the effective stiffness is positive definite
    /// (tests).
    #[cfg(test)]
    Sparse,
}

impl PredictorChoice {
    /// The factor a sparse predictor uses, if it may use one.
    fn factor_choice(self, n: usize) -> Option<FactorChoice> {
        match self {
            PredictorChoice::Cheapest => (n >= SPARSE_MIN_DOFS).then_some(FactorChoice::Cheapest),
            #[cfg(test)]
            PredictorChoice::Dense => None,
            #[cfg(test)]
            PredictorChoice::Banded => Some(FactorChoice::Banded),
            #[cfg(test)]
            PredictorChoice::Sparse => Some(FactorChoice::Sparse),
        }
    }
}

impl StepOperator {
    /// `plan`: how `K̃` is factorised (`None`: the dense predictor only); `choice`: whether
    /// the dense predictor is taken where it is estimated to be faster, over `steps` steps
    /// (`None`: unknown, per step only).
    fn new(
        sys: &System,
        scheme: &NewmarkFamily,
        h: f64,
        plan: Option<&FactorPlan>,
        choice: PredictorChoice,
        dense_lanes: usize,
        steps: Option<usize>,
    ) -> Result<Self, SimError> {
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
        let n = sys.n_dof();
        let singular = SimError::SingularTangent { t: 0.0, dt: h };
        // The operators of the right-hand side R (see SparseRhs): K, C, M.
        let alpha_form = alpha_m != 0.0 || alpha_f != 0.0;
        let uses = [true, alpha_form || sys.has_damping, alpha_form];
        let n_operators = uses.iter().filter(|used| **used).count();
        let sparse = plan.and_then(|plan| {
            // Rough cycles per step: the dense predictor streams n² values per operator,
            // `dense_lanes` per instruction while they stay in a core's cache, about one a
            // cycle beyond (DENSE_CACHE_BYTES); the sparse one multiplies the sparse rows
            // and substitutes forward and back (FactorPlan::solve_cost).
            let nnz = [&st.stiffness, &st.damping, &st.mass]
                .iter()
                .zip(uses)
                .filter(|(_, used)| *used)
                .map(|(a, _)| a.nnz())
                .sum::<usize>();
            let dense_values = n_operators * n * n;
            let dense_cost = if dense_values * 8 <= DENSE_CACHE_BYTES {
                dense_values / (2 * dense_lanes)
            } else {
                dense_values
            };
            let sparse_cost = nnz + plan.solve_cost();
            // The setups, amortised over the run's steps where they are known: the dense LU
            // of K̃ (n³/3 multiply-adds) and its solves for the n columns of each operator
            // (n³ each), against one sparse factorisation (FactorPlan::factor_cost); about a
            // cycle a multiply-add both.
            let (dense_total, sparse_total) = match steps {
                Some(steps) => (
                    (dense_cost as f64) * steps as f64
                        + (n as f64).powi(3) * (1.0 / 3.0 + n_operators as f64),
                    (sparse_cost as f64) * steps as f64 + plan.factor_cost() as f64,
                ),
                None => (dense_cost as f64, sparse_cost as f64),
            };
            let dense_allowed = n <= MAX_DENSE_DOFS;
            if choice == PredictorChoice::Cheapest && dense_allowed && sparse_total >= dense_total {
                return None;
            }
            let terms = [
                (1.0, &st.stiffness),
                (c_m * a[0], &st.mass),
                (a[1], &st.damping),
            ];
            plan.factor(&terms)
        });
        type Solve = Box<dyn FnMut(DMatrix<f64>) -> Result<Vec<f64>, SimError>>;
        let (predictor, mut solve, info): (Predictor, Solve, FactorInfo) = match sparse {
            Some(factor) => {
                let f = factor.clone();
                let solve = move |rhs: DMatrix<f64>| -> Result<Vec<f64>, SimError> {
                    let mut col = rhs.column(0).iter().copied().collect::<Vec<_>>();
                    f.solve_in_place(&mut col);
                    if col.iter().any(|v| !v.is_finite()) {
                        return Err(SimError::SingularTangent { t: 0.0, dt: h });
                    }
                    Ok(col)
                };
                let order = factor.permutation();
                let rhs = if alpha_form {
                    let inertia = alpha_m / (1.0 - alpha_f);
                    SparseRhs::Alpha(StackedRows::new(
                        [
                            &[(1.0, &st.stiffness)],
                            &[(1.0, &st.damping)],
                            &[(inertia, &st.mass)],
                        ],
                        order,
                    ))
                } else if sys.has_damping {
                    let (k, c) = (&[(1.0, &st.stiffness)], &[(1.0, &st.damping)]);
                    SparseRhs::StiffnessDamping(StackedRows::new([k, c], order))
                } else {
                    SparseRhs::Stiffness(StackedRows::new([&[(1.0, &st.stiffness)]], order))
                };
                let inv = inverse_permutation(factor.permutation());
                let load_rows = sys
                    .loads
                    .iter()
                    .map(|l| l.dofs.iter().map(|&d| inv[d]).collect())
                    .collect();
                let info = factor.describe();
                let predictor = Predictor::Sparse {
                    factor,
                    rhs,
                    load_rows,
                };
                (predictor, Box::new(solve), info)
            }
            // A large model never densifies: its K̃ is not symmetric (gyroscopic forces, which
            // the Cholesky factors cannot take), or not positive definite.
            None if n > MAX_DENSE_DOFS && !st.damping_is_symmetric() => {
                return invalid(format!(
                    "structure.gyroscopic: {n} DOFs spinning make K̃ unsymmetric, which the \
                     sparse Cholesky factor cannot take, and the dense LU takes at most \
                     {MAX_DENSE_DOFS}; reduce the model (vibroimpact.fe.reduction)"
                ))
            }
            None if n > MAX_DENSE_DOFS => return Err(singular),
            None => {
                let dense = st.dense("newmark (dense predictor)")?;
                let (m, c, k) = (&dense.mass, &dense.damping, &dense.stiffness);
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
                let mut operators = vec![solve(k.clone())?];
                if uses[1] {
                    operators.push(solve(c.clone())?);
                }
                if uses[2] {
                    operators.push(solve(m * (alpha_m / (1.0 - alpha_f)))?);
                }
                let mut loads = Vec::with_capacity(sys.loads.len());
                for l in &sys.loads {
                    let mut col = DMatrix::zeros(n, 1);
                    for &d in &l.dofs {
                        col[d] += 1.0;
                    }
                    loads.push(solve(col)?);
                }
                let info = FactorInfo {
                    solver: "dense",
                    dofs: n,
                    bandwidth: None,
                    stored_values: (n_operators + loads.len()) * n * n,
                };
                (Predictor::Dense { operators, loads }, Box::new(solve), info)
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
            info,
        })
    }
}

/// `y −= A x` for an `N × N` row-major `A` (the dense predictor of a model of `N` DOFs), with
/// the sums of [`DenseMatVec::apply`] below four rows, in the same order.
#[inline(always)]
fn mat_vec_sub_sized<const N: usize>(a: &[f64], x: &[f64], y: &mut [f64]) {
    let (a, x, y) = (&a[..N * N], &x[..N], &mut y[..N]);
    for (yi, row) in y.iter_mut().zip(a.chunks_exact(N)) {
        *yi -= row.iter().zip(x).map(|(r, x)| r * x).sum::<f64>();
    }
}

/// `d −= Σ_k A_k y_k`: the dense predictor's operators applied to the vectors `inputs` they
/// multiply (`x̃ + c_f x₀`, `ṽ + c_f v₀`, `a₀`), at a small model's size `N` below four.
#[inline(always)]
fn dense_correction<const N: usize, O: AsRef<[f64]>>(
    mat_vec: &DenseMatVec,
    operators: &[O],
    inputs: [&[f64]; 3],
    d: &mut [f64],
) {
    for (operator, input) in operators.iter().zip(inputs) {
        let operator = operator.as_ref();
        if N > 0 && N < 4 {
            mat_vec_sub_sized::<N>(operator, input, d);
        } else {
            mat_vec.apply(operator, input, d);
        }
    }
}

/// The linear increment `e + d̃` of the gap coordinate of the unit gap on DOF `d`.
#[inline(always)]
fn unit_increment(d: usize, e: &[f64], d_tilde: &[f64]) -> f64 {
    e[d] + d_tilde[d]
}

/// The linear increment of `gap`'s coordinate: its combination of `e` plus that of `d̃` (as
/// `System::gap_coordinates` of each, in one pass).
#[inline(always)]
fn gap_increment(gap: &Gap, e: &[f64], d_tilde: &[f64]) -> f64 {
    let (mut de, mut dp) = (-0.0, -0.0); // as `Iterator::sum`
    for (&d, &c) in gap.dofs.iter().zip(&gap.coefficients) {
        de += c * e[d];
        dp += c * d_tilde[d];
    }
    de + dp
}

/// The scheme's formulas at one DOF for a step of `h`, the one home of the arithmetic of both
/// the general step ([`NewmarkStepper::step`]) and the free run ([`NewmarkStepper::free_run`]):
/// the same operations in the same order in both.
#[derive(Clone, Copy)]
struct StepFormulas {
    h: f64,
    /// `h²(½ − β)`, `(1 − γ) h`, `c_f`.
    d_a: f64,
    v_a: f64,
    c_f: f64,
    /// Newmark's `a₀ = 1/(β h²)`, `γ`, `1 − γ`.
    a0: f64,
    gamma: f64,
    one_minus_gamma: f64,
}

impl StepFormulas {
    #[inline(always)]
    fn new(constants: &SchemeConstants, gamma: f64, a0: f64, h: f64) -> Self {
        Self {
            h,
            d_a: h * h * constants.half_minus_beta,
            v_a: constants.one_minus_gamma * h,
            c_f: constants.c_f,
            a0,
            gamma,
            one_minus_gamma: constants.one_minus_gamma,
        }
    }

    /// Newmark's displacement predictor `d̃ = h v₀ + h²(½ − β) a₀` and the vectors the
    /// predictor's operators multiply, `x̃ + c_f x₀` and `ṽ + c_f v₀`.
    #[inline(always)]
    fn predictors(&self, x: f64, v: f64, a: f64) -> [f64; 3] {
        let d_tilde = self.h * v + self.d_a * a;
        [
            d_tilde,
            x + d_tilde + self.c_f * x,
            v + self.v_a * a + self.c_f * v,
        ]
    }

    /// The Newmark relations (eqs. 14, 18) in predictor form from the correction `e`:
    /// `x₁ = x₀ + d̃ + e`, `a₁ = a₀ e` (the same as `a₀ Δx − a₂ v₀ − a₃ a₀` without its
    /// cancellation of large terms; below [`NEGLIGIBLE_ACCELERATION`] set to 0), `v₁` from
    /// `a₁`. Returns `[x₁, v₁, a₁]`.
    #[inline(always)]
    fn relations(&self, x0: f64, v0: f64, a0: f64, d_tilde: f64, e: f64) -> [f64; 3] {
        let x1 = x0 + (d_tilde + e);
        let a = self.a0 * e;
        let a1 = if a.abs() < NEGLIGIBLE_ACCELERATION {
            0.0
        } else {
            a
        };
        [
            x1,
            v0 + self.h * (self.one_minus_gamma * a0 + self.gamma * a1),
            a1,
        ]
    }
}

/// The scheme's constants a step uses, computed once per run (the same expressions the step
/// evaluated each time: the same values; `c_f` was a division per step).
#[derive(Debug, Clone, Copy)]
struct SchemeConstants {
    /// `½ − β`, `1 − γ`.
    half_minus_beta: f64,
    one_minus_gamma: f64,
    /// `c_f = α_f/(1−α_f)`, the weight of the start of the step's loads and contact forces.
    c_f: f64,
}

impl SchemeConstants {
    fn new(scheme: &NewmarkFamily) -> Self {
        Self {
            half_minus_beta: 0.5 - scheme.beta,
            one_minus_gamma: 1.0 - scheme.gamma,
            c_f: scheme.alpha_f / (1.0 - scheme.alpha_f),
        }
    }
}

/// Newmark-family stepper with its per-step-size operators and preallocated work space.
pub struct NewmarkStepper {
    scheme: NewmarkFamily,
    constants: SchemeConstants,
    newton: NewtonSettings,
    operators: OperatorCache<StepOperator>,
    /// The step's vectors over the DOFs are [`Inline`]: a model of up to four DOFs keeps them
    /// at constant places in the stepper, read at its size without a length check.
    dx: Inline<f64>,
    /// How `K̃` is factorised (`None`: dense predictor only), decided on the first operator.
    plan: OnceLock<Option<FactorPlan>>,
    /// Work vector of the sparse solve (the banded factor's zero padding on both sides).
    padded: Vec<f64>,
    /// Scratch memory of the sparse solve.
    scratch: MemBuffer,
    /// `x̃ + c_f x₀` and `ṽ + c_f v₀`, the inputs of the predictor's right-hand side.
    tilde: [Inline<f64>; 2],
    /// Newmark's displacement predictor `d̃ = h v₀ + h²(½ − β) a₀`.
    d_tilde: Inline<f64>,
    /// `y −= A x` for the dense predictor (SIMD where the CPU has it).
    mat_vec: DenseMatVec,
    choice: PredictorChoice,
    /// The run's steps, over which the predictor's setup is amortised (`None`: unknown).
    steps: Option<usize>,
    du_lin: Vec<f64>,
    rate_lin: Vec<f64>,
    gap_newton: GapNewton,
    /// The last step was in free flight ([`Stepper::last_step_free`]).
    free: bool,
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
            constants: SchemeConstants::new(&scheme),
            newton,
            operators: OperatorCache::new(newton.max_step_cuts),
            dx: Inline::new(n, 0.0),
            plan: OnceLock::new(),
            padded: Vec::new(),
            scratch: MemBuffer::new(faer::dyn_stack::StackReq::EMPTY),
            tilde: [Inline::new(n, 0.0), Inline::new(n, 0.0)],
            d_tilde: Inline::new(n, 0.0),
            mat_vec: DenseMatVec::fastest(),
            choice: PredictorChoice::Cheapest,
            steps: None,
            du_lin: vec![0.0; ng],
            rate_lin: vec![0.0; ng],
            gap_newton: GapNewton::new(ng),
            free: false,
        })
    }

    /// The run takes about `steps` steps: the predictor is chosen by its setup plus that
    /// many steps (before [`Self::prepare`]).
    pub fn expect_steps(&mut self, steps: usize) {
        self.steps = Some(steps);
    }

    /// Builds the operator of the largest step now, so that a singular tangent is reported
    /// before the run starts.
    pub fn prepare(&mut self, sys: &System, h: f64) -> Result<(), SimError> {
        let op = self.operator(sys, h)?;
        self.operators.set_largest(op);
        Ok(())
    }

    fn operator(&self, sys: &System, h: f64) -> Result<StepOperator, SimError> {
        build_operator(
            sys,
            &self.scheme,
            h,
            &self.plan,
            self.choice,
            self.mat_vec.lanes,
            self.steps,
        )
    }
}

/// The floor of a step's cost, for the benchmarks: the operator of steps of `h` built as a
/// run of `steps` steps builds it, then `solves` bare solves with it timed (the forward and backward
/// substitution with the sparse factor, in its order; one mat-vec with the dense
/// predictor). Returns the linear solver and the seconds per solve.
pub fn substitution_time(
    sys: &System,
    scheme: NewmarkFamily,
    h: f64,
    steps: usize,
    solves: usize,
) -> Result<(FactorInfo, f64), SimError> {
    let mut stepper = NewmarkStepper::new(sys, scheme, NewtonSettings::default())?;
    stepper.expect_steps(steps);
    let op = stepper.operator(sys, h)?;
    let n = sys.n_dof();
    let rhs: Vec<f64> = (0..n).map(|i| (i as f64).sin()).collect();
    let started = std::time::Instant::now();
    match &op.predictor {
        Predictor::Sparse { factor, .. } => {
            let mut z = vec![0.0; factor.work_len()];
            let mut scratch = MemBuffer::new(factor.scratch());
            for _ in 0..solves {
                z[factor.offset()..factor.offset() + n].copy_from_slice(&rhs);
                factor.solve_permuted(&mut z, MemStack::new(&mut scratch));
            }
            std::hint::black_box(&z);
        }
        Predictor::Dense { operators, .. } => {
            let mut d = vec![0.0; n];
            for _ in 0..solves {
                (stepper.mat_vec.sub)(&operators[0], &rhs, &mut d);
            }
            std::hint::black_box(&d);
        }
    }
    Ok((
        op.info,
        started.elapsed().as_secs_f64() / solves.max(1) as f64,
    ))
}

/// The operator of steps of `h`, the factor plan made on first use.
fn build_operator(
    sys: &System,
    scheme: &NewmarkFamily,
    h: f64,
    plan: &OnceLock<Option<FactorPlan>>,
    choice: PredictorChoice,
    dense_lanes: usize,
    steps: Option<usize>,
) -> Result<StepOperator, SimError> {
    let plan = plan.get_or_init(|| {
        let st = &sys.structure;
        // the Cholesky factors need a symmetric K̃: gyroscopic forces take the dense LU
        choice
            .factor_choice(sys.n_dof())
            .filter(|_| st.damping_is_symmetric())
            .map(|c| FactorPlan::new(&[&st.mass, &st.damping, &st.stiffness], c))
    });
    StepOperator::new(sys, scheme, h, plan.as_ref(), choice, dense_lanes, steps)
}

impl Stepper for NewmarkStepper {
    /// Models of up to four DOFs take a step compiled for their size ([`Self::step`] with
    /// `N = n`): the same arithmetic in the same order, the loops over the DOFs unrolled and
    /// their bounds checks resolved at compile time.
    fn attempt(
        &mut self,
        sys: &System,
        s0: &State,
        level: usize,
        h: f64,
        s1: &mut State,
    ) -> Result<usize, StepFailure> {
        by_size!(s0.x.len(), |N| self.step::<N>(sys, s0, level, h, s1))
    }

    fn linear_solver(&self) -> Option<FactorInfo> {
        self.operators.largest().map(|op| op.info)
    }

    /// A step that `GapNewton::free_flight` found free (no radial gap: that test covers the
    /// 1-D walls only through the predictor, and a radial wall's slide is checked at commit),
    /// its motion finite.
    #[inline(always)]
    fn last_step_free(&self) -> bool {
        self.free
    }

    /// The step [`Self::attempt`] dispatches to.
    fn step_path(&self, sys: &System) -> &'static str {
        sized_step_path(sys.n_dof())
    }
}

/// The stepper of a model of `N` DOFs ([`by_size`], 0: any) for the fixed-step loop, which is
/// compiled per size with it: its step is called without the dispatch on the size.
pub(crate) struct SizedNewmark<'a, const N: usize>(pub &'a mut NewmarkStepper);

impl<const N: usize> Stepper for SizedNewmark<'_, N> {
    #[inline(always)]
    fn attempt(
        &mut self,
        sys: &System,
        s0: &State,
        level: usize,
        h: f64,
        s1: &mut State,
    ) -> Result<usize, StepFailure> {
        debug_assert_eq!(dofs::<N>(s0.x.len()), s0.x.len());
        self.0.attempt_sized::<N>(sys, s0, level, h, s1)
    }

    fn linear_solver(&self) -> Option<FactorInfo> {
        self.0.linear_solver()
    }

    #[inline(always)]
    fn last_step_free(&self) -> bool {
        self.0.free
    }

    fn step_path(&self, sys: &System) -> &'static str {
        self.0.step_path(sys)
    }

    /// [`NewmarkStepper::free_run`] for a model of one to four DOFs (none for the others),
    /// compiled with rows and without.
    fn free_run(
        &mut self,
        sys: &System,
        run: &mut Run,
        h: f64,
        step: usize,
        max: usize,
        rows: bool,
    ) -> Option<usize> {
        match (N > 0, rows) {
            (false, _) => None,
            (true, true) => self.0.free_run::<N, true>(sys, run, h, step, max),
            (true, false) => self.0.free_run::<N, false>(sys, run, h, step, max),
        }
    }
}

impl NewmarkStepper {
    /// [`Self::step`] out of line (as `attempt`): the stepper an argument, not a pointer
    /// loaded from the wrapper, so that LLVM knows that its vectors do not overlap the
    /// states' (inlined into the wrapper, the 2-DOF rotor's step lost its paired operations:
    /// +1.6 % on its run; in line in the time loop, the SDOF cases +28 instructions a step).
    #[inline(never)]
    fn attempt_sized<const N: usize>(
        &mut self,
        sys: &System,
        s0: &State,
        level: usize,
        h: f64,
        s1: &mut State,
    ) -> Result<usize, StepFailure> {
        self.step::<N>(sys, s0, level, h, s1)
    }

    /// One attempt of a step of `h` from `s0` into `s1` ([`Stepper::attempt`]); `N`: the
    /// model's DOFs when it has at most four (known at compile time), 0 otherwise.
    #[inline(always)]
    fn step<const N: usize>(
        &mut self,
        sys: &System,
        s0: &State,
        level: usize,
        h: f64,
        s1: &mut State,
    ) -> Result<usize, StepFailure> {
        let build = || {
            build_operator(
                sys,
                &self.scheme,
                h,
                &self.plan,
                self.choice,
                self.mat_vec.lanes,
                self.steps,
            )
        };
        let op = self
            .operators
            .ensure(level, h, build)
            .map_err(|_| StepFailure::singular_tangent())?;
        let gamma = self.scheme.gamma;
        let c_f = self.constants.c_f;
        let a0 = op.a[0];
        let n = dofs::<N>(s0.x.len());

        // Linear predictor (see StepOperator).
        s1.t = s0.t + h;
        for (g, load) in s1.load.iter_mut().zip(&sys.loads) {
            *g = load.value(s1.t);
        }
        // d̃, and the vectors `R`'s operators multiply: x̃ + c_f x₀, ṽ + c_f v₀, a₀; the
        // correction e = Δx − d̃ accumulates in dx
        // (at constant places for a small model; `[..n]`: one length for the general one)
        let (x_old, v_old, a_old) = (s0.x.sized::<N>(), s0.v.sized::<N>(), s0.a.sized::<N>());
        let (x_old, v_old, a_old) = (&x_old[..n], &v_old[..n], &a_old[..n]);
        let f = StepFormulas::new(&self.constants, gamma, a0, h);
        let [xt, vt] = &mut self.tilde;
        let (d_tilde, d, xt, vt) = (
            self.d_tilde.sized_mut::<N>(),
            self.dx.sized_mut::<N>(),
            xt.sized_mut::<N>(),
            vt.sized_mut::<N>(),
        );
        for i in 0..n {
            [d_tilde[i], xt[i], vt[i]] = f.predictors(x_old[i], v_old[i], a_old[i]);
            d[i] = 0.0;
        }
        let inputs: [&[f64]; 3] = [xt, vt, a_old];
        match &op.predictor {
            Predictor::Dense { operators, loads } => {
                dense_correction::<N, _>(&self.mat_vec, operators, inputs, d);
                for (l, col) in loads.iter().enumerate() {
                    let coef = s1.load[l] + c_f * s0.load[l];
                    if coef != 0.0 {
                        axpy(coef, &col[..n], d);
                    }
                }
            }
            Predictor::Sparse {
                factor,
                rhs,
                load_rows,
            } => {
                let z = &mut self.padded;
                z.resize(factor.work_len(), 0.0);
                let off = factor.offset();
                let body = &mut z[off..off + n];
                body.fill(0.0);
                match rhs {
                    SparseRhs::Stiffness(rows) => rows.add_to(|j| [-xt[j]], body),
                    SparseRhs::StiffnessDamping(rows) => rows.add_to(|j| [-xt[j], -vt[j]], body),
                    SparseRhs::Alpha(rows) => rows.add_to(|j| [-xt[j], -vt[j], -a_old[j]], body),
                }
                for (l, rows) in load_rows.iter().enumerate() {
                    let value = s1.load[l] + c_f * s0.load[l];
                    for &r in rows {
                        body[r] += value;
                    }
                }
                let scratch = factor.scratch();
                if !MemStack::new(&mut self.scratch).can_hold(scratch) {
                    self.scratch = MemBuffer::new(scratch);
                }
                factor.solve_permuted(z, MemStack::new(&mut self.scratch));
                for (new, &old) in factor.permutation().iter().enumerate() {
                    d[old] = z[off + new];
                }
            }
        }
        if c_f != 0.0 {
            for (col, &p) in op.gaps.iter().zip(&s0.phi) {
                if p != 0.0 {
                    axpy(-c_f * p, &col[..n], self.dx.sized_mut::<N>());
                }
            }
        }
        // The gap coordinates of e and of d̃ (as System::gap_coordinates, in one pass), and
        // the linear predictor's gap coordinates u₀ + Δu_lin (Newton's first iterate).
        let (dx, d_tilde) = (self.dx.sized::<N>(), self.d_tilde.sized::<N>());
        let newton = &mut self.gap_newton;
        let gaps = self.du_lin.iter_mut().zip(&mut newton.u).zip(&s0.u);
        if let Some(dofs) = &sys.unit_dofs {
            for (((du, u), &u0), &d) in gaps.zip(dofs) {
                *du = unit_increment(d, dx, d_tilde);
                *u = u0 + *du;
            }
        } else {
            for (((du, u), &u0), gap) in gaps.zip(&sys.gaps) {
                *du = gap_increment(gap, dx, d_tilde);
                *u = u0 + *du;
            }
        }

        // Free flight (no wall closed at either end: the linear step is the step, with no
        // contact force) needs no Newton, no contact terms and no wall evaluated; otherwise
        // Newton (Self::contact_correction).
        let free = newton.free_flight(sys, &s0.walls);
        let iterations = if free {
            0
        } else {
            self.contact_correction::<N>(sys, s0, level, h, s1)?
        };

        // The Newmark relations (StepFormulas::relations).
        let dx = self.dx.sized::<N>();
        let (x0, v0, a0_old) = (s0.x.sized::<N>(), s0.v.sized::<N>(), s0.a.sized::<N>());
        let (x0, v0, a0_old) = (&x0[..n], &v0[..n], &a0_old[..n]);
        let (x1, v1, a1_new) = (
            &mut s1.x.sized_mut::<N>()[..n],
            &mut s1.v.sized_mut::<N>()[..n],
            &mut s1.a.sized_mut::<N>()[..n],
        );
        let d_tilde = self.d_tilde.sized::<N>();
        for i in 0..n {
            [x1[i], v1[i], a1_new[i]] = f.relations(x0[i], v0[i], a0_old[i], d_tilde[i], dx[i]);
        }
        self.free = if free {
            s1.finish_free_flight::<N>(sys, &self.gap_newton.u) && !sys.has_radial
        } else {
            s1.finish_gaps(sys, &self.gap_newton.u);
            false
        };
        Ok(iterations)
    }

    /// Up to `max` steps of `h` of the fixed grid from its step `step` in free flight
    /// ([`Stepper::free_run`]), each committed and, with `ROWS`, recorded: the general step's
    /// arithmetic ([`StepFormulas`], [`dense_correction`], the loads' columns) with the motion
    /// of the model's `N` DOFs, the operators, the walls and the gap coordinates in local
    /// arrays and nothing else, while what the general step would do besides is nothing (the
    /// driver's conditions, `Run::drive`): the dense predictor, no contact force at the start
    /// (so no `φ` term), every wall open; the loads (their values at the general step's
    /// `s₀.t + h` and their work, [`load_work`]) only without rows. Ends, before taking it,
    /// at the first step whose linear predictor closes a wall or whose motion is not finite:
    /// the general step then takes it as before. Returns the steps taken; `None`: never any
    /// for this model (loads with rows, more than [`FREE_RUN_LOADS`] loads, the sparse
    /// predictor, more than [`FREE_RUN_WALLS`] walls).
    #[inline(never)]
    fn free_run<const N: usize, const ROWS: bool>(
        &mut self,
        sys: &System,
        run: &mut Run,
        h: f64,
        step: usize,
        max: usize,
    ) -> Option<usize> {
        let op = self.operators.largest()?;
        let Predictor::Dense { operators, loads } = &op.predictor else {
            return None;
        };
        let nl = loads.len();
        if (ROWS && nl > 0) || nl > FREE_RUN_LOADS || operators.len() > 3 {
            return None;
        }
        let walls = FreeWalls::new(sys)?;
        // Everything a step reads, in locals: the rows' writes cannot alias them, so they
        // are not reloaded from the stepper and the model every step.
        let f = StepFormulas::new(&self.constants, self.scheme.gamma, op.a[0], h);
        let mut ops = [[0.0; MAX_SIZED * MAX_SIZED]; 3];
        for (local, operator) in ops.iter_mut().zip(operators) {
            local[..N * N].copy_from_slice(&operator[..N * N]);
        }
        let ops = &ops[..operators.len()];
        let mut columns = [[0.0; N]; FREE_RUN_LOADS];
        for (local, column) in columns.iter_mut().zip(loads) {
            local.copy_from_slice(&column[..N]);
        }
        let columns = &columns[..nl];
        let cur = &*run.cur;
        let [mut x, mut v, mut a] = local_motion::<N>(cur);
        // the loads' values at the step's start and the external work so far
        let mut load = [0.0; FREE_RUN_LOADS];
        load[..nl].copy_from_slice(&cur.load);
        let mut work = run.account.external_work();
        let ng = sys.gaps.len();
        let mut u = [0.0; FREE_RUN_WALLS];
        u[..ng].copy_from_slice(&cur.u);
        let mut rows = if ROWS {
            run.out.free_rows::<N>(&run.account)
        } else {
            run.out.no_free_rows::<N>()
        };
        // (the gap coordinates' increments and the walls' penetrations of a step: only the
        // first `ng` and walls are read, so they are not cleared per step)
        let (mut du, mut depth) = ([0.0; FREE_RUN_WALLS], [0.0; FREE_RUN_WALLS]);
        let mut taken = 0;
        while taken < max {
            let (mut d_tilde, mut xt, mut vt, mut e) = ([0.0; N], [0.0; N], [0.0; N], [0.0; N]);
            for i in 0..N {
                [d_tilde[i], xt[i], vt[i]] = f.predictors(x[i], v[i], a[i]);
            }
            dense_correction::<N, _>(&self.mat_vec, ops, [&xt, &vt, &a], &mut e);
            // the loads at the step's end as the general step has it, and their columns
            let mut load1 = [0.0; FREE_RUN_LOADS];
            if !ROWS {
                let t1 = grid_time(step + taken, h) + h;
                for (value, l) in load1.iter_mut().zip(&sys.loads) {
                    *value = l.value(t1);
                }
                for ((column, &f1), &f0) in columns.iter().zip(&load1).zip(&load) {
                    let coef = f1 + f.c_f * f0;
                    if coef != 0.0 {
                        axpy(coef, column, &mut e);
                    }
                }
            }
            // the gap coordinates' increments, and the walls' penetrations at the end (as the
            // general step's Newton's first iterate): any wall closing ends the run
            if let Some(unit) = &walls.unit_dofs {
                for (du, &d) in du[..ng].iter_mut().zip(unit) {
                    *du = unit_increment(d, &e, &d_tilde);
                }
            } else {
                for (du, gap) in du[..ng].iter_mut().zip(&sys.gaps) {
                    *du = gap_increment(gap, &e, &d_tilde);
                }
            }
            if walls.closing(|g| u[g] + du[g], &mut depth) {
                break;
            }
            let (mut x1, mut v1, mut a1) = ([0.0; N], [0.0; N], [0.0; N]);
            for i in 0..N {
                [x1[i], v1[i], a1[i]] = f.relations(x[i], v[i], a[i], d_tilde[i], e[i]);
            }
            if !(0..N).all(|i| finite_motion(x1[i], v1[i])) {
                break;
            }
            if !ROWS {
                for ((l, &f0), &f1) in sys.loads.iter().zip(&load).zip(&load1) {
                    work += load_work(&l.dofs, [f0, f1], &x, &x1);
                }
                load = load1;
            }
            (x, v, a) = (x1, v1, a1);
            for (u, du) in u[..ng].iter_mut().zip(&du) {
                *u += du;
            }
            taken += 1;
            if ROWS {
                rows.write(
                    grid_time(step + taken, h),
                    [&x, &v, &a],
                    walls.walls(),
                    &depth,
                );
            }
        }
        if taken > 0 {
            let end = FreeRunEnd {
                taken,
                t: grid_time(step + taken, h),
                step_end: grid_time(step + taken - 1, h) + h,
                motion: [&x, &v, &a],
                u: &u[..ng],
                loads: (!ROWS && nl > 0).then_some((&load[..nl], work)),
            };
            run.end_free_run(sys, rows, end);
        }
        Some(taken)
    }

    /// The contact step's part of [`Self::step`] (some wall closed at an end of the step):
    /// Newton on the gap coordinates, starting from the previous step's contact forces, with
    /// the gap rates that follow the increment through eq. 17 (u̇₁ = a₁ Δu − a₄ u̇₀ − a₅ ü₀),
    /// then the correction `e = e_lin − Σ_g G_g φ_g`. Out of line, so that a free-flight step
    /// does not carry Newton's registers and stack frame.
    #[inline(never)]
    fn contact_correction<const N: usize>(
        &mut self,
        sys: &System,
        s0: &State,
        level: usize,
        h: f64,
        s1: &mut State,
    ) -> Result<usize, StepFailure> {
        let op = self.operators.get(level);
        let [_, a1, _, _, a4, a5] = op.a;
        let n = dofs::<N>(s0.x.len());
        // u̇_lin = −a₄ u̇₀ − a₅ ü₀
        let rate_lin = |r0: f64, acc0: f64| -a4 * r0 - a5 * acc0;
        let one = (&op.w[..], &s0.u[..], &self.du_lin[..]);
        let start = (&s0.u_rate[..], &s0.u_accel[..], &s0.phi[..]);
        if let (([w], [u0], [du_lin]), ([r0], [acc0], [phi0]), [phi], false) =
            (one, start, s1.phi.as_mut_slice(), sys.has_radial)
        {
            // one 1-D gap coordinate: its numbers by value, without the general path's work
            // vectors and slices; the first iterate Δu_lin − W φ₀ (as `GapNewton::start_from`)
            let g = OneGap {
                w: *w,
                u0: *u0,
                du_lin: *du_lin,
                rate_lin: rate_lin(*r0, *acc0),
                c_v: a1,
                start: &s0.walls,
                h,
            };
            let du = g.du_lin - g.w * *phi0;
            let newton = &mut self.gap_newton;
            let iterations = newton.solve_one(sys, &self.newton, &g, du, &mut s1.walls, phi)?;
            if *phi != 0.0 {
                axpy(-*phi, &op.gaps[0][..n], self.dx.sized_mut::<N>());
            }
            return Ok(iterations);
        }
        let gap_rates = s0.u_rate.iter().zip(&s0.u_accel);
        for (rate, (r0, acc0)) in self.rate_lin.iter_mut().zip(gap_rates) {
            *rate = rate_lin(*r0, *acc0);
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
        let newton = &mut self.gap_newton;
        newton.start_from(&op.w, &self.du_lin, &s0.phi);
        let iterations = newton.solve(sys, &self.newton, &problem, &mut s1.walls, &mut s1.phi)?;
        let dx = self.dx.sized_mut::<N>();
        for (col, &p) in op.gaps.iter().zip(&s1.phi) {
            if p != 0.0 {
                axpy(-p, &col[..n], dx);
            }
        }
        Ok(iterations)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use nalgebra::{DMatrix, DVector};

    use super::*;
    use crate::contact::{Hertz, Law};
    use crate::gap::{Gap, Side};
    use crate::linalg::Csr;
    use crate::structure::{LinearStructure, Load, LoadHistory};

    /// A damped 30-DOF chain in scrambled DOF order with two gaps (one relative) and a
    /// harmonic load.
    fn chain() -> System {
        let n = 30;
        let order: Vec<usize> = (0..n).map(|i| (i * 7) % n).collect();
        let (mut m, mut k) = (DMatrix::zeros(n, n), DMatrix::zeros(n, n));
        for i in 0..n {
            m[(order[i], order[i])] = 1.0 + 0.02 * i as f64;
            k[(order[i], order[i])] += 1e5;
            if i + 1 < n {
                let (p, q) = (order[i], order[i + 1]);
                k[(p, p)] += 2e5;
                k[(q, q)] += 2e5;
                k[(p, q)] -= 2e5;
                k[(q, p)] -= 2e5;
            }
        }
        let c = &m * 3.0 + &k * 1e-5;
        let s = LinearStructure::new(m, c, k).unwrap();
        let law = || Law::Hertz(Hertz::new(1e9, 1.5).unwrap());
        let gaps = vec![
            Gap {
                dofs: vec![order[5]],
                coefficients: vec![1.0],
                clearance: 1e-4,
                side: Side::Both,
                law: law(),
            },
            Gap {
                dofs: vec![order[20], order[21]],
                coefficients: vec![1.0, -1.0],
                clearance: 2e-5,
                side: Side::Both,
                law: law(),
            },
        ];
        let load = Load {
            dofs: vec![order[0], order[29]],
            amplitude: 50.0,
            history: LoadHistory::Harmonic {
                frequency: 40.0,
                phase: 0.3,
            },
        };
        System::new(s, gaps, vec![load]).unwrap()
    }

    fn run(sys: &System, scheme: NewmarkFamily, choice: PredictorChoice) -> (State, usize) {
        let n = sys.n_dof();
        let mut stepper = NewmarkStepper::new(sys, scheme, NewtonSettings::default()).unwrap();
        stepper.choice = choice;
        let v0 = DVector::from_fn(n, |i, _| 0.05 * (i as f64).sin());
        let mut cur = State::initial(sys, DVector::zeros(n), v0, 0.0).unwrap();
        let mut next = cur.clone();
        let (h, mut contacts) = (2e-6, 0);
        for _ in 0..5000 {
            stepper.attempt(sys, &cur, 0, h, &mut next).unwrap();
            stepper.accept(sys, &next);
            std::mem::swap(&mut cur, &mut next);
            contacts += cur.phi.iter().filter(|p| **p != 0.0).count();
        }
        (cur, contacts)
    }

    /// A gap's DOFs and coefficients, clearance and side.
    pub(crate) type GapSpec<'a> = (&'a [(usize, f64)], f64, Side);

    /// A chain of `n` masses (springs to ground and between neighbours, Rayleigh damping
    /// `c`), a harmonic load on the last, and `walls`, each with Lankarani–Nikravesh's law.
    pub(crate) fn small_chain(n: usize, c: f64, walls: &[GapSpec]) -> System {
        let (mut m, mut k) = (DMatrix::zeros(n, n), DMatrix::zeros(n, n));
        for i in 0..n {
            m[(i, i)] = 1.0 + 0.3 * i as f64;
            k[(i, i)] += 4e4;
            if i + 1 < n {
                k[(i, i)] += 1e5;
                k[(i + 1, i + 1)] += 1e5;
                k[(i, i + 1)] -= 1e5;
                k[(i + 1, i)] -= 1e5;
            }
        }
        let damping = &m * c + &k * (1e-2 * c / 100.0);
        let s = LinearStructure::new(m, damping, k).unwrap();
        let gaps = walls
            .iter()
            .map(|(dofs, clearance, side)| Gap {
                dofs: dofs.iter().map(|d| d.0).collect(),
                coefficients: dofs.iter().map(|d| d.1).collect(),
                clearance: *clearance,
                side: *side,
                law: Law::Hysteretic(
                    crate::contact::Hysteretic::new("lankarani-nikravesh", 1e9, 1.5, 0.8).unwrap(),
                ),
            })
            .collect();
        let load = Load {
            dofs: vec![n - 1],
            amplitude: 40.0,
            history: LoadHistory::Harmonic {
                frequency: 35.0,
                phase: 0.2,
            },
        };
        System::new(s, gaps, vec![load]).unwrap()
    }

    /// The small models the steps compiled for a size are checked on: one DOF with a
    /// one-sided and with a two-sided stop, 2- and 3-DOF chains with damping, a harmonic load
    /// and a relative gap.
    pub(crate) fn small_models() -> [System; 4] {
        [
            small_chain(1, 0.0, &[(&[(0, 1.0)], 1e-3, Side::Positive)]),
            small_chain(1, 2.0, &[(&[(0, 1.0)], 1e-3, Side::Both)]),
            small_chain(2, 3.0, &[(&[(1, 1.0), (0, -1.0)], 1e-4, Side::Both)]),
            small_chain(
                3,
                1.0,
                &[
                    (&[(0, 1.0)], 1e-3, Side::Negative),
                    (&[(2, 1.0), (1, -1.0)], 5e-4, Side::Both),
                ],
            ),
        ]
    }

    /// Runs 4,000 steps of `h` on `sys` twice, by `attempt` (compiled for the size) and by
    /// `general`, from the same start and accepting each, and asserts the same state after
    /// every step; returns the steps' count of closed walls and of free-flight steps.
    pub(crate) fn assert_sized_equals_general<S: Stepper>(
        sys: &System,
        make: impl Fn() -> S,
        general: impl Fn(&mut S, &System, &State, f64, &mut State) -> Result<usize, StepFailure>,
        h: f64,
    ) -> (usize, usize) {
        let n = sys.n_dof();
        let mut states = [0, 1].map(|_| {
            let v0 = DVector::from_fn(n, |i, _| 0.3 - 0.2 * i as f64);
            let cur = State::initial(sys, DVector::zeros(n), v0, 0.0).unwrap();
            (make(), cur.clone(), cur)
        });
        let (mut contacts, mut free) = (0, 0);
        for _ in 0..4000 {
            for (sized, (stepper, cur, next)) in states.iter_mut().enumerate() {
                let iterations = if sized == 1 {
                    stepper.attempt(sys, cur, 0, h, next)
                } else {
                    general(stepper, sys, cur, h, next)
                };
                iterations.unwrap();
                stepper.accept(sys, next);
                std::mem::swap(cur, next);
            }
            let (general, sized) = (&states[0].1, &states[1].1);
            assert_eq!(
                (&general.x, &general.v, &general.a, &general.phi, &general.u),
                (&sized.x, &sized.v, &sized.a, &sized.phi, &sized.u),
                "{n} DOFs, t {}",
                general.t
            );
            assert_eq!(general.walls, sized.walls);
            assert_eq!(states[0].0.last_step_free(), states[1].0.last_step_free());
            contacts += general.walls.iter().filter(|w| w.closed()).count();
            free += usize::from(states[1].0.last_step_free());
        }
        (contacts, free)
    }

    /// Newmark's step compiled for one to four DOFs gives the general step's bits (one DOF
    /// with one wall and with two, 2- and 3-DOF chains with damping, a harmonic load and a
    /// relative gap), each with Newmark, HHT-α and generalized-α.
    #[test]
    fn sized_step_equals_the_general_step() {
        for sys in &small_models() {
            for scheme in TEST_SCHEMES {
                let make = || NewmarkStepper::new(sys, scheme, NewtonSettings::default()).unwrap();
                let general =
                    |s: &mut NewmarkStepper, sys: &System, s0: &State, h, s1: &mut State| {
                        s.step::<0>(sys, s0, 0, h, s1)
                    };
                let (contacts, free) = assert_sized_equals_general(sys, make, general, 2e-5);
                let n = sys.n_dof();
                assert!(
                    contacts > 50,
                    "{n} DOFs, {scheme:?}: {contacts} steps in contact"
                );
                assert!(
                    free > 1000,
                    "{n} DOFs, {scheme:?}: {free} free-flight steps"
                );
            }
        }
    }

    /// The run's statistics name the step that ran: the sized step for one to four DOFs
    /// (`attempt`'s dispatch), the general one for five, and for methods without a sized step.
    #[test]
    fn stats_name_the_step_path() {
        use crate::simulate::{simulate, Method, RunSettings};
        for n in 1..=5 {
            let sys = small_chain(n, 1.0, &[(&[(0, 1.0)], 1e-3, Side::Both)]);
            let settings = RunSettings {
                t_end: 1e-3,
                dt: 1e-5,
                every: 1,
                record_dofs: vec![0],
                newton: NewtonSettings::default(),
                adaptive: None,
            };
            let expected = match n {
                1..=4 => format!("fixed-size N={n}"),
                _ => "general".to_string(),
            };
            for method in [
                Method::Newmark(NewmarkFamily::average_acceleration()),
                Method::GeneralizedAlpha(TEST_SCHEMES[2]),
            ] {
                let (x0, v0) = (DVector::zeros(n), DVector::from_element(n, 0.1));
                let out = simulate(&sys, method, &settings, x0, v0).unwrap();
                assert_eq!(out.stats.step_path, expected, "{n} DOFs, {method:?}");
            }
            let adaptive = RunSettings {
                adaptive: Some(crate::settings::Adaptive {
                    rtol: 1e-6,
                    atol: 1e-9,
                    dt_min: 1e-9,
                    dt_max: 1e-4,
                }),
                ..settings
            };
            let (x0, v0) = (DVector::zeros(n), DVector::from_element(n, 0.1));
            let out = simulate(&sys, Method::Dop853, &adaptive, x0, v0).unwrap();
            assert_eq!(out.stats.step_path, "general");
        }
    }

    /// The dense, the banded and the general sparse predictors (each scheme's right-hand
    /// side: K; K and C; K, C and M) take the same steps, contacts included: the states agree
    /// to 1e-12 of their scale after 5,000 steps with over 100 steps in contact.
    #[test]
    fn dense_banded_and_sparse_predictors_agree() {
        let sys = chain();
        for scheme in TEST_SCHEMES {
            let (dense, contacts) = run(&sys, scheme, PredictorChoice::Dense);
            assert!(contacts > 100, "{contacts} contact steps");
            // max |a − b| / max |a|
            let relative = |a: &[f64], b: &[f64]| {
                let diff = a
                    .iter()
                    .zip(b)
                    .fold(0.0_f64, |m, (p, q)| m.max((p - q).abs()));
                diff / a.iter().fold(0.0_f64, |m, p| m.max(p.abs()))
            };
            for choice in [PredictorChoice::Banded, PredictorChoice::Sparse] {
                let (other, _) = run(&sys, scheme, choice);
                let (dx, dv) = (relative(&dense.x, &other.x), relative(&dense.v, &other.v));
                assert!(
                    dx < 1e-12 && dv < 1e-12,
                    "{scheme:?} {choice:?}: {dx:e}, {dv:e}"
                );
            }
        }
    }

    /// A small 3-D solid (a 7 × 7 × 7 spring lattice, 343 DOFs, whose dense operator fits a
    /// core's cache): the dense predictor is the faster per step, but its setup (an LU and
    /// n solves, n³·4/3 multiply-adds) outweighs that over a short run, so a run of 10 steps
    /// takes the sparse factor and one of 10⁶ (or of unknown length) the dense operator; the
    /// crossover lies between the two totals' break-even and the steps either side of it.
    #[test]
    fn setup_cost_decides_the_predictor_of_a_short_run() {
        let k = Csr::from_dense(&crate::factor::tests::lattice(7));
        let n = k.n();
        let m = Csr::from_dense(&DMatrix::from_diagonal(&DVector::from_fn(n, |i, _| {
            1e-3 * (1.0 + 0.01 * i as f64)
        })));
        let zero = Csr::from_parts(n, vec![0; n + 1], vec![], vec![]).unwrap();
        let sys = System::new(
            LinearStructure::from_sparse(m, zero, k).unwrap(),
            vec![],
            vec![],
        )
        .unwrap();
        let scheme = NewmarkFamily::average_acceleration();
        let h = 1e-4;
        let solver = |steps: Option<usize>| {
            let plan = OnceLock::new();
            let op = build_operator(&sys, &scheme, h, &plan, PredictorChoice::Cheapest, 4, steps)
                .unwrap();
            op.info.solver
        };
        assert_eq!(solver(None), "dense");
        assert_eq!(solver(Some(1_000_000)), "dense");
        assert!(
            solver(Some(10)).starts_with("sparse"),
            "{}",
            solver(Some(10))
        );
        // the break-even of the two estimates: sparse just below it, dense just above
        let plan = FactorPlan::new(
            &[&sys.structure.mass, &sys.structure.stiffness],
            FactorChoice::Cheapest,
        );
        let sparse_step = (sys.structure.stiffness.nnz() + plan.solve_cost()) as f64;
        let dense_step = (n * n) as f64 / 8.0; // in cache, 4 lanes
        let setup = (n as f64).powi(3) * (1.0 / 3.0 + 1.0) - plan.factor_cost() as f64;
        let even = setup / (sparse_step - dense_step);
        assert!(even > 10.0 && even < 1e6, "{even}");
        assert!(solver(Some((0.9 * even) as usize)).starts_with("sparse"));
        assert_eq!(solver(Some((1.1 * even) as usize + 1)), "dense");
    }

    /// `diag(d) + off (sub- and super-diagonal)` of size `n` as sparse rows.
    fn tridiagonal(n: usize, d: f64, off: f64) -> Csr {
        let (mut ptr, mut idx, mut val) = (vec![0], vec![], vec![]);
        for i in 0..n {
            for j in i.saturating_sub(1)..(i + 2).min(n) {
                if j == i || off != 0.0 {
                    idx.push(j);
                    val.push(if j == i { d } else { off });
                }
            }
            ptr.push(idx.len());
        }
        Csr::from_parts(n, ptr, idx, val).unwrap()
    }

    /// Above [`MAX_DENSE_DOFS`] the stepper works on the sparse rows only: the run takes its
    /// steps through an impact without ever building the dense matrices, and an effective
    /// stiffness that is not positive definite is a singular tangent, not a dense LU.
    #[test]
    fn large_models_never_densify() {
        let n = MAX_DENSE_DOFS + 1;
        let zero = Csr::from_parts(n, vec![0; n + 1], vec![], vec![]).unwrap();
        let (m, k) = (tridiagonal(n, 1.0, 0.0), tridiagonal(n, 2e4, -1e4));
        let s = LinearStructure::from_sparse(m.clone(), zero.clone(), k).unwrap();
        let gap = Gap {
            dofs: vec![n - 1],
            coefficients: vec![1.0],
            clearance: 1e-4,
            side: Side::Positive,
            law: Law::Hertz(Hertz::new(1e9, 1.5).unwrap()),
        };
        let sys = System::new(s, vec![gap], vec![]).unwrap();
        let scheme = NewmarkFamily::average_acceleration();
        let mut stepper = NewmarkStepper::new(&sys, scheme, NewtonSettings::default()).unwrap();
        let v0 = DVector::from_fn(n, |i, _| if i == n - 1 { 1.0 } else { 0.0 });
        let mut cur = State::initial(&sys, DVector::zeros(n), v0, 0.0).unwrap();
        let mut next = cur.clone();
        let mut contact = false;
        for _ in 0..400 {
            stepper.attempt(&sys, &cur, 0, 1e-6, &mut next).unwrap();
            stepper.accept(&sys, &next);
            std::mem::swap(&mut cur, &mut next);
            contact |= cur.phi[0] != 0.0;
        }
        assert!(contact && cur.x[n - 1] > 1e-4, "{}", cur.x[n - 1]);
        assert!(sys.structure.dense.get().is_none());
        // K̃ = K + 4M/h² with K = −1e9 I and h = 1 ms: indefinite
        let negative = tridiagonal(n, -1e9, 0.0);
        let s = LinearStructure::from_sparse(m, zero, negative).unwrap();
        let sys = System::new(s, vec![], vec![]).unwrap();
        let cheapest = PredictorChoice::Cheapest;
        let op = build_operator(&sys, &scheme, 1e-3, &OnceLock::new(), cheapest, 4, None);
        assert!(matches!(op, Err(SimError::SingularTangent { .. })));
        assert!(sys.structure.dense.get().is_none());
    }
}
