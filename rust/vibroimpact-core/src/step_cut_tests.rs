//! A rejected or cut step leaves no trace (issue 10, item 2): attempts never mutate the
//! current state, so a run whose every full step is rejected (after a real attempt that also
//! scribbles over the trial state) and then taken as two half steps is identical to a run at
//! the half step.

use nalgebra::{DMatrix, DVector};

use crate::contact::{Hysteretic, Law};
use crate::driver::Run;
use crate::error::SimError;
use crate::gap::{Gap, Side, WallState};
use crate::integrators::{NewmarkFamily, NewmarkStepper, NewtonSettings, StepFailure, Stepper};
use crate::simulate::{simulate, Method, RunSettings};
use crate::step_control::FixedSteps;
use crate::structure::{LinearStructure, Load, LoadHistory};
use crate::system::{State, System};

/// Takes every step of the largest size for real, then wrecks the trial state and reports a
/// failure, so that the driver must cut it.
struct Flaky {
    inner: NewmarkStepper,
    rejected: usize,
}

impl Stepper for Flaky {
    fn attempt(
        &mut self,
        sys: &System,
        from: &State,
        level: usize,
        h: f64,
        to: &mut State,
    ) -> Result<usize, StepFailure> {
        let result = self.inner.attempt(sys, from, level, h, to);
        if level > 0 {
            return result;
        }
        self.rejected += 1;
        to.t = f64::NAN;
        to.x.fill(f64::NAN);
        to.v.fill(1e9);
        to.phi.fill(-7.0);
        for w in to.walls.iter_mut() {
            *w = WallState {
                penetration: 1.0,
                rate: -3.0,
                force: 1e12,
                elastic_force: 1e12,
                potential: 1e6,
                d_penetration: 1.0,
                d_rate: 1.0,
                impact_speed: 42.0,
                max_penetration: 2.0,
                friction: 5.0,
                slip: -1.0,
                slide: 3.0,
            };
        }
        Err(StepFailure {
            gap: 0,
            penetration: 1.0,
            iterations: 1,
            singular: false,
        })
    }

    fn accept(&mut self, sys: &System, state: &State) {
        self.inner.accept(sys, state);
    }
}

fn system() -> System {
    let s = LinearStructure::new(
        DMatrix::from_element(2, 2, 0.0)
            + DMatrix::from_diagonal(&DVector::from_vec(vec![100.0, 10.0])),
        DMatrix::from_row_slice(2, 2, &[50.0, -50.0, -50.0, 50.0]),
        DMatrix::from_row_slice(2, 2, &[1e6, -1e6, -1e6, 1e6]),
    )
    .unwrap();
    let law =
        |ce| Law::Hysteretic(Hysteretic::new("lankarani-nikravesh", 1.5e11, 1.5, ce).unwrap());
    let gaps = vec![
        Gap {
            dofs: vec![0],
            coefficients: vec![1.0],
            clearance: 0.005,
            side: Side::Both,
            law: law(0.9),
        },
        Gap {
            dofs: vec![0, 1],
            coefficients: vec![1.0, -1.0],
            clearance: 0.001,
            side: Side::Both,
            law: law(0.5),
        },
    ];
    System::new(s, gaps, vec![]).unwrap()
}

