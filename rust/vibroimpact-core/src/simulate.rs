//! The time loop: steps of a fixed size with automatic step cutting, the impact table, the energy
//! account and decimated output into preallocated buffers (docs/architecture.md,
//! docs/conventions.md). A [`Sink`] (`simulate_streamed`) takes the recorded rows in blocks while
//! the run goes on (long runs stream to disk), follows its progress and receives its solver
//! [`Event`]s.

use std::time::Instant;

use nalgebra::DVector;

use crate::error::{invalid, SimError, ENERGY_GROWTH_LIMIT};
use crate::gap::{ImpactLog, ImpactRecord, WallInterior};
use crate::integrators::dop853::{self, Steps};
use crate::integrators::{
    Bathe, BatheStepper, NewmarkFamily, NewmarkStepper, NewtonSettings, PreciseIntegration,
    PreciseStepper, StepFailure, Stepper,
};
use crate::interrupt;
use crate::step_control::{Adaptive, StepControl};
use crate::system::{State, System};

/// Which integrator advances the run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Method {
    /// Newmark-β / HHT-α / generalized-α with Newton on the gap forces.
    NewmarkFamily(NewmarkFamily),
    /// Precise integration with the Adams treatment of the gap forces (paper eqs. 32–43).
    Precise(PreciseIntegration),
    /// Bathe's composite trapezoidal / three-point backward scheme with Newton on the gaps.
    Bathe(Bathe),
    /// Rigid gaps only: event-driven impacts with Newton's restitution law
    /// (`crate::impulsive`, docs/rigid-impacts.md).
    EventDriven(crate::impulsive::EventDriven),
    /// Rigid gaps only: Moreau–Jean θ-method time stepping with one LCP per step.
    MoreauJean(crate::impulsive::MoreauJean),
    /// Explicit Runge–Kutta DOP853 with located contact events (`integrators::dop853`).
    Dop853,
}

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

/// Solver statistics.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Stats {
    /// Fixed steps: accepted steps (including the sub-steps of cut steps). Adaptive steps:
    /// every step solved for a kept result — in contact, average acceleration's step doubling
    /// counts the whole step and both halves (`crate::step_control`).
    pub steps: usize,
    pub newton_iterations: usize,
    /// Step attempts discarded: Newton did not converge, and (adaptive) steps rejected by the
    /// error estimate or retried to land on an event.
    pub rejected_steps: usize,
    /// Newton failures retried with shorter steps (halved, or the next adaptive level).
    pub step_cuts: usize,
    pub wall_time_s: f64,
}

/// Energy account at the recorded instants, J (docs/conventions.md).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct EnergyHistory {
    pub kinetic: Vec<f64>,
    pub strain: Vec<f64>,
    /// Potential stored in the conservative part of the contact forces.
    pub contact_potential: Vec<f64>,
    pub external_work: Vec<f64>,
    pub damping_dissipated: Vec<f64>,
    pub contact_dissipated: Vec<f64>,
}

impl EnergyHistory {
    /// `E + D − E₀ − W_ext` at each recorded instant: zero up to the time discretisation.
    pub fn balance(&self) -> Vec<f64> {
        let e0 = self.kinetic[0] + self.strain[0] + self.contact_potential[0];
        (0..self.kinetic.len())
            .map(|k| {
                self.kinetic[k]
                    + self.strain[k]
                    + self.contact_potential[k]
                    + self.damping_dissipated[k]
                    + self.contact_dissipated[k]
                    - e0
                    - self.external_work[k]
            })
            .collect()
    }

    /// Largest balance error relative to the largest energy that entered the system.
    pub fn relative_balance_error(&self) -> f64 {
        let mut b = BalanceError::default();
        b.add(self);
        b.value()
    }

    fn with_capacity(n: usize) -> Self {
        let e = || Vec::with_capacity(n);
        Self {
            kinetic: e(),
            strain: e(),
            contact_potential: e(),
            external_work: e(),
            damping_dissipated: e(),
            contact_dissipated: e(),
        }
    }
}

