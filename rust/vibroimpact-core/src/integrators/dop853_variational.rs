//! DOP853's state-transition matrix: the exact derivative of the discrete scheme at the steps
//! it took ("internal differentiation", Bock 1981). Each stage `Y_i = z₀ + h Σ_j a_ij K_j`,
//! `K_i = f(t_i, Y_i)` is differentiated: `dY_i = Φ₀ + h Σ_j a_ij dK_j`, `dK_i = J(Y_i) dY_i`
//! with `J = [[0, I], [−M⁻¹(K + Σ F_δ bbᵀ), −M⁻¹(C + Σ F_δ̇ bbᵀ)]]` at the stage (the contact
//! tangent of each active wall there), and `Φ₁ = Φ₀ + h Σ_i b_i dK_i`. A law that depends on
//! the approach speed `v_imp` (fixed at the contact's onset) adds `∂F/∂v_imp · ∂v_imp/∂z₀`,
//! the latter taken at the onset through the located switch.
//!
//! The step landed on a wall's switch `h(z(t_s)) = 0` ends at a time that depends on the
//! initial state: `dt_s/dz₀ = −∇hᵀΦ/(∇hᵀf⁻)` with `f⁻` the vector field before the switch. The
//! switching function `h` is the penetration `δ` at a contact's onset or end, and the law's
//! force formula `F(δ, δ̇, v_imp)` where it falls to zero while the wall is still in and is
//! clamped there (Kelvin–Voigt's `k δ + c δ̇` before `δ` reaches 0: its release,
//! `dop853::release_walls`). [`Variational::switch`] keeps that row and moves `Φ` along `f⁻`
//! onto the surface (`Φ ← Φ + f⁻ dt_s/dz₀`, so that `∇hᵀΦ = 0`); the step after it then starts
//! there at the perturbed time under the post-switch law (its stages carry `∂f/∂t · dt_s`, the
//! loads' rate), and its end is brought back to the fixed time (`Φ ← Φ − f dt_s/dz₀`). To first
//! order this is the saltation matrix `S = I + (f⁺ − f⁻) ∇hᵀ / (∇hᵀ f⁻)` at the switch
//! (Kelvin–Voigt's force jump `c δ̇` at the onset included; `S = I` at its release, where the
//! force is continuous and only its slope jumps), and no stage differentiates across the
//! surface: the first stage after it sits on it with `∇hᵀ dY = 0`, where a linear spring's or
//! Kelvin–Voigt's slope jumps, none of which then enters; every other stage is on one side
//! (docs/periodic-orbits.md).
//!
//! With a [`Parameter`], a last column `∂z/∂p` rides along: its stages carry the forcing
//! `[0; M⁻¹(∂F_ext/∂p − Σ s b F_δ ∂δ/∂p)]`, its switches `∂δ/∂p` in `dt_s/dp`, and a load
//! frequency's time scale `r = (dT/dp)/T` moves each step's start by `r t₀` (the loads' rate)
//! and its length by `r h` (`d(end)/dh`).
//!
//! The step sizes are those the error control chose; the steps land on every switch, so the
//! derivative is that of the integrated flow to the method's tolerance. Contacts are then
//! integrated in time only (no step in `ζ = √δ`, whose duration would depend on the state).
//! Dense `2n × 2n` matrices: for the small models DOP853 is meant for.

use nalgebra::{DMatrix, DVector, RowDVector};

use super::super::dop853_tableau::{A, B, C, STAGES};
use super::{dot, radial_normal_force, smooth_switch, Contact, Stages, StepEnd};
use crate::contact::{ContactLaw, MIN_IMPACT_SPEED};
use crate::gap::{radial_contact, Side, WallState};
use crate::sensitivity::{Parameter, StateTransition};
use crate::system::System;

/// Relative step of the central difference of a law's force in its approach speed.
const IMPACT_SPEED_STEP: f64 = 1e-6;

