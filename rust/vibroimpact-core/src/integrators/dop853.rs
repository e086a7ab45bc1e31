//! DOP853 with located contact events: the explicit Runge–Kutta pair of order 8 (error
//! estimators of orders 5 and 3) of Dormand & Prince (Hairer, Nørsett & Wanner, *Solving
//! ODEs I*, 1993, §II.10) on `x' = v`, `M v' = F(t) − C v − K x − Σ φ_g b_gᵀ`, for small
//! models and the short, stiff contacts of a few DOFs, where an eighth-order method needs tens
//! of steps per impact instead of thousands.
//!
//! The contact set is fixed inside a step, so every step integrates a smooth equation: each
//! wall's closing and opening (and a tabulated law's first peak, where it turns onto its
//! unloading curve) is located on the step's quintic Hermite interpolant of the penetration
//! (value, rate and acceleration at both ends) and the step is retaken to end there, until
//! the event lies within [`EVENT_NEAR`] of a step (or [`EVENT_TOL`] of `t_end`, or a linear
//! stator's tolerance-scaled window, [`switch_slack`]) of the step's end; the wall is
//! switched at the start of the next step. A force clamped to zero before
//! its wall opens (its law's formula turned tensile) is landed on too. A closing predicted
//! inside the next step is landed on at once. `v_imp`, `t_start`, `t_end` and `v_out` are
//! therefore those of the integrated motion, to its tolerance; peaks (penetration, force,
//! displacement) are found inside the steps on the dense output of order 7
//! ([`Inside::scan`]). A Hertzian force starts and ends like `t^1.5`: with adaptive steps a
//! power-law contact's first step and its last ones are taken in `ζ = √δ` ([`Clock::Root`]),
//! where the motion is analytic; otherwise the first step of a contact and a step landed on
//! a closing or opening take the larger, third-order error estimate. The work integrals of
//! the energy account and each wall's impulse are integrated with the same stages (no
//! trapezoidal rule) and the work integrals are error-controlled too, so the energy balance
//! closes to the method's accuracy.
//!
//! Explicit: the step is bounded by the stiffest mode (`ω_max h ≲ 5`), so FE models with
//! stiff high modes are better served by the implicit methods.

use super::dop853_tableau::{A, A_DENSE, B, C, C_DENSE, D, DENSE_STAGES, E3, E5, STAGES};
use super::sized::{by_size, dofs, Inline, MAX_SIZED};
use crate::contact::{power_law, ContactForce, ContactLaw, Law, MIN_IMPACT_SPEED};
use crate::driver::{Run, StepIntegrals, StepPolicy};
use crate::error::SimError;
use crate::gap::{
    radial_contact, radial_force, Gap, Radial, RadialKinematics, Side, WallInterior, WallState,
};
use crate::interpolation::QuinticSegment;
use crate::observe::Turn;
use crate::sensitivity::StateTransition;
use crate::settings::Adaptive;
use crate::structure::LoadValues;
use crate::system::System;

#[path = "dop853_variational.rs"]
mod variational;
use variational::Variational;

/// Events closer than this fraction of the step (or of `t_end`) to a step's end are
/// switched at the next step's start instead of being landed on: the force law is zero on
/// the open side of the wall, so switching that early changes the motion by far less than
/// the tolerance, and the impact table interpolates the crossing inside the step anyway (not
/// so for a force that jumps at the onset, [`jumps_at_onset`]: those are landed on to
/// round-off).
const EVENT_NEAR: f64 = 1e-5;
/// The smallest such distance, as a fraction of `t_end`.
const EVENT_TOL: f64 = 1e-14;

/// Sub-intervals of a step on which a crossing of the penetration is searched.
const EVENT_SAMPLES: usize = 32;

/// Landings on one event before the step is kept as it is.
const MAX_LANDINGS: usize = 8;

/// A switch this close to a step's end (in fractions of the step) is landed on to round-off
/// when the state-transition matrix is carried or a force jumps at its onset
/// (`landing_correction`).
const LANDING_WINDOW: f64 = 1e-3;

/// The share of the velocity's tolerance that a linear stator's switch may cost where it is
/// switched off the step's end ([`switch_slack`]).
const SWITCH_ERROR: f64 = 0.1;

/// Models up to this many DOFs apply a dense `M⁻¹` instead of solving with `M`'s factor.
const MAX_DENSE_INVERSE: usize = 32;

/// The highest derivative of the free motion's Taylor series on which a predicted closing is
/// refined ([`Dynamics::free_closing`]).
const SERIES_ORDER: usize = 8;

/// Newton iterations of a closing refined on the free motion's Taylor series.
const CLOSING_ITERATIONS: usize = 8;

/// How the steps are sized.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Steps {
    /// Steps of this size (shortened to land on events, then back on the grid `k·dt`).
    Fixed(f64),
    /// The local error kept below the tolerances; `first` is the first step.
    Adaptive {
        tol: Adaptive,
        dt_max: f64,
        first: f64,
    },
}

/// A wall's contact state, fixed during a step.
#[derive(Debug, Clone, Copy, Default)]
struct Contact {
    active: bool,
    impact_speed: f64,
    max_penetration: f64,
    /// Active and not yet past the first peak of the penetration.
    peak_pending: bool,
    /// Integrated in time to its end: a step in `ζ` ([`Clock::Root`]) failed in this
    /// contact, or its law does not suit one.
    in_time: bool,
    /// Active with its law's force clamped to zero (released before the wall opens); kept
    /// only while the state-transition matrix is carried ([`release_walls`]).
    released: bool,
}

/// The right-hand side: the acceleration and the power of the work integrals.
struct Dynamics<'s> {
    sys: &'s System,
    cv: Vec<f64>,
    /// `M⁻¹`, `C` and `K` (each row-major) of a small model, whose products are then dense
    /// dot products (a sparse product's row bookkeeping costs several times more at 2 DOFs).
    small: Option<Small>,
    /// The same of a model of up to [`MAX_SIZED`] DOFs inline ([`small_matrices`]).
    sized_small: [[f64; MAX_SIZED * MAX_SIZED]; 3],
    rhs: Vec<f64>,
    loads: LoadValues,
    /// Each wall as the right-hand side applies it.
    walls: Vec<WallTerm<'s>>,
    /// Each wall's force at the last evaluation, N.
    forces: Vec<f64>,
    /// `K` has a nonzero entry (a free body has none).
    has_stiffness: bool,
    /// The free motion's Taylor coefficients `x⁽ᵏ⁾/k!` (row `k`, [`Self::free_closing`]) and the
    /// loads' derivatives `F⁽ᵏ⁾` that make them.
    series: Vec<f64>,
    load_series: Vec<f64>,
    /// A state on the series: displacement, velocity and acceleration.
    series_state: [Vec<f64>; 3],
}

/// A wall as the right-hand side applies it, its gap, law and DOFs looked up once per run
/// instead of at every evaluation.
#[derive(Clone, Copy)]
enum WallTerm<'s> {
    /// A radial wall: its gap's friction and centre, the DOFs of its `x` and `y`.
    Radial {
        radial: &'s Radial,
        dofs: [usize; 2],
        law: WallLaw<'s>,
        clearance: f64,
    },
    /// A wall of a 1-D gap.
    Line {
        gap: &'s Gap,
        law: WallLaw<'s>,
        sign: f64,
        clearance: f64,
    },
}

/// A wall's law with whether it is a linear stator ([`linear_stator`]) resolved once: a
/// stage tested the law's family, exponent and series spring at every evaluation.
#[derive(Clone, Copy)]
struct WallLaw<'s> {
    law: &'s Law,
    /// The stiffness of a linear stator.
    linear: Option<f64>,
}

impl<'s> WallLaw<'s> {
    fn new(law: &'s Law) -> Self {
        Self {
            law,
            linear: linear_stator(law),
        }
    }
}

impl<'s> WallTerm<'s> {
    /// The wall's penetration, rate and acceleration at a state (a radial wall's:
    /// `δ = ρ − c`, `δ̇ = n·ṗ`, `δ̈ = n·p̈ + (|ṗ|² − δ̇²)/ρ`).
    #[inline]
    fn motion(&self, x: &[f64], v: &[f64], a: &[f64]) -> [f64; 3] {
        match *self {
            Self::Radial {
                radial: r,
                dofs: [ix, iy],
                clearance,
                ..
            } => {
                let k = RadialKinematics::new(
                    [x[ix] - r.center[0], x[iy] - r.center[1]],
                    [v[ix], v[iy]],
                );
                let accel = k.normal[0] * a[ix] + k.normal[1] * a[iy] + k.slide * k.slide / k.rho;
                [k.rho - clearance, k.rate, accel]
            }
            Self::Line {
                gap,
                sign,
                clearance,
                ..
            } => [
                signed_coordinate(gap, sign, x) - clearance,
                signed_coordinate(gap, sign, v),
                signed_coordinate(gap, sign, a),
            ],
        }
    }

    fn new(sys: &'s System, j: usize) -> Self {
        let wall = &sys.walls[j];
        let gap = &sys.gaps[wall.gap];
        match &gap.side {
            Side::Radial(r) => Self::Radial {
                radial: r,
                dofs: [gap.dofs[0], sys.gaps[r.partner].dofs[0]],
                law: WallLaw::new(&gap.law),
                clearance: wall.clearance,
            },
            _ => Self::Line {
                gap,
                law: WallLaw::new(&gap.law),
                sign: wall.sign,
                clearance: wall.clearance,
            },
        }
    }
}

/// A small model's matrices, row-major.
struct Small {
    mass_inverse: Vec<f64>,
    damping: Vec<f64>,
    stiffness: Vec<f64>,
}

/// A small model's `M⁻¹`, `C` and `K` for code compiled for `N` DOFs ([`by_size`]): for
/// `N > 0` (always small) the inline copies `sized`, with no test of `small` and their
/// length a constant; else `small`'s, if the model is small.
#[inline(always)]
fn small_matrices<'a, const N: usize>(
    small: &'a Option<Small>,
    sized: &'a [[f64; MAX_SIZED * MAX_SIZED]; 3],
    n: usize,
) -> Option<[&'a [f64]; 3]> {
    const { assert!(MAX_SIZED <= MAX_DENSE_INVERSE) };
    if N > 0 {
        Some(sized.each_ref().map(|m| &m[..N * N]))
    } else {
        small
            .as_ref()
            .map(|s| [&s.mass_inverse, &s.damping, &s.stiffness].map(|m| &m[..n * n]))
    }
}

/// A working vector of `n` zeros: for code compiled for `N > 0` DOFs an array on the stack (its
/// length a constant, no pointer or length reloaded around the right-hand side's writes), else
/// the general size's buffer `general`, which it borrows.
enum Vector<'b, const N: usize> {
    Sized([f64; N]),
    General(&'b mut [f64]),
}

impl<'b, const N: usize> Vector<'b, N> {
    #[inline(always)]
    fn new(general: &'b mut [f64], n: usize) -> Self {
        if N > 0 {
            Self::Sized([0.0; N])
        } else {
            let general = &mut general[..n];
            general.fill(0.0);
            Self::General(general)
        }
    }

    #[inline(always)]
    fn get(&mut self) -> &mut [f64] {
        match self {
            Self::Sized(a) => a,
            Self::General(v) => v,
        }
    }
}

/// `y += alpha A x` for a row-major `A`.
#[inline]
fn dense_mul_add(a: &[f64], alpha: f64, x: &[f64], y: &mut [f64]) {
    for (yi, row) in y.iter_mut().zip(a.chunks_exact(x.len())) {
        *yi += alpha * dot(row, x);
    }
}

impl<'s> Dynamics<'s> {
    fn new(sys: &'s System) -> Self {
        let n = sys.n_dof();
        let st = &sys.structure;
        let small = (n <= MAX_DENSE_INVERSE).then(|| {
            let row_major = |apply: &dyn Fn(&mut [f64])| {
                let mut matrix = vec![0.0; n * n];
                let mut column = vec![0.0; n];
                for j in 0..n {
                    column.fill(0.0);
                    column[j] = 1.0;
                    apply(&mut column);
                    for (i, &c) in column.iter().enumerate() {
                        matrix[i * n + j] = c;
                    }
                }
                matrix
            };
            let product = |a: &crate::linalg::Csr| {
                row_major(&|column: &mut [f64]| {
                    let e = column.to_vec();
                    column.fill(0.0);
                    a.mul_add(1.0, &e, column);
                })
            };
            Small {
                mass_inverse: row_major(&|column: &mut [f64]| st.solve_mass(column)),
                damping: product(&st.damping),
                stiffness: product(&st.stiffness),
            }
        });
        let mut sized_small = [[0.0; MAX_SIZED * MAX_SIZED]; 3];
        if let Some(small) = small.as_ref().filter(|_| n <= MAX_SIZED) {
            for (sized, m) in
                sized_small
                    .iter_mut()
                    .zip([&small.mass_inverse, &small.damping, &small.stiffness])
            {
                sized[..n * n].copy_from_slice(m);
            }
        }
        Self {
            sys,
            cv: vec![0.0; n],
            small,
            sized_small,
            rhs: vec![0.0; n],
            loads: LoadValues::new(&sys.loads),
            walls: (0..sys.walls.len())
                .map(|j| WallTerm::new(sys, j))
                .collect(),
            forces: vec![0.0; sys.walls.len()],
            has_stiffness: sys.structure.stiffness.values().iter().any(|&k| k != 0.0),
            series: vec![0.0; (SERIES_ORDER + 1) * n],
            load_series: vec![0.0; (SERIES_ORDER - 1) * n],
            series_state: [vec![0.0; n], vec![0.0; n], vec![0.0; n]],
        }
    }

