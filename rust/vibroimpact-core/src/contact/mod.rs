//! Contact-force laws `F(δ, δ̇, v_imp)` (paper §2.2, Table 2; DESIGN.md §3).
//!
//! Every law gives the force and its two partial derivatives, which Newton uses as the
//! consistent tangent. A law sees only its own parameters, never the system. Laws are
//! evaluated only while the gap is closed (`δ > 0`); the force is never tensile: a damped
//! law whose formula goes negative near separation is clamped to zero (with zero tangent).

mod geometry;
mod hertz;
mod hysteretic;
mod kelvin_voigt;

pub use geometry::{ContactGeometry, Material};
pub use hertz::Hertz;
pub use hysteretic::{Flores, Gonthier, HuntCrossley, HuntCrossleyDamping, LankaraniNikravesh};
pub use kelvin_voigt::KelvinVoigt;

use crate::error::{invalid, SimError};

/// Approach speeds below this (m/s) are raised to it in laws that divide by `v_imp`,
/// so that a grazing contact gives a large but finite damping coefficient.
pub const MIN_IMPACT_SPEED: f64 = 1e-8;

/// Force of a law and its tangent at one state.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ContactForce {
    /// Compressive contact force `F ≥ 0`, N.
    pub force: f64,
    /// `∂F/∂δ`, N/m.
    pub d_penetration: f64,
    /// `∂F/∂δ̇`, N·s/m.
    pub d_rate: f64,
    /// Conservative part of the force, `F_el(δ)`, N (for the energy account).
    pub elastic: f64,
    /// Potential stored in the conservative part, `∫₀^δ F_el`, J.
    pub potential: f64,
}

/// A contact-force law.
pub trait ContactLaw {
    /// Force and partial derivatives for penetration `δ > 0`, rate `δ̇` and approach speed
    /// `v_imp > 0`, before clamping (the value may be negative for damped laws).
    fn evaluate(&self, penetration: f64, rate: f64, impact_speed: f64) -> ContactForce;

    /// Conservative part of the force, `F_el(δ)`, N.
    fn elastic_force(&self, penetration: f64) -> f64 {
        if penetration <= 0.0 {
            return 0.0;
        }
        self.evaluate(penetration, 0.0, 1.0).elastic
    }

    /// Potential stored in the conservative part, `∫₀^δ F_el`, J.
    fn elastic_energy(&self, penetration: f64) -> f64 {
        if penetration <= 0.0 {
            return 0.0;
        }
        self.evaluate(penetration, 0.0, 1.0).potential
    }

    /// Force clamped to be compressive: zero force and zero tangent where the formula is
    /// tensile (the conservative part and its potential are still reported).
    #[inline]
    fn force(&self, penetration: f64, rate: f64, impact_speed: f64) -> ContactForce {
        if penetration <= 0.0 {
            return ContactForce::default();
        }
        let f = self.evaluate(penetration, rate, impact_speed);
        if f.force > 0.0 {
            f
        } else {
            ContactForce {
                force: 0.0,
                d_penetration: 0.0,
                d_rate: 0.0,
                ..f
            }
        }
    }
}

/// The library of laws, as plain data (enum dispatch keeps the time loop free of virtual calls).
#[derive(Debug, Clone, PartialEq)]
pub enum Law {
    Hertz(Hertz),
    KelvinVoigt(KelvinVoigt),
    HuntCrossley(HuntCrossley),
    LankaraniNikravesh(LankaraniNikravesh),
    Gonthier(Gonthier),
    Flores(Flores),
}

macro_rules! dispatch {
    ($self:ident, $law:ident => $body:expr) => {
        match $self {
            Law::Hertz($law) => $body,
            Law::KelvinVoigt($law) => $body,
            Law::HuntCrossley($law) => $body,
            Law::LankaraniNikravesh($law) => $body,
            Law::Gonthier($law) => $body,
            Law::Flores($law) => $body,
        }
    };
}

impl ContactLaw for Law {
    #[inline]
    fn evaluate(&self, penetration: f64, rate: f64, impact_speed: f64) -> ContactForce {
        dispatch!(self, law => law.evaluate(penetration, rate, impact_speed))
    }
}

impl Law {
    /// Kebab-case name used in model files, the CLI and JSON output.
    pub fn name(&self) -> &'static str {
        match self {
            Law::Hertz(_) => "hertz",
            Law::KelvinVoigt(_) => "kelvin-voigt",
            Law::HuntCrossley(_) => "hunt-crossley",
            Law::LankaraniNikravesh(_) => "lankarani-nikravesh",
            Law::Gonthier(_) => "gonthier",
            Law::Flores(_) => "flores",
        }
    }

    /// Whether the law needs the approach speed `v_imp` of the current impact.
    pub fn uses_impact_speed(&self) -> bool {
        match self {
            Law::Hertz(_) | Law::KelvinVoigt(_) => false,
            Law::HuntCrossley(hc) => matches!(hc.damping, HuntCrossleyDamping::Restitution(_)),
            Law::LankaraniNikravesh(_) | Law::Gonthier(_) | Law::Flores(_) => true,
        }
    }
}

