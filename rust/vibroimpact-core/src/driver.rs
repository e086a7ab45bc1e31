//! The one time loop of every method ([`Run::drive`]) and the state its step policies share:
//! the current and trial states, the impact table, the energy account, the decimated output
//! and the watchers (docs/architecture.md).
//!
//! The step lifecycle: a [`StepPolicy`] (fixed steps with cuts and adaptive error control,
//! `crate::step_control`; DOP853 with located events, `integrators::dop853`; event-driven and
//! Moreau–Jean, `crate::impulsive`) attempts steps in `run.trial` from `run.cur` and discards
//! or retakes them as it sees fit (cuts, rejections, landings on events), then commits each
//! step it keeps with [`Run::commit_trial`]: statistics, finiteness, energy account, peaks,
//! impact table, `--verbose` events, the [`StepObserver`] (sweeps), and every
//! [`interrupt::CHECK_EVERY`] steps the sink's progress, the interrupt flag and the energy
//! check. A located event that changes the state in place (a rigid impact's velocity jump)
//! is reported by [`Run::impact`] and [`Run::jump`]. [`Run::drive`] records a row every
//! `every` advances of the policy and the last one; [`Run::finish`] ends the run. A policy
//! asked for the state-transition matrix (`Run::wants_sensitivity`, `crate::sensitivity`)
//! carries it and hands it out through [`StepPolicy::sensitivity`].

use std::time::Instant;

use nalgebra::DVector;

use crate::error::{SimError, ENERGY_GROWTH_LIMIT};
use crate::gap::{FrictionLaw, ImpactLog, ImpactRecord, Side, WallInterior, WallState};
use crate::integrators::sized::by_size;
use crate::integrators::{StepFailure, Stepper};
use crate::interrupt;
use crate::linalg::Csr;
use crate::observe::{Event, Sink, StepObserver, Turn};
use crate::output::{Rows, RunOutput, Stats};
use crate::sensitivity::StateTransition;
use crate::system::{State, System};

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

/// What a method does per step: the step policy that [`Run::drive`] advances.
pub(crate) trait StepPolicy {
    /// Advances the run by one step of its output grid, committing every step it keeps with
    /// [`Run::commit_trial`]: one step of the fixed grid (however many cut sub-steps, or
    /// flights between impacts, it took) or one accepted adaptive step. `Ok(false)`: the run
    /// had already reached its end; an error stops it (the results up to then are kept).
    fn advance(&mut self, run: &mut Run, sys: &System) -> Result<bool, SimError>;

    /// The state-transition matrix from the run's start to the end of the last advance
    /// (composed over its kept steps and, at each located event, the saltation matrix),
    /// handed to the observer and, at the end, to the output. `None`: not computed (not asked
    /// for, or the policy computes none).
    fn sensitivity(&self) -> Option<&StateTransition> {
        None
    }

    /// Whether each advance commits exactly one step and hands its commits no turning points
    /// inside the step (the fixed grid until a step is cut): with a row every advance, every
    /// committed state is then a row, and the peaks can come from the rows.
    fn commits_once_per_advance(&self) -> bool {
        false
    }

    /// Takes up to `max` steps in free flight before the next advance, each committed and,
    /// with `rows`, recorded ([`Stepper::free_run`]: the fixed grid's Newmark and Adams
    /// steps); only steps the observer has no use for ([`Run::unobserved_until`]). Called by
    /// [`Run::drive`] only where nothing else watches a step: see there. Returns the steps
    /// taken; `None`: it takes no more (the default), and is not asked again.
    fn free_run(
        &mut self,
        _run: &mut Run,
        _sys: &System,
        _max: usize,
        _rows: bool,
    ) -> Option<usize> {
        None
    }
}

/// The state of a run and everything accumulated from its accepted steps.
pub(crate) struct Run<'o> {
    /// Boxed, so that a commit swaps two pointers, not the states' vectors.
    pub cur: Box<State>,
    pub trial: Box<State>,
    /// The impact table from the closings and openings of the committed steps; `None` when
    /// the policy keeps its own (the impulsive methods: an impact is an instant).
    pub log: Option<ImpactLog>,
    pub out: Recorder<'o>,
    pub account: Account,
    pub stats: Stats,
    observer: Option<&'o mut dyn StepObserver>,
    /// The observer's [`StepObserver::quiet_until`].
    quiet_until: f64,
    /// The end time of the last committed step when the observer has not had its state
    /// ([`StepObserver::final_state`]): its state is `cur`'s until an impact's jump changes it.
    observed_end: Option<f64>,
    /// Accepted steps since the last poll of the interrupt flag and check of the energy.
    since_check: usize,
    /// Mechanical energy at t = 0, J.
    e0: f64,
    /// Largest energy that entered the system up to the last check, J.
    energy_in: f64,
    /// Per wall while it is closed: accepted steps and Newton iterations (for
    /// [`Event::ContactEnd`]; only when the sink wants events).
    contact: Option<Vec<(usize, usize)>>,
    /// The sink wants [`Event`]s.
    events: bool,
    /// The policy is to carry the state-transition matrix (`crate::sensitivity`).
    pub wants_sensitivity: bool,
    /// With it, the parameter whose column `∂z/∂p` it carries too.
    pub sensitivity_parameter: Option<crate::sensitivity::Parameter>,
    /// It, at the end of the last advance.
    state_transition: Option<StateTransition>,
}

impl<'o> Run<'o> {
    pub(crate) fn new(
        sys: &System,
        x0: DVector<f64>,
        v0: DVector<f64>,
        record_dofs: Vec<usize>,
        n_rec: usize,
    ) -> Result<Self, SimError> {
        let cur = Box::new(State::initial(sys, x0, v0, 0.0)?);
        let mut log = ImpactLog::new(sys.walls.len());
        log.start(&sys.walls, &cur.walls, 0.0);
        let account = Account::new(sys);
        let mut out = Recorder::new(sys, record_dofs, n_rec);
        for (m, &d) in out.max_abs.iter_mut().zip(&out.dofs) {
            *m = cur.x[d].abs();
        }
        out.record(sys, &cur, &account);
        let e0 = mechanical_energy(sys, &cur);
        Ok(Self {
            since_check: 0,
            e0,
            energy_in: e0,
            trial: cur.clone(),
            cur,
            log: Some(log),
            out,
            account,
            stats: Stats::default(),
            observer: None,
            quiet_until: f64::NEG_INFINITY,
            observed_end: None,
            contact: None,
            events: false,
            wants_sensitivity: false,
            sensitivity_parameter: None,
            state_transition: None,
        })
    }