#[test]
fn cut_steps_equal_a_run_at_the_cut_step_size() {
    let sys = system();
    let (t_end, n_steps) = (0.02, 1000);
    let x0 = DVector::zeros(2);
    let v0 = DVector::from_vec(vec![8.0, -3.0]);
    let scheme = NewmarkFamily::average_acceleration();
    let newton = NewtonSettings::default();

    let h0 = t_end / n_steps as f64;
    let mut flaky = Flaky {
        inner: NewmarkStepper::new(&sys, scheme, newton).unwrap(),
        rejected: 0,
    };
    flaky.inner.prepare(&sys, h0).unwrap();
    let mut run = Run::new(&sys, x0.clone(), v0.clone(), vec![0, 1], n_steps + 2).unwrap();
    let error = run.drive(&sys, &mut FixedSteps::new(&mut flaky, h0, n_steps, 1), 1);
    assert!(error.is_none(), "{error:?}");
    assert_eq!(flaky.rejected, n_steps);
    assert_eq!(run.stats.step_cuts, n_steps);
    assert_eq!(run.stats.steps, 2 * n_steps);

    let settings = RunSettings {
        t_end,
        dt: t_end / (2 * n_steps) as f64,
        every: 1,
        record_dofs: vec![0, 1],
        newton,
        adaptive: None,
    };
    let reference = simulate(&sys, Method::Newmark(scheme), &settings, x0, v0).unwrap();
    assert!(reference.error.is_none());
    assert_eq!(reference.stats.steps, 2 * n_steps);

    // the same trajectory, bit for bit, and the same impact table (times, and the peaks
    // interpolated in time, to the last bits of the step instants)
    let last = reference.rows.time.len() - 1;
    assert_eq!(run.cur.x[..], reference.rows.displacement[2 * last..]);
    assert_eq!(run.cur.v[..], reference.rows.velocity[2 * last..]);
    let ours = &run.log.as_ref().unwrap().records;
    assert!(ours.len() >= 4, "{} impacts", ours.len());
    assert_eq!(ours.len(), reference.impacts.len());
    let close =
        |x: f64, y: f64| (x - y).abs() <= 1e-12 * y.abs().max(1e-12) || (x.is_nan() && y.is_nan());
    for (a, b) in ours.iter().zip(&reference.impacts) {
        assert_eq!((a.gap, a.side), (b.gap, b.side));
        for (x, y) in [
            (a.t_start, b.t_start),
            (a.t_end, b.t_end),
            (a.v_in, b.v_in),
            (a.v_out, b.v_out),
            (a.delta_max, b.delta_max),
            (a.force_max, b.force_max),
            (a.impulse, b.impulse),
        ] {
            assert!(close(x, y), "{a:?}\n{b:?}");
        }
    }
    // the peaks: per commit from the first cut on, from the rows in the uncut reference
    let out = run.finish(&sys, None, h0, std::time::Instant::now(), None);
    assert_eq!(out.max_abs_displacement, reference.max_abs_displacement);
    assert!(out.max_abs_displacement.iter().all(|&m| m > 0.0));
}

/// Finds the effective stiffness singular for every step from `t_fail` on, whatever its
/// size (as a structure whose stiffness cancels the inertia term would).
struct SingularFrom {
    inner: NewmarkStepper,
    t_fail: f64,
    attempts_after: usize,
}

impl Stepper for SingularFrom {
    fn attempt(
        &mut self,
        sys: &System,
        from: &State,
        level: usize,
        h: f64,
        to: &mut State,
    ) -> Result<usize, StepFailure> {
        if from.t >= self.t_fail {
            self.attempts_after += 1;
            return Err(StepFailure::singular_tangent());
        }
        self.inner.attempt(sys, from, level, h, to)
    }

    fn accept(&mut self, sys: &System, state: &State) {
        self.inner.accept(sys, state);
    }
}

/// A singular operator met mid-run, after the step cuts, is reported as such (with the time
/// and the smallest step tried), not as a Newton failure, and the steps before it are kept.
#[test]
fn singular_operator_mid_run_is_reported_with_its_time() {
    let sys = system();
    let (h0, n_steps, max_cuts) = (1e-5, 100, 2);
    let mut stepper = SingularFrom {
        inner: NewmarkStepper::new(
            &sys,
            NewmarkFamily::average_acceleration(),
            NewtonSettings::default(),
        )
        .unwrap(),
        t_fail: 40.5 * h0,
        attempts_after: 0,
    };
    stepper.inner.prepare(&sys, h0).unwrap();
    let x0 = DVector::zeros(2);
    let v0 = DVector::from_vec(vec![1.0, -1.0]);
    let mut run = Run::new(&sys, x0, v0, vec![0, 1], n_steps + 2).unwrap();
    let error = run.drive(
        &sys,
        &mut FixedSteps::new(&mut stepper, h0, n_steps, max_cuts),
        1,
    );
    match &error {
        Some(SimError::SingularTangent { t, dt }) => {
            assert!((t - 41.0 * h0).abs() < 1e-15, "{t}");
            assert_eq!(*dt, h0 / 4.0);
        }
        other => panic!("expected a singular tangent, got {other:?}"),
    }
    // one attempt per level: h0, the first h0/2, the first h0/4
    assert_eq!(stepper.attempts_after, 1 + max_cuts);
    assert_eq!(run.stats.steps, 41);
    let message = error.expect("checked above").to_string();
    assert!(
        message.contains("singular for dt = 2.500e-6 s at t = 4.1"),
        "{message}"
    );
    assert!(message.contains("on no gap"), "{message}");
}

