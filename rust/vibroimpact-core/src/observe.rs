//! What watches a run from inside the time loop: a [`Sink`] (rows in blocks, progress,
//! solver [`Event`]s) and a [`StepObserver`] (every accepted step: the sweeps' reducers).

use crate::output::Rows;
use crate::sensitivity::StateTransition;
use crate::system::{State, System};

/// Where a DOF's displacement turns inside a step: the fraction of the step and the value (m
/// or rad), on the integrator's own interpolant.
pub type Turn = (f64, f64);

/// Sees every accepted step of a run: streaming reducers (sweeps: Poincaré samples, peaks,
/// impact statistics; `crate::sweep`) that need more than the decimated output without
/// storing the history. Called after each accepted step from `s0` to `s1` of length `h`;
/// `turns`: where each recorded DOF's displacement turns inside the step (fraction of the
/// step, value), when the integrator knows it from its own interpolant.
pub trait StepObserver {
    fn accepted(
        &mut self,
        sys: &System,
        s0: &State,
        s1: &State,
        h: f64,
        turns: Option<&[Option<Turn>]>,
    );

    /// The steps from `s0` of length `h` with `s0.t + h <= quiet_until()` (a sweep's
    /// transient) are not handed to [`Self::accepted`]. Read once, when the observer is
    /// attached; the default hands it every step.
    fn quiet_until(&self) -> f64 {
        f64::NEG_INFINITY
    }

    /// The end state of the last accepted step, quiet or not: `s`'s `x` and `v` and the
    /// step's end time `t` (the run's state may carry a grid-rounded time); called at the
    /// run's end, and before an impact's velocity jump changes the state in place.
    fn final_state(&mut self, _s: &State, _t: f64) {}

    /// An impact on the rigid wall `wall` (index into `sys.walls`) at `t` with approach
    /// speed `speed`, m/s: the impulsive methods, whose impacts are velocity jumps at an
    /// instant between two accepted steps rather than a closing inside one.
    fn impact(&mut self, _sys: &System, _wall: usize, _t: f64, _speed: f64) {}

    /// The state-transition matrix from the run's start to the end of the step of the output
    /// grid just taken, from the step policies that compute one (asked for by
    /// `simulate_with_sensitivity`; `crate::sensitivity`).
    fn sensitivity(&mut self, _transition: &StateTransition) {}
}

/// A solver event reported to a [`Sink`] that asks for them (`vibroimpact run --verbose`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Event {
    /// Newton did not converge on the step of length `dt` from `t` (after `iterations`
    /// iterations, worst at `gap` with that penetration, m); it is retried with shorter steps.
    StepCut {
        t: f64,
        dt: f64,
        gap: usize,
        penetration: f64,
        iterations: usize,
    },
    /// The wall on `side` (+1 / −1) of `gap` closed in the step that ended at `t`, with the
    /// approach speed `speed`, m/s.
    ContactStart {
        t: f64,
        gap: usize,
        side: f64,
        speed: f64,
    },
    /// It opened again in the step that ended at `t`, after `steps` accepted steps in contact
    /// that took `iterations` Newton iterations; `speed` is the separation speed, m/s.
    ContactEnd {
        t: f64,
        gap: usize,
        side: f64,
        speed: f64,
        steps: usize,
        iterations: usize,
    },
    /// A rigid wall on `side` of `gap` was hit at `t` (the impulsive methods): approach speed
    /// `v_in` and separation speed `v_out`, m/s (0: the wall stays closed, sticking).
    Impact {
        t: f64,
        gap: usize,
        side: f64,
        v_in: f64,
        v_out: f64,
    },
    /// The stepper solves the effective stiffness of steps of `dt` with this factor (once,
    /// before the first step).
    LinearSolver {
        dt: f64,
        factor: crate::factor::FactorInfo,
    },
}

/// Watches a run of any method from inside the time loop: takes the recorded rows in blocks,
/// so that they need not be held until the end, follows the simulated time and receives
/// [`Event`]s. Each of its functions has a default that does nothing; the calls cost nothing
/// measurable (rows: once per block; progress: every [`crate::interrupt::CHECK_EVERY`]
/// steps; events: only if asked for).
pub trait Sink {
    /// Hand the rows over every this many recorded rows (`None`: keep them all).
    fn chunk_rows(&self) -> Option<usize> {
        None
    }
    /// A block of `chunk_rows()` rows, in order.
    fn rows(&mut self, _rows: Rows) {}
    /// Whether [`Event`]s are wanted.
    fn wants_events(&self) -> bool {
        false
    }
    fn event(&mut self, _event: Event) {}
    /// The simulated time reached, s.
    fn progress(&mut self, _t: f64) {}
}
