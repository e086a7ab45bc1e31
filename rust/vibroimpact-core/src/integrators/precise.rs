//! Precise integration with the Adams multi-step treatment of the nonlinear term (paper
//! eqs. 32–43; Zhong & Williams 1994 for `Φ`, the "precise Adams multi-step method").
//!
//! With the dual variable `p = M q' + C q/2` (eq. 33) the equation of motion is
//! `y' = H y + f(y, t)` for `y = [q; p]` (eq. 34), with (eqs. 36–37)
//! `H = [[A₁, A₄], [A₂, A₃]]`, `A₁ = −M⁻¹C/2`, `A₄ = M⁻¹`, `A₂ = CM⁻¹C/4 − K`, `A₃ = −CM⁻¹/2`,
//! and `f = [0; F(t) − Σ_g φ_g b_gᵀ]`: the external loads and the contact forces. Over a step
//! `η`, Duhamel's integral (eq. 38) is exact for the linear part:
//! `y_{k+1} = Φ y_k + ∫₀^η e^{H(η−τ)} f(t_k + τ) dτ` with `Φ = exp(Hη)`. With `f` replaced
//! by a polynomial `Σ_m d_m (τ/η)^m` on the step (eq. 39), the integral is `Σ_m D_m d_m`
//! with the Duhamel matrices `D_m = η^{m+1} Φ_m(η)` (eqs. 40–41). `Φ` and every `D_m` come
//! from one matrix exponential by the 2^N algorithm ([`super::expm`]) and are computed once
//! per step size (`level`), never per step; a step then costs one `2n × 2n` mat-vec plus a
//! few columns per load and per gap.
//!
//! Two ways to choose the polynomial:
//! * **Adams** (the paper's method, eqs. 42–43): `f` is extrapolated from `f_k, f_{k−1},
//!   f_{k−2}` (explicit; third order). The first two steps have no such history: they
//!   predict with the lower-order extrapolation through the points available, evaluate `f` at
//!   the prediction, and correct with the interpolation through `t_{k+1}` too (a PEC step,
//!   local error `O(η³)` and `O(η⁴)`), so the method keeps its order from the start. The
//!   points may be unevenly spaced (after a step cut), and a point whose spacing is less than
//!   half the step is dropped rather than extrapolated from.
//!   Explicit means conditionally stable in the contact stiffness: on a free mass against a
//!   linear contact spring of frequency `ω_c`, the step is stable for `ω_c η ≤ 0.97`.
//! * **Predictor–corrector** (`predictor_corrector = true`): the Adams step above predicts;
//!   the corrector treats the contact force implicitly as its average over the step,
//!   `(φ_k + φ_{k+1})/2` (the loads, known functions of time, by the quadratic through
//!   `t_{k−1}, t_k, t_{k+1}`), and solves for `φ_{k+1}` by Newton on the gap coordinates
//!   exactly as the Newmark family does ([`super::newton::GapNewton`]). On the same free mass
//!   and spring this is the average-acceleration rule: unconditionally stable (spectral
//!   radius 1 for every `ω_c η`, no numerical damping), against `ω_c η ≤ 0.97` for Adams.
//!   The contact force is then second order; the linear structure stays exact.
//!
//! The state is carried as `z = [x; v]`: `Φ` and the `D_m` are mapped once per step size
//! through the exact change of variables `y = T z`, `T = [[I, 0], [C/2, M]]`
//! (`q' = M⁻¹(p − Cq/2)`), and the acceleration comes from the equation of motion.

use nalgebra::DMatrix;

use super::expm::duhamel;
use super::free_run::{local_motion, FreeWalls, FREE_RUN_WALLS};
use super::newton::{solve_small, GapNewton, GapProblem, NewtonSettings, RateMap};
use super::sized::{by_size, dofs, sized_step_path, MAX_SIZED};
use super::{OperatorCache, StepFailure, Stepper};
use crate::driver::{FreeRunEnd, Run};
use crate::error::{invalid, SimError};
use crate::gap::WallState;
use crate::linalg::axpy;
use crate::step_control::grid_time;
use crate::structure::{DenseStructure, LinearStructure};
use crate::system::{finite_motion, State, System, Tangent};

/// Settings of the precise integration method.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PreciseIntegration {
    /// Treat the contact force implicitly (predictor–corrector with Newton on the gaps)
    /// instead of by explicit Adams extrapolation.
    pub predictor_corrector: bool,
}

/// A past point of the Adams history wider than this fraction of the step is dropped.
const MIN_SPACING: f64 = 0.5;

