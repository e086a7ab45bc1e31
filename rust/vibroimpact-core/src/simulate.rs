//! The time loop: steps of a fixed size with automatic step cutting, the impact table, the
//! energy account and decimated output into preallocated buffers (DESIGN.md §5–6).

use std::time::Instant;

use nalgebra::DVector;

use crate::error::{invalid, SimError, ENERGY_GROWTH_LIMIT};
use crate::gap::{ImpactLog, ImpactRecord};
use crate::integrators::{
    Bathe, BatheStepper, NewmarkFamily, NewmarkStepper, NewtonSettings, PreciseIntegration,
    PreciseStepper, Stepper,
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
    /// Accepted steps (including the sub-steps of cut steps).
    pub steps: usize,
    pub newton_iterations: usize,
    /// Step attempts that failed (Newton did not converge).
    pub rejected_steps: usize,
    /// Failed steps that were halved and retried.
    pub step_cuts: usize,
    pub wall_time_s: f64,
}

/// Energy account at the recorded instants, J (DESIGN.md §6).
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
        let e0 = self.kinetic[0] + self.strain[0] + self.contact_potential[0];
        let scale = (0..self.kinetic.len())
            .map(|k| {
                (self.kinetic[k] + self.strain[k] + self.contact_potential[k])
                    .max(e0 + self.external_work[k].abs())
            })
            .fold(0.0, f64::max);
        let worst = self.balance().iter().fold(0.0f64, |m, e| m.max(e.abs()));
        if scale > 0.0 {
            worst / scale
        } else {
            worst
        }
    }
}

/// Everything a run returns. Arrays are row-major with time as the first axis.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RunOutput {
    pub time: Vec<f64>,
    pub record_dofs: Vec<usize>,
    /// Largest |x| of each recorded DOF over every step (not only the recorded ones), m.
    pub max_abs_displacement: Vec<f64>,
    pub displacement: Vec<f64>,
    pub velocity: Vec<f64>,
    pub acceleration: Vec<f64>,
    /// Per gap: largest penetration over its walls (negative: open by that much), m.
    pub gap_penetration: Vec<f64>,
    /// Per gap: contact force magnitude, N.
    pub gap_force: Vec<f64>,
    pub energy: EnergyHistory,
    pub impacts: Vec<ImpactRecord>,
    pub stats: Stats,
    /// Step size actually used, s.
    pub dt: f64,
    /// Why the run stopped early; the arrays then hold the results up to that time.
    pub error: Option<SimError>,
}

/// Sees every accepted step of a run: streaming reducers (sweeps: Poincaré samples, peaks,
/// impact statistics; `crate::sweep`) that need more than the decimated output without
/// storing the history. Called after each accepted step from `s0` to `s1` of length `h`.
pub trait StepObserver {
    fn accepted(&mut self, sys: &System, s0: &State, s1: &State, h: f64);
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
    let control = match adaptive {
        Some(a) => Some(StepControl::new(a, method, t_end, dt)?),
        None => None,
    };
    let n_steps_f = (t_end / dt - 1e-9).ceil();
    if control.is_none() && n_steps_f > 1e10 {
        return invalid(format!(
            "solver.dt: {dt} gives {n_steps_f:.3e} steps for t_end = {t_end}; expected at most 1e10"
        ));
    }
    let n_steps = n_steps_f as usize;
    let h0 = match &control {
        Some(c) => c.dt_max,
        None => t_end / n_steps as f64,
    };
    let max_levels = match &control {
        Some(c) => c.levels(),
        None => newton.max_step_cuts,
    };

    let n_rec = if control.is_some() {
        1024
    } else {
        n_steps / every + 2
    };
    let mut run = Run::new(sys, x0, v0, record_dofs.clone(), n_rec)?;
    run.observer = observer;
    let stepper: Result<Box<dyn Stepper>, SimError> = (|| -> Result<Box<dyn Stepper>, SimError> {
        Ok(match method {
            Method::NewmarkFamily(scheme) => {
                let mut s = NewmarkStepper::new(
                    sys,
                    scheme,
                    NewtonSettings {
                        max_step_cuts: max_levels,
                        ..newton
                    },
                )?;
                s.prepare(sys, h0)?;
                Box::new(s)
            }
            Method::Precise(variant) => {
                let settings = NewtonSettings {
                    max_step_cuts: max_levels,
                    ..newton
                };
                let mut s = PreciseStepper::new(sys, variant, settings)?;
                s.prepare(sys, h0)?;
                Box::new(s)
            }
            Method::Bathe(scheme) => {
                let settings = NewtonSettings {
                    max_step_cuts: max_levels,
                    ..newton
                };
                let mut s = BatheStepper::new(sys, scheme, settings)?;
                s.prepare(sys, h0)?;
                Box::new(s)
            }
            Method::EventDriven(_) | Method::MoreauJean(_) => {
                unreachable!("the impulsive methods returned above")
            }
        })
    })();
    let error = match stepper {
        // A singular tangent is a solver failure at t = 0: the initial state is the result.
        Err(e @ SimError::SingularTangent { .. }) => Some(e),
        Err(e) => return Err(e),
        Ok(mut stepper) => {
            let error = match &control {
                None => run.fixed_steps(
                    sys,
                    stepper.as_mut(),
                    h0,
                    n_steps,
                    every,
                    newton.max_step_cuts,
                ),
                Some(c) => c.run(&mut run, sys, stepper.as_mut(), every),
            };
            // the last check of the energy (runs shorter than interrupt::CHECK_EVERY steps)
            error.or_else(|| run.check_energy(sys).err())
        }
    };
    if error.is_some() && run.out.time.last() != Some(&run.cur.t) {
        run.out.record(sys, &run.cur, &run.account);
    }
    run.stats.wall_time_s = started.elapsed().as_secs_f64();
    let out = run.out;
    Ok(RunOutput {
        time: out.time,
        record_dofs: record_dofs.clone(),
        max_abs_displacement: out.max_abs,
        displacement: out.x,
        velocity: out.v,
        acceleration: out.a,
        gap_penetration: out.penetration,
        gap_force: out.force,
        energy: out.energy,
        impacts: run.log.records,
        stats: run.stats,
        dt: h0,
        error,
    })
}