    /// Where open wall `j` closes on the free motion (every wall open) from `state` at `t`,
    /// `guess` (s) after it at constant acceleration ([`predicted_closing`]): refined by
    /// Newton's method on the motion's Taylor series to [`SERIES_ORDER`], so that the step
    /// landed on it ends within its switching window (a quadratic's root falls 1e-3 of the
    /// way short or long, and a tiny step or a retake follows), [`EVENT_NEAR`] of the step or
    /// the wall's `slack` (s, [`switch_slack`]). `None` where the series is not
    /// available (a large model, a run-up, a load that is not smooth), is truncated above the
    /// landing's precision, or Newton does not settle near `guess`. Compiled for `N` DOFs
    /// ([`by_size`]): the series' rows in arrays on the stack for `N > 0` (their length a
    /// constant, its indices checked at compile time), else in the general size's buffers.
    #[inline(always)]
    fn free_closing<const N: usize>(
        &mut self,
        contacts: &[Contact],
        t: f64,
        state: &StepEnd,
        j: usize,
        guess: f64,
        slack: f64,
    ) -> Option<f64> {
        let sys = self.sys;
        let st = &sys.structure;
        let n = dofs::<N>(state.x.len());
        let [mass_inverse, damping, stiffness] =
            small_matrices::<N>(&self.small, &self.sized_small, n)?;
        if contacts.iter().any(|c| c.active) || st.varying_gyroscopic().is_some() {
            return None;
        }
        let mut sized_series = [[0.0; N]; SERIES_ORDER + 1];
        let mut sized_forcing = [[0.0; N]; SERIES_ORDER - 1];
        let (series, forcing): (&mut [f64], &mut [f64]) = if N > 0 {
            (
                sized_series.as_flattened_mut(),
                sized_forcing.as_flattened_mut(),
            )
        } else {
            (&mut self.series, &mut self.load_series)
        };
        // the loads' derivatives F⁽ᵏ⁾, k ≤ SERIES_ORDER − 2
        let orders = SERIES_ORDER - 1;
        forcing.fill(0.0);
        let mut derivatives = [0.0; SERIES_ORDER - 1];
        for load in &sys.loads {
            if !load.smooth_derivatives(t, &mut derivatives) {
                return None;
            }
            for (k, dk) in derivatives.iter().enumerate() {
                for &d in &load.dofs {
                    forcing[k * n + d] += dk;
                }
            }
        }
        // x⁽ᵏ⁺²⁾ = M⁻¹ (F⁽ᵏ⁾ − C x⁽ᵏ⁺¹⁾ − K x⁽ᵏ⁾)
        series[..n].copy_from_slice(&state.x[..n]);
        series[n..2 * n].copy_from_slice(&state.v[..n]);
        let mut rhs = Vector::<N>::new(&mut self.rhs, n);
        let rhs = rhs.get();
        for k in 0..orders {
            let (known, next) = series.split_at_mut((k + 2) * n);
            let (xk, xk1) = (&known[k * n..(k + 1) * n], &known[(k + 1) * n..(k + 2) * n]);
            rhs.copy_from_slice(&forcing[k * n..(k + 1) * n]);
            dense_mul_add(damping, -1.0, xk1, rhs);
            dense_mul_add(stiffness, -1.0, xk, rhs);
            for (xi, row) in next[..n].iter_mut().zip(mass_inverse.chunks_exact(n)) {
                *xi = dot(row, rhs);
            }
        }
        // k! divided out: row k holds x⁽ᵏ⁾/k!
        let mut factorial = 1.0;
        for (k, row) in series.chunks_exact_mut(n).enumerate().skip(2) {
            factorial *= k as f64;
            row.iter_mut().for_each(|x| *x /= factorial);
        }
        let [x, v, a] = &mut self.series_state;
        let mut state = [x, v, a].map(|b| Vector::<N>::new(b, n));
        let [x, v, a] = &mut state;
        let (x, v, a) = (x.get(), v.get(), a.get());
        let mut tau = guess;
        for _ in 0..CLOSING_ITERATIONS {
            for d in 0..n {
                let (mut p, mut dp, mut ddp) = (0.0, 0.0, 0.0);
                for k in (0..=SERIES_ORDER).rev() {
                    let c = series[k * n + d];
                    ddp = ddp * tau + 2.0 * dp;
                    dp = dp * tau + p;
                    p = p * tau + c;
                }
                (x[d], v[d], a[d]) = (p, dp, ddp);
            }
            let [delta, delta_rate, _] = wall_motion(sys, j, x, v, a);
            let correction = delta / delta_rate;
            tau -= correction;
            if !(tau > 0.0 && (tau - guess).abs() < 0.5 * guess) {
                return None;
            }
            // within the wall's switching window: EVENT_NEAR of the step, or its slack
            let precision = EVENT_NEAR.max(slack / tau);
            if correction.abs() <= 0.01 * precision * tau {
                // the last term, the truncation's size, within the landing's precision
                let last = series[SERIES_ORDER * n..(SERIES_ORDER + 1) * n]
                    .iter()
                    .fold(0.0, |m: f64, c| m.max(c.abs()));
                let truncated = last * tau.powi(SERIES_ORDER as i32);
                return (truncated <= precision * delta_rate.abs() * tau).then_some(tau);
            }
        }
        None
    }

    /// `a = M⁻¹ (F(t) − (C + Ω(t) G) v − K x − Σ φ_g b_gᵀ)` with the forces of the active walls; returns
    /// the power of the loads, of the damping and of the contact forces' dissipative part
    /// (the integrands of the energy account, docs/conventions.md). `root`: a wall whose
    /// penetration is given (`ζ²` of a [`Clock::Root`] step) instead of taken from `x`.
    fn accel(
        &mut self,
        contacts: &[Contact],
        root: Option<(usize, f64)>,
        t: f64,
        x: &[f64],
        v: &[f64],
        a: &mut [f64],
    ) -> [f64; 3] {
        by_size!(x.len(), |N| self
            .accel_sized::<N>(contacts, root, t, x, v, a))
    }

    /// [`Self::accel`] compiled for `N` DOFs ([`by_size`]).
    #[inline(always)]
    fn accel_sized<const N: usize>(
        &mut self,
        contacts: &[Contact],
        root: Option<(usize, f64)>,
        t: f64,
        x: &[f64],
        v: &[f64],
        a: &mut [f64],
    ) -> [f64; 3] {
        let n = dofs::<N>(x.len());
        let (x, v, a) = (&x[..n], &v[..n], &mut a[..n]);
        let sys = self.sys;
        let st = &sys.structure;
        let mut rhs = Vector::<N>::new(&mut self.rhs, n);
        let f = rhs.get();
        let external = self.loads.apply(&sys.loads, t, f, v);
        let mut contact = 0.0;
        let walls = self.walls.iter().zip(contacts).zip(&mut self.forces);
        for (j, ((wall, c), wall_force)) in walls.enumerate() {
            if !c.active {
                *wall_force = 0.0;
                continue;
            }
            let (gap, law, sign, clearance) = match *wall {
                WallTerm::Radial {
                    radial: r,
                    dofs: [ix, iy],
                    law,
                    clearance,
                } => {
                    let (k, force) = radial_wall_force(r, [ix, iy], law, clearance, c, x, v);
                    let spin = r.radius * st.spin.start;
                    let (phi, friction) = radial_force(r, &k, force.force, spin);
                    f[ix] -= phi[0];
                    f[iy] -= phi[1];
                    *wall_force = force.force;
                    contact += (force.force - force.elastic) * k.rate + friction * k.slide;
                    continue;
                }
                WallTerm::Line {
                    gap,
                    law,
                    sign,
                    clearance,
                } => (gap, law, sign, clearance),
            };
            let (mut u, mut u_rate) = (0.0, 0.0);
            for (&d, &coef) in gap.dofs.iter().zip(&gap.coefficients) {
                u += coef * x[d];
                u_rate += coef * v[d];
            }
            let penetration = match root {
                Some((w, p)) if w == j => p,
                _ => sign * u - clearance,
            };
            let rate = sign * u_rate;
            let force = force_in_contact(law, c, penetration, rate);
            for (&d, &coef) in gap.dofs.iter().zip(&gap.coefficients) {
                f[d] -= sign * coef * force.force;
            }
            *wall_force = force.force;
            contact += (force.force - force.elastic) * rate;
        }
        let small = small_matrices::<N>(&self.small, &self.sized_small, n);
        let mut damping = 0.0;
        if sys.has_damping {
            let mut cv = Vector::<N>::new(&mut self.cv, n);
            let cv = cv.get();
            match small {
                Some([_, damping, _]) => dense_mul_add(damping, 1.0, v, cv),
                None => st.damping.mul_add(1.0, v, cv),
            }
            for ((fi, ci), vi) in f.iter_mut().zip(&*cv).zip(v) {
                *fi -= ci;
                damping += ci * vi;
            }
        }
        if let Some(g) = st.varying_gyroscopic() {
            // a run-up: `damping` holds Ω(0) G; the rest of Ω(t) G x' (no power: G = −Gᵀ)
            g.mul_add(-(st.spin.speed(t) - st.spin.start), v, f);
        }
        match small {
            Some([_, _, stiffness]) if self.has_stiffness => dense_mul_add(stiffness, -1.0, x, f),
            None if self.has_stiffness => st.stiffness.mul_add(-1.0, x, f),
            _ => {}
        }
        match small {
            Some([mass_inverse, ..]) => {
                for (ai, row) in a.iter_mut().zip(mass_inverse.chunks_exact(n)) {
                    *ai = dot(row, f);
                }
            }
            None => {
                a.copy_from_slice(f);
                st.solve_mass(a);
            }
        }
        [external, damping, contact]
    }

    /// Evaluates the right-hand side at a step's end: its acceleration, powers and forces,
    /// and each wall's motion.
    fn at(&mut self, contacts: &[Contact], root: Option<(usize, f64)>, t: f64, end: &mut StepEnd) {
        end.power = self.accel(contacts, root, t, &end.x, &end.v, &mut end.a);
        end.forces.copy_from_slice(&self.forces);
        for (motion, wall) in end.walls.iter_mut().zip(&self.walls) {
            *motion = wall.motion(&end.x, &end.v, &end.a);
        }
    }
}

/// Values kept per component: the 12 stages of a step, the next step's first (FSAL) and the
/// dense output's three.
const K: usize = DENSE_STAGES;

/// Stage values of one step, stored per component so that each combination of stages is a
/// dot product over one fixed-size row (its length a constant, not a stride kept by hand):
/// `kx[d][i]` is DOF `d`'s velocity at stage `i`, `kv` its
/// acceleration, `kp[p][i]` the power `p` of the energy account, `kf[w][i]` wall `w`'s
/// force.
struct Stages {
    kx: Rows,
    kv: Rows,
    kp: [[f64; K]; 3],
    /// Which powers can be nonzero: the loads' (the model has loads), the damping's (it has
    /// damping), the contact forces'; the others' work stays 0 without being integrated.
    powers: [bool; 3],
    kf: Vec<[f64; K]>,
    /// `dt/dζ` per stage of a [`Clock::Root`] step.
    kt: [f64; K],
    xs: Vec<f64>,
    vs: Vec<f64>,
    acc: Vec<f64>,
}

/// One row of stage values per component.
type Rows = Inline<[f64; K]>;

/// The end of a step.
struct StepEnd {
    x: Inline<f64>,
    v: Inline<f64>,
    a: Inline<f64>,
    power: [f64; 3],
    /// Each wall's force, N.
    forces: Vec<f64>,
    /// Increments over the step of the work integrals, J, and of each wall's impulse, N·s.
    work: [f64; 3],
    impulse: Vec<f64>,
    /// Each wall's penetration (m), its rate and acceleration ([`wall_motion`]).
    walls: Vec<[f64; 3]>,
}

/// `Σ_j w_j k_j` over the first `w.len()` stage values `k`.
#[inline]
fn dot(w: &[f64], k: &[f64]) -> f64 {
    w.iter().zip(k).map(|(w, k)| w * k).sum()
}

/// [`dot`] over a row `w` of the tableau, whose zero weights (a quarter of `A`'s and `B`'s)
/// are left out: the rows are constants, so the terms go at compile time. The same sum where
/// it is finite (a zero weight's term is a zero, which leaves a sum unchanged).
#[inline(always)]
fn combine(w: &[f64], k: &[f64; K]) -> f64 {
    w.iter()
        .zip(k)
        .filter(|(w, _)| **w != 0.0)
        .map(|(w, k)| w * k)
        .sum()
}

/// Stores stage `i`'s values `values` (one per component), times `scale`, into `k`.
#[inline]
fn store(k: &mut [[f64; K]], i: usize, values: &[f64], scale: f64) {
    for (row, &v) in k.iter_mut().zip(values) {
        row[i] = scale * v;
    }
}

