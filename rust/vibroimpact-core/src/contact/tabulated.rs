//! A user law from tabulated force–indentation data: a loading curve and an unloading curve.
//!
//! Rule (stateless: the law sees only `δ`, `δ̇` and `v_imp`, not the largest penetration of
//! the current impact):
//!
//! * while `δ̇ ≥ 0` (loading) the force is the loading curve `F_L(δ)`;
//! * while `δ̇ ≤ −w` (unloading) it is the unloading curve `F_U(δ)`, as given (neither scaled
//!   nor shifted: the unloading curve is that of an impact whose largest penetration is at
//!   least the current one);
//! * in between it passes smoothly from one to the other,
//!   `F = F_U + (F_L − F_U) s(1 + δ̇/w)` with `s(x) = 3x² − 2x³`, so that the force and its
//!   derivatives stay continuous where the motion reverses (Newton needs that);
//! * `w = reversal_band · v_imp` (default `reversal_band` 0.01).
//!
//! Both curves are piecewise linear through the points given, start at `(0, 0)`, have
//! increasing penetrations and non-decreasing forces, and are continued linearly beyond
//! their last point. The unloading curve lies on or below the loading curve everywhere (so
//! the loop dissipates). The conservative part reported to the energy account is `F_L` and
//! its potential `∫₀^δ F_L`; what the force does below it is dissipated.

use super::{ContactForce, ContactLaw, MIN_IMPACT_SPEED};
use crate::error::{invalid, SimError};

/// A piecewise-linear curve through `(0, 0)`, continued linearly beyond its last point.
#[derive(Debug, Clone, PartialEq)]
pub struct Curve {
    penetration: Vec<f64>,
    force: Vec<f64>,
    /// Slope of segment `i` (`[x_i, x_{i+1}]`); the last one continues the curve.
    slope: Vec<f64>,
    /// `∫₀^{x_i} F`.
    integral: Vec<f64>,
}

impl Curve {
    fn new(which: &str, penetration: Vec<f64>, force: Vec<f64>) -> Result<Self, SimError> {
        let n = penetration.len();
        if n < 2 || force.len() != n {
            return invalid(format!(
                "tabulated: {which}_penetration has {n} values and {which}_force {}; expected \
                 the same number, at least 2",
                force.len()
            ));
        }
        if penetration[0] != 0.0 || force[0] != 0.0 {
            return invalid(format!(
                "tabulated: {which} curve starts at ({}, {}); expected (0, 0) (no force at first \
                 touch)",
                penetration[0], force[0]
            ));
        }
        for i in 1..n {
            let (x0, x1) = (penetration[i - 1], penetration[i]);
            if !(x1.is_finite() && x1 > x0) {
                return invalid(format!(
                    "tabulated: {which}_penetration[{i}] = {x1} is not valid; expected finite \
                     values increasing from 0, in m"
                ));
            }
            let (f0, f1) = (force[i - 1], force[i]);
            if !(f1.is_finite() && f1 >= f0) {
                return invalid(format!(
                    "tabulated: {which}_force[{i}] = {f1} is not valid; expected finite values \
                     >= 0 that do not decrease with penetration, in N"
                ));
            }
        }
        let mut slope = Vec::with_capacity(n - 1);
        let mut integral = Vec::with_capacity(n);
        integral.push(0.0);
        for i in 0..n - 1 {
            let h = penetration[i + 1] - penetration[i];
            slope.push((force[i + 1] - force[i]) / h);
            integral.push(integral[i] + 0.5 * h * (force[i] + force[i + 1]));
        }
        Ok(Self {
            penetration,
            force,
            slope,
            integral,
        })
    }

    /// `(F, dF/dδ, ∫₀^δ F)` at `δ ≥ 0`.
    #[inline]
    fn eval(&self, penetration: f64) -> (f64, f64, f64) {
        let last = self.slope.len() - 1;
        let i = self
            .penetration
            .partition_point(|&x| x <= penetration)
            .saturating_sub(1)
            .min(last);
        let dx = penetration - self.penetration[i];
        let s = self.slope[i];
        let f = self.force[i] + s * dx;
        (f, s, self.integral[i] + dx * (self.force[i] + 0.5 * s * dx))
    }

    fn last_slope(&self) -> f64 {
        self.slope[self.slope.len() - 1]
    }

    /// The points `(δ, F)` the curve was built from.
    pub fn points(&self) -> (&[f64], &[f64]) {
        (&self.penetration, &self.force)
    }
}

/// User law from tabulated loading and unloading curves (see the module documentation for
/// the rule). Its hysteresis is rate-independent: the damping does not depend on ce or on
/// `v_imp` except through the width `w = reversal_band · v_imp` of the reversal.
#[derive(Debug, Clone, PartialEq)]
pub struct Tabulated {
    loading: Curve,
    unloading: Curve,
    /// Width of the reversal as a fraction of `v_imp`, 0 < reversal_band <= 1.
    pub reversal_band: f64,
}

