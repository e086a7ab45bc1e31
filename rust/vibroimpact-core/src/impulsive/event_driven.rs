//! Event-driven integration of rigid impacts.
//!
//! Between events the motion is smooth and, for a set `S` of walls held closed (sticking),
//! linear: `z' = A_S z + B_S F(t)` for `z = [x; v]`, with the contact forces of the stuck
//! walls eliminated, `a = Π M⁻¹ (F − C v − K x)`, `Π = I − M⁻¹ G_Sᵀ W_S⁻¹ G_S`,
//! `W_S = G_S M⁻¹ G_Sᵀ`, `λ_S = W_S⁻¹ G_S M⁻¹ (F − C v − K x)`. It is integrated exactly by
//! the matrix exponential (`crate::integrators::expm`), once per wall set for the step `dt`:
//! * constant and harmonic loads ([`LoadOscillator`]) are the output `F = P w` of their own
//!   linear oscillator `w' = Ω w` (`w = 1`; `w = (sin θ, cos θ)`, `θ = 2πft + φ`), so the
//!   flight of `[x; v; w]` is autonomous, `z̃' = Ã z̃`, and `exp(Ã dt)` is its exact
//!   propagator: a full step is one mat-vec, and the acceleration and the stuck walls'
//!   forces at its end, linear in `z̃` too, one more (`Mode::rates`). A trial instant inside
//!   a step (locating an event) is `exp(Ã τ) z̃` by its Taylor series (`expm::expm_action`:
//!   a few mat-vecs, to round-off), the exponential where that series is not safe (stiff
//!   modes); a wall whose quintic (below) is bounded below zero on the step is not sampled;
//! * with a table load (linear between its breakpoints), a flight is split at the
//!   breakpoints inside it and each piece integrated exactly: `exp(A_S η)` and the Duhamel
//!   matrices of the line through the piece's ends (`expm::duhamel`), cached for a full step
//!   without a breakpoint, computed anew for the other pieces and each trial instant.
//!
//! Events, located in each step on a quintic Hermite interpolant of every free wall's
//! penetration (`δ, δ̇, δ̈` at both ends, 32 samples) and of every stuck wall's force
//! (cubic Hermite of `λ, λ̇`), then refined on the exact solution by safeguarded Newton to
//! round-off:
//! * **impact**: a free wall's `δ` crosses 0 upwards;
//! * **release**: a stuck wall's contact force `λ` crosses 0 downwards (it would become
//!   tensile).
//!
//! At an event, every wall within round-off of contact (`δ ≥ −tol`) takes part:
//! * **simultaneous impacts** (rule): the generalized Newton law on all of them together,
//!   `0 ≤ P ⊥ δ̇⁺ + e δ̇⁻ ≤ 0`, one LCP with the Delassus matrix `G M⁻¹ Gᵀ`. For walls whose
//!   Delassus matrix is diagonal (decoupled gaps) this is each wall's own Newton impact; for
//!   coupled walls it is the unique impulse that leaves no wall approaching.
//! * **chattering / Zeno** (rule): after an impact with separation speed `v⁺` on a wall
//!   pushed into it by an acceleration `δ̈ > 0`, the next flight would last about
//!   `2 v⁺/δ̈`; when that is shorter than `chatter_fraction · dt`, the impact is made
//!   plastic (`e = 0` for that wall) and the wall is held closed. Under a locally constant
//!   `δ̈` the impacts it replaces would have accumulated within
//!   `2 v⁺/(δ̈ (1 − e)) < chatter_fraction · dt / (1 − e)`: that bounds the error in the
//!   sticking instant. More than `max_events_per_step` events in one step also make every
//!   further impact in the step plastic, so the loop always ends.
//! * **sticking and release**: the walls at rest on contact (`|δ̇| ≤ tol`) solve the
//!   acceleration LCP `0 ≤ λ ⊥ −δ̈ ≥ 0`; those with `λ > 0` are held closed until their
//!   force would become tensile.
//!
//! Limitations: an excursion into a wall shorter than a sample spacing (`dt/32`) that the
//! quintic interpolant does not show is missed (choose `dt` below the shortest flight of
//! interest); the exponential costs `O((2n + 2k)³)` per wall set (with a table load, per
//! trial instant and per piece of a step that holds a breakpoint too; small and reduced
//! models).

use nalgebra::{DMatrix, DVector};

use super::lcp::solve_lcp;
use super::moreau_jean::check_initial;
use super::{fill_gaps, Rigidity};
use crate::driver::{Run, StepPolicy};
use crate::error::SimError;
use crate::gap::ImpactRecord;
use crate::integrators::expm::{duhamel, expm, expm_action};
use crate::interpolation::QuinticSegment;
use crate::observe::Turn;
use crate::sensitivity::{saltation_update, Parameter, StateTransition};
use crate::structure::LoadHistory;
use crate::system::{State, System};

/// The method's name in errors.
const METHOD: &str = "event-driven";

/// Settings of the event-driven method.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EventDriven {
    /// A wall sticks when the flight after an impact would be shorter than
    /// `chatter_fraction · dt` (the chattering rule); `0 ≤ chatter_fraction < 1`.
    pub chatter_fraction: f64,
    /// Events allowed in one step before every further impact in it is made plastic.
    pub max_events_per_step: usize,
}

/// Constant and harmonic loads as the output of a linear oscillator: `F_l(t) = (P w(t))_l`,
/// `w' = Ω w`, one state for a constant load (`w = 1`), two for a harmonic one
/// (`w = (sin θ, cos θ)`, `θ = 2πft + φ`, `Ω = [[0, 2πf], [−2πf, 0]]`).
struct LoadOscillator {
    /// `P` (loads × states), the amplitudes.
    output: DMatrix<f64>,
    /// `Ω`.
    generator: DMatrix<f64>,
    /// The first state of each load, with its angular frequency (`None`: constant).
    states: Vec<(usize, Option<(f64, f64)>)>,
}

impl LoadOscillator {
    /// `None` if a load is a table or a run-up's unbalance (not the output of a finite linear
    /// oscillator).
    fn new(sys: &System) -> Option<Self> {
        let mut states = Vec::new();
        let mut m = 0;
        for load in &sys.loads {
            match &load.history {
                LoadHistory::Constant => {
                    states.push((m, None));
                    m += 1;
                }
                LoadHistory::Harmonic { frequency, phase } => {
                    states.push((m, Some((2.0 * std::f64::consts::PI * frequency, *phase))));
                    m += 2;
                }
                LoadHistory::Table { .. } | LoadHistory::Unbalance { .. } => return None,
            }
        }
        let mut output = DMatrix::zeros(sys.loads.len(), m);
        let mut generator = DMatrix::zeros(m, m);
        for (l, (&(first, harmonic), load)) in states.iter().zip(&sys.loads).enumerate() {
            output[(l, first)] = load.amplitude;
            if let Some((omega, _)) = harmonic {
                generator[(first, first + 1)] = omega;
                generator[(first + 1, first)] = -omega;
            }
        }
        Some(Self {
            output,
            generator,
            states,
        })
    }

