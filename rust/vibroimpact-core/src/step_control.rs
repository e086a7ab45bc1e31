//! The step policies of the implicit and precise integrators ([`Stepper`]s): fixed steps
//! with automatic step cutting ([`FixedSteps`]) and adaptive steps ([`StepControl`]).
//!
//! Adaptive stepping for the Newmark family (docs/integrators.md): a local error estimate, step
//! growth in free flight and reduction in contact, and every gap's closing and opening (and
//! the first peak of each contact) located inside the step and landed on, so that no contact
//! is stepped over and `v_imp`, `t_start`, `t_end`, `v_out` and the peak come from a step that
//! ends at the event. In contact, average acceleration doubles its steps and keeps their
//! Richardson extrapolation (fourth order): on the paper's SDOF case that reaches fixed
//! `dt = 1 µs` accuracy with about 15× fewer Newmark steps (`tests/test_adaptive.py`).
//!
//! Step sizes are `dt_max / 2^(k/4)` (quarter octaves, so the factorised operators are cached
//! per `k`, never built per step), except for the steps that land on an event or on `t_end`,
//! whose operator is built for that one size.

use nalgebra::DMatrix;

use crate::driver::{Run, StepPolicy};
use crate::error::{invalid, SimError};
use crate::gap::{Wall, WallState};
use crate::integrators::{NewmarkFamily, NewmarkTransition};
use crate::integrators::{StepFailure, Stepper, ANY_LEVEL};
use crate::output::Stats;
use crate::sensitivity::StateTransition;
use crate::settings::Adaptive;
use crate::system::{State, System, Tangent};

/// Peaks of the penetration closer than this fraction of the step to its ends are not
/// landed on.
const PEAK_MARGIN: f64 = 1e-2;

/// Cached step sizes per halving of the step.
const LEVELS_PER_OCTAVE: f64 = 4.0;

/// What [`FixedSteps`] carries along its accepted (sub-)steps besides the state: nothing
/// (`()`, compiled away), or a state-transition matrix ([`NewmarkTransition`]).
pub(crate) trait StepDerivative {
    /// Composes it with the accepted step of length `h` from `s0` to `s1`.
    fn step(&mut self, sys: &System, s0: &State, s1: &State, h: f64) -> Result<(), SimError>;
    fn transition(&self) -> Option<&StateTransition>;
}

impl StepDerivative for () {
    #[inline(always)]
    fn step(&mut self, _: &System, _: &State, _: &State, _: f64) -> Result<(), SimError> {
        Ok(())
    }
    fn transition(&self) -> Option<&StateTransition> {
        None
    }
}

impl StepDerivative for NewmarkTransition {
    fn step(&mut self, sys: &System, s0: &State, s1: &State, h: f64) -> Result<(), SimError> {
        NewmarkTransition::step(self, sys, s0, s1, h)
    }
    fn transition(&self) -> Option<&StateTransition> {
        Some(NewmarkTransition::transition(self))
    }
}

/// The time `k h0` of step `k` of the fixed grid of steps `h0` (through i64: one conversion
/// instruction where u64 takes five; the same value below 2^63 steps).
#[inline(always)]
pub(crate) fn grid_time(k: usize, h0: f64) -> f64 {
    k as i64 as f64 * h0
}

/// How many of the steps of the grid of steps `h0` from its step `k` on, up to `max > 0`,
/// end by `t` as a commit has them (`grid_time(j, h0) + h0 <= t`: the general step's
/// `s₀.t + h`, `Run::commit_step`'s test of a quiet step); that end grows with `j`, so the
/// first step that does not is found by bisection.
fn steps_ending_by(k: usize, h0: f64, t: f64, max: usize) -> usize {
    let ends_by = |j: usize| grid_time(j, h0) + h0 <= t;
    let (mut quiet, mut loud) = (k, k + max - 1);
    if ends_by(loud) {
        return max;
    }
    if !ends_by(quiet) {
        return 0;
    }
    while loud - quiet > 1 {
        let mid = quiet + (loud - quiet) / 2;
        if ends_by(mid) {
            quiet = mid;
        } else {
            loud = mid;
        }
    }
    loud - k
}

