//! DOP853's state-transition matrix: the exact derivative of the discrete scheme at the steps
//! it took ("internal differentiation", Bock 1981). Each stage `Y_i = z₀ + h Σ_j a_ij K_j`,
//! `K_i = f(t_i, Y_i)` is differentiated: `dY_i = Φ₀ + h Σ_j a_ij dK_j`, `dK_i = J(Y_i) dY_i`
//! with `J = [[0, I], [−M⁻¹(K + Σ F_δ bbᵀ), −M⁻¹(C + Σ F_δ̇ bbᵀ)]]` at the stage (the contact
//! tangent of each active wall there), and `Φ₁ = Φ₀ + h Σ_i b_i dK_i`. A law that depends on
//! the approach speed `v_imp` (fixed at the contact's onset) adds `∂F/∂v_imp · ∂v_imp/∂z₀`,
//! the latter taken at the onset through the located switch. At each switch of a wall (its
//! contact's onset or end, where a law such as Kelvin–Voigt's jumps by `c δ̇`) the saltation
//! matrix `S = I + (f⁺ − f⁻) ∇δᵀ / δ̇` composes `Φ` (docs/periodic-orbits.md).
//!
//! The step sizes are those the error control chose; the steps land on every switch, so the
//! derivative is that of the integrated flow to the method's tolerance. Contacts are then
//! integrated in time only (no step in `ζ = √δ`, whose duration would depend on the state).
//! Dense `2n × 2n` matrices: for the small models DOP853 is meant for.

use nalgebra::{DMatrix, DVector, RowDVector};

use super::super::dop853_tableau::{A, B, STAGES};
use super::{dot, Contact, Dynamics, Stages, StepEnd, K};
use crate::contact::{ContactLaw, MIN_IMPACT_SPEED};
use crate::sensitivity::{saltation_update, StateTransition};
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
    /// Per wall: its row `s b` (so that `δ = s b·x − d`) and `M⁻¹ s b`.
    rows: Vec<DVector<f64>>,
    m_inv_rows: Vec<DVector<f64>>,
    /// Per wall in contact with a law that uses it: `∂v_imp/∂z₀`.
    impact_speed: Vec<Option<RowDVector<f64>>>,
    /// The stages' `dK_i`, `2n × 2n`.
    dk: Vec<DMatrix<f64>>,
}

impl Variational {
    pub(super) fn new(sys: &System) -> Self {
        let n = sys.n_dof();
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
        Self {
            n,
            phi: StateTransition::identity(n),
            minus_k,
            minus_c,
            rows,
            m_inv_rows,
            impact_speed: vec![None; sys.walls.len()],
            dk: vec![DMatrix::zeros(2 * n, 2 * n); STAGES],
        }
    }

    /// Composes `Φ` with the accepted step of length `h` in time from `start`, whose stage
    /// values `stages` holds, under the contact set `contacts`.
    pub(super) fn step(
        &mut self,
        sys: &System,
        stages: &Stages,
        contacts: &[Contact],
        start: &StepEnd,
        h: f64,
    ) {
        let n = self.n;
        let (mut xs, mut vs) = (vec![0.0; n], vec![0.0; n]);
        for (i, a_i) in A.iter().enumerate() {
            let mut dy = self.phi.matrix.clone();
            for (j, &a) in a_i.iter().enumerate() {
                if a != 0.0 {
                    dy += &self.dk[j] * (h * a);
                }
            }
            for d in 0..n {
                xs[d] = start.x[d] + h * dot(a_i, &stages.kx[d * K..(d + 1) * K]);
                vs[d] = start.v[d] + h * dot(a_i, &stages.kv[d * K..(d + 1) * K]);
            }
            let dx = dy.rows(0, n);
            let dv = dy.rows(n, n);
            let mut bottom = &self.minus_k * dx + &self.minus_c * dv;
            for (j, (wall, c)) in sys.walls.iter().zip(contacts).enumerate() {
                if !c.active {
                    continue;
                }
                let row = &self.rows[j];
                let raw = row.dot(&DVector::from_column_slice(&xs)) - wall.clearance;
                let rate = row.dot(&DVector::from_column_slice(&vs));
                let (f_delta, f_rate, f_speed) = tangent(sys, j, c, raw, rate);
                let mut along = (row.transpose() * dx) * f_delta + (row.transpose() * dv) * f_rate;
                if let (Some(grad), true) = (&self.impact_speed[j], f_speed != 0.0) {
                    along += grad * f_speed;
                }
                bottom -= &self.m_inv_rows[j] * along;
            }
            let dk = &mut self.dk[i];
            dk.rows_mut(0, n).copy_from(&dv);
            dk.rows_mut(n, n).copy_from(&bottom);
        }
        for (b, dk) in B.iter().zip(&self.dk) {
            if *b != 0.0 {
                self.phi.matrix += dk * (h * b);
            }
        }
    }

