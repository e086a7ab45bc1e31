//! Adaptive stepping for the Newmark family (DESIGN.md §4): a local error estimate, step
//! growth in free flight and reduction in contact, and every gap's closing and opening
//! located inside the step and landed on, so that no contact is stepped over and `v_imp`,
//! `t_start`, `t_end` and `v_out` come from a step that ends at the event.
//!
//! Step sizes are `dt_max / 2^(k/4)` (quarter octaves, so the factorised operators are cached
//! per `k`, never built per step), except for the steps that land on an event or on `t_end`, whose operator is
//! built for that one size.

use crate::error::{invalid, SimError};
use crate::integrators::{Stepper, ANY_LEVEL};
use crate::interpolation::HermiteSegment;
use crate::simulate::{Method, Run};
use crate::system::{State, System};

/// Cached step sizes per halving of the step.
const LEVELS_PER_OCTAVE: f64 = 4.0;

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

/// Adaptive stepping, validated and resolved against the run's duration.
pub(crate) struct StepControl {
    tol: Adaptive,
    pub dt_max: f64,
    /// `dt_max / 2^(levels/4)` ≤ `dt_min`.
    levels: usize,
    first_level: usize,
    /// `β − 1/6`: the Zienkiewicz–Xie (1991) local error is `(β − 1/6) h² (a₁ − a₀)`.
    error_constant: f64,
    t_end: f64,
}