/// [`EnergyHistory::relative_balance_error`] accumulated over consecutive blocks of rows
/// (a streamed run's [`Rows`], then the rows left in its [`RunOutput`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BalanceError {
    /// Mechanical energy of the first row, J.
    e0: Option<f64>,
    /// Largest energy that entered the system, J.
    scale: f64,
    /// Largest |E + D − E₀ − W_ext|, J.
    worst: f64,
}

impl BalanceError {
    /// Takes the rows of `e` (the rows that follow those added before).
    pub fn add(&mut self, e: &EnergyHistory) {
        for k in 0..e.kinetic.len() {
            let total = e.kinetic[k] + e.strain[k] + e.contact_potential[k];
            let e0 = *self.e0.get_or_insert(total);
            self.scale = self.scale.max(total.max(e0 + e.external_work[k].abs()));
            let balance =
                total + e.damping_dissipated[k] + e.contact_dissipated[k] - e0 - e.external_work[k];
            self.worst = self.worst.max(balance.abs());
        }
    }

    /// The largest balance error relative to the largest energy that entered the system
    /// (absolute, J, if none did).
    pub fn value(&self) -> f64 {
        if self.scale > 0.0 {
            self.worst / self.scale
        } else {
            self.worst
        }
    }
}

/// Everything a run returns. Arrays are row-major with time as the first axis.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RunOutput {
    /// The recorded rows (those not already handed to a streaming sink).
    pub rows: Rows,
    pub record_dofs: Vec<usize>,
    /// Largest |x| of each recorded DOF over every step (not only the recorded ones), m.
    pub max_abs_displacement: Vec<f64>,
    pub impacts: Vec<ImpactRecord>,
    pub stats: Stats,
    /// Step size actually used, s.
    pub dt: f64,
    /// Why the run stopped early; the arrays then hold the results up to that time.
    pub error: Option<SimError>,
}

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
}

/// Consecutive recorded rows: the time histories of a run (or of a block of it) at the
/// recorded instants, row-major with time first.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Rows {
    pub time: Vec<f64>,
    /// Per recorded DOF, m (rad on rotations) and its rates.
    pub displacement: Vec<f64>,
    pub velocity: Vec<f64>,
    pub acceleration: Vec<f64>,
    /// Per gap: largest penetration over its walls (negative: open by that much), m.
    pub gap_penetration: Vec<f64>,
    /// Per gap: contact force magnitude, N.
    pub gap_force: Vec<f64>,
    pub energy: EnergyHistory,
}

impl Rows {
    fn with_capacity(n_rec: usize, n_dofs: usize, n_gaps: usize) -> Self {
        let per = |k: usize| Vec::with_capacity(n_rec * k);
        Self {
            time: per(1),
            displacement: per(n_dofs),
            velocity: per(n_dofs),
            acceleration: per(n_dofs),
            gap_penetration: per(n_gaps),
            gap_force: per(n_gaps),
            energy: EnergyHistory::with_capacity(n_rec),
        }
    }
}

/// A solver event reported to a [`Sink`] that asks for them (`vibroimpact run --verbose`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Event {
    /// Newton did not converge on the step of length `dt` from `t` (after `iterations`
    /// iterations, worst at `gap` with that penetration, m); it is retried as two halves.
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
}

/// Watches a run from inside the time loop (compliant methods; the impulsive methods only
/// deliver their rows at the end): takes the recorded rows in blocks, so that they need not
/// be held until the end, follows the simulated time and receives [`Event`]s. Every method
/// has a default that does nothing; the calls cost nothing measurable (rows: once per block;
/// progress: every [`interrupt::CHECK_EVERY`] steps; events: only if asked for).
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

/// Runs `sys` from `x0, v0` at `t = 0`. Invalid settings are refused before the run; a
/// failure during the run is returned in `RunOutput::error` with the results up to then.
pub fn simulate(
    sys: &System,
    method: Method,
    settings: &RunSettings,
    x0: DVector<f64>,
    v0: DVector<f64>,
) -> Result<RunOutput, SimError> {
    simulate_observed(sys, method, settings, x0, v0, None)
}

