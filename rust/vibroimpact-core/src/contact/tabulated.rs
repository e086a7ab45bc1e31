//! A user law from tabulated force–indentation data: a loading curve and an unloading curve.
//!
//! Rule, in a contact whose largest penetration so far is `δ_m` (the wall state carries it
//! beside `v_imp`, `gap::WallState::max_penetration`):
//!
//! * while `δ̇ ≥ 0` (loading) the force is the loading curve `F_L(δ)`;
//! * while `δ̇ ≤ −w` (unloading) it is the unloading curve stretched to start on the loading
//!   curve at `δ_m`: `F_U*(δ) = F_L(δ_m) · F_U(δ δ_e/δ_m) / F_U(δ_e)`, where `δ_e` is the last
//!   unloading point (the given curve is the unloading from `δ_e`, and is reproduced when
//!   `δ_m = δ_e` and `F_U(δ_e) = F_L(δ_e)`). Penetrations are scaled by `δ_m/δ_e` and forces by
//!   `F_L(δ_m)/F_U(δ_e)`, so every impact unloads along the same shape, from where it turned.
//!   `F_U*` is capped by `F_L` (never above the loading curve, so no impact gains energy);
//! * in between it passes smoothly from one to the other,
//!   `F = F_U* + (F_L − F_U*) s(1 + δ̇/w)` with `s(x) = 3x² − 2x³`, so that the force and its
//!   derivatives stay continuous where the motion reverses (Newton needs that);
//! * `w = reversal_band · v_imp` (default `reversal_band` 0.01).
//!
//! At `δ ≥ δ_m` both curves give `F_L(δ)`. The integrators take `δ_m` as the largest
//! penetration at the ends of the steps of the current contact (`max(δ_m(start), δ)`, so the
//! Newton tangent is exact); a lone evaluation ([`ContactLaw::evaluate`]) takes `δ_m = δ_e`.
//! For a linear loading curve `k δ` and an unloading shape with residual indentation `r δ_e`
//! (points `(0, 0)`, `(r δ_e, 0)`, `(δ_e, k δ_e)`), one impact to `δ_m` dissipates
//! `k δ_m² r / 2` of the `k δ_m² / 2` it stored: the restitution `√(1 − r)` for every speed.
//!
//! Both curves are piecewise linear through the points given, start at `(0, 0)`, have
//! increasing penetrations and non-decreasing forces; the loading curve is continued linearly
//! beyond its last point (the stretched unloading curve only samples `[0, δ_e]`). The
//! unloading points lie on or below the loading curve and end at a positive force. The
//! conservative part reported to the energy account is `F_L` and its potential `∫₀^δ F_L`;
//! what the force does below it is dissipated.

use super::catalog::check_parameter;
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

/// The first fault of curve `which` (`loading` or `unloading`) of a [`Tabulated`] law: the
/// parameter to name (`<which>_penetration` or `<which>_force`) and what it expects; `None`
/// when the points make a curve (at least 2 finite points, as many forces as penetrations,
/// from `(0, 0)`, increasing penetrations, non-decreasing forces; a loading curve whose last
/// two points rise, as it is continued beyond them).
pub fn curve_fault(which: &str, penetration: &[f64], force: &[f64]) -> Option<(String, String)> {
    let (px, fx) = (format!("{which}_penetration"), format!("{which}_force"));
    let n = penetration.len();
    let fault = |field: &String, expected: String| Some((field.clone(), expected));
    if n < 2 {
        return fault(&px, "at least 2 penetrations, in m".into());
    }
    if force.len() != n {
        return fault(&fx, format!("{n} forces, one per {px} value, in N"));
    }
    if penetration[0] != 0.0 || force[0] != 0.0 {
        let field = if penetration[0] != 0.0 { &px } else { &fx };
        return fault(
            field,
            "a curve from (0, 0) (no force at first touch)".into(),
        );
    }
    if !penetration
        .windows(2)
        .all(|w| w[1].is_finite() && w[1] > w[0])
    {
        return fault(&px, "finite penetrations increasing from 0, in m".into());
    }
    if !force.windows(2).all(|w| w[1].is_finite() && w[1] >= w[0]) {
        return fault(
            &fx,
            "finite forces from 0 that do not decrease with penetration, in N".into(),
        );
    }
    if which == "loading" && force[n - 1] <= force[n - 2] {
        return fault(
            &fx,
            "a curve whose last two points rise (it is continued beyond them)".into(),
        );
    }
    None
}

