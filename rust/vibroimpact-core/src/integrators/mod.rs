//! Time integrators. Each advances a [`State`] by one step of a given size without touching
//! it (so a failed attempt is simply discarded and the step cut), behind the [`Stepper`] trait.

mod newmark;
mod newton;

pub use newmark::{NewmarkFamily, NewmarkStepper};
pub use newton::NewtonSettings;

use crate::system::{State, System};

/// Why a step attempt failed; the driver cuts the step and retries.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepFailure {
    pub gap: usize,
    pub penetration: f64,
    pub iterations: usize,
}

/// One step of an integrator: from `from`, of length `h` (= dt / 2^level), into `to`.
pub trait Stepper {
    /// Returns the number of Newton iterations spent.
    fn attempt(
        &mut self,
        sys: &System,
        from: &State,
        level: usize,
        h: f64,
        to: &mut State,
    ) -> Result<usize, StepFailure>;
}