    /// `w(t)`, into `w`.
    fn state(&self, t: f64, w: &mut [f64]) {
        for &(first, harmonic) in &self.states {
            match harmonic {
                None => w[first] = 1.0,
                Some((omega, phase)) => {
                    let (sin, cos) = (omega * t + phase).sin_cos();
                    w[first] = sin;
                    w[first + 1] = cos;
                }
            }
        }
    }
}

/// How a wall set's flight is propagated (module docs).
enum Flow {
    /// `Ã = [[A_S, B_S P], [0, Ω]]` and its cached `exp(Ã dt)`.
    Autonomous {
        a: DMatrix<f64>,
        full: Option<DMatrix<f64>>,
    },
    /// Table loads: the cached `exp(A_S dt)` and the Duhamel matrices of a line over the step.
    Piecewise {
        full: Option<(DMatrix<f64>, Vec<DMatrix<f64>>)>,
    },
}

/// Matrices of one wall set.
struct Mode {
    a: DMatrix<f64>,
    b: DMatrix<f64>,
    /// Walls held closed, `G_S`, `W_S⁺`, `M⁻¹ G_Sᵀ`.
    set: Vec<usize>,
    gs: DMatrix<f64>,
    w_pinv: DMatrix<f64>,
    m_inv_gt: DMatrix<f64>,
    /// `Π M⁻¹`.
    pi_m_inv: DMatrix<f64>,
    /// With an autonomous flow: the rows of `Ã` that give the acceleration, then `λ_S`
    /// (`W_S⁺ G_S M⁻¹ [−K, −C, L P]`), from `z̃`: both are linear in the flight's state.
    rates: Option<DMatrix<f64>>,
    flow: Flow,
}

impl Mode {
    fn new(rig: &Rigidity, loads: Option<&LoadOscillator>, set: Vec<usize>) -> Self {
        let n = rig.n;
        let gs = rig.jacobian(&set);
        let m_inv_gt = &rig.m_inv * gs.transpose();
        let w = &gs * &m_inv_gt;
        let w_pinv = if set.is_empty() {
            DMatrix::zeros(0, 0)
        } else {
            w.clone()
                .pseudo_inverse(1e-12 * w.amax())
                .unwrap_or_else(|_| DMatrix::zeros(set.len(), set.len()))
        };
        let pi_m_inv = &rig.m_inv - &m_inv_gt * &w_pinv * &gs * &rig.m_inv;
        let st = &rig.dense;
        let mut a = DMatrix::zeros(2 * n, 2 * n);
        a.view_mut((0, n), (n, n)).fill_with_identity();
        a.view_mut((n, 0), (n, n))
            .copy_from(&(-(&pi_m_inv * &st.stiffness)));
        a.view_mut((n, n), (n, n))
            .copy_from(&(-(&pi_m_inv * &st.damping)));
        let nl = rig.load_cols.ncols();
        let mut b = DMatrix::zeros(2 * n, nl);
        b.view_mut((n, 0), (n, nl))
            .copy_from(&(&pi_m_inv * &rig.load_cols));
        let (flow, rates) = match loads {
            Some(osc) => {
                let m = osc.generator.nrows();
                let mut aug = DMatrix::zeros(2 * n + m, 2 * n + m);
                aug.view_mut((0, 0), (2 * n, 2 * n)).copy_from(&a);
                aug.view_mut((0, 2 * n), (2 * n, m))
                    .copy_from(&(&b * &osc.output));
                aug.view_mut((2 * n, 2 * n), (m, m))
                    .copy_from(&osc.generator);
                // f = [−K, −C, L P] z̃: a = Π M⁻¹ f, λ_S = W_S⁺ G_S M⁻¹ f
                let mut force = DMatrix::zeros(n, 2 * n + m);
                force.view_mut((0, 0), (n, n)).copy_from(&(-&st.stiffness));
                force.view_mut((0, n), (n, n)).copy_from(&(-&st.damping));
                force
                    .view_mut((0, 2 * n), (n, m))
                    .copy_from(&(&rig.load_cols * &osc.output));
                let ns = set.len();
                let mut rates = DMatrix::zeros(n + ns, 2 * n + m);
                rates
                    .view_mut((0, 0), (n, 2 * n + m))
                    .copy_from(&aug.view((n, 0), (n, 2 * n + m)));
                if ns > 0 {
                    rates
                        .view_mut((n, 0), (ns, 2 * n + m))
                        .copy_from(&(&w_pinv * (&gs * (&rig.m_inv * force))));
                }
                (Flow::Autonomous { a: aug, full: None }, Some(rates))
            }
            None => (Flow::Piecewise { full: None }, None),
        };
        Self {
            a,
            b,
            set,
            gs,
            w_pinv,
            m_inv_gt,
            pi_m_inv,
            rates,
            flow,
        }
    }

    /// `exp(A_S η)` and the Duhamel matrices `D_0`, `D_1` of a load linear over `η`.
    fn operator(&self, eta: f64) -> (DMatrix<f64>, Vec<DMatrix<f64>>) {
        duhamel(&self.a, eta, &self.b, 1)
    }

    /// Caches the propagator of the full step `h0`.
    fn prepare(&mut self, h0: f64) {
        match &mut self.flow {
            Flow::Autonomous { a, full } if full.is_none() => *full = Some(expm(&(&*a * h0))),
            Flow::Piecewise { full } if full.is_none() => {
                *full = Some(duhamel(&self.a, h0, &self.b, 1));
            }
            _ => {}
        }
    }

    /// `exp(A_S h0)`, once [`Mode::prepare`]d.
    fn full_transition(&self) -> DMatrix<f64> {
        let n2 = self.a.nrows();
        match &self.flow {
            Flow::Autonomous { full, .. } => full
                .as_ref()
                .expect("prepared")
                .view((0, 0), (n2, n2))
                .into_owned(),
            Flow::Piecewise { full } => full.as_ref().expect("prepared").0.clone(),
        }
    }