    /// Ends the run stopped by `error` (if any): the last check of the energy (runs shorter
    /// than [`interrupt::CHECK_EVERY`] steps), the row of the instant it stopped at, the last
    /// progress report, and everything it returns; `dt`: the step used, s.
    /// `impacts`: the table of a policy that keeps its own (else the run's log).
    pub(crate) fn finish(
        mut self,
        sys: &System,
        error: Option<SimError>,
        dt: f64,
        started: Instant,
        impacts: Option<Vec<ImpactRecord>>,
    ) -> RunOutput {
        self.settle_observer();
        let error = error.or_else(|| self.check_energy(sys).err());
        if error.is_some() && self.out.last_time != self.cur.t {
            self.out.record(sys, &self.cur, &self.account);
        }
        if let Some(sink) = self.out.sink.as_deref_mut() {
            sink.progress(self.cur.t);
        }
        self.stats.wall_time_s = started.elapsed().as_secs_f64();
        let mut out = self.out;
        out.complete();
        RunOutput {
            rows: out.rows,
            record_dofs: out.dofs,
            max_abs_displacement: out.max_abs,
            impacts: impacts
                .or(self.log.map(|log| log.records))
                .unwrap_or_default(),
            stats: self.stats,
            dt,
            error,
            state_transition: self.state_transition,
        }
    }

    /// Hands every accepted step from now on to `observer` but those it has no use for
    /// ([`StepObserver::quiet_until`]).
    pub(crate) fn observe(&mut self, observer: &'o mut dyn StepObserver) {
        self.quiet_until = observer.quiet_until();
        self.observer = Some(observer);
    }

    /// Hands the observer the state of the last committed step, if it has not had it
    /// ([`StepObserver::final_state`]), while `cur` is still that state.
    fn settle_observer(&mut self) {
        if let (Some(t), Some(observer)) = (self.observed_end.take(), self.observer.as_deref_mut())
        {
            observer.final_state(&self.cur, t);
        }
    }

    /// Computes from now on only what the observer needs ([`crate::settings::Outputs::Observed`]): no impact
    /// table, no peaks, no damping's work, no contacts' work but a radial gap's.
    pub(crate) fn keep_only_observed(&mut self, sys: &System) {
        self.log = None;
        self.out.peaks = Peaks::Off;
        self.out.max_abs.clear();
        self.account.damping_work = false;
        self.account.contact_work = sys.has_radial;
    }

    /// Hands the rows recorded from now on, the progress and the events to `sink`.
    pub(crate) fn watch(&mut self, sink: &'o mut dyn Sink) {
        self.events = sink.wants_events();
        if self.events {
            self.contact = Some(vec![(0, 0); self.cur.walls.len()]);
        }
        self.out.chunk = sink.chunk_rows().map(|n| n.max(1));
        self.out.sink = Some(sink);
        // the next row asks for room again, which is now also room in the block
        self.out.room = 0;
    }

    /// Reports the linear solver of `stepper` for steps of `dt` (when the sink wants events).
    pub(crate) fn report_linear_solver(&mut self, stepper: &dyn Stepper, dt: f64) {
        if let (Some(sink), Some(factor)) = (self.out.sink.as_deref_mut(), stepper.linear_solver())
        {
            if sink.wants_events() {
                sink.event(Event::LinearSolver { dt, factor });
            }
        }
    }