/// `H` of eqs. 36–37 and `M⁻¹`.
fn hamiltonian(st: &DenseStructure) -> Result<(DMatrix<f64>, DMatrix<f64>), SimError> {
    let n = st.mass.nrows();
    let (m, c, k) = (&st.mass, &st.damping, &st.stiffness);
    let m_inv = m
        .clone()
        .cholesky()
        .ok_or_else(|| SimError::InvalidModel("structure.mass: not positive definite".into()))?
        .inverse();
    let mut h = DMatrix::zeros(2 * n, 2 * n);
    h.view_mut((0, 0), (n, n)).copy_from(&(&m_inv * c * -0.5));
    h.view_mut((0, n), (n, n)).copy_from(&m_inv);
    h.view_mut((n, 0), (n, n))
        .copy_from(&(c * &m_inv * c * 0.25 - k));
    h.view_mut((n, n), (n, n)).copy_from(&(c * &m_inv * -0.5));
    Ok((h, m_inv))
}

/// The matrices of the method for one step `η`, in the paper's variables `[q; p]`.
#[derive(Debug, Clone, PartialEq)]
pub struct PreciseMatrices {
    /// `H` (eqs. 36–37).
    pub hamiltonian: DMatrix<f64>,
    /// `Φ = exp(Hη)`, by the 2^N algorithm.
    pub phi: DMatrix<f64>,
    /// `D_m = η^{m+1} Φ_m(η) [0; I]` for m = 0, 1, 2 (eqs. 40–41): the columns that act on a
    /// force, 2n × n each.
    pub duhamel: Vec<DMatrix<f64>>,
}

/// [`PreciseMatrices`] of a structure for a step `eta`, for tests against an independent
/// `expm`.
pub fn precise_matrices(
    structure: &LinearStructure,
    eta: f64,
) -> Result<PreciseMatrices, SimError> {
    let n = structure.n_dof();
    let (hamiltonian, _) = hamiltonian(&*structure.dense("precise")?)?;
    let mut b = DMatrix::zeros(2 * n, n);
    b.view_mut((n, 0), (n, n)).fill_with_identity();
    let (phi, duhamel) = duhamel(&hamiltonian, eta, &b, 2);
    Ok(PreciseMatrices {
        hamiltonian,
        phi,
        duhamel,
    })
}

/// `Φ` and the Duhamel columns for one step size, in `z = [x; v]`.
struct StepOperator {
    /// `T⁻¹ Φ T`, row-major 2n × 2n.
    phi: Vec<f64>,
    /// `T⁻¹ D_m [0; b_j]` for m = 0, 1, 2: the loads' columns, then the gaps'.
    cols: Vec<[Vec<f64>; 3]>,
    /// Predictor–corrector: `W`, `S` (row-major, gaps × gaps) of the gap problem, with
    /// `u = u_lin − W φ_{k+1}`, `u̇ = u̇_lin − V φ_{k+1}` and `S = V W⁻¹`.
    w: Vec<f64>,
    s: Vec<f64>,
}

/// What does not depend on the step size.
struct Fixed {
    n: usize,
    /// `H`, and the force columns `[0; b_j]` (loads, then gaps).
    h: DMatrix<f64>,
    b: DMatrix<f64>,
    /// `T`, `T⁻¹`.
    t: DMatrix<f64>,
    t_inv: DMatrix<f64>,
    /// `M⁻¹K`, `M⁻¹C` (row-major) and `M⁻¹ b_j`: the acceleration from the equation of motion.
    m_inv_k: Vec<f64>,
    m_inv_c: Vec<f64>,
    m_inv_b: Vec<Vec<f64>>,
}

impl Fixed {
    fn new(sys: &System) -> Result<Self, SimError> {
        let n = sys.n_dof();
        let st = &*sys.structure.dense("precise")?;
        let (h, m_inv) = hamiltonian(st)?;
        let (nl, ng) = (sys.loads.len(), sys.gaps.len());
        let mut b = DMatrix::zeros(2 * n, nl + ng);
        for (l, load) in sys.loads.iter().enumerate() {
            for &d in &load.dofs {
                b[(n + d, l)] += 1.0;
            }
        }
        for (g, gap) in sys.gaps.iter().enumerate() {
            for (&d, &c) in gap.dofs.iter().zip(&gap.coefficients) {
                b[(n + d, nl + g)] += c;
            }
        }
        let mut t = DMatrix::identity(2 * n, 2 * n);
        t.view_mut((n, 0), (n, n)).copy_from(&(&st.damping * 0.5));
        t.view_mut((n, n), (n, n)).copy_from(&st.mass);
        let mut t_inv = DMatrix::identity(2 * n, 2 * n);
        t_inv
            .view_mut((n, 0), (n, n))
            .copy_from(&(&m_inv * &st.damping * -0.5));
        t_inv.view_mut((n, n), (n, n)).copy_from(&m_inv);
        let row_major = |a: DMatrix<f64>| a.transpose().as_slice().to_vec();
        let m_inv_b = (0..nl + ng)
            .map(|j| (&m_inv * b.view((n, j), (n, 1))).as_slice().to_vec())
            .collect();
        Ok(Self {
            n,
            m_inv_k: row_major(&m_inv * &st.stiffness),
            m_inv_c: row_major(&m_inv * &st.damping),
            m_inv_b,
            h,
            b,
            t,
            t_inv,
        })
    }