impl StepControl {
    pub fn new(tol: Adaptive, method: Method, t_end: f64, dt: f64) -> Result<Self, SimError> {
        let Method::NewmarkFamily(scheme) = method else {
            return invalid(
                "solver.adaptive: true is not valid for this method; expected adaptive = false \
                 (adaptive stepping is available for the Newmark family)",
            );
        };
        for (name, v) in [("rtol", tol.rtol), ("atol", tol.atol)] {
            if !(v.is_finite() && v >= 0.0) {
                return invalid(format!(
                    "solver.{name}: {v} is not valid; expected a tolerance >= 0"
                ));
            }
        }
        if tol.rtol == 0.0 && tol.atol == 0.0 {
            return invalid("solver.rtol: 0 with atol = 0 is not valid; expected a tolerance > 0");
        }
        if !(tol.dt_min.is_finite() && tol.dt_min > 0.0) {
            return invalid(format!(
                "solver.dt_min: {} is not valid; expected a step > 0 in s",
                tol.dt_min
            ));
        }
        if !(tol.dt_max.is_finite() && tol.dt_max >= tol.dt_min && tol.dt_max <= t_end) {
            return invalid(format!(
                "solver.dt_max: {} is not valid; expected dt_min <= dt_max <= t_end ({} to {t_end} s)",
                tol.dt_max, tol.dt_min
            ));
        }
        let dt_max = t_end / (t_end / tol.dt_max - 1e-9).ceil();
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

    /// Runs to `t_end`. Returns the error that stopped the run, if any.
    pub fn run(
        &self,
        run: &mut Run,
        sys: &System,
        stepper: &mut dyn Stepper,
        every: usize,
    ) -> Option<SimError> {
        let mut level = self.first_level;
        // Events closer than this to a step's ends are not landed on separately.
        let event_tol = (self.step(self.levels) * 1e-3).max(1e-15 * self.t_end);
        let mut accepted = 0usize;
        let mut landing: Option<f64> = None;
        // Acceleration and length of the previous accepted step, for the velocity error.
        let mut a_prev = run.cur.a.clone();
        let mut h_prev: Option<f64> = None;
        while self.t_end - run.cur.t > 1e-13 * self.t_end {
            let remaining = self.t_end - run.cur.t;
            let (mut h, mut key) = (self.step(level), level);
            if let Some(h_event) = landing.take() {
                (h, key) = (h_event, ANY_LEVEL);
            }
            if h >= remaining * (1.0 - 1e-12) {
                (h, key) = (remaining, ANY_LEVEL);
            }
            let iterations = match stepper.attempt(sys, &run.cur, key, h, &mut run.trial) {
                Ok(it) => it,
                Err(failure) => {
                    run.stats.rejected_steps += 1;
                    run.stats.newton_iterations += failure.iterations;
                    if h > self.step(self.levels) * (1.0 + 1e-12) {
                        run.stats.step_cuts += 1;
                        level = (self.level_for(h) + 1).min(self.levels);
                        continue;
                    }
                    // Newton failing on a blown-up state: report the blow-up
                    if let Err(e) = run.check_energy(sys) {
                        return Some(e);
                    }
                    return Some(SimError::NewtonFailed {
                        t: run.cur.t,
                        gap: failure.gap,
                        penetration: failure.penetration,
                        iterations: failure.iterations,
                        dt: h,
                    });
                }
            };
            // Land on the earliest gap event inside the step.
            if let Some(theta) = earliest_event(&run.cur, &run.trial, h) {
                let h_event = theta * h;
                if h_event > event_tol && h - h_event > event_tol {
                    run.stats.newton_iterations += iterations;
                    landing = Some(h_event);
                    continue;
                }
            }
            let mut err = self.error(&run.cur, &run.trial, h, h_prev.map(|hp| (&a_prev[..], hp)));
            if unresolved_contact(&run.cur, &run.trial, h) {
                err = err.max(8.0);
            }
            if err > 1.0 && h > self.step(self.levels) * (1.0 + 1e-12) {
                run.stats.rejected_steps += 1;
                run.stats.newton_iterations += iterations;
                let shrink = (0.9 * err.powf(-1.0 / 3.0)).clamp(0.1, 0.5);
                level = self
                    .level_for(h * shrink)
                    .max(self.level_for(h) + 1)
                    .min(self.levels);
                continue;
            }
            a_prev.copy_from_slice(&run.cur.a);
            // the acceleration history is not smooth across a contact event
            let event_at_end = run
                .cur
                .walls
                .iter()
                .zip(&run.trial.walls)
                .any(|(w0, w1)| w0.closed() != w1.closed());
            h_prev = if event_at_end { None } else { Some(h) };
            if let Err(e) = run.accept(sys, stepper, h, iterations) {
                return Some(e);
            }
            accepted += 1;
            if accepted % every == 0 {
                run.out.record(sys, &run.cur, &run.account);
            }
            let grow = if err > 0.0 {
                (0.9 * err.powf(-1.0 / 3.0)).clamp(0.2, 4.0)
            } else {
                4.0
            };
            level = self.level_for(h * grow);
        }
        if accepted % every != 0 {
            run.out.record(sys, &run.cur, &run.account);
        }
        None
    }
}

/// A wall in contact at either end of the step whose interpolated penetration peaks inside
/// the step well above both ends: the step is longer than the contact can be resolved with
/// (a short, grazing contact), so the peak and the force history would be lost.
fn unresolved_contact(s0: &State, s1: &State, h: f64) -> bool {
    s0.walls.iter().zip(&s1.walls).any(|(w0, w1)| {
        if !(w0.closed() || w1.closed()) {
            return false;
        }
        let seg = HermiteSegment {
            y0: w0.penetration,
            dy0: w0.rate,
            y1: w1.penetration,
            dy1: w1.rate,
            h,
        };
        let ends = w0.penetration.max(w1.penetration).max(0.0);
        matches!(seg.interior_peak(), Some((_, peak)) if peak > 2.0 * ends)
    })
}

/// Fraction of the step at which the first wall opens, closes, or touches and leaves again
/// (a grazing contact that both step ends miss), from each wall's Hermite interpolant.
fn earliest_event(s0: &State, s1: &State, h: f64) -> Option<f64> {
    let mut first: Option<f64> = None;
    for (w0, w1) in s0.walls.iter().zip(&s1.walls) {
        let seg = HermiteSegment {
            y0: w0.penetration,
            dy0: w0.rate,
            y1: w1.penetration,
            dy1: w1.rate,
            h,
        };
        let theta = if w0.closed() != w1.closed() {
            Some(seg.crossing())
        } else if w0.closed() {
            None
        } else {
            // Open at both ends but moving in then out: does the interpolant touch the wall?
            match seg.interior_peak() {
                Some((s_peak, peak)) if peak > 0.0 => Some(seg.crossing_between(0.0, s_peak)),
                _ => None,
            }
        };
        if let Some(t) = theta {
            first = Some(first.map_or(t, |f: f64| f.min(t)));
        }
    }
    first
}
