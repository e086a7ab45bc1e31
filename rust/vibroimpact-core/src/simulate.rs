//! The entry points of a run (docs/architecture.md, docs/conventions.md): checks the settings,
//! picks the step policy of the [`Method`] and drives it. A [`Sink`] (`simulate_streamed`)
//! takes the recorded rows in blocks while the run goes on (long runs stream to disk), follows
//! its progress and receives its solver [`Event`]s; a [`StepObserver`] (`simulate_observed`)
//! sees every accepted step. The shared run types live in their own modules and are
//! re-exported here, the public path of a run's API.

use std::time::Instant;

use nalgebra::DVector;

use crate::driver::Run;
use crate::error::{invalid, SimError};
use crate::impulsive::{EventDrivenSteps, MoreauJeanSteps};
use crate::integrators::dop853::{Dop853Steps, Steps};
use crate::integrators::sized::by_size;
use crate::integrators::{
    BatheStepper, NewmarkStepper, NewmarkTransition, NewtonSettings, PreciseStepper, SizedNewmark,
    Stepper,
};
use crate::method_catalog;
use crate::sensitivity::Parameter;
use crate::step_control::{AdaptiveSteps, FixedSteps, StepControl};
use crate::system::System;

pub use crate::method::Method;
pub use crate::observe::{Event, Sink, StepObserver, Turn};
pub use crate::output::{BalanceError, EnergyHistory, Rows, RunOutput, Stats};
pub use crate::settings::{Adaptive, Outputs, RunSettings};

/// The most rows an adaptive run reserves before its first step.
const MAX_RESERVED_ROWS: usize = 1024;

/// Runs `sys` from `x0, v0` at `t = 0`. Invalid settings are refused before the run; a
/// failure during the run is returned in `RunOutput::error` with the results up to then.
pub fn simulate(
    sys: &System,
    method: Method,
    settings: &RunSettings,
    x0: DVector<f64>,
    v0: DVector<f64>,
) -> Result<RunOutput, SimError> {
    simulate_observed(sys, method, settings, x0, v0, None, Outputs::All)
}

/// [`simulate`], with `observer` called on every accepted step (and on every rigid impact of
/// the impulsive methods); `outputs`: what the run computes besides (a sweep point needs only
/// its observer's, [`Outputs::Observed`]; without an observer, everything).
pub fn simulate_observed(
    sys: &System,
    method: Method,
    settings: &RunSettings,
    x0: DVector<f64>,
    v0: DVector<f64>,
    observer: Option<&mut dyn StepObserver>,
    outputs: Outputs,
) -> Result<RunOutput, SimError> {
    let observer = observer.map(|o| (o, outputs));
    run_watched(sys, method, settings, x0, v0, observer, None, None)
}

/// [`simulate_observed`], carrying the state-transition matrix `∂(x, v)(t_end)/∂(x₀, v₀)`
/// along (`RunOutput::state_transition`; `crate::sensitivity`): DOP853, the event-driven
/// method and the Newmark family at fixed steps, refused before the run for the others
/// (`sensitivity::check_supported`); with `parameter`, its column `∂z(t_end)/∂p` beside it
/// (DOP853 and the Newmark family; the event-driven method for a clearance:
/// `sensitivity::parameter_for`).
pub fn simulate_with_sensitivity(
    sys: &System,
    method: Method,
    settings: &RunSettings,
    x0: DVector<f64>,
    v0: DVector<f64>,
    parameter: Option<Parameter>,
    observer: Option<&mut dyn StepObserver>,
) -> Result<RunOutput, SimError> {
    crate::sensitivity::check_supported(sys, method, settings.adaptive.is_some())?;
    if let Some(p) = parameter.filter(|&p| !crate::sensitivity::carries_parameter(sys, method, p)) {
        return invalid(format!(
            "solver.method: '{}' does not carry the column of {p:?}; expected 'dop853' or the \
             Newmark family (or 'event-driven' for a gap's clearance, or a load's with constant and \
             harmonic loads only)",
            method.name()
        ));
    }
    run_watched(
        sys,
        method,
        settings,
        x0,
        v0,
        observer.map(|o| (o, Outputs::All)),
        None,
        Some(parameter),
    )
}