/// Steps of a fixed size `h0` on the grid `k h0`, each halved (recursively, up to `max_cuts`
/// times) when Newton fails; `derivative` composed along them. Compiled per stepper type `S`
/// where the caller knows it (the Newmark family's), so that its step is inlined into the
/// time loop; `dyn Stepper` otherwise.
pub(crate) struct FixedSteps<'s, S: Stepper + ?Sized, D: StepDerivative = ()> {
    stepper: &'s mut S,
    h0: f64,
    n_steps: usize,
    max_cuts: usize,
    /// Steps of the grid taken.
    step: usize,
    /// Levels of the sub-steps still to take in the current grid step.
    pending: Vec<usize>,
    derivative: D,
    /// The first step of the grid an observer is handed ([`Run::unobserved_until`]), found on
    /// the first free run.
    observed_from: Option<usize>,
}

impl<'s, S: Stepper + ?Sized> FixedSteps<'s, S> {
    pub fn new(stepper: &'s mut S, h0: f64, n_steps: usize, max_cuts: usize) -> Self {
        Self {
            stepper,
            h0,
            n_steps,
            max_cuts,
            step: 0,
            pending: Vec::with_capacity(2 * max_cuts + 2),
            derivative: (),
            observed_from: None,
        }
    }

    /// Carries `derivative` along every accepted (sub-)step.
    pub fn with_derivative<D: StepDerivative>(self, derivative: D) -> FixedSteps<'s, S, D> {
        FixedSteps {
            stepper: self.stepper,
            h0: self.h0,
            n_steps: self.n_steps,
            max_cuts: self.max_cuts,
            step: self.step,
            pending: self.pending,
            derivative,
            observed_from: self.observed_from,
        }
    }
}

impl<S: Stepper + ?Sized, D: StepDerivative> StepPolicy for FixedSteps<'_, S, D> {
    fn sensitivity(&self) -> Option<&StateTransition> {
        self.derivative.transition()
    }

    /// Until a step is cut (`Run::step_cut` then keeps the peaks per commit).
    fn commits_once_per_advance(&self) -> bool {
        true
    }

    /// The stepper's free run ([`Stepper::free_run`]) on the grid, up to its end and over
    /// the steps the observer has no use for (none after the first it has: none again).
    fn free_run(&mut self, run: &mut Run, sys: &System, max: usize, rows: bool) -> Option<usize> {
        let max = max.min(self.n_steps - self.step);
        if max == 0 {
            return Some(0);
        }
        let observed_from = *self.observed_from.get_or_insert_with(|| {
            let left = self.n_steps - self.step;
            self.step + steps_ending_by(self.step, self.h0, run.unobserved_until(), left)
        });
        let max = max.min(observed_from.saturating_sub(self.step));
        if max == 0 {
            return None;
        }
        let taken = (self.stepper).free_run(sys, run, self.h0, self.step, max, rows)?;
        self.step += taken;
        Some(taken)
    }

    fn advance(&mut self, run: &mut Run, sys: &System) -> Result<bool, SimError> {
        if self.step == self.n_steps {
            return Ok(false);
        }
        self.step += 1;
        // the grid step first, and its halves (pending) only if it fails
        let mut attempt = Some(0);
        while let Some(level) = attempt.take().or_else(|| self.pending.pop()) {
            let h = if level == 0 {
                self.h0
            } else {
                self.h0 / (1u64 << level) as f64
            };
            match self
                .stepper
                .attempt(sys, &run.cur, level, h, &mut run.trial)
            {
                Ok(iterations) => {
                    self.derivative.step(sys, &run.cur, &run.trial, h)?;
                    let free = self.stepper.last_step_free();
                    run.accept(sys, self.stepper, h, iterations, free)?;
                }
                Err(failure) => {
                    run.stats.rejected_steps += 1;
                    run.stats.newton_iterations += failure.iterations;
                    if level < self.max_cuts {
                        run.stats.step_cuts += 1;
                        run.step_cut(&failure, run.cur.t, h);
                        self.pending.push(level + 1);
                        self.pending.push(level + 1);
                    } else {
                        // Newton failing on a blown-up state: report the blow-up
                        run.check_energy(sys)?;
                        return Err(failure.into_error(run.cur.t, h));
                    }
                }
            }
        }
        run.cur.t = grid_time(self.step, self.h0);
        Ok(true)
    }
}

/// Adaptive stepping, validated and resolved against the run's duration.
pub(crate) struct StepControl {
    tol: Adaptive,
    pub dt_max: f64,
    /// `dt_max / 2^(levels/4)` ≤ `dt_min`.
    levels: usize,
    first_level: usize,
    /// `β − 1/6`: the Zienkiewicz–Xie (1991) local error is `(β − 1/6) h² (a₁ − a₀)`.
    error_constant: f64,
    /// Average acceleration (γ = 1/2, β = 1/4, no α): a symmetric rule, whose error expands
    /// in even powers of `h`, so that Richardson extrapolation gains two orders.
    symmetric: bool,
    t_end: f64,
}