/// [`simulate`], with `observer` called on every accepted step.
pub fn simulate_observed(
    sys: &System,
    method: Method,
    settings: &RunSettings,
    x0: DVector<f64>,
    v0: DVector<f64>,
    observer: Option<&mut dyn StepObserver>,
) -> Result<RunOutput, SimError> {
    run_watched(sys, method, settings, x0, v0, observer, None)
}

/// [`simulate`], with `sink` taking the recorded rows in blocks of `sink.chunk_rows()` as they
/// are recorded (the returned [`RunOutput`] then holds only the rows recorded after the last
/// block, at least the last one; the impact table, the peaks and the statistics are whole), following the simulated
/// time and receiving the solver events. [`BalanceError`] gives the energy balance error over
/// all the blocks. The impulsive methods hand everything over at the end.
pub fn simulate_streamed(
    sys: &System,
    method: Method,
    settings: &RunSettings,
    x0: DVector<f64>,
    v0: DVector<f64>,
    sink: &mut dyn Sink,
) -> Result<RunOutput, SimError> {
    run_watched(sys, method, settings, x0, v0, None, Some(sink))
}

fn run_watched<'o>(
    sys: &System,
    method: Method,
    settings: &RunSettings,
    x0: DVector<f64>,
    v0: DVector<f64>,
    observer: Option<&'o mut dyn StepObserver>,
    sink: Option<&'o mut dyn Sink>,
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
    crate::impulsive::check_method_laws(sys, &method)?;
    if crate::impulsive::is_impulsive(&method) {
        if observer.is_some() {
            return invalid(
                "solver.method: the impulsive methods (event-driven, moreau-jean) do not feed \
                 step observers (sweep reducers); expected a force law and a compliant method",
            );
        }
        return crate::impulsive::simulate_impulsive(sys, method, settings, x0, v0);
    }
    // Fixed steps: dt is shortened so that t_end is a whole number of steps. Adaptive steps:
    // the cached sizes are dt_max / 2^k, with dt_max likewise a whole fraction of t_end.
    let explicit = matches!(method, Method::Dop853);
    let control = match adaptive {
        Some(a) if !explicit => Some(StepControl::new(a, method, t_end, dt)?),
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

    let n_rec = if adaptive.is_some() {
        1024
    } else {
        n_steps / every + 2
    };
    let mut run = Run::new(sys, x0, v0, record_dofs.clone(), n_rec)?;
    run.observer = observer;
    if let Some(sink) = sink {
        run.watch(sink);
    }
    let error = match explicit_steps {
        Some(steps) => dop853::run(&mut run, sys, steps, t_end, every),
        None => {
            // Every stepper caches one operator per level of the step cuts (or adaptive sizes).
            let cut_newton = NewtonSettings {
                max_step_cuts: max_levels,
                ..newton
            };
            match stepper(sys, method, cut_newton, h0) {
                // A singular tangent is a solver failure at t = 0: the initial state is the result.
                Err(e @ SimError::SingularTangent { .. }) => Some(e),
                Err(e) => return Err(e),
                Ok(mut stepper) => match &control {
                    None => run.fixed_steps(
                        sys,
                        stepper.as_mut(),
                        h0,
                        n_steps,
                        every,
                        newton.max_step_cuts,
                    ),
                    Some(c) => c.run(&mut run, sys, stepper.as_mut(), every),
                },
            }
        }
    };
    // the last check of the energy (runs shorter than interrupt::CHECK_EVERY steps)
    let error = error.or_else(|| run.check_energy(sys).err());
    if error.is_some() && run.out.last_time != run.cur.t {
        run.out.record(sys, &run.cur, &run.account);
    }
    if let Some(sink) = run.out.sink.as_deref_mut() {
        sink.progress(run.cur.t);
    }
    run.stats.wall_time_s = started.elapsed().as_secs_f64();
    let out = run.out;
    Ok(RunOutput {
        rows: out.rows,
        record_dofs: record_dofs.clone(),
        max_abs_displacement: out.max_abs,
        impacts: run.log.records,
        stats: run.stats,
        dt: h0,
        error,
    })
}