/// [`simulate`], with `sink` taking the recorded rows in blocks of `sink.chunk_rows()` as they
/// are recorded (the returned [`RunOutput`] then holds only the rows recorded after the last
/// block, at least the last one; the impact table, the peaks and the statistics are whole),
/// following the simulated time and receiving the solver events. [`BalanceError`] gives the
/// energy balance error over all the blocks.
pub fn simulate_streamed(
    sys: &System,
    method: Method,
    settings: &RunSettings,
    x0: DVector<f64>,
    v0: DVector<f64>,
    sink: &mut dyn Sink,
) -> Result<RunOutput, SimError> {
    run_watched(sys, method, settings, x0, v0, None, Some(sink), None)
}

#[allow(clippy::too_many_arguments)]
fn run_watched<'o>(
    sys: &System,
    method: Method,
    settings: &RunSettings,
    x0: DVector<f64>,
    v0: DVector<f64>,
    observer: Option<(&'o mut dyn StepObserver, Outputs)>,
    sink: Option<&'o mut dyn Sink>,
    sensitivity: Option<Option<Parameter>>,
) -> Result<RunOutput, SimError> {
    let started = Instant::now();
    let RunSettings {
        t_end,
        dt,
        every,
        ref record_dofs,
        newton,
        adaptive,
    } = *settings;
    if !(t_end.is_finite() && t_end > 0.0) {
        return invalid(format!(
            "solver.t_end: {t_end} is not valid; expected a duration > 0 in s"
        ));
    }
    if !(dt.is_finite() && dt > 0.0) {
        return invalid(format!(
            "solver.dt: {dt} is not valid; expected a step > 0 in s"
        ));
    }
    if dt > t_end {
        return invalid(format!(
            "solver.dt: {dt} is larger than solver.t_end = {t_end}; expected dt <= t_end"
        ));
    }
    if every == 0 {
        return invalid("output.every: 0 is not valid; expected an integer >= 1");
    }
    let n = sys.n_dof();
    if let Some(d) = record_dofs.iter().find(|&&d| d >= n) {
        return invalid(format!(
            "output.dofs: {d} is out of range; expected 0 <= dof < {n}"
        ));
    }
    // Rigid gaps (massless bar) are for the impulsive methods only, and they take no others.
    method.check_laws(sys)?;
    // a run-up's gyroscopic forces Ω(t) G change the implicit methods' effective matrix
    if sys.structure.varying_gyroscopic().is_some() && !matches!(method, Method::Dop853) {
        return invalid(format!(
            "structure.spin_profile: a run-up of a rotor with gyroscopic forces is not available \
             with method '{}' (its effective matrix would change with Ω(t)); expected \
             solver.method = 'dop853'",
            method.name()
        ));
    }
    method_catalog::entry_of(&method).check_adaptive(adaptive.is_some())?;
    // Fixed steps: dt is shortened so that t_end is a whole number of steps. Adaptive steps:
    // the cached sizes are dt_max / 2^k, with dt_max likewise a whole fraction of t_end.
    let explicit = matches!(method, Method::Dop853);
    let control = match adaptive {
        Some(a) if !explicit => {
            let scheme = method
                .newmark_family()
                .expect("the implicit methods that step adaptively are the Newmark family's");
            Some(StepControl::new(a, scheme, t_end, dt)?)
        }
        _ => None,
    };
    let n_steps_f = (t_end / dt - 1e-9).ceil();
    if adaptive.is_none() && n_steps_f > 1e10 {
        return invalid(format!(
            "solver.dt: {dt} gives {n_steps_f:.3e} steps for t_end = {t_end}; expected at most 1e10"
        ));
    }
    let n_steps = n_steps_f as usize;
    let explicit_steps = match adaptive {
        _ if !explicit => None,
        Some(tol) => Some(Steps::Adaptive {
            tol,
            dt_max: tol.checked_dt_max(t_end)?,
            first: dt,
        }),
        None => Some(Steps::Fixed(t_end / n_steps as f64)),
    };
    let h0 = match (&control, &explicit_steps) {
        (Some(c), _) => c.dt_max,
        (_, Some(Steps::Adaptive { dt_max, .. })) => *dt_max,
        _ => t_end / n_steps as f64,
    };
    let max_levels = match &control {
        Some(c) => c.levels(),
        None => newton.max_step_cuts,
    };

    // rows reserved: fixed steps, every one; adaptive steps, one per longest step up to
    // MAX_RESERVED_ROWS (the buffers grow past it), so that a short run reserves little
    let n_rec = if adaptive.is_some() {
        ((t_end / h0).ceil() as usize / every + 2).min(MAX_RESERVED_ROWS)
    } else {
        n_steps / every + 2
    };
    let mut run = Run::new(sys, x0, v0, record_dofs.clone(), n_rec)?;
    if let Some((observer, outputs)) = observer {
        run.observe(observer);
        if outputs == Outputs::Observed {
            run.keep_only_observed(sys);
        }
    }
    run.wants_sensitivity = sensitivity.is_some();
    run.sensitivity_parameter = sensitivity.flatten();
    if let Some(sink) = sink {
        run.watch(sink);
    }
    let mut impacts = None;
    let error = match (explicit_steps, method) {
        (Some(steps), _) => {
            let mut policy = Dop853Steps::new(&run, sys, steps, t_end);
            run.drive(sys, &mut policy, every)
        }
        // the impulsive methods keep their own impact table: an impact is an instant
        (None, Method::EventDriven(m)) => {
            run.log = None;
            let mut policy = EventDrivenSteps::new(&mut run, sys, m, n_steps, h0)?;
            let error = run.drive(sys, &mut policy, every);
            impacts = Some(policy.impacts());
            error
        }
        (None, Method::MoreauJean(m)) => {
            run.log = None;
            let mut policy = MoreauJeanSteps::new(&run, sys, m, n_steps, h0)?;
            let error = run.drive(sys, &mut policy, every);
            impacts = Some(policy.impacts());
            error
        }
        (None, _) => {
            // Every stepper caches one operator per level of the step cuts (or adaptive sizes).
            let cut_newton = NewtonSettings {
                max_step_cuts: max_levels,
                ..newton
            };
            match stepper(sys, method, cut_newton, h0, (t_end / h0).round() as usize) {
                // A singular tangent is a solver failure at t = 0: the initial state is the result.
                Err(e @ SimError::SingularTangent { .. }) => Some(e),
                Err(e) => return Err(e),
                Ok(mut stepper) => {
                    run.report_linear_solver(stepper.as_dyn(), h0);
                    run.stats.step_path = stepper.as_dyn().step_path(sys);
                    let cuts = newton.max_step_cuts;
                    match (&control, &mut stepper) {
                        (None, Implicit::Newmark(s)) => by_size!(sys.n_dof(), |N| fixed_steps(
                            &mut run,
                            sys,
                            method,
                            &mut SizedNewmark::<N>(s.as_mut()),
                            h0,
                            n_steps,
                            cuts,
                            every,
                        ))?,
                        (None, Implicit::Other(s)) => fixed_steps(
                            &mut run,
                            sys,
                            method,
                            s.as_mut(),
                            h0,
                            n_steps,
                            cuts,
                            every,
                        )?,
                        (Some(c), s) => {
                            let mut policy = AdaptiveSteps::new(c, s.as_dyn(), &run, sys);
                            run.drive(sys, &mut policy, every)
                        }
                    }
                }
            }
        }
    };
    Ok(run.finish(sys, error, h0, started, impacts))
}