impl StepControl {
    pub fn new(
        tol: Adaptive,
        scheme: NewmarkFamily,
        t_end: f64,
        dt: f64,
    ) -> Result<Self, SimError> {
        let dt_max = tol.checked_dt_max(t_end)?;
        let octaves = (dt_max / tol.dt_min).log2();
        if octaves > 60.0 {
            return invalid(format!(
                "solver.dt_min: {} is not valid; expected dt_max / dt_min <= 2^60",
                tol.dt_min
            ));
        }
        let levels = (LEVELS_PER_OCTAVE * octaves).ceil().max(0.0) as usize;
        let first_level =
            ((LEVELS_PER_OCTAVE * (dt_max / dt).log2()).ceil().max(0.0) as usize).min(levels);
        Ok(Self {
            tol,
            dt_max,
            levels,
            first_level,
            error_constant: (scheme.beta - 1.0 / 6.0).abs(),
            symmetric: scheme.gamma == 0.5
                && scheme.beta == 0.25
                && scheme.alpha_m == 0.0
                && scheme.alpha_f == 0.0,
            t_end,
        })
    }

    pub fn levels(&self) -> usize {
        self.levels
    }

    fn step(&self, level: usize) -> f64 {
        self.dt_max * (-(level as f64) / LEVELS_PER_OCTAVE).exp2()
    }

    /// Level whose step is the largest not above `h`.
    fn level_for(&self, h: f64) -> usize {
        let level = (LEVELS_PER_OCTAVE * (self.dt_max / h).log2() - 1e-9).ceil();
        (level.max(0.0) as usize).min(self.levels)
    }

    /// Local error of the step relative to the tolerance (≤ 1 is acceptable): displacement
    /// `(β − 1/6) h² |a₁ − a₀|` (Zienkiewicz & Xie 1991) and velocity `h³ |a''| / 12` (the
    /// trapezoidal rule's), with `a''` from the accelerations of this and the previous step.
    fn error(&self, s0: &State, s1: &State, h: f64, previous: Option<(&[f64], f64)>) -> f64 {
        let c = self.error_constant * h * h;
        let mut worst = 0.0f64;
        for i in 0..s0.x.len() {
            let e = c * (s1.a[i] - s0.a[i]).abs();
            let scale = self.tol.atol + self.tol.rtol * s1.x[i].abs().max(s0.x[i].abs());
            worst = worst.max(e / scale);
            if let Some((a_prev, h_prev)) = previous {
                let jerk1 = (s1.a[i] - s0.a[i]) / h;
                let jerk0 = (s0.a[i] - a_prev[i]) / h_prev;
                let snap = (jerk1 - jerk0) / (0.5 * (h + h_prev));
                let e_v = h * h * h * snap.abs() / 12.0;
                // velocity tolerance: rtol on the speed, atol spread over the largest step
                let scale_v =
                    self.tol.atol / self.dt_max + self.tol.rtol * s1.v[i].abs().max(s0.v[i].abs());
                worst = worst.max(e_v / scale_v);
            }
        }
        worst
    }

    /// Richardson error of step doubling relative to the tolerance (≤ 1 is acceptable): the
    /// two half steps `fine` against the one full step `coarse` of the same length; both are
    /// second order, so `(fine − coarse)/3` estimates the error of `fine` (Hairer, Nørsett &
    /// Wanner, *Solving ODEs I*, §II.4). Displacement against `atol + rtol |x|`, velocity
    /// against `atol / dt_max + rtol v_max`, with `v_max` the largest speed of the DOF so far.
    fn doubling_error(&self, s0: &State, coarse: &State, fine: &State, v_max: &[f64]) -> f64 {
        let mut worst = 0.0f64;
        for (i, &speed) in v_max.iter().enumerate() {
            let e_x = (fine.x[i] - coarse.x[i]).abs() / 3.0;
            let scale_x = self.tol.atol + self.tol.rtol * fine.x[i].abs().max(s0.x[i].abs());
            let e_v = (fine.v[i] - coarse.v[i]).abs() / 3.0;
            let scale_v = self.tol.atol / self.dt_max + self.tol.rtol * speed;
            worst = worst.max(e_x / scale_x).max(e_v / scale_v);
        }
        worst
    }