impl Tabulated {
    pub fn new(
        loading_penetration: Vec<f64>,
        loading_force: Vec<f64>,
        unloading_penetration: Vec<f64>,
        unloading_force: Vec<f64>,
        reversal_band: f64,
    ) -> Result<Self, SimError> {
        let loading = Curve::new("loading", loading_penetration, loading_force)?;
        let unloading = Curve::new("unloading", unloading_penetration, unloading_force)?;
        if loading.last_slope() <= 0.0 {
            return invalid(format!(
                "tabulated: loading_force ends flat (slope {}); expected the last two points \
                 to rise, so that the curve can be continued beyond them",
                loading.last_slope()
            ));
        }
        if !(reversal_band > 0.0 && reversal_band <= 1.0) {
            return invalid(format!(
                "tabulated: reversal_band = {reversal_band} is not valid; expected \
                 0 < reversal_band <= 1 (a fraction of the approach speed)"
            ));
        }
        // Both curves are linear between the union of their points and beyond the last one.
        let tol = |f: f64| 1e-12 * f.abs().max(1e-300);
        for &x in loading.penetration.iter().chain(&unloading.penetration) {
            let (fl, _, _) = loading.eval(x);
            let (fu, _, _) = unloading.eval(x);
            if fu > fl + tol(fl) {
                return invalid(format!(
                    "tabulated: the unloading curve is above the loading curve at penetration \
                     {x} m ({fu} N > {fl} N); expected unloading <= loading"
                ));
            }
        }
        if unloading.last_slope() > loading.last_slope() * (1.0 + 1e-12) {
            return invalid(format!(
                "tabulated: the unloading curve rises faster than the loading curve beyond the \
                 data ({} N/m > {} N/m); expected unloading <= loading at every penetration",
                unloading.last_slope(),
                loading.last_slope()
            ));
        }
        Ok(Self {
            loading,
            unloading,
            reversal_band,
        })
    }

    pub fn loading(&self) -> &Curve {
        &self.loading
    }

    pub fn unloading(&self) -> &Curve {
        &self.unloading
    }

    /// Secant stiffness of the loading curve at its last point, N/m (for step-size
    /// estimates).
    pub fn secant_stiffness(&self) -> f64 {
        let n = self.loading.penetration.len() - 1;
        self.loading.force[n] / self.loading.penetration[n]
    }
}

impl ContactLaw for Tabulated {
    #[inline]
    fn evaluate(&self, penetration: f64, rate: f64, impact_speed: f64) -> ContactForce {
        let (fl, dl, potential) = self.loading.eval(penetration);
        let (force, d_penetration, d_rate) = if rate >= 0.0 {
            (fl, dl, 0.0)
        } else {
            let (fu, du, _) = self.unloading.eval(penetration);
            let w = self.reversal_band * impact_speed.max(MIN_IMPACT_SPEED);
            let x = 1.0 + rate / w;
            if x <= 0.0 {
                (fu, du, 0.0)
            } else {
                let s = x * x * (3.0 - 2.0 * x);
                let ds = 6.0 * x * (1.0 - x) / w;
                (fu + (fl - fu) * s, du + (dl - du) * s, (fl - fu) * ds)
            }
        };
        ContactForce {
            force,
            d_penetration,
            d_rate,
            elastic: fl,
            potential,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn law() -> Tabulated {
        Tabulated::new(
            vec![0.0, 1e-5, 2e-5, 4e-5],
            vec![0.0, 10.0, 30.0, 80.0],
            vec![0.0, 1e-5, 3e-5],
            vec![0.0, 2.0, 20.0],
            0.01,
        )
        .unwrap()
    }

    #[test]
    fn follows_the_curves_and_reverses_smoothly() {
        let t = law();
        let v = 0.3;
        assert_eq!(t.evaluate(1.5e-5, 0.1, v).force, 20.0);
        assert_eq!(t.evaluate(1.5e-5, 0.0, v).force, 20.0);
        assert!((t.evaluate(1.5e-5, -0.1, v).force - 6.5).abs() < 1e-12);
        // Beyond the data: continued with the last slope (2.5e6 N/m loading, 0.9e6 unloading).
        assert!((t.evaluate(5e-5, 0.1, v).force - 105.0).abs() < 1e-9);
        assert!((t.evaluate(5e-5, -1.0, v).force - 38.0).abs() < 1e-9);
        // Half-way through the reversal band: s(1/2) = 1/2.
        let mid = t.evaluate(1.5e-5, -0.5 * 0.01 * v, v).force;
        assert!((mid - 0.5 * (20.0 + 6.5)).abs() < 1e-12);
        // Potential of the loading curve.
        let p = t.evaluate(2e-5, 0.0, v).potential;
        assert!((p - (0.5 * 1e-5 * 10.0 + 0.5 * 1e-5 * 40.0)).abs() < 1e-18);
    }

    #[test]
    fn bad_tables_are_refused() {
        let ok = || vec![0.0, 1e-5, 2e-5];
        let f = || vec![0.0, 10.0, 30.0];
        // Unloading above loading.
        assert!(Tabulated::new(ok(), f(), ok(), vec![0.0, 11.0, 30.0], 0.01).is_err());
        // Not starting at 0.
        assert!(Tabulated::new(vec![1e-6, 1e-5, 2e-5], f(), ok(), f(), 0.01).is_err());
        // Decreasing force, non-increasing penetration, length mismatch, bad band.
        assert!(Tabulated::new(ok(), vec![0.0, 10.0, 5.0], ok(), f(), 0.01).is_err());
        assert!(Tabulated::new(vec![0.0, 1e-5, 1e-5], f(), ok(), f(), 0.01).is_err());
        assert!(Tabulated::new(ok(), vec![0.0, 1.0], ok(), f(), 0.01).is_err());
        assert!(Tabulated::new(ok(), f(), ok(), f(), 0.0).is_err());
        // Unloading continued more steeply than loading.
        assert!(Tabulated::new(ok(), f(), ok(), vec![0.0, 0.0, 25.0], 0.01).is_err());
        assert!(Tabulated::new(ok(), f(), ok(), f(), 0.01).is_ok());
    }
}
