//! Hertzian laws with hysteresis damping, `F = K δⁿ (1 + χ δ̇ / v_imp)` (paper eqs. 5–13;
//! the reviews of Machado et al. 2012, Skrinjar et al. 2018 and Corral et al. 2021).
//!
//! They differ only in how the hysteresis damping factor `χ` follows from the restitution
//! `ce` (their relations are data: [`Family::Hysteretic`] entries of the catalog); the damping coefficient is `D = χ K / v_imp` in `F = K δⁿ + D δⁿ δ̇`. For one impact
//! of a free mass on a rigid wall the effective restitution `e` of such a law depends on `χ`
//! alone (not on `K`, `n`, the mass or `v_imp`): integrating `m v dv/dδ = −K δⁿ (1 + χ v/v_imp)`
//! over the compression and the restitution phase gives
//! `χ − ln(1 + χ) = −χ e − ln(1 − χ e)` (see [`exact_hysteresis_factor`]).

use super::catalog::{check_parameter, law_entry, Family, LawEntry};
use super::hertz::power_law;
use super::{ContactForce, ContactLaw, MIN_IMPACT_SPEED};
use crate::error::{invalid, SimError};

/// `K δⁿ (1 + χ δ̇ / v_imp)` and its derivatives.
#[inline]
fn hysteretic_force(
    stiffness: f64,
    exponent: f64,
    factor: f64,
    penetration: f64,
    rate: f64,
    impact_speed: f64,
) -> ContactForce {
    let c = factor / impact_speed.max(MIN_IMPACT_SPEED);
    with_damping(power_law(stiffness, exponent, penetration), c, rate)
}

/// `F_el (1 + c δ̇)` and its derivatives, from the elastic backbone `F_el`.
#[inline]
fn with_damping(elastic: ContactForce, c: f64, rate: f64) -> ContactForce {
    let damping = 1.0 + c * rate;
    ContactForce {
        force: elastic.force * damping,
        d_penetration: elastic.d_penetration * damping,
        d_rate: elastic.force * c,
        ..elastic
    }
}

/// The effective restitution `e` of one impact on a rigid wall of a law with hysteresis
/// factor `χ`: the root in `[0, 1/χ)` of `χ − ln(1 + χ) = −χ e − ln(1 − χ e)` (1 for `χ = 0`).
pub fn restitution_of_factor(factor: f64) -> f64 {
    if factor.is_nan() || factor <= 0.0 {
        return 1.0;
    }
    let target = factor - factor.ln_1p();
    // g(e) = −χe − ln(1 − χe) − target grows from −target at e = 0 to +∞ at e = 1/χ.
    let g = |e: f64| -factor * e - (-factor * e).ln_1p() - target;
    let (mut lo, mut hi) = (0.0, (1.0 / factor).min(1.0));
    if g(hi) <= 0.0 {
        return hi;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if g(mid) > 0.0 {
            hi = mid;
        } else {
            lo = mid;
        }
        if hi - lo <= 1e-16 * hi.max(1e-300) {
            break;
        }
    }
    0.5 * (lo + hi)
}

/// The hysteresis factor `χ` for which one impact of a Hunt–Crossley-form law restitutes
/// exactly `ce`: the root of `χ − ln(1 + χ) = −χ ce − ln(1 − χ ce)` in `(0, 1/ce)` (0 for
/// `ce = 1`). Solved by bisection once, when the law is built.
pub fn exact_hysteresis_factor(ce: f64) -> f64 {
    if ce >= 1.0 {
        return 0.0;
    }
    // h(χ) = χ − ln(1 + χ) + χ ce + ln(1 − χ ce): positive for small χ, → −∞ at χ → 1/ce.
    let h = |chi: f64| chi - chi.ln_1p() + chi * ce + (-chi * ce).ln_1p();
    let (mut lo, mut hi) = (0.0_f64, 1.0 / ce);
    // A lower bound with h > 0 keeps the bisection away from the root at χ = 0.
    let mut probe = 1.5 * (1.0 - ce);
    while h(probe) <= 0.0 && probe > 1e-300 {
        probe *= 0.5;
    }
    lo = lo.max(probe.min(hi));
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if h(mid) > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-15 * hi {
            break;
        }
    }
    0.5 * (lo + hi)
}