/// `Φ` carried along DOP853's accepted steps.
pub(super) struct Variational {
    n: usize,
    pub(super) phi: StateTransition,
    /// `−M⁻¹K` and `−M⁻¹C`, `n × n`.
    minus_k: DMatrix<f64>,
    minus_c: DMatrix<f64>,
    /// Per wall: its row `s b` (so that `δ = s b·x − d`) and `M⁻¹ s b` (zero for a radial
    /// wall, whose normal turns with the state: [`RadialWall`]).
    rows: Vec<DVector<f64>>,
    m_inv_rows: Vec<DVector<f64>>,
    /// Per wall: its radial gap's DOFs and `M⁻¹` columns, if it is radial.
    radial: Vec<Option<RadialWall>>,
    /// Per wall in contact with a law that uses it: `∂v_imp/∂z₀`.
    impact_speed: Vec<Option<RowDVector<f64>>>,
    /// The stages' `dK_i`, `2n × 2n`.
    dk: Vec<DMatrix<f64>>,
    /// The stages' derivatives in the step's length, `2n`.
    dk_h: Vec<DVector<f64>>,
    /// The last step's `d(end)/dh` (`None` before the first step).
    rate_of_end: Option<DVector<f64>>,
    /// `dt_s/dz₀` of the switch the next step starts from (`None`: no switch there).
    time_shift: Option<RowDVector<f64>>,
    /// The parameter whose column is `Φ`'s last, with its time scale and per wall `∂δ/∂p`.
    parameter: Option<(Parameter, f64, Vec<f64>)>,
    /// The spin speed's column: `−M⁻¹G` (the gyroscopic forces' `∂/∂Ω`), if `G` is there.
    minus_g: Option<DMatrix<f64>>,
}

impl Variational {
    pub(super) fn new(sys: &System, parameter: Option<Parameter>) -> Self {
        let n = sys.n_dof();
        let columns = 2 * n + usize::from(parameter.is_some());
        let st = &sys.structure;
        let column = |j: usize, apply: &dyn Fn(&[f64], &mut [f64])| {
            let mut e = vec![0.0; n];
            e[j] = 1.0;
            let mut out = vec![0.0; n];
            apply(&e, &mut out);
            st.solve_mass(&mut out);
            out
        };
        let matrix = |apply: &dyn Fn(&[f64], &mut [f64])| {
            let columns: Vec<Vec<f64>> = (0..n).map(|j| column(j, apply)).collect();
            DMatrix::from_fn(n, n, |i, j| columns[j][i])
        };
        let minus_k = matrix(&|x, y| st.stiffness.mul_add(-1.0, x, y));
        let minus_c = matrix(&|x, y| st.damping.mul_add(-1.0, x, y));
        let minus_g = (st.gyroscopic.as_ref())
            .filter(|_| parameter == Some(Parameter::SpinSpeed))
            .map(|g| matrix(&|x, y| g.mul_add(-1.0, x, y)));
        let rows: Vec<DVector<f64>> = sys
            .walls
            .iter()
            .map(|wall| {
                let gap = &sys.gaps[wall.gap];
                let mut row = DVector::zeros(n);
                for (&d, &c) in gap.dofs.iter().zip(&gap.coefficients) {
                    row[d] += wall.sign * c;
                }
                row
            })
            .collect();
        let m_inv_rows = rows
            .iter()
            .map(|row| {
                let mut r = row.as_slice().to_vec();
                st.solve_mass(&mut r);
                DVector::from_vec(r)
            })
            .collect();
        let radial = (0..sys.walls.len())
            .map(|j| RadialWall::of(sys, j))
            .collect();
        Self {
            n,
            phi: StateTransition::start(n, parameter.is_some()),
            minus_k,
            minus_c,
            rows,
            m_inv_rows,
            radial,
            impact_speed: vec![None; sys.walls.len()],
            dk: vec![DMatrix::zeros(2 * n, columns); STAGES],
            dk_h: vec![DVector::zeros(2 * n); STAGES],
            rate_of_end: None,
            time_shift: None,
            minus_g,
            parameter: parameter.map(|p| {
                let walls = (0..sys.walls.len())
                    .map(|j| p.penetration_derivative(sys, j))
                    .collect();
                (p, p.time_scale(sys), walls)
            }),
        }
    }

