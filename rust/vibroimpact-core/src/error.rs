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
    },
    /// The effective stiffness `K + a0 M + a1 C` cannot be factorised.
    SingularTangent {
        /// Step size for which the factorisation failed, s.
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
            SimError::Diverged { t } => write!(
                f,
                "the solution diverged (non-finite state) at t = {t:.9e} s; \
                 reduce dt or check the model's units"
            ),
            SimError::SingularTangent { dt } => write!(
                f,
                "the effective stiffness K + M/(beta dt^2) + gamma C/(beta dt) is singular \
                 for dt = {dt:.3e} s; check the mass matrix"
            ),
        }
    }
}

impl std::error::Error for SimError {}

/// Shorthand for refusing a model with a message naming the field.
pub(crate) fn invalid<T>(msg: impl Into<String>) -> Result<T, SimError> {
    Err(SimError::InvalidModel(msg.into()))
}