/// The independent variable of a step.
#[derive(Debug, Clone, Copy)]
enum Clock {
    /// The time.
    Time,
    /// `ζ = √δ` of wall `wall`, from `from` (Hénon's change of variable, 1982, made regular
    /// at `δ = 0` by the square root): near a contact's start and end `δ ≈ v_imp (t − t₀)`,
    /// so a force `∝ δ^1.5` is `∝ ζ³` and the motion is analytic in `ζ` where in `t` it is
    /// not (a term `∝ (t − t₀)^3.5`). With `dt/dζ = 2ζ/δ'`, `δ(x) − ζ²` is conserved
    /// exactly, a step to `ζ = 0` ends on the opening, and eighth order holds up to it.
    /// `offset`: the wall's penetration at `ζ = 0` (< 0 for a closing switched on just
    /// before the wall), so that the force sees `δ = ζ² + offset`, the motion's penetration.
    Root { wall: usize, from: f64, offset: f64 },
}

impl Clock {
    /// The wall and its penetration `ζ²` at the fraction `c` of a step `h`.
    #[inline]
    fn penetration(self, c: f64, h: f64) -> Option<(usize, f64)> {
        match self {
            Clock::Time => None,
            Clock::Root { wall, from, offset } => Some((wall, (from + c * h).powi(2) + offset)),
        }
    }

    /// `dt/dζ` at the fraction `c` of a step `h` with velocities `v` (1 for the time);
    /// `None` if the wall's penetration does not move the way `ζ` does there.
    #[inline]
    fn dt_dvar(self, sys: &System, c: f64, h: f64, v: &[f64]) -> Option<f64> {
        match self {
            Clock::Time => Some(1.0),
            Clock::Root { wall, from, .. } => {
                let rate = toward_wall(sys, wall, v);
                (rate * h > 0.0).then(|| 2.0 * (from + c * h) / rate)
            }
        }
    }
}

impl Stages {
    fn new(sys: &System) -> Self {
        let n = sys.n_dof();
        Self {
            kx: Rows::new(n, [0.0; K]),
            kv: Rows::new(n, [0.0; K]),
            kp: [[0.0; K]; 3],
            powers: [!sys.loads.is_empty(), sys.has_damping, true],
            kf: vec![[0.0; K]; sys.walls.len()],
            kt: [0.0; K],
            xs: vec![0.0; n],
            vs: vec![0.0; n],
            acc: vec![0.0; n],
        }
    }

    /// One step of `h` in the `clock`'s variable from `start` (its `a`, `power` and forces
    /// the first stage) into `end`; returns the step's duration, or `None` if a
    /// [`Clock::Root`] step's wall turns inside it (the step must be shorter).
    #[allow(clippy::too_many_arguments)]
    fn step(
        &mut self,
        dynamics: &mut Dynamics,
        contacts: &[Contact],
        clock: Clock,
        t0: f64,
        start: &StepEnd,
        h: f64,
        end: &mut StepEnd,
    ) -> Option<f64> {
        by_size!(start.x.len(), |N| self
            .step_sized::<N>(dynamics, contacts, clock, t0, start, h, end))
    }

    /// [`Self::step`] compiled for `N` DOFs ([`by_size`]).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn step_sized<const N: usize>(
        &mut self,
        dynamics: &mut Dynamics,
        contacts: &[Contact],
        clock: Clock,
        t0: f64,
        start: &StepEnd,
        h: f64,
        end: &mut StepEnd,
    ) -> Option<f64> {
        let n = dofs::<N>(start.x.len());
        let g = clock.dt_dvar(dynamics.sys, 0.0, h, &start.v)?;
        self.kt[0] = g;
        store(self.kx.sized_mut::<N>(), 0, start.v.sized::<N>(), g);
        store(self.kv.sized_mut::<N>(), 0, start.a.sized::<N>(), g);
        store(&mut self.kp, 0, &start.power, g);
        store(&mut self.kf, 0, &start.forces, g);
        let root = matches!(clock, Clock::Root { .. });
        // each stage its own code: its row of `A` a constant, its combination unrolls; and
        // compiled apart for a step in time, where `dt/dvar` is 1 and no wall's penetration
        // is given
        macro_rules! stages {
            ($this:expr, $state:expr, $in_time:literal; $($i:literal)*) => {
                $($this.stage::<N, $i, $in_time>($state, dynamics, contacts, clock, t0, start, h)?;)*
            };
        }
        self.with_state::<N, _>(n, |this, mut state| {
            if root {
                stages!(this, &mut state, false; 1 2 3 4 5 6 7 8 9 10 11);
            } else {
                stages!(this, &mut state, true; 1 2 3 4 5 6 7 8 9 10 11);
            }
            Some(())
        })?;
        const _: () = assert!(
            STAGES == 12,
            "one `stages!` entry per stage after the first"
        );
        for ((((x1, v1), kx), kv), (x0, v0)) in end
            .x
            .sized_mut::<N>()
            .iter_mut()
            .zip(end.v.sized_mut::<N>().iter_mut())
            .zip(self.kx.sized::<N>().iter())
            .zip(self.kv.sized::<N>().iter())
            .zip(start.x.sized::<N>().iter().zip(start.v.sized::<N>()))
        {
            *x1 = x0 + h * combine(&B, kx);
            *v1 = v0 + h * combine(&B, kv);
        }
        for ((w, kp), &used) in end.work.iter_mut().zip(self.kp.iter()).zip(&self.powers) {
            *w = if used { h * combine(&B, kp) } else { 0.0 };
        }
        for ((impulse, kf), c) in end.impulse.iter_mut().zip(self.kf.iter()).zip(contacts) {
            *impulse = if c.active { h * combine(&B, kf) } else { 0.0 };
        }
        let duration = if root { h * combine(&B, &self.kt) } else { h };
        dynamics.at(contacts, clock.penetration(1.0, h), t0 + duration, end);
        // the end's rate may be zero on a step to ζ = 0 only if the wall grazes (not
        // integrated in ζ), so its `dt/dζ` is finite; the first-same-as-last stage
        let g = clock.dt_dvar(dynamics.sys, 1.0, h, &end.v)?;
        self.kt[STAGES] = g;
        store(self.kx.sized_mut::<N>(), STAGES, end.v.sized::<N>(), g);
        store(self.kv.sized_mut::<N>(), STAGES, end.a.sized::<N>(), g);
        store(&mut self.kp, STAGES, &end.power, g);
        Some(duration)
    }

    /// Runs `body` with the stage's state and acceleration (`xs`, `vs`, `acc`) as working
    /// vectors compiled for `N` DOFs ([`Vector`]).
    #[inline(always)]
    fn with_state<const N: usize, R>(
        &mut self,
        n: usize,
        body: impl FnOnce(&mut Self, [&mut [f64]; 3]) -> R,
    ) -> R {
        let mut general: [Vec<f64>; 3] = if N == 0 {
            [&mut self.xs, &mut self.vs, &mut self.acc].map(std::mem::take)
        } else {
            Default::default()
        };
        let [xs, vs, acc] = &mut general;
        let [mut xs, mut vs, mut acc] = [xs, vs, acc].map(|b| Vector::<N>::new(b, n));
        let result = body(self, [xs.get(), vs.get(), acc.get()]);
        if N == 0 {
            [self.xs, self.vs, self.acc] = general;
        }
        result
    }

    /// Stage `I` of a step: its state (into `state`: `xs`, `vs`, `acc`) from the stages
    /// before it, the right-hand side there, kept; `None` as [`Self::step`]. `IN_TIME`: the
    /// `clock` is [`Clock::Time`].
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn stage<const N: usize, const I: usize, const IN_TIME: bool>(
        &mut self,
        state: &mut [&mut [f64]; 3],
        dynamics: &mut Dynamics,
        contacts: &[Contact],
        clock: Clock,
        t0: f64,
        start: &StepEnd,
        h: f64,
    ) -> Option<()> {
        let [xs, vs, acc] = state;
        let a = A[I];
        self.stage_state::<N>(a, start, h, xs, vs);
        let (t, g, wall) = if IN_TIME {
            (t0 + C[I] * h, 1.0, None)
        } else {
            (
                t0 + h * combine(a, &self.kt),
                clock.dt_dvar(dynamics.sys, C[I], h, vs)?,
                clock.penetration(C[I], h),
            )
        };
        // the right-hand side at the stage's size, inlined into the stage: no call and no
        // dispatch on the size per evaluation
        let power = dynamics.accel_sized::<N>(contacts, wall, t, xs, vs, acc);
        self.kt[I] = g;
        self.keep::<N>(I, g, power, &dynamics.forces, vs, acc);
        Some(())
    }

    /// Hairer's error norm of the last step (≤ 1 is acceptable): the fifth-order estimate
    /// damped by the third-order one, `|h| ‖e₅‖² / √((‖e₅‖² + 0.01 ‖e₃‖²) N)`, with each
    /// displacement scaled by `atol + rtol |x|` and each velocity by
    /// `atol / dt_max + rtol v_max` (`v_max` the DOF's largest speed so far), and the three work
    /// integrals of the energy account by `rtol` times the run's `energy` scale. A `rough` step
    /// (the first of a contact, where a Hertzian force grows like `t^1.5` and no
    /// expansion in `h` holds) takes the larger of the two estimates instead: there the
    /// damped one can fall several times below the true error. A [`Clock::Root`] step's
    /// duration is checked too, scaled by the time in which the wall's gap coordinate moves
    /// by its tolerance. Returns the norm and, for the next step's size, the same estimates
    /// measured in the next step's scales ([`Self::motion_error`]).
    #[allow(clippy::too_many_arguments)]
    fn error(
        &self,
        sys: &System,
        clock: Clock,
        tol: &Adaptive,
        dt_max: f64,
        start: &StepEnd,
        end: &StepEnd,
        v_max: &[f64],
        energy: f64,
        h: f64,
        rough: bool,
    ) -> [f64; 2] {
        let ahead = matches!(clock, Clock::Time).then_some(h);
        let [mut e5, mut e3, mut e5_next, mut e3_next] = by_size!(start.x.len(), |N| self
            .motion_error::<N>(tol, dt_max, start, end, v_max, ahead));
        let mut components = 2 * start.x.len();
        if let Clock::Root { wall, .. } = clock {
            let at = |y0: &[f64], y1: &[f64]| {
                toward_wall(sys, wall, y0)
                    .abs()
                    .max(toward_wall(sys, wall, y1).abs())
            };
            let st = (tol.atol + tol.rtol * at(&start.x, &end.x)) / at(&start.v, &end.v);
            let (d5, d3) = (
                (combine(&E5, &self.kt) / st).powi(2),
                (combine(&E3, &self.kt) / st).powi(2),
            );
            (e5, e3, e5_next, e3_next) = (e5 + d5, e3 + d3, e5_next + d5, e3_next + d3);
            components += 1;
        }
        let motion = [
            norm(e5, e3, components as f64, h, rough),
            norm(e5_next, e3_next, components as f64, h, rough),
        ];
        // the energy account's work integrals: their integrands may have kinks that the
        // motion hardly feels (a tabulated law's loading curve while it unloads)
        let se = tol.rtol * energy;
        if se <= 0.0 {
            return motion;
        }
        let (mut w5, mut w3) = (0.0, 0.0);
        for (kp, _) in self.kp.iter().zip(self.powers).filter(|(_, used)| *used) {
            w5 += (combine(&E5, kp) / se).powi(2);
            w3 += (combine(&E3, kp) / se).powi(2);
        }
        let work = norm(w5, w3, 3.0, h, rough);
        motion.map(|m| m.max(work))
    }

    /// The sums of the squared scaled fifth- and third-order error estimates of the `n` DOFs'
    /// displacements and velocities ([`Self::error`]), then the same sums with each
    /// displacement scaled as the next step of the same length `ahead` (s) will scale it, from
    /// the step's end and its end extrapolated at constant acceleration: where a
    /// displacement's scale `atol + rtol |x|` shrinks (a rotor's orbit passing near the
    /// centre), the next step's error grows by as much, and a step sized on the last one's
    /// scale is rejected (without `ahead`, a step in `ζ`: the same sums).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn motion_error<const N: usize>(
        &self,
        tol: &Adaptive,
        dt_max: f64,
        start: &StepEnd,
        end: &StepEnd,
        v_max: &[f64],
        ahead: Option<f64>,
    ) -> [f64; 4] {
        let n = dofs::<N>(start.x.len());
        let (mut e5, mut e3) = (0.0, 0.0);
        let (mut e5_next, mut e3_next) = (0.0, 0.0);
        let ends = (start.x.sized::<N>().iter().zip(end.x.sized::<N>()))
            .zip(end.v.sized::<N>())
            .zip(&v_max[..n]);
        let stages = (self.kx.sized::<N>().iter()).zip(self.kv.sized::<N>());
        for (((((&x0, &x1), &v1), &speed), (kx, kv)), &a1) in
            ends.zip(stages).zip(end.a.sized::<N>())
        {
            let sx = tol.atol + tol.rtol * x0.abs().max(x1.abs());
            let sv = tol.atol / dt_max + tol.rtol * speed.max(v1.abs());
            let (x5, x3) = (combine(&E5, kx), combine(&E3, kx));
            let (v5, v3) = (
                (combine(&E5, kv) / sv).powi(2),
                (combine(&E3, kv) / sv).powi(2),
            );
            e5 += (x5 / sx).powi(2) + v5;
            e3 += (x3 / sx).powi(2) + v3;
            let sx_next = match ahead {
                Some(h) => tol.atol + tol.rtol * x1.abs().max((x1 + h * (v1 + 0.5 * h * a1)).abs()),
                None => sx,
            };
            e5_next += (x5 / sx_next).powi(2) + v5;
            e3_next += (x3 / sx_next).powi(2) + v3;
        }
        [e5, e3, e5_next, e3_next]
    }

    /// The state of a stage with coefficients `a` over the stages before it, into `xs`, `vs`.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn stage_state<const N: usize>(
        &self,
        a: &[f64],
        start: &StepEnd,
        h: f64,
        xs: &mut [f64],
        vs: &mut [f64],
    ) {
        // the size a constant here too (inside a closure that is not inlined, a captured
        // count would be read at run time)
        let n = dofs::<N>(start.x.len());
        for ((((xs, vs), kx), kv), (x0, v0)) in xs[..n]
            .iter_mut()
            .zip(vs[..n].iter_mut())
            .zip(self.kx.sized::<N>().iter())
            .zip(self.kv.sized::<N>().iter())
            .zip(start.x.sized::<N>().iter().zip(start.v.sized::<N>()))
        {
            *xs = x0 + h * combine(a, kx);
            *vs = v0 + h * combine(a, kv);
        }
    }

    /// Keeps stage `i`'s rates (the velocities `vs`, the accelerations `acc`, the powers and
    /// the wall forces) times `dt/dvar`.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn keep<const N: usize>(
        &mut self,
        i: usize,
        dt_dvar: f64,
        power: [f64; 3],
        forces: &[f64],
        vs: &[f64],
        acc: &[f64],
    ) {
        let n = dofs::<N>(vs.len());
        store(self.kx.sized_mut::<N>(), i, &vs[..n], dt_dvar);
        store(self.kv.sized_mut::<N>(), i, &acc[..n], dt_dvar);
        store(&mut self.kp, i, &power, dt_dvar);
        store(&mut self.kf, i, forces, dt_dvar);
    }

    /// The three extra stages of the dense output of the last step in time (Hairer's
    /// continuous extension of order 7), compiled for `N` DOFs ([`by_size`]).
    #[inline(always)]
    fn extend<const N: usize>(
        &mut self,
        dynamics: &mut Dynamics,
        contacts: &[Contact],
        t0: f64,
        start: &StepEnd,
        h: f64,
    ) {
        let n = dofs::<N>(start.x.len());
        self.with_state::<N, _>(n, |this, mut state| {
            // each stage its own code, as the step's: its row of `A_DENSE` a constant (in a
            // loop over the rows, each zero weight was tested at run time)
            this.dense_stage::<N, 0>(&mut state, dynamics, contacts, t0, start, h);
            this.dense_stage::<N, 1>(&mut state, dynamics, contacts, t0, start, h);
            this.dense_stage::<N, 2>(&mut state, dynamics, contacts, t0, start, h);
        });
        const _: () = assert!(A_DENSE.len() == 3, "one `dense_stage` per extra stage");
    }

    /// Extra stage `M` of the dense output ([`Self::extend`]).
    #[inline(always)]
    fn dense_stage<const N: usize, const M: usize>(
        &mut self,
        state: &mut [&mut [f64]; 3],
        dynamics: &mut Dynamics,
        contacts: &[Contact],
        t0: f64,
        start: &StepEnd,
        h: f64,
    ) {
        let [xs, vs, acc] = state;
        self.stage_state::<N>(A_DENSE[M], start, h, xs, vs);
        let t = t0 + C_DENSE[M] * h;
        let power = dynamics.accel_sized::<N>(contacts, None, t, xs, vs, acc);
        self.keep::<N>(STAGES + 1 + M, 1.0, power, &dynamics.forces, vs, acc);
    }

    /// DOF `d`'s displacement and velocity at the fraction `s` of the last step in time, on
    /// its dense output ([`Self::extend`] first): with `y` either,
    /// `y₀ + s(F₀ + (1−s)(F₁ + s(F₂ + (1−s)(F₃ + s(F₄ + (1−s)(F₅ + s F₆))))))`.
    fn dense(&self, d: usize, start: &StepEnd, end: &StepEnd, h: f64, s: f64) -> [f64; 2] {
        [
            self.dense_displacement(d, start, end, h, s),
            dense_column(
                &self.kv[d],
                [start.v[d], end.v[d]],
                [start.a[d], end.a[d]],
                h,
                s,
            ),
        ]
    }

    /// [`Self::dense`]'s displacement alone (where a displacement turns, its value).
    fn dense_displacement(&self, d: usize, start: &StepEnd, end: &StepEnd, h: f64, s: f64) -> f64 {
        dense_column(
            &self.kx[d],
            [start.x[d], end.x[d]],
            [start.v[d], end.v[d]],
            h,
            s,
        )
    }
}

