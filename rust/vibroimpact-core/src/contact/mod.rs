//! Contact-force laws `F(δ, δ̇, v_imp)` (paper §2.2, Table 2; docs/contact-laws.md).
//!
//! Every law gives the force and its two partial derivatives, which Newton uses as the
//! consistent tangent. A law sees only its own parameters, never the system. Laws are
//! evaluated only while the gap is closed (`δ > 0`); the force is never tensile: a damped
//! law whose formula goes negative near separation is clamped to zero (with zero tangent).
//!
//! Families, one file each: [`Hertz`] (elastic); [`KelvinVoigt`] (linear spring–dashpot);
//! the Hertzian laws with hysteresis damping `K δⁿ (1 + χ δ̇/v_imp)` in `hysteretic`
//! ([`Hysteretic`], one type for all: each law is its relation `χ(ce)`, an entry of the
//! catalog [`LAWS`]; [`HuntCrossley`] with a given damping coefficient); [`Tabulated`]
//! loading/unloading curves; and the massless bar [`Rigid`]. The catalog (`catalog`) names
//! every law with its parameters, defaults and source. Stiffness from geometry and material is
//! in `geometry`.

mod catalog;
mod geometry;
mod hertz;
mod hysteretic;
mod kelvin_voigt;
mod rigid;
mod tabulated;

pub use catalog::{
    alternatives_fault, force_law_names, law_entry, Family, LawEntry, Parameter, ParameterValue,
    ParameterValues, Requirement, ValueKind, LAWS, ONE_OF_RESTITUTION_OR_DAMPING, RIGID,
};
pub use geometry::{
    combined_modulus, johnson_cylinder_in_hole_approach, ContactGeometry, Material,
};
pub(crate) use hertz::power_law;
pub use hertz::Hertz;
pub use hysteretic::{exact_hysteresis_factor, restitution_of_factor, HuntCrossley, Hysteretic};
pub use kelvin_voigt::KelvinVoigt;
pub use rigid::Rigid;
pub use tabulated::{curve_fault, Curve, Tabulated};

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

/// The library of laws, as plain data (enum dispatch keeps the time loop free of virtual calls);
/// which laws there are, with their names and parameters: [`LAWS`].
#[derive(Debug, Clone, PartialEq)]
pub enum Law {
    Hertz(Hertz),
    KelvinVoigt(KelvinVoigt),
    /// Every law `K δⁿ (1 + χ(ce) δ̇/v_imp)` ([`Family::Hysteretic`]).
    Hysteretic(Hysteretic),
    /// Hunt–Crossley with a given damping coefficient (with a restitution it is
    /// [`Law::Hysteretic`]).
    HuntCrossley(HuntCrossley),
    Tabulated(Tabulated),
    /// The massless bar: impulsive methods only (not a force law).
    Rigid(Rigid),
}

