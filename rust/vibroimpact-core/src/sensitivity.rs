//! The state-transition matrix of a run, `Φ(t) = ∂z(t)/∂z₀` with `z = [x; v]`: what shooting
//! for periodic orbits needs (its monodromy matrix is `Φ` over the orbit's period, whose
//! eigenvalues are the Floquet multipliers; docs/periodic-orbits.md).
//!
//! The step policies that compute it (DOP853: the derivative of each Runge–Kutta stage; the
//! event-driven method: the exact `exp(A h)` of its flights; the Newmark family at fixed
//! steps: the derivative of each converged step of its discrete map,
//! `integrators::newmark_variational`) carry `Φ` from the run's start; the first two compose
//! it, at every located event where the vector field or the state jumps, with the saltation
//! matrix ([`saltation`]; DOP853 to first order: it differentiates the landing condition of
//! the step that ends on the switch, `integrators::dop853_variational`). [`crate::simulate::simulate_with_sensitivity`] returns
//! it in [`crate::output::RunOutput::state_transition`].

use nalgebra::{DMatrix, DVector};

use crate::error::{invalid, SimError};
use crate::integrators::MAX_TRANSITION_DOFS;
use crate::method::Method;
use crate::system::System;

/// `Φ(t) = ∂(x(t), v(t))/∂(x₀, v₀)`, `2n × 2n`: from the run's start to the end of the last
/// advance of its step policy.
#[derive(Debug, Clone, PartialEq)]
pub struct StateTransition {
    pub matrix: DMatrix<f64>,
}

impl StateTransition {
    /// `Φ = I` for `n` DOFs (the run's start).
    pub fn identity(n: usize) -> Self {
        Self {
            matrix: DMatrix::identity(2 * n, 2 * n),
        }
    }

    /// `Φ ← S Φ` for the saltation matrix `S` of an event ([`saltation`]) given as the rank-one
    /// update `S = R + u ∇hᵀ` with `R` the jump map's Jacobian (`None`: the state does not
    /// jump, `R = I`), `u = (f⁺ − R f⁻)/(∇hᵀ f⁻)`.
    pub fn compose_event(
        &mut self,
        jump: Option<&DMatrix<f64>>,
        u: &DVector<f64>,
        grad_h: &DVector<f64>,
    ) {
        let row = grad_h.transpose() * &self.matrix;
        if let Some(r) = jump {
            self.matrix = r * &self.matrix;
        }
        self.matrix += u * row;
    }
}

/// The saltation matrix of an event `h(z) = 0` crossed with the vector field `f⁻` before it
/// and `f⁺` after it, the state jumping by a map of Jacobian `R` (`I` when it does not jump):
/// `S = R + (f⁺ − R f⁻) ∇hᵀ / (∇hᵀ f⁻)` (Müller 1995; Leine & Nijmeijer 2004, §7.2), returned
/// as `u = (f⁺ − R f⁻)/(∇hᵀ f⁻)` for [`StateTransition::compose_event`].
/// `None` if the event is grazing (`∇hᵀ f⁻ = 0`: the derivative does not exist).
pub fn saltation_update(
    jump: Option<&DMatrix<f64>>,
    f_minus: &DVector<f64>,
    f_plus: &DVector<f64>,
    grad_h: &DVector<f64>,
) -> Option<DVector<f64>> {
    let transversal = grad_h.dot(f_minus);
    if transversal == 0.0 || !transversal.is_finite() {
        return None;
    }
    let r_f = match jump {
        Some(r) => r * f_minus,
        None => f_minus.clone(),
    };
    Some((f_plus - r_f) / transversal)
}

/// The full saltation matrix `S` (for tests and the docs' derivation; the policies apply it as
/// a rank-one update).
pub fn saltation(
    jump: Option<&DMatrix<f64>>,
    f_minus: &DVector<f64>,
    f_plus: &DVector<f64>,
    grad_h: &DVector<f64>,
) -> Option<DMatrix<f64>> {
    let u = saltation_update(jump, f_minus, f_plus, grad_h)?;
    let m = f_minus.len();
    let r = jump.cloned().unwrap_or_else(|| DMatrix::identity(m, m));
    Some(r + u * grad_h.transpose())
}