    /// One attempt of `h` from `from` into `to`; a Newton failure is counted and turned into
    /// the level to retry at, or into the run's error at the smallest step.
    #[allow(clippy::too_many_arguments)]
    fn attempt(
        &self,
        run_stats: &mut Stats,
        sys: &System,
        stepper: &mut dyn Stepper,
        from: &State,
        key: usize,
        h: f64,
        to: &mut State,
    ) -> Result<usize, Retry> {
        stepper.attempt(sys, from, key, h, to).map_err(|failure| {
            run_stats.rejected_steps += 1;
            run_stats.newton_iterations += failure.iterations;
            if h > self.step(self.levels) * (1.0 + 1e-12) {
                run_stats.step_cuts += 1;
                Retry::Level((self.level_for(h) + 1).min(self.levels), failure)
            } else {
                Retry::Failed(failure.into_error(from.t, h))
            }
        })
    }

    /// Level after a rejected step of `h` with error `err` > 1: at least one level down.
    fn shrunk_level(&self, h: f64, err: f64) -> usize {
        let shrink = (0.9 * err.powf(-1.0 / 3.0)).clamp(0.1, 0.5);
        self.level_for(h * shrink)
            .max(self.level_for(h) + 1)
            .min(self.levels)
    }
}

/// Adaptive steps ([`StepControl`]) of a [`Stepper`]: what carries from one step to the next.
pub(crate) struct AdaptiveSteps<'s> {
    control: &'s StepControl,
    stepper: &'s mut dyn Stepper,
    /// Largest step at which the Richardson extrapolation is kept ([`extrapolation_limit`]).
    h_extrapolate: f64,
    level: usize,
    /// Events closer than this to a step's ends are not landed on separately.
    event_tol: f64,
    /// A wall this close (in time) to closing is touching (landings stop short of it).
    touch_tol: f64,
    /// The next step lands on an event this far ahead, s.
    landing: Option<f64>,
    /// Acceleration and length of the previous accepted step, for the velocity error.
    a_prev: Vec<f64>,
    h_prev: Option<f64>,
    /// Last step accepted in contact: the first step of the next contact.
    h_contact: Option<f64>,
    /// Per wall: closed (or touching) by the last accepted step.
    just_closed: Vec<bool>,
    /// Per wall: closed and not yet past the first peak of the contact.
    peak_pending: Vec<bool>,
    /// Per DOF: the largest speed so far, m/s.
    v_max: Vec<f64>,
    mid: State,
    fine: State,
    scratch: Scratch,
}

impl<'s> AdaptiveSteps<'s> {
    /// From the run's current state.
    pub fn new(
        control: &'s StepControl,
        stepper: &'s mut dyn Stepper,
        run: &Run,
        sys: &System,
    ) -> Self {
        let event_tol = (control.step(control.levels) * 1e-3).max(1e-15 * control.t_end);
        Self {
            control,
            stepper,
            h_extrapolate: if control.symmetric {
                extrapolation_limit(sys)
            } else {
                0.0
            },
            level: control.first_level,
            event_tol,
            touch_tol: 4.0 * event_tol.max(1e-9 * control.dt_max),
            landing: None,
            a_prev: run.cur.a.to_vec(),
            h_prev: None,
            h_contact: None,
            just_closed: vec![false; sys.walls.len()],
            peak_pending: vec![false; sys.walls.len()],
            v_max: run.cur.v.iter().map(|v| v.abs()).collect(),
            mid: State::clone(&run.cur),
            fine: State::clone(&run.cur),
            scratch: Scratch::new(sys),
        }
    }
}