    /// Composes `Φ` with the accepted step of length `h` in time from `start` at `t0`, whose
    /// stage values `stages` holds, under the contact set `contacts`, and keeps the derivative
    /// of its end in its length.
    pub(super) fn step(
        &mut self,
        sys: &System,
        stages: &Stages,
        contacts: &[Contact],
        t0: f64,
        start: &StepEnd,
        h: f64,
    ) {
        let n = self.n;
        let time_shift = self.time_shift.take();
        // the parameter's column: its start time's derivative r t₀
        let scaled = self.parameter.as_ref().map_or(0.0, |p| p.1 * t0);
        let (mut xs, mut vs) = (vec![0.0; n], vec![0.0; n]);
        let stage = |i: usize| {
            let mut k = DVector::zeros(2 * n);
            for d in 0..n {
                k[d] = stages.kx[d][i];
                k[n + d] = stages.kv[d][i];
            }
            k
        };
        let mut rate_of_end = DVector::zeros(2 * n);
        for (i, a_i) in A.iter().enumerate() {
            let mut dy = self.phi.matrix.clone();
            let mut dy_h = DVector::zeros(2 * n);
            for (j, &a) in a_i.iter().enumerate() {
                if a != 0.0 {
                    dy += &self.dk[j] * (h * a);
                    dy_h += (stage(j) + &self.dk_h[j] * h) * a;
                }
            }
            for d in 0..n {
                xs[d] = start.x[d] + h * dot(a_i, &stages.kx[d]);
                vs[d] = start.v[d] + h * dot(a_i, &stages.kv[d]);
            }
            let tangents: Vec<Option<WallTangent>> = sys
                .walls
                .iter()
                .zip(contacts)
                .enumerate()
                .map(|(j, (wall, c))| {
                    c.active.then(|| {
                        if self.radial[j].is_some() {
                            return WallTangent::Radial(radial_tangent(sys, j, c, &xs, &vs));
                        }
                        let row = &self.rows[j];
                        let raw = row.dot(&DVector::from_column_slice(&xs)) - wall.clearance;
                        let rate = row.dot(&DVector::from_column_slice(&vs));
                        let (f_delta, f_rate, f_speed) = tangent(sys, j, c, raw, rate);
                        WallTangent::Line {
                            f_delta,
                            f_rate,
                            f_speed,
                        }
                    })
                })
                .collect();
            let loads = (time_shift.is_some() || C[i] != 0.0 || scaled != 0.0)
                .then(|| load_rate(sys, t0 + C[i] * h));
            let mut bottom = self.apply_jacobian(&tangents, &dy, true);
            if let (Some(shift), Some(loads)) = (&time_shift, &loads) {
                bottom += loads * shift;
            }
            if let Some((p, _, _)) = &self.parameter {
                let mut forcing = p.load_derivative(sys, t0 + C[i] * h);
                sys.structure.solve_mass(forcing.as_mut_slice());
                if let Some(minus_g) = &self.minus_g {
                    forcing += minus_g * DVector::from_column_slice(&vs);
                }
                if let Some(loads) = &loads {
                    forcing += loads * scaled;
                }
                let mut last = bottom.column_mut(2 * n);
                last += forcing;
            }
            let mut bottom_h = self.apply_jacobian(
                &tangents,
                &DMatrix::from_column_slice(2 * n, 1, dy_h.as_slice()),
                false,
            );
            if let Some(loads) = &loads {
                bottom_h += loads * C[i];
            }
            let dk = &mut self.dk[i];
            dk.rows_mut(0, n).copy_from(&dy.rows(n, n));
            dk.rows_mut(n, n).copy_from(&bottom);
            let dk_h = &mut self.dk_h[i];
            dk_h.rows_mut(0, n).copy_from(&dy_h.rows(n, n));
            dk_h.rows_mut(n, n).copy_from(&bottom_h.column(0));
            if B[i] != 0.0 {
                rate_of_end += (stage(i) + &self.dk_h[i] * h) * B[i];
            }
        }
        for (b, dk) in B.iter().zip(&self.dk) {
            if *b != 0.0 {
                self.phi.matrix += dk * (h * b);
            }
        }
        if let Some(shift) = &time_shift {
            // back to the step's nominal end: its length shortened by the switch's delay
            self.phi.matrix -= &rate_of_end * shift;
        }
        if let Some((_, r, _)) = &self.parameter {
            // the step's length scales with the run's time
            let mut last = self.phi.matrix.column_mut(2 * n);
            last += &rate_of_end * (r * h);
        }
        self.rate_of_end = Some(rate_of_end);
    }

