//! Moreau–Jean time stepping (Moreau 1988; Jean 1999, CMAME 177:235; Acary & Brogliato 2008,
//! "Numerical Methods for Nonsmooth Dynamical Systems", §10.1).
//!
//! A θ-method on the velocities with impulses instead of forces:
//! `M (v₊ − v) = h [θ f₊ + (1−θ) f] − Gᵀ P`, `x₊ = x + h [θ v₊ + (1−θ) v]`, with
//! `f = F(t) − C v − K x`. Eliminating `x₊`: `Â (v₊ − v) = h [F_θ − C v − K x − hθ K v] − Gᵀ P`,
//! `Â = M + hθ C + h²θ² K` (factorised once). The walls predicted closed at
//! `x̃ = x + h v / 2` are active, and on them the velocity-level Newton law
//! `0 ≤ P ⊥ −(δ̇₊ + e δ̇) ≥ 0` is one LCP per step, `W = G Â⁻¹ Gᵀ`, `q = −(G v_free + e G v)`
//! ([`super::lcp::solve_lcp`]: enumeration up to 10 active walls, projected Gauss–Seidel
//! beyond). Impacts, sticking and chattering need no special treatment; an impact's
//! instant is known to one step (first order), the smooth motion is second order for θ = ½.
//! With θ = ½ the energy identity is exact: the impulses dissipate
//! `Σ P (δ̇ + δ̇₊)/2` per step, which is what the energy account records.
//!
//! Impact table: consecutive steps in which a wall carries an impulse form one row, from the
//! first (`t_start`) to the last (`t_end`) such step end, with `v_in` the approach speed
//! before the first, `v_out` the separation speed after the last, the summed impulse, and
//! `force_max = NaN`. The gap force column is the mean contact force `P/h` of the step.

use nalgebra::{DMatrix, DVector};

use super::lcp::solve_lcp;
use super::{fill_gaps, Rigidity};
use crate::driver::{Run, StepPolicy};
use crate::error::{invalid, SimError};
use crate::gap::ImpactRecord;
use crate::system::System;

/// The method's name in errors.
const METHOD: &str = "moreau-jean";

/// Settings of Moreau–Jean time stepping.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MoreauJean {
    /// `θ ∈ [½, 1]`: ½ is the trapezoidal rule (no numerical damping of the smooth motion),
    /// 1 backward Euler.
    pub theta: f64,
}

/// Moreau–Jean as the run's step policy: one θ-step, and one LCP, per step of the grid.
pub(crate) struct MoreauJeanSteps {
    rig: Rigidity,
    theta: f64,
    h: f64,
    n_steps: usize,
    /// Steps taken.
    k: usize,
    /// `Â⁻¹` and `Â⁻¹ g_j` per wall.
    a_inv: DMatrix<f64>,
    ainv_g: Vec<DVector<f64>>,
    x: DVector<f64>,
    v: DVector<f64>,
    records: Vec<ImpactRecord>,
    /// Per wall: its row in `records` while consecutive steps carry impulses.
    open: Vec<Option<usize>>,
    /// Per wall: the impulse of the last step, N·s.
    impulse: Vec<f64>,
}

impl MoreauJeanSteps {
    /// From `run.cur` (at `t = 0`); `n_steps` steps of `h`.
    pub fn new(
        run: &Run,
        sys: &System,
        method: MoreauJean,
        n_steps: usize,
        h: f64,
    ) -> Result<Self, SimError> {
        method.validate()?;
        let rig = Rigidity::new(sys, METHOD)?;
        let th = method.theta;
        let x = DVector::from_column_slice(&run.cur.x);
        let v = DVector::from_column_slice(&run.cur.v);
        check_initial(sys, &rig, &x)?;
        let d = &rig.dense;
        let a_hat = &d.mass + &d.damping * (h * th) + &d.stiffness * (h * h * th * th);
        let a_inv = a_hat
            .lu()
            .try_inverse()
            .ok_or(SimError::SingularTangent { t: 0.0, dt: h })?;
        let ainv_g: Vec<DVector<f64>> = rig.g.iter().map(|g| &a_inv * g).collect();
        let nw = rig.n_walls();
        Ok(Self {
            rig,
            theta: th,
            h,
            n_steps,
            k: 0,
            a_inv,
            ainv_g,
            x,
            v,
            records: Vec::new(),
            open: vec![None; nw],
            impulse: vec![0.0; nw],
        })
    }

    /// The impact table: a contact still carrying impulses in the last step is still closed.
    pub fn impacts(mut self) -> Vec<ImpactRecord> {
        for (j, o) in self.open.iter().enumerate() {
            if let Some(idx) = *o {
                if self.impulse[j] > 0.0 {
                    self.records[idx].t_end = f64::NAN;
                    self.records[idx].v_out = f64::NAN;
                }
            }
        }
        self.records
    }
}