/// The stepper of an implicit or precise method: the Newmark family's by its type, so that
/// the fixed-step loop is compiled for it ([`FixedSteps`]), the others behind `dyn`.
enum Implicit {
    Newmark(Box<NewmarkStepper>),
    Other(Box<dyn Stepper>),
}

impl Implicit {
    fn as_dyn(&mut self) -> &mut dyn Stepper {
        match self {
            Implicit::Newmark(s) => s.as_mut(),
            Implicit::Other(s) => s.as_mut(),
        }
    }
}

/// Drives `run` with fixed steps of `h0` (cut up to `max_cuts` times) taken by `stepper`,
/// carrying the state-transition matrix along when the run wants it (the Newmark family).
#[allow(clippy::too_many_arguments)]
fn fixed_steps<S: Stepper + ?Sized>(
    run: &mut Run,
    sys: &System,
    method: Method,
    stepper: &mut S,
    h0: f64,
    n_steps: usize,
    max_cuts: usize,
    every: usize,
) -> Result<Option<SimError>, SimError> {
    let mut policy = FixedSteps::new(stepper, h0, n_steps, max_cuts);
    Ok(match method.newmark_family() {
        Some(scheme) if run.wants_sensitivity => {
            let parameter = run.sensitivity_parameter;
            let transition = NewmarkTransition::new(sys, scheme, &run.cur, parameter)?;
            run.drive(sys, &mut policy.with_derivative(transition), every)
        }
        _ => run.drive(sys, &mut policy, every),
    })
}