    /// Contact forces `λ_S` of the stuck walls and the acceleration.
    fn accel(
        &self,
        sys: &System,
        rig: &Rigidity,
        t: f64,
        x: &DVector<f64>,
        v: &DVector<f64>,
    ) -> (DVector<f64>, DVector<f64>) {
        let f = rig.smooth_force(sys, t, x, v);
        let a = &self.pi_m_inv * &f;
        let lambda = if self.set.is_empty() {
            DVector::zeros(0)
        } else {
            &self.w_pinv * (&self.gs * (&rig.m_inv * &f))
        };
        (lambda, a)
    }

    /// `λ̇_S`, with `Ḟ` by a central difference of the loads.
    fn lambda_rate(
        &self,
        sys: &System,
        rig: &Rigidity,
        t: f64,
        v: &DVector<f64>,
        a: &DVector<f64>,
        dt: f64,
    ) -> DVector<f64> {
        if self.set.is_empty() {
            return DVector::zeros(0);
        }
        let st = &sys.structure;
        let eps = 1e-4 * dt;
        let mut fdot = DVector::zeros(rig.n);
        for load in &sys.loads {
            let d = (load.value(t + eps) - load.value(t - eps)) / (2.0 * eps);
            for &k in &load.dofs {
                fdot[k] += d;
            }
        }
        st.damping.mul_add(-1.0, a.as_slice(), fdot.as_mut_slice());
        st.stiffness
            .mul_add(-1.0, v.as_slice(), fdot.as_mut_slice());
        &self.w_pinv * (&self.gs * (&rig.m_inv * fdot))
    }

    /// Holds the stuck walls exactly closed (mass-weighted projection).
    fn project(&self, rig: &Rigidity, x: &mut DVector<f64>, v: &mut DVector<f64>) {
        if self.set.is_empty() {
            return;
        }
        let gap = DVector::from_iterator(
            self.set.len(),
            self.set.iter().map(|&j| rig.penetration(j, x)),
        );
        *x -= &self.m_inv_gt * (&self.w_pinv * gap);
        let rate = &self.gs * &*v;
        *v -= &self.m_inv_gt * (&self.w_pinv * rate);
    }
}

/// A state of the flight, with its acceleration and the forces `λ` of the stuck walls
/// (computed once, where the state is).
#[derive(Clone)]
struct Point {
    t: f64,
    x: DVector<f64>,
    v: DVector<f64>,
    a: DVector<f64>,
    lambda: DVector<f64>,
}

struct Driver<'a> {
    sys: &'a System,
    rig: Rigidity,
    /// The loads as an oscillator, unless one is a table.
    loads: Option<LoadOscillator>,
    method: EventDriven,
    h0: f64,
    /// The wall sets met so far, each with its matrices.
    modes: Vec<Mode>,
    /// Index in `modes` of the current wall set, `stuck`.
    current: usize,
    pos_tol: f64,
    vel_tol: f64,
    records: Vec<ImpactRecord>,
    open: Vec<Option<usize>>,
    /// Walls held closed, sorted.
    stuck: Vec<usize>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Event {
    Impact(usize),
    Release(usize),
}

/// Quintic Hermite interpolant on `[0, 1]` of values, first and second derivatives (the
/// derivatives already scaled by the interval length).
fn quintic(p: [f64; 6], s: f64) -> f64 {
    let (s2, s3) = (s * s, s * s * s);
    let (s4, s5) = (s3 * s, s3 * s2);
    let h0 = 1.0 - 10.0 * s3 + 15.0 * s4 - 6.0 * s5;
    let h1 = s - 6.0 * s3 + 8.0 * s4 - 3.0 * s5;
    let h2 = 0.5 * (s2 - 3.0 * s3 + 3.0 * s4 - s5);
    let h3 = 10.0 * s3 - 15.0 * s4 + 6.0 * s5;
    let h4 = -4.0 * s3 + 7.0 * s4 - 3.0 * s5;
    let h5 = 0.5 * (s3 - 2.0 * s4 + s5);
    p[0] * h0 + p[1] * h1 + p[2] * h2 + p[3] * h3 + p[4] * h4 + p[5] * h5
}

fn cubic(p: [f64; 4], s: f64) -> f64 {
    let (s2, s3) = (s * s, s * s * s);
    p[0] * (2.0 * s3 - 3.0 * s2 + 1.0)
        + p[1] * (s3 - 2.0 * s2 + s)
        + p[2] * (-2.0 * s3 + 3.0 * s2)
        + p[3] * (s3 - s2)
}

/// The breakpoints of the table loads strictly inside the flight from `t` of length `eta`
/// (not within round-off of its ends), in increasing order: between them every load is
/// linear in time.
fn breakpoints(sys: &System, t: f64, eta: f64) -> Vec<f64> {
    let (lo, hi) = (t + 1e-12 * eta, t + eta * (1.0 - 1e-12));
    let mut cuts: Vec<f64> = Vec::new();
    for load in &sys.loads {
        if let LoadHistory::Table { time, .. } = &load.history {
            let first = time.partition_point(|&s| s <= lo);
            cuts.extend(time[first..].iter().take_while(|&&s| s < hi));
        }
    }
    cuts.sort_by(f64::total_cmp);
    cuts.dedup();
    cuts
}

/// An upper bound of [`quintic`] on `[0, 1]`, with room for its round-off: the weights of the
/// end values are in `[0, 1]` and sum to 1, the others are below `16/81` (those of the
/// first derivatives) and `0.01728` (the second) in magnitude.
fn quintic_bound(p: [f64; 6]) -> f64 {
    let derivatives = 0.1976 * (p[1].abs() + p[4].abs()) + 0.0173 * (p[2].abs() + p[5].abs());
    let scale = p.iter().map(|c| c.abs()).sum::<f64>();
    p[0].max(p[3]) + derivatives + 1e-12 * scale
}

const SAMPLES: usize = 32;