    /// The acceleration of `s` from the equation of motion, `a = M⁻¹(Σ_l F_l b_l − K x − C v
    /// − Σ_g φ_g b_g)`, with the contact forces when `contact` (else they are zero); `N` as
    /// [`PreciseStepper::step`].
    #[inline(always)]
    fn acceleration<const N: usize>(&self, s: &mut State, contact: bool) {
        let n = dofs::<N>(self.n);
        let (x, v, a) = (s.x.sized::<N>(), s.v.sized::<N>(), s.a.sized_mut::<N>());
        for (i, a) in a.iter_mut().enumerate() {
            let (rk, rc) = (
                &self.m_inv_k[i * n..(i + 1) * n],
                &self.m_inv_c[i * n..(i + 1) * n],
            );
            *a = unforced_acceleration(rk, rc, x, v);
        }
        for (&g, col) in s.load.iter().zip(&self.m_inv_b) {
            if g != 0.0 {
                axpy(g, &col[..n], a);
            }
        }
        if contact {
            let gaps = &self.m_inv_b[s.load.len()..];
            for (&p, col) in s.phi.iter().zip(gaps) {
                if p != 0.0 {
                    axpy(-p, &col[..n], a);
                }
            }
        }
    }

    fn operator(&self, sys: &System, h: f64, implicit: bool) -> Result<StepOperator, SimError> {
        let n2 = 2 * self.n;
        let (phi, d) = duhamel(&self.h, h, &self.b, 2);
        let phi_z = &self.t_inv * phi * &self.t;
        let d_z: Vec<DMatrix<f64>> = d.iter().map(|dm| &self.t_inv * dm).collect();
        if phi_z
            .iter()
            .chain(d_z.iter().flat_map(|m| m.iter()))
            .any(|v| !v.is_finite())
        {
            return invalid(format!(
                "solver.dt: {h} gives a non-finite transition matrix exp(H dt); check the \
                 structure's matrices"
            ));
        }
        let cols = (0..self.b.ncols())
            .map(|j| {
                let col = |m: usize| d_z[m].column(j).iter().copied().collect::<Vec<f64>>();
                [col(0), col(1), col(2)]
            })
            .collect::<Vec<_>>();
        let ng = sys.gaps.len();
        let (mut w, mut s) = (Vec::new(), Vec::new());
        if implicit && ng > 0 {
            // Column h of W and V: the gap coordinates and rates moved by −½ D₀ [0; b_h].
            let nl = sys.loads.len();
            let mut wm = DMatrix::zeros(ng, ng);
            let mut vm = DMatrix::zeros(ng, ng);
            let mut row = vec![0.0; ng];
            for hi in 0..ng {
                let y = &cols[nl + hi][0];
                sys.gap_coordinates(&y[..self.n], &mut row);
                for gi in 0..ng {
                    wm[(gi, hi)] = 0.5 * row[gi];
                }
                sys.gap_coordinates(&y[self.n..n2], &mut row);
                for gi in 0..ng {
                    vm[(gi, hi)] = 0.5 * row[gi];
                }
            }
            let scale = wm.norm();
            if !(scale.is_finite() && scale > 0.0) {
                return invalid(format!(
                    "solver.dt: {h} makes the contact forces move no gap over a step (dt is a \
                     whole number of periods of the structure); change dt"
                ));
            }
            // Pseudo-inverse: gaps on the same coordinate make W singular but consistent.
            let w_pinv = wm
                .clone()
                .pseudo_inverse(1e-13 * scale)
                .map_err(|e| SimError::InvalidModel(format!("solver.dt: {h}: {e}")))?;
            let sm = &vm * w_pinv;
            w = wm.transpose().as_slice().to_vec();
            s = sm.transpose().as_slice().to_vec();
        }
        Ok(StepOperator {
            phi: phi_z.transpose().as_slice().to_vec(),
            cols,
            w,
            s,
        })
    }
}

/// Entry `i` of `−M⁻¹(K x + C v)`, from row `i` of `M⁻¹K` and `M⁻¹C`: a DOF's acceleration
/// without loads and contact forces (the one home of its arithmetic: the step's
/// [`Fixed::acceleration`] and the free run's).
#[inline(always)]
fn unforced_acceleration(m_inv_k: &[f64], m_inv_c: &[f64], x: &[f64], v: &[f64]) -> f64 {
    let mut acc = 0.0;
    for j in 0..x.len() {
        acc -= m_inv_k[j] * x[j] + m_inv_c[j] * v[j];
    }
    acc
}