impl StepPolicy for AdaptiveSteps<'_> {
    /// One accepted step (up to `t_end`).
    ///
    /// In free flight (and for the schemes other than average acceleration) each step is one
    /// Newmark step checked by [`StepControl::error`]. While a wall is closed, average
    /// acceleration takes each step twice, as one step and as two half steps, checks the
    /// difference ([`StepControl::doubling_error`]) and keeps the Richardson extrapolation
    /// `fine + (fine − coarse)/3`, fourth order for the smooth part of the contact (the rule
    /// is symmetric: its error expands in even powers of `h`) — provided the structure's
    /// stiffest mode is resolved ([`extrapolation_limit`]). Every attempt counts: the steps
    /// of an extrapolated step are its three Newmark steps, and `rejected_steps` counts the
    /// attempts discarded for the error, for an event inside them, or for Newton.
    fn advance(&mut self, run: &mut Run, sys: &System) -> Result<bool, SimError> {
        let c = self.control;
        loop {
            if c.t_end - run.cur.t <= 1e-13 * c.t_end {
                return Ok(false);
            }
            let remaining = c.t_end - run.cur.t;
            let (mut h, mut key) = (c.step(self.level), self.level);
            let landed = self.landing.is_some();
            if let Some(h_event) = self.landing.take() {
                (h, key) = (h_event, ANY_LEVEL);
            }
            if h >= remaining * (1.0 - 1e-12) {
                (h, key) = (remaining, ANY_LEVEL);
            }
            let mut iterations = match c.attempt(
                &mut run.stats,
                sys,
                self.stepper,
                &run.cur,
                key,
                h,
                &mut run.trial,
            ) {
                Ok(it) => it,
                Err(Retry::Level(l, failure)) => {
                    run.step_cut(&failure, run.cur.t, h);
                    self.level = l;
                    continue;
                }
                Err(Retry::Failed(e)) => return Err(run.check_energy(sys).err().unwrap_or(e)),
            };
            let walls = &sys.walls;
            // Where an event is within `near` of a step's end, the step is not cut for it.
            let near = self.event_tol.max(1e-9 * h);
            let inside = |t: f64, h: f64| t > near && h - t > near;
            // Land on the earliest closing, opening or grazing contact inside the step.
            if let Some(t) = next_crossing(walls, &run.cur, &run.trial, h, near) {
                if inside(t, h) {
                    reject(&mut run.stats, 1, iterations);
                    self.landing = Some(t);
                    continue;
                }
            }
            let in_contact = run.cur.walls.iter().any(|w| w.closed())
                || run.trial.walls.iter().any(|w| w.closed());
            let above_min = h > c.step(c.levels) * (1.0 + 1e-12);
            // A contact that the step resolves badly: past its peak in the step after the
            // closing, or (short, grazing) peaking inside the step far above both ends.
            let past_peak = self
                .just_closed
                .iter()
                .zip(&run.trial.walls)
                .any(|(&closed_now, w1)| closed_now && w1.closed() && w1.rate < 0.0);
            let unresolved =
                in_contact && (past_peak || unresolved_contact(&run.cur, &run.trial, h));
            let extrapolate = in_contact && h <= self.h_extrapolate;
            // the single step's own estimate; with step doubling a quarter of it (two half
            // steps have a quarter of one step's error) rejects a step before its halves
            let mut err = c.error(
                &run.cur,
                &run.trial,
                h,
                self.h_prev.map(|hp| (&self.a_prev[..], hp)),
            );
            if extrapolate {
                err *= 0.25;
            }
            if unresolved {
                err = err.max(1e3);
            }
            if err > 1.0 && above_min {
                reject(&mut run.stats, 1, iterations);
                self.level = c.shrunk_level(h, err);
                continue;
            }
            // The deepest point of a contact inside an acceptable step: land on it, unless
            // it is within 1 % of the step's ends (the peak is then off by (h/100)² δ̈ / 2).
            if let Some(theta) = next_peak(&run.cur, &run.trial, h, &self.peak_pending) {
                if (PEAK_MARGIN..1.0 - PEAK_MARGIN).contains(&theta) {
                    reject(&mut run.stats, 1, iterations);
                    self.landing = Some(theta * h);
                    continue;
                }
            }
            let mut solves = 1;
            if extrapolate {
                let half = 0.5 * h;
                let half_key = match key {
                    k if k != ANY_LEVEL && k + LEVELS_PER_OCTAVE as usize <= c.levels => {
                        k + LEVELS_PER_OCTAVE as usize
                    }
                    _ => ANY_LEVEL,
                };
                let halves = c
                    .attempt(
                        &mut run.stats,
                        sys,
                        self.stepper,
                        &run.cur,
                        half_key,
                        half,
                        &mut self.mid,
                    )
                    .and_then(|it| {
                        c.attempt(
                            &mut run.stats,
                            sys,
                            self.stepper,
                            &self.mid,
                            half_key,
                            half,
                            &mut self.fine,
                        )
                        .map(|it2| it + it2)
                    });
                match halves {
                    Ok(it) => iterations += it,
                    Err(Retry::Level(l, failure)) => {
                        run.step_cut(&failure, run.cur.t, half);
                        reject(&mut run.stats, 1, iterations);
                        self.level = l;
                        continue;
                    }
                    Err(Retry::Failed(e)) => return Err(run.check_energy(sys).err().unwrap_or(e)),
                }
                solves = 3;
                // an event the half steps see inside them (not at their ends)
                let event = [(&*run.cur, &self.mid, 0.0), (&self.mid, &self.fine, half)]
                    .into_iter()
                    .filter_map(|(a, b, offset)| {
                        let crossing =
                            next_crossing(walls, a, b, half, near).filter(|&t| inside(t, half));
                        let peak = next_peak(a, b, half, &self.peak_pending)
                            .filter(|theta| (PEAK_MARGIN..1.0 - PEAK_MARGIN).contains(theta))
                            .map(|theta| theta * half);
                        crossing.or(peak).map(|t| offset + t)
                    })
                    .find(|&t| inside(t, h));
                if let Some(h_event) = event {
                    reject(&mut run.stats, solves, iterations);
                    self.landing = Some(h_event);
                    continue;
                }
                err = c.doubling_error(&run.cur, &run.trial, &self.fine, &self.v_max);
                if err > 1.0 && above_min {
                    reject(&mut run.stats, solves, iterations);
                    self.level = c.shrunk_level(h, err);
                    continue;
                }
                self.scratch
                    .extrapolate(sys, &run.cur, &self.fine, h, &mut run.trial);
                self.h_prev = None;
            } else {
                self.a_prev.copy_from_slice(&run.cur.a);
                // the acceleration history is not smooth across a contact event
                let event_at_end = run
                    .cur
                    .walls
                    .iter()
                    .zip(&run.trial.walls)
                    .any(|(w0, w1)| w0.closed() != w1.closed());
                self.h_prev = if event_at_end || landed {
                    None
                } else {
                    Some(h)
                };
            }
            for (j, (w0, w1)) in run.cur.walls.iter().zip(&run.trial.walls).enumerate() {
                self.just_closed[j] = !w0.closed() && touching(w1, self.touch_tol);
            }
            let closing = self.just_closed.contains(&true);
            for ((pending, &closed_now), w1) in self
                .peak_pending
                .iter_mut()
                .zip(&self.just_closed)
                .zip(&run.trial.walls)
            {
                *pending = closed_now || (*pending && w1.closed() && w1.rate > 0.0);
            }
            run.accept(sys, self.stepper, h, iterations, false)?;
            run.stats.steps += solves - 1;
            for (m, v) in self.v_max.iter_mut().zip(&run.cur.v) {
                *m = m.max(v.abs());
            }
            if in_contact && !landed {
                self.h_contact = Some(h);
            }
            // at most 4× per step, 10× when the step was exact (free flight of a free mass)
            let grow = if err > 0.0 {
                (0.9 * err.powf(-1.0 / 3.0)).clamp(0.2, 4.0)
            } else {
                10.0
            };
            let mut next = h * grow;
            // A wall closed by this step: the contact starts with the last contact's step.
            if let (true, Some(hc)) = (closing, self.h_contact) {
                next = next.min(hc);
            }
            self.level = c.level_for(next);
            return Ok(true);
        }
    }
}