impl Driver<'_> {
    /// Makes the mode of `stuck` the current one, built on its first use.
    fn select(&mut self) {
        self.current = match self.modes.iter().position(|m| m.set == self.stuck) {
            Some(i) => i,
            None => {
                let mut m = Mode::new(&self.rig, self.loads.as_ref(), self.stuck.clone());
                m.prepare(self.h0);
                self.modes.push(m);
                self.modes.len() - 1
            }
        };
    }

    /// The matrices of the current wall set.
    fn mode(&self) -> &Mode {
        &self.modes[self.current]
    }

    /// Exact state after `eta` from `p` with the current wall set.
    fn advance(&self, p: &Point, eta: f64) -> Point {
        let h0 = self.h0;
        let full = (eta - h0).abs() <= 1e-12 * h0;
        let mode = self.mode();
        let n = self.rig.n;
        let sys = self.sys;
        let mut rates = None;
        let z1 = match &mode.flow {
            Flow::Autonomous { a, full: cached } => {
                let z = self.flight_state(p);
                let z1 = if full {
                    cached.as_ref().expect("prepared") * z
                } else {
                    expm_action(a, &z, eta).unwrap_or_else(|| expm(&(a * eta)) * &z)
                };
                rates = mode.rates.as_ref().map(|r| r * &z1);
                z1
            }
            Flow::Piecewise { full: cached } => {
                let mut z = DVector::zeros(2 * n);
                z.rows_mut(0, n).copy_from(&p.x);
                z.rows_mut(n, n).copy_from(&p.v);
                let loads = |t: f64| {
                    DVector::from_iterator(sys.loads.len(), sys.loads.iter().map(|l| l.value(t)))
                };
                let cuts = breakpoints(sys, p.t, eta);
                let mut start = p.t;
                let mut l0 = loads(start);
                for end in cuts.iter().copied().chain([p.t + eta]) {
                    let fresh;
                    let (phi, d) = if full && cuts.is_empty() {
                        let f = cached.as_ref().expect("prepared");
                        (&f.0, &f.1)
                    } else {
                        fresh = mode.operator(end - start);
                        (&fresh.0, &fresh.1)
                    };
                    let l1 = loads(end);
                    z = phi * z + &d[0] * &l0 + &d[1] * (&l1 - &l0);
                    (start, l0) = (end, l1);
                }
                z
            }
        };
        let mut x = z1.rows(0, n).into_owned();
        let mut v = z1.rows(n, n).into_owned();
        mode.project(&self.rig, &mut x, &mut v);
        let t = p.t + eta;
        match rates {
            Some(r) => Point {
                t,
                x,
                v,
                a: r.rows(0, n).into_owned(),
                lambda: r.rows(n, r.nrows() - n).into_owned(),
            },
            None => self.point(t, x, v),
        }
    }

    /// The autonomous flight's state `z̃ = [x; v; w]` at `p` (constant and harmonic loads).
    fn flight_state(&self, p: &Point) -> DVector<f64> {
        let osc = self.loads.as_ref().expect("autonomous flow");
        let n = self.rig.n;
        let mut z = DVector::zeros(2 * n + osc.generator.nrows());
        z.rows_mut(0, n).copy_from(&p.x);
        z.rows_mut(n, n).copy_from(&p.v);
        osc.state(p.t, &mut z.as_mut_slice()[2 * n..]);
        z
    }

    /// The forcing `Q` of a load parameter's column in the current wall set's flight: the
    /// column `c = ∂z/∂p` obeys `c' = A_S c + Q z̃`. An amplitude or a phase enters through the
    /// loads' output, `∂F/∂p = (∂P/∂p) w`: the load's own state `w_k` (`sin θ`; a constant
    /// load's 1) for its amplitude, `a_k cos θ` for its phase. The frequency `f` of the forcing
    /// period scales the run's time (its length and steps are fixed fractions of `1/f`): at a
    /// fixed phase `s = f t` the flight is `dz̃/ds = Ã z̃/f` with `Ω/f` constant, so
    /// `dc/ds = A_S c/f − ż/f²`, that is `c' = A_S c + r ż`, `r = −1/f`
    /// ([`Parameter::time_scale`]), `Q = r Ã_z` (the rows of `Ã` that give `ż`).
    fn column_forcing(&self, parameter: Parameter) -> DMatrix<f64> {
        let mode = self.mode();
        let Flow::Autonomous { a, .. } = &mode.flow else {
            unreachable!("carries_parameter: constant and harmonic loads only")
        };
        let osc = self.loads.as_ref().expect("autonomous flow");
        let n2 = 2 * self.rig.n;
        let mut q = DMatrix::zeros(a.nrows(), a.ncols());
        match parameter {
            Parameter::LoadFrequency(_) => q
                .rows_mut(0, n2)
                .copy_from(&(a.rows(0, n2) * parameter.time_scale(self.sys))),
            Parameter::LoadAmplitude(k) | Parameter::LoadPhase(k) => {
                let first = osc.states[k].0;
                let (state, weight) = match parameter {
                    Parameter::LoadAmplitude(_) => (first, 1.0),
                    _ => (first + 1, self.sys.loads[k].amplitude),
                };
                q.view_mut((0, n2 + state), (n2, 1))
                    .copy_from(&(mode.b.column(k) * weight));
            }
            Parameter::Clearance(_) => {}
            Parameter::SpinSpeed => unreachable!("carries_parameter: not the spin speed"),
        }
        q
    }

    /// `(∫₀^h exp(Ã (h − τ)) Q exp(Ã τ) dτ)_z` for the current wall set's flight of length
    /// `h` and a load parameter's forcing `Q` ([`Driver::column_forcing`]): the upper right
    /// block of `exp([[Ã, Q], [0, Ã]] h)` (Van Loan 1978), its `z` rows. Applied to the
    /// flight's start `z̃₀` it is what the parameter adds to the column over the flight.
    fn column_flow(&self, parameter: Parameter, h: f64) -> DMatrix<f64> {
        let Flow::Autonomous { a, .. } = &self.mode().flow else {
            unreachable!("carries_parameter: constant and harmonic loads only")
        };
        let m = a.nrows();
        let mut big = DMatrix::zeros(2 * m, 2 * m);
        big.view_mut((0, 0), (m, m)).copy_from(a);
        big.view_mut((0, m), (m, m))
            .copy_from(&self.column_forcing(parameter));
        big.view_mut((m, m), (m, m)).copy_from(a);
        expm(&(big * h))
            .view((0, m), (2 * self.rig.n, m))
            .into_owned()
    }

    /// The point at `t`, `x`, `v` with its acceleration and forces, for the current wall set.
    fn point(&self, t: f64, x: DVector<f64>, v: DVector<f64>) -> Point {
        let (lambda, a) = self.mode().accel(self.sys, &self.rig, t, &x, &v);
        Point { t, x, v, a, lambda }
    }

    /// `exp(A_S η)` of the current wall set (cached for the full step).
    fn transition(&self, eta: f64) -> DMatrix<f64> {
        let mode = self.mode();
        if (eta - self.h0).abs() <= 1e-12 * self.h0 {
            mode.full_transition()
        } else {
            expm(&(&mode.a * eta))
        }
    }

    /// `λ` of the stuck walls and the acceleration, with the current wall set, computed anew
    /// (a point carries them: `p.lambda`, `p.a`).
    fn accel(&self, p: &Point) -> (DVector<f64>, DVector<f64>) {
        self.mode().accel(self.sys, &self.rig, p.t, &p.x, &p.v)
    }

    fn lambda_rate(&self, p: &Point, a: &DVector<f64>) -> DVector<f64> {
        self.mode()
            .lambda_rate(self.sys, &self.rig, p.t, &p.v, a, self.h0)
    }

    /// Event function of a candidate at `p`: value and time derivative, increasing through 0.
    fn event_value(&mut self, ev: Event, p: &Point) -> (f64, f64) {
        match ev {
            Event::Impact(j) => (self.rig.penetration(j, &p.x), self.rig.rate(j, &p.v)),
            Event::Release(j) => {
                let r = self.stuck.iter().position(|&k| k == j).unwrap();
                let ld = self.lambda_rate(p, &p.a);
                (-p.lambda[r], -ld[r])
            }
        }
    }

    /// Refines an event inside `(lo, hi]` from `guess` on the exact solution (Newton with
    /// bisection as the safeguard); returns the event instant offset and the state there.
    fn refine(&mut self, p0: &Point, ev: Event, lo: f64, hi: f64, guess: f64) -> (f64, Point) {
        self.root(p0, |d, p| d.event_value(ev, p), lo, hi, guess)
    }

    /// The instant in `(lo, hi]` after `p0` where `f` (value and time derivative at a state,
    /// increasing through 0) vanishes on the exact solution, from `guess` by Newton with
    /// bisection as the safeguard, and the state there.
    fn root(
        &mut self,
        p0: &Point,
        f: impl Fn(&mut Self, &Point) -> (f64, f64),
        mut lo: f64,
        mut hi: f64,
        guess: f64,
    ) -> (f64, Point) {
        let mut tau = guess.clamp(lo, hi);
        let tol = 4.0 * f64::EPSILON * (p0.t + hi).max(self.h0);
        let mut state = self.advance(p0, tau);
        for _ in 0..60 {
            let (f, df) = f(self, &state);
            if f < 0.0 {
                lo = lo.max(tau);
            } else {
                hi = hi.min(tau);
            }
            if f == 0.0 || hi - lo <= tol {
                break;
            }
            let mut next = if df > 0.0 { tau - f / df } else { f64::NAN };
            if !(next > lo && next < hi) {
                next = 0.5 * (lo + hi);
            }
            let converged = (next - tau).abs() <= tol;
            tau = next;
            state = self.advance(p0, tau);
            if converged {
                break;
            }
        }
        // Land on the side where the event has happened (δ ≥ 0 / λ ≤ 0) within round-off.
        (tau, state)
    }

    /// The earliest event in `(0, eta]` from `p0` (whose end state is `p1`), if any.
    fn find_event(&mut self, p0: &Point, p1: &Point, eta: f64) -> Option<(f64, Event, Point)> {
        let nw = self.rig.n_walls();
        let (l0, a0) = (&p0.lambda, &p0.a);
        let (l1, a1) = (&p1.lambda, &p1.a);
        let mut candidates: Vec<(f64, f64, f64, Event)> = Vec::new();
        for j in 0..nw {
            if let Some(r) = self.stuck.iter().position(|&k| k == j) {
                let ld0 = self.lambda_rate(p0, a0)[r];
                let ld1 = self.lambda_rate(p1, a1)[r];
                let c = [l0[r], eta * ld0, l1[r], eta * ld1];
                let mut prev = 0.0;
                for i in 1..=SAMPLES {
                    let s = i as f64 / SAMPLES as f64;
                    if cubic(c, s) < 0.0 {
                        let g = bisect(|s| -cubic(c, s), prev, s);
                        candidates.push((prev * eta, s * eta, g * eta, Event::Release(j)));
                        break;
                    }
                    prev = s;
                }
                continue;
            }
            let g = &self.rig.g[j];
            let (d0, r0, q0) = (self.rig.penetration(j, &p0.x), g.dot(&p0.v), g.dot(a0));
            let (d1, r1, q1) = (self.rig.penetration(j, &p1.x), g.dot(&p1.v), g.dot(a1));
            let c = [d0, eta * r0, eta * eta * q0, d1, eta * r1, eta * eta * q1];
            // No sample can be above the wall (nor above the threshold below, >= 0): the
            // wall stays open, as sampling would find.
            if quintic_bound(c) <= 0.0 {
                continue;
            }
            // A wall that starts on contact (just released, or grazing) must get clearly
            // into it within the first sample: round-off around δ = 0 is not an impact.
            let on_wall = d0.abs() <= self.pos_tol;
            let mut prev = 0.0;
            for i in 1..=SAMPLES {
                let s = i as f64 / SAMPLES as f64;
                let threshold = if i == 1 && on_wall { self.pos_tol } else { 0.0 };
                if quintic(c, s) > threshold {
                    let guess = if i == 1 && on_wall {
                        // Leaving the wall: the next contact of a short flight.
                        if r0 < 0.0 && q0 > 0.0 {
                            (-2.0 * r0 / q0 / eta).min(s)
                        } else {
                            0.5 * s
                        }
                    } else {
                        bisect(|s| quintic(c, s), prev, s)
                    };
                    let lo = if i == 1 { 0.0 } else { prev * eta };
                    candidates.push((lo, s * eta, guess * eta, Event::Impact(j)));
                    break;
                }
                prev = s;
            }
        }
        let mut best: Option<(f64, Event, Point)> = None;
        for (lo, hi, guess, ev) in candidates {
            let (tau, state) = self.refine(p0, ev, lo, hi, guess);
            let (f, _) = self.event_value(ev, &state);
            // A false alarm of the interpolant: the exact solution does not reach the event.
            if f < -self.tol_of(ev) {
                continue;
            }
            if best.as_ref().is_none_or(|b| tau < b.0) {
                best = Some((tau, ev, state));
            }
        }
        best
    }

    fn tol_of(&self, ev: Event) -> f64 {
        match ev {
            Event::Impact(_) => self.pos_tol,
            Event::Release(_) => f64::INFINITY,
        }
    }

    fn open_record(&mut self, j: usize, t: f64, v_in: f64) -> usize {
        let wall = &self.sys.walls[j];
        self.records.push(ImpactRecord {
            gap: wall.gap,
            side: wall.sign,
            t_start: t,
            t_end: t,
            v_in,
            v_out: f64::NAN,
            delta_max: 0.0,
            force_max: f64::NAN,
            friction_max: 0.0,
            impulse: 0.0,
        });
        self.records.len() - 1
    }

    /// Resolves an event at `p` (impacts, sticking, release); `released` is the wall whose
    /// force reached zero, if that was the event; `plastic` makes every impact plastic.
    /// Returns the energy the impacts dissipated, J, and each impact (wall, approach and
    /// separation speed, m/s).
    fn resolve(
        &mut self,
        p: &mut Point,
        released: Option<usize>,
        plastic: bool,
    ) -> (f64, Vec<(usize, f64, f64)>) {
        let nw = self.rig.n_walls();
        let contact: Vec<usize> = (0..nw)
            .filter(|&j| self.rig.penetration(j, &p.x) >= -self.pos_tol)
            .collect();
        if contact.is_empty() {
            return (0.0, Vec::new());
        }
        let v_before = p.v.clone();
        let rate0: Vec<f64> = contact.iter().map(|&j| self.rig.rate(j, &p.v)).collect();
        let mut e: Vec<f64> = contact
            .iter()
            .map(|&j| {
                if plastic {
                    0.0
                } else {
                    self.rig.restitution[j]
                }
            })
            .collect();
        let gc = self.rig.jacobian(&contact);
        let m_inv_gt = &self.rig.m_inv * gc.transpose();
        let w = &gc * &m_inv_gt;
        let mut impulse = vec![0.0; contact.len()];
        if rate0.iter().any(|&r| r > self.vel_tol) {
            // Impacts: generalized Newton law, repeated once with the chattering walls plastic.
            for _ in 0..2 {
                let q: Vec<f64> = rate0.iter().zip(&e).map(|(r, e)| -(1.0 + e) * r).collect();
                impulse = solve_lcp(&w, &q);
                let v_after = &v_before - &m_inv_gt * DVector::from_column_slice(&impulse);
                // Chattering: the flight after this impact would be too short.
                let (_, a) = self.mode().accel(self.sys, &self.rig, p.t, &p.x, &v_after);
                let mut changed = false;
                for (r, &j) in contact.iter().enumerate() {
                    if impulse[r] > 0.0 && e[r] > 0.0 {
                        let sep = -self.rig.rate(j, &v_after);
                        let push = self.rig.g[j].dot(&a);
                        if push > 0.0
                            && sep > 0.0
                            && 2.0 * sep / push < self.method.chatter_fraction * self.h0
                        {
                            e[r] = 0.0;
                            changed = true;
                        }
                    }
                }
                p.v = v_after;
                if !changed {
                    break;
                }
            }
        }
        let (k0, _) = self.rig.energies(self.sys, &p.x, &v_before);
        let (k1, _) = self.rig.energies(self.sys, &p.x, &p.v);
        let mut impacts = Vec::new();
        // Impact rows.
        for (r, &j) in contact.iter().enumerate() {
            if impulse[r] <= 0.0 {
                continue;
            }
            impacts.push((j, rate0[r].max(0.0), (-self.rig.rate(j, &p.v)).max(0.0)));
            if let Some(idx) = self.open[j] {
                self.records[idx].impulse += impulse[r];
                continue;
            }
            let idx = self.open_record(j, p.t, rate0[r].max(0.0));
            let rec = &mut self.records[idx];
            rec.impulse = impulse[r];
            rec.v_out = (-self.rig.rate(j, &p.v)).max(0.0);
        }
        // Sticking: the walls at rest on contact solve the acceleration LCP.
        let at_rest: Vec<usize> = contact
            .iter()
            .copied()
            .filter(|&j| Some(j) != released && self.rig.rate(j, &p.v).abs() <= self.vel_tol)
            .collect();
        let new_stuck: Vec<usize> = if at_rest.is_empty() {
            Vec::new()
        } else {
            let ga = self.rig.jacobian(&at_rest);
            let wa = &ga * (&self.rig.m_inv * ga.transpose());
            let f = self.rig.smooth_force(self.sys, p.t, &p.x, &p.v);
            let q: Vec<f64> = (-(&ga * (&self.rig.m_inv * f))).iter().copied().collect();
            let lambda = solve_lcp(&wa, &q);
            let scale = lambda.iter().fold(0.0f64, |m, l| m.max(*l));
            at_rest
                .iter()
                .zip(&lambda)
                .filter(|(_, &l)| l > 1e-12 * scale)
                .map(|(&j, _)| j)
                .collect()
        };
        // Rows of walls that start or stop sticking.
        for j in 0..nw {
            let was = self.stuck.contains(&j);
            let is = new_stuck.contains(&j);
            if is && !was {
                // The impact that ended the chattering, or a grazing touch, stays open.
                let idx = match self.records.iter().rposition(|r| {
                    r.t_start == p.t
                        && r.gap == self.sys.walls[j].gap
                        && r.side == self.sys.walls[j].sign
                }) {
                    Some(idx) => idx,
                    None => self.open_record(j, p.t, 0.0),
                };
                let rec = &mut self.records[idx];
                rec.t_end = f64::NAN;
                rec.v_out = f64::NAN;
                self.open[j] = Some(idx);
            } else if was && !is {
                if let Some(idx) = self.open[j].take() {
                    let rec = &mut self.records[idx];
                    rec.t_end = p.t;
                    rec.v_out = (-self.rig.rate(j, &p.v)).max(0.0);
                }
            }
        }
        self.stuck = new_stuck;
        self.select();
        self.modes[self.current].project(&self.rig, &mut p.x, &mut p.v);
        (p.lambda, p.a) = self.accel(p);
        (k0 - k1, impacts)
    }

    /// Adds `∫ λ dt` (trapezoidal) and the peak force of the stuck walls over `[p0, p1]`.
    fn stuck_forces(&mut self, p0: &Point, p1: &Point) {
        if self.stuck.is_empty() {
            return;
        }
        let (l0, l1) = (&p0.lambda, &p1.lambda);
        for (r, &j) in self.stuck.iter().enumerate() {
            if let Some(idx) = self.open[j] {
                let rec = &mut self.records[idx];
                rec.impulse += 0.5 * (p1.t - p0.t) * (l0[r] + l1[r]);
                let peak = l0[r].max(l1[r]);
                rec.force_max = if rec.force_max.is_nan() {
                    peak
                } else {
                    rec.force_max.max(peak)
                };
            }
        }
    }

    /// Writes `p` into the run's state `s`: the acceleration and the contact forces `λ` of
    /// the stuck walls (all of it elastic, so that the run's energy account adds no contact
    /// work: the impacts' dissipation goes to it through [`Run::jump`]).
    fn fill(&mut self, p: &Point, s: &mut State) {
        let sys = self.sys;
        let l = &p.lambda;
        s.t = p.t;
        s.x.copy_from_slice(p.x.as_slice());
        s.v.copy_from_slice(p.v.as_slice());
        s.a.copy_from_slice(p.a.as_slice());
        fill_gaps(sys, &self.rig, s, |j| {
            self.stuck
                .iter()
                .position(|&k| k == j)
                .map_or(0.0, |r| l[r].max(0.0))
        });
    }
}