macro_rules! dispatch {
    ($self:ident, $law:ident => $body:expr) => {
        match $self {
            Law::Hertz($law) => $body,
            Law::KelvinVoigt($law) => $body,
            Law::Hysteretic($law) => $body,
            Law::HuntCrossley($law) => $body,
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
    /// Its entry in the catalog [`LAWS`].
    pub fn entry(&self) -> &'static LawEntry {
        let family = |f: fn(&Family) -> bool| {
            LAWS.iter()
                .find(|e| f(&e.family))
                .expect("every family has a law in the catalog")
        };
        match self {
            Law::Hertz(_) => family(|f| matches!(f, Family::Elastic)),
            Law::KelvinVoigt(_) => family(|f| matches!(f, Family::SpringDashpot)),
            Law::Hysteretic(law) => law.law,
            Law::HuntCrossley(_) => {
                law_entry("hunt-crossley").expect("hunt-crossley is in the catalog")
            }
            Law::Tabulated(_) => family(|f| matches!(f, Family::Tabulated)),
            Law::Rigid(_) => &RIGID,
        }
    }

    /// Kebab-case name used in model files, the CLI and JSON output.
    pub fn name(&self) -> &'static str {
        self.entry().name
    }

    /// Whether the law needs the approach speed `v_imp` of the current impact.
    pub fn uses_impact_speed(&self) -> bool {
        matches!(self, Law::Hysteretic(_) | Law::Tabulated(_))
    }

    /// Hysteresis factor `χ` of the laws `K δⁿ (1 + χ δ̇/v_imp)`, `None` for the others.
    pub fn hysteresis_factor(&self) -> Option<f64> {
        match self {
            Law::Hysteretic(law) => Some(law.hysteresis_factor()),
            _ => None,
        }
    }

    /// Whether this is the massless bar (rigid wall, impulsive methods only).
    pub fn is_rigid(&self) -> bool {
        matches!(self, Law::Rigid(_))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Hertz-like loading through 12 points, unloading at 40 % of it.
    fn curves() -> [Vec<f64>; 4] {
        let x: Vec<f64> = (0..12).map(|i| i as f64 * 1e-5).collect();
        let f: Vec<f64> = x.iter().map(|d| 2.0e9 * d.powf(1.5)).collect();
        let g: Vec<f64> = f.iter().map(|v| 0.4 * v).collect();
        [x.clone(), f, x, g]
    }

    fn tabulated() -> Tabulated {
        let [x, f, ux, g] = curves();
        Tabulated::new(x, f, ux, g, 0.05).unwrap()
    }

    fn all_laws() -> Vec<Law> {
        let k = 2.0e9;
        let mut laws = vec![
            Law::Hertz(Hertz::new(k, 1.5).unwrap()),
            Law::KelvinVoigt(KelvinVoigt::new(4.0e7, 3.0e3).unwrap()),
            Law::HuntCrossley(HuntCrossley::new(k, 1.5, 1.0e9).unwrap()),
            Law::Tabulated(tabulated()),
        ];
        for (i, entry) in LAWS.iter().enumerate() {
            if let Family::Hysteretic(_) = entry.family {
                let ce = 0.15 + 0.06 * i as f64;
                let n = if i % 2 == 0 { 1.5 } else { 1.3 };
                laws.push(Law::Hysteretic(
                    Hysteretic::new(entry.name, k, n, ce).unwrap(),
                ));
            }
        }
        laws
    }

    #[test]
    fn every_force_law_of_the_catalog_is_tested_and_named_back() {
        let laws = all_laws();
        for name in force_law_names() {
            assert!(laws.iter().any(|l| l.name() == name), "{name}");
        }
        assert_eq!(Law::Rigid(Rigid::new(0.5).unwrap()).name(), "rigid");
        for name_of in [|e: &LawEntry| e.name, |e: &LawEntry| e.class_name] {
            let names: Vec<_> = LAWS.iter().map(name_of).collect();
            let mut unique = names.clone();
            unique.sort_unstable();
            unique.dedup();
            assert_eq!(unique.len(), names.len(), "unique: {names:?}");
        }
    }

    /// What a spec gives is what the law's own constructor builds; a parameter left out takes
    /// the catalog's default.
    #[test]
    fn laws_are_built_from_their_parameters() {
        let mut v = ParameterValues::default();
        v.set("stiffness", ParameterValue::Number(2e9));
        v.set("restitution", ParameterValue::Number(0.7));
        let built = Law::from_parameters("flores", &v).unwrap();
        let direct = Hysteretic::new("flores", 2e9, 1.5, 0.7).unwrap();
        assert_eq!(built, Law::Hysteretic(direct));
        assert_eq!(built.hysteresis_factor(), Some(1.6 * (1.0 - 0.7) / 0.7));
        v.set("exponent", ParameterValue::Number(1.3));
        assert_eq!(
            Law::from_parameters("hunt-crossley", &v).unwrap(),
            Law::Hysteretic(Hysteretic::new("hunt-crossley", 2e9, 1.3, 0.7).unwrap())
        );
        v.set("damping", ParameterValue::Number(5.0));
        let both = Law::from_parameters("hunt-crossley", &v)
            .unwrap_err()
            .to_string();
        assert_eq!(
            both,
            "hunt-crossley: damping is not valid; expected exactly one of restitution or damping"
        );
        let mut b = ParameterValues::default();
        b.set("stiffness", ParameterValue::Number(2e9));
        b.set("damping", ParameterValue::Number(5.0));
        assert_eq!(
            Law::from_parameters("hunt-crossley", &b).unwrap(),
            Law::HuntCrossley(HuntCrossley::new(2e9, 1.5, 5.0).unwrap())
        );
        let msg = Law::from_parameters("gonthier", &b)
            .unwrap_err()
            .to_string();
        assert!(msg.starts_with("gonthier: restitution is missing"), "{msg}");
        let names = [
            "loading_penetration",
            "loading_force",
            "unloading_penetration",
            "unloading_force",
        ];
        let mut c = ParameterValues::default();
        for (name, values) in names.into_iter().zip(curves()) {
            c.set(name, ParameterValue::Numbers(values));
        }
        let [x, f, ux, g] = curves();
        assert_eq!(
            Law::from_parameters("tabulated", &c).unwrap(),
            Law::Tabulated(Tabulated::new(x, f, ux, g, 0.01).unwrap())
        );
        assert!(Law::from_parameters("bogus", &c).is_err());
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
        assert!(KelvinVoigt::new(1e9, -2.0).is_err());
        assert!(HuntCrossley::new(1e9, 1.5, -1.0).is_err());
        for law in LAWS {
            if let Family::Hysteretic(_) = law.family {
                let msg = Hysteretic::new(law.name, 1e9, 1.5, 0.0)
                    .unwrap_err()
                    .to_string();
                let name = law.name;
                assert!(
                    msg.starts_with(&format!("{name}: restitution = 0")),
                    "{msg}"
                );
                assert!(!msg.contains('\n'));
                assert!(Hysteretic::new(name, 1e9, 1.5, 1.2).is_err(), "{name}");
                assert!(Hysteretic::new(name, 1e9, 1.5, f64::NAN).is_err(), "{name}");
            }
        }
    }
}