/// Entry `i` of the free response `Φ z` (eq. 38 without the forces) from row `i` of `Φ`
/// (`z = [x; v]`; the step's and the free run's arithmetic).
#[inline(always)]
fn free_response(phi_row: &[f64], x: &[f64], v: &[f64]) -> f64 {
    let (rx, rv) = phi_row.split_at(x.len());
    let mut acc = 0.0;
    for j in 0..x.len() {
        acc += rx[j] * x[j] + rv[j] * v[j];
    }
    acc
}

/// Loads and contact forces at one accepted instant, and the step that ended there.
#[derive(Debug, Clone)]
struct Sample {
    t: f64,
    /// Length of the step that ended at `t` (NaN for the first instant), s.
    h: f64,
    load: Vec<f64>,
    phi: Vec<f64>,
}

/// Monomial coefficients of the Lagrange basis through up to three nodes `s_i` (in units of
/// the step, 0 = start of the step): `d_m = Σ_i w[i][m] f_i` gives `f(s) = Σ_m d_m s^m`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Weights {
    nodes: [f64; 3],
    count: usize,
    w: [[f64; 3]; 3],
}

impl Weights {
    fn new() -> Self {
        Self {
            nodes: [f64::NAN; 3],
            count: 0,
            w: [[0.0; 3]; 3],
        }
    }

    /// Recomputes only when the nodes change (after a step cut or at the start).
    fn set(&mut self, nodes: &[f64]) {
        let p = nodes.len();
        if p == self.count && nodes == &self.nodes[..p] {
            return;
        }
        self.count = p;
        self.nodes = [f64::NAN; 3];
        self.nodes[..p].copy_from_slice(nodes);
        for i in 0..p {
            // Vandermonde system V d = e_i, V[r][m] = s_r^m.
            let mut a = [0.0; 9];
            let mut rhs = [0.0; 3];
            for (r, &s) in nodes.iter().enumerate() {
                let mut pow = 1.0;
                for m in 0..p {
                    a[r * p + m] = pow;
                    pow *= s;
                }
            }
            rhs[i] = 1.0;
            let ok = solve_small(&mut a[..p * p], &mut rhs[..p], p);
            debug_assert!(ok, "distinct nodes");
            self.w[i] = [0.0; 3];
            self.w[i][..p].copy_from_slice(&rhs[..p]);
        }
    }

    /// `d_m` of values `f_i` at the nodes.
    #[inline]
    fn coefficients(&self, f: [f64; 3]) -> [f64; 3] {
        let mut d = [0.0; 3];
        for (i, fi) in f.iter().enumerate().take(self.count) {
            if *fi != 0.0 {
                for (dm, wm) in d.iter_mut().zip(&self.w[i]) {
                    *dm += wm * fi;
                }
            }
        }
        d
    }
}

/// Precise-integration stepper: per-size operators, the Adams history, work space.
pub struct PreciseStepper {
    variant: PreciseIntegration,
    newton: NewtonSettings,
    fixed: Fixed,
    operators: OperatorCache<StepOperator>,
    /// A ring: `history[newest]` is the state the next step starts from, the next older at
    /// `newest + 1` (mod 3).
    history: [Sample; 3],
    newest: usize,
    history_len: usize,
    /// Length of the last attempted step (the one `accept` refers to).
    last_h: f64,
    /// The last attempt was an Adams step in free flight ([`Stepper::last_step_free`]).
    free_flight: bool,
    predictor: Weights,
    corrector: Weights,
    free: Vec<f64>,
    z: Vec<f64>,
    z_pred: Vec<f64>,
    u: Vec<f64>,
    u_rate: Vec<f64>,
    walls_pred: Vec<WallState>,
    phi_pred: Vec<f64>,
    tangent: Tangent,
    du_lin: Vec<f64>,
    rate_lin: Vec<f64>,
    gap_newton: GapNewton,
}

impl PreciseStepper {
    pub fn new(
        sys: &System,
        variant: PreciseIntegration,
        newton: NewtonSettings,
    ) -> Result<Self, SimError> {
        let n = sys.n_dof();
        let (nl, ng) = (sys.loads.len(), sys.gaps.len());
        let sample = Sample {
            t: f64::NAN,
            h: f64::NAN,
            load: vec![0.0; nl],
            phi: vec![0.0; ng],
        };
        Ok(Self {
            variant,
            newton,
            fixed: Fixed::new(sys)?,
            operators: OperatorCache::new(newton.max_step_cuts),
            history: [sample.clone(), sample.clone(), sample],
            newest: 0,
            history_len: 0,
            last_h: f64::NAN,
            free_flight: false,
            predictor: Weights::new(),
            corrector: Weights::new(),
            free: vec![0.0; 2 * n],
            z: vec![0.0; 2 * n],
            z_pred: vec![0.0; 2 * n],
            u: vec![0.0; ng],
            u_rate: vec![0.0; ng],
            walls_pred: vec![WallState::default(); sys.walls.len()],
            phi_pred: vec![0.0; ng],
            tangent: Tangent::new(ng),
            du_lin: vec![0.0; ng],
            rate_lin: vec![0.0; ng],
            gap_newton: GapNewton::new(ng),
        })
    }