/// Root of `f` in `[a, b]` with `f(a) ≤ 0 < f(b)`, by bisection to 1e-6 of the interval.
fn bisect(f: impl Fn(f64) -> f64, mut a: f64, mut b: f64) -> f64 {
    for _ in 0..24 {
        let m = 0.5 * (a + b);
        if f(m) > 0.0 {
            b = m;
        } else {
            a = m;
        }
    }
    0.5 * (a + b)
}

/// The event-driven method as the run's step policy: each step of the grid `k·dt` is the
/// flights between the events inside it, each committed to the run, with the state changed
/// in place at each event ([`Run::jump`]).
pub(crate) struct EventDrivenSteps<'s> {
    d: Driver<'s>,
    p: Point,
    h0: f64,
    n_steps: usize,
    /// Steps of the grid taken.
    k: usize,
    /// The state-transition matrix, when the run asks for it (`Run::wants_sensitivity`):
    /// `exp(A h)` of every flight (exact for the linear structure) and the saltation matrix
    /// of every impact; with a clearance's column (`Run::sensitivity_parameter`), each wall's
    /// `∂δ/∂p` for its impacts; with a load's, the flights' part ([`Driver::column_forcing`]).
    transition: Option<StateTransition>,
    clearance_derivative: Vec<f64>,
    /// A load's parameter whose column the flights carry ([`Driver::column_forcing`]), with
    /// each wall set's [`Driver::column_flow`] over the full step, cached.
    load_parameter: Option<Parameter>,
    column_flows: Vec<Option<DMatrix<f64>>>,
}