    /// The acceleration rows `−M⁻¹(K dx + C dv + Σ (F_δ bbᵀdx + F_δ̇ bbᵀdv))` of `J dy` for a
    /// stage with the active walls' `tangents` (and, with `full`, for `dy = [dΦ | dq]`: the
    /// term of a law's approach speed and the parameter's `F_δ ∂δ/∂p`); a radial wall's
    /// term is its 2×2 tangent's ([`RadialTangent`]).
    fn apply_jacobian(
        &self,
        tangents: &[Option<WallTangent>],
        dy: &DMatrix<f64>,
        full: bool,
    ) -> DMatrix<f64> {
        let n = self.n;
        let dx = dy.rows(0, n);
        let dv = dy.rows(n, n);
        let mut bottom = &self.minus_k * dx + &self.minus_c * dv;
        for (j, t) in tangents.iter().enumerate() {
            let (f_delta, f_rate, f_speed) = match t {
                None => continue,
                Some(WallTangent::Radial(t)) => {
                    self.apply_radial(j, t, dy, full, &mut bottom);
                    continue;
                }
                Some(WallTangent::Line {
                    f_delta,
                    f_rate,
                    f_speed,
                }) => (*f_delta, *f_rate, *f_speed),
            };
            let row = &self.rows[j];
            let mut along = (row.transpose() * dx) * f_delta + (row.transpose() * dv) * f_rate;
            if let (Some(grad), true) = (&self.impact_speed[j], full && f_speed != 0.0) {
                along += grad * f_speed;
            }
            if let (Some((_, _, walls)), true) = (&self.parameter, full) {
                along[2 * n] += f_delta * walls[j];
            }
            bottom -= &self.m_inv_rows[j] * along;
        }
        bottom
    }