    /// Builds the operator of the largest step now, so that a problem is reported before
    /// the run starts.
    pub fn prepare(&mut self, sys: &System, h: f64) -> Result<(), SimError> {
        let op = self
            .fixed
            .operator(sys, h, self.variant.predictor_corrector)?;
        self.operators.set_largest(op);
        Ok(())
    }

    /// Makes the newest sample the step's start `s0` (a new run, or a state the history does
    /// not end at): the Adams formulas then restart from one point.
    fn sync_history(&mut self, s0: &State, h: f64) {
        if self.history_ends_at(s0.t, h) {
            return;
        }
        let first = &mut self.history[self.newest];
        first.t = s0.t;
        first.h = f64::NAN;
        first.load.copy_from_slice(&s0.load);
        first.phi.copy_from_slice(&s0.phi);
        self.history_len = 1;
    }

    /// Whether the history's newest sample is the instant `t` (to a step `h`'s 1e-9).
    fn history_ends_at(&self, t: f64, h: f64) -> bool {
        self.history_len > 0 && (self.history[self.newest].t - t).abs() <= 1e-9 * h
    }

    /// Past points usable for a step `h`: `[0, s₁, s₂]` in units of `h`.
    fn past_nodes(&self, h: f64) -> ([f64; 3], usize) {
        let mut nodes = [0.0; 3];
        let mut count = 1;
        for i in 0..2 {
            let spacing = self.history[(self.newest + i) % 3].h;
            if self.history_len > i + 1 && spacing.is_finite() && spacing >= MIN_SPACING * h {
                nodes[i + 1] = nodes[i] - spacing / h;
                count += 1;
            } else {
                break;
            }
        }
        (nodes, count)
    }
}

/// `out += Σ_l Σ_m d_m(load_l) D_m b_l − Σ_g Σ_m d_m(φ_g) D_m b_g` for the polynomial through
/// the values at the nodes of `w` (`loads[i]`, `phis[i]`: values at node i); gaps are skipped
/// when `phis` is `None`. `N`: as [`PreciseStepper::step`] (`out` holds `2N` values).
#[inline(always)]
fn add_forces<const N: usize>(
    cols: &[[Vec<f64>; 3]],
    w: &Weights,
    loads: [&[f64]; 3],
    phis: Option<[&[f64]; 3]>,
    out: &mut [f64],
) {
    let nl = loads[0].len();
    for (l, col) in cols[..nl].iter().enumerate() {
        let d = w.coefficients([loads[0][l], loads[1][l], loads[2][l]]);
        for (dm, cm) in d.iter().zip(col).take(w.count) {
            if *dm != 0.0 {
                axpy(*dm, &cm[..out.len()], out);
            }
        }
    }
    if let Some(phis) = phis {
        for (g, col) in cols[nl..].iter().enumerate() {
            let d = w.coefficients([phis[0][g], phis[1][g], phis[2][g]]);
            for (dm, cm) in d.iter().zip(col).take(w.count) {
                if *dm != 0.0 {
                    axpy(-*dm, &cm[..out.len()], out);
                }
            }
        }
    }
}

impl Stepper for PreciseStepper {
    /// Models of up to four DOFs take a step compiled for their size ([`Self::step`] with
    /// `N = n`): the same arithmetic in the same order, the loops over the DOFs unrolled.
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

    fn accept(&mut self, _sys: &System, state: &State) {
        self.newest = if self.newest == 0 { 2 } else { self.newest - 1 };
        let newest = &mut self.history[self.newest];
        newest.t = state.t;
        newest.h = self.last_h;
        // element by element: no memcpy call for a few values
        for (to, &from) in newest.load.iter_mut().zip(&state.load) {
            *to = from;
        }
        for (to, &from) in newest.phi.iter_mut().zip(&state.phi) {
            *to = from;
        }
        self.history_len = (self.history_len + 1).min(3);
    }

    /// An Adams step whose walls stayed open at both ends (found by the gap coordinates alone,
    /// as `GapNewton::free_flight`, before any wall is evaluated), its motion finite.
    #[inline(always)]
    fn last_step_free(&self) -> bool {
        self.free_flight
    }