impl<'s> EventDrivenSteps<'s> {
    /// From `run.cur` (at `t = 0`), resolving an impact there; `n_steps` steps of `h0`.
    pub fn new(
        run: &mut Run,
        sys: &'s System,
        method: EventDriven,
        n_steps: usize,
        h0: f64,
    ) -> Result<Self, SimError> {
        method.validate()?;
        let rig = Rigidity::new(sys, METHOD)?;
        let x0 = DVector::from_column_slice(&run.cur.x);
        let v0 = DVector::from_column_slice(&run.cur.v);
        check_initial(sys, &rig, &x0)?;
        let nw = rig.n_walls();
        // Round-off scales of the gap coordinates and rates.
        let a0 = &rig.m_inv * rig.smooth_force(sys, 0.0, &x0, &v0);
        let t_end = n_steps as f64 * h0;
        let mut x_scale = 1e-300f64;
        let mut v_scale = 1e-300f64;
        for j in 0..nw {
            let g = &rig.g[j];
            x_scale = x_scale
                .max(rig.clearance[j].abs())
                .max(g.dot(&x0).abs())
                .max(g.dot(&v0).abs() * h0)
                .max(g.dot(&a0).abs() * h0 * h0);
            v_scale = v_scale
                .max(g.dot(&v0).abs())
                .max(g.dot(&a0).abs() * t_end.min(1e3 * h0));
        }
        v_scale = v_scale.max(x_scale / h0);
        let mut d = Driver {
            sys,
            rig,
            loads: LoadOscillator::new(sys),
            method,
            h0,
            modes: Vec::new(),
            current: 0,
            pos_tol: 1e-10 * x_scale,
            vel_tol: 1e-10 * v_scale,
            records: Vec::new(),
            open: vec![None; nw],
            stuck: Vec::new(),
        };
        d.select();
        let p = d.point(0.0, x0, v0);
        let parameter = run.sensitivity_parameter;
        let transition = run
            .wants_sensitivity
            .then(|| StateTransition::start(d.rig.n, parameter.is_some()));
        let clearance_derivative = (0..nw)
            .map(|j| parameter.map_or(0.0, |p| p.penetration_derivative(sys, j)))
            .collect();
        let load_parameter =
            parameter.filter(|p| run.wants_sensitivity && !matches!(p, Parameter::Clearance(_)));
        let mut policy = Self {
            d,
            p,
            h0,
            n_steps,
            k: 0,
            transition,
            clearance_derivative,
            load_parameter,
            column_flows: Vec::new(),
        };
        policy.resolve(run, None, false);
        Ok(policy)
    }