    /// Moves `Φ` onto every wall's switching surface that `start` (the end of the step landed
    /// on it) lies on, from the contact set `before` to `after`: the penetration `δ = 0` of a
    /// contact's onset or end, the force `F(δ, δ̇, v_imp) = 0` of a release inside the wall
    /// (Kelvin–Voigt's clamp); keeps the switch time's derivative for the next step (see the
    /// module doc) and that of each new contact's approach speed. A grazing switch (the
    /// switching function's rate zero) has no derivative and is passed over.
    pub(super) fn switch(
        &mut self,
        sys: &System,
        before: &[Contact],
        after: &[Contact],
        start: &StepEnd,
    ) {
        let n = self.n;
        for j in 0..after.len() {
            let onset_or_end = before[j].active != after[j].active;
            let release = after[j].released && !before[j].released;
            if !(onset_or_end || release) {
                continue;
            }
            let (row, rate, rate_row) = self.switch_gradient(sys, j, start);
            let row = &row;
            // the switching function's slopes in δ, δ̇ and v_imp
            let (h_delta, h_rate, h_speed) = if onset_or_end {
                self.impact_speed[j] = None;
                (1.0, 0.0, 0.0)
            } else {
                let [delta, rate, _] = start.walls[j];
                let (_, f_delta, f_rate, f_speed) = formula_slopes(sys, j, &after[j], delta, rate);
                (f_delta, f_rate, f_speed)
            };
            // the landed step's end moves along d(end)/dh (≈ f⁻) with its length
            let Some(f_minus) = &self.rate_of_end else {
                continue;
            };
            // ∇δ = (row, 0) and ∇δ̇ = (rate_row, row): a radial wall's δ̇ turns with its normal
            let turn = rate_row
                .as_ref()
                .map_or(0.0, |r| r.dot(&f_minus.rows(0, n)));
            let transversal = h_delta * row.dot(&f_minus.rows(0, n))
                + h_rate * (row.dot(&f_minus.rows(n, n)) + turn);
            if transversal == 0.0 || !transversal.is_finite() {
                continue;
            }
            // dt_s/dz₀ from h(z(t_s)) = 0, and Φ of the state at the perturbed switch time
            let mut along = (row.transpose() * self.phi.matrix.rows(0, n)) * h_delta
                + (row.transpose() * self.phi.matrix.rows(n, n)) * h_rate;
            if let (Some(r), true) = (&rate_row, h_rate != 0.0) {
                along += (r.transpose() * self.phi.matrix.rows(0, n)) * h_rate;
            }
            if let (Some(grad), true) = (&self.impact_speed[j], h_speed != 0.0) {
                along += grad * h_speed;
            }
            if let Some((_, _, walls)) = &self.parameter {
                along[2 * n] += h_delta * walls[j];
            }
            let shift = along * (-1.0 / transversal);
            self.phi.matrix += f_minus * &shift;
            let law = &sys.gaps[sys.walls[j].gap].law;
            if after[j].active && law.uses_impact_speed() && rate > MIN_IMPACT_SPEED {
                // v_imp = δ̇ at the onset, whose state Φ now is
                let mut speed = row.transpose() * self.phi.matrix.rows(n, n);
                if let Some(rate_row) = &rate_row {
                    speed += rate_row.transpose() * self.phi.matrix.rows(0, n);
                }
                self.impact_speed[j] = Some(speed);
            }
            self.time_shift = Some(match self.time_shift.take() {
                Some(earlier) => earlier + shift,
                None => shift,
            });
        }
    }
}

/// `M⁻¹ ∂F_ext/∂t` at `t`: the loads' rate, what a step started at a perturbed time carries.
fn load_rate(sys: &System, t: f64) -> DVector<f64> {
    let mut rate = vec![0.0; sys.n_dof()];
    for load in &sys.loads {
        let g = load.rate(t);
        for &d in &load.dofs {
            rate[d] += g;
        }
    }
    sys.structure.solve_mass(&mut rate);
    DVector::from_vec(rate)
}

/// Wall `j`'s `∂F/∂δ`, `∂F/∂δ̇` and `∂F/∂v_imp` at the raw penetration `raw` and rate `rate`
/// of a stage, as [`Dynamics::accel`] evaluates the force ([`super::force_in_contact`]: a
/// linear law's formula on both sides of the wall; any other from the smallest positive
/// penetration, so with no slope below it, and zero where the force is clamped).
fn tangent(sys: &System, j: usize, c: &Contact, raw: f64, rate: f64) -> (f64, f64, f64) {
    if smooth_switch(sys, j) {
        let (_, f_delta, f_rate, f_speed) = formula_slopes(sys, j, c, raw, rate);
        return (f_delta, f_rate, f_speed);
    }
    let (force, f_delta, f_rate, f_speed) =
        formula_slopes(sys, j, c, raw.max(f64::MIN_POSITIVE), rate);
    if force <= 0.0 {
        return (0.0, 0.0, 0.0);
    }
    let f_delta = if raw > f64::MIN_POSITIVE {
        f_delta
    } else {
        0.0
    };
    (f_delta, f_rate, f_speed)
}