/// The stepper of an implicit or precise `method`, its operators prepared for steps of `h0`
/// and chosen for a run of about `steps` of them (adaptive runs: at least that many).
fn stepper(
    sys: &System,
    method: Method,
    newton: NewtonSettings,
    h0: f64,
    steps: usize,
) -> Result<Implicit, SimError> {
    Ok(match method {
        Method::Newmark(scheme) | Method::GeneralizedAlpha(scheme) | Method::Hht(scheme) => {
            let mut s = NewmarkStepper::new(sys, scheme, newton)?;
            s.expect_steps(steps);
            s.prepare(sys, h0)?;
            Implicit::Newmark(Box::new(s))
        }
        Method::Precise(variant) => {
            let mut s = PreciseStepper::new(sys, variant, newton)?;
            s.prepare(sys, h0)?;
            Implicit::Other(Box::new(s))
        }
        Method::Bathe(scheme) => {
            let mut s = BatheStepper::new(sys, scheme, newton)?;
            s.prepare(sys, h0)?;
            Implicit::Other(Box::new(s))
        }
        Method::EventDriven(_) | Method::MoreauJean(_) | Method::Dop853 => {
            unreachable!("the impulsive and explicit methods have no stepper")
        }
    })
}

#[cfg(test)]
mod tests {
    use nalgebra::{DMatrix, DVector};

    use super::*;
    use crate::contact::{Hysteretic, Law};
    use crate::gap::{Gap, Side};
    use crate::integrators::{NewmarkFamily, PreciseIntegration};
    use crate::interrupt;
    use crate::structure::LinearStructure;

    /// The paper's SDOF case: 1 kg on 4 kN/m, 3 mm clearances both sides, 8 m/s at t = 0.
    fn sdof() -> System {
        let s = LinearStructure::new(
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::from_element(1, 1, 0.0),
            DMatrix::from_element(1, 1, 4.0e3),
        )
        .unwrap();
        let law =
            Law::Hysteretic(Hysteretic::new("lankarani-nikravesh", 1.5e11, 1.5, 0.5).unwrap());
        let gap = Gap {
            dofs: vec![0],
            coefficients: vec![1.0],
            clearance: 0.003,
            side: Side::Both,
            law,
        };
        System::new(s, vec![gap], vec![]).unwrap()
    }