    /// The impact table.
    pub fn impacts(self) -> Vec<ImpactRecord> {
        self.d.records
    }

    /// Resolves the event at the current point and makes the result the run's state; returns
    /// the walls that took an impulse.
    fn resolve(&mut self, run: &mut Run, released: Option<usize>, plastic: bool) -> Vec<usize> {
        let (dissipated, impacts) = self.d.resolve(&mut self.p, released, plastic);
        run.jump(dissipated, |cur| self.d.fill(&self.p, cur));
        impacts
            .into_iter()
            .map(|(j, v_in, v_out)| {
                run.impact(self.d.sys, j, self.p.t, v_in, v_out);
                j
            })
            .collect()
    }

    /// `Φ ← exp(A h) Φ` for a flight of length `h` from the current point, just committed;
    /// a load parameter's column `c ← exp(A h) c + (Van Loan's block) z̃₀`
    /// ([`Driver::column_flow`]).
    fn carry_flight(&mut self, h: f64) {
        let Some(t) = &mut self.transition else {
            return;
        };
        t.matrix = self.d.transition(h) * &t.matrix;
        let Some(parameter) = self.load_parameter else {
            return;
        };
        let d = &self.d;
        let fresh;
        let flow = if (h - self.h0).abs() <= 1e-12 * self.h0 {
            if self.column_flows.len() <= d.current {
                self.column_flows.resize(d.current + 1, None);
            }
            &*self.column_flows[d.current].get_or_insert_with(|| d.column_flow(parameter, h))
        } else {
            fresh = d.column_flow(parameter, h);
            &fresh
        };
        let m = t.matrix.nrows();
        let mut column = t.matrix.column_mut(m);
        column += flow * d.flight_state(&self.p);
    }

