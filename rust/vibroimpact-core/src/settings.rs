//! How long a run is, its steps and what it records.

use crate::error::{invalid, SimError};
use crate::integrators::NewtonSettings;

/// Step size, duration and what to record.
#[derive(Debug, Clone, PartialEq)]
pub struct RunSettings {
    /// Simulated duration, s.
    pub t_end: f64,
    /// Step size, s (reduced slightly if needed so that `t_end` is a whole number of steps).
    pub dt: f64,
    /// Record every k-th step (the first and last steps are always recorded).
    pub every: usize,
    /// DOFs whose displacement, velocity and acceleration are recorded.
    pub record_dofs: Vec<usize>,
    pub newton: NewtonSettings,
    /// Adaptive step control (Newmark family only); `dt` is then the first step.
    pub adaptive: Option<Adaptive>,
}

/// What a run computes beyond its steps, its statistics and its error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outputs {
    /// Everything a run returns: rows, peaks, impact table and energy account.
    All,
    /// Only what its `StepObserver` takes of each step (a sweep point, which keeps only its
    /// reduction): no peaks (`RunOutput::max_abs_displacement` empty), no impact table, and
    /// of the energy account per step only what the energy check reads (the external work;
    /// the contacts' work with a radial gap), so the rows' dissipation columns are incomplete.
    Observed,
}

/// Tolerances and limits of adaptive stepping.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Adaptive {
    /// Relative tolerance on the local displacement error.
    pub rtol: f64,
    /// Absolute tolerance on it, m.
    pub atol: f64,
    /// Smallest step, s.
    pub dt_min: f64,
    /// Largest step, s.
    pub dt_max: f64,
}

impl Adaptive {
    /// Checks the tolerances and limits against the run's duration; returns `dt_max`
    /// shortened so that `t_end` is a whole number of largest steps.
    pub(crate) fn checked_dt_max(&self, t_end: f64) -> Result<f64, SimError> {
        for (name, v) in [("rtol", self.rtol), ("atol", self.atol)] {
            if !(v.is_finite() && v >= 0.0) {
                return invalid(format!(
                    "solver.{name}: {v} is not valid; expected a tolerance >= 0"
                ));
            }
        }
        if self.rtol == 0.0 && self.atol == 0.0 {
            return invalid("solver.rtol: 0 with atol = 0 is not valid; expected a tolerance > 0");
        }
        if !(self.dt_min.is_finite() && self.dt_min > 0.0) {
            return invalid(format!(
                "solver.dt_min: {} is not valid; expected a step > 0 in s",
                self.dt_min
            ));
        }
        if !(self.dt_max.is_finite() && self.dt_max >= self.dt_min && self.dt_max <= t_end) {
            return invalid(format!(
                    "solver.dt_max: {} is not valid; expected dt_min <= dt_max <= t_end ({} to {t_end} s)",
                    self.dt_max, self.dt_min
                ));
        }
        Ok(t_end / (t_end / self.dt_max - 1e-9).ceil())
    }
}
