use super::catalog::check_parameter;
use super::{ContactForce, ContactLaw};
use crate::error::SimError;

/// Linear spring–dashpot (Kelvin–Voigt), `F = k δ + c δ̇` while in contact: the paper's
/// spring–damping description of a clearance (Fig. 1b). The force is clamped at zero
/// near separation, where `c δ̇` would pull the bodies together.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KelvinVoigt {
    /// Spring stiffness `k`, N/m.
    pub stiffness: f64,
    /// Dashpot coefficient `c`, N·s/m.
    pub damping: f64,
}

impl KelvinVoigt {
    pub fn new(stiffness: f64, damping: f64) -> Result<Self, SimError> {
        check_parameter("kelvin-voigt", "stiffness", stiffness)?;
        check_parameter("kelvin-voigt", "damping", damping)?;
        Ok(Self { stiffness, damping })
    }
}

impl ContactLaw for KelvinVoigt {
    #[inline]
    fn evaluate(&self, penetration: f64, rate: f64, _impact_speed: f64) -> ContactForce {
        let elastic = self.stiffness * penetration;
        ContactForce {
            force: elastic + self.damping * rate,
            d_penetration: self.stiffness,
            d_rate: self.damping,
            elastic,
            potential: 0.5 * elastic * penetration,
        }
    }
}