    /// `Φ ← S Φ` at the impact of wall `j` from `before` to the current point: the velocity
    /// jump `v⁺ = R_v v⁻`, `R_v = I − (1 + e) M⁻¹ g gᵀ/(g M⁻¹ gᵀ)` with the restitution `e`
    /// that was applied, and the saltation matrix `S = R + (f⁺ − R f⁻) ∇hᵀ/(∇hᵀ f⁻)`,
    /// `h = g·x − d` (docs/periodic-orbits.md). A sticking wall or simultaneous impacts are
    /// refused: their derivative is not computed.
    fn carry_impact(&mut self, before: &Point, walls: &[usize]) -> Result<(), SimError> {
        if self.transition.is_none() {
            return Ok(());
        }
        let t = self.p.t;
        let unsupported = |what: &str| {
            Err(SimError::InvalidModel(format!(
                "solver: the state-transition matrix is not available at t = {t:.9e} s: {what};                  expected separate impacts (no sticking, no simultaneous impacts)"
            )))
        };
        if !self.d.stuck.is_empty() {
            return unsupported("a wall sticks (contact at rest)");
        }
        let &[j] = walls else {
            return if walls.is_empty() {
                Ok(())
            } else {
                unsupported("walls are hit at the same instant")
            };
        };
        let n = self.d.rig.n;
        let g = self.d.rig.g[j].clone();
        let (rate_in, rate_out) = (g.dot(&before.v), g.dot(&self.p.v));
        let m_inv_g = &self.d.rig.m_inv * &g;
        let mut jump = DMatrix::identity(2 * n, 2 * n);
        let scale = (rate_in - rate_out) / rate_in / g.dot(&m_inv_g);
        let mut velocity_block = jump.view_mut((n, n), (n, n));
        velocity_block -= &m_inv_g * g.transpose() * scale;
        let (_, a_minus) = self.d.accel(before);
        let (_, a_plus) = self.d.accel(&self.p.clone());
        let field = |v: &DVector<f64>, a: &DVector<f64>| {
            let mut f = DVector::zeros(2 * n);
            f.rows_mut(0, n).copy_from(v);
            f.rows_mut(n, n).copy_from(a);
            f
        };
        let f_minus = field(&before.v, &a_minus);
        let f_plus = field(&self.p.v, &a_plus);
        let mut grad = DVector::zeros(2 * n);
        grad.rows_mut(0, n).copy_from(&g);
        let Some(u) = saltation_update(Some(&jump), &f_minus, &f_plus, &grad) else {
            return unsupported("an impact at zero speed (grazing)");
        };
        let transition = self.transition.as_mut().expect("checked");
        transition.compose_event(Some(&jump), &u, &grad, self.clearance_derivative[j]);
        Ok(())
    }
}

impl Driver<'_> {
    /// Commits the flight from `from` (the run's current state) to `to`, of length `h`, with
    /// the turning points of the recorded displacements inside it when an observer watches.
    fn commit(
        &mut self,
        run: &mut Run,
        sys: &System,
        from: &Point,
        to: &Point,
        h: f64,
    ) -> Result<(), SimError> {
        self.fill(to, &mut run.trial);
        if !run.observed() {
            return run.commit_trial(sys, h, 0, None);
        }
        let mut turns = vec![None; self.rig.n];
        for &d in run.recorded_dofs() {
            turns[d] = self.turning_point(from, to, h, d);
        }
        run.commit_with_turns(sys, h, &turns)
    }

    /// Where DOF `d`'s displacement turns inside the flight from `p0` to `p1` (of length
    /// `h`, no event inside) if its velocity changes sign between the ends: the fraction of
    /// the flight and the displacement there, located on the exact solution (the zero of the
    /// velocity by Newton from the quintic interpolant's turning point) to round-off.
    fn turning_point(&mut self, p0: &Point, p1: &Point, h: f64, d: usize) -> Option<Turn> {
        let (v0, v1) = (p0.v[d], p1.v[d]);
        if v0 * v1 >= 0.0 {
            return None;
        }
        let seg = QuinticSegment::new([p0.x[d], v0, p0.a[d]], [p1.x[d], v1, p1.a[d]], h);
        let guess = seg.first_crossing(true, v0 < 0.0, SAMPLES).unwrap_or(0.5);
        // increasing through 0: the velocity at a minimum, minus it at a maximum
        let sign = if v0 < 0.0 { 1.0 } else { -1.0 };
        let (tau, at) = self.root(p0, |_, p| (sign * p.v[d], sign * p.a[d]), 0.0, h, guess * h);
        Some((tau / h, at.x[d]))
    }
}

impl StepPolicy for EventDrivenSteps<'_> {
    fn sensitivity(&self) -> Option<&StateTransition> {
        self.transition.as_ref()
    }

    fn advance(&mut self, run: &mut Run, sys: &System) -> Result<bool, SimError> {
        if self.k == self.n_steps {
            return Ok(false);
        }
        self.k += 1;
        let h0 = self.h0;
        let max_events = self.d.method.max_events_per_step;
        let t_target = self.k as f64 * h0;
        let mut events = 0usize;
        loop {
            let eta = t_target - self.p.t;
            if eta <= 1e-12 * h0 {
                self.p.t = t_target;
                run.cur.t = t_target;
                return Ok(true);
            }
            let mut end = self.d.advance(&self.p, eta);
            match self.d.find_event(&self.p, &end, eta) {
                None => {
                    self.d.stuck_forces(&self.p, &end);
                    end.t = t_target;
                    self.d.commit(run, sys, &self.p, &end, eta)?;
                    self.carry_flight(eta);
                    self.p = end;
                    return Ok(true);
                }
                Some((tau, ev, mut at)) => {
                    at.t = self.p.t + tau;
                    self.d.stuck_forces(&self.p, &at);
                    self.d.commit(run, sys, &self.p, &at, tau)?;
                    self.carry_flight(tau);
                    self.p = at;
                    events += 1;
                    if events > 100 * max_events {
                        return Err(SimError::InvalidModel(format!(
                            "solver: more than {} events in the step ending at t = {t_target:.9e} s; \
                             the impacts accumulate faster than the sticking rule ends them; \
                             raise chatter_fraction",
                            100 * max_events
                        )));
                    }
                    let released = match ev {
                        Event::Release(j) => Some(j),
                        Event::Impact(_) => None,
                    };
                    let before = self.p.clone();
                    let walls = self.resolve(run, released, events > max_events);
                    self.carry_impact(&before, &walls)?;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_quintic_bound_is_above_every_value_on_the_step() {
        // coefficients of every sign and of scales 1e-6 to 1 (a splitmix-like sequence)
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1);
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let mut tight = 0.0f64;
        for _ in 0..5000 {
            let p: [f64; 6] = std::array::from_fn(|_| next() * 10f64.powf(-6.0 * next().abs()));
            let bound = quintic_bound(p);
            let top = (0..=1024)
                .map(|i| quintic(p, i as f64 / 1024.0))
                .fold(f64::NEG_INFINITY, f64::max);
            assert!(top <= bound, "{p:?}: {top} > {bound}");
            if top > 0.0 {
                tight = tight.max(top / bound);
            }
        }
        // and within a factor two of the largest value for some of them
        assert!(tight > 0.5, "{tight}");
    }
}
