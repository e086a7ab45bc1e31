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

/// `K δⁿ` with its derivative and potential `K δⁿ⁺¹/(n+1)`: the elastic backbone shared by
/// the Hertzian laws, for `δ > 0` (one `powf`; a square root for Hertz's n = 3/2).
#[inline]
pub(crate) fn power_law(stiffness: f64, exponent: f64, penetration: f64) -> ContactForce {
    let pow_nm1 = if exponent == 1.5 {
        penetration.sqrt()
    } else {
        penetration.powf(exponent - 1.0)
    };
    let force = stiffness * pow_nm1 * penetration;
    ContactForce {
        force,
        d_penetration: stiffness * exponent * pow_nm1,
        d_rate: 0.0,
        elastic: force,
        potential: force * penetration / (exponent + 1.0),
    }
}

impl ContactLaw for Hertz {
    #[inline]
    fn evaluate(&self, penetration: f64, _rate: f64, _impact_speed: f64) -> ContactForce {
        power_law(self.stiffness, self.exponent, penetration)
    }
}