    #[derive(Default)]
    struct Collect {
        chunk: Option<usize>,
        events: bool,
        blocks: Vec<Rows>,
        seen: Vec<Event>,
        progress: Vec<f64>,
    }

    impl Sink for Collect {
        fn chunk_rows(&self) -> Option<usize> {
            self.chunk
        }
        fn rows(&mut self, rows: Rows) {
            self.blocks.push(rows);
        }
        fn wants_events(&self) -> bool {
            self.events
        }
        fn event(&mut self, event: Event) {
            self.seen.push(event);
        }
        fn progress(&mut self, t: f64) {
            self.progress.push(t);
        }
    }

    fn settings(dt: f64, adaptive: Option<Adaptive>, max_iterations: usize) -> RunSettings {
        RunSettings {
            t_end: 0.02,
            dt,
            every: 3,
            record_dofs: vec![0],
            newton: NewtonSettings {
                max_iterations,
                ..NewtonSettings::default()
            },
            adaptive,
        }
    }

    #[test]
    fn streamed_blocks_are_the_whole_run() {
        let sys = sdof();
        let method = Method::Newmark(NewmarkFamily::average_acceleration());
        let adaptive = Adaptive {
            rtol: 1e-4,
            atol: 1e-9,
            dt_min: 1e-9,
            dt_max: 1e-4,
        };
        // 6668 rows at fixed steps: blocks of 40 and 28 left; blocks of 1667, a divisor: the
        // last block stays in the output (it is handed over only when a next row comes)
        let fixed = settings(1e-6, None, 25);
        for (s, chunk) in [
            (fixed.clone(), 40),
            (fixed, 1667),
            (settings(1e-6, Some(adaptive), 25), 40),
        ] {
            let (x0, v0) = (DVector::zeros(1), DVector::from_element(1, 8.0));
            let whole = simulate(&sys, method, &s, x0.clone(), v0.clone()).unwrap();
            let mut sink = Collect {
                chunk: Some(chunk),
                ..Collect::default()
            };
            let rest = simulate_streamed(&sys, method, &s, x0, v0, &mut sink).unwrap();
            assert!(
                sink.blocks.len() >= 3 && (1..=chunk).contains(&rest.rows.time.len()),
                "{} blocks, {} rows left, {} rows",
                sink.blocks.len(),
                rest.rows.time.len(),
                whole.rows.time.len()
            );
            let mut all = sink.blocks.clone();
            all.push(Rows {
                time: rest.rows.time.clone(),
                displacement: rest.rows.displacement.clone(),
                velocity: rest.rows.velocity.clone(),
                acceleration: rest.rows.acceleration.clone(),
                gap_penetration: rest.rows.gap_penetration.clone(),
                gap_force: rest.rows.gap_force.clone(),
                energy: rest.rows.energy.clone(),
            });
            let cat = |f: &dyn Fn(&Rows) -> &Vec<f64>| -> Vec<f64> {
                all.iter().flat_map(|r| f(r).iter().copied()).collect()
            };
            assert!(all[..all.len() - 1].iter().all(|r| r.time.len() == chunk));
            if chunk == 1667 {
                assert_eq!((whole.rows.time.len(), rest.rows.time.len()), (6668, 1667));
            }
            assert_eq!(cat(&|r| &r.time), whole.rows.time);
            assert_eq!(cat(&|r| &r.displacement), whole.rows.displacement);
            assert_eq!(cat(&|r| &r.acceleration), whole.rows.acceleration);
            assert_eq!(cat(&|r| &r.gap_force), whole.rows.gap_force);
            assert_eq!(
                cat(&|r| &r.energy.external_work),
                whole.rows.energy.external_work
            );
            let mut balance = BalanceError::default();
            for r in &all {
                balance.add(&r.energy);
            }
            assert_eq!(balance.value(), whole.rows.energy.relative_balance_error());
            assert_eq!(rest.impacts, whole.impacts);
            assert_eq!(rest.max_abs_displacement, whole.max_abs_displacement);
            // progress: increasing, every 64 steps, ending at t_end
            assert!(sink.progress.windows(2).all(|w| w[0] <= w[1]));
            // every = 3: at least 3 accepted steps between recorded rows (stats.steps of an
            // adaptive run also counts the halves of its doubled steps, so it is not used here)
            let accepted = 3 * (whole.rows.time.len() - 2);
            assert!(sink.progress.len() >= accepted / interrupt::CHECK_EVERY);
            assert!((sink.progress.last().unwrap() - 0.02).abs() < 1e-12);
            assert!(sink.seen.is_empty(), "events were not asked for");
        }
    }

