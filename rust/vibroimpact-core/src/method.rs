//! Which integrator advances a run: its settings and the laws it takes. Its name (Python's
//! `integrator`, the model file's `solver.method`, a spec's `kind`) is its catalog entry's
//! (`crate::method_catalog`).

use crate::error::{invalid, SimError};
use crate::impulsive::{EventDriven, MoreauJean};
use crate::integrators::{Bathe, NewmarkFamily, PreciseIntegration};
use crate::method_catalog;
use crate::system::System;

/// Which integrator advances the run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Method {
    /// Newmark-β with Newton on the gap forces (`α_m = α_f = 0`).
    Newmark(NewmarkFamily),
    /// Generalized-α (Chung & Hulbert 1993): the Newmark family's step with `α_m`, `α_f` from
    /// the spectral radius at infinity.
    GeneralizedAlpha(NewmarkFamily),
    /// HHT-α (Hilber, Hughes & Taylor 1977): the Newmark family's step with `α_m = 0`.
    Hht(NewmarkFamily),
    /// Precise integration with the Adams treatment of the gap forces (paper eqs. 32–43).
    Precise(PreciseIntegration),
    /// Bathe's composite trapezoidal / three-point backward scheme with Newton on the gaps.
    Bathe(Bathe),
    /// Rigid gaps only: event-driven impacts with Newton's restitution law
    /// (`crate::impulsive`, docs/rigid-impacts.md).
    EventDriven(EventDriven),
    /// Rigid gaps only: Moreau–Jean θ-method time stepping with one LCP per step.
    MoreauJean(MoreauJean),
    /// Explicit Runge–Kutta DOP853 with located contact events (`integrators::dop853`).
    Dop853,
}

impl Method {
    /// The method's name in the model file and in messages: its catalog entry's.
    pub fn name(&self) -> &'static str {
        method_catalog::entry_of(self).name
    }

    /// The Newmark-family scheme of Newmark-β, generalized-α and HHT-α (`None` for the
    /// others): they share one stepper.
    pub fn newmark_family(&self) -> Option<NewmarkFamily> {
        match *self {
            Method::Newmark(s) | Method::GeneralizedAlpha(s) | Method::Hht(s) => Some(s),
            _ => None,
        }
    }

    /// Whether the method is impulsive (`crate::impulsive`: rigid gaps only).
    pub fn is_impulsive(&self) -> bool {
        matches!(self, Method::EventDriven(_) | Method::MoreauJean(_))
    }

    /// Refuses rigid gaps with the compliant integrators and compliant laws with the impulsive
    /// methods (one line naming the gap, its law and the method).
    pub fn check_laws(&self, sys: &System) -> Result<(), SimError> {
        let impulsive = self.is_impulsive();
        if let (Some(i), Method::Precise(_) | Method::Bathe(_)) = (
            sys.gaps
                .iter()
                .position(|g| matches!(g.side, crate::gap::Side::Radial(_))),
            self,
        ) {
            return invalid(format!(
                "gaps[{i}].kind: 'radial' is not available with solver.method '{}'; expected \
                 'dop853', 'newmark', 'hht' or 'generalized-alpha'",
                self.name()
            ));
        }
        for (i, g) in sys.gaps.iter().enumerate() {
            if g.law.is_rigid() && !impulsive {
                return invalid(format!(
                    "gaps[{i}].law.kind: 'rigid' needs solver.method = 'event-driven' or \
                     'moreau-jean'; method '{}' takes force laws only",
                    self.name()
                ));
            }
            if !g.law.is_rigid() && impulsive {
                return invalid(format!(
                    "gaps[{i}].law.kind: '{}' is a force law; solver.method '{}' takes rigid gaps \
                     only (kind = 'rigid')",
                    g.law.name(),
                    self.name()
                ));
            }
        }
        Ok(())
    }
}