/// The stepper of an implicit or precise `method`, its operators prepared for steps of `h0`.
fn stepper(
    sys: &System,
    method: Method,
    newton: NewtonSettings,
    h0: f64,
) -> Result<Box<dyn Stepper>, SimError> {
    Ok(match method {
        Method::NewmarkFamily(scheme) => {
            let mut s = NewmarkStepper::new(sys, scheme, newton)?;
            s.prepare(sys, h0)?;
            Box::new(s)
        }
        Method::Precise(variant) => {
            let mut s = PreciseStepper::new(sys, variant, newton)?;
            s.prepare(sys, h0)?;
            Box::new(s)
        }
        Method::Bathe(scheme) => {
            let mut s = BatheStepper::new(sys, scheme, newton)?;
            s.prepare(sys, h0)?;
            Box::new(s)
        }
        Method::EventDriven(_) | Method::MoreauJean(_) | Method::Dop853 => {
            unreachable!("the impulsive and explicit methods have no stepper")
        }
    })
}

/// What an integrator computed over a step beyond its ends, for the run's accounts.
pub(crate) struct StepIntegrals<'a> {
    /// Increments of the external work and of the damping and contact dissipation, J.
    pub work: [f64; 3],
    /// Per wall: impulse, largest force and peak penetration inside the step.
    pub walls: WallInterior<'a>,
    /// Per DOF: where its displacement turns inside the step, if it does (fraction of the
    /// step, value in m or rad), on the integrator's own interpolant; `None` for the DOFs
    /// that are not recorded.
    pub displacement_turns: &'a [Option<Turn>],
}

/// The state of a run and everything accumulated from its accepted steps.
pub(crate) struct Run<'o> {
    pub cur: State,
    pub trial: State,
    pub log: ImpactLog,
    pub out: Recorder<'o>,
    pub account: Account,
    pub stats: Stats,
    pub observer: Option<&'o mut dyn StepObserver>,
    /// Accepted steps since the last poll of the interrupt flag and check of the energy.
    since_check: usize,
    /// Mechanical energy at t = 0, J.
    e0: f64,
    /// Largest energy that entered the system up to the last check, J.
    energy_in: f64,
    /// Per wall while it is closed: accepted steps and Newton iterations (for
    /// [`Event::ContactEnd`]; only when the sink wants events).
    contact: Option<Vec<(usize, usize)>>,
}

impl<'o> Run<'o> {
    pub(crate) fn new(
        sys: &System,
        x0: DVector<f64>,
        v0: DVector<f64>,
        record_dofs: Vec<usize>,
        n_rec: usize,
    ) -> Result<Self, SimError> {
        let cur = State::initial(sys, x0, v0, 0.0)?;
        let mut log = ImpactLog::new(sys.walls.len());
        log.start(&sys.walls, &cur.walls, 0.0);
        let account = Account::default();
        let mut out = Recorder::new(sys, record_dofs, n_rec);
        out.record(sys, &cur, &account);
        let e0 = mechanical_energy(sys, &cur);
        Ok(Self {
            since_check: 0,
            e0,
            energy_in: e0,
            trial: cur.clone(),
            cur,
            log,
            out,
            account,
            stats: Stats::default(),
            observer: None,
            contact: None,
        })
    }

    /// Hands the rows recorded from now on, the progress and the events to `sink`.
    pub(crate) fn watch(&mut self, sink: &'o mut dyn Sink) {
        if sink.wants_events() {
            self.contact = Some(vec![(0, 0); self.cur.walls.len()]);
        }
        self.out.chunk = sink.chunk_rows().map(|n| n.max(1));
        self.out.sink = Some(sink);
    }

    /// Reports a step from `t` of length `dt` that Newton could not take and that is retried
    /// shorter (when the sink wants events).
    pub(crate) fn step_cut(&mut self, failure: &StepFailure, t: f64, dt: f64) {
        if let (Some(sink), Some(_)) = (self.out.sink.as_deref_mut(), &self.contact) {
            sink.event(Event::StepCut {
                t,
                dt,
                gap: failure.gap,
                penetration: failure.penetration,
                iterations: failure.iterations,
            });
        }
    }