    /// Reports a step from `t` of length `dt` that Newton could not take and that is retried
    /// shorter (when the sink wants events).
    pub(crate) fn step_cut(&mut self, failure: &StepFailure, t: f64, dt: f64) {
        // the cut's sub-steps are committed but not recorded: their peaks per commit from now
        self.out.peaks_per_commit();
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

    /// Reports the walls that close or open in the accepted step from `cur` to `trial`, when
    /// the sink wants events (`contact` is kept only then). The test in line: every contact
    /// step of a run without such a sink paid the call (paper's case, callgrind: −6 a step).
    #[inline(always)]
    fn contact_events(&mut self, sys: &System, iterations: usize) {
        if self.contact.is_some() {
            self.report_contact_events(sys, iterations);
        }
    }

    #[inline(never)]
    fn report_contact_events(&mut self, sys: &System, iterations: usize) {
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
    /// account, peaks and impact table. Returns an error if the state is not finite. `free`:
    /// the trial state is the stepper's last attempt and [`Stepper::last_step_free`] (a
    /// policy that keeps an earlier attempt, or compares several, passes `false`). In line in
    /// the policy (out of line, a step that is not free pays ~28 instructions for the call).
    #[inline(always)]
    pub fn accept<S: Stepper + ?Sized>(
        &mut self,
        sys: &System,
        stepper: &mut S,
        h: f64,
        iterations: usize,
        free: bool,
    ) -> Result<(), SimError> {
        if free {
            self.commit_step::<true>(sys, h, 0, None, None)?;
        } else {
            self.commit_ends(sys, h, iterations)?;
        }
        stepper.accept(sys, &self.cur);
        Ok(())
    }

    /// [`Self::commit`] of a step that the integrator knows by its ends only (no integrals, no
    /// turns: every stepper's accepted attempt), compiled apart so that the tests of what it
    /// knew inside the step fold away.
    #[inline(never)]
    fn commit_ends(&mut self, sys: &System, h: f64, iterations: usize) -> Result<(), SimError> {
        self.commit_step::<false>(sys, h, iterations, None, None)
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
        let turns = integrals.map(|i| i.displacement_turns);
        self.commit(sys, h, iterations, integrals, turns)
    }

    /// [`Self::commit_trial`] without integrals but with `turns` (per DOF, as
    /// [`StepIntegrals::displacement_turns`]): a method that locates them on its exact
    /// solution (the event-driven flights) when [`Self::observed`].
    pub(crate) fn commit_with_turns(
        &mut self,
        sys: &System,
        h: f64,
        turns: &[Option<Turn>],
    ) -> Result<(), SimError> {
        self.commit(sys, h, 0, None, Some(turns))
    }

    /// The DOFs whose displacements are recorded.
    pub(crate) fn recorded_dofs(&self) -> &[usize] {
        &self.out.dofs
    }

    /// Whether a [`StepObserver`] watches the run (the one that asks for the turning points
    /// inside the steps of a method that spends work locating them).
    pub(crate) fn observed(&self) -> bool {
        self.observer.is_some()
    }

    /// The general commit ([`Self::commit_step`] with the walls), one body out of line for
    /// every method's callers; only the fixed-step loop's free steps inline the other variant.
    fn commit(
        &mut self,
        sys: &System,
        h: f64,
        iterations: usize,
        integrals: Option<&StepIntegrals>,
        turns: Option<&[Option<Turn>]>,
    ) -> Result<(), SimError> {
        self.commit_step::<false>(sys, h, iterations, integrals, turns)
    }

    /// [`Self::commit`]; `FREE`: the step was in free flight without a radial gap, its motion
    /// finite ([`Stepper::last_step_free`]), so no wall is closed at either end: the contact terms,
    /// the impact table and the sliding check have nothing to do, and the walls are not
    /// looked at (in line in the fixed-step loop).
    #[inline(always)]
    fn commit_step<const FREE: bool>(
        &mut self,
        sys: &System,
        h: f64,
        iterations: usize,
        integrals: Option<&StepIntegrals>,
        turns: Option<&[Option<Turn>]>,
    ) -> Result<(), SimError> {
        self.stats.newton_iterations += iterations;
        self.stats.steps += 1;
        let trial = &self.trial;
        // (a free step's stepper tested it: Stepper::last_step_free)
        if !FREE && !motion_finite(trial) {
            return Err(SimError::Diverged {
                t: trial.t,
                gap: busiest_gap(sys, &self.cur),
            });
        }
        if !FREE && sys.has_radial {
            check_sliding(sys, &self.cur, trial)?;
        }
        match integrals {
            Some(i) => self.account.add(i.work),
            None => self.account.commit(sys, &self.cur, trial),
        }
        if self.out.peaks == Peaks::PerCommit {
            for (m, &d) in self.out.max_abs.iter_mut().zip(&self.out.dofs) {
                let inside = turns.and_then(|t| t[d]);
                *m = m
                    .max(trial.x[d].abs())
                    .max(inside.map_or(0.0, |(_, x)| x.abs()));
            }
        }
        // a wall closed at either end of the step: the only ones the contact accounts and
        // the impact table look at (when the run keeps them)
        let touching = !FREE
            && (self.log.is_some() || self.account.contact_work)
            && self
                .cur
                .walls
                .iter()
                .zip(&trial.walls)
                .any(|(w0, w1)| w0.closed() || w1.closed());
        if touching {
            // each such wall's contact terms (without integrals) and its row of the table in
            // one pass (a pass for each cost a contact step of the paper's case ~10
            // instructions more; the pass without the test, whose set-up a step with every
            // wall open then paid, the rotor's Newmark run +0.9 %)
            let interior = integrals.map(|i| &i.walls);
            let (t0, dt) = (self.cur.t, trial.t - self.cur.t);
            let ends = sys.walls.iter().zip(&self.cur.walls).zip(&trial.walls);
            for (j, ((wall, w0), w1)) in ends.enumerate() {
                if !w0.closed() && !w1.closed() {
                    continue;
                }
                if integrals.is_none() {
                    self.account.contact_terms(w0, w1, dt);
                }
                if let Some(log) = self.log.as_mut() {
                    log.commit_wall(sys, j, wall, w0, w1, t0, h, interior);
                }
            }
        }
        if self.log.is_some() && touching {
            self.contact_events(sys, iterations);
        }
        if let Some(observer) = self.observer.as_deref_mut() {
            // (the complement of `>`: a NaN time is handed to the observer)
            let quiet = self.cur.t + h <= self.quiet_until;
            if !quiet {
                observer.accepted(sys, &self.cur, &self.trial, h, turns);
            }
            self.observed_end = Some(self.trial.t);
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
        let mut entered = self.e0 + self.account.external_work.abs();
        if sys.has_radial {
            // the work friction brings in from the prescribed spin (dry-friction whirl)
            entered += (-self.account.contact_dissipated).max(0.0);
        }
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

    /// The one time loop: advances `policy` to the end of the run, recording a row every
    /// `every` advances and after the last one. Returns the error that stopped the run, if any.
    /// Compiled per policy, so that a policy's `advance` is inlined into the loop.
    pub(crate) fn drive<P: StepPolicy + ?Sized>(
        &mut self,
        sys: &System,
        policy: &mut P,
        every: usize,
    ) -> Option<SimError> {
        // advances left until the next row (a countdown: no division per step)
        let mut until_row = every;
        // Free runs (StepPolicy::free_run) take the steps in free flight in one tight loop,
        // where nothing is watched per step: no state-transition matrix, no radial gap (its
        // slide is checked per step), no damping's work, only steps the observer has no use
        // for (a sweep's transient, Self::unobserved_until); either a row every step, the
        // rows' energies from the rows and no loads (their work would change the rows'
        // account), or no row and no peaks (a sweep's, Outputs::Observed: the row steps and
        // the last step are general steps); the peaks from the rows or off (Self::free_room).
        // A run ends at the next check of the interrupt and the energy and at the rows' room
        // (a full streamed block) or the next row, which the general step then takes.
        let rows = every == 1;
        let mut free_runs = !self.wants_sensitivity
            && !sys.has_radial
            && !self.account.damping_work
            && if rows {
                self.out.energies_from_rows && sys.loads.is_empty()
            } else {
                self.out.peaks == Peaks::Off
            };
        if self.out.peaks != Peaks::Off {
            self.out.peaks = if every == 1 && policy.commits_once_per_advance() {
                Peaks::FromRows
            } else {
                Peaks::PerCommit
            };
        }
        loop {
            if free_runs && self.free_run_starts() {
                // (without rows, up to the advance before the next row)
                let room = self.free_room(rows, until_row - 1);
                if room > 0 {
                    match policy.free_run(self, sys, room, rows) {
                        Some(taken) if !rows => until_row -= taken,
                        Some(_) => {}
                        None => free_runs = false,
                    }
                }
            }
            match policy.advance(self, sys) {
                Ok(true) => {
                    if let Some(observer) = self.observer.as_deref_mut() {
                        if let Some(s) = policy.sensitivity() {
                            observer.sensitivity(s);
                        }
                    }
                    until_row -= 1;
                    if until_row == 0 {
                        until_row = every;
                        self.out.record(sys, &self.cur, &self.account);
                    }
                }
                Ok(false) => {
                    self.state_transition = policy.sensitivity().cloned();
                    if until_row != every {
                        self.out.record(sys, &self.cur, &self.account);
                    }
                    return None;
                }
                Err(e) => {
                    self.state_transition = policy.sensitivity().cloned();
                    return Some(e);
                }
            }
        }
    }

    /// The steps a free run may take from here ([`Self::drive`]): up to the next check of the
    /// interrupt and the energy, and with `rows` the rows that fit, else `before_row`; none
    /// while the peaks are kept per commit (after a cut step).
    fn free_room(&self, rows: bool, before_row: usize) -> usize {
        if self.out.peaks == Peaks::PerCommit {
            return 0;
        }
        let to_check = (interrupt::CHECK_EVERY - 1).saturating_sub(self.since_check);
        to_check.min(if rows {
            self.out.room.saturating_sub(self.out.written)
        } else {
            before_row
        })
    }

    /// The steps from `s0` of length `h` with `s0.t + h` at most this are not handed to an
    /// observer ([`Self::commit_step`]'s test, [`StepObserver::quiet_until`]): every step
    /// without one.
    pub(crate) fn unobserved_until(&self) -> f64 {
        if self.observer.is_some() {
            self.quiet_until
        } else {
            f64::INFINITY
        }
    }

    /// Whether a free run may start from `cur` ([`Stepper::free_run`]): no contact force and
    /// every wall open, without force or potential, as in the state the trial becomes after a
    /// free step (an open wall keeps them, a closed one is reset: `WallState::set_open`), so
    /// that the rows' forces and potentials are +0. Asked by [`Self::drive`], not by the
    /// steppers: a contact's steps do not pay the calls down to them.
    fn free_run_starts(&self) -> bool {
        let unloaded = |w: &WallState| w.force.to_bits() == 0 && w.potential.to_bits() == 0;
        self.cur.phi.iter().all(|&p| p == 0.0)
            && self.cur.walls.iter().all(|w| !w.closed() && unloaded(w))
            && self.trial.walls.iter().all(|w| w.closed() || unloaded(w))
    }

    /// Ends a free run ([`Stepper::free_run`]) as `end` says: its rows (if any) become the
    /// recorder's, `cur` the state the general steps would have left (its gap rates, walls and
    /// forces from the last step's motion and gap coordinates, `State::finish_free_flight`;
    /// its loads' values), the account their external work, the steps count as committed, and
    /// an observer has had the last step (quiet: [`Self::settle_observer`] hands it its state).
    pub(crate) fn end_free_run<const N: usize>(
        &mut self,
        sys: &System,
        rows: FreeRows<N>,
        end: FreeRunEnd<N>,
    ) {
        let FreeRunEnd {
            taken,
            t,
            step_end,
            motion: [x, v, a],
            u,
            loads,
        } = end;
        self.out.wrote_free(rows);
        if let Some((values, external_work)) = loads {
            self.cur.load.copy_from_slice(values);
            self.account.external_work = external_work;
        }
        if self.observer.is_some() {
            self.observed_end = Some(step_end);
        }
        let cur = &mut *self.cur;
        cur.t = t;
        cur.x.sized_mut::<N>().copy_from_slice(x);
        cur.v.sized_mut::<N>().copy_from_slice(v);
        cur.a.sized_mut::<N>().copy_from_slice(a);
        let finite = cur.finish_free_flight::<N>(sys, u);
        debug_assert!(finite);
        self.stats.steps += taken;
        self.since_check += taken;
    }

    /// A rigid wall's impact at `t` with approach speed `v_in` and separation speed `v_out`,
    /// m/s (the impulsive methods, whose impacts are instants, not closings inside a step):
    /// to the observer and, as [`Event::Impact`], to the sink.
    pub(crate) fn impact(&mut self, sys: &System, wall: usize, t: f64, v_in: f64, v_out: f64) {
        if let Some(observer) = self.observer.as_deref_mut() {
            observer.impact(sys, wall, t, v_in);
        }
        if let (true, Some(sink)) = (self.events, self.out.sink.as_deref_mut()) {
            let w = &sys.walls[wall];
            sink.event(Event::Impact {
                t,
                gap: w.gap,
                side: w.sign,
                v_in,
                v_out,
            });
        }
    }

    /// A located event changes `cur` in place by `jump` (an impact's velocity jump,
    /// dissipating `dissipated` J): to the energy account and the peaks; the observer is
    /// handed the state before it.
    pub(crate) fn jump(&mut self, dissipated: f64, jump: impl FnOnce(&mut State)) {
        self.settle_observer();
        jump(&mut self.cur);
        self.account.add([0.0, 0.0, dissipated]);
        for (m, &d) in self.out.max_abs.iter_mut().zip(&self.out.dofs) {
            *m = m.max(self.cur.x[d].abs());
        }
    }

    /// Adds energy dissipated by contact impulses inside the last committed step, J.
    pub(crate) fn impulses_dissipated(&mut self, dissipated: f64) {
        self.account.add([0.0, 0.0, dissipated]);
    }
}

/// Where a free run ([`Stepper::free_run`]) ended, for [`Run::end_free_run`].
pub(crate) struct FreeRunEnd<'a, const N: usize> {
    /// Steps taken.
    pub taken: usize,
    /// The last step's end on the grid, and as the general step has it (`s₀.t + h`: the time
    /// its loads are evaluated at and an observer is handed).
    pub t: f64,
    pub step_end: f64,
    /// Its motion `[x, v, a]` and gap coordinates.
    pub motion: [&'a [f64; N]; 3],
    pub u: &'a [f64],
    /// With loads: their values at `step_end` and the account's external work, J.
    pub loads: Option<(&'a [f64], f64)>,
}

/// The work of a load on `dofs` over a step, `½ (f₀ + f₁) Σ (x₁ − x₀)` over them from its
/// values `[f₀, f₁]` and the displacements at the step's ends: the account's
/// ([`Account::commit`]) and a free run's, one arithmetic.
#[inline(always)]
pub(crate) fn load_work(dofs: &[usize], [f0, f1]: [f64; 2], x0: &[f64], x1: &[f64]) -> f64 {
    let moved: f64 = dofs.iter().map(|&d| x1[d] - x0[d]).sum();
    0.5 * (f0 + f1) * moved
}

/// Work integrals, accumulated every step with the trapezoidal rule in displacement,
/// `W = Σ Δxᵀ (f₀ + f₁)/2`, which is exact for the average-acceleration rule's linear part.
pub(crate) struct Account {
    external_work: f64,
    damping_dissipated: f64,
    contact_dissipated: f64,
    /// The damping matrix's form `Δxᵀ C (v₀ + v₁)`.
    damping: EnergyForm,
    /// The damping's and the contacts' work are accounted (the external work always is: the
    /// energy check reads it; [`Run::keep_only_observed`] turns them off).
    damping_work: bool,
    contact_work: bool,
}

impl Account {
    fn new(sys: &System) -> Self {
        Self {
            external_work: 0.0,
            damping_dissipated: 0.0,
            contact_dissipated: 0.0,
            damping: EnergyForm::new(&sys.structure.damping),
            damping_work: sys.has_damping,
            contact_work: true,
        }
    }

    /// The external work so far, J.
    pub(crate) fn external_work(&self) -> f64 {
        self.external_work
    }

    /// Adds increments of the external work, the damping and the contact dissipation, J.
    fn add(&mut self, work: [f64; 3]) {
        self.external_work += work[0];
        self.damping_dissipated += work[1];
        self.contact_dissipated += work[2];
    }

    /// The external work and the damping's (the contacts' come from
    /// [`Self::contact_terms`]). In line in both variants of `Run::commit_step` (called out
    /// of line, the rotor's Newmark run costs +0.8 %).
    #[inline(always)]
    fn commit(&mut self, sys: &System, s0: &State, s1: &State) {
        for (l, load) in sys.loads.iter().enumerate() {
            let f = [s0.load[l], s1.load[l]];
            self.external_work += load_work(&load.dofs, f, &s0.x, &s1.x);
        }
        if self.damping_work {
            // Δxᵀ C (v₀ + v₁)/2
            let st = &sys.structure;
            let mut d = self
                .damping
                .increment(&st.damping, &s0.x, &s1.x, &s0.v, &s1.v);
            if let Some(g) = &st.gyroscopic {
                // the gyroscopic forces Ω G x' (in `damping`) do no work
                d -= st.spin.start * g.increment_form(&s0.x, &s1.x, &s0.v, &s1.v);
            }
            self.damping_dissipated += 0.5 * d;
        }
    }

    /// The contact dissipation over a step `dt` long of a wall closed at either end of it,
    /// `w0` to `w1` (an open wall's terms are zero).
    #[inline(always)]
    fn contact_terms(&mut self, w0: &WallState, w1: &WallState, dt: f64) {
        let fd0 = w0.force - w0.elastic_force;
        let fd1 = w1.force - w1.elastic_force;
        self.contact_dissipated += 0.5 * (w1.penetration - w0.penetration) * (fd0 + fd1);
        // a radial wall's friction: its power F_T ρθ̇, trapezoidal in time
        let friction = w0.friction * w0.slide + w1.friction * w1.slide;
        self.contact_dissipated += 0.5 * dt * friction;
    }
}

/// Refuses a step in which a radial gap in contact under Coulomb friction has its sliding
/// speed `v_rel` change sign ([`SimError::Sticking`], at the linear interpolant's zero).
fn check_sliding(sys: &System, s0: &State, s1: &State) -> Result<(), SimError> {
    for ((wall, w0), w1) in sys.walls.iter().zip(&s0.walls).zip(&s1.walls) {
        let coulomb = matches!(
            sys.gaps[wall.gap].side,
            Side::Radial(r) if r.friction > 0.0 && r.friction_law == FrictionLaw::Coulomb
        );
        if coulomb && w0.closed() && w1.closed() && w0.slip * w1.slip <= 0.0 && w0.slip != w1.slip {
            let theta = w0.slip / (w0.slip - w1.slip);
            return Err(SimError::Sticking {
                t: s0.t + theta * (s1.t - s0.t),
                gap: wall.gap,
            });
        }
    }
    Ok(())
}

/// Whether the displacements and velocities of `s` are finite: compiled for the small
/// models' sizes ([`by_size`]), whose values are then at constant places, without the
/// slices' length tests (a third of a free-flight step's commit otherwise).
#[inline(always)]
fn motion_finite(s: &State) -> bool {
    by_size!(s.x.len(), |N| s.motion_finite::<N>())
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

/// Where a run's peaks `max_abs` come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Peaks {
    /// Each committed state ([`Run::commit`]) and each jump ([`Run::jump`]).
    PerCommit,
    /// Every committed state is recorded (a row every advance of a policy that commits once
    /// per advance, [`StepPolicy::commits_once_per_advance`]): from the rows when they are
    /// handed on ([`Recorder::complete`]), not per commit.
    FromRows,
    /// Not kept ([`crate::settings::Outputs::Observed`]).
    Off,
}

/// Decimated output buffers, handed to the sink (if any) every `chunk` rows.
pub(crate) struct Recorder<'o> {
    dofs: Vec<usize>,
    /// The walls of each gap (adjacent in `System::walls`), one column each.
    gap_walls: Vec<std::ops::Range<usize>>,
    /// The kinetic and strain energies' forms (mass and stiffness).
    kinetic: EnergyForm,
    strain: EnergyForm,
    /// Both forms are diagonal and every DOF is recorded, in order: the rows' kinetic and
    /// strain energies are evaluated from their recorded velocities and displacements when
    /// the rows are handed on ([`Self::complete`]), not per row (the same values).
    energies_from_rows: bool,
    /// The model has one DOF and it is recorded: a row's motion is read at constant places,
    /// without the dispatch on the model's size (every row of the 1-DOF models).
    one_dof: bool,
    /// The rows, written by index ([`Self::record`]): their columns' lengths lag behind
    /// `written` until [`Self::sync`].
    rows: Rows,
    /// Rows written into `rows`.
    written: usize,
    /// Rows that fit in every column of `rows` and, when streamed, in the block
    /// ([`Self::make_room`]).
    room: usize,
    /// The peaks (empty without them, [`Peaks::Off`]).
    max_abs: Vec<f64>,
    peaks: Peaks,
    /// Rows of `rows` already in `max_abs`.
    peaks_taken: usize,
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
        let mut gap_walls: Vec<std::ops::Range<usize>> = Vec::with_capacity(sys.n_gaps);
        for (j, wall) in sys.walls.iter().enumerate() {
            match gap_walls.last_mut() {
                Some(r) if sys.walls[r.start].gap == wall.gap => r.end = j + 1,
                _ => gap_walls.push(j..j + 1),
            }
        }
        let (kinetic, strain) = (
            EnergyForm::new(&sys.structure.mass),
            EnergyForm::new(&sys.structure.stiffness),
        );
        let energies_from_rows = matches!(
            (&kinetic, &strain),
            (EnergyForm::Diagonal(_), EnergyForm::Diagonal(_))
        ) && dofs.iter().copied().eq(0..sys.n_dof());
        Self {
            gap_walls,
            kinetic,
            strain,
            energies_from_rows,
            one_dof: sys.n_dof() == 1 && dofs == [0],
            rows: Rows::with_capacity(n_rec, dofs.len(), sys.n_gaps),
            written: 0,
            room: 0,
            max_abs: vec![0.0; dofs.len()],
            peaks: Peaks::PerCommit,
            peaks_taken: 0,
            dofs,
            last_time: f64::NAN,
            chunk: None,
            sink: None,
        }
    }

    /// The kinetic and strain energies of the rows recorded without them
    /// ([`Self::energies_from_rows`]), and the peaks of the rows not yet taken
    /// ([`Peaks::FromRows`]).
    fn complete(&mut self) {
        self.sync();
        let rows = &mut self.rows;
        if self.energies_from_rows {
            self.kinetic.fill(&mut rows.energy.kinetic, &rows.velocity);
            self.strain
                .fill(&mut rows.energy.strain, &rows.displacement);
        }
        let n = self.dofs.len();
        if self.peaks == Peaks::FromRows {
            // one DOF's column at a time: one tight loop per DOF, not one short loop per row
            let new_rows = &rows.displacement[self.peaks_taken * n..];
            let peak = |m: f64, x: &f64| m.max(x.abs());
            if let [m] = self.max_abs.as_mut_slice() {
                // one DOF: its column is the block, without a stride known only at run time
                *m = largest_abs(*m, new_rows);
            } else {
                for (i, m) in self.max_abs.iter_mut().enumerate() {
                    *m = new_rows[i..].iter().step_by(n).fold(*m, peak);
                }
            }
            self.peaks_taken = rows.time.len();
        }
    }

    /// Takes the peaks of the rows so far and keeps them per commit from now on (if kept).
    fn peaks_per_commit(&mut self) {
        self.complete();
        if self.peaks == Peaks::FromRows {
            self.peaks = Peaks::PerCommit;
        }
    }

    /// Writes the row of `s`. In line in its callers: out of line, its frame, spills and call
    /// were a fifth of a row's instructions.
    #[inline(always)]
    pub fn record(&mut self, sys: &System, s: &State, account: &Account) {
        // one test a row, for the columns' capacity and the streamed block's end together
        if self.written >= self.room {
            self.make_room(sys);
        }
        let r = self.written;
        self.written += 1;
        let rows = &mut self.rows;
        put(&mut rows.time, r, s.t);
        self.last_time = s.t;
        // (the peaks are kept by the commits, Run::commit and Run::jump, or taken from the
        // rows, Self::complete)
        if self.one_dof {
            debug_assert_eq!(s.x.len(), 1);
            put_motion::<1>(rows, &[0], r, s);
        } else {
            by_size!(s.x.len(), |N| put_motion::<N>(rows, &self.dofs, r, s));
        }
        // Walls of one gap are adjacent: one column per gap (deepest wall, summed force).
        let mut potential = 0.0;
        if let [_] = self.gap_walls[..] {
            // one gap (its walls are all the walls): without the loop and the slicing
            let (pen, force) = gap_columns(&s.walls, &mut potential);
            put(&mut rows.gap_penetration, r, pen);
            put(&mut rows.gap_force, r, force);
        } else {
            let first = r * self.gap_walls.len();
            for (i, walls) in (first..).zip(self.gap_walls.iter().map(|w| &s.walls[w.clone()])) {
                let (pen, force) = gap_columns(walls, &mut potential);
                put(&mut rows.gap_penetration, i, pen);
                put(&mut rows.gap_force, i, force);
            }
        }
        let e = &mut rows.energy;
        if !self.energies_from_rows {
            put(
                &mut e.kinetic,
                r,
                self.kinetic.value(&sys.structure.mass, &s.v),
            );
            put(
                &mut e.strain,
                r,
                self.strain.value(&sys.structure.stiffness, &s.x),
            );
        }
        put(&mut e.contact_potential, r, potential);
        put(&mut e.external_work, r, account.external_work);
        put(&mut e.damping_dissipated, r, account.damping_dissipated);
        put(&mut e.contact_dissipated, r, account.contact_dissipated);
    }

    /// The columns of a free run's rows from the next row on ([`FreeRows`]; the conditions of
    /// [`Run::drive`]'s free runs: every DOF recorded, in order, the energies from the rows;
    /// its rows within the room, [`Run::free_room`]), the account's values fixed over it.
    pub(crate) fn free_rows<const N: usize>(&mut self, account: &Account) -> FreeRows<N> {
        debug_assert!(self.energies_from_rows && self.dofs.len() == N);
        let (r, gaps) = (self.written, self.gap_walls.len());
        let rows = &mut self.rows;
        let e = &mut rows.energy;
        let at = |column: &mut Vec<f64>, width: usize| {
            debug_assert!(self.room * width <= column.capacity());
            // SAFETY: within the allocation: `make_room` made every column's capacity at
            // least `room > r` rows (asserted above in debug builds).
            unsafe { column.as_mut_ptr().add(r * width) }
        };
        FreeRows {
            time: at(&mut rows.time, 1),
            motion: [
                at(&mut rows.displacement, N),
                at(&mut rows.velocity, N),
                at(&mut rows.acceleration, N),
            ],
            gap_penetration: at(&mut rows.gap_penetration, gaps),
            gap_force: at(&mut rows.gap_force, gaps),
            energy: [
                at(&mut e.contact_potential, 1),
                at(&mut e.external_work, 1),
                at(&mut e.damping_dissipated, 1),
                at(&mut e.contact_dissipated, 1),
            ],
            account: [
                account.external_work,
                account.damping_dissipated,
                account.contact_dissipated,
            ],
            gaps,
            written: 0,
            room: self.room - r,
            last_time: self.last_time,
        }
    }

    /// The columns of a free run that writes no rows ([`Self::free_rows`] with no room).
    pub(crate) fn no_free_rows<const N: usize>(&self) -> FreeRows<N> {
        let none = std::ptr::null_mut();
        FreeRows {
            time: none,
            motion: [none; 3],
            gap_penetration: none,
            gap_force: none,
            energy: [none; 4],
            account: [0.0; 3],
            gaps: 0,
            written: 0,
            room: 0,
            last_time: self.last_time,
        }
    }

    /// The rows a free run wrote ([`Self::free_rows`]) are the recorder's.
    pub(crate) fn wrote_free<const N: usize>(&mut self, rows: FreeRows<N>) {
        rows.fill_constants();
        self.written += rows.written;
        self.last_time = rows.last_time;
    }

    /// The columns [`Self::record`] writes, each with its values a row (the kinetic and
    /// strain energies' none when they come from the rows, [`Self::complete`]).
    fn columns(&mut self) -> impl Iterator<Item = (&mut Vec<f64>, usize)> {
        let (n, gaps) = (self.dofs.len(), self.gap_walls.len());
        let energies = usize::from(!self.energies_from_rows);
        let Rows {
            time,
            displacement,
            velocity,
            acceleration,
            gap_penetration,
            gap_force,
            energy: e,
        } = &mut self.rows;
        [
            (time, 1),
            (displacement, n),
            (velocity, n),
            (acceleration, n),
            (gap_penetration, gaps),
            (gap_force, gaps),
            (&mut e.kinetic, energies),
            (&mut e.strain, energies),
            (&mut e.contact_potential, 1),
            (&mut e.external_work, 1),
            (&mut e.damping_dissipated, 1),
            (&mut e.contact_dissipated, 1),
        ]
        .into_iter()
        .filter(|&(_, width)| width > 0)
    }

    /// Brings the columns' lengths up to the rows written.
    fn sync(&mut self) {
        let written = self.written;
        for (column, width) in self.columns() {
            assert!(written * width <= column.capacity());
            // SAFETY: within the capacity (asserted), and `record` wrote every value of the
            // rows below `written` (each row `width` values from `row * width`).
            unsafe { column.set_len(written * width) };
        }
    }

    /// Room for at least one more row: a full streamed block goes to the sink first (before
    /// the next row is added, so that the last row always stays for the `RunOutput`), then
    /// every column gets room for one more (amortised growth, as `push`'s).
    #[cold]
    #[inline(never)]
    fn make_room(&mut self, sys: &System) {
        let block = self.chunk.filter(|_| self.sink.is_some());
        if let Some(n) = block.filter(|&n| self.written >= n) {
            let fresh = Rows::with_capacity(n, self.dofs.len(), sys.n_gaps);
            self.complete();
            (self.peaks_taken, self.written) = (0, 0);
            let full = std::mem::replace(&mut self.rows, fresh);
            if let Some(sink) = self.sink.as_deref_mut() {
                sink.rows(full);
            }
        }
        self.sync();
        let rows = self
            .columns()
            .map(|(column, width)| {
                column.reserve(width);
                column.capacity() / width
            })
            .fold(usize::MAX, usize::min);
        self.room = block.map_or(rows, |n| rows.min(n));
    }
}

/// The columns a free run writes its rows into ([`Recorder::free_rows`]), as pointers to its
/// first row held in locals: the run's values do not get reloaded after each write, which
/// could alias them for all the compiler knows, and the columns are not looked up per row.
pub(crate) struct FreeRows<const N: usize> {
    time: *mut f64,
    /// Displacement, velocity, acceleration.
    motion: [*mut f64; 3],
    gap_penetration: *mut f64,
    gap_force: *mut f64,
    /// Contact potential, external work, damping and contact dissipation.
    energy: [*mut f64; 4],
    /// The account's values (no work in free flight without loads or damping's work).
    account: [f64; 3],
    gaps: usize,
    /// Rows written, and that fit.
    written: usize,
    room: usize,
    last_time: f64,
}

impl<const N: usize> FreeRows<N> {
    /// [`Recorder::record`] of a free-flight state at `t`: `motion` its `x`, `v` and `a`,
    /// `walls` each wall's gap, sign and clearance (walls of a gap adjacent) and `depth` its
    /// penetration; every wall open, without force or potential ([`Run::free_run_starts`]):
    /// each gap's column the deepest of its walls (as [`gap_columns`] of the walls
    /// `State::finish_free_flight` opens); the force, the potential and the account's
    /// columns at the run's end ([`Self::fill_constants`]).
    #[inline(always)]
    pub(crate) fn write(
        &mut self,
        t: f64,
        motion: [&[f64; N]; 3],
        walls: &[(usize, f64, f64)],
        depth: &[f64],
    ) {
        assert!(self.written < self.room);
        let r = self.written;
        self.written += 1;
        self.last_time = t;
        // SAFETY: row `r` is below the room of every column (asserted; `Recorder::free_rows`)
        // and each writes its `width` values of the row from `r * width`.
        unsafe {
            self.time.add(r).write(t);
            for (column, values) in self.motion.into_iter().zip(motion) {
                for (i, &value) in values.iter().enumerate() {
                    column.add(r * N + i).write(value);
                }
            }
            let first = r * self.gaps;
            let mut previous = usize::MAX;
            let mut deepest = 0.0;
            for (&(g, ..), &depth) in walls.iter().zip(depth) {
                deepest = if g == previous {
                    f64::max(deepest, depth)
                } else {
                    depth
                };
                previous = g;
                self.gap_penetration.add(first + g).write(deepest);
            }
        }
    }

    /// The columns that stay the same over the run, for every row written: no force, no
    /// contact potential, the account's values (filled in one pass each, not per row).
    fn fill_constants(&self) {
        let rows = self.written;
        // SAFETY: the rows `write` wrote, within the room of every column as there.
        unsafe {
            for i in 0..rows * self.gaps {
                self.gap_force.add(i).write(0.0);
            }
            let [potential, work @ ..] = self.energy;
            for r in 0..rows {
                potential.add(r).write(0.0);
            }
            for (column, value) in work.into_iter().zip(self.account) {
                for r in 0..rows {
                    column.add(r).write(value);
                }
            }
        }
    }
}

/// A gap's columns from its walls' states (adjacent in `State::walls`): the deepest wall's
/// penetration and the summed force; their potentials added to `potential`. A one- or
/// two-sided gap without the loop over its walls (the same sums).
#[inline(always)]
fn gap_columns(walls: &[WallState], potential: &mut f64) -> (f64, f64) {
    match walls {
        [one] => {
            *potential += one.potential;
            (one.penetration, one.force)
        }
        [near, far] => {
            *potential += near.potential;
            *potential += far.potential;
            (
                near.penetration.max(far.penetration),
                near.force + far.force,
            )
        }
        _ => {
            let (mut pen, mut force) = (walls[0].penetration, walls[0].force);
            *potential += walls[0].potential;
            for other in &walls[1..] {
                pen = pen.max(other.penetration);
                force += other.force;
                *potential += other.potential;
            }
            (pen, force)
        }
    }
}

/// The recorded DOFs' displacements, velocities and accelerations of `s` into row `r` of
/// `rows`; `N`: the model's DOFs ([`by_size`]: a small model's values at constant places,
/// without their slices' length tests).
#[inline(always)]
fn put_motion<const N: usize>(rows: &mut Rows, dofs: &[usize], r: usize, s: &State) {
    let (x, v, a) = (s.x.sized::<N>(), s.v.sized::<N>(), s.a.sized::<N>());
    let mut put_dof = |i: usize, d: usize| {
        put(&mut rows.displacement, i, x[d]);
        put(&mut rows.velocity, i, v[d]);
        put(&mut rows.acceleration, i, a[d]);
    };
    // one recorded DOF (the 1-DOF models) without the loop's setup
    match *dofs {
        [d] => put_dof(r, d),
        ref dofs => (r * dofs.len()..)
            .zip(dofs)
            .for_each(|(i, &d)| put_dof(i, d)),
    }
}

/// Writes `value` at `column[i]`, which may be past its length (the rows not yet synced,
/// [`Recorder::sync`]) but is within its capacity ([`Recorder::make_room`]).
#[inline(always)]
fn put(column: &mut Vec<f64>, i: usize, value: f64) {
    debug_assert!(i < column.capacity());
    // SAFETY: `i` is below the capacity: `Recorder::record` writes the row `r < room`, and
    // `make_room` made every column's capacity at least `room` times its values a row.
    unsafe { column.as_mut_ptr().add(i).write(value) };
}

/// The largest of `m` and the `|x|` of `values`, in four running maxima combined at the end
/// so that the loop vectorises: the same value as one fold in order (the largest of the
/// values that are not NaN, which `f64::max` passes over, whatever their order).
fn largest_abs(m: f64, values: &[f64]) -> f64 {
    let peak = |m: f64, x: &f64| m.max(x.abs());
    let blocks = values.chunks_exact(4);
    let m = blocks.remainder().iter().fold(m, peak);
    let lanes = blocks.fold([m; 4], |l, b| std::array::from_fn(|k| peak(l[k], &b[k])));
    lanes.into_iter().fold(m, f64::max)
}

/// `½ yᵀ A y` of a structure matrix for every recorded row: by its diagonal when it has no
/// other entries (lumped masses, grounded springs, the 1-DOF models), without the sparse
/// form's setup per call, and with the same sums as [`Csr::quadratic_form`] (so the same
/// values); by the sparse form otherwise.
enum EnergyForm {
    Diagonal(Vec<f64>),
    Sparse,
}

impl EnergyForm {
    fn new(a: &Csr) -> Self {
        let (row_start, cols, vals) = a.parts();
        let mut diagonal = vec![0.0; a.n()];
        for (i, d) in diagonal.iter_mut().enumerate() {
            match &cols[row_start[i]..row_start[i + 1]] {
                [] => {}
                [j] if *j == i => *d = vals[row_start[i]],
                _ => return Self::Sparse,
            }
        }
        Self::Diagonal(diagonal)
    }

    /// Appends to `column` the diagonal form's value of each row of `rows` (every DOF of
    /// the model per row) past the column's length.
    fn fill(&self, column: &mut Vec<f64>, rows: &[f64]) {
        let Self::Diagonal(d) = self else {
            unreachable!("the energies come from the rows only with diagonal forms")
        };
        let rows = &rows[column.len() * d.len()..];
        // the common sizes compiled with their length known, so that a row's sum is unrolled
        match d.len() {
            1 => Self::fill_sized::<1>(d, column, rows),
            2 => Self::fill_sized::<2>(d, column, rows),
            n => column.extend(rows.chunks_exact(n).map(|y| diagonal_form(d, y))),
        }
    }

    /// [`Self::fill`] for `N` DOFs: the same sums, over rows of a length known at compile time.
    fn fill_sized<const N: usize>(d: &[f64], column: &mut Vec<f64>, rows: &[f64]) {
        let d: &[f64; N] = d.try_into().expect("a diagonal of N entries");
        column.extend(rows.chunks_exact(N).map(|y| diagonal_form(d, y)));
    }

    /// `(x₁ − x₀)ᵀ A (y₀ + y₁)` with [`Csr::increment_form`]'s sums.
    #[inline]
    fn increment(&self, a: &Csr, x0: &[f64], x1: &[f64], y0: &[f64], y1: &[f64]) -> f64 {
        match self {
            Self::Diagonal(d) => x0
                .iter()
                .zip(x1)
                .zip(y0.iter().zip(y1))
                .zip(d)
                .map(|(((x0, x1), (y0, y1)), di)| (x1 - x0) * (0.0 + di * (y0 + y1)))
                .sum(),
            Self::Sparse => a.increment_form(x0, x1, y0, y1),
        }
    }

    #[inline]
    fn value(&self, a: &Csr, y: &[f64]) -> f64 {
        match self {
            Self::Diagonal(d) => diagonal_form(d, y),
            Self::Sparse => a.quadratic_form(y),
        }
    }
}

/// `½ yᵀ diag(d) y` with [`Csr::quadratic_form`]'s sums (its row sum of one term is
/// `0.0 + d_i y_i`).
#[inline]
fn diagonal_form(d: &[f64], y: &[f64]) -> f64 {
    0.5 * y
        .iter()
        .zip(d)
        .map(|(yi, di)| yi * (0.0 + di * yi))
        .sum::<f64>()
}

#[cfg(test)]
mod tests {
    use nalgebra::{DMatrix, DVector};

    use super::*;
    use crate::contact::{Hysteretic, Law};
    use crate::gap::Gap;
    use crate::integrators::{NewmarkFamily, NewtonSettings};
    use crate::simulate::{simulate, Method, RunSettings};
    use crate::structure::{LinearStructure, Load, LoadHistory};

    /// Two lumped masses on grounded springs and dampers (diagonal M, C, K), a gap between
    /// them with both walls, a harmonic load on the second; `stiffness_coupling` adds a
    /// spring between them (K no longer diagonal).
    fn two_masses(stiffness_coupling: f64) -> System {
        let m = DMatrix::from_diagonal(&DVector::from_vec(vec![1.0, 0.4]));
        let mut k = DMatrix::from_diagonal(&DVector::from_vec(vec![4e4, 9e4]));
        k += DMatrix::from_row_slice(2, 2, &[1.0, -1.0, -1.0, 1.0]) * stiffness_coupling;
        let c = DMatrix::from_diagonal(&DVector::from_vec(vec![2.0, 1.0]));
        let gap = Gap {
            dofs: vec![1, 0],
            coefficients: vec![1.0, -1.0],
            clearance: 5e-4,
            side: Side::Both,
            law: Law::Hysteretic(Hysteretic::new("lankarani-nikravesh", 1e9, 1.5, 0.8).unwrap()),
        };
        let load = Load {
            dofs: vec![1],
            amplitude: 60.0,
            history: LoadHistory::Harmonic {
                frequency: 30.0,
                phase: 0.0,
            },
        };
        let s = LinearStructure::new(m, c, k).unwrap();
        System::new(s, vec![gap], vec![load]).unwrap()
    }

    /// The peaks' four running maxima give the in-order fold's value, NaN among the values
    /// or not, for every remainder length.
    #[test]
    fn largest_abs_is_the_fold_in_order() {
        let values: Vec<f64> = (0..23)
            .map(|k| ((k * 7919) % 31) as f64 * if k % 3 == 0 { -0.5 } else { 0.25 })
            .collect();
        let mut with_nan = values.clone();
        with_nan[5] = f64::NAN;
        for v in [&values, &with_nan] {
            for n in 0..v.len() {
                for m in [0.0_f64, 3.0, 100.0] {
                    let fold = v[..n].iter().fold(m, |m, x| m.max(x.abs()));
                    assert_eq!(largest_abs(m, &v[..n]).to_bits(), fold.to_bits());
                }
            }
        }
    }

    /// The recorder evaluates the kinetic and strain energies from the recorded rows after
    /// the run exactly when both forms are diagonal and every DOF is recorded in order, and
    /// those columns equal the ones evaluated row by row (the same DOFs recorded in the other
    /// order), to the bit, over a fixed-step run with contacts, with every row and with every
    /// third.
    #[test]
    fn energies_from_the_rows_equal_the_energies_per_row() {
        let sys = two_masses(0.0);
        let from_rows =
            |dofs: Vec<usize>, sys: &System| Recorder::new(sys, dofs, 1).energies_from_rows;
        assert!(from_rows(vec![0, 1], &sys));
        assert!(!from_rows(vec![1, 0], &sys));
        assert!(!from_rows(vec![1], &sys));
        assert!(!from_rows(vec![0, 1], &two_masses(2e4)));
        for every in [1, 3] {
            let run = |record_dofs: Vec<usize>| {
                let settings = RunSettings {
                    t_end: 0.1,
                    dt: 1e-5,
                    every,
                    record_dofs,
                    newton: NewtonSettings::default(),
                    adaptive: None,
                };
                let method = Method::Newmark(NewmarkFamily::average_acceleration());
                let v0 = DVector::from_vec(vec![0.2, -0.3]);
                simulate(&sys, method, &settings, DVector::zeros(2), v0).unwrap()
            };
            let (ordered, reversed) = (run(vec![0, 1]), run(vec![1, 0]));
            assert!(
                ordered.impacts.len() >= 4,
                "{} impacts",
                ordered.impacts.len()
            );
            let (a, b) = (&ordered.rows.energy, &reversed.rows.energy);
            assert_eq!(a.kinetic.len(), ordered.rows.time.len());
            assert_eq!(a.kinetic, b.kinetic);
            assert_eq!(a.strain, b.strain);
            assert!(a.kinetic.iter().any(|e| *e > 0.0) && a.strain.iter().any(|e| *e > 0.0));
        }
    }

    /// The diagonal form gives `Csr::quadratic_form`'s and `Csr::increment_form`'s values (the
    /// same sums, to the bit) for diagonal matrices with empty rows, signed zeros and negative
    /// entries; any off-diagonal entry makes the form the sparse one.
    #[test]
    fn diagonal_energy_form_equals_the_sparse_form() {
        let y = [0.3, -1.7, 0.0, 2.5e-3, -4.0e5];
        let (z, w) = ([0.1, -1.7, -0.0, 2.0, 3.0], [-0.3, 2.0, 0.0, -2.5e-3, 1e-9]);
        for diagonal in [
            vec![100.0, 0.0, 3.0, 1e-9, 7.5],
            vec![0.0; 5],
            vec![-2.0, 1.0, 1.0, 0.0, 1e11],
        ] {
            let a = Csr::from_dense(&DMatrix::from_diagonal(&diagonal.clone().into()));
            let form = EnergyForm::new(&a);
            assert!(matches!(form, EnergyForm::Diagonal(_)));
            for k in 1..=y.len() {
                let sub = Csr::from_dense(&DMatrix::from_fn(k, k, |i, j| {
                    if i == j {
                        diagonal[i]
                    } else {
                        0.0
                    }
                }));
                let got = EnergyForm::new(&sub).value(&sub, &y[..k]);
                assert_eq!(got, sub.quadratic_form(&y[..k]), "{diagonal:?} {k}");
                let (x1, y1) = (&z[..k], &w[..k]);
                let got = EnergyForm::new(&sub).increment(&sub, &y[..k], x1, &y[..k], y1);
                let expected = sub.increment_form(&y[..k], x1, &y[..k], y1);
                assert_eq!(got.to_bits(), expected.to_bits(), "{diagonal:?} {k}");
            }
            assert_eq!(form.value(&a, &y), a.quadratic_form(&y));
        }
        let coupled = Csr::from_dense(&DMatrix::from_row_slice(2, 2, &[2.0, -1.0, -1.0, 2.0]));
        assert!(matches!(EnergyForm::new(&coupled), EnergyForm::Sparse));
    }
}