    /// The step [`Self::attempt`] dispatches to.
    fn step_path(&self, sys: &System) -> &'static str {
        sized_step_path(sys.n_dof())
    }

    /// [`Self::free_run`] of the Adams steps of a model of one to four DOFs (none for the
    /// others, nor for the predictor–corrector, whose steps evaluate the walls, nor without
    /// rows).
    #[allow(private_interfaces)]
    fn free_run(
        &mut self,
        sys: &System,
        run: &mut Run,
        h: f64,
        step: usize,
        max: usize,
        rows: bool,
    ) -> Option<usize> {
        if self.variant.predictor_corrector || !rows {
            return None;
        }
        by_size!(sys.n_dof(), |N| self.free_run::<N>(sys, run, h, step, max))
    }
}

impl PreciseStepper {
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
        let implicit = self.variant.predictor_corrector;
        self.last_h = h;
        self.free_flight = false;
        self.sync_history(s0, h);
        let (nodes, count) = self.past_nodes(h);
        let [h1, h2] = [1, 2].map(|i| (self.newest + i) % 3);
        let fixed = &self.fixed;
        let op = self
            .operators
            .ensure(level, h, || fixed.operator(sys, h, implicit))
            .map_err(|_| StepFailure::singular_tangent())?;
        let Self {
            newton: ref settings,
            ref fixed,
            ref history,
            ref mut predictor,
            ref mut corrector,
            ref mut free,
            ref mut z,
            ref mut z_pred,
            ref mut u,
            ref mut u_rate,
            ref mut walls_pred,
            ref mut phi_pred,
            ref mut tangent,
            ref mut du_lin,
            ref mut rate_lin,
            ref mut gap_newton,
            ..
        } = *self;
        let n = dofs::<N>(fixed.n);
        let n2 = 2 * n;
        let ng = sys.gaps.len();
        let (x0, v0) = (s0.x.sized::<N>(), s0.v.sized::<N>());

        s1.t = s0.t + h;
        for (g, load) in s1.load.iter_mut().zip(&sys.loads) {
            *g = load.value(s1.t);
        }
        // The free response Φ z₀, shared by predictor and corrector.
        let free = &mut free[..n2];
        for (row, out) in op.phi.chunks_exact(n2).zip(free.iter_mut()) {
            *out = free_response(row, x0, v0);
        }
        let (h1, h2) = (&history[h1], &history[h2]);
        let past_loads = [&s0.load[..], &h1.load[..], &h2.load[..]];
        let past_phis = [&s0.phi[..], &h1.phi[..], &h2.phi[..]];
        let z = &mut z[..n2];
        let mut iterations = 0;
        let mut gaps = GapBuffers {
            u: &mut u[..],
            u_rate: &mut u_rate[..],
            tangent,
        };

