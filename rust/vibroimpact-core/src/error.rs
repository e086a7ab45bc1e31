//! Errors of the compute core. Plain data, mapped to Python exceptions by the binding crate.

use std::fmt;

/// Why a model was refused or a run stopped.
#[derive(Debug, Clone, PartialEq)]
pub enum SimError {
    /// The model or the settings are inconsistent (named field, value, what was expected).
    InvalidModel(String),
    /// Newton–Raphson did not converge even after the allowed step cuts.
    NewtonFailed {
        /// Time at the start of the failing step, s.
        t: f64,
        /// Index of the gap with the largest residual.
        gap: usize,
        /// Penetration of that gap at the last iterate, m.
        penetration: f64,
        /// Iterations spent on the smallest step tried.
        iterations: usize,
        /// Smallest step tried, s.
        dt: f64,
    },
    /// The state became NaN or infinite.
    Diverged {
        /// Time at which the state stopped being finite, s.
        t: f64,
        /// The gap in contact with the largest force at the last finite state, if any.
        gap: Option<usize>,
    },
    /// The mechanical energy grew far beyond every energy that entered the system (initial
    /// energy plus external work): the integration is unstable or a law creates energy.
    EnergyGrowth {
        /// Time of the check that found it, s.
        t: f64,
        /// Kinetic + strain + contact potential energy then, J.
        energy: f64,
        /// Largest energy that entered the system up to then, J.
        reference: f64,
        /// The gap in contact with the largest force then, if any.
        gap: Option<usize>,
    },
    /// An interrupt was requested ([`crate::interrupt`]): the run stopped at `t`.
    Interrupted {
        /// Time of the last accepted step, s.
        t: f64,
    },
    /// A radial gap's sliding speed `v_rel` crossed zero in contact under Coulomb friction:
    /// sticking is not modelled.
    Sticking {
        /// Instant of the crossing (linear between the step's ends), s.
        t: f64,
        gap: usize,
    },
    /// The effective stiffness `K + a0 M + a1 C` cannot be factorised.
    SingularTangent {
        /// Time at the start of the step that needed it, s (0 when found before the run).
        t: f64,
        /// Step size for which the factorisation failed (the smallest tried), s.
        dt: f64,
    },
}

impl fmt::Display for SimError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SimError::InvalidModel(msg) => write!(f, "{msg}"),
            SimError::NewtonFailed {
                t,
                gap,
                penetration,
                iterations,
                dt,
            } => write!(
                f,
                "Newton-Raphson did not converge at t = {t:.9e} s on gap {gap} \
                 (penetration {penetration:.3e} m) after {iterations} iterations \
                 with the step cut to {dt:.3e} s; reduce dt or check the contact stiffness"
            ),
            SimError::Diverged { t, gap } => write!(
                f,
                "the solution diverged (non-finite state) at t = {t:.9e} s{}; \
                 reduce dt or check the model's units",
                on_gap(*gap)
            ),
            SimError::EnergyGrowth {
                t,
                energy,
                reference,
                gap,
            } => write!(
                f,
                "the solution diverged (energy blow-up) at t = {t:.9e} s{}: the mechanical \
                 energy {energy:.3e} J exceeds {:.0e} times the largest energy that entered \
                 the system ({reference:.3e} J); reduce dt, use an unconditionally stable \
                 method (Newmark average acceleration) or check the contact law",
                on_gap(*gap),
                ENERGY_GROWTH_LIMIT
            ),
            SimError::Sticking { t, gap } => write!(
                f,
                "gaps[{gap}]: the sliding speed v_rel = R Omega + rho theta' at the contact \
                 crossed zero at t = {t:.9e} s in contact (the rotor would stick to the stator): \
                 sticking is not modelled with Coulomb friction; set friction_law = \
                 'regularised' with regularisation_speed (m/s), F_T = mu F_N tanh(v_rel / v_reg)"
            ),
            SimError::Interrupted { t } => write!(
                f,
                "interrupted at t = {t:.9e} s; the results up to then are kept"
            ),
            SimError::SingularTangent { t, dt } => write!(
                f,
                "the effective stiffness K + M/(beta dt^2) + gamma C/(beta dt) is singular \
                 for dt = {dt:.3e} s at t = {} (a property of the structure, on no \
                 gap); check the mass and stiffness matrices (a negative stiffness \
                 cancelling the inertia term) or change dt",
                if *t == 0.0 {
                    "0 s, before the first step".to_string()
                } else {
                    format!("{t:.9e} s")
                }
            ),
        }
    }
}

impl std::error::Error for SimError {}

/// Energy growth, relative to the largest energy that entered the system, that counts as a
/// blow-up ([`SimError::EnergyGrowth`]).
pub const ENERGY_GROWTH_LIMIT: f64 = 1e3;

fn on_gap(gap: Option<usize>) -> String {
    match gap {
        Some(g) => format!(" with gap {g} in contact"),
        None => " with no gap in contact".to_string(),
    }
}

/// Shorthand for refusing a model with a message naming the field.
pub(crate) fn invalid<T>(msg: impl Into<String>) -> Result<T, SimError> {
    Err(SimError::InvalidModel(msg.into()))
}