impl Curve {
    fn new(which: &str, penetration: Vec<f64>, force: Vec<f64>) -> Result<Self, SimError> {
        if let Some((field, expected)) = curve_fault(which, &penetration, &force) {
            let value = if field.ends_with("_force") {
                &force
            } else {
                &penetration
            };
            return invalid(format!(
                "tabulated: {field} = {value:?} is not valid; expected {expected}"
            ));
        }
        let n = penetration.len();
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

    /// The points `(δ, F)` the curve was built from.
    pub fn points(&self) -> (&[f64], &[f64]) {
        (&self.penetration, &self.force)
    }
}

/// User law from tabulated loading and unloading curves (see the module documentation for
/// the rule: the unloading curve is stretched to start on the loading curve at the largest
/// penetration of each contact). Its hysteresis is rate-independent: the damping does not
/// depend on ce or on `v_imp` except through the width `w = reversal_band · v_imp` of the
/// reversal.
#[derive(Debug, Clone, PartialEq)]
pub struct Tabulated {
    loading: Curve,
    unloading: Curve,
    /// Width of the reversal as a fraction of `v_imp`, 0 < reversal_band <= 1.
    pub reversal_band: f64,
    /// Last point `(δ_e, F_U(δ_e))` of the unloading curve.
    end_penetration: f64,
    end_force: f64,
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
        check_parameter("tabulated", "reversal_band", reversal_band)?;
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
        let last = unloading.penetration.len() - 1;
        let (end_penetration, end_force) = (unloading.penetration[last], unloading.force[last]);
        if end_force <= 0.0 {
            return invalid(format!(
                "tabulated: unloading_force ends at {end_force} N; expected a last force > 0 (the \
                 curve is scaled to start on the loading curve at each impact's largest \
                 penetration)"
            ));
        }
        Ok(Self {
            loading,
            unloading,
            reversal_band,
            end_penetration,
            end_force,
        })
    }

