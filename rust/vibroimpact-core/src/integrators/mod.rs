//! Time integrators. Each advances a [`State`] by one step of a given size without touching
//! it (so a failed attempt is simply discarded and the step cut), behind the [`Stepper`] trait.

mod bathe;
pub(crate) mod dop853;
mod dop853_tableau;
pub mod expm;
mod free_run;
mod newmark;
mod newmark_variational;
mod newton;
mod precise;
pub(crate) mod sized;

pub use bathe::{Bathe, BatheStepper};
pub(crate) use newmark::SizedNewmark;
pub use newmark::{substitution_time, NewmarkFamily, NewmarkStepper};
pub(crate) use newmark_variational::{NewmarkTransition, MAX_TRANSITION_DOFS};
pub use newton::NewtonSettings;
pub use precise::{precise_matrices, PreciseIntegration, PreciseMatrices, PreciseStepper};

use crate::error::SimError;
use crate::factor::FactorInfo;
use crate::system::{State, System};

/// `level` of a step whose size is not `dt / 2^level` (adaptive steps landing on an event or
/// on `t_end`): the stepper builds, or reuses, a one-off operator for that size.
pub const ANY_LEVEL: usize = usize::MAX;

/// An integrator's per-step-size operators: one per cached level (`dt / 2^level`) and the
/// last step of any other size ([`ANY_LEVEL`], e.g. a step landed on an event), each built
/// on first use — per step size, never per step.
pub(crate) struct OperatorCache<T> {
    levels: Vec<Option<T>>,
    one_off: Option<(f64, T)>,
}

impl<T> OperatorCache<T> {
    /// A cache for levels `0 ..= max_level`.
    pub(crate) fn new(max_level: usize) -> Self {
        Self {
            levels: (0..=max_level).map(|_| None).collect(),
            one_off: None,
        }
    }

    /// Stores the operator of level 0 (the largest step), built before the run.
    pub(crate) fn set_largest(&mut self, op: T) {
        self.levels[0] = Some(op);
    }

    /// Builds the operator of a step of length `h` at `level` unless it is cached, and
    /// returns it (one look-up where a step used to ensure it, then get it). In line: LLVM
    /// left it out of the Newmark step compiled per model size, a call each step.
    #[inline(always)]
    pub(crate) fn ensure<E>(
        &mut self,
        level: usize,
        h: f64,
        build: impl FnOnce() -> Result<T, E>,
    ) -> Result<&T, E> {
        match self.levels.get_mut(level) {
            Some(slot) => {
                if slot.is_none() {
                    *slot = Some(build()?);
                }
                Ok(slot.as_ref().expect("built above"))
            }
            None => {
                if self.one_off.as_ref().is_none_or(|(size, _)| *size != h) {
                    self.one_off = Some((h, build()?));
                }
                Ok(&self.one_off.as_ref().expect("built above").1)
            }
        }
    }

    /// The operator of level 0, if it is built.
    pub(crate) fn largest(&self) -> Option<&T> {
        self.levels.first().and_then(Option::as_ref)
    }

    /// The operator [`Self::ensure`] made available for `level`.
    pub(crate) fn get(&self, level: usize) -> &T {
        match self.levels.get(level) {
            Some(slot) => slot.as_ref().expect("ensured before use"),
            None => &self.one_off.as_ref().expect("ensured before use").1,
        }
    }
}

/// Why a step attempt failed; the driver cuts the step and retries.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepFailure {
    pub gap: usize,
    pub penetration: f64,
    pub iterations: usize,
    /// The step's effective stiffness could not be factorised (no Newton iteration ran).
    pub singular: bool,
}

impl StepFailure {
    /// A step whose effective stiffness is singular.
    pub fn singular_tangent() -> Self {
        Self {
            gap: 0,
            penetration: 0.0,
            iterations: 0,
            singular: true,
        }
    }

    /// The run's error when a step from `t` failed at its smallest size `dt`.
    pub fn into_error(self, t: f64, dt: f64) -> SimError {
        if self.singular {
            SimError::SingularTangent { t, dt }
        } else {
            SimError::NewtonFailed {
                t,
                gap: self.gap,
                penetration: self.penetration,
                iterations: self.iterations,
                dt,
            }
        }
    }
}

/// The step lifecycle of an integrator (after OpenSees' `newStep`/`commit`): `attempt` a step
/// of length `h` (= dt / 2^level, so that per-size operators can be cached by `level`) from
/// `from` into `to` without changing anything the next attempt depends on; the driver then
/// either calls `accept` (and `to` becomes the current state) or discards `to` and attempts
/// shorter steps.
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

    /// The last successful attempt became the current state (multi-step methods shift their
    /// history here).
    fn accept(&mut self, _sys: &System, _state: &State) {}

    /// The last successful attempt was in free flight: every wall open at both ends of the
    /// step, found without evaluating a wall, and its motion finite (then the commit skips
    /// the contact accounts, the impact table and its finiteness test without looking at the
    /// walls; a step that is not finite commits as any other, which reports it). `false` when
    /// not known.
    fn last_step_free(&self) -> bool {
        false
    }

    /// The linear solver of the largest step's effective stiffness, for the log (steppers
    /// that choose one).
    fn linear_solver(&self) -> Option<FactorInfo> {
        None
    }

    /// Takes up to `max` steps of `h` of the fixed grid from its step `step` while they are
    /// in free flight, each committed and (with `rows`) recorded as the general step and the
    /// driver would (the fixed-step loop's free run, [`crate::driver::Run::drive`]); returns
    /// how many, `None` if it never takes any (the default).
    #[allow(private_interfaces)] // the crate's own fixed-step loop calls it
    fn free_run(
        &mut self,
        _sys: &System,
        _run: &mut crate::driver::Run,
        _h: f64,
        _step: usize,
        _max: usize,
        _rows: bool,
    ) -> Option<usize> {
        None
    }

    /// Which step it takes for `sys` ([`crate::output::Stats::step_path`]).
    fn step_path(&self, _sys: &System) -> &'static str {
        "general"
    }
}