        if !implicit && count == 3 {
            // Adams (eqs. 42–43): f extrapolated from t_k, t_{k−1}, t_{k−2}.
            predictor.set(&nodes);
            z.copy_from_slice(free);
            add_forces::<N>(&op.cols, predictor, past_loads, Some(past_phis), z);
            // Free flight (every wall open at both ends: no wall evaluated, no contact force)
            sys.gap_coordinates(&z[..n], &mut gap_newton.u);
            if gap_newton.free_flight(sys, &s0.walls) {
                s1.x.sized_mut::<N>().copy_from_slice(&z[..n]);
                s1.v.sized_mut::<N>().copy_from_slice(&z[n..]);
                fixed.acceleration::<N>(s1, false);
                self.free_flight = s1.finish_free_flight::<N>(sys, &gap_newton.u);
                return Ok(0);
            }
            gaps.evaluate(sys, &s0.walls, z, n, h, &mut s1.walls, &mut s1.phi);
        } else {
            // Predict with the points available; evaluate the contact forces there.
            predictor.set(&nodes[..count]);
            let z_pred = &mut z_pred[..n2];
            z_pred.copy_from_slice(free);
            add_forces::<N>(&op.cols, predictor, past_loads, Some(past_phis), z_pred);
            gaps.evaluate(sys, &s0.walls, z_pred, n, h, walls_pred, phi_pred);
            // Correct with the polynomial through t_{k+1}, t_k (and t_{k−1}).
            let mut cnodes = [1.0, 0.0, 0.0];
            let ccount = (count + 1).min(3);
            cnodes[2] = nodes[1];
            corrector.set(&cnodes[..ccount]);
            let loads_c = [&s1.load[..], &s0.load[..], &h1.load[..]];
            z.copy_from_slice(free);
            if !implicit {
                let phis_c = [&phi_pred[..], &s0.phi[..], &h1.phi[..]];
                add_forces::<N>(&op.cols, corrector, loads_c, Some(phis_c), z);
                gaps.evaluate(sys, &s0.walls, z, n, h, &mut s1.walls, &mut s1.phi);
            } else {
                // Loads by the corrector's polynomial; contact force (φ_k + φ_{k+1})/2.
                add_forces::<N>(&op.cols, corrector, loads_c, None, z);
                let nl = sys.loads.len();
                for (col, &p) in op.cols[nl..].iter().zip(&s0.phi) {
                    if p != 0.0 {
                        axpy(-0.5 * p, &col[0], z);
                    }
                }
                if ng > 0 {
                    sys.gap_coordinates(&z[..n], du_lin);
                    sys.gap_coordinates(&z[n..], rate_lin);
                    // Every Δu_lin first: the rate correction below mixes all gaps.
                    for (d, u0) in du_lin.iter_mut().zip(&s0.u) {
                        *d -= u0;
                    }
                    gap_newton.start_from(&op.w, du_lin, phi_pred);
                    // u̇ = u̇_lin − V φ = u̇_lin − S (Δu_lin − Δu).
                    for (rate, srow) in rate_lin.iter_mut().zip(op.s.chunks_exact(ng)) {
                        let sdu: f64 = srow.iter().zip(du_lin.iter()).map(|(a, b)| a * b).sum();
                        *rate -= sdu;
                    }
                    let problem = GapProblem {
                        w: &op.w,
                        u0: &s0.u,
                        du_lin,
                        rate_lin,
                        rate: if ng == 1 {
                            RateMap::Diagonal(op.s[0])
                        } else {
                            RateMap::Full(&op.s)
                        },
                        start: &s0.walls,
                        h,
                    };
                    iterations =
                        gap_newton.solve(sys, settings, &problem, &mut s1.walls, &mut s1.phi)?;
                    for (col, &p) in op.cols[nl..].iter().zip(s1.phi.iter()) {
                        if p != 0.0 {
                            axpy(-0.5 * p, &col[0], z);
                        }
                    }
                }
            }
        }
        // State, gap coordinates and the acceleration from the equation of motion; the gap
        // coordinates are Newton's, or those of the last `z` evaluated (the step's end).
        s1.x.sized_mut::<N>().copy_from_slice(&z[..n]);
        s1.v.sized_mut::<N>().copy_from_slice(&z[n..]);
        fixed.acceleration::<N>(s1, true);
        s1.finish_gaps(sys, if implicit && ng > 0 { &gap_newton.u } else { u });
        Ok(iterations)
    }

    /// Up to `max` Adams steps of `h` of the fixed grid from its step `step` in free flight
    /// ([`Stepper::free_run`]), each committed and recorded: the general step's arithmetic
    /// ([`free_response`], [`unforced_acceleration`]) with the motion of the model's `N` DOFs,
    /// `Φ`, `M⁻¹K`, `M⁻¹C` and the walls in local arrays, while the step is `z₁ = Φ z₀` (eq. 38
    /// with no force to extrapolate: no loads, and no contact force at the three instants of
    /// the Adams history, eqs. 42–43) and what the general step would do besides is nothing
    /// (the driver's conditions, `Run::drive`). Ends, before taking it, at the first step
    /// that closes a wall or whose motion is not finite: the general step then takes it as
    /// before. Leaves the history as the general steps' `accept` would. Returns the steps
    /// taken; `None`: never any for this model (`N = 0`: more than four DOFs; loads, more
    /// than [`super::free_run::FREE_RUN_WALLS`] walls).
    #[inline(never)]
    fn free_run<const N: usize>(
        &mut self,
        sys: &System,
        run: &mut Run,
        h: f64,
        step: usize,
        max: usize,
    ) -> Option<usize> {
        let op = self.operators.largest()?;
        if N == 0 || !sys.loads.is_empty() {
            return None;
        }
        // the Adams step of the full history (`Self::step`, `count == 3`), every force in it 0
        let unforced = |s: &Sample| s.phi.iter().all(|&p| p == 0.0);
        if !(self.history_ends_at(run.cur.t, h)
            && self.past_nodes(h).1 == 3
            && self.history.iter().all(unforced))
        {
            return Some(0);
        }
        let walls = FreeWalls::new(sys)?;
        let mut phi = [[0.0; 2 * MAX_SIZED]; 2 * MAX_SIZED];
        for (local, row) in phi.iter_mut().zip(op.phi.chunks_exact(2 * N)) {
            local[..2 * N].copy_from_slice(row);
        }
        let (mut m_inv_k, mut m_inv_c) =
            ([[0.0; MAX_SIZED]; MAX_SIZED], [[0.0; MAX_SIZED]; MAX_SIZED]);
        let fixed = &self.fixed;
        let rows = fixed
            .m_inv_k
            .chunks_exact(N)
            .zip(fixed.m_inv_c.chunks_exact(N));
        for ((k, c), (row_k, row_c)) in m_inv_k.iter_mut().zip(&mut m_inv_c).zip(rows) {
            k[..N].copy_from_slice(row_k);
            c[..N].copy_from_slice(row_c);
        }
        let [mut x, mut v, mut a] = local_motion::<N>(&run.cur);
        let ng = sys.gaps.len();
        let mut rows = run.out.free_rows::<N>(&run.account);
        // a motion's gap coordinates (as `System::gap_coordinates`; a unit gap's is its DOF's
        // displacement, `−0 + 1·x`)
        let coordinates = |x: &[f64; N], u: &mut [f64; FREE_RUN_WALLS]| {
            if let Some(unit) = &walls.unit_dofs {
                for (u, &d) in u[..ng].iter_mut().zip(unit) {
                    *u = x[d];
                }
            } else {
                for (u, gap) in u[..ng].iter_mut().zip(&sys.gaps) {
                    *u = gap.coordinate(x);
                }
            }
        };
        // (the gap coordinates and the walls' penetrations at a step's end: only the first
        // `ng` and walls are read, so they are not cleared per step)
        let (mut u, mut depth) = ([0.0; FREE_RUN_WALLS], [0.0; FREE_RUN_WALLS]);
        let mut taken = 0;
        while taken < max {
            let response = |row: usize| free_response(&phi[row][..2 * N], &x, &v);
            let (x1, v1): ([f64; N], [f64; N]) = (
                std::array::from_fn(response),
                std::array::from_fn(|i| response(N + i)),
            );
            // a wall closing at the end, or a motion not finite, ends the run
            coordinates(&x1, &mut u);
            let finite = (0..N).all(|i| finite_motion(x1[i], v1[i]));
            if walls.closing(|g| u[g], &mut depth) || !finite {
                break;
            }
            let a1 = std::array::from_fn(|i| {
                unforced_acceleration(&m_inv_k[i][..N], &m_inv_c[i][..N], &x1, &v1)
            });
            (x, v, a) = (x1, v1, a1);
            taken += 1;
            rows.write(
                grid_time(step + taken, h),
                [&x, &v, &a],
                walls.walls(),
                &depth,
            );
        }
        if taken > 0 {
            let t = grid_time(step + taken, h);
            coordinates(&x, &mut u);
            let end = FreeRunEnd {
                taken,
                t,
                step_end: grid_time(step + taken - 1, h) + h,
                motion: [&x, &v, &a],
                u: &u[..ng],
                loads: None,
            };
            run.end_free_run(sys, rows, end);
            // the history's last three instants, as `accept` leaves them: each step's end
            // `t₀ + h` (`Self::step`'s `s1.t`) after a step of `h`, its forces 0 as before
            for k in taken.saturating_sub(3)..taken {
                self.newest = if self.newest == 0 { 2 } else { self.newest - 1 };
                let sample = &mut self.history[self.newest];
                sample.t = grid_time(step + k, h) + h;
                sample.h = h;
            }
        }
        Some(taken)
    }
}