/// Counts `solves` discarded attempts and their Newton iterations.
fn reject(stats: &mut Stats, solves: usize, iterations: usize) {
    stats.rejected_steps += solves;
    stats.newton_iterations += iterations;
}

/// Why an attempt is not used: retry at this level, or the run stops with this error.
enum Retry {
    /// Retry at this level; the failure that asked for it.
    Level(usize, StepFailure),
    Failed(SimError),
}

/// Work space of the Richardson extrapolation.
struct Scratch {
    u: Vec<f64>,
    u_rate: Vec<f64>,
    tangent: Tangent,
}

impl Scratch {
    fn new(sys: &System) -> Self {
        let ng = sys.gaps.len();
        Self {
            u: vec![0.0; ng],
            u_rate: vec![0.0; ng],
            tangent: Tangent::new(ng),
        }
    }

    /// `coarse ← fine + (fine − coarse)/3` for `x`, `v`, `a`, with the contact forces
    /// evaluated at the extrapolated gap coordinates (walls that were closed at `s0` keep
    /// their approach speed).
    fn extrapolate(&mut self, sys: &System, s0: &State, fine: &State, h: f64, coarse: &mut State) {
        for (c, f) in [
            (&mut coarse.x, &fine.x),
            (&mut coarse.v, &fine.v),
            (&mut coarse.a, &fine.a),
        ] {
            for (ci, &fi) in c.iter_mut().zip(f) {
                *ci = fi + (fi - *ci) / 3.0;
            }
        }
        sys.gap_coordinates(&coarse.x, &mut self.u);
        sys.gap_coordinates(&coarse.v, &mut self.u_rate);
        sys.evaluate_contacts(
            &s0.walls,
            &self.u,
            &self.u_rate,
            h,
            &mut coarse.walls,
            &mut coarse.phi,
            &mut self.tangent,
        );
        coarse.finish_gaps(sys, &self.u);
    }
}