/// A law `K δⁿ (1 + χ δ̇ / v_imp)` of the catalog whose factor `χ` follows from a restitution
/// `ce` by its relation ([`Family::Hysteretic`]; which laws, their sources and relations:
/// [`LAWS`](super::LAWS)). `χ` is evaluated once, when the law is built.
#[derive(Clone, Copy, PartialEq)]
pub struct Hysteretic {
    /// Its entry in the catalog (name, source, relation).
    pub law: &'static LawEntry,
    /// Contact stiffness `K`, N/mⁿ.
    pub stiffness: f64,
    /// Exponent `n` (1.5 for point contact).
    pub exponent: f64,
    /// Coefficient of restitution `ce`, 0 < ce ≤ 1.
    pub restitution: f64,
    factor: f64,
}

impl Hysteretic {
    /// The hysteretic law called `name` (`"lankarani-nikravesh"`, ...).
    pub fn new(
        name: &str,
        stiffness: f64,
        exponent: f64,
        restitution: f64,
    ) -> Result<Self, SimError> {
        match law_entry(name) {
            Some(law) if matches!(law.family, Family::Hysteretic(_)) => {
                Self::build(law, stiffness, exponent, restitution)
            }
            _ => invalid(format!("'{name}' is not a hysteretic contact law")),
        }
    }

    pub(crate) fn build(
        law: &'static LawEntry,
        stiffness: f64,
        exponent: f64,
        restitution: f64,
    ) -> Result<Self, SimError> {
        let Family::Hysteretic(relation) = law.family else {
            return invalid(format!("'{}' is not a hysteretic contact law", law.name));
        };
        check_parameter(law.name, "stiffness", stiffness)?;
        check_parameter(law.name, "exponent", exponent)?;
        check_parameter(law.name, "restitution", restitution)?;
        Ok(Self {
            law,
            stiffness,
            exponent,
            restitution,
            factor: relation(restitution),
        })
    }

    /// Hysteresis factor `χ` in `F = K δⁿ (1 + χ δ̇ / v_imp)`.
    pub fn hysteresis_factor(&self) -> f64 {
        self.factor
    }
}

impl std::fmt::Debug for Hysteretic {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Hysteretic")
            .field("law", &self.law.name)
            .field("stiffness", &self.stiffness)
            .field("exponent", &self.exponent)
            .field("restitution", &self.restitution)
            .field("factor", &self.factor)
            .finish()
    }
}

impl ContactLaw for Hysteretic {
    #[inline]
    fn evaluate(&self, penetration: f64, rate: f64, impact_speed: f64) -> ContactForce {
        hysteretic_force(
            self.stiffness,
            self.exponent,
            self.factor,
            penetration,
            rate,
            impact_speed,
        )
    }
}

/// Hunt–Crossley (1975, J. Appl. Mech. 42:440), paper eq. 5, with its damping coefficient
/// given: `F = K δⁿ + b δⁿ δ̇`, independent of `v_imp`. With a restitution instead it is the
/// [`Hysteretic`] law `hunt-crossley` of the catalog, `χ = 3(1 − ce)/2` (paper eq. 6).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HuntCrossley {
    /// Contact stiffness `K`, N/mⁿ.
    pub stiffness: f64,
    /// Exponent `n`.
    pub exponent: f64,
    /// Damping coefficient `b`, N·s/mⁿ⁺¹.
    pub damping: f64,
}

impl HuntCrossley {
    pub fn new(stiffness: f64, exponent: f64, damping: f64) -> Result<Self, SimError> {
        check_parameter("hunt-crossley", "stiffness", stiffness)?;
        check_parameter("hunt-crossley", "exponent", exponent)?;
        check_parameter("hunt-crossley", "damping", damping)?;
        Ok(Self {
            stiffness,
            exponent,
            damping,
        })
    }
}

