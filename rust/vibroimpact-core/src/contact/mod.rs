//! Contact-force laws `F(δ, δ̇, v_imp)` (paper §2.2, Table 2; docs/contact-laws.md).
//!
//! Every law gives the force and its two partial derivatives, which Newton uses as the
//! consistent tangent. A law sees only its own parameters, never the system. Laws are
//! evaluated only while the gap is closed (`δ > 0`); the force is never tensile: a damped
//! law whose formula goes negative near separation is clamped to zero (with zero tangent).
//!
//! Families, one file each: [`Hertz`] (elastic); [`KelvinVoigt`] (linear spring–dashpot);
//! the Hertzian laws with hysteresis damping `K δⁿ (1 + χ δ̇/v_imp)` in `hysteretic`
//! ([`HuntCrossley`], [`HerbertMcWhannell`], [`LeeWang`], [`LankaraniNikravesh`],
//! [`Gonthier`], [`ZhiyingQishao`], [`Flores`], [`HuGuo`], [`GharibHurmuzlu`], [`Ye`],
//! [`CarvalhoMartins`], [`ExactRestitution`]); and [`Tabulated`] loading/unloading curves.
//! Stiffness from geometry and material is in `geometry`.

mod geometry;
mod hertz;
mod hysteretic;
mod kelvin_voigt;
mod rigid;
mod tabulated;

pub use geometry::{
    combined_modulus, johnson_cylinder_in_hole_approach, ContactGeometry, Material,
};
pub use hertz::Hertz;
pub use hysteretic::{
    exact_hysteresis_factor, restitution_of_factor, CarvalhoMartins, ExactRestitution, Flores,
    GharibHurmuzlu, Gonthier, HerbertMcWhannell, HuGuo, HuntCrossley, HuntCrossleyDamping,
    LankaraniNikravesh, LeeWang, Ye, ZhiyingQishao,
};
pub use kelvin_voigt::KelvinVoigt;
pub use rigid::Rigid;
pub use tabulated::{Curve, Tabulated};

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

    /// The force inside a contact whose largest penetration so far is `max_penetration`
    /// (only [`Tabulated`] depends on it; the others are [`ContactLaw::evaluate`]).
    #[inline]
    fn evaluate_in_contact(
        &self,
        penetration: f64,
        rate: f64,
        impact_speed: f64,
        _max_penetration: f64,
    ) -> ContactForce {
        self.evaluate(penetration, rate, impact_speed)
    }

    /// Force clamped to be compressive: zero force and zero tangent where the formula is
    /// tensile (the conservative part and its potential are still reported).
    #[inline]
    fn force(&self, penetration: f64, rate: f64, impact_speed: f64) -> ContactForce {
        if penetration <= 0.0 {
            return ContactForce::default();
        }
        compressive(self.evaluate(penetration, rate, impact_speed))
    }

    /// [`ContactLaw::force`] inside a contact whose largest penetration so far is
    /// `max_penetration` (what the time integrators evaluate).
    #[inline]
    fn force_in_contact(
        &self,
        penetration: f64,
        rate: f64,
        impact_speed: f64,
        max_penetration: f64,
    ) -> ContactForce {
        if penetration <= 0.0 {
            return ContactForce::default();
        }
        compressive(self.evaluate_in_contact(penetration, rate, impact_speed, max_penetration))
    }
}