/// A chain of `n` masses on springs with Rayleigh damping, a Lankarani–Nikravesh gap on the
/// first DOF (`side`) and a harmonic load on the last.
fn damped_chain(n: usize, side: Side) -> System {
    let (mut m, mut k) = (DMatrix::zeros(n, n), DMatrix::zeros(n, n));
    for i in 0..n {
        m[(i, i)] = 1.0 + 0.3 * i as f64;
        k[(i, i)] += 4e4;
        if i + 1 < n {
            k[(i, i)] += 1e5;
            k[(i + 1, i + 1)] += 1e5;
            k[(i, i + 1)] -= 1e5;
            k[(i + 1, i)] -= 1e5;
        }
    }
    let c = &m * 2.0 + &k * 2e-4;
    let gap = Gap {
        dofs: vec![0],
        coefficients: vec![1.0],
        clearance: 1e-3,
        side,
        law: Law::Hysteretic(Hysteretic::new("lankarani-nikravesh", 1e9, 1.5, 0.8).unwrap()),
    };
    let load = Load {
        dofs: vec![n - 1],
        amplitude: 40.0,
        history: LoadHistory::Harmonic {
            frequency: 35.0,
            phase: 0.2,
        },
    };
    System::new(
        LinearStructure::new(m, c, k).unwrap(),
        vec![gap],
        vec![load],
    )
    .unwrap()
}

/// The fixed-step loop compiled for the Newmark stepper's type (what `simulate` runs) and the
/// same loop through `dyn Stepper` take the same steps, to the bit: every recorded row (the
/// energy account's columns included), the peaks, the statistics and the impact table, on 1-
/// to 4-DOF damped chains with a load and a one- or two-sided gap, with Newmark and
/// generalized-α.
#[test]
fn compiled_fixed_step_loop_equals_the_dyn_loop() {
    let alpha = NewmarkFamily {
        alpha_m: 0.6 / 1.8,
        alpha_f: 0.8 / 1.8,
        gamma: 0.5 - 0.6 / 1.8 + 0.8 / 1.8,
        beta: 0.25 * (1.0 - 0.6 / 1.8 + 0.8 / 1.8) * (1.0 - 0.6 / 1.8 + 0.8 / 1.8),
    };
    for n in 1..=4 {
        for side in [Side::Positive, Side::Both] {
            let sys = damped_chain(n, side);
            for scheme in [NewmarkFamily::average_acceleration(), alpha] {
                let (t_end, n_steps) = (0.05, 5000);
                let h0 = t_end / n_steps as f64;
                let newton = NewtonSettings::default();
                let v0 = DVector::from_fn(n, |i, _| 0.5 - 0.2 * i as f64);
                let settings = RunSettings {
                    t_end,
                    dt: h0,
                    every: 1,
                    record_dofs: (0..n).collect(),
                    newton,
                    adaptive: None,
                };
                let method = if scheme.alpha_m == 0.0 {
                    Method::Newmark(scheme)
                } else {
                    Method::GeneralizedAlpha(scheme)
                };
                let x0 = DVector::zeros(n);
                let compiled = simulate(&sys, method, &settings, x0.clone(), v0.clone()).unwrap();
                assert_eq!(compiled.rows.time.len(), n_steps + 1);
                assert!(
                    compiled.impacts.len() >= 2,
                    "{n} DOFs: {:?}",
                    compiled.impacts
                );

                let mut stepper = NewmarkStepper::new(&sys, scheme, newton).unwrap();
                stepper.expect_steps(n_steps);
                stepper.prepare(&sys, h0).unwrap();
                let general: &mut dyn Stepper = &mut stepper;
                let mut run = Run::new(&sys, x0, v0, (0..n).collect(), n_steps + 2).unwrap();
                let mut policy = FixedSteps::new(general, h0, n_steps, newton.max_step_cuts);
                let error = run.drive(&sys, &mut policy, 1);
                assert!(error.is_none(), "{error:?}");
                let started = std::time::Instant::now();
                let out = run.finish(&sys, None, h0, started, None);
                assert_eq!(out.rows, compiled.rows, "{n} DOFs, {side:?}, {scheme:?}");
                assert_eq!(out.max_abs_displacement, compiled.max_abs_displacement);
                assert_eq!(out.stats.steps, compiled.stats.steps);
                // (Debug: the open contact's NaN end compares equal, every float exactly)
                assert_eq!(
                    format!("{:?}", out.impacts),
                    format!("{:?}", compiled.impacts)
                );
            }
        }
    }
}