    /// The unloading curve of a contact that reached `max_penetration > penetration`, capped
    /// by the loading value `(fl, dl)`: `(F_U*, ∂F_U*/∂δ)`.
    #[inline]
    fn stretched_unloading(
        &self,
        penetration: f64,
        max_penetration: f64,
        (fl, dl): (f64, f64),
    ) -> (f64, f64) {
        let (f_turn, _, _) = self.loading.eval(max_penetration);
        let stretch = self.end_penetration / max_penetration;
        let scale = f_turn / self.end_force;
        let (fu, du, _) = self.unloading.eval(penetration * stretch);
        let (fu, du) = (scale * fu, scale * du * stretch);
        if fu < fl {
            (fu, du)
        } else {
            (fl, dl)
        }
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
    /// A lone evaluation: the contact's largest penetration is taken as `δ_e`.
    #[inline]
    fn evaluate(&self, penetration: f64, rate: f64, impact_speed: f64) -> ContactForce {
        self.evaluate_in_contact(penetration, rate, impact_speed, self.end_penetration)
    }

    #[inline]
    fn evaluate_in_contact(
        &self,
        penetration: f64,
        rate: f64,
        impact_speed: f64,
        max_penetration: f64,
    ) -> ContactForce {
        let (fl, dl, potential) = self.loading.eval(penetration);
        let (force, d_penetration, d_rate) = if rate >= 0.0 || penetration >= max_penetration {
            (fl, dl, 0.0)
        } else {
            let (fu, du) = self.stretched_unloading(penetration, max_penetration, (fl, dl));
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
        // Alone, the unloading curve starts at δ_e = 3e-5 on the loading curve (55 N): the
        // given one (20 N there) scaled by 55/20, 6.5 N → 17.875 N at 1.5e-5.
        let unloading = 6.5 * 55.0 / 20.0;
        assert!((t.evaluate(1.5e-5, -0.1, v).force - unloading).abs() < 1e-12);
        // Beyond the data the loading curve is continued with its last slope, 2.5e6 N/m; past
        // the largest penetration unloading gives the loading force.
        assert!((t.evaluate(5e-5, 0.1, v).force - 105.0).abs() < 1e-9);
        assert!((t.evaluate(5e-5, -1.0, v).force - 105.0).abs() < 1e-9);
        // Half-way through the reversal band: s(1/2) = 1/2.
        let mid = t.evaluate(1.5e-5, -0.5 * 0.01 * v, v).force;
        assert!((mid - 0.5 * (20.0 + unloading)).abs() < 1e-12);
        // Potential of the loading curve.
        let p = t.evaluate(2e-5, 0.0, v).potential;
        assert!((p - (0.5 * 1e-5 * 10.0 + 0.5 * 1e-5 * 40.0)).abs() < 1e-18);
    }

    /// `F_U*(δ) = F_L(δ_m) F_U(δ δ_e/δ_m)/F_U(δ_e)`, written out for the table's points.
    #[test]
    fn unloading_is_stretched_to_the_largest_penetration() {
        let t = law();
        let loading = |d: f64| t.loading.eval(d).0;
        // Inside the data (δ_m = 2e-5: 30 N) and beyond it (δ_m = 6e-5: 130 N).
        for &(dm, f_turn) in &[(2e-5, 30.0), (6e-5, 130.0)] {
            assert!((loading(dm) - f_turn).abs() < 1e-9);
            let stretch = 3e-5 / dm;
            for &d in &[0.2 * dm, 0.5 * dm, 0.9 * dm, 0.999 * dm] {
                let x = d * stretch; // on the given curve
                let given = if x <= 1e-5 {
                    2.0 * x / 1e-5
                } else {
                    2.0 + 18.0 * (x - 1e-5) / 2e-5
                };
                let expected = (f_turn * given / 20.0).min(loading(d));
                let f = t.evaluate_in_contact(d, -1.0, 0.3, dm).force;
                assert!(
                    (f - expected).abs() < 1e-9 * f_turn,
                    "{dm} {d}: {f} vs {expected}"
                );
            }
            // It starts on the loading curve.
            let f = t
                .evaluate_in_contact(dm * (1.0 - 1e-12), -1.0, 0.3, dm)
                .force;
            assert!((f - f_turn).abs() < 1e-6 * f_turn);
        }
    }

    /// Linear loading `k δ`, unloading shape with residual indentation `r δ_e`: one impact
    /// to `δ_m` returns `k δ_m² (1 − r)/2` of the `k δ_m²/2` stored, whatever `δ_m`.
    #[test]
    fn returned_energy_has_the_closed_form() {
        let (k, de, r) = (3.0e7, 2e-5, 0.35);
        let t = Tabulated::new(
            vec![0.0, de],
            vec![0.0, k * de],
            vec![0.0, r * de, de],
            vec![0.0, 0.0, k * de],
            0.01,
        )
        .unwrap();
        for &dm in &[0.3 * de, de, 2.5 * de] {
            let n = 4000;
            let h = dm / n as f64;
            let f = |d: f64| t.evaluate_in_contact(d, -1.0, 1.0, dm).force;
            let mut returned = 0.0;
            for i in 0..n {
                let a = i as f64 * h;
                returned += h * (f(a) + 4.0 * f(a + 0.5 * h) + f(a + h)) / 6.0;
            }
            let expected = k * dm * dm * (1.0 - r) / 2.0;
            // The kink at r δ_m falls on a node of the Simpson grid for these δ_m.
            assert!(
                (returned - expected).abs() < 1e-9 * expected,
                "{dm}: {returned} vs {expected}"
            );
        }
    }

    /// The tangent inside a contact (δ_m fixed, as in a step whose start is deeper) equals
    /// finite differences, away from the kinks.
    #[test]
    fn derivatives_in_contact_match_finite_differences() {
        let t = law();
        let v = 0.3;
        let w = 0.01 * v;
        for &dm in &[2.5e-5, 5e-5] {
            for i in 1..40 {
                let d = dm * (i as f64 + 0.37) / 41.0;
                for &rate in &[-1.0, -0.4 * w, 0.2] {
                    let hp = 1e-6 * d;
                    let hr = 1e-7;
                    let c = t.evaluate_in_contact(d, rate, v, dm);
                    let fd_p = (t.evaluate_in_contact(d + hp, rate, v, dm).force
                        - t.evaluate_in_contact(d - hp, rate, v, dm).force)
                        / (2.0 * hp);
                    let fd_r = (t.evaluate_in_contact(d, rate + hr, v, dm).force
                        - t.evaluate_in_contact(d, rate - hr, v, dm).force)
                        / (2.0 * hr);
                    let near_kink = [1e-5, 2e-5, 4e-5]
                        .iter()
                        .chain(&[1e-5 * dm / 3e-5])
                        .any(|k| (d - k).abs() < 4.0 * hp);
                    if near_kink {
                        continue;
                    }
                    let scale = c.d_penetration.abs() + c.force / d;
                    assert!(
                        (c.d_penetration - fd_p).abs() <= 1e-5 * scale,
                        "{dm} {d} {rate}"
                    );
                    assert!((c.d_rate - fd_r).abs() <= 1e-5 * (c.d_rate.abs() + c.force / w));
                }
            }
        }
    }

    #[test]
    fn bad_tables_are_refused() {
        let ok = || vec![0.0, 1e-5, 2e-5];
        let f = || vec![0.0, 10.0, 30.0];
        // Unloading above loading.
        assert!(Tabulated::new(ok(), f(), ok(), vec![0.0, 11.0, 30.0], 0.01).is_err());
        // Not starting at 0.
        let msg = Tabulated::new(vec![1e-6, 1e-5, 2e-5], f(), ok(), f(), 0.01)
            .unwrap_err()
            .to_string();
        assert_eq!(
            msg,
            "tabulated: loading_penetration = [1e-6, 1e-5, 2e-5] is not valid; expected a curve \
             from (0, 0) (no force at first touch)"
        );
        // Decreasing force, non-increasing penetration, length mismatch, bad band.
        assert!(Tabulated::new(ok(), vec![0.0, 10.0, 5.0], ok(), f(), 0.01).is_err());
        assert!(Tabulated::new(vec![0.0, 1e-5, 1e-5], f(), ok(), f(), 0.01).is_err());
        assert!(Tabulated::new(ok(), vec![0.0, 1.0], ok(), f(), 0.01).is_err());
        assert!(Tabulated::new(ok(), f(), ok(), f(), 0.0).is_err());
        // An unloading curve without force has no shape to scale.
        let msg = Tabulated::new(ok(), f(), ok(), vec![0.0, 0.0, 0.0], 0.01)
            .unwrap_err()
            .to_string();
        assert!(
            msg.starts_with("tabulated: unloading_force ends at 0 N"),
            "{msg}"
        );
        assert!(Tabulated::new(ok(), f(), ok(), f(), 0.01).is_ok());
    }
}