/// Zero force and tangent where the formula is tensile, the conservative part kept.
#[inline]
fn compressive(f: ContactForce) -> ContactForce {
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

/// The library of laws, as plain data (enum dispatch keeps the time loop free of virtual calls).
#[derive(Debug, Clone, PartialEq)]
pub enum Law {
    Hertz(Hertz),
    KelvinVoigt(KelvinVoigt),
    HuntCrossley(HuntCrossley),
    HerbertMcWhannell(HerbertMcWhannell),
    LeeWang(LeeWang),
    LankaraniNikravesh(LankaraniNikravesh),
    Gonthier(Gonthier),
    ZhiyingQishao(ZhiyingQishao),
    Flores(Flores),
    HuGuo(HuGuo),
    GharibHurmuzlu(GharibHurmuzlu),
    Ye(Ye),
    CarvalhoMartins(CarvalhoMartins),
    ExactRestitution(ExactRestitution),
    Tabulated(Tabulated),
    /// The massless bar: impulsive methods only (not in [`LAW_NAMES`], which lists the
    /// force laws; its name is [`RIGID_NAME`]).
    Rigid(Rigid),
}

/// Kebab-case name of [`Law::Rigid`] (`[gaps.law] kind = "rigid"`).
pub const RIGID_NAME: &str = "rigid";

/// Kebab-case names of the laws, in the order of [`Law`] (model files, CLI, JSON).
pub const LAW_NAMES: [&str; 15] = [
    "hertz",
    "kelvin-voigt",
    "hunt-crossley",
    "herbert-mcwhannell",
    "lee-wang",
    "lankarani-nikravesh",
    "gonthier",
    "zhiying-qishao",
    "flores",
    "hu-guo",
    "gharib-hurmuzlu",
    "ye",
    "carvalho-martins",
    "exact-restitution",
    "tabulated",
];

macro_rules! dispatch {
    ($self:ident, $law:ident => $body:expr) => {
        match $self {
            Law::Hertz($law) => $body,
            Law::KelvinVoigt($law) => $body,
            Law::HuntCrossley($law) => $body,
            Law::HerbertMcWhannell($law) => $body,
            Law::LeeWang($law) => $body,
            Law::LankaraniNikravesh($law) => $body,
            Law::Gonthier($law) => $body,
            Law::ZhiyingQishao($law) => $body,
            Law::Flores($law) => $body,
            Law::HuGuo($law) => $body,
            Law::GharibHurmuzlu($law) => $body,
            Law::Ye($law) => $body,
            Law::CarvalhoMartins($law) => $body,
            Law::ExactRestitution($law) => $body,
            Law::Tabulated($law) => $body,
            Law::Rigid($law) => $body,
        }
    };
}

impl ContactLaw for Law {
    #[inline]
    fn evaluate(&self, penetration: f64, rate: f64, impact_speed: f64) -> ContactForce {
        dispatch!(self, law => law.evaluate(penetration, rate, impact_speed))
    }

    #[inline]
    fn evaluate_in_contact(
        &self,
        penetration: f64,
        rate: f64,
        impact_speed: f64,
        max_penetration: f64,
    ) -> ContactForce {
        dispatch!(self, law => law.evaluate_in_contact(penetration, rate, impact_speed, max_penetration))
    }
}

impl Law {
    /// Kebab-case name used in model files, the CLI and JSON output.
    pub fn name(&self) -> &'static str {
        let index = match self {
            Law::Hertz(_) => 0,
            Law::KelvinVoigt(_) => 1,
            Law::HuntCrossley(_) => 2,
            Law::HerbertMcWhannell(_) => 3,
            Law::LeeWang(_) => 4,
            Law::LankaraniNikravesh(_) => 5,
            Law::Gonthier(_) => 6,
            Law::ZhiyingQishao(_) => 7,
            Law::Flores(_) => 8,
            Law::HuGuo(_) => 9,
            Law::GharibHurmuzlu(_) => 10,
            Law::Ye(_) => 11,
            Law::CarvalhoMartins(_) => 12,
            Law::ExactRestitution(_) => 13,
            Law::Tabulated(_) => 14,
            Law::Rigid(_) => return RIGID_NAME,
        };
        LAW_NAMES[index]
    }

    /// Whether the law needs the approach speed `v_imp` of the current impact.
    pub fn uses_impact_speed(&self) -> bool {
        match self {
            Law::Hertz(_) | Law::KelvinVoigt(_) | Law::Rigid(_) => false,
            Law::HuntCrossley(hc) => matches!(hc.damping, HuntCrossleyDamping::Restitution(_)),
            _ => true,
        }
    }

    /// Hysteresis factor `χ` of the laws `K δⁿ (1 + χ δ̇/v_imp)`, `None` for the others.
    pub fn hysteresis_factor(&self) -> Option<f64> {
        match self {
            Law::Hertz(_) | Law::KelvinVoigt(_) | Law::Tabulated(_) | Law::Rigid(_) => None,
            Law::HuntCrossley(l) => l.hysteresis_factor(),
            Law::HerbertMcWhannell(l) => Some(l.hysteresis_factor()),
            Law::LeeWang(l) => Some(l.hysteresis_factor()),
            Law::LankaraniNikravesh(l) => Some(l.hysteresis_factor()),
            Law::Gonthier(l) => Some(l.hysteresis_factor()),
            Law::ZhiyingQishao(l) => Some(l.hysteresis_factor()),
            Law::Flores(l) => Some(l.hysteresis_factor()),
            Law::HuGuo(l) => Some(l.hysteresis_factor()),
            Law::GharibHurmuzlu(l) => Some(l.hysteresis_factor()),
            Law::Ye(l) => Some(l.hysteresis_factor()),
            Law::CarvalhoMartins(l) => Some(l.hysteresis_factor()),
            Law::ExactRestitution(l) => Some(l.hysteresis_factor()),
        }
    }

    /// Whether this is the massless bar (rigid wall, impulsive methods only).
    pub fn is_rigid(&self) -> bool {
        matches!(self, Law::Rigid(_))
    }

    /// Builds a law whose damping is given by a restitution `ce` from its kebab-case name
    /// (the hysteretic family, Hunt–Crossley included).
    pub fn with_restitution(
        name: &str,
        stiffness: f64,
        exponent: f64,
        restitution: f64,
    ) -> Option<Result<Law, SimError>> {
        let (k, n, ce) = (stiffness, exponent, restitution);
        Some(match name {
            "hunt-crossley" => {
                HuntCrossley::new(k, n, HuntCrossleyDamping::Restitution(ce)).map(Law::HuntCrossley)
            }
            "herbert-mcwhannell" => HerbertMcWhannell::new(k, n, ce).map(Law::HerbertMcWhannell),
            "lee-wang" => LeeWang::new(k, n, ce).map(Law::LeeWang),
            "lankarani-nikravesh" => LankaraniNikravesh::new(k, n, ce).map(Law::LankaraniNikravesh),
            "gonthier" => Gonthier::new(k, n, ce).map(Law::Gonthier),
            "zhiying-qishao" => ZhiyingQishao::new(k, n, ce).map(Law::ZhiyingQishao),
            "flores" => Flores::new(k, n, ce).map(Law::Flores),
            "hu-guo" => HuGuo::new(k, n, ce).map(Law::HuGuo),
            "gharib-hurmuzlu" => GharibHurmuzlu::new(k, n, ce).map(Law::GharibHurmuzlu),
            "ye" => Ye::new(k, n, ce).map(Law::Ye),
            "carvalho-martins" => CarvalhoMartins::new(k, n, ce).map(Law::CarvalhoMartins),
            "exact-restitution" => ExactRestitution::new(k, n, ce).map(Law::ExactRestitution),
            _ => return None,
        })
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

    fn tabulated() -> Tabulated {
        // Hertz-like loading through 12 points, unloading at 40 % of it.
        let x: Vec<f64> = (0..12).map(|i| i as f64 * 1e-5).collect();
        let f: Vec<f64> = x.iter().map(|d| 2.0e9 * d.powf(1.5)).collect();
        let g: Vec<f64> = f.iter().map(|v| 0.4 * v).collect();
        Tabulated::new(x.clone(), f, x, g, 0.05).unwrap()
    }

    fn all_laws() -> Vec<Law> {
        let k = 2.0e9;
        let mut laws = vec![
            Law::Hertz(Hertz::new(k, 1.5).unwrap()),
            Law::KelvinVoigt(KelvinVoigt::new(4.0e7, 3.0e3).unwrap()),
            Law::HuntCrossley(
                HuntCrossley::new(k, 1.5, HuntCrossleyDamping::Coefficient(1.0e9)).unwrap(),
            ),
            Law::Tabulated(tabulated()),
        ];
        for (i, name) in LAW_NAMES.iter().enumerate() {
            let ce = 0.15 + 0.06 * i as f64;
            let n = if i % 2 == 0 { 1.5 } else { 1.3 };
            if let Some(law) = Law::with_restitution(name, k, n, ce) {
                laws.push(law.unwrap());
            }
        }
        laws
    }

    #[test]
    fn every_name_has_a_law() {
        let laws = all_laws();
        for name in LAW_NAMES {
            assert!(laws.iter().any(|l| l.name() == name), "{name}");
        }
    }

    /// Tiny deterministic generator (no dev-dependency): uniform in [0, 1).
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// Analytic derivatives equal central finite differences at random states
    /// (δ log-uniform in [1e-8, 1e-4] m, δ̇ in [−1, 1] m/s, v_imp in [0.01, 3] m/s).
    #[test]
    fn derivatives_match_finite_differences() {
        let mut rng = Lcg(42);
        let knots: Vec<f64> = (0..12).map(|i| i as f64 * 1e-5).collect();
        for law in all_laws() {
            let mut checked = 0;
            while checked < 400 {
                let pen = 10f64.powf(-8.0 + 4.0 * rng.next());
                let rate = 2.0 * rng.next() - 1.0;
                let v_imp = 0.01 + 3.0 * rng.next();
                let hp = pen * 1e-6;
                let hr = 1e-7 * v_imp;
                // The tabulated curves have kinks at their points and the reversal band edges.
                if let Law::Tabulated(t) = &law {
                    let w = t.reversal_band * v_imp;
                    if knots.iter().any(|k| (pen - k).abs() < 2.0 * hp)
                        || rate.abs() < 2.0 * hr
                        || (rate + w).abs() < 2.0 * hr
                    {
                        continue;
                    }
                }
                checked += 1;
                let f = law.evaluate(pen, rate, v_imp);
                let fd_pen = (law.evaluate(pen + hp, rate, v_imp).force
                    - law.evaluate(pen - hp, rate, v_imp).force)
                    / (2.0 * hp);
                let fd_rate = (law.evaluate(pen, rate + hr, v_imp).force
                    - law.evaluate(pen, rate - hr, v_imp).force)
                    / (2.0 * hr);
                let scale_p = f.d_penetration.abs() + f.force.abs() / pen;
                let scale_r = f.d_rate.abs() + f.force.abs() / v_imp;
                assert!(
                    (f.d_penetration - fd_pen).abs() <= 1e-6 * scale_p,
                    "{}: dF/dδ {} vs {fd_pen} at δ = {pen}, δ̇ = {rate}, v = {v_imp}",
                    law.name(),
                    f.d_penetration
                );
                assert!(
                    (f.d_rate - fd_rate).abs() <= 1e-6 * scale_r,
                    "{}: dF/dδ̇ {} vs {fd_rate} at δ = {pen}, δ̇ = {rate}, v = {v_imp}",
                    law.name(),
                    f.d_rate
                );
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
        for name in LAW_NAMES {
            if let Some(r) = Law::with_restitution(name, 1e9, 1.5, 0.0) {
                let msg = r.unwrap_err().to_string();
                assert!(
                    msg.starts_with(&format!("{name}: restitution = 0")),
                    "{msg}"
                );
                assert!(!msg.contains('\n'));
            }
            if let Some(r) = Law::with_restitution(name, 1e9, 1.5, f64::NAN) {
                assert!(r.is_err(), "{name}");
            }
        }
    }
}
