//! Impulsive methods for rigid gaps (the massless bar, paper Fig. 1a; docs/rigid-impacts.md):
//! Newton's restitution law `δ̇⁺ = −e δ̇⁻` applied as an instantaneous velocity jump through the
//! generalized impulse, `Δv = −M⁻¹ Gᵀ P`, with `P ≥ 0` from the impact LCP
//! (`Δv = −(1+e)(b·v) M⁻¹bᵀ/(b M⁻¹ bᵀ)` for a single wall).
//!
//! * [`EventDriven`] (`event_driven`): impact times located by root finding; the linear
//!   structure integrated exactly between events (matrix exponential); simultaneous impacts
//!   resolved together by the generalized Newton law (one LCP); chattering ended by a
//!   sticking rule.
//! * [`MoreauJean`] (`moreau_jean`): θ-method time stepping with one LCP per step on the
//!   gap velocities (Moreau 1988, Jean 1999).
//!
//! Rigid gaps are accepted only by these methods, and these methods accept only rigid gaps
//! (`Method::check_laws`). Both write the same impact table as the compliant integrators:
//! an impact is a row with `t_start = t_end` (the impact instant), `v_in`, `v_out`, the
//! impulse `P` (N·s), `delta_max = 0` and `force_max = NaN` (an impact has no finite force).
//! A contact that sticks (event-driven) is a row from the impact that ended the chattering
//! to the release, with `force_max` the largest contact force while stuck and `impulse`
//! including `∫ λ dt`. See docs/rigid-impacts.md.

pub(crate) mod event_driven;
pub mod lcp;
pub(crate) mod moreau_jean;

pub use event_driven::EventDriven;
pub use moreau_jean::MoreauJean;

use std::sync::Arc;

use nalgebra::{DMatrix, DVector};

use crate::error::SimError;
use crate::gap::ImpactRecord;
use crate::output::{Rows, RunOutput, Stats};
use crate::settings::RunSettings;
use crate::structure::DenseStructure;
use crate::system::System;

/// What the impulsive methods need of the system: the walls as rows `g_j = s_j b_g` of the
/// constraint Jacobian (`δ_j = g_j · x − d_j`), `M⁻¹`, and the load columns.
pub(crate) struct Rigidity {
    pub n: usize,
    /// The structure's dense matrices (the impulsive methods work with dense projections).
    pub dense: Arc<DenseStructure>,
    pub m_inv: DMatrix<f64>,
    /// One row per wall (n columns).
    pub g: Vec<DVector<f64>>,
    pub clearance: Vec<f64>,
    pub restitution: Vec<f64>,
    /// `n × n_loads`: the DOF pattern of each load.
    pub load_cols: DMatrix<f64>,
}

impl Rigidity {
    /// For the impulsive `method` (named in the error if the model is too large to be dense).
    pub fn new(sys: &System, method: &str) -> Result<Self, SimError> {
        let n = sys.n_dof();
        let dense = sys.structure.dense(method)?;
        let m_inv = dense
            .mass
            .clone()
            .cholesky()
            .ok_or_else(|| SimError::InvalidModel("structure.mass: not positive definite".into()))?
            .inverse();
        let mut g = Vec::new();
        let mut clearance = Vec::new();
        let mut restitution = Vec::new();
        for wall in &sys.walls {
            let gap = &sys.gaps[wall.gap];
            let mut row = DVector::zeros(n);
            for (&d, &c) in gap.dofs.iter().zip(&gap.coefficients) {
                row[d] += wall.sign * c;
            }
            g.push(row);
            clearance.push(wall.clearance);
            restitution.push(match &gap.law {
                crate::contact::Law::Rigid(r) => r.restitution,
                _ => 1.0,
            });
        }
        let mut load_cols = DMatrix::zeros(n, sys.loads.len());
        for (l, load) in sys.loads.iter().enumerate() {
            for &d in &load.dofs {
                load_cols[(d, l)] += 1.0;
            }
        }
        Ok(Self {
            n,
            dense,
            m_inv,
            g,
            clearance,
            restitution,
            load_cols,
        })
    }

    pub fn n_walls(&self) -> usize {
        self.g.len()
    }

    /// Penetration `δ_j` (negative: open).
    pub fn penetration(&self, j: usize, x: &DVector<f64>) -> f64 {
        self.g[j].dot(x) - self.clearance[j]
    }

    pub fn rate(&self, j: usize, v: &DVector<f64>) -> f64 {
        self.g[j].dot(v)
    }

    /// `G_S` (rows of the walls in `set`).
    pub fn jacobian(&self, set: &[usize]) -> DMatrix<f64> {
        DMatrix::from_fn(set.len(), self.n, |r, c| self.g[set[r]][c])
    }