/// Largest step at which the Richardson extrapolation of average acceleration is kept, s.
/// Extrapolation turns the rule's amplification of a mode with `ω h ≫ 1` from `|R| = 1` into
/// `(4 R(h/2)² − R(h))/3 → 5/3`, and for `ω h` small into `1 + (ω h)⁶/576` per step, so the
/// structure's stiffest mode (and its largest damping rate) must be resolved: `0.2 / ω_max`,
/// from the eigenvalues of `L⁻¹ K L⁻ᵀ` and `L⁻¹ C L⁻ᵀ` (`M = L Lᵀ`; `C + Ω G` for a rotor: its
/// symmetric part, and the largest |λ| of its skew part). Models with more than
/// [`MAX_EIGEN_DOFS`] DOFs are not extrapolated.
fn extrapolation_limit(sys: &System) -> f64 {
    if sys.n_dof() > MAX_EIGEN_DOFS {
        return 0.0;
    }
    let Ok(st) = sys.structure.dense("adaptive extrapolation") else {
        return 0.0;
    };
    let Some(chol) = st.mass.clone().cholesky() else {
        return 0.0;
    };
    let l = chol.l();
    let largest = |a: &DMatrix<f64>| -> Option<f64> {
        if a.iter().all(|&v| v == 0.0) {
            return Some(0.0);
        }
        let y = l.solve_lower_triangular(a)?;
        let z = l.solve_lower_triangular(&y.transpose())?;
        let sym = (&z + z.transpose()) * 0.5;
        // the skew part (gyroscopic forces Ω G of a rotor): its rate is the largest |λ|,
        // from the eigenvalues of −S² = SᵀS
        let skew = (&z - z.transpose()) * 0.5;
        let whirl = if skew.iter().all(|&v| v == 0.0) {
            0.0
        } else {
            (skew.transpose() * &skew)
                .symmetric_eigenvalues()
                .max()
                .max(0.0)
                .sqrt()
        };
        Some(sym.symmetric_eigenvalues().max().max(whirl))
    };
    match (largest(&st.stiffness), largest(&st.damping)) {
        (Some(k), Some(c)) => {
            let rate = k.sqrt().max(c);
            if rate > 0.0 {
                0.2 / rate
            } else {
                f64::INFINITY
            }
        }
        _ => 0.0,
    }
}

/// DOFs up to which [`extrapolation_limit`] computes the structure's eigenvalues.
const MAX_EIGEN_DOFS: usize = 200;

/// A wall closed, or open but closing within `tol` seconds.
fn touching(w: &WallState, tol: f64) -> bool {
    w.closed() || (w.rate > 0.0 && w.penetration + w.rate * tol >= 0.0)
}

/// A wall in contact at either end of the step whose interpolated penetration peaks inside
/// the step well above both ends: the step is longer than the contact can be resolved with
/// (a short, grazing contact), so the peak and the force history would be lost.
fn unresolved_contact(s0: &State, s1: &State, h: f64) -> bool {
    s0.walls.iter().zip(&s1.walls).any(|(w0, w1)| {
        if !(w0.closed() || w1.closed()) {
            return false;
        }
        let ends = w0.penetration.max(w1.penetration).max(0.0);
        matches!(w0.penetration_segment(w1, h).interior_peak(), Some((_, peak)) if peak > 2.0 * ends)
    })
}

