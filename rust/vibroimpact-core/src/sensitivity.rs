//! The state-transition matrix of a run, `Φ(t) = ∂z(t)/∂z₀` with `z = [x; v]`: what shooting
//! for periodic orbits needs (its monodromy matrix is `Φ` over the orbit's period, whose
//! eigenvalues are the Floquet multipliers; docs/periodic-orbits.md).
//!
//! The step policies that compute it (DOP853: the derivative of each Runge–Kutta stage; the
//! event-driven method: the exact `exp(A h)` of its flights) carry `Φ` from the run's start
//! and compose it, at every located event where the vector field or the state jumps, with the
//! saltation matrix ([`saltation`]). [`crate::simulate::simulate_with_sensitivity`] returns
//! it in [`crate::output::RunOutput::state_transition`].

use nalgebra::{DMatrix, DVector};

use crate::error::{invalid, SimError};
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

/// Refuses a run whose state-transition matrix the `method` does not compute, or whose laws
/// it cannot differentiate, before it starts.
pub(crate) fn check_supported(sys: &System, method: Method) -> Result<(), SimError> {
    if !matches!(method, Method::Dop853 | Method::EventDriven(_)) {
        return invalid(format!(
            "solver.method: '{}' does not compute the state-transition matrix; expected \
             'dop853' (compliant contact laws) or 'event-driven' (rigid stops)",
            method.name()
        ));
    }
    if let Some((i, _)) = sys
        .gaps
        .iter()
        .enumerate()
        .find(|(_, g)| matches!(g.law, crate::contact::Law::Tabulated(_)))
    {
        return invalid(format!(
            "gaps[{i}].law: 'tabulated' has no state-transition matrix yet (its unloading \
             curve depends on the contact's history); expected an analytic law"
        ));
    }
    if let Some((i, g)) = sys
        .gaps
        .iter()
        .enumerate()
        .find(|(_, g)| stiff_at_first_touch(&g.law))
    {
        return invalid(format!(
            "gaps[{i}].law: '{}' is stiff at first touch (its force's slope jumps at δ = 0), \
             and the step that lands on the opening is not yet differentiated for such a law \
             (its multipliers would be off by ~1e-4); expected an exponent > 1 or a rigid stop",
            g.law.name()
        ));
    }
    Ok(())
}

/// A law whose stiffness `∂F/∂δ` does not vanish as `δ → 0⁺` (Kelvin–Voigt, a power law of
/// exponent ≤ 1): the field's Jacobian jumps at the wall, which the landing step's
/// differentiation does not take yet (checked against finite differences: the error falls
/// only as `h^1.5`).
fn stiff_at_first_touch(law: &crate::contact::Law) -> bool {
    use crate::contact::Law;
    match law {
        Law::KelvinVoigt(_) => true,
        Law::Hertz(l) => l.exponent <= 1.0,
        Law::Hysteretic(l) => l.exponent <= 1.0,
        Law::HuntCrossley(l) => l.exponent <= 1.0,
        Law::Tabulated(_) | Law::Rigid(_) => false,
    }
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
