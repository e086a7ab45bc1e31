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

use nalgebra::DVector;

use super::lcp::solve_lcp;
use super::{steps, Output, Rigidity, Work};
use crate::error::{invalid, SimError};
use crate::gap::ImpactRecord;
use crate::output::{RunOutput, Stats};
use crate::settings::RunSettings;
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

impl Default for MoreauJean {
    fn default() -> Self {
        Self { theta: 0.5 }
    }
}

impl MoreauJean {
    pub fn validate(&self) -> Result<(), SimError> {
        if !(self.theta >= 0.5 && self.theta <= 1.0) {
            return invalid(format!(
                "solver.theta: {} is not valid; expected 0.5 <= theta <= 1",
                self.theta
            ));
        }
        Ok(())
    }
}

pub(crate) fn run(
    sys: &System,
    method: MoreauJean,
    settings: &RunSettings,
    x0: DVector<f64>,
    v0: DVector<f64>,
) -> Result<RunOutput, SimError> {
    method.validate()?;
    let started = std::time::Instant::now();
    let rig = Rigidity::new(sys, METHOD)?;
    let (n_steps, h) = steps(settings);
    let th = method.theta;
    let st = &sys.structure;
    let nw = rig.n_walls();
    check_initial(sys, &rig, &x0)?;
    let d = &rig.dense;
    let a_hat = &d.mass + &d.damping * (h * th) + &d.stiffness * (h * h * th * th);
    let a_inv = a_hat
        .lu()
        .try_inverse()
        .ok_or(SimError::SingularTangent { t: 0.0, dt: h })?;
    let ainv_g: Vec<DVector<f64>> = rig.g.iter().map(|g| &a_inv * g).collect();
    let (mut x, mut v) = (x0, v0);
    let mut out = Output::new(settings.record_dofs.clone());
    let mut work = Work::default();
    let a0 = &rig.m_inv * rig.smooth_force(sys, 0.0, &x, &v);
    out.record(sys, &rig, 0.0, &x, &v, &a0, &vec![0.0; nw], &work);
    let mut records: Vec<ImpactRecord> = Vec::new();
    let mut open: Vec<Option<usize>> = vec![None; nw];
    let mut stats = Stats::default();
    let mut error = None;
    let mut impulse = vec![0.0; nw];
    for k in 1..=n_steps {
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
        let mut v1 = &v + &a_inv * (rhs * h);
        let x_pred = &x + &v * (0.5 * h);
        let active: Vec<usize> = (0..nw)
            .filter(|&j| rig.penetration(j, &x_pred) >= 0.0)
            .collect();
        impulse.iter_mut().for_each(|p| *p = 0.0);
        if !active.is_empty() {
            let m = active.len();
            let w =
                nalgebra::DMatrix::from_fn(m, m, |r, c| rig.g[active[r]].dot(&ainv_g[active[c]]));
            let q: Vec<f64> = active
                .iter()
                .map(|&j| -(rig.rate(j, &v1) + rig.restitution[j] * rig.rate(j, &v)))
                .collect();
            let p = solve_lcp(&w, &q);
            for (r, &j) in active.iter().enumerate() {
                if p[r] > 0.0 {
                    v1.axpy(-p[r], &ainv_g[j], 1.0);
                    impulse[j] = p[r];
                }
            }
        }
        let x1 = &x + (&v + (&v1 - &v) * th) * h;
        work.commit(sys, t0, &x, &v, t1, &x1, &v1);
        for j in 0..nw {
            let (r0, r1) = (rig.rate(j, &v), rig.rate(j, &v1));
            if impulse[j] > 0.0 {
                work.contact_dissipated += impulse[j] * 0.5 * (r0 + r1);
                let idx = *open[j].get_or_insert_with(|| {
                    let wall = &sys.walls[j];
                    records.push(ImpactRecord {
                        gap: wall.gap,
                        side: wall.sign,
                        t_start: t1,
                        t_end: t1,
                        v_in: r0.max(0.0),
                        v_out: f64::NAN,
                        delta_max: 0.0,
                        force_max: f64::NAN,
                        impulse: 0.0,
                    });
                    records.len() - 1
                });
                let rec = &mut records[idx];
                rec.impulse += impulse[j];
                rec.t_end = t1;
                rec.v_out = (-r1).max(0.0);
            } else {
                open[j] = None;
            }
        }
        let a1 = (&v1 - &v) / h;
        x = x1;
        v = v1;
        stats.steps += 1;
        if x.iter().chain(v.iter()).any(|s| !s.is_finite()) {
            error = Some(SimError::Diverged { t: t1, gap: None });
            let forces: Vec<f64> = impulse.iter().map(|p| p / h).collect();
            out.record(sys, &rig, t1, &x, &v, &a1, &forces, &work);
            break;
        }
        if crate::interrupt::requested() {
            error = Some(SimError::Interrupted { t: t1 });
            let forces: Vec<f64> = impulse.iter().map(|p| p / h).collect();
            out.record(sys, &rig, t1, &x, &v, &a1, &forces, &work);
            break;
        }
        out.peaks(&x);
        if k % settings.every == 0 || k == n_steps {
            let forces: Vec<f64> = impulse.iter().map(|p| p / h).collect();
            out.record(sys, &rig, t1, &x, &v, &a1, &forces, &work);
        }
    }
    // A contact still carrying impulses in the last step is still closed.
    for (j, o) in open.iter().enumerate() {
        if let Some(idx) = *o {
            if impulse[j] > 0.0 {
                records[idx].t_end = f64::NAN;
                records[idx].v_out = f64::NAN;
            }
        }
    }
    stats.wall_time_s = started.elapsed().as_secs_f64();
    Ok(out.finish(records, stats, h, error))
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