/// One component `y` of [`Stages::dense`] from its stage values `k`, its values `y` and rates
/// `f` at the step's ends.
#[inline]
fn dense_column(k: &[f64; K], [y0, y1]: [f64; 2], [f0, f1]: [f64; 2], h: f64, s: f64) -> f64 {
    let dy = y1 - y0;
    let f = [
        dy,
        h * f0 - dy,
        2.0 * dy - h * (f1 + f0),
        h * combine(&D[0], k),
        h * combine(&D[1], k),
        h * combine(&D[2], k),
        h * combine(&D[3], k),
    ];
    let mut y = 0.0;
    for (i, fi) in f.iter().enumerate().rev() {
        y = (y + fi) * if i % 2 == 0 { s } else { 1.0 - s };
    }
    y0 + y
}

/// `x^(1/8)` by three square roots (a `powf` costs several times more, once or twice a step).
#[inline]
fn eighth_root(x: f64) -> f64 {
    x.sqrt().sqrt().sqrt()
}

/// The step's growth factor for the error norm `err` of an eighth-order step,
/// `0.9 err^(−1/8)` (before its bounds).
#[inline]
fn step_factor(err: f64) -> f64 {
    0.9 / eighth_root(err)
}

/// Hairer's norm from the sums of squares `e5`, `e3` of the scaled estimates over
/// `components`; a `rough` step takes the larger estimate undamped.
fn norm(e5: f64, e3: f64, components: f64, h: f64, rough: bool) -> f64 {
    if e5 == 0.0 && e3 == 0.0 {
        return 0.0;
    }
    if rough {
        return h.abs() * (e5.max(e3) / components).sqrt();
    }
    h.abs() * e5 / ((e5 + 0.01 * e3) * components).sqrt()
}

/// Wall `j`'s gap coordinate `b·y` of a state vector `y`, signed towards the wall.
#[inline]
fn toward_wall(sys: &System, j: usize, y: &[f64]) -> f64 {
    let wall = &sys.walls[j];
    signed_coordinate(&sys.gaps[wall.gap], wall.sign, y)
}

/// Gap `g`'s coordinate `b·y` of a state vector `y`, times `sign` (a wall's, towards it).
#[inline]
fn signed_coordinate(g: &Gap, sign: f64, y: &[f64]) -> f64 {
    let u: f64 = g
        .dofs
        .iter()
        .zip(&g.coefficients)
        .map(|(&d, &c)| c * y[d])
        .sum();
    sign * u
}

/// Wall `j`'s penetration, rate and acceleration at a state ([`WallTerm::motion`]).
fn wall_motion(sys: &System, j: usize, x: &[f64], v: &[f64], a: &[f64]) -> [f64; 3] {
    WallTerm::new(sys, j).motion(x, v, a)
}

/// Switches the walls that close or open (or pass their first peak) at the state: a closing
/// wall takes the approach speed as `v_imp`. Returns whether any wall switched and the last
/// wall that closed. A wall whose force continues through it ([`continues_through_wall`])
/// switches on its penetration `δ + τ δ̇ + τ² δ̈ / 2` at the end of the window `τ`, the larger
/// of `tol_t` and `within` (s, the next step's event window): it opens where it would open
/// inside the window (the next step would not land on an opening that near its start, and
/// would apply the tensile force all along), and a grazing touch that would be over inside
/// the window (its penetration below `|δ̈| τ² / 8`) is not closed.
fn switch_walls(
    sys: &System,
    contacts: &mut [Contact],
    slack: &[f64],
    state: &StepEnd,
    tol_t: f64,
    within: f64,
) -> (bool, Option<usize>) {
    let (mut switched, mut closed) = (false, None);
    for (j, c) in contacts.iter_mut().enumerate() {
        let [delta, rate, accel] = state.walls[j];
        let continues = continues_through_wall(&sys.gaps[sys.walls[j].gap].law);
        let near = tol_t.max(slack[j]);
        let window = near.max(within);
        let ahead = delta + window * (rate + 0.5 * accel * window);
        let closes = rate > 0.0 && delta + rate * near >= 0.0 && !(continues && ahead < 0.0);
        let opens = if continues {
            ahead <= 0.0
        } else {
            rate < 0.0 && delta + rate * tol_t <= 0.0
        };
        if !c.active && closes {
            *c = Contact {
                active: true,
                impact_speed: rate.max(MIN_IMPACT_SPEED),
                max_penetration: delta.max(0.0),
                peak_pending: true,
                in_time: !smooth_in_root(sys, j),
                released: false,
            };
            switched = true;
            closed = Some(j);
        } else if c.active && opens {
            *c = Contact::default();
            switched = true;
        } else if c.active && c.peak_pending && rate <= accel.abs() * tol_t {
            c.peak_pending = false;
        }
    }
    (switched, closed)
}

/// Whether gap `g`'s force jumps at its wall's onset (Kelvin–Voigt's `c δ̇` with `c > 0`):
/// switched up to [`EVENT_NEAR`] of a step early, it would act that long before the wall is
/// reached (an error of `c δ̇` times that time in the momentum, 5.6e-7 in the velocity of the
/// test oscillator at `rtol = 1e-11`), so the steps land on its switches to round-off.
fn jumps_at_onset(sys: &System, g: usize) -> bool {
    matches!(sys.gaps[g].law, Law::KelvinVoigt(law) if law.damping > 0.0)
}

/// Marks the active walls whose law's force (its formula, before the clamp to compressive)
/// has fallen to zero at the state, within `tol_t` (s), while the wall is still in: there the
/// force is clamped and the vector field's slope jumps (Kelvin–Voigt's `k δ + c δ̇`, strongly
/// damped laws). Returns whether any wall was released. The motion's force is continuous
/// there: only the landing on switches to round-off (`exact_switches`) needs to know it.
fn release_walls(sys: &System, contacts: &mut [Contact], state: &StepEnd, tol_t: f64) -> bool {
    let mut released = false;
    for (j, c) in contacts.iter_mut().enumerate() {
        if !c.active || c.released || state.walls[j][0] <= 0.0 || is_radial(sys, j) {
            continue;
        }
        let (force, rate) = force_formula(sys, j, c, state.walls[j]);
        if rate < 0.0 && force + rate * tol_t <= 0.0 {
            c.released = true;
            released = true;
        }
    }
    released
}

/// Wall `j`'s force formula (not clamped) and its rate at its motion `[δ, δ̇, δ̈]` in the
/// contact `c`.
fn force_formula(
    sys: &System,
    j: usize,
    c: &Contact,
    [delta, rate, accel]: [f64; 3],
) -> (f64, f64) {
    let law = &sys.gaps[sys.walls[j].gap].law;
    let f = law.evaluate_in_contact(delta, rate, c.impact_speed, c.max_penetration.max(delta));
    (f.force, f.d_penetration * rate + f.d_rate * accel)
}

fn is_radial(sys: &System, j: usize) -> bool {
    matches!(sys.gaps[sys.walls[j].gap].side, Side::Radial(_))
}

/// What happens to a wall inside a step.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Event {
    Closing,
    Opening,
    /// The first peak of the penetration.
    Peak,
    /// The force falls to zero while the wall is still in (its law's formula turns tensile
    /// and is clamped: Kelvin–Voigt, strongly damped laws).
    Release,
}

/// The first event inside a step: its fraction of the step, its wall and kind (a peak only
/// with `peaks`), if one lies more than `tol_t` inside the step (a wall's closing or opening
/// more than its `slack`, s, too).
#[allow(clippy::too_many_arguments)]
fn first_event(
    sys: &System,
    contacts: &[Contact],
    slack: &[f64],
    start: &StepEnd,
    end: &StepEnd,
    h: f64,
    tol_t: f64,
    peaks: bool,
) -> Option<(f64, usize, Event)> {
    let within = |tol: f64| move |s: &f64| s * h > tol && (1.0 - s) * h > tol;
    let inside = within(tol_t);
    let mut first: Option<(f64, usize, Event)> = None;
    for (j, c) in contacts.iter().enumerate() {
        let seg = QuinticSegment::new(start.walls[j], end.walls[j], h);
        let crossing = seg
            .first_crossing(false, !c.active, EVENT_SAMPLES)
            .filter(within(tol_t.max(slack[j])))
            .map(|s| {
                (
                    s,
                    if c.active {
                        Event::Opening
                    } else {
                        Event::Closing
                    },
                )
            });
        let peak = if peaks && c.active && c.peak_pending && turns_at_peak(sys, j) {
            seg.first_crossing(true, false, EVENT_SAMPLES)
                .filter(inside)
                .map(|s| (s, Event::Peak))
        } else {
            None
        };
        // a force clamped to zero at the step's end: where its formula turned tensile while
        // the wall was still in, a kink
        let clamped = c.active && start.forces[j] > 0.0 && end.forces[j] == 0.0;
        let release = clamped
            .then(|| release(&sys.gaps[sys.walls[j].gap].law, c, &seg, h))
            .flatten()
            .filter(inside)
            .map(|s| (s, Event::Release));
        for (s, event) in crossing.into_iter().chain(peak).chain(release) {
            if first.is_none_or(|(f, _, _)| s < f) {
                first = Some((s, j, event));
            }
        }
    }
    first
}