    /// The fixed-step loop's free runs of the Newmark family and of precise integration's
    /// Adams steps (every step recorded, nothing watched per step: `Run::drive`) take the
    /// general step's steps: the paper's case recorded every step (free runs between the
    /// contacts) and every second step (the general step throughout) has the same rows at the
    /// same steps, to the bit, and the same impacts, peaks, energy balance and statistics.
    #[test]
    fn free_runs_take_the_general_steps() {
        let sys = sdof();
        for method in [
            Method::Newmark(NewmarkFamily::average_acceleration()),
            Method::Precise(PreciseIntegration::default()),
        ] {
            let run = |every: usize| {
                let s = RunSettings {
                    every,
                    ..settings(1e-6, None, 25)
                };
                let (x0, v0) = (DVector::zeros(1), DVector::from_element(1, 8.0));
                simulate(&sys, method, &s, x0, v0).unwrap()
            };
            let (each, second) = (run(1), run(2));
            assert!(each.error.is_none() && second.error.is_none(), "{method:?}");
            assert!(
                each.impacts.len() >= 5,
                "{method:?}: {} impacts: free runs between them",
                each.impacts.len()
            );
            assert_eq!(
                (each.rows.time.len(), second.rows.time.len()),
                (20_001, 10_001)
            );
            let even = |column: &[f64]| column.iter().step_by(2).copied().collect::<Vec<_>>();
            let (a, b) = (&each.rows, &second.rows);
            assert_eq!(even(&a.time), b.time);
            assert_eq!(even(&a.displacement), b.displacement, "{method:?}");
            assert_eq!(even(&a.velocity), b.velocity);
            assert_eq!(even(&a.acceleration), b.acceleration);
            assert_eq!(even(&a.gap_penetration), b.gap_penetration);
            assert_eq!(even(&a.gap_force), b.gap_force);
            assert_eq!(even(&a.energy.kinetic), b.energy.kinetic);
            assert_eq!(
                even(&a.energy.contact_dissipated),
                b.energy.contact_dissipated
            );
            assert_eq!(each.impacts, second.impacts);
            assert_eq!(each.max_abs_displacement, second.max_abs_displacement);
            assert_eq!(
                (each.stats.steps, each.stats.newton_iterations),
                (second.stats.steps, second.stats.newton_iterations)
            );
        }
    }