impl StepPolicy for MoreauJeanSteps {
    fn advance(&mut self, run: &mut Run, sys: &System) -> Result<bool, SimError> {
        if self.k == self.n_steps {
            return Ok(false);
        }
        self.k += 1;
        let (k, h, th) = (self.k, self.h, self.theta);
        let rig = &self.rig;
        let st = &sys.structure;
        let nw = rig.n_walls();
        let (x, v) = (&self.x, &self.v);
        let t0 = (k - 1) as f64 * h;
        let t1 = k as f64 * h;
        // h [F_θ − C v − K x − hθ K v]
        let mut rhs = DVector::zeros(rig.n);
        for load in &sys.loads {
            let val = th * load.value(t1) + (1.0 - th) * load.value(t0);
            for &d in &load.dofs {
                rhs[d] += val;
            }
        }
        st.damping.mul_add(-1.0, v.as_slice(), rhs.as_mut_slice());
        st.stiffness.mul_add(-1.0, x.as_slice(), rhs.as_mut_slice());
        st.stiffness
            .mul_add(-h * th, v.as_slice(), rhs.as_mut_slice());
        let mut v1 = v + &self.a_inv * (rhs * h);
        let x_pred = x + v * (0.5 * h);
        let active: Vec<usize> = (0..nw)
            .filter(|&j| rig.penetration(j, &x_pred) >= 0.0)
            .collect();
        let impulse = &mut self.impulse;
        impulse.iter_mut().for_each(|p| *p = 0.0);
        if !active.is_empty() {
            let m = active.len();
            let w = DMatrix::from_fn(m, m, |r, c| rig.g[active[r]].dot(&self.ainv_g[active[c]]));
            let q: Vec<f64> = active
                .iter()
                .map(|&j| -(rig.rate(j, &v1) + rig.restitution[j] * rig.rate(j, v)))
                .collect();
            let p = solve_lcp(&w, &q);
            for (r, &j) in active.iter().enumerate() {
                if p[r] > 0.0 {
                    v1.axpy(-p[r], &self.ainv_g[j], 1.0);
                    impulse[j] = p[r];
                }
            }
        }
        let x1 = x + (v + (&v1 - v) * th) * h;
        let mut dissipated = 0.0;
        let mut impacts = Vec::new();
        for (j, &p) in impulse.iter().enumerate() {
            let (r0, r1) = (rig.rate(j, v), rig.rate(j, &v1));
            if p > 0.0 {
                dissipated += p * 0.5 * (r0 + r1);
                let records = &mut self.records;
                let idx = *self.open[j].get_or_insert_with(|| {
                    let wall = &sys.walls[j];
                    impacts.push((j, r0.max(0.0), (-r1).max(0.0)));
                    records.push(ImpactRecord {
                        gap: wall.gap,
                        side: wall.sign,
                        t_start: t1,
                        t_end: t1,
                        v_in: r0.max(0.0),
                        v_out: f64::NAN,
                        delta_max: 0.0,
                        force_max: f64::NAN,
                        friction_max: 0.0,
                        impulse: 0.0,
                    });
                    records.len() - 1
                });
                let rec = &mut records[idx];
                rec.impulse += p;
                rec.t_end = t1;
                rec.v_out = (-r1).max(0.0);
            } else {
                self.open[j] = None;
            }
        }
        let s = &mut run.trial;
        s.t = t1;
        s.x.copy_from_slice(x1.as_slice());
        s.v.copy_from_slice(v1.as_slice());
        for ((a, &v1), &v0) in s.a.iter_mut().zip(v1.iter()).zip(v.iter()) {
            *a = (v1 - v0) / h;
        }
        // the gap force column: the mean contact force P/h of the step
        fill_gaps(sys, rig, s, |j| impulse[j] / h);
        self.x = x1;
        self.v = v1;
        run.impulses_dissipated(dissipated);
        run.commit_trial(sys, h, 0, None)?;
        for (j, v_in, v_out) in impacts {
            run.impact(sys, j, t1, v_in, v_out);
        }
        Ok(true)
    }
}

/// Refuses an initial state inside a rigid wall.
pub(crate) fn check_initial(
    sys: &System,
    rig: &Rigidity,
    x0: &DVector<f64>,
) -> Result<(), SimError> {
    for j in 0..rig.n_walls() {
        let pen = rig.penetration(j, x0);
        let scale = rig.clearance[j]
            .abs()
            .max(rig.g[j].dot(x0).abs())
            .max(1e-300);
        if pen > 1e-9 * scale {
            let wall = &sys.walls[j];
            return invalid(format!(
                "initial.displacement: gaps[{}] starts {pen:.3e} m inside its rigid {} wall; \
                 expected a state on or outside every rigid wall",
                wall.gap,
                if wall.sign > 0.0 {
                    "positive"
                } else {
                    "negative"
                }
            ));
        }
    }
    Ok(())
}