    /// Composes `Φ` with the saltation matrix of every wall that switched at `start` (time
    /// `t`) from the contact set `before` to `after`, one wall at a time, and keeps the
    /// derivative of each new contact's approach speed.
    pub(super) fn switch(
        &mut self,
        sys: &System,
        dynamics: &mut Dynamics,
        before: &[Contact],
        after: &[Contact],
        start: &StepEnd,
        t: f64,
    ) {
        let n = self.n;
        let mut current = before.to_vec();
        let mut a = vec![0.0; n];
        for j in 0..after.len() {
            if before[j].active == after[j].active {
                current[j] = after[j];
                continue;
            }
            dynamics.accel(&current, None, t, &start.x, &start.v, &mut a);
            let a_minus = DVector::from_column_slice(&a);
            current[j] = after[j];
            dynamics.accel(&current, None, t, &start.x, &start.v, &mut a);
            let a_plus = DVector::from_column_slice(&a);
            let v = DVector::from_column_slice(&start.v);
            let row = &self.rows[j];
            let rate = row.dot(&v);
            let mut grad = DVector::zeros(2 * n);
            grad.rows_mut(0, n).copy_from(row);
            let mut f_minus = DVector::zeros(2 * n);
            f_minus.rows_mut(0, n).copy_from(&v);
            let mut f_plus = f_minus.clone();
            f_minus.rows_mut(n, n).copy_from(&a_minus);
            f_plus.rows_mut(n, n).copy_from(&a_plus);
            self.impact_speed[j] = None;
            let law = &sys.gaps[sys.walls[j].gap].law;
            if after[j].active && law.uses_impact_speed() && rate > MIN_IMPACT_SPEED {
                // v_imp = δ̇ at the onset: d/dz₀ of δ̇(z(t*)) with t*(z₀) from δ(z(t*)) = 0
                let phi = &self.phi.matrix;
                let d_rate = row.transpose() * phi.rows(n, n);
                let d_delta = row.transpose() * phi.rows(0, n);
                self.impact_speed[j] = Some(d_rate - d_delta * (row.dot(&a_minus) / rate));
            }
            if let Some(u) = saltation_update(None, &f_minus, &f_plus, &grad) {
                self.phi.compose_event(None, &u, &grad);
            }
        }
    }
}

/// Wall `j`'s `∂F/∂δ`, `∂F/∂δ̇` and `∂F/∂v_imp` at the raw penetration `raw` and rate `rate`
/// of a stage, as [`Dynamics::accel`] evaluates the force (from the smallest positive
/// penetration, so with no slope below it).
fn tangent(sys: &System, j: usize, c: &Contact, raw: f64, rate: f64) -> (f64, f64, f64) {
    let law = &sys.gaps[sys.walls[j].gap].law;
    let penetration = raw.max(f64::MIN_POSITIVE);
    let max_penetration = c.max_penetration.max(penetration);
    let force = |speed: f64| law.force_in_contact(penetration, rate, speed, max_penetration);
    let f = force(c.impact_speed);
    let f_speed = if law.uses_impact_speed() {
        let dv = IMPACT_SPEED_STEP * c.impact_speed;
        (force(c.impact_speed + dv).force - force(c.impact_speed - dv).force) / (2.0 * dv)
    } else {
        0.0
    };
    let f_delta = if raw > f64::MIN_POSITIVE {
        f.d_penetration
    } else {
        0.0
    };
    (f_delta, f.d_rate, f_speed)
}