/// Where a contact force's formula (before the clamp to compressive) falls to zero inside a
/// step while the wall is still in, along the wall's interpolated penetration `seg`:
/// bracketed on [`EVENT_SAMPLES`] points, then bisected to round-off (`None` if the
/// penetration reaches zero first: an opening).
fn release(law: &Law, c: &Contact, seg: &QuinticSegment, h: f64) -> Option<f64> {
    let force = |s: f64| {
        let penetration = seg.value(s);
        let max_penetration = c.max_penetration.max(penetration);
        law.evaluate_in_contact(
            penetration,
            seg.slope(s) / h,
            c.impact_speed,
            max_penetration,
        )
        .force
    };
    let n = EVENT_SAMPLES as f64;
    let k = (1..=EVENT_SAMPLES)
        .take_while(|&k| seg.value(k as f64 / n) > 0.0)
        .find(|&k| force(k as f64 / n) <= 0.0)?;
    let (mut lo, mut hi) = ((k - 1) as f64 / n, k as f64 / n);
    while hi - lo > 1e-13 {
        let mid = 0.5 * (lo + hi);
        if force(mid) > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(hi)
}

/// The earliest time after `state` at which an open wall closes if every wall's
/// penetration kept its present acceleration, and that wall.
fn predicted_closing(contacts: &[Contact], state: &StepEnd) -> Option<(f64, usize)> {
    let mut first: Option<(f64, usize)> = None;
    for (j, c) in contacts.iter().enumerate() {
        let [delta, rate, accel] = state.walls[j];
        if c.active || delta >= 0.0 {
            continue;
        }
        // δ + rate τ + accel τ²/2 = 0, its roots without cancellation
        let disc = rate * rate - 2.0 * accel * delta;
        if disc < 0.0 {
            continue;
        }
        let q = -0.5 * (rate + rate.signum() * disc.sqrt());
        let roots = [q / (0.5 * accel), delta / q];
        for tau in roots.into_iter().filter(|t| t.is_finite() && *t > 0.0) {
            if first.is_none_or(|(f, _)| tau < f) {
                first = Some((tau, j));
            }
        }
    }
    first
}

/// Whether wall `j`'s force law turns at the penetration's peak (a tabulated law onto its
/// unloading curve), so that a step must end there; through any other law the motion is
/// smooth at the peak, which [`Inside::scan`] finds inside the step.
fn turns_at_peak(sys: &System, j: usize) -> bool {
    matches!(sys.gaps[sys.walls[j].gap].law, Law::Tabulated(_))
}

/// A contact's start or end integrated in `ζ = √δ` of its wall ([`Clock::Root`]).
#[derive(Debug, Clone, Copy)]
struct RootPhase {
    wall: usize,
    /// The contact starts (`ζ` grows from 0: one step) rather than ends (`ζ` falls to 0).
    rising: bool,
    /// Length of the next step in `ζ`, m^½.
    dz: f64,
    /// Steps of the phase rejected so far.
    rejections: usize,
    /// The time step proposed when the phase began, taken after it.
    h_after: f64,
}

/// Rejections after which a contact's start or end is integrated in time instead of in `ζ`
/// (a grazing wall, whose penetration turns within the first steps; a force with a kink).
const MAX_ROOT_REJECTIONS: usize = 6;

/// Whether a contact's start and end are integrated in `ζ = √δ`: the force is a power of
/// `δ` times a smooth factor, so smooth in `ζ`. Not a tabulated law (kinks at its points) nor
/// Kelvin–Voigt (linear, so already smooth in time; it ends where its clamp at `F = 0`
/// kinks, before `δ = 0`), nor a radial wall (its `δ` is not linear in the state).
fn smooth_in_root(sys: &System, j: usize) -> bool {
    let gap = &sys.gaps[sys.walls[j].gap];
    !matches!(gap.side, Side::Radial(_))
        && !matches!(
            gap.law,
            Law::Tabulated(_) | Law::KelvinVoigt(_) | Law::Rigid(_)
        )
}

/// The phase that integrates wall `j`'s opening in `ζ` from `start`, if the wall is inside
/// and on its way out there (past its peak).
fn opening_phase(contact: &Contact, j: usize, start: &StepEnd, h: f64) -> Option<RootPhase> {
    let [delta, rate, _] = start.walls[j];
    let past_peak = delta > 0.0 && delta < contact.max_penetration && rate < 0.0;
    (!contact.in_time && past_peak).then(|| RootPhase {
        wall: j,
        rising: false,
        dz: delta.sqrt(),
        rejections: 0,
        h_after: h,
    })
}

/// DOP853's steps: what carries from one step to the next (see the module doc).
pub(crate) struct Dop853Steps<'s> {
    steps: Steps,
    t_end: f64,
    /// Events this close to `t_end` (s) are switched, not landed on.
    tol_t: f64,
    dynamics: Dynamics<'s>,
    stages: Stages,
    contacts: Vec<Contact>,
    /// The step's ends, boxed: their DOF vectors are inline ([`Inline`]), and a step's end
    /// becomes the next one's start by swapping two pointers.
    start: Box<StepEnd>,
    end: Box<StepEnd>,
    /// The DOFs whose turning points the peaks and the sweeps' observers need.
    recorded: Vec<usize>,
    inside: Inside,
    v_max: Vec<f64>,
    /// The next step's size, s.
    h: f64,
    dt_fixed: Option<f64>,
    /// A step to retake ending on an event: its length and whether the event is singular.
    landing: Option<(f64, bool)>,
    landings: usize,
    /// The last attempt was rejected for its error: the next accepted step does not grow.
    rejected: bool,
    /// The first accepted step of the last contact: the first step of the next one, if it
    /// is not integrated in ζ.
    h_contact: Option<f64>,
    /// The step proposed when the last contact began from free motion.
    h_free: Option<f64>,
    /// The step in ζ of the last contact's start: the first try of the next one.
    dz_contact: Option<f64>,
    /// A wall closed at the start of the pending step (its size goes to `h_contact`).
    contact_started: bool,
    /// A contact's start or end in progress in ζ (adaptive steps only).
    root: Option<RootPhase>,
    /// Length and error of the last accepted step, for the predictive controller.
    last: Option<(f64, f64)>,
    grid_step: usize,
    /// How close (s) to a wall's event the last step ended for the wall to be switched.
    near_switch: f64,
    /// How far (s) each wall's closing or opening may lie from a step's end and be switched
    /// there ([`switch_slack`]).
    slack: Vec<f64>,
    /// Steps land on every switch to round-off ([`landing_correction`]): the
    /// state-transition matrix differentiates the landing condition, and a force that jumps
    /// at its wall's onset ([`jumps_at_onset`]) must not act before it.
    exact_switches: bool,
    /// The state-transition matrix, when the run asks for it (`Run::wants_sensitivity`).
    variational: Option<Variational>,
}

impl<'s> Dop853Steps<'s> {
    /// From `run.cur`, to `t_end`.
    pub fn new(run: &Run, sys: &'s System, steps: Steps, t_end: f64) -> Self {
        let n = sys.n_dof();
        let tol_t = EVENT_TOL * t_end;
        let mut dynamics = Dynamics::new(sys);
        let stages = Stages::new(sys);
        let mut contacts: Vec<Contact> = run
            .cur
            .walls
            .iter()
            .enumerate()
            .map(|(j, w)| Contact {
                active: w.closed(),
                impact_speed: w.impact_speed,
                max_penetration: w.max_penetration,
                peak_pending: w.closed() && w.rate > 0.0,
                in_time: !smooth_in_root(sys, j),
                released: false,
            })
            .collect();
        let variational = run
            .wants_sensitivity
            .then(|| Variational::new(sys, run.sensitivity_parameter));
        if variational.is_some() {
            in_time_only(&mut contacts);
        }
        let fresh = || StepEnd {
            x: Inline::new(n, 0.0),
            v: Inline::new(n, 0.0),
            a: Inline::new(n, 0.0),
            power: [0.0; 3],
            forces: vec![0.0; sys.walls.len()],
            work: [0.0; 3],
            impulse: vec![0.0; sys.walls.len()],
            walls: vec![[0.0; 3]; sys.walls.len()],
        };
        let mut start = Box::new(fresh());
        start.x.copy_from_slice(&run.cur.x);
        start.v.copy_from_slice(&run.cur.v);
        dynamics.at(&contacts, None, run.cur.t, &mut start);
        let exact_switches =
            variational.is_some() || sys.walls.iter().any(|w| jumps_at_onset(sys, w.gap));
        let slack = match steps {
            Steps::Adaptive { tol, .. } if !exact_switches => switch_slack(
                sys,
                dynamics.small.as_ref().map(|s| &s.mass_inverse[..]),
                tol.rtol,
            ),
            _ => vec![0.0; sys.walls.len()],
        };
        if exact_switches {
            release_walls(sys, &mut contacts, &start, 0.0);
        }
        let end = Box::new(fresh());
        // the DOFs whose turning points the peaks and the sweeps' observers need
        let recorded = run.out.dofs().to_vec();
        let inside = Inside {
            force_max: vec![0.0; sys.walls.len()],
            delta_max: vec![0.0; sys.walls.len()],
            displacement_turn: vec![None; n],
        };
        let v_max: Vec<f64> = start.v.iter().map(|v| v.abs()).collect();
        let (h, dt_fixed) = match steps {
            Steps::Fixed(dt) => (dt, Some(dt)),
            Steps::Adaptive { first, dt_max, .. } => (first.min(dt_max), None),
        };
        Self {
            steps,
            t_end,
            tol_t,
            dynamics,
            stages,
            contacts,
            start,
            end,
            recorded,
            inside,
            v_max,
            h,
            dt_fixed,
            landing: None,
            landings: 0,
            rejected: false,
            h_contact: None,
            h_free: None,
            dz_contact: None,
            contact_started: false,
            root: None,
            last: None,
            grid_step: 0,
            near_switch: tol_t,
            slack,
            exact_switches,
            variational,
        }
    }
}

/// How much longer (s) a step of length `h` that ended at `end` must be to end on a wall's
/// switch (its onset or end, `δ = 0`, or its force's release, [`release_walls`]), if one lies
/// within [`LANDING_WINDOW`] of the step's length from its end (at most `room` later), to
/// first order in the switching function's rate: `None` once it ends on it to round-off.
fn landing_correction(
    sys: &System,
    contacts: &[Contact],
    end: &StepEnd,
    t: f64,
    h: f64,
    room: f64,
) -> Option<f64> {
    let wall = contacts
        .iter()
        .zip(&end.walls)
        .filter(|(c, [_, rate, _])| if c.active { *rate < 0.0 } else { *rate > 0.0 })
        .map(|(_, [delta, rate, _])| -delta / rate);
    let release = contacts
        .iter()
        .enumerate()
        .filter(|&(j, c)| c.active && !c.released && end.walls[j][0] > 0.0 && !is_radial(sys, j))
        .map(|(j, c)| force_formula(sys, j, c, end.walls[j]))
        .filter(|(_, rate)| *rate < 0.0)
        .map(|(force, rate)| -force / rate);
    wall.chain(release)
        .filter(|tau| tau.abs() < LANDING_WINDOW * h && *tau < room)
        .filter(|tau| tau.abs() > 4.0 * f64::EPSILON * t.max(h))
        .min_by(|a, b| a.total_cmp(b))
}

/// Integrates every contact in time (no step in `ζ`, whose duration depends on the state):
/// what the state-transition matrix is carried along.
fn in_time_only(contacts: &mut [Contact]) {
    for c in contacts {
        c.in_time = true;
    }
}