/// Wall `j`'s force formula `F` (before the clamp to compressive) at the penetration
/// `penetration > 0` and rate `rate` in the contact `c`, with `∂F/∂δ`, `∂F/∂δ̇` and
/// `∂F/∂v_imp` (a central difference).
fn formula_slopes(
    sys: &System,
    j: usize,
    c: &Contact,
    penetration: f64,
    rate: f64,
) -> (f64, f64, f64, f64) {
    let law = &sys.gaps[sys.walls[j].gap].law;
    let max_penetration = c.max_penetration.max(penetration);
    let force = |speed: f64| law.evaluate_in_contact(penetration, rate, speed, max_penetration);
    let f = force(c.impact_speed);
    let f_speed = if law.uses_impact_speed() {
        let dv = IMPACT_SPEED_STEP * c.impact_speed;
        (force(c.impact_speed + dv).force - force(c.impact_speed - dv).force) / (2.0 * dv)
    } else {
        0.0
    };
    (f.force, f.d_penetration, f.d_rate, f_speed)
}

/// A wall's contact tangent at a stage.
enum WallTangent {
    /// A 1-D gap's wall: `∂F/∂δ`, `∂F/∂δ̇` and `∂F/∂v_imp` along its fixed row.
    Line {
        f_delta: f64,
        f_rate: f64,
        f_speed: f64,
    },
    Radial(RadialTangent),
}

/// A radial wall's DOFs `(ix, iy)`, the columns `M⁻¹ e_ix`, `M⁻¹ e_iy` its force acts
/// through, and its rotor's radius `R` (`∂v_rel/∂Ω`).
struct RadialWall {
    dofs: [usize; 2],
    m_inv: [DVector<f64>; 2],
    radius: f64,
}

impl RadialWall {
    /// Wall `j`'s, if its gap is radial.
    fn of(sys: &System, j: usize) -> Option<Self> {
        let gap = sys.walls[j].gap;
        let Side::Radial(r) = &sys.gaps[gap].side else {
            return None;
        };
        let dofs = [sys.gaps[gap].dofs[0], sys.gaps[r.partner].dofs[0]];
        let column = |d: usize| {
            let mut e = vec![0.0; sys.n_dof()];
            e[d] = 1.0;
            sys.structure.solve_mass(&mut e);
            DVector::from_vec(e)
        };
        Some(Self {
            dofs,
            m_inv: [column(dofs[0]), column(dofs[1])],
            radius: r.radius,
        })
    }
}

/// A radial wall's force `φ = F_N e` (`e = n + μ s(v_rel) t`, docs/rotors.md §Radial gaps) at
/// a stage: its 2×2 tangents `∂φ/∂p`, `∂φ/∂ṗ` (the turning normal and the friction included,
/// [`radial_contact`]), the direction `e` and the law's `∂F_N/∂δ`, `∂F_N/∂v_imp` (for the
/// terms of a parameter's `∂δ/∂p` and of the approach speed, both along `e`), and `∂φ/∂v_rel`
/// (`F_N μ s'(v_rel) t`: the spin speed's term through `v_rel = R Ω + ρθ̇`).
struct RadialTangent {
    d_u: [[f64; 2]; 2],
    d_rate: [[f64; 2]; 2],
    direction: [f64; 2],
    f_delta: f64,
    f_speed: f64,
    d_slip: [f64; 2],
}

