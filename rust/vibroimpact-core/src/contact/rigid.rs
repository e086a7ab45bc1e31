use super::catalog::check_parameter;
use super::{ContactForce, ContactLaw};
use crate::error::SimError;

/// The massless bar (paper Fig. 1a; docs/rigid-impacts.md): a rigid wall with Newton's restitution
/// law `δ̇⁺ = −e δ̇⁻`, applied as an instantaneous velocity jump through the generalized
/// impulse. It has no force–indentation relation: only the impulsive methods
/// (`Method::EventDriven`, `Method::MoreauJean`) accept it, and every compliant integrator
/// refuses it when the run is set up, so [`ContactLaw::evaluate`] is never used in a run
/// (it returns zero force).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rigid {
    /// Newton's coefficient of restitution `e`, `0 ≤ e ≤ 1` (0: plastic impact).
    pub restitution: f64,
}

impl Rigid {
    pub fn new(restitution: f64) -> Result<Self, SimError> {
        check_parameter("rigid", "restitution", restitution)?;
        Ok(Self { restitution })
    }
}

impl ContactLaw for Rigid {
    #[inline]
    fn evaluate(&self, _penetration: f64, _rate: f64, _impact_speed: f64) -> ContactForce {
        ContactForce::default()
    }
}