    /// `F(t) − C v − K x`.
    pub fn smooth_force(
        &self,
        sys: &System,
        t: f64,
        x: &DVector<f64>,
        v: &DVector<f64>,
    ) -> DVector<f64> {
        let st = &sys.structure;
        let mut f = DVector::zeros(self.n);
        for load in &sys.loads {
            let val = load.value(t);
            for &d in &load.dofs {
                f[d] += val;
            }
        }
        st.damping.mul_add(-1.0, v.as_slice(), f.as_mut_slice());
        st.stiffness.mul_add(-1.0, x.as_slice(), f.as_mut_slice());
        f
    }

    /// Energy `½ vᵀ M v` and `½ xᵀ K x`.
    pub fn energies(&self, sys: &System, x: &DVector<f64>, v: &DVector<f64>) -> (f64, f64) {
        let st = &sys.structure;
        (
            st.mass.quadratic_form(v.as_slice()),
            st.stiffness.quadratic_form(x.as_slice()),
        )
    }
}

/// Work integrals between two states (trapezoidal in displacement, as the compliant driver).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Work {
    pub external: f64,
    pub damping: f64,
    pub contact_dissipated: f64,
}

impl Work {
    #[allow(clippy::too_many_arguments)]
    pub fn commit(
        &mut self,
        sys: &System,
        t0: f64,
        x0: &DVector<f64>,
        v0: &DVector<f64>,
        t1: f64,
        x1: &DVector<f64>,
        v1: &DVector<f64>,
    ) {
        for load in &sys.loads {
            let moved: f64 = load.dofs.iter().map(|&d| x1[d] - x0[d]).sum();
            self.external += 0.5 * (load.value(t0) + load.value(t1)) * moved;
        }
        let (x0, x1, v0, v1) = (x0.as_slice(), x1.as_slice(), v0.as_slice(), v1.as_slice());
        self.damping += 0.5 * sys.structure.damping.increment_form(x0, x1, v0, v1);
    }
}

/// Decimated output of the impulsive methods.
pub(crate) struct Output {
    pub record_dofs: Vec<usize>,
    pub rows: Rows,
    pub max_abs: Vec<f64>,
}

impl Output {
    pub fn new(record_dofs: Vec<usize>) -> Self {
        let nd = record_dofs.len();
        Self {
            record_dofs,
            rows: Rows::default(),
            max_abs: vec![0.0; nd],
        }
    }

    pub fn peaks(&mut self, x: &DVector<f64>) {
        for (m, &d) in self.max_abs.iter_mut().zip(&self.record_dofs) {
            *m = m.max(x[d].abs());
        }
    }

    /// Records one instant; `wall_force` is the contact force of each wall (N).
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &mut self,
        sys: &System,
        rig: &Rigidity,
        t: f64,
        x: &DVector<f64>,
        v: &DVector<f64>,
        a: &DVector<f64>,
        wall_force: &[f64],
        work: &Work,
    ) {
        self.peaks(x);
        let rows = &mut self.rows;
        rows.time.push(t);
        for &d in &self.record_dofs {
            rows.displacement.push(x[d]);
            rows.velocity.push(v[d]);
            rows.acceleration.push(a[d]);
        }
        let ng = sys.gaps.len();
        let mut pen = vec![f64::NEG_INFINITY; ng];
        let mut force = vec![0.0; ng];
        for (j, wall) in sys.walls.iter().enumerate() {
            pen[wall.gap] = pen[wall.gap].max(rig.penetration(j, x));
            force[wall.gap] += wall_force[j];
        }
        rows.gap_penetration.extend_from_slice(&pen);
        rows.gap_force.extend_from_slice(&force);
        let (kinetic, strain) = rig.energies(sys, x, v);
        let e = &mut rows.energy;
        e.kinetic.push(kinetic);
        e.strain.push(strain);
        e.contact_potential.push(0.0);
        e.external_work.push(work.external);
        e.damping_dissipated.push(work.damping);
        e.contact_dissipated.push(work.contact_dissipated);
    }

    pub fn finish(
        self,
        impacts: Vec<ImpactRecord>,
        stats: Stats,
        dt: f64,
        error: Option<SimError>,
    ) -> RunOutput {
        RunOutput {
            rows: self.rows,
            record_dofs: self.record_dofs,
            max_abs_displacement: self.max_abs,
            impacts,
            stats,
            dt,
            error,
        }
    }
}

/// Number of steps and the step actually used (as the compliant driver: `t_end` a whole
/// number of steps).
pub(crate) fn steps(settings: &RunSettings) -> (usize, f64) {
    let n = (settings.t_end / settings.dt - 1e-9).ceil().max(1.0) as usize;
    (n, settings.t_end / n as f64)
}