/// Radial wall `j`'s [`RadialTangent`] at DOF displacements `x` and velocities `v`, its
/// normal force evaluated as [`super::Dynamics::accel`] does.
fn radial_tangent(sys: &System, j: usize, c: &Contact, x: &[f64], v: &[f64]) -> RadialTangent {
    let wall = &sys.walls[j];
    let gap = &sys.gaps[wall.gap];
    let Side::Radial(r) = &gap.side else {
        unreachable!("a radial wall's gap is radial")
    };
    let (k, force) = radial_normal_force(sys, j, c, x, v);
    let (f_delta, f_rate, f_speed) = tangent(sys, j, c, k.rho - wall.clearance, k.rate);
    let state = WallState {
        force: force.force,
        d_penetration: f_delta,
        d_rate: f_rate,
        ..WallState::default()
    };
    let spin = r.radius * sys.structure.spin.start;
    let rf = radial_contact(r, &k, &state, spin);
    let (slip, slip_rate) = if r.friction > 0.0 {
        let (f, d) = r.friction_factor(spin + k.slide);
        (r.friction * f, r.friction * d)
    } else {
        (0.0, 0.0)
    };
    RadialTangent {
        d_u: rf.d_u,
        d_rate: rf.d_rate,
        direction: [
            k.normal[0] + slip * k.tangent[0],
            k.normal[1] + slip * k.tangent[1],
        ],
        f_delta,
        f_speed,
        d_slip: [
            force.force * slip_rate * k.tangent[0],
            force.force * slip_rate * k.tangent[1],
        ],
    }
}

impl Variational {
    /// Subtracts radial wall `j`'s term `M⁻¹ [e_ix e_iy] dφ` from the acceleration rows
    /// `bottom` of `J dy`, `dφ = ∂φ/∂p dp + ∂φ/∂ṗ dṗ` (with `full`: and the approach speed's
    /// and the parameter's terms along `e`).
    fn apply_radial(
        &self,
        j: usize,
        t: &RadialTangent,
        dy: &DMatrix<f64>,
        full: bool,
        bottom: &mut DMatrix<f64>,
    ) {
        let n = self.n;
        let wall = self.radial[j].as_ref().expect("a radial wall");
        for a in 0..2 {
            let mut along = RowDVector::zeros(dy.ncols());
            for (b, &d) in wall.dofs.iter().enumerate() {
                along += dy.row(d) * t.d_u[a][b] + dy.row(n + d) * t.d_rate[a][b];
            }
            if full {
                if let (Some(grad), true) = (&self.impact_speed[j], t.f_speed != 0.0) {
                    along += grad * (t.direction[a] * t.f_speed);
                }
                if let Some((p, _, walls)) = &self.parameter {
                    along[2 * n] += t.direction[a] * t.f_delta * walls[j];
                    if *p == Parameter::SpinSpeed {
                        along[2 * n] += t.d_slip[a] * wall.radius;
                    }
                }
            }
            *bottom -= &wall.m_inv[a] * along;
        }
    }

    /// Wall `j`'s `∇_x δ` at the state `start`, its `δ̇` there and (a radial wall's) `∇_x δ̇`:
    /// a 1-D wall's fixed row; a radial wall's normal `n` and `(ρθ̇/ρ) t` at its DOFs
    /// (`∇_v δ̇ = ∇_x δ` for both).
    fn switch_gradient(
        &self,
        sys: &System,
        j: usize,
        start: &StepEnd,
    ) -> (DVector<f64>, f64, Option<DVector<f64>>) {
        let Some(wall) = &self.radial[j] else {
            let row = self.rows[j].clone();
            let rate = row.dot(&DVector::from_column_slice(&start.v));
            return (row, rate, None);
        };
        let gap = sys.walls[j].gap;
        let Side::Radial(r) = &sys.gaps[gap].side else {
            unreachable!("a radial wall's gap is radial")
        };
        let k = sys.radial_at_dofs(r, gap, &start.x, &start.v);
        let (mut row, mut rate_row) = (DVector::zeros(self.n), DVector::zeros(self.n));
        for (a, &d) in wall.dofs.iter().enumerate() {
            row[d] = k.normal[a];
            rate_row[d] = k.slide / k.rho * k.tangent[a];
        }
        (row, k.rate, Some(rate_row))
    }
}