/// Scratch buffers for evaluating the contacts at a predicted state `z = [x; v]`.
struct GapBuffers<'a> {
    u: &'a mut [f64],
    u_rate: &'a mut [f64],
    tangent: &'a mut Tangent,
}

impl GapBuffers<'_> {
    /// Gap coordinates and rates of `z`, then every wall's state and force.
    #[allow(clippy::too_many_arguments)]
    fn evaluate(
        &mut self,
        sys: &System,
        start: &[WallState],
        z: &[f64],
        n: usize,
        h: f64,
        walls: &mut [WallState],
        phi: &mut [f64],
    ) {
        sys.gap_coordinates(&z[..n], self.u);
        sys.gap_coordinates(&z[n..], self.u_rate);
        sys.evaluate_contacts(start, self.u, self.u_rate, h, walls, phi, self.tangent);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrators::newmark::tests::{assert_sized_equals_general, small_models};

    /// The step compiled for a small model's size gives the general step's bits, through the
    /// Adams history, contacts and free flights, in both variants.
    #[test]
    fn sized_step_equals_the_general_step() {
        for sys in &small_models() {
            for predictor_corrector in [false, true] {
                let variant = PreciseIntegration {
                    predictor_corrector,
                };
                let make = || PreciseStepper::new(sys, variant, NewtonSettings::default()).unwrap();
                let general =
                    |s: &mut PreciseStepper, sys: &System, s0: &State, h, s1: &mut State| {
                        s.step::<0>(sys, s0, 0, h, s1)
                    };
                let (contacts, free) = assert_sized_equals_general(sys, make, general, 1e-5);
                let n = sys.n_dof();
                assert!(
                    contacts > 50,
                    "{n} DOFs, {variant:?}: {contacts} steps in contact"
                );
                if !predictor_corrector {
                    assert!(free > 1000, "{n} DOFs: {free} free-flight Adams steps");
                }
            }
        }
    }
}