/// Time into the step to land on for the first wall that closes, opens, or touches and leaves
/// again (a grazing contact that both step ends miss), from each wall's Hermite interpolant.
/// A step landing on a closing stops `short` before it, so that it ends open: a law whose force
/// jumps at first touch (Kelvin–Voigt's `c δ̇`) has no Newmark solution exactly at the wall.
fn next_crossing(walls: &[Wall], s0: &State, s1: &State, h: f64, short: f64) -> Option<f64> {
    let mut first: Option<f64> = None;
    for (wall, (w0, w1)) in walls.iter().zip(s0.walls.iter().zip(&s1.walls)) {
        let seg = w0.penetration_segment(w1, h);
        let t = match (w0.closed(), w1.closed()) {
            (false, true) => {
                // Up to the closing the motion is free of this wall: the start state's Taylor
                // polynomial follows it (exactly for a free mass) where the interpolant to an
                // end state that the contact force has already thrown back does not.
                let accel = wall.sign * s0.u_accel[wall.gap];
                let free = first_root(w0.penetration, w0.rate, 0.5 * accel, h);
                Some(free.map_or(seg.crossing(), |tau| (tau / h).min(seg.crossing())) * h - short)
            }
            (true, false) => Some(seg.crossing() * h),
            (true, true) => None,
            // Open at both ends but moving in then out: does the interpolant touch the wall?
            (false, false) => match seg.interior_peak() {
                Some((s_peak, peak)) if peak > 0.0 => {
                    Some(seg.crossing_between(0.0, s_peak) * h - short)
                }
                _ => None,
            },
        };
        if let Some(t) = t {
            first = Some(first.map_or(t, |f: f64| f.min(t)));
        }
    }
    first
}

/// Fraction of the step at which a closed wall reaches the first peak of its penetration
/// since it closed (`pending`; later peaks, of a contact that chatters, are not landed on).
fn next_peak(s0: &State, s1: &State, h: f64, pending: &[bool]) -> Option<f64> {
    s0.walls
        .iter()
        .zip(&s1.walls)
        .zip(pending)
        .filter(|((w0, w1), &p)| p && w0.closed() && w1.closed())
        .filter_map(|((w0, w1), _)| {
            w0.penetration_segment(w1, h)
                .interior_peak()
                .map(|(s, _)| s)
        })
        .min_by(f64::total_cmp)
}

/// Smallest `τ ∈ (0, h]` with `c + b τ + a τ² = 0`, if any.
fn first_root(c: f64, b: f64, a: f64, h: f64) -> Option<f64> {
    let roots = if a == 0.0 {
        [-c / b, f64::NAN]
    } else {
        let disc = b * b - 4.0 * a * c;
        if disc < 0.0 {
            return None;
        }
        let q = -0.5 * (b + b.signum() * disc.sqrt());
        [q / a, c / q]
    };
    roots
        .into_iter()
        .filter(|t| *t > 0.0 && *t <= h)
        .min_by(f64::total_cmp)
}

#[cfg(test)]
mod tests {
    use nalgebra::{DMatrix, DVector};

    use super::*;
    use crate::structure::LinearStructure;

    #[test]
    fn first_root_of_the_free_flight_polynomial() {
        // constant speed: 1 m to go at 1 m/s
        assert_eq!(first_root(-1.0, 1.0, 0.0, 2.0), Some(1.0));
        // from rest under 2 m/s² (a = ½·2): t² = 1
        assert!((first_root(-1.0, 0.0, 1.0, 2.0).unwrap() - 1.0).abs() < 1e-15);
        // the earlier of two roots: −3 + 4τ − τ² = −(τ − 1)(τ − 3)
        assert!((first_root(-3.0, 4.0, -1.0, 5.0).unwrap() - 1.0).abs() < 1e-15);
        // beyond the step, and turning back before the wall
        assert_eq!(first_root(-1.0, 1.0, 0.0, 0.5), None);
        assert_eq!(first_root(-1.0, 1.0, -1.0, 10.0), None);
    }

    fn two_masses(c: f64, k: f64) -> System {
        let coupling = |v: f64| DMatrix::from_row_slice(2, 2, &[v, -v, -v, v]);
        let s = LinearStructure::new(
            DMatrix::from_diagonal(&DVector::from_vec(vec![100.0, 10.0])),
            coupling(c),
            coupling(k),
        )
        .unwrap();
        System::new(s, vec![], vec![]).unwrap()
    }

    #[test]
    fn extrapolation_limit_resolves_the_stiffest_mode() {
        // two masses on a spring: ω² = k (1/m₁ + 1/m₂); the damper's rate c (1/m₁ + 1/m₂)
        let limit = extrapolation_limit(&two_masses(50.0, 1e6));
        let omega = (1e6f64 * (0.01 + 0.1)).sqrt();
        assert!((limit * omega / 0.2 - 1.0).abs() < 1e-12, "{limit}");
        // an overdamped coupling: the damping rate decides
        let limit = extrapolation_limit(&two_masses(1e5, 1e6));
        assert!((limit * 1e5 * 0.11 / 0.2 - 1.0).abs() < 1e-12, "{limit}");
        // free masses: any step
        assert_eq!(extrapolation_limit(&two_masses(0.0, 0.0)), f64::INFINITY);
    }
}