impl StepPolicy for Dop853Steps<'_> {
    fn sensitivity(&self) -> Option<&StateTransition> {
        self.variational.as_ref().map(|v| &v.phi)
    }

    /// One accepted step (up to `t_end`).
    fn advance(&mut self, run: &mut Run, sys: &System) -> Result<bool, SimError> {
        loop {
            if self.t_end - run.cur.t <= 1e-13 * self.t_end {
                return Ok(false);
            }
            let t0 = run.cur.t;
            let was_free = self.contacts.iter().all(|c| !c.active);
            let before = self.variational.is_some().then(|| self.contacts.clone());
            let within = EVENT_NEAR * self.h;
            let (switched, closed) = switch_walls(
                sys,
                &mut self.contacts,
                &self.slack,
                &self.start,
                self.near_switch,
                within,
            );
            let released = self.exact_switches
                && release_walls(sys, &mut self.contacts, &self.start, self.near_switch);
            if let (Some(var), Some(before), true) =
                (&mut self.variational, before, switched || released)
            {
                var.switch(sys, &before, &self.contacts, &self.start);
                in_time_only(&mut self.contacts);
            }
            if switched {
                self.dynamics.at(&self.contacts, None, t0, &mut self.start);
                self.last = None;
                // a contact is short: the steps of the free motion resume after it at the size
                // proposed before it (the error control cuts one that is too long)
                match (was_free, self.contacts.iter().all(|c| !c.active)) {
                    (true, false) => self.h_free = Some(self.h),
                    (false, true) => self.h = self.h.max(self.h_free.unwrap_or(self.h)),
                    _ => {}
                }
                self.contact_started = self.contacts.iter().any(|c| c.active && c.peak_pending);
                if let (true, Some(hc)) = (self.contact_started, self.h_contact) {
                    self.h = self.h.min(hc);
                }
                if let (Some(j), Steps::Adaptive { .. }) =
                    (closed.filter(|&j| !self.contacts[j].in_time), self.steps)
                {
                    let rate = self.start.walls[j][1];
                    self.root = Some(RootPhase {
                        wall: j,
                        rising: true,
                        dz: self.dz_contact.unwrap_or_else(|| (rate * self.h).sqrt()),
                        rejections: 0,
                        h_after: self.h,
                    });
                }
            }
            // a contact that the next step would leave (its penetration extrapolated with its
            // rate and acceleration): its end in ζ at once, not after a step that finds the
            // opening and is discarded for the force's kink there
            if self.root.is_none() && self.landing.is_none() && self.dt_fixed.is_none() {
                self.root = self.contacts.iter().enumerate().find_map(|(j, c)| {
                    let [delta, rate, accel] = self.start.walls[j];
                    let leaves = c.active && delta + self.h * (rate + 0.5 * self.h * accel) < 0.0;
                    leaves
                        .then(|| opening_phase(c, j, &self.start, self.h))
                        .flatten()
                });
            }
            // a closing within the next step, predicted at constant acceleration (exact in free
            // flight under constant forces) and refined on the free motion's Taylor series:
            // landed on at once instead of after a step that finds it; a step that falls short
            // or overshoots is corrected as any landing
            if self.root.is_none() && self.landing.is_none() && self.dt_fixed.is_none() {
                let limit = self.h.min(self.t_end - t0);
                self.landing = predicted_closing(&self.contacts, &self.start)
                    .filter(|&(tau, _)| tau < limit)
                    .map(|(tau, j)| {
                        let (dynamics, contacts, start) =
                            (&mut self.dynamics, &self.contacts, &*self.start);
                        let slack = self.slack[j];
                        let refined = by_size!(start.x.len(), |N| dynamics
                            .free_closing::<N>(contacts, t0, start, j, tau, slack));
                        (refined.unwrap_or(tau), j)
                    })
                    .filter(|&(tau, _)| tau > self.near_switch && tau < limit)
                    .map(|(tau, j)| (tau, !smooth_switch(sys, j)));
            }
            // the step: in ζ during a contact's start or end, else in time
            // a step in ζ that ends the contact (lands on ζ = 0)
            let mut opens = false;
            let (clock, h_try, target) = match self.root {
                Some(phase) => {
                    let delta = self.start.walls[phase.wall][0];
                    let from = delta.max(0.0).sqrt();
                    let dz = if phase.rising {
                        phase.dz
                    } else {
                        // at most half-way back to the peak's ζ, where dt/dζ is singular: a
                        // step nearer to it has an error several times its estimate
                        let peak = self.contacts[phase.wall].max_penetration.sqrt();
                        -phase.dz.min(0.5 * (peak - from).max(0.0)).min(from)
                    };
                    opens = !phase.rising && dz == -from;
                    let clock = Clock::Root {
                        wall: phase.wall,
                        from,
                        offset: delta - from * from,
                    };
                    (clock, dz, dz)
                }
                None => {
                    let target = match self.dt_fixed {
                        Some(dt) => ((self.grid_step + 1) as f64 * dt).min(self.t_end) - t0,
                        None => self.h,
                    };
                    let mut h_try = self.landing.map_or(target, |(h, _)| h).min(self.t_end - t0);
                    if self.t_end - (t0 + h_try) < 1e-13 * self.t_end {
                        h_try = self.t_end - t0;
                    }
                    (Clock::Time, h_try, target)
                }
            };
            // a step landed on a closing or opening meets the force's singularity at its end
            let singular_end = self.landing.take().is_some_and(|(_, singular)| singular);
            let duration = self.stages.step(
                &mut self.dynamics,
                &self.contacts,
                clock,
                t0,
                &self.start,
                h_try,
                &mut self.end,
            );
            if let Some(phase) = self
                .root
                .filter(|_| duration.is_some_and(|d| t0 + d > self.t_end))
            {
                // a step in ζ past t_end: the rest of the contact is integrated in time
                self.contacts[phase.wall].in_time = true;
                self.root = None;
                continue;
            }
            let (mut err, mut err_next) = (0.0, 0.0);
            if let Steps::Adaptive { tol, dt_max, .. } = self.steps {
                // the first step of a contact and a step landed on an event (a contact's end)
                // meet the force's δ^1.5 singularity, unless the step is in ζ or the force
                // is linear in δ
                let rough_start = self.contact_started
                    && (self.contacts.iter().enumerate())
                        .any(|(j, c)| c.active && c.peak_pending && !smooth_switch(sys, j));
                let rough = matches!(clock, Clock::Time) && (rough_start || singular_end);
                [err, err_next] = duration.map_or([f64::INFINITY; 2], |_| {
                    self.stages.error(
                        sys,
                        clock,
                        &tol,
                        dt_max,
                        &self.start,
                        &self.end,
                        &self.v_max,
                        run.energy_scale(),
                        h_try,
                        rough,
                    )
                });
                if let Some(mut phase) = self.root.filter(|_| err > 1.0) {
                    run.stats.rejected_steps += 1;
                    phase.rejections += 1;
                    phase.dz = h_try.abs() * step_factor(err).clamp(0.2, 0.9);
                    self.root = (phase.rejections <= MAX_ROOT_REJECTIONS).then_some(phase);
                    if self.root.is_none() {
                        self.contacts[phase.wall].in_time = true;
                        self.h = self.h.min(duration.unwrap_or(self.h));
                    }
                    continue;
                }
                if err > 1.0 && h_try > tol.dt_min * (1.0 + 1e-12) {
                    run.stats.rejected_steps += 1;
                    // a wall closing or opening inside the step: the kink of the force there is
                    // what the error sees; an opening is integrated in ζ, a closing landed on
                    let near = (EVENT_NEAR * h_try).max(self.tol_t);
                    if self.landings < MAX_LANDINGS {
                        if let Some((s, j, event)) = first_event(
                            sys,
                            &self.contacts,
                            &self.slack,
                            &self.start,
                            &self.end,
                            h_try,
                            near,
                            false,
                        ) {
                            self.root = (event == Event::Opening)
                                .then(|| opening_phase(&self.contacts[j], j, &self.start, h_try))
                                .flatten();
                            if self.root.is_none() {
                                self.landing = Some((s * h_try, !smooth_switch(sys, j)));
                                self.landings += 1;
                            }
                            self.last = None;
                            continue;
                        }
                    }
                    self.h = (h_try * step_factor(err).max(0.2)).max(tol.dt_min);
                    self.landings = 0;
                    self.rejected = true;
                    self.last = None;
                    continue;
                }
            }
            let duration = duration.expect("a step in time has a duration");
            let near = (EVENT_NEAR * duration).max(self.tol_t);
            if self.landings < MAX_LANDINGS {
                if let Some((s, j, event)) = first_event(
                    sys,
                    &self.contacts,
                    &self.slack,
                    &self.start,
                    &self.end,
                    duration,
                    near,
                    true,
                ) {
                    run.stats.rejected_steps += 1;
                    let opening = match (event, clock, self.dt_fixed) {
                        (Event::Opening, Clock::Time, None) => {
                            opening_phase(&self.contacts[j], j, &self.start, h_try)
                        }
                        _ => None,
                    };
                    self.root = opening;
                    if self.root.is_none() {
                        let singular = matches!(event, Event::Closing | Event::Opening)
                            && !smooth_switch(sys, j);
                        self.landing = Some((s * duration, singular));
                        self.landings += 1;
                    }
                    continue;
                }
            }
            // the step that ends next to a switch is retaken to end on it to round-off
            if self.exact_switches && self.landings < MAX_LANDINGS {
                let room = match self.dt_fixed {
                    Some(_) => target - duration,
                    None => self.t_end - t0 - duration,
                } - self.tol_t;
                if let Some(tau) = landing_correction(
                    sys,
                    &self.contacts,
                    &self.end,
                    t0 + duration,
                    duration,
                    room,
                ) {
                    run.stats.rejected_steps += 1;
                    self.landing = Some((duration + tau, true));
                    self.landings += 1;
                    continue;
                }
            }
            self.landings = 0;
            self.near_switch = 2.0 * near;
            let landed = h_try < target * (1.0 - 1e-12);
            if let Some(var) = &mut self.variational {
                var.step(sys, &self.stages, &self.contacts, t0, &self.start, duration);
            }
            self.inside.scan(
                sys,
                &self.recorded,
                &self.contacts,
                &mut self.stages,
                &mut self.dynamics,
                clock,
                t0,
                &self.start,
                &self.end,
                duration,
            );
            commit(
                run,
                sys,
                &mut self.contacts,
                &self.end,
                duration,
                &self.inside,
                &mut self.dynamics.loads,
            )?;
            if self.dt_fixed.is_some() && !landed {
                self.grid_step += 1;
            }
            for (m, v) in self.v_max.iter_mut().zip(&self.end.v) {
                *m = m.max(v.abs());
            }
            std::mem::swap(&mut self.start, &mut self.end);
            let Steps::Adaptive { tol, dt_max, .. } = self.steps else {
                return Ok(true);
            };
            let max_growth = if self.rejected { 1.0 } else { 6.0 };
            let grow = if err_next > 0.0 {
                step_factor(err_next)
            } else {
                max_growth
            };
            self.rejected = false;
            if let Some(mut phase) = self.root {
                // the contact's start: one step in ζ, then in time from the step's duration;
                // its end: in ζ until ζ = 0, then in time with the step proposed before it
                self.last = None;
                if phase.rising {
                    self.dz_contact = Some(h_try);
                    self.contact_started = false;
                    self.h = duration.clamp(tol.dt_min, dt_max);
                    self.root = None;
                } else if opens {
                    self.h = phase.h_after;
                    self.root = None;
                } else {
                    phase.dz = h_try.abs() * grow.clamp(0.2, max_growth);
                    self.root = Some(phase);
                }
                return Ok(true);
            }
            if self.contact_started {
                self.h_contact = Some(h_try);
                self.contact_started = false;
            }
            // a landed step is short for the event, not for its error: the next step is the
            // one proposed before the landing; after a rejection the step does not grow
            if !landed {
                let mut grow = grow;
                // Gustafsson's predictive controller (as in Hairer's RADAU5): an error that
                // grew from the last step is extrapolated, so that a steepening solution
                // (the end of a Hertzian contact) shrinks the step before it is rejected
                if let (Some((h_last, err_last)), true) = (self.last, err > 0.0) {
                    grow = grow.min(
                        0.9 * (h_try / h_last) / eighth_root(err) * eighth_root(err_last / err),
                    );
                }
                self.h = (h_try * grow.clamp(0.2, max_growth)).clamp(tol.dt_min, dt_max);
                self.last = (err > 0.0).then_some((h_try, err));
            }
            return Ok(true);
        }
    }
}

/// Makes the step's end the run's current state: wall states, gap coordinates, loads; the
/// integrated work increments go to the energy account, the impulses, the largest forces and
/// the peaks inside the step to the impact table and the peak displacements.
fn commit(
    run: &mut Run,
    sys: &System,
    contacts: &mut [Contact],
    end: &StepEnd,
    h: f64,
    inside: &Inside,
    loads: &mut LoadValues,
) -> Result<(), SimError> {
    let t = run.cur.t + h;
    for (j, c) in contacts.iter_mut().enumerate() {
        if c.active {
            let at_end = end.walls[j][0];
            c.max_penetration = c.max_penetration.max(inside.delta_max[j]).max(at_end);
        }
    }
    let s = &mut run.trial;
    s.t = t;
    s.x.copy_from_slice(&end.x);
    s.v.copy_from_slice(&end.v);
    s.a.copy_from_slice(&end.a);
    // the right-hand side's evaluation (a `sin_cos` every few steps, not a `sin` per load):
    // these values only describe the state, DOP853's work integrals being its own
    loads.evaluate(&sys.loads, t);
    s.load.copy_from_slice(&loads.values);
    sys.gap_coordinates(&end.x, &mut s.u);
    sys.gap_coordinates(&end.v, &mut s.u_rate);
    sys.gap_coordinates(&end.a, &mut s.u_accel);
    s.phi.fill(0.0);
    for (j, ((wall, c), w)) in sys
        .walls
        .iter()
        .zip(contacts)
        .zip(s.walls.iter_mut())
        .enumerate()
    {
        let (penetration, rate) = sys.wall_motion(j, &s.u, &s.u_rate);
        *w = WallState {
            penetration,
            rate,
            impact_speed: if c.active {
                c.impact_speed
            } else {
                rate.max(MIN_IMPACT_SPEED)
            },
            max_penetration: c.max_penetration.max(penetration),
            ..WallState::default()
        };
        let radial = match &sys.gaps[wall.gap].side {
            Side::Radial(r) => Some((r, sys.radial_kinematics(r, wall.gap, &s.u, &s.u_rate))),
            _ => None,
        };
        if c.active && penetration > 0.0 {
            let f = sys.gaps[wall.gap].law.force_in_contact(
                penetration,
                rate,
                c.impact_speed,
                w.max_penetration,
            );
            w.force = f.force;
            w.d_penetration = f.d_penetration;
            w.d_rate = f.d_rate;
            w.elastic_force = f.elastic;
            w.potential = f.potential;
            if let Some((r, k)) = &radial {
                let rf = radial_contact(r, k, w, r.radius * sys.structure.spin.start);
                s.phi[wall.gap] += rf.phi[0];
                s.phi[r.partner] += rf.phi[1];
                w.friction = rf.friction;
            } else {
                s.phi[wall.gap] += wall.sign * f.force;
            }
        }
        if let Some((r, k)) = &radial {
            w.slide = k.slide;
            w.slip = r.radius * sys.structure.spin.start + k.slide;
        }
    }
    let integrals = StepIntegrals {
        work: end.work,
        walls: WallInterior {
            impulse: &end.impulse,
            force_max: &inside.force_max,
            delta_max: &inside.delta_max,
        },
        displacement_turns: &inside.displacement_turn,
    };
    run.commit_trial(sys, h, 0, Some(&integrals))
}