/// Refuses a run whose state-transition matrix the `method` (with adaptive steps if
/// `adaptive`) does not compute, or whose laws it cannot differentiate, before it starts.
pub(crate) fn check_supported(
    sys: &System,
    method: Method,
    adaptive: bool,
) -> Result<(), SimError> {
    if let Some(i) = sys
        .gaps
        .iter()
        .position(|g| matches!(g.side, crate::gap::Side::Radial(_)))
    {
        return invalid(format!(
            "gaps[{i}].kind: 'radial' has no state-transition matrix yet (its normal turns with \
             the state and its friction is not differentiated); expected 1-D gaps"
        ));
    }
    let newmark = matches!(method, Method::NewmarkFamily(_));
    if !(newmark || matches!(method, Method::Dop853 | Method::EventDriven(_))) {
        return invalid(format!(
            "solver.method: '{}' does not compute the state-transition matrix; expected \
             'dop853' or the Newmark family (compliant contact laws) or 'event-driven' (rigid \
             stops)",
            method.name()
        ));
    }
    if newmark && adaptive {
        return invalid(
            "solver.adaptive: true is not valid for the Newmark family's state-transition \
             matrix (its landed steps' lengths depend on the state); expected adaptive = false",
        );
    }
    if matches!(method, Method::Dop853) && !adaptive && !sys.gaps.is_empty() {
        return invalid(
            "solver.adaptive: false is not valid for DOP853's state-transition matrix (the steps \
             landed on a contact's onset and end are not differentiated in their length: \
             multipliers off by ~1e-3 at 8,000 steps a period); expected adaptive steps",
        );
    }
    let n = sys.n_dof();
    if newmark && n > MAX_TRANSITION_DOFS {
        return invalid(format!(
            "structure: {n} DOFs is more than the Newmark family's state-transition matrix \
             takes (dense, at most {MAX_TRANSITION_DOFS}); expected a reduced model \
             (vibroimpact.fe.reduction)"
        ));
    }
    if let Some((i, g)) = sys.gaps.iter().enumerate().find(|(_, g)| {
        matches!(g.law, crate::contact::Law::Tabulated(_)) || (newmark && g.law.uses_impact_speed())
    }) {
        return invalid(format!(
            "gaps[{i}].law: '{}' has no state-transition matrix with method '{}' yet (its force \
             depends on the contact's history); expected a law of the penetration and its rate",
            g.law.name(),
            method.name()
        ));
    }
    if let Some((i, g)) = sys
        .gaps
        .iter()
        .enumerate()
        .find(|(_, g)| !newmark && releases_inside(&g.law))
    {
        return invalid(format!(
            "gaps[{i}].law: '{}' has no state-transition matrix with DOP853 yet (its force is \
             clamped to zero inside the wall, a kink whose landing is not differentiated: \
             multipliers off by ~1e-2); expected another compliant law, or a Newmark-family \
             method (fixed steps)",
            g.law.name()
        ));
    }
    Ok(())
}

/// Kelvin–Voigt's force `k δ + c δ̇` turns tensile before the wall opens and is clamped there:
/// DOP853 lands on that release with a step whose length depends on the initial state, which
/// (unlike a wall's onset and end, `integrators::dop853_variational`) is not differentiated.
/// Measured against central differences of the map (the 1-DOF oscillator, `k = 1e4`,
/// `c = 20`): 1.2e-2 at `rtol = 1e-12`, 4e-2 at `1e-10` (with `c = 1e-9`: 4e-9).
fn releases_inside(law: &crate::contact::Law) -> bool {
    matches!(law, crate::contact::Law::KelvinVoigt(_))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The 1-DOF rigid stop with restitution `e` (`x'' + c x' + k x = F`, wall at `x = d`):
    /// the general formula gives `[[−e, 0], [(1+e)(F − k d)/v⁻, −e]]` (docs/periodic-orbits.md).
    #[test]
    fn rigid_stop_saltation_is_the_closed_form() {
        let (c, k, f, d, v, e) = (0.1, 1.0, 0.3, 0.5, 0.7, 0.8);
        let accel = |v: f64| f - c * v - k * d;
        let f_minus = DVector::from_vec(vec![v, accel(v)]);
        let f_plus = DVector::from_vec(vec![-e * v, accel(-e * v)]);
        let jump = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, -e]);
        let grad = DVector::from_vec(vec![1.0, 0.0]);
        let s = saltation(Some(&jump), &f_minus, &f_plus, &grad).unwrap();
        let expected = [-e, 0.0, (1.0 + e) * (f - k * d) / v, -e];
        for (i, want) in expected.iter().enumerate() {
            let got = s[(i / 2, i % 2)];
            assert!(
                (got - want).abs() < 1e-15,
                "S[{i}] = {got}, expected {want}"
            );
        }
        assert!(saltation(None, &DVector::from_vec(vec![0.0, 1.0]), &f_plus, &grad).is_none());
    }
}
