//! Hertzian laws with hysteresis damping, `F = K δⁿ (1 + χ δ̇ / v_imp)` (paper eqs. 5–13).
//! They differ only in how the hysteresis factor `χ` follows from the restitution `ce`.

use super::hertz::power_law;
use super::{
    check_exponent, check_restitution, check_stiffness, ContactForce, ContactLaw, MIN_IMPACT_SPEED,
};
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

macro_rules! hysteresis_law {
    ($(#[$doc:meta])* $name:ident, $label:literal, |$ce:ident| $factor:expr) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, PartialEq)]
        pub struct $name {
            /// Contact stiffness `K`, N/mⁿ.
            pub stiffness: f64,
            /// Exponent `n` (1.5 for point contact).
            pub exponent: f64,
            /// Coefficient of restitution `ce`, 0 < ce ≤ 1.
            pub restitution: f64,
            factor: f64,
        }

        impl $name {
            pub fn new(stiffness: f64, exponent: f64, restitution: f64) -> Result<Self, SimError> {
                check_stiffness($label, stiffness)?;
                check_exponent($label, exponent)?;
                check_restitution($label, restitution)?;
                let $ce = restitution;
                Ok(Self { stiffness, exponent, restitution, factor: $factor })
            }

            /// Hysteresis factor `χ` in `F = K δⁿ (1 + χ δ̇ / v_imp)`.
            pub fn hysteresis_factor(&self) -> f64 {
                self.factor
            }
        }

        impl ContactLaw for $name {
            #[inline]
            fn evaluate(&self, penetration: f64, rate: f64, impact_speed: f64) -> ContactForce {
                hysteretic_force(self.stiffness, self.exponent, self.factor, penetration, rate, impact_speed)
            }
        }
    };
}

hysteresis_law!(
    /// Lankarani–Nikravesh (1990, J. Mech. Des. 112:369), paper eq. 8:
    /// `F = K δⁿ [1 + 3(1 − ce²)/4 · δ̇/v_imp]`. Derived for ce close to 1.
    LankaraniNikravesh, "lankarani-nikravesh", |ce| 0.75 * (1.0 - ce * ce)
);

hysteresis_law!(
    /// Gonthier, McPhee, Lange & Piedbœuf (2004, Multibody Syst. Dyn. 11:209), paper eq. 9:
    /// `F = K δⁿ [1 + (1 − ce²)/ce · δ̇/v_imp]` (the paper's eq. 9 prints `ce²` in the
    /// denominator; its Table 2 and Gonthier et al. have `ce`, which is used here).
    Gonthier, "gonthier", |ce| (1.0 - ce * ce) / ce
);

hysteresis_law!(
    /// Flores, Machado, Silva & Martins (2011, Multibody Syst. Dyn. 25:357), paper eq. 13:
    /// `F = K δⁿ [1 + 8(1 − ce)/(5 ce) · δ̇/v_imp]`. Valid over the whole range of ce.
    Flores, "flores", |ce| 1.6 * (1.0 - ce) / ce
);

/// How the Hunt–Crossley damping is given.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum HuntCrossleyDamping {
    /// Damping coefficient `b` in `F = K δⁿ + b δⁿ δ̇`, N·s/mⁿ⁺¹.
    Coefficient(f64),
    /// Restitution `ce`, with `b = 3K(1 − ce)/(2 v_imp)` (paper eq. 6).
    Restitution(f64),
}

/// Hunt–Crossley (1975, J. Appl. Mech. 42:440), paper eqs. 5–6: `F = K δⁿ + b δⁿ δ̇`.
/// With a restitution, `b = 3K(1 − ce)/(2 v_imp)`, i.e. `χ = 3(1 − ce)/2`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HuntCrossley {
    /// Contact stiffness `K`, N/mⁿ.
    pub stiffness: f64,
    /// Exponent `n`.
    pub exponent: f64,
    /// Damping coefficient or restitution.
    pub damping: HuntCrossleyDamping,
}

impl HuntCrossley {
    pub fn new(
        stiffness: f64,
        exponent: f64,
        damping: HuntCrossleyDamping,
    ) -> Result<Self, SimError> {
        check_stiffness("hunt-crossley", stiffness)?;
        check_exponent("hunt-crossley", exponent)?;
        match damping {
            HuntCrossleyDamping::Coefficient(b) if !(b.is_finite() && b >= 0.0) => {
                return invalid(format!(
                    "hunt-crossley: damping = {b} is not valid; expected a finite value >= 0"
                ))
            }
            HuntCrossleyDamping::Restitution(ce) => check_restitution("hunt-crossley", ce)?,
            _ => {}
        }
        Ok(Self {
            stiffness,
            exponent,
            damping,
        })
    }
}

impl ContactLaw for HuntCrossley {
    #[inline]
    fn evaluate(&self, penetration: f64, rate: f64, impact_speed: f64) -> ContactForce {
        match self.damping {
            HuntCrossleyDamping::Restitution(ce) => hysteretic_force(
                self.stiffness,
                self.exponent,
                1.5 * (1.0 - ce),
                penetration,
                rate,
                impact_speed,
            ),
            // K δⁿ + b δⁿ δ̇ = K δⁿ (1 + (b/K) δ̇).
            HuntCrossleyDamping::Coefficient(b) => with_damping(
                power_law(self.stiffness, self.exponent, penetration),
                b / self.stiffness,
                rate,
            ),
        }
    }
}

impl HuntCrossley {
    /// Restitution-parameterised law's factor, or `None` for a given coefficient.
    pub fn hysteresis_factor(&self) -> Option<f64> {
        match self.damping {
            HuntCrossleyDamping::Restitution(ce) => Some(1.5 * (1.0 - ce)),
            HuntCrossleyDamping::Coefficient(_) => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn factors_follow_the_papers() {
        let ce = 0.5;
        let ln = LankaraniNikravesh::new(1e9, 1.5, ce).unwrap();
        assert!((ln.hysteresis_factor() - 0.5625).abs() < 1e-15);
        let g = Gonthier::new(1e9, 1.5, ce).unwrap();
        assert!((g.hysteresis_factor() - 1.5).abs() < 1e-15);
        let f = Flores::new(1e9, 1.5, ce).unwrap();
        assert!((f.hysteresis_factor() - 1.6).abs() < 1e-15);
        let hc = HuntCrossley::new(1e9, 1.5, HuntCrossleyDamping::Restitution(ce)).unwrap();
        assert!((hc.hysteresis_factor().unwrap() - 0.75).abs() < 1e-15);
    }
}