/// The state of a run and everything accumulated from its accepted steps.
pub(crate) struct Run<'o> {
    pub cur: State,
    pub trial: State,
    pub log: ImpactLog,
    pub out: Recorder,
    pub account: Account,
    pub stats: Stats,
    pub observer: Option<&'o mut dyn StepObserver>,
    /// Accepted steps since the last poll of the interrupt flag and check of the energy.
    since_check: usize,
    /// Mechanical energy at t = 0, J.
    e0: f64,
    /// Largest energy that entered the system up to the last check, J.
    energy_in: f64,
}

impl Run<'_> {
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
        })
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
        self.stats.newton_iterations += iterations;
        self.stats.steps += 1;
        let trial = &self.trial;
        if trial.x.iter().chain(trial.v.iter()).any(|v| !v.is_finite()) {
            return Err(SimError::Diverged {
                t: trial.t,
                gap: busiest_gap(sys, &self.cur),
            });
        }
        self.account.commit(sys, &self.cur, trial);
        for (m, &d) in self.out.max_abs.iter_mut().zip(&self.out.dofs) {
            *m = m.max(trial.x[d].abs());
        }
        self.log
            .commit(&sys.walls, &self.cur.walls, &trial.walls, self.cur.t, h);
        if let Some(observer) = self.observer.as_deref_mut() {
            observer.accepted(sys, &self.cur, &self.trial, h);
        }
        std::mem::swap(&mut self.cur, &mut self.trial);
        stepper.accept(sys, &self.cur);
        self.since_check += 1;
        if self.since_check >= interrupt::CHECK_EVERY {
            self.since_check = 0;
            if interrupt::requested() {
                return Err(SimError::Interrupted { t: self.cur.t });
            }
            self.check_energy(sys)?;
        }
        Ok(())
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
    fn commit(&mut self, sys: &System, s0: &State, s1: &State) {
        for (l, load) in sys.loads.iter().enumerate() {
            let moved: f64 = load.dofs.iter().map(|&d| s1.x[d] - s0.x[d]).sum();
            self.external_work += 0.5 * (s0.load[l] + s1.load[l]) * moved;
        }
        if sys.has_damping {
            // Δxᵀ C (v₀ + v₁)/2
            let d = sys
                .sparse
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
    sys.sparse.mass.quadratic_form(&s.v) + sys.sparse.stiffness.quadratic_form(&s.x) + potential
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

/// Decimated output buffers.
pub(crate) struct Recorder {
    dofs: Vec<usize>,
    time: Vec<f64>,
    x: Vec<f64>,
    v: Vec<f64>,
    a: Vec<f64>,
    penetration: Vec<f64>,
    force: Vec<f64>,
    energy: EnergyHistory,
    max_abs: Vec<f64>,
}

impl Recorder {
    fn new(sys: &System, dofs: Vec<usize>, n_rec: usize) -> Self {
        let nd = dofs.len();
        let ng = sys.gaps.len();
        let max_abs = vec![0.0; nd];
        let e = || Vec::with_capacity(n_rec);
        Self {
            dofs,
            time: e(),
            x: Vec::with_capacity(n_rec * nd),
            v: Vec::with_capacity(n_rec * nd),
            a: Vec::with_capacity(n_rec * nd),
            penetration: Vec::with_capacity(n_rec * ng),
            force: Vec::with_capacity(n_rec * ng),
            energy: EnergyHistory {
                kinetic: e(),
                strain: e(),
                contact_potential: e(),
                external_work: e(),
                damping_dissipated: e(),
                contact_dissipated: e(),
            },
            max_abs,
        }
    }

    pub fn record(&mut self, sys: &System, s: &State, account: &Account) {
        self.time.push(s.t);
        for (m, &d) in self.max_abs.iter_mut().zip(&self.dofs) {
            *m = m.max(s.x[d].abs());
        }
        for &d in &self.dofs {
            self.x.push(s.x[d]);
            self.v.push(s.v[d]);
            self.a.push(s.a[d]);
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
            self.penetration.push(pen);
            self.force.push(force);
        }
        let kinetic = sys.sparse.mass.quadratic_form(&s.v);
        let strain = sys.sparse.stiffness.quadratic_form(&s.x);
        let e = &mut self.energy;
        e.kinetic.push(kinetic);
        e.strain.push(strain);
        e.contact_potential.push(potential);
        e.external_work.push(account.external_work);
        e.damping_dissipated.push(account.damping_dissipated);
        e.contact_dissipated.push(account.contact_dissipated);
    }
}
