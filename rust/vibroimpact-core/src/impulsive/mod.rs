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

mod event_driven;
pub mod lcp;
mod moreau_jean;

pub use event_driven::EventDriven;
pub(crate) use event_driven::EventDrivenSteps;
pub use moreau_jean::MoreauJean;
pub(crate) use moreau_jean::MoreauJeanSteps;

use std::sync::Arc;

use nalgebra::{DMatrix, DVector};

use crate::error::SimError;
use crate::gap::WallState;
use crate::structure::DenseStructure;
use crate::system::{State, System};

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

/// Sets the loads, gap coordinates and wall states of `s` from its `t`, `x`, `v` and `a`;
/// `force(j)`: wall `j`'s contact force (N), all of it elastic, so that the run's energy
/// account adds no contact work (the impulsive methods give it the dissipation of their
/// impulses themselves).
pub(crate) fn fill_gaps(sys: &System, rig: &Rigidity, s: &mut State, force: impl Fn(usize) -> f64) {
    for (value, load) in s.load.iter_mut().zip(&sys.loads) {
        *value = load.value(s.t);
    }
    sys.gap_coordinates(&s.x, &mut s.u);
    sys.gap_coordinates(&s.v, &mut s.u_rate);
    sys.gap_coordinates(&s.a, &mut s.u_accel);
    s.phi.fill(0.0);
    // a wall's row of G is its side times its gap's row: δ = s u − d, δ̇ = s u̇
    for (j, (wall, w)) in sys.walls.iter().zip(s.walls.iter_mut()).enumerate() {
        let f = force(j);
        s.phi[wall.gap] += wall.sign * f;
        *w = WallState {
            penetration: wall.sign * s.u[wall.gap] - rig.clearance[j],
            rate: wall.sign * s.u_rate[wall.gap],
            force: f,
            elastic_force: f,
            ..WallState::default()
        };
    }
}