    #[test]
    fn events_name_the_step_cuts_and_each_contact() {
        let sys = sdof();
        let method = Method::Newmark(NewmarkFamily::average_acceleration());
        // three Newton iterations are too few for some contact steps of 20 µs: cuts
        let s = settings(2e-5, None, 3);
        let mut sink = Collect {
            events: true,
            ..Collect::default()
        };
        let (x0, v0) = (DVector::zeros(1), DVector::from_element(1, 8.0));
        let out = simulate_streamed(&sys, method, &s, x0, v0, &mut sink).unwrap();
        assert!(out.error.is_none() && out.stats.step_cuts > 0);
        let cuts: Vec<_> = sink
            .seen
            .iter()
            .filter_map(|e| match *e {
                Event::StepCut {
                    t, gap, iterations, ..
                } => Some((t, gap, iterations)),
                _ => None,
            })
            .collect();
        assert_eq!(cuts.len(), out.stats.step_cuts);
        assert!(cuts.iter().all(|&(_, gap, it)| gap == 0 && it == 3));
        let starts: Vec<_> = sink
            .seen
            .iter()
            .filter_map(|e| match *e {
                Event::ContactStart { t, speed, side, .. } => Some((t, speed, side)),
                _ => None,
            })
            .collect();
        let ends: Vec<_> = sink
            .seen
            .iter()
            .filter_map(|e| match *e {
                Event::ContactEnd {
                    t,
                    steps,
                    iterations,
                    ..
                } => Some((t, steps, iterations)),
                _ => None,
            })
            .collect();
        assert_eq!(starts.len(), out.impacts.len());
        assert!(out.impacts.len() >= 4);
        for (start, record) in starts.iter().zip(&out.impacts) {
            // the event comes with the step that closed the gap: within one step of the
            // interpolated closing instant, with the impact table's approach speed
            assert!(start.0 >= record.t_start && start.0 - record.t_start <= 2e-5 + 1e-12);
            assert!((start.1 - record.v_in).abs() <= 1e-9 * record.v_in && start.2 == record.side);
        }
        for (end, record) in ends.iter().zip(&out.impacts) {
            assert!(end.0 >= record.t_end && end.0 - record.t_end <= 2e-5 + 1e-12);
            assert!(end.1 >= 2 && end.2 >= end.1, "{end:?}");
        }
    }

    /// An adaptive run reserves one row per longest step (a short run: a few), up to
    /// `MAX_RESERVED_ROWS`; a run that records more grows its buffers and keeps every row: the
    /// same rows as the run streamed in blocks of 40, which start with fresh buffers.
    #[test]
    fn adaptive_rows_reserved_by_the_longest_step_and_grown_past_it() {
        let sys = sdof();
        let (x0, v0) = (DVector::zeros(1), DVector::from_element(1, 8.0));
        let tol = |dt_max| Adaptive {
            rtol: 1e-7,
            atol: 1e-14,
            dt_min: 1e-12,
            dt_max,
        };
        let short = RunSettings {
            t_end: 2e-6,
            every: 1,
            ..settings(1e-6, Some(tol(2e-6)), 25)
        };
        let out = simulate(&sys, Method::Dop853, &short, x0.clone(), v0.clone()).unwrap();
        let rows = out.rows.time.len();
        assert!(
            rows >= 2 && out.rows.time.capacity() <= 3.max(rows),
            "{rows} rows"
        );
        for method in [
            Method::Dop853,
            Method::Newmark(NewmarkFamily::average_acceleration()),
        ] {
            let long = RunSettings {
                every: 1,
                ..settings(1e-6, Some(tol(1e-5)), 25)
            };
            let whole = simulate(&sys, method, &long, x0.clone(), v0.clone()).unwrap();
            let n = whole.rows.time.len();
            assert!(n > MAX_RESERVED_ROWS, "{n} rows");
            let mut sink = Collect {
                chunk: Some(40),
                ..Collect::default()
            };
            let rest =
                simulate_streamed(&sys, method, &long, x0.clone(), v0.clone(), &mut sink).unwrap();
            let mut time: Vec<f64> = sink.blocks.iter().flat_map(|b| b.time.clone()).collect();
            let mut x: Vec<f64> = sink
                .blocks
                .iter()
                .flat_map(|b| b.displacement.clone())
                .collect();
            time.extend(&rest.rows.time);
            x.extend(&rest.rows.displacement);
            assert_eq!(time, whole.rows.time);
            assert_eq!(x, whole.rows.displacement);
            assert_eq!(whole.rows.energy.kinetic.len(), n);
        }
    }
}