pub(crate) fn check_stiffness(law: &str, stiffness: f64) -> Result<(), SimError> {
    if !(stiffness.is_finite() && stiffness > 0.0) {
        return invalid(format!(
            "{law}: stiffness = {stiffness} is not valid; expected a finite value > 0"
        ));
    }
    Ok(())
}

pub(crate) fn check_exponent(law: &str, exponent: f64) -> Result<(), SimError> {
    if !(exponent.is_finite() && exponent >= 1.0) {
        return invalid(format!(
            "{law}: exponent = {exponent} is not valid; expected a finite value >= 1"
        ));
    }
    Ok(())
}

pub(crate) fn check_restitution(law: &str, restitution: f64) -> Result<(), SimError> {
    if !(restitution > 0.0 && restitution <= 1.0) {
        return invalid(format!(
            "{law}: restitution = {restitution} is not valid; expected 0 < restitution <= 1"
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn all_laws() -> Vec<Law> {
        let k = 2.0e9;
        vec![
            Law::Hertz(Hertz::new(k, 1.5).unwrap()),
            Law::KelvinVoigt(KelvinVoigt::new(4.0e7, 3.0e3).unwrap()),
            Law::HuntCrossley(
                HuntCrossley::new(k, 1.5, HuntCrossleyDamping::Restitution(0.7)).unwrap(),
            ),
            Law::HuntCrossley(
                HuntCrossley::new(k, 1.5, HuntCrossleyDamping::Coefficient(1.0e9)).unwrap(),
            ),
            Law::LankaraniNikravesh(LankaraniNikravesh::new(k, 1.5, 0.6).unwrap()),
            Law::Gonthier(Gonthier::new(k, 1.3, 0.5).unwrap()),
            Law::Flores(Flores::new(k, 1.5, 0.9).unwrap()),
        ]
    }

    /// Analytic derivatives equal central finite differences over a grid of states.
    #[test]
    fn derivatives_match_finite_differences() {
        for law in all_laws() {
            for &pen in &[1e-7, 3e-6, 2e-5, 1e-4] {
                for &rate in &[-0.4, -0.05, 0.0, 0.1, 0.6] {
                    let v_imp = 0.3;
                    let f = law.evaluate(pen, rate, v_imp);
                    let hp = pen * 1e-6;
                    let fd_pen = (law.evaluate(pen + hp, rate, v_imp).force
                        - law.evaluate(pen - hp, rate, v_imp).force)
                        / (2.0 * hp);
                    let hr = 1e-6;
                    let fd_rate = (law.evaluate(pen, rate + hr, v_imp).force
                        - law.evaluate(pen, rate - hr, v_imp).force)
                        / (2.0 * hr);
                    let scale_p = f.d_penetration.abs().max(1.0);
                    let scale_r = f.d_rate.abs().max(1e-3);
                    assert!(
                        (f.d_penetration - fd_pen).abs() <= 1e-6 * scale_p,
                        "{}: dF/dδ {} vs {fd_pen}",
                        law.name(),
                        f.d_penetration
                    );
                    assert!(
                        (f.d_rate - fd_rate).abs() <= 1e-6 * scale_r,
                        "{}: dF/dδ̇ {} vs {fd_rate}",
                        law.name(),
                        f.d_rate
                    );
                }
            }
        }
    }

    #[test]
    fn force_is_never_tensile() {
        for law in all_laws() {
            for &rate in &[-100.0, -1.0, -0.3] {
                let f = law.force(1e-6, rate, 0.3);
                assert!(f.force >= 0.0, "{}", law.name());
                if f.force == 0.0 {
                    assert_eq!(f.d_penetration, 0.0);
                    assert_eq!(f.d_rate, 0.0);
                }
            }
            assert_eq!(law.force(-1e-6, 1.0, 0.3).force, 0.0);
        }
    }

    #[test]
    fn elastic_energy_is_integral_of_elastic_force() {
        for law in all_laws() {
            let pen = 4e-5;
            let n = 20_000;
            let h = pen / n as f64;
            let mut integral = 0.0;
            for i in 0..n {
                let a = law.elastic_force(i as f64 * h);
                let b = law.elastic_force((i + 1) as f64 * h);
                let m = law.elastic_force((i as f64 + 0.5) * h);
                integral += h * (a + 4.0 * m + b) / 6.0;
            }
            let e = law.elastic_energy(pen);
            assert!((integral - e).abs() <= 1e-9 * e, "{}", law.name());
        }
    }

    #[test]
    fn invalid_parameters_are_refused() {
        assert!(Hertz::new(-1.0, 1.5).is_err());
        assert!(Hertz::new(1.0, 0.5).is_err());
        assert!(LankaraniNikravesh::new(1e9, 1.5, 0.0).is_err());
        assert!(Flores::new(1e9, 1.5, 1.2).is_err());
        assert!(KelvinVoigt::new(1e9, -2.0).is_err());
        assert!(HuntCrossley::new(1e9, 1.5, HuntCrossleyDamping::Coefficient(-1.0)).is_err());
    }
}