    /// Reports the walls that close or open in the accepted step from `cur` to `trial`.
    fn contact_events(&mut self, sys: &System, iterations: usize) {
        let (Some(contact), Some(sink)) = (self.contact.as_mut(), self.out.sink.as_deref_mut())
        else {
            return;
        };
        let t = self.trial.t;
        for (((wall, w0), w1), c) in sys
            .walls
            .iter()
            .zip(&self.cur.walls)
            .zip(&self.trial.walls)
            .zip(contact.iter_mut())
        {
            match (w0.closed(), w1.closed()) {
                (false, true) => {
                    *c = (1, iterations);
                    sink.event(Event::ContactStart {
                        t,
                        gap: wall.gap,
                        side: wall.sign,
                        speed: w1.impact_speed,
                    });
                }
                (true, true) => *c = (c.0 + 1, c.1 + iterations),
                (true, false) => {
                    sink.event(Event::ContactEnd {
                        t,
                        gap: wall.gap,
                        side: wall.sign,
                        speed: -w1.rate,
                        steps: c.0 + 1,
                        iterations: c.1 + iterations,
                    });
                    *c = (0, 0);
                }
                (false, false) => {}
            }
        }
    }

    /// Makes the trial state of a successful attempt of length `h` the current one: energy
    /// account, peaks and impact table. Returns an error if the state is not finite.
    pub fn accept(
        &mut self,
        sys: &System,
        stepper: &mut dyn Stepper,
        h: f64,
        iterations: usize,
    ) -> Result<(), SimError> {
        self.commit_trial(sys, h, iterations, None)?;
        stepper.accept(sys, &self.cur);
        Ok(())
    }

    /// [`Self::accept`] for any integrator: `integrals` holds what the integrator computed
    /// itself over the step (work increments, impulses, largest forces); without it they come
    /// from the step's ends (trapezoidal rule, parabola through the force samples).
    pub(crate) fn commit_trial(
        &mut self,
        sys: &System,
        h: f64,
        iterations: usize,
        integrals: Option<&StepIntegrals>,
    ) -> Result<(), SimError> {
        self.stats.newton_iterations += iterations;
        self.stats.steps += 1;
        let trial = &self.trial;
        if trial.x.iter().chain(trial.v.iter()).any(|v| !v.is_finite()) {
            return Err(SimError::Diverged {
                t: trial.t,
                gap: busiest_gap(sys, &self.cur),
            });
        }
        match integrals {
            Some(i) => self.account.add(i.work),
            None => self.account.commit(sys, &self.cur, trial),
        }
        for (m, &d) in self.out.max_abs.iter_mut().zip(&self.out.dofs) {
            let inside = integrals.and_then(|i| i.displacement_turns[d]);
            *m = m
                .max(trial.x[d].abs())
                .max(inside.map_or(0.0, |(_, x)| x.abs()));
        }
        let interior = integrals.map(|i| &i.walls);
        self.log.commit(
            &sys.walls,
            &self.cur.walls,
            &trial.walls,
            self.cur.t,
            h,
            interior,
        );
        self.contact_events(sys, iterations);
        if let Some(observer) = self.observer.as_deref_mut() {
            let turns = integrals.map(|i| i.displacement_turns);
            observer.accepted(sys, &self.cur, &self.trial, h, turns);
        }
        std::mem::swap(&mut self.cur, &mut self.trial);
        self.since_check += 1;
        if self.since_check >= interrupt::CHECK_EVERY {
            self.since_check = 0;
            if let Some(sink) = self.out.sink.as_deref_mut() {
                sink.progress(self.cur.t);
            }
            if interrupt::requested() {
                return Err(SimError::Interrupted { t: self.cur.t });
            }
            self.check_energy(sys)?;
        }
        Ok(())
    }

    /// The scale of the run's energies, J: the initial mechanical energy or the external work
    /// done so far, whichever is larger.
    pub(crate) fn energy_scale(&self) -> f64 {
        self.e0.max(self.account.external_work.abs())
    }