/// What turns inside an accepted step: each wall's largest force and peak penetration (0
/// where it does not peak inside) and where each recorded DOF's displacement turns (fraction
/// of the step and value; `None` for the others), so that no step needs to end on a peak.
struct Inside {
    force_max: Vec<f64>,
    delta_max: Vec<f64>,
    displacement_turn: Vec<Option<Turn>>,
}

/// Where `y` turns inside a step (its rate changes sign between the ends), located on the
/// quintic Hermite interpolant of `(y, y', y'')` at the ends: the fraction of the step and
/// the interpolant's value there (error `O(h⁶)`).
fn turning_point(start: [f64; 3], end: [f64; 3], h: f64) -> Option<Turn> {
    if start[1] * end[1] >= 0.0 {
        return None;
    }
    let seg = QuinticSegment::new(start, end, h);
    seg.first_crossing(true, start[1] < 0.0, EVENT_SAMPLES)
        .map(|s| (s, seg.value(s)))
}

/// Samples per step of a wall's force along its interpolated penetration.
const FORCE_SAMPLES: usize = 8;

/// The dense output of a step in time, extended on first use (two or three evaluations are
/// spent only in a step where something turns).
struct Dense<'a, 'd, 's> {
    stages: &'a mut Stages,
    dynamics: &'a mut Dynamics<'s>,
    contacts: &'a [Contact],
    t0: f64,
    start: &'d StepEnd,
    end: &'d StepEnd,
    h: f64,
    extended: bool,
}

impl Dense<'_, '_, '_> {
    /// DOF `d`'s displacement and velocity at the fraction `s` of the step.
    fn dof(&mut self, d: usize, s: f64) -> [f64; 2] {
        self.extend();
        self.stages.dense(d, self.start, self.end, self.h, s)
    }

    /// DOF `d`'s displacement alone at the fraction `s` of the step.
    fn displacement(&mut self, d: usize, s: f64) -> f64 {
        self.extend();
        (self.stages).dense_displacement(d, self.start, self.end, self.h, s)
    }

    /// The dense output's three extra stages, computed on first use.
    fn extend(&mut self) {
        if !self.extended {
            let (stages, dynamics) = (&mut *self.stages, &mut *self.dynamics);
            let (contacts, t0, start, h) = (self.contacts, self.t0, self.start, self.h);
            by_size!(start.x.len(), |N| stages
                .extend::<N>(dynamics, contacts, t0, start, h));
            self.extended = true;
        }
    }

    /// Wall `j`'s penetration and its rate at the fraction `s` of the step.
    fn wall(&mut self, sys: &System, j: usize, s: f64) -> (f64, f64) {
        let wall = &sys.walls[j];
        let gap = &sys.gaps[wall.gap];
        if let Side::Radial(r) = &gap.side {
            let [x, v] = self.dof(gap.dofs[0], s);
            let [y, w] = self.dof(sys.gaps[r.partner].dofs[0], s);
            let k = crate::gap::RadialKinematics::new([x - r.center[0], y - r.center[1]], [v, w]);
            return (k.rho - wall.clearance, k.rate);
        }
        let (mut u, mut rate) = (0.0, 0.0);
        for (&d, &coef) in gap.dofs.iter().zip(&gap.coefficients) {
            let [x, v] = self.dof(d, s);
            u += coef * x;
            rate += coef * v;
        }
        (wall.sign * u - wall.clearance, wall.sign * rate)
    }
}

impl Inside {
    /// Finds what turns inside an accepted step (of the DOFs, the `recorded` ones): located
    /// on the quintic interpolants (the force's largest value by golden-section search along
    /// it), valued on the dense output of order 7 for a step in time, whose error is the
    /// step's; on the quintic for a step in `ζ` (a contact's ends, short in time).
    #[allow(clippy::too_many_arguments)]
    fn scan(
        &mut self,
        sys: &System,
        recorded: &[usize],
        contacts: &[Contact],
        stages: &mut Stages,
        dynamics: &mut Dynamics,
        clock: Clock,
        t0: f64,
        start: &StepEnd,
        end: &StepEnd,
        h: f64,
    ) {
        let in_time = matches!(clock, Clock::Time);
        let mut dense = Dense {
            stages,
            dynamics,
            contacts,
            t0,
            start,
            end,
            h,
            extended: false,
        };
        for &d in recorded {
            let ends = [start, end].map(|y| [y.x[d], y.v[d], y.a[d]]);
            self.displacement_turn[d] = turning_point(ends[0], ends[1], h)
                .map(|(s, x)| (s, if in_time { dense.displacement(d, s) } else { x }));
        }
        for (j, c) in contacts.iter().enumerate() {
            (self.delta_max[j], self.force_max[j]) = (0.0, 0.0);
            if !c.active {
                continue;
            }
            let ends = [start.walls[j], end.walls[j]];
            let seg = QuinticSegment::new(ends[0], ends[1], h);
            if let Some((s, penetration)) = turning_point(ends[0], ends[1], h) {
                self.delta_max[j] = if in_time {
                    dense.wall(sys, j, s).0
                } else {
                    penetration
                };
            }
            let law = WallLaw::new(&sys.gaps[sys.walls[j].gap].law);
            // as the dynamics evaluate it (a linear stator's formula without the law's
            // dispatch): from the smallest penetration at least, so that the first instant of
            // a contact (Kelvin–Voigt's c·v_imp) is a candidate
            let evaluate = |penetration: f64, rate: f64| {
                force_in_contact(law, c, penetration.max(f64::MIN_POSITIVE), rate)
            };
            // the force's rate at the ends, F_δ δ' + F_δ' δ'': it peaks inside only if it
            // rises at the start and falls at the end (else the larger end is the largest)
            let [(f0, rising), (f1, falling)] = ends.map(|[delta, rate, accel]| {
                let f = evaluate(delta, rate);
                (f.force, f.d_penetration * rate + f.d_rate * accel)
            });
            self.force_max[j] = f0.max(f1);
            if !(rising > 0.0 && falling < 0.0) {
                continue;
            }
            let force = |(penetration, rate): (f64, f64)| evaluate(penetration, rate).force;
            let on_segment = |s: f64| force((seg.value(s), seg.slope(s) / h));
            let samples: [f64; FORCE_SAMPLES + 1] =
                std::array::from_fn(|k| on_segment(k as f64 / FORCE_SAMPLES as f64));
            let (k, &best) = samples
                .iter()
                .enumerate()
                .max_by(|a, b| a.1.total_cmp(b.1))
                .expect("samples");
            // the force rises at the start and falls at the end, so its peak is inside even
            // where the largest sample is an end's (a peak within 1/8 of the step of it)
            let ds = 1.0 / FORCE_SAMPLES as f64;
            let (a, b) = (k.saturating_sub(1), (k + 1).min(FORCE_SAMPLES));
            let s = golden_max(on_segment, a as f64 * ds, b as f64 * ds);
            let peak = if in_time {
                force(dense.wall(sys, j, s))
            } else {
                on_segment(s).max(best)
            };
            self.force_max[j] = self.force_max[j].max(peak);
        }
    }
}

/// The maximiser of a unimodal `f` on `[a, b]` by golden-section search, to 1e-9 of the
/// step (the value, stationary at the maximum, is then exact to round-off).
fn golden_max(f: impl Fn(f64) -> f64, a: f64, b: f64) -> f64 {
    let r = 0.5 * (5f64.sqrt() - 1.0);
    let (mut a, mut b) = (a, b);
    let (mut c, mut d) = (b - r * (b - a), a + r * (b - a));
    let (mut fc, mut fd) = (f(c), f(d));
    while b - a > 1e-9 {
        if fc > fd {
            (b, d, fd) = (d, c, fc);
            c = b - r * (b - a);
            fc = f(c);
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + r * (b - a);
            fd = f(d);
        }
    }
    0.5 * (a + b)
}

/// Radial wall `j`'s kinematics and its normal force at the DOF state `x`, `v`, from the
/// smallest positive penetration as a 1-D wall's (what [`Dynamics::accel`] applies and the
/// variational equations differentiate).
fn radial_normal_force(
    sys: &System,
    j: usize,
    c: &Contact,
    x: &[f64],
    v: &[f64],
) -> (RadialKinematics, ContactForce) {
    let WallTerm::Radial {
        radial,
        dofs,
        law,
        clearance,
    } = WallTerm::new(sys, j)
    else {
        unreachable!("wall {j} is radial")
    };
    radial_wall_force(radial, dofs, law, clearance, c, x, v)
}

/// [`radial_normal_force`] of the radial wall `r` on the DOFs `[ix, iy]` (its `x` and `y`,
/// `System::radial_at_dofs`'s), its `law` and `clearance`. Inlined: the right-hand side uses
/// two of the force's five values, so the others are not computed there.
#[inline(always)]
fn radial_wall_force(
    r: &Radial,
    [ix, iy]: [usize; 2],
    law: WallLaw,
    clearance: f64,
    c: &Contact,
    x: &[f64],
    v: &[f64],
) -> (RadialKinematics, ContactForce) {
    let k = RadialKinematics::new([x[ix] - r.center[0], x[iy] - r.center[1]], [v[ix], v[iy]]);
    let force = force_in_contact(law, c, k.rho - clearance, k.rate);
    (k, force)
}

/// The force a wall in the contact `c` applies at the penetration `penetration` (≤ 0 up to
/// its switching tolerance) and its rate, as [`Dynamics::accel`] applies it: its law's
/// formula, tensile past the wall, where it continues through it
/// ([`continues_through_wall`]); else clamped to compressive and evaluated from the smallest
/// penetration at least: a wall is closed up to its switching tolerance before it is reached,
/// and a force that does not start from zero (Kelvin–Voigt's `c δ̇`) must not jump inside the
/// step.
fn force_in_contact(law: WallLaw, c: &Contact, penetration: f64, rate: f64) -> ContactForce {
    if let Some(stiffness) = law.linear {
        // the law's own formula (`Hertz::evaluate`'s), without its dispatch and branches
        return power_law(stiffness, 1.0, penetration);
    }
    let penetration = penetration.max(f64::MIN_POSITIVE);
    let max_penetration = c.max_penetration.max(penetration);
    law.law
        .force_in_contact(penetration, rate, c.impact_speed, max_penetration)
}

/// Whether a law's force continues analytically through its wall: a law linear in the
/// penetration (Hertz's with exponent 1 and no series spring: a linear stator). In contact,
/// such a wall's force is its formula on both sides, tensile past the wall (as event-located
/// Runge–Kutta codes integrate each mode's own vector field, Hairer, Nørsett & Wanner §II.6),
/// so every step integrates an analytic field: a step that crosses the opening keeps its
/// eighth-order error estimate, is accepted at its length and the opening is located on its
/// interpolant as precisely as the motion, then landed on by one retake (a clamped force's
/// kink inside the step is seen as an error of 1e4–1e6 tolerances, and the opening only
/// approached through rejections); a contact switched on just before its wall (within its
/// switching window) starts smoothly, its tensile force acting only that long (a clamped one
/// kinks there, inside the first step, whose first stages then carry an error of order
/// `h² k δ̇ / m`); and the first step of a contact and a step landed on its closing or opening
/// take the usual error estimate (no `rough` one, [`Stages::error`]). No accepted step applies
/// the tensile force beyond the switching window ([`switch_walls`], the events located inside
/// the step).
fn continues_through_wall(law: &Law) -> bool {
    linear_stator(law).is_some()
}

/// The stiffness `K` (N/m) of a law linear in the penetration, `F = K δ` (Hertz's with
/// exponent 1 and no series spring), or `None`.
#[inline]
fn linear_stator(law: &Law) -> Option<f64> {
    match law {
        Law::Hertz(h) if h.exponent == 1.0 && h.compliance == 0.0 => Some(h.stiffness),
        _ => None,
    }
}

/// How far (s) each wall's closing or opening may lie from a step's end and still be switched
/// there instead of landed on. A linear stator's force continues through its wall
/// ([`continues_through_wall`]), so a switch `τ` off the crossing applies (or leaves out) a
/// force `K |δ̇| t` for `t < τ`: a velocity error `ω² |δ̇| τ² / 2` along the wall, `ω² = K bᵀM⁻¹b
/// ≤ K |b|² ‖M⁻¹‖∞`, which `τ = √(2 SWITCH_ERROR rtol) / ω` keeps to [`SWITCH_ERROR`] of the
/// tolerance of a velocity `|δ̇|`. At a loose tolerance a landing found on a long step's
/// interpolant misses the crossing by more than [`EVENT_NEAR`] of the step and was retaken
/// a second time at almost every contact. Zero for other laws and without a dense `M⁻¹`.
fn switch_slack(sys: &System, mass_inverse: Option<&[f64]>, rtol: f64) -> Vec<f64> {
    let n = sys.n_dof();
    let norm = mass_inverse.map_or(0.0, |m| {
        m.chunks_exact(n)
            .map(|row| row.iter().map(|x| x.abs()).sum::<f64>())
            .fold(0.0, f64::max)
    });
    sys.walls
        .iter()
        .map(|w| {
            let gap = &sys.gaps[w.gap];
            let b2: f64 = gap.coefficients.iter().map(|c| c * c).sum();
            match linear_stator(&gap.law) {
                Some(k) if norm > 0.0 => (2.0 * SWITCH_ERROR * rtol / (k * b2 * norm)).sqrt(),
                _ => 0.0,
            }
        })
        .collect()
}

