use super::{check_exponent, check_stiffness, ContactForce, ContactLaw};
use crate::error::SimError;

/// Hertz contact, `F = K δⁿ` (Hertz 1882; paper eq. 3). Elastic: no energy is lost.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hertz {
    /// Contact stiffness `K`, N/mⁿ.
    pub stiffness: f64,
    /// Exponent `n` (1.5 for point contact).
    pub exponent: f64,
}

impl Hertz {
    pub fn new(stiffness: f64, exponent: f64) -> Result<Self, SimError> {
        check_stiffness("hertz", stiffness)?;
        check_exponent("hertz", exponent)?;
        Ok(Self {
            stiffness,
            exponent,
        })
    }
}

/// `K δⁿ` and its derivative: the elastic backbone shared by the Hertzian laws.
#[inline]
pub(crate) fn power_law(stiffness: f64, exponent: f64, penetration: f64) -> (f64, f64) {
    let pow_nm1 = penetration.powf(exponent - 1.0);
    let force = stiffness * pow_nm1 * penetration;
    (force, stiffness * exponent * pow_nm1)
}

#[inline]
pub(crate) fn power_law_energy(stiffness: f64, exponent: f64, penetration: f64) -> f64 {
    if penetration <= 0.0 {
        return 0.0;
    }
    stiffness * penetration.powf(exponent + 1.0) / (exponent + 1.0)
}

impl ContactLaw for Hertz {
    #[inline]
    fn evaluate(&self, penetration: f64, _rate: f64, _impact_speed: f64) -> ContactForce {
        let (force, d_penetration) = power_law(self.stiffness, self.exponent, penetration);
        ContactForce {
            force,
            d_penetration,
            d_rate: 0.0,
        }
    }
    fn elastic_force(&self, penetration: f64) -> f64 {
        if penetration <= 0.0 {
            return 0.0;
        }
        power_law(self.stiffness, self.exponent, penetration).0
    }
    fn elastic_energy(&self, penetration: f64) -> f64 {
        power_law_energy(self.stiffness, self.exponent, penetration)
    }
}