    /// [`SimError::EnergyGrowth`] if the mechanical energy exceeds
    /// [`ENERGY_GROWTH_LIMIT`] times the largest energy that entered the system (the initial
    /// energy plus the external work, or the initial energy alone).
    pub(crate) fn check_energy(&mut self, sys: &System) -> Result<(), SimError> {
        let entered = self.e0 + self.account.external_work.abs();
        self.energy_in = self.energy_in.max(entered);
        let energy = mechanical_energy(sys, &self.cur);
        if self.energy_in > 0.0 && energy > ENERGY_GROWTH_LIMIT * self.energy_in {
            return Err(SimError::EnergyGrowth {
                t: self.cur.t,
                energy,
                reference: self.energy_in,
                gap: busiest_gap(sys, &self.cur),
            });
        }
        Ok(())
    }

    /// `n_steps` steps of `h0`, each halved (recursively, up to `max_cuts` times) when
    /// Newton fails.
    pub(crate) fn fixed_steps(
        &mut self,
        sys: &System,
        stepper: &mut dyn Stepper,
        h0: f64,
        n_steps: usize,
        every: usize,
        max_cuts: usize,
    ) -> Option<SimError> {
        let mut pending: Vec<usize> = Vec::with_capacity(2 * max_cuts + 2);
        for step in 1..=n_steps {
            pending.push(0);
            while let Some(level) = pending.pop() {
                let h = h0 / (1u64 << level) as f64;
                match stepper.attempt(sys, &self.cur, level, h, &mut self.trial) {
                    Ok(iterations) => {
                        if let Err(e) = self.accept(sys, stepper, h, iterations) {
                            return Some(e);
                        }
                    }
                    Err(failure) => {
                        self.stats.rejected_steps += 1;
                        self.stats.newton_iterations += failure.iterations;
                        if level < max_cuts {
                            self.stats.step_cuts += 1;
                            self.step_cut(&failure, self.cur.t, h);
                            pending.push(level + 1);
                            pending.push(level + 1);
                        } else {
                            // Newton failing on a blown-up state: report the blow-up
                            if let Err(e) = self.check_energy(sys) {
                                return Some(e);
                            }
                            return Some(failure.into_error(self.cur.t, h));
                        }
                    }
                }
            }
            self.cur.t = step as f64 * h0;
            if step % every == 0 || step == n_steps {
                self.out.record(sys, &self.cur, &self.account);
            }
        }
        None
    }
}

/// Work integrals, accumulated every step with the trapezoidal rule in displacement,
/// `W = Σ Δxᵀ (f₀ + f₁)/2`, which is exact for the average-acceleration rule's linear part.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Account {
    external_work: f64,
    damping_dissipated: f64,
    contact_dissipated: f64,
}

impl Account {
    /// Adds increments of the external work, the damping and the contact dissipation, J.
    fn add(&mut self, work: [f64; 3]) {
        self.external_work += work[0];
        self.damping_dissipated += work[1];
        self.contact_dissipated += work[2];
    }

    fn commit(&mut self, sys: &System, s0: &State, s1: &State) {
        for (l, load) in sys.loads.iter().enumerate() {
            let moved: f64 = load.dofs.iter().map(|&d| s1.x[d] - s0.x[d]).sum();
            self.external_work += 0.5 * (s0.load[l] + s1.load[l]) * moved;
        }
        if sys.has_damping {
            // Δxᵀ C (v₀ + v₁)/2
            let d = sys
                .structure
                .damping
                .increment_form(&s0.x, &s1.x, &s0.v, &s1.v);
            self.damping_dissipated += 0.5 * d;
        }
        for (w0, w1) in s0.walls.iter().zip(&s1.walls) {
            if w0.closed() || w1.closed() {
                let fd0 = w0.force - w0.elastic_force;
                let fd1 = w1.force - w1.elastic_force;
                self.contact_dissipated += 0.5 * (w1.penetration - w0.penetration) * (fd0 + fd1);
            }
        }
    }
}