/// Whether wall `j`'s force continues through its wall ([`continues_through_wall`]).
fn smooth_switch(sys: &System, j: usize) -> bool {
    continues_through_wall(&sys.gaps[sys.walls[j].gap].law)
}

#[cfg(test)]
mod tests {
    use nalgebra::{DMatrix, DVector};

    use crate::contact::{Hertz, Law};
    use crate::gap::{Gap, Side};
    use crate::integrators::sized::by_size;
    use crate::integrators::NewtonSettings;
    use crate::method::Method;
    use crate::settings::{Adaptive, RunSettings};
    use crate::simulate::simulate;
    use crate::structure::LinearStructure;
    use crate::system::System;

    use super::{force_in_contact, linear_stator, Contact, WallLaw};
    use crate::contact::ContactLaw;

    /// A linear stator's force in contact (its own path) is its law's evaluation, bit for
    /// bit, on both sides of the wall; other laws (a Hertz exponent, a series spring, another
    /// family) take the law's path.
    #[test]
    fn linear_stator_force_is_the_laws() {
        let linear = Law::Hertz(Hertz::new(1e6, 1.0).unwrap());
        assert_eq!(linear_stator(&linear), Some(1e6));
        for other in [
            Law::Hertz(Hertz::new(1e6, 1.5).unwrap()),
            Law::Hertz(Hertz::new(1e6, 1.0).unwrap().in_series(1e-7).unwrap()),
        ] {
            assert_eq!(linear_stator(&other), None);
        }
        let c = Contact {
            active: true,
            impact_speed: 0.3,
            max_penetration: 2e-6,
            ..Contact::default()
        };
        for i in 0..=200 {
            let delta = (i as f64 - 40.0) * 3.7e-8;
            let law = linear.evaluate_in_contact(delta, 0.1, 0.3, 2e-6_f64.max(delta));
            let path = force_in_contact(WallLaw::new(&linear), &c, delta, 0.1);
            assert_eq!(path, law, "{delta}");
        }
    }

    /// The dense output of one step of an undamped oscillator (`x = sin t`) against the exact
    /// motion inside the step: its error falls at least like `h⁸` (order 7, a local error),
    /// by 2⁸ = 256 when the step halves (the velocity's; the displacement's by 2⁹ here).
    #[test]
    fn dense_output_is_of_order_seven() {
        let s = LinearStructure::new(
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::zeros(1, 1),
            DMatrix::from_element(1, 1, 1.0),
        )
        .unwrap();
        let sys = System::new(s, vec![], vec![]).unwrap();
        let mut dynamics = super::Dynamics::new(&sys);
        let mut stages = super::Stages::new(&sys);
        let error = |h: f64, dynamics: &mut super::Dynamics, stages: &mut super::Stages| {
            let state = || super::StepEnd {
                x: super::Inline::new(1, 0.0),
                v: super::Inline::new(1, 1.0),
                a: super::Inline::new(1, 0.0),
                power: [0.0; 3],
                forces: vec![],
                work: [0.0; 3],
                impulse: vec![],
                walls: vec![],
            };
            let (start, mut end) = (state(), state());
            stages
                .step(dynamics, &[], super::Clock::Time, 0.0, &start, h, &mut end)
                .unwrap();
            stages.extend::<1>(dynamics, &[], 0.0, &start, h);
            let s = 0.37;
            let [x, v] = stages.dense(0, &start, &end, h, s);
            [(x - (s * h).sin()).abs(), (v - (s * h).cos()).abs()]
        };
        let coarse = error(0.4, &mut dynamics, &mut stages);
        let fine = error(0.2, &mut dynamics, &mut stages);
        for (c, f) in coarse.iter().zip(&fine) {
            let ratio = c / f;
            assert!((200.0..1100.0).contains(&ratio), "{c:e} / {f:e} = {ratio}");
        }
    }

    /// A closing predicted at constant acceleration and refined on the free motion's Taylor
    /// series equals the closed form of a damped oscillator under a constant and a harmonic
    /// load (`x = x_p + e^{−ζωt}(…)`, its zero located by bisection) to 1e-8 of the time to
    /// it (a landing needs `EVENT_NEAR`, 1e-5), where the constant-acceleration guess is off by
    /// more than 1e-4.
    #[test]
    fn free_closing_equals_the_closed_form() {
        use crate::structure::{Load, LoadHistory};
        let (m, c, k, f0, fa, w) = (1.0, 4.0, 1e4, 1.0, 0.5, 150.0);
        let s = LinearStructure::new(
            DMatrix::from_element(1, 1, m),
            DMatrix::from_element(1, 1, c),
            DMatrix::from_element(1, 1, k),
        )
        .unwrap();
        let gap = Gap {
            dofs: vec![0],
            coefficients: vec![1.0],
            clearance: 2e-3,
            side: Side::Positive,
            law: Law::Hertz(Hertz::new(1e9, 1.5).unwrap()),
        };
        let loads = vec![
            Load {
                dofs: vec![0],
                amplitude: f0,
                history: LoadHistory::Constant,
            },
            Load {
                dofs: vec![0],
                amplitude: fa,
                history: LoadHistory::Harmonic {
                    frequency: w / (2.0 * std::f64::consts::PI),
                    phase: 0.0,
                },
            },
        ];
        let sys = System::new(s, vec![gap], loads).unwrap();
        // the exact motion from x0, v0 at t = 0: the particular solution of each load and
        // the damped free motion that meets the initial state
        let (x0, v0) = (0.0, 0.5);
        let (wn, zeta) = ((k / m).sqrt(), c / (2.0 * (k * m).sqrt()));
        let wd = wn * (1.0 - zeta * zeta).sqrt();
        let z = nalgebra::Complex::new(k - m * w * w, c * w);
        let amp = fa / z; // x_h = Im(amp e^{iwt})
        let particular = |t: f64| {
            let e = nalgebra::Complex::new(0.0, w * t).exp();
            (
                f0 / k + (amp * e).im,
                (amp * e * nalgebra::Complex::new(0.0, w)).im,
            )
        };
        let (p0, pv0) = particular(0.0);
        let (a, b) = (x0 - p0, (v0 - pv0 + zeta * wn * (x0 - p0)) / wd);
        let exact = |t: f64| {
            particular(t).0 + (-zeta * wn * t).exp() * (a * (wd * t).cos() + b * (wd * t).sin())
        };
        let (mut lo, mut hi) = (0.0, 1e-2);
        assert!(exact(hi) > 2e-3);
        while hi - lo > 1e-16 {
            let mid = 0.5 * (lo + hi);
            if exact(mid) < 2e-3 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let mut dynamics = super::Dynamics::new(&sys);
        let contacts = [Contact::default()];
        let mut start = super::StepEnd {
            x: super::Inline::new(1, x0),
            v: super::Inline::new(1, v0),
            a: super::Inline::new(1, 0.0),
            power: [0.0; 3],
            forces: vec![0.0],
            work: [0.0; 3],
            impulse: vec![0.0],
            walls: vec![[0.0; 3]],
        };
        dynamics.at(&contacts, None, 0.0, &mut start);
        let (guess, wall) = super::predicted_closing(&contacts, &start).unwrap();
        assert!((guess / lo - 1.0).abs() > 1e-4, "{guess} {lo}");
        let refined = by_size!(start.x.len(), |N| dynamics
            .free_closing::<N>(&contacts, 0.0, &start, wall, guess, 0.0))
        .unwrap();
        assert!((refined / lo - 1.0).abs() < 1e-8, "{refined} {lo}");
    }

    /// A free mass onto a Hertz wall: the closing landed on (t = d/v, v_in = v), the peak
    /// indentation from energy, `(5 m v² / 4K)^(2/5)`, restitution 1, energy conserved.
    #[test]
    fn hertz_impact_of_a_free_mass_matches_energy_closed_form() {
        let (m, v, k, d) = (2.0, 1.5, 3e9, 1e-3);
        let s = LinearStructure::new(
            DMatrix::from_element(1, 1, m),
            DMatrix::zeros(1, 1),
            DMatrix::zeros(1, 1),
        )
        .unwrap();
        let gap = Gap {
            dofs: vec![0],
            coefficients: vec![1.0],
            clearance: d,
            side: Side::Positive,
            law: Law::Hertz(Hertz::new(k, 1.5).unwrap()),
        };
        let sys = System::new(s, vec![gap], vec![]).unwrap();
        let settings = RunSettings {
            t_end: 2e-3,
            dt: 1e-5,
            every: 1,
            record_dofs: vec![0],
            newton: NewtonSettings::default(),
            adaptive: Some(Adaptive {
                rtol: 1e-10,
                atol: 1e-14,
                dt_min: 1e-12,
                dt_max: 4e-5,
            }),
        };
        let out = simulate(
            &sys,
            Method::Dop853,
            &settings,
            DVector::zeros(1),
            DVector::from_element(1, v),
        )
        .unwrap();
        assert!(out.error.is_none());
        assert_eq!(out.impacts.len(), 1);
        let imp = &out.impacts[0];
        assert!(
            (imp.t_start / (d / v) - 1.0).abs() < 1e-13,
            "{}",
            imp.t_start
        );
        assert!((imp.v_in / v - 1.0).abs() < 1e-13);
        let delta_max = (2.5 * m * v * v / (2.0 * k)).powf(0.4);
        assert!(
            (imp.delta_max / delta_max - 1.0).abs() < 2e-9,
            "{}",
            imp.delta_max
        );
        assert!((imp.v_out / v - 1.0).abs() < 1e-9, "{}", imp.v_out);
        let e = &out.rows.energy;
        let e0 = e.kinetic[0];
        for i in 0..e.kinetic.len() {
            let total = e.kinetic[i] + e.contact_potential[i];
            assert!((total / e0 - 1.0).abs() < 3e-9, "{i}: {total}");
        }
    }

    /// The rub of `rotor_bench` (a Jeffcott rotor on a linear stator with regularised
    /// friction), 100 revolutions at `rtol`: the final displacement, contacts, rejections.
    fn linear_stator_rub(rtol: f64) -> ([f64; 2], usize, usize) {
        use crate::gap::{FrictionLaw, Radial};
        use crate::structure::{Load, LoadHistory};
        use std::f64::consts::{FRAC_PI_2, PI};
        let spin = 150.0;
        let eye = DMatrix::<f64>::identity(2, 2);
        let st = LinearStructure::new(eye.clone(), &eye * 10.0, &eye * 1e4)
            .unwrap()
            .spinning(None, spin)
            .unwrap();
        let gap = Gap {
            dofs: vec![0, 1],
            coefficients: vec![1.0, 1.0],
            clearance: 1e-4,
            side: Side::Radial(Radial {
                center: [0.0, 0.0],
                friction: 0.05,
                radius: 0.01,
                friction_law: FrictionLaw::Regularised { speed: 0.05 },
                partner: 0,
            }),
            law: Law::Hertz(Hertz::new(1e6, 1.0).unwrap()),
        };
        let unbalance = |dof: usize, phase: f64| Load {
            dofs: vec![dof],
            amplitude: 1e-4 * spin * spin,
            history: LoadHistory::Harmonic {
                frequency: spin / (2.0 * PI),
                phase,
            },
        };
        let loads = vec![unbalance(0, 0.0), unbalance(1, -FRAC_PI_2)];
        let sys = System::new(st, vec![gap], loads).unwrap();
        let period = 2.0 * PI / spin;
        let t_end = 100.0 * period;
        let settings = RunSettings {
            t_end,
            dt: period / 100.0,
            every: 1_000_000,
            record_dofs: vec![0, 1],
            newton: NewtonSettings::default(),
            adaptive: Some(Adaptive {
                rtol,
                atol: 1e-14_f64.min(rtol * 1e-4),
                dt_min: period / 1e6,
                dt_max: t_end / 50.0,
            }),
        };
        let out = simulate(
            &sys,
            Method::Dop853,
            &settings,
            DVector::zeros(2),
            DVector::zeros(2),
        )
        .unwrap();
        assert!(out.error.is_none());
        let x = &out.rows.displacement;
        (
            [x[x.len() - 2], x[x.len() - 1]],
            out.impacts.len(),
            out.stats.rejected_steps,
        )
    }

    /// At a loose tolerance a linear stator's switch is taken within its window
    /// ([`super::switch_slack`]) instead of landed on again (2.9 retaken steps a contact
    /// before, 1.23 now: the step over the opening and some closings), to the tolerance's
    /// accuracy.
    #[test]
    fn linear_stator_switches_at_a_loose_tolerance_are_not_retaken_twice() {
        let (reference, contacts, _) = linear_stator_rub(1e-12);
        let (x, coarse_contacts, rejected) = linear_stator_rub(1e-6);
        assert_eq!(coarse_contacts, contacts);
        assert!(rejected < 3 * contacts / 2, "{rejected} for {contacts}");
        let error = (x[0] - reference[0]).hypot(x[1] - reference[1]);
        // 7.9e-8 m, 0.08 % of the clearance (1.0e-6 m after 1,000 revolutions, as before)
        assert!(error < 2e-7, "{error}");
    }
}