impl ContactLaw for HuntCrossley {
    #[inline]
    fn evaluate(&self, penetration: f64, rate: f64, _impact_speed: f64) -> ContactForce {
        // K δⁿ + b δⁿ δ̇ = K δⁿ (1 + (b/K) δ̇).
        with_damping(
            power_law(self.stiffness, self.exponent, penetration),
            self.damping / self.stiffness,
            rate,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn factor(name: &str, ce: f64) -> f64 {
        Hysteretic::new(name, 1e9, 1.5, ce)
            .unwrap()
            .hysteresis_factor()
    }

    #[test]
    fn factors_follow_the_papers() {
        let ce = 0.5;
        let expected = [
            ("hunt-crossley", 0.75),
            ("herbert-mcwhannell", 1.0),
            ("lee-wang", 0.375),
            ("lankarani-nikravesh", 0.5625),
            ("gonthier", 1.5),
            ("zhiying-qishao", 0.5625 * 1f64.exp()),
            ("flores", 1.6),
            ("hu-guo", 1.5),
            ("gharib-hurmuzlu", 1.0),
            ("ye", 1.6),
            ("carvalho-martins", 0.75 * 10.5 / 5.5),
            ("exact-restitution", exact_hysteresis_factor(ce)),
        ];
        for (name, chi) in expected {
            assert!((factor(name, ce) - chi).abs() < 1e-15, "{name}");
        }
        // every hysteretic law of the catalog is checked above
        let hysteretic = super::super::LAWS
            .iter()
            .filter(|e| matches!(e.family, Family::Hysteretic(_)));
        assert_eq!(hysteretic.count(), expected.len());
        assert!(Hysteretic::new("hertz", 1e9, 1.5, ce).is_err());
    }

    /// Carvalho–Martins and Gonthier coincide at ce = 1/3 (Carvalho & Martins 2019).
    #[test]
    fn carvalho_martins_meets_gonthier_at_one_third() {
        let ce = 1.0 / 3.0;
        assert!((factor("carvalho-martins", ce) - factor("gonthier", ce)).abs() < 1e-14);
    }

    /// Hu–Guo's `3(1 − ce)/(2 ce)` tends to the exact relation as ce → 1 (the `4 ce` variant
    /// would tend to half of it); Gharib–Hurmuzlu's restitutes `ce/(1 − ce)` for small ce.
    #[test]
    fn hu_guo_and_gharib_hurmuzlu_limits() {
        for &ce in &[0.999, 0.9999] {
            let ratio = factor("hu-guo", ce) / exact_hysteresis_factor(ce);
            assert!((ratio - 1.0).abs() < 5.0 * (1.0 - ce), "{ce}: {ratio}");
        }
        for &ce in &[0.01, 0.05, 0.1] {
            let e = restitution_of_factor(factor("gharib-hurmuzlu", ce));
            assert!((e / (ce / (1.0 - ce)) - 1.0).abs() < 1e-3, "{ce}: {e}");
        }
    }

    /// The exact factor and the restitution it gives are inverse functions.
    #[test]
    fn exact_factor_inverts_restitution() {
        for &ce in &[0.01, 0.1, 0.3, 0.5, 0.7, 0.9, 0.99, 0.999_999] {
            let chi = exact_hysteresis_factor(ce);
            assert!(chi > 0.0 && chi * ce < 1.0, "{ce}: {chi}");
            let e = restitution_of_factor(chi);
            assert!((e - ce).abs() < 1e-9, "{ce}: {chi} -> {e}");
        }
        assert_eq!(exact_hysteresis_factor(1.0), 0.0);
        assert_eq!(restitution_of_factor(0.0), 1.0);
        // Near ce = 1 the relation tends to Hunt–Crossley's χ ≈ 3(1 − ce)/2.
        let ce = 0.999;
        assert!((exact_hysteresis_factor(ce) / (1.5 * (1.0 - ce)) - 1.0).abs() < 2e-3);
    }
}