/// Kinetic + strain + contact potential energy of a state, J.
fn mechanical_energy(sys: &System, s: &State) -> f64 {
    let potential: f64 = s.walls.iter().map(|w| w.potential).sum();
    sys.structure.mass.quadratic_form(&s.v)
        + sys.structure.stiffness.quadratic_form(&s.x)
        + potential
}

/// The gap of the wall in contact with the largest force, if any.
fn busiest_gap(sys: &System, s: &State) -> Option<usize> {
    sys.walls
        .iter()
        .zip(&s.walls)
        .filter(|(_, w)| w.closed())
        .max_by(|a, b| a.1.force.abs().total_cmp(&b.1.force.abs()))
        .map(|(wall, _)| wall.gap)
}

/// Decimated output buffers, handed to the sink (if any) every `chunk` rows.
pub(crate) struct Recorder<'o> {
    dofs: Vec<usize>,
    rows: Rows,
    max_abs: Vec<f64>,
    /// Time of the last recorded row (NaN before the first), s.
    last_time: f64,
    chunk: Option<usize>,
    sink: Option<&'o mut dyn Sink>,
}

impl Recorder<'_> {
    /// The recorded DOFs.
    pub fn dofs(&self) -> &[usize] {
        &self.dofs
    }

    fn new(sys: &System, dofs: Vec<usize>, n_rec: usize) -> Self {
        Self {
            rows: Rows::with_capacity(n_rec, dofs.len(), sys.gaps.len()),
            max_abs: vec![0.0; dofs.len()],
            dofs,
            last_time: f64::NAN,
            chunk: None,
            sink: None,
        }
    }

    pub fn record(&mut self, sys: &System, s: &State, account: &Account) {
        // a full block goes before the next row is added, so the last row always stays for
        // the RunOutput
        if let (Some(n), Some(sink)) = (self.chunk, self.sink.as_deref_mut()) {
            if self.rows.time.len() >= n {
                let fresh = Rows::with_capacity(n, self.dofs.len(), sys.gaps.len());
                sink.rows(std::mem::replace(&mut self.rows, fresh));
            }
        }
        let rows = &mut self.rows;
        rows.time.push(s.t);
        self.last_time = s.t;
        for (m, &d) in self.max_abs.iter_mut().zip(&self.dofs) {
            *m = m.max(s.x[d].abs());
        }
        for &d in &self.dofs {
            rows.displacement.push(s.x[d]);
            rows.velocity.push(s.v[d]);
            rows.acceleration.push(s.a[d]);
        }
        // Walls of one gap are adjacent: one column per gap (deepest wall, summed force).
        let mut potential = 0.0;
        let mut walls = sys.walls.iter().zip(&s.walls).peekable();
        while let Some((wall, ws)) = walls.next() {
            let (mut pen, mut force) = (ws.penetration, ws.force);
            potential += ws.potential;
            while let Some((_, other)) = walls.next_if(|(w, _)| w.gap == wall.gap) {
                pen = pen.max(other.penetration);
                force += other.force;
                potential += other.potential;
            }
            rows.gap_penetration.push(pen);
            rows.gap_force.push(force);
        }
        let kinetic = sys.structure.mass.quadratic_form(&s.v);
        let strain = sys.structure.stiffness.quadratic_form(&s.x);
        let e = &mut rows.energy;
        e.kinetic.push(kinetic);
        e.strain.push(strain);
        e.contact_potential.push(potential);
        e.external_work.push(account.external_work);
        e.damping_dissipated.push(account.damping_dissipated);
        e.contact_dissipated.push(account.contact_dissipated);
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{DMatrix, DVector};

    use super::*;
    use crate::contact::{Hysteretic, Law};
    use crate::gap::{Gap, Side};
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
        let method = Method::NewmarkFamily(NewmarkFamily::average_acceleration());
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

    #[test]
    fn events_name_the_step_cuts_and_each_contact() {
        let sys = sdof();
        let method = Method::NewmarkFamily(NewmarkFamily::average_acceleration());
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
}
