//! Batch runs for parameter sweeps and bifurcation diagrams (docs/sweeps.md): many variants
//! of a model run in parallel threads (rayon), each reduced while it runs to what a sweep
//! needs, so that no time history is ever stored:
//!
//! * stroboscopic (Poincaré) samples of displacement and velocity at `t = (N_tr + k) T`,
//!   `k = 1 … N` (or `per_period` samples a period, `t = N_tr T + k T / per_period`), after a
//!   transient of `N_tr` forcing periods `T` — taken at the step that
//!   ends there (fixed steps are made a whole fraction of `T`) or, with adaptive steps, from
//!   the cubic Hermite interpolant of the accepted step that contains the instant;
//! * after the transient: largest and smallest displacement (step ends and the Hermite
//!   interpolant's interior extrema), RMS displacement (Simpson's rule on the interpolant),
//!   and per gap the number of impacts, the largest approach speed and the first impacts'
//!   approach speeds and forcing phases (the crossing located as in the impact table);
//! * the final state `(x, v)` of every DOF, so that a response curve can continue from it:
//!   [`run_sweep`] with chains runs the points of each chain one after the other, each
//!   starting from the final state of the previous one (up- and down-sweeps, hysteresis).

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

use nalgebra::DVector;
use rayon::prelude::*;

use crate::error::{invalid, SimError};
use crate::gap::WallState;
use crate::integrators::sized::by_size;
use crate::interpolation::HermiteSegment;
use crate::method::Method;
use crate::observe::{StepObserver, Turn};
use crate::output::Stats;
use crate::settings::{Outputs, RunSettings};
use crate::simulate::simulate_observed;
use crate::system::{State, System};

/// What a sweep keeps of each run, and how long the run is.
#[derive(Debug, Clone, PartialEq)]
pub struct Sampling {
    /// Sampling (forcing) period `T`, s.
    pub period: f64,
    /// Transient `N_tr`, in periods: nothing is kept before `N_tr T`.
    pub transient: usize,
    /// Number of samples `N`, `per_period` a period: the run lasts `(N_tr + N / per_period) T`.
    pub samples: usize,
    /// Samples per period (1: the stroboscopic map; more: a time history at `T / per_period`
    /// for spectra, e.g. a rotor's full-spectrum waterfall).
    pub per_period: usize,
    /// DOFs sampled (displacement, velocity, peaks, RMS).
    pub dofs: Vec<usize>,
    /// Approach speeds and phases kept per gap (the first impacts after the transient).
    pub max_impacts: usize,
}

impl Sampling {
    /// Start of the kept window, s.
    pub fn start(&self) -> f64 {
        self.transient as f64 * self.period
    }

    /// Duration of the run, s.
    pub fn t_end(&self) -> f64 {
        (self.transient as f64 + self.samples as f64 / self.per_period as f64) * self.period
    }

    fn validate(&self, n_dof: usize) -> Result<(), SimError> {
        if !(self.period.is_finite() && self.period > 0.0) {
            return invalid(format!(
                "sweep.period: {} is not valid; expected a forcing period > 0 in s",
                self.period
            ));
        }
        if self.samples == 0 {
            return invalid("sweep.periods: 0 is not valid; expected at least 1 sampled period");
        }
        if self.per_period == 0 || self.samples % self.per_period != 0 {
            return invalid(format!(
                "sweep.per_period: {} is not valid; expected an integer >= 1 that divides the \
                 {} samples",
                self.per_period, self.samples
            ));
        }
        if let Some(d) = self.dofs.iter().find(|&&d| d >= n_dof) {
            return invalid(format!(
                "sweep.dofs: {d} is out of range; expected 0 <= dof < {n_dof}"
            ));
        }
        Ok(())
    }
}

/// One point of a sweep: a model variant, how to run it and what to keep.
#[derive(Debug, Clone)]
pub struct SweepJob {
    pub system: Arc<System>,
    pub method: Method,
    /// `t_end`, `every` and `record_dofs` are set from `sampling`; with fixed steps `dt` is
    /// shortened so that a period is a whole number of steps (samples land on step ends).
    pub settings: RunSettings,
    pub x0: DVector<f64>,
    pub v0: DVector<f64>,
    pub sampling: Sampling,
}

/// What a sweep keeps of one run. Per-DOF arrays follow `Sampling::dofs`; per-gap arrays the
/// model's gaps. Values not reached (a run stopped by an error) are NaN.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PointSummary {
    /// Stroboscopic samples, row-major `samples × dofs`, m and m/s.
    pub poincare_displacement: Vec<f64>,
    pub poincare_velocity: Vec<f64>,
    /// After the transient: largest and smallest displacement and its RMS, m.
    pub displacement_max: Vec<f64>,
    pub displacement_min: Vec<f64>,
    pub displacement_rms: Vec<f64>,
    /// After the transient, per gap: impacts (contacts that began), largest approach speed
    /// (m/s; NaN without impacts).
    pub impact_count: Vec<usize>,
    pub impact_velocity_max: Vec<f64>,
    /// The first `max_impacts` impacts of each gap, row-major `gaps × max_impacts`: approach
    /// speed (m/s) and phase in the forcing period (fraction in [0, 1)); NaN-padded.
    pub impact_velocity: Vec<f64>,
    pub impact_phase: Vec<f64>,
    /// State of every DOF at the end of the run (m, m/s) and its time (s).
    pub final_displacement: Vec<f64>,
    pub final_velocity: Vec<f64>,
    pub final_time: f64,
    pub stats: Stats,
    /// Why the run stopped early (invalid settings or a solver failure).
    pub error: Option<SimError>,
}

/// The streaming reducer of one run.
struct Reducer<'a> {
    sampling: &'a Sampling,
    n_gaps: usize,
    /// The model has one DOF: its steps are reduced without the dispatch on the model's
    /// size (the 1-DOF sweeps, every step after the transient).
    one_dof: bool,
    start: f64,
    /// Index (1-based) of the next stroboscopic sample, and its time (s; infinite when
    /// every sample is taken).
    next_sample: usize,
    next_time: f64,
    /// Time between samples, `T / per_period`, s.
    interval: f64,
    /// Per sampled DOF, in [`Sampling::dofs`]' order: what its steps add up to (one array a
    /// step walks, not four).
    per_dof: Vec<DofReduction>,
    /// The time the `∫ x² dt` cover, s.
    covered: f64,
    out: PointSummary,
}

/// A sampled DOF's `∫ x² dt` and its largest and smallest displacement after the transient
/// (into [`PointSummary`]'s displacement RMS, max and min at the end, [`Reducer::finish`]).
struct DofReduction {
    dof: usize,
    square_integral: f64,
    max: f64,
    min: f64,
}

impl<'a> Reducer<'a> {
    fn new(sampling: &'a Sampling, n_gaps: usize, x0: &[f64], v0: &[f64]) -> Self {
        let nd = sampling.dofs.len();
        let ns = sampling.samples;
        let ni = sampling.max_impacts;
        let mut reducer = Self {
            sampling,
            n_gaps,
            one_dof: x0.len() == 1,
            start: sampling.start(),
            interval: sampling.period / sampling.per_period as f64,
            next_sample: 1,
            next_time: f64::INFINITY,
            per_dof: (sampling.dofs.iter())
                .map(|&dof| DofReduction {
                    dof,
                    square_integral: 0.0,
                    max: f64::NEG_INFINITY,
                    min: f64::INFINITY,
                })
                .collect(),
            covered: 0.0,
            out: PointSummary {
                poincare_displacement: vec![f64::NAN; ns * nd],
                poincare_velocity: vec![f64::NAN; ns * nd],
                displacement_max: Vec::new(),
                displacement_min: Vec::new(),
                displacement_rms: Vec::new(),
                impact_count: vec![0; n_gaps],
                impact_velocity_max: vec![f64::NAN; n_gaps],
                impact_velocity: vec![f64::NAN; n_gaps * ni],
                impact_phase: vec![f64::NAN; n_gaps * ni],
                final_displacement: x0.to_vec(),
                final_velocity: v0.to_vec(),
                final_time: 0.0,
                stats: Stats::default(),
                error: None,
            },
        };
        reducer.next_time = reducer.sample_time(1);
        reducer
    }

    /// The time of sample `k` (1-based), s; infinite past the last.
    fn sample_time(&self, k: usize) -> f64 {
        if k <= self.sampling.samples {
            self.start + k as f64 * self.interval
        } else {
            f64::INFINITY
        }
    }

    fn finish(mut self) -> PointSummary {
        let out = &mut self.out;
        let reached = |v: f64| if v.is_infinite() { f64::NAN } else { v };
        let rms = |r: &DofReduction| {
            if self.covered > 0.0 {
                (r.square_integral / self.covered).sqrt()
            } else {
                f64::NAN
            }
        };
        out.displacement_max = self.per_dof.iter().map(|r| reached(r.max)).collect();
        out.displacement_min = self.per_dof.iter().map(|r| reached(r.min)).collect();
        out.displacement_rms = self.per_dof.iter().map(rms).collect();
        self.out
    }
}

/// Step ends closer than this fraction of the step to an instant are taken as landing on it.
const STEP_END_TOLERANCE: f64 = 1e-6;

/// Hermite interpolant of DOF `d`'s displacement over the step, from the displacements and
/// velocities `(x0, v0)` at its start and `(x1, v1)` at its end (a state's, or their sized
/// slices, [`Reducer::peaks_and_rms`]).
#[inline(always)]
fn displacement_segment(
    [x0, v0]: [&[f64]; 2],
    [x1, v1]: [&[f64]; 2],
    d: usize,
    h: f64,
) -> HermiteSegment {
    HermiteSegment {
        y0: x0[d],
        dy0: v0[d],
        y1: x1[d],
        dy1: v1[d],
        h,
    }
}

impl StepObserver for Reducer<'_> {
    fn accepted(
        &mut self,
        sys: &System,
        s0: &State,
        s1: &State,
        h: f64,
        turns: Option<&[Option<Turn>]>,
    ) {
        if s0.t + h <= self.start + STEP_END_TOLERANCE * h {
            // nothing is kept of the transient (the steps that end by `start` do not come
            // here, Self::quiet_until; the final state comes through Self::final_state)
            return;
        }
        if self.one_dof {
            // (a 1-DOF sweep's every step after the transient: in line, without the dispatch
            // on the model's size)
            debug_assert_eq!(s1.x.len(), 1);
            self.reduce_sized::<1>(sys, s0, s1, h, turns);
        } else {
            self.reduce(sys, s0, s1, h, turns);
        }
    }

    /// The transient: nothing is kept of its steps.
    fn quiet_until(&self) -> f64 {
        self.start
    }

    /// The run's final state (once, at its end: not copied every step).
    fn final_state(&mut self, s: &State, t: f64) {
        self.out.final_displacement.copy_from_slice(&s.x);
        self.out.final_velocity.copy_from_slice(&s.v);
        self.out.final_time = t;
    }

    fn impact(&mut self, sys: &System, wall: usize, t: f64, speed: f64) {
        self.count_impact(sys.walls[wall].gap, t, speed);
    }
}

impl Reducer<'_> {
    /// [`StepObserver::accepted`] for a step that ends after the transient: its samples, its
    /// part of the peaks and the RMS, its impacts; compiled for the model's size
    /// ([`by_size`]), out of line (a 1-DOF model's in line, [`Self::reduce_sized`]).
    #[inline(never)]
    fn reduce(
        &mut self,
        sys: &System,
        s0: &State,
        s1: &State,
        h: f64,
        turns: Option<&[Option<Turn>]>,
    ) {
        by_size!(s1.x.len(), |N| self
            .reduce_sized::<N>(sys, s0, s1, h, turns));
    }

    /// [`Self::reduce`] for `N` DOFs: what every step does in line, what only some steps do
    /// (a sample, a wall that closes) out of line.
    #[inline(always)]
    fn reduce_sized<const N: usize>(
        &mut self,
        sys: &System,
        s0: &State,
        s1: &State,
        h: f64,
        turns: Option<&[Option<Turn>]>,
    ) {
        let (t0, t1) = (s0.t, s0.t + h);
        let tol = STEP_END_TOLERANCE * h;
        if self.next_time <= t1 + tol {
            self.take_samples(s0, s1, h);
        }

        // Peaks and RMS over the part of the step after the transient, [θa, 1]: all of it
        // but in the step that ends the transient
        if t0 >= self.start - tol {
            self.peaks_and_rms::<N>(s0, s1, h, turns, 0.0);
        } else {
            self.peaks_and_rms::<N>(s0, s1, h, turns, (self.start - t0) / h);
        }

        // Impacts: a wall that closes inside the step (a rigid wall's impacts come as such,
        // `StepObserver::impact`).
        for (wall, (ws0, ws1)) in s0.walls.iter().zip(&s1.walls).enumerate() {
            if ws1.closed() && !ws0.closed() {
                self.wall_closed(sys, wall, ws0, ws1, t0, h);
            }
        }
    }

    /// The stroboscopic samples inside the step `(t0, t1]`.
    #[inline(never)]
    fn take_samples(&mut self, s0: &State, s1: &State, h: f64) {
        let (t0, t1) = (s0.t, s0.t + h);
        let tol = STEP_END_TOLERANCE * h;
        let dofs = &self.sampling.dofs;
        let nd = dofs.len();
        while self.next_time <= t1 + tol {
            let ts = self.next_time;
            let row = (self.next_sample - 1) * nd;
            if (t1 - ts).abs() <= tol {
                for (j, &d) in dofs.iter().enumerate() {
                    self.out.poincare_displacement[row + j] = s1.x[d];
                    self.out.poincare_velocity[row + j] = s1.v[d];
                }
            } else {
                let theta = ((ts - t0) / h).clamp(0.0, 1.0);
                for (j, &d) in dofs.iter().enumerate() {
                    let x = displacement_segment([&s0.x, &s0.v], [&s1.x, &s1.v], d, h);
                    let v = HermiteSegment {
                        y0: s0.v[d],
                        dy0: s0.a[d],
                        y1: s1.v[d],
                        dy1: s1.a[d],
                        h,
                    };
                    self.out.poincare_displacement[row + j] = x.value(theta);
                    self.out.poincare_velocity[row + j] = v.value(theta);
                }
            }
            self.next_sample += 1;
            self.next_time = self.sample_time(self.next_sample);
        }
    }

    /// The wall `wall` closed inside the step from `t0`: an impact at the located crossing.
    #[inline(never)]
    fn wall_closed(
        &mut self,
        sys: &System,
        wall: usize,
        ws0: &WallState,
        ws1: &WallState,
        t0: f64,
        h: f64,
    ) {
        let gap = sys.walls[wall].gap;
        if sys.gaps[gap].law.is_rigid() {
            return;
        }
        let seg = ws0.penetration_segment(ws1, h);
        let theta = seg.crossing();
        self.count_impact(gap, t0 + theta * h, seg.rate(theta));
    }

    /// The peaks and the RMS over the fraction `[theta_a, 1]` of the step, for `N` DOFs.
    /// Compiled in line for each call: with `theta_a = 0`, the case of every step but one,
    /// its interpolant's values at `theta_a` and at the middle are folded into constants.
    #[inline(always)]
    fn peaks_and_rms<const N: usize>(
        &mut self,
        s0: &State,
        s1: &State,
        h: f64,
        turns: Option<&[Option<Turn>]>,
        theta_a: f64,
    ) {
        let span = (1.0 - theta_a) * h;
        self.covered += span;
        let start: [&[f64]; 2] = [s0.x.sized::<N>(), s0.v.sized::<N>()];
        let end: [&[f64]; 2] = [s1.x.sized::<N>(), s1.v.sized::<N>()];
        for r in &mut self.per_dof {
            let seg = displacement_segment(start, end, r.dof, h);
            let xa = if theta_a == 0.0 {
                seg.y0
            } else {
                seg.value(theta_a)
            };
            let xb = seg.y1;
            let xm = seg.value(0.5 * (1.0 + theta_a));
            r.square_integral += span / 6.0 * (xa * xa + 4.0 * xm * xm + xb * xb);
            let (mut hi, mut lo) = (xa.max(xb), xa.min(xb));
            // an interior extremum: the integrator's own turning point, or the rate turning
            // from + to − (a peak) or from − to + (a trough) inside the step
            let turned = (seg.dy0 > 0.0 && seg.dy1 < 0.0) || (seg.dy0 < 0.0 && seg.dy1 > 0.0);
            if turns.is_some() || turned {
                (hi, lo) = interior_extremes(seg, turns.map(|t| t[r.dof]), theta_a, hi, lo);
            }
            r.max = r.max.max(hi);
            r.min = r.min.min(lo);
        }
    }

    /// An impact on `gap` at `tc` with approach speed `speed`: counted after the transient.
    fn count_impact(&mut self, gap: usize, tc: f64, speed: f64) {
        if tc <= self.start {
            return;
        }
        let (period, max_impacts) = (self.sampling.period, self.sampling.max_impacts);
        debug_assert!(gap < self.n_gaps);
        let k = self.out.impact_count[gap];
        if k < max_impacts {
            self.out.impact_velocity[gap * max_impacts + k] = speed;
            let phase = ((tc - self.start) / period).rem_euclid(1.0);
            self.out.impact_phase[gap * max_impacts + k] = phase;
        }
        self.out.impact_count[gap] = k + 1;
        let vmax = &mut self.out.impact_velocity_max[gap];
        *vmax = vmax.max(speed); // NaN (no impact yet) gives way to the speed
    }
}

/// `hi` and `lo` of a step over its fraction `[theta_a, 1]` widened by its interior peak or
/// trough: the integrator's own turning point `turn` when it locates them (`Some(turns)`:
/// `turn` of this DOF, if any), else the interpolant's. Out of line, `seg` by value: a step
/// in which the rate keeps its sign (most) neither pays for its registers nor writes `seg`.
#[inline(never)]
fn interior_extremes(
    seg: HermiteSegment,
    turn: Option<Option<Turn>>,
    theta_a: f64,
    hi: f64,
    lo: f64,
) -> (f64, f64) {
    let (mut hi, mut lo) = (hi, lo);
    if let Some(turn) = turn {
        // the integrator's own turning point (a peak or a trough)
        if let Some((_, x)) = turn.filter(|&(s, _)| s >= theta_a) {
            (hi, lo) = (hi.max(x), lo.min(x));
        }
    } else if seg.dy0 > 0.0 && seg.dy1 < 0.0 {
        // an interior peak needs the rate to turn from + to − inside the step
        if let Some((s, peak)) = seg.interior_peak() {
            if s >= theta_a {
                hi = hi.max(peak);
            }
        }
    } else if seg.dy0 < 0.0 && seg.dy1 > 0.0 {
        // and a trough from − to +: the peak of −x
        let neg = HermiteSegment {
            y0: -seg.y0,
            dy0: -seg.dy0,
            y1: -seg.y1,
            dy1: -seg.dy1,
            h: seg.h,
        };
        if let Some((s, peak)) = neg.interior_peak() {
            if s >= theta_a {
                lo = lo.min(-peak);
            }
        }
    }
    (hi, lo)
}

/// Runs one point from `x0, v0` (the job's own initial state unless given).
pub fn run_point(job: &SweepJob, start: Option<(&[f64], &[f64])>) -> PointSummary {
    let sampling = &job.sampling;
    let (x0, v0) = match start {
        Some((x, v)) => (DVector::from_column_slice(x), DVector::from_column_slice(v)),
        None => (job.x0.clone(), job.v0.clone()),
    };
    let mut reducer = Reducer::new(sampling, job.system.n_gaps, x0.as_slice(), v0.as_slice());
    let fail = |mut reducer: Reducer<'_>, e: SimError| {
        reducer.out.error = Some(e);
        reducer.finish()
    };
    if let Err(e) = sampling.validate(job.system.n_dof()) {
        return fail(reducer, e);
    }
    let mut settings = job.settings.clone();
    let period = sampling.period;
    settings.t_end = sampling.t_end();
    settings.every = usize::MAX;
    settings.record_dofs = sampling.dofs.clone();
    if settings.adaptive.is_none() && settings.dt.is_finite() && settings.dt > 0.0 {
        // a whole number of steps between samples: they land on step ends
        let interval = period / sampling.per_period as f64;
        settings.dt = interval / (interval / settings.dt - 1e-9).ceil().max(1.0);
    }
    match simulate_observed(
        &job.system,
        job.method,
        &settings,
        x0,
        v0,
        Some(&mut reducer),
        Outputs::Observed,
    ) {
        Ok(out) => {
            let stats = out.stats;
            let error = out.error;
            let mut summary = reducer.finish();
            summary.stats = stats;
            summary.error = error;
            summary
        }
        Err(e) => fail(reducer, e),
    }
}

/// Thread pools by size, built once and shared by the calls that ask for that many threads.
fn pool(threads: usize) -> Result<Arc<rayon::ThreadPool>, SimError> {
    static POOLS: OnceLock<Mutex<HashMap<usize, Arc<rayon::ThreadPool>>>> = OnceLock::new();
    let mut pools = POOLS
        .get_or_init(|| Mutex::new(HashMap::new()))
        .lock()
        .unwrap_or_else(|e| e.into_inner());
    if let Some(p) = pools.get(&threads) {
        return Ok(p.clone());
    }
    let p = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(|i| format!("vibroimpact-sweep-{i}"))
        .build()
        .map_err(|e| SimError::InvalidModel(format!("sweep.threads: {e}")))?;
    let p = Arc::new(p);
    pools.insert(threads, p.clone());
    Ok(p)
}

/// Runs every job in parallel and returns their summaries in job order.
///
/// Without `chains` the points are independent. With `chains` (each job in exactly one chain)
/// the jobs of a chain run one after the other, each from the final state of the previous one
/// (numerical continuation of a response curve; a point that failed passes on nothing, and
/// the next starts from its own initial state); the chains run in parallel.
///
/// `threads`: size of the thread pool (`None`: rayon's global pool, all cores). The results
/// do not depend on it: every point is computed by one thread, in the same operations.
pub fn run_sweep(
    jobs: &[SweepJob],
    chains: Option<&[Vec<usize>]>,
    threads: Option<usize>,
) -> Result<Vec<PointSummary>, SimError> {
    if let Some(chains) = chains {
        let mut seen = vec![false; jobs.len()];
        for &j in chains.iter().flatten() {
            if j >= jobs.len() || seen[j] {
                return invalid(format!(
                    "sweep.chains: job {j} is out of range or in two chains; expected each of \
                     the {} jobs in exactly one chain",
                    jobs.len()
                ));
            }
            seen[j] = true;
        }
        if let Some(j) = seen.iter().position(|s| !s) {
            return invalid(format!(
                "sweep.chains: job {j} is in no chain; expected each job in exactly one chain"
            ));
        }
    }
    if threads == Some(0) {
        return invalid("sweep.threads: 0 is not valid; expected at least 1 thread");
    }
    let work = || -> Vec<PointSummary> {
        match chains {
            None => jobs.par_iter().map(|job| run_point(job, None)).collect(),
            Some(chains) => {
                let done: Vec<Vec<(usize, PointSummary)>> = chains
                    .par_iter()
                    .map(|chain| run_chain(jobs, chain))
                    .collect();
                let mut slots: Vec<Option<PointSummary>> = vec![None; jobs.len()];
                for (j, s) in done.into_iter().flatten() {
                    slots[j] = Some(s);
                }
                slots.into_iter().map(Option::unwrap_or_default).collect()
            }
        }
    };
    Ok(match threads {
        None => work(),
        Some(n) => pool(n)?.install(work),
    })
}

fn run_chain(jobs: &[SweepJob], chain: &[usize]) -> Vec<(usize, PointSummary)> {
    let mut out: Vec<(usize, PointSummary)> = Vec::with_capacity(chain.len());
    for &j in chain {
        let start = out
            .last()
            .map(|(_, p)| p)
            .filter(|p| p.error.is_none())
            .map(|p| (p.final_displacement.clone(), p.final_velocity.clone()));
        let job = &jobs[j];
        let summary = match &start {
            Some((x, v)) if x.len() == job.system.n_dof() => {
                run_point(job, Some((x.as_slice(), v.as_slice())))
            }
            _ => run_point(job, None),
        };
        out.push((j, summary));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::{KelvinVoigt, Law};
    use crate::gap::{Gap, Side};
    use crate::integrators::{NewmarkFamily, NewtonSettings};
    use crate::simulate::simulate;
    use crate::structure::{LinearStructure, Load, LoadHistory};
    use nalgebra::DMatrix;

    /// `x'' + 2ζω x' + ω² x = F sin(2π f t)` with a stiff wall at `x = d`.
    fn oscillator(frequency: f64, clearance: f64) -> System {
        let w = 2.0 * std::f64::consts::PI;
        let structure = LinearStructure::new(
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::from_element(1, 1, 2.0 * 0.05 * w),
            DMatrix::from_element(1, 1, w * w),
        )
        .unwrap();
        let gap = Gap {
            dofs: vec![0],
            coefficients: vec![1.0],
            clearance,
            side: Side::Positive,
            law: Law::KelvinVoigt(KelvinVoigt::new(1e5, 20.0).unwrap()),
        };
        let load = Load {
            dofs: vec![0],
            amplitude: 1.0,
            history: LoadHistory::Harmonic {
                frequency,
                phase: 0.0,
            },
        };
        System::new(structure, vec![gap], vec![load]).unwrap()
    }

    /// Bitwise equality (NaN padding included), wall time aside.
    fn same(a: &PointSummary, b: &PointSummary) -> bool {
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let fields = |p: &PointSummary| {
            [
                bits(&p.poincare_displacement),
                bits(&p.poincare_velocity),
                bits(&p.displacement_max),
                bits(&p.displacement_min),
                bits(&p.displacement_rms),
                bits(&p.impact_velocity_max),
                bits(&p.impact_velocity),
                bits(&p.impact_phase),
                bits(&p.final_displacement),
                bits(&p.final_velocity),
                bits(&[p.final_time]),
            ]
        };
        fields(a) == fields(b)
            && a.impact_count == b.impact_count
            && a.stats.steps == b.stats.steps
            && a.stats.newton_iterations == b.stats.newton_iterations
            && a.error == b.error
    }

    fn job(frequency: f64, clearance: f64) -> SweepJob {
        SweepJob {
            system: Arc::new(oscillator(frequency, clearance)),
            method: Method::Newmark(NewmarkFamily::average_acceleration()),
            settings: RunSettings {
                t_end: 1.0,
                dt: 1e-3,
                every: 1,
                record_dofs: vec![0],
                newton: NewtonSettings::default(),
                adaptive: None,
            },
            x0: DVector::zeros(1),
            v0: DVector::zeros(1),
            sampling: Sampling {
                period: 1.0 / frequency,
                transient: 5,
                samples: 4,
                per_period: 1,
                dofs: vec![0],
                max_impacts: 3,
            },
        }
    }

    #[test]
    fn samples_equal_the_full_history_at_whole_periods() {
        let j = job(0.8, 0.02);
        let p = run_point(&j, None);
        assert!(p.error.is_none());
        // the same run, every step kept
        let period = j.sampling.period;
        let dt = period / (period / j.settings.dt - 1e-9).ceil();
        let settings = RunSettings {
            t_end: j.sampling.t_end(),
            dt,
            ..j.settings.clone()
        };
        let full = simulate(&j.system, j.method, &settings, j.x0.clone(), j.v0.clone()).unwrap();
        let m = (period / dt).round() as usize;
        for k in 1..=4 {
            let i = (5 + k) * m;
            assert_eq!(p.poincare_displacement[k - 1], full.rows.displacement[i]);
            assert_eq!(p.poincare_velocity[k - 1], full.rows.velocity[i]);
        }
        let last = full.rows.time.len() - 1;
        assert_eq!(p.final_displacement[0], full.rows.displacement[last]);
        assert_eq!(p.final_velocity[0], full.rows.velocity[last]);
        let kept = &full.rows.displacement[5 * m..];
        let step_max = kept.iter().copied().fold(f64::MIN, f64::max);
        let step_min = kept.iter().copied().fold(f64::MAX, f64::min);
        assert!(p.displacement_max[0] >= step_max && p.displacement_max[0] < step_max + 1e-4);
        assert!(p.displacement_min[0] <= step_min && p.displacement_min[0] > step_min - 1e-4);
        let n_imp = full
            .impacts
            .iter()
            .filter(|r| r.t_start > j.sampling.start())
            .count();
        assert!(n_imp > 0);
        assert_eq!(p.impact_count[0], n_imp);
        let first = full
            .impacts
            .iter()
            .find(|r| r.t_start > j.sampling.start())
            .unwrap();
        assert_eq!(p.impact_velocity[0], first.v_in);
    }

    /// `per_period` samples a period are the rows of the full history every `T / per_period`.
    #[test]
    fn samples_per_period_are_the_history_at_their_instants() {
        let mut j = job(0.8, 0.02);
        j.sampling.per_period = 5;
        j.sampling.samples = 20;
        let p = run_point(&j, None);
        assert!(p.error.is_none());
        let interval = j.sampling.period / 5.0;
        let dt = interval / (interval / j.settings.dt - 1e-9).ceil();
        let settings = RunSettings {
            t_end: j.sampling.t_end(),
            dt,
            ..j.settings.clone()
        };
        let full = simulate(&j.system, j.method, &settings, j.x0.clone(), j.v0.clone()).unwrap();
        let m = (interval / dt).round() as usize;
        assert_eq!(full.rows.time.len() - 1, (5 * 5 + 20) * m);
        for k in 1..=20 {
            let i = (5 * 5 + k) * m;
            assert_eq!(p.poincare_displacement[k - 1], full.rows.displacement[i]);
            assert_eq!(p.poincare_velocity[k - 1], full.rows.velocity[i]);
        }
        j.sampling.per_period = 3;
        assert!(run_point(&j, None).error.is_some());
    }

    /// A point's summary is the same, to the bit, whether its run computes every output or
    /// only what the reducer takes (`Outputs::Observed`: no peaks, no impact table).
    #[test]
    fn observed_outputs_give_the_same_summary() {
        for method in [
            Method::Newmark(NewmarkFamily::average_acceleration()),
            Method::Dop853,
        ] {
            let mut j = job(0.8, 0.02);
            j.method = method;
            let quick = run_point(&j, None);
            assert!(quick.error.is_none() && quick.impact_count[0] > 0);
            let sampling = &j.sampling;
            let interval = sampling.period / sampling.per_period as f64;
            let settings = RunSettings {
                t_end: sampling.t_end(),
                dt: interval / (interval / j.settings.dt - 1e-9).ceil(),
                every: usize::MAX,
                record_dofs: sampling.dofs.clone(),
                ..j.settings.clone()
            };
            let run = |outputs: Outputs| {
                let mut reducer = Reducer::new(sampling, 1, j.x0.as_slice(), j.v0.as_slice());
                let (sys, x0, v0) = (&j.system, j.x0.clone(), j.v0.clone());
                let out =
                    simulate_observed(sys, method, &settings, x0, v0, Some(&mut reducer), outputs)
                        .unwrap();
                let mut summary = reducer.finish();
                summary.stats = out.stats;
                (summary, out)
            };
            let (all, full) = run(Outputs::All);
            let (observed, reduced) = run(Outputs::Observed);
            assert!(same(&all, &observed) && same(&quick, &observed));
            assert!(!full.impacts.is_empty() && full.max_abs_displacement[0] > 0.0);
            assert!(reduced.impacts.is_empty() && reduced.max_abs_displacement.is_empty());
            assert_eq!(
                full.rows.energy.external_work,
                reduced.rows.energy.external_work
            );
        }
    }

    /// The reducer handed every step, the transient's too (no `quiet_until`).
    struct EveryStep<'r, 'a>(&'r mut Reducer<'a>);

    impl StepObserver for EveryStep<'_, '_> {
        fn accepted(
            &mut self,
            sys: &System,
            s0: &State,
            s1: &State,
            h: f64,
            turns: Option<&[Option<Turn>]>,
        ) {
            self.0.accepted(sys, s0, s1, h, turns);
        }

        fn final_state(&mut self, s: &State, t: f64) {
            self.0.final_state(s, t);
        }

        fn impact(&mut self, sys: &System, wall: usize, t: f64, speed: f64) {
            self.0.impact(sys, wall, t, speed);
        }
    }

    #[test]
    fn a_quiet_transient_gives_the_same_summary() {
        // the benchmark's oscillator with damping `c` and a wall of `law`: event-driven for a
        // rigid one; negative damping: a run the energy check stops inside the transient
        let point = |c: f64, law: Law| {
            let mut j = job(0.8, 0.02);
            let w = 2.0 * std::f64::consts::PI;
            let one = |v: f64| DMatrix::from_element(1, 1, v);
            let structure = LinearStructure::new(one(1.0), one(c), one(w * w)).unwrap();
            let mut sys = oscillator(0.8, 0.02);
            if matches!(law, Law::Rigid(_)) {
                j.method = Method::EventDriven(crate::impulsive::EventDriven::default());
            }
            sys.gaps[0].law = law;
            j.system = Arc::new(System::new(structure, sys.gaps, sys.loads).unwrap());
            j.sampling.transient = if c < 0.0 { 50 } else { 5 };
            j
        };
        let kelvin_voigt = || Law::KelvinVoigt(KelvinVoigt::new(1e5, 20.0).unwrap());
        let rigid = || Law::Rigid(crate::contact::Rigid::new(0.8).unwrap());
        for (j, fails) in [
            (point(0.63, kelvin_voigt()), false),
            (point(0.63, rigid()), false),
            (point(-3.0, kelvin_voigt()), true),
            (point(-3.0, rigid()), true),
        ] {
            let quiet = run_point(&j, None);
            assert_eq!(quiet.error.is_some(), fails, "{:?}", quiet.error);
            let sampling = &j.sampling;
            let mut settings = j.settings.clone();
            settings.t_end = sampling.t_end();
            settings.every = usize::MAX;
            settings.dt = sampling.period / (sampling.period / settings.dt - 1e-9).ceil();
            let mut reducer = Reducer::new(sampling, 1, j.x0.as_slice(), j.v0.as_slice());
            let (sys, x0, v0) = (&j.system, j.x0.clone(), j.v0.clone());
            let mut every = EveryStep(&mut reducer);
            let out = simulate_observed(
                sys,
                j.method,
                &settings,
                x0,
                v0,
                Some(&mut every),
                Outputs::Observed,
            )
            .unwrap();
            let mut summary = reducer.finish();
            (summary.stats, summary.error) = (out.stats, out.error);
            assert!(same(&quiet, &summary));
        }
    }

    /// The reducer handed every step, as [`EveryStep`], noting whether a wall is closed at
    /// the end of the transient.
    struct Unquiet<'r, 'a> {
        every: EveryStep<'r, 'a>,
        in_contact_at_start: bool,
    }

    impl StepObserver for Unquiet<'_, '_> {
        fn accepted(
            &mut self,
            sys: &System,
            s0: &State,
            s1: &State,
            h: f64,
            turns: Option<&[Option<Turn>]>,
        ) {
            let start = self.every.0.start;
            if s0.t + h <= start && s1.t + h > start {
                self.in_contact_at_start = s1.walls.iter().any(WallState::closed);
            }
            self.every.accepted(sys, s0, s1, h, turns);
        }

        fn final_state(&mut self, s: &State, t: f64) {
            self.every.final_state(s, t);
        }
    }

    /// A fixed-step point's transient in free flight goes through the stepper's free run (its
    /// steps quiet: `Run::unobserved_until`), with the loads' values, predictor columns and
    /// work: the summary, the statistics and the account's external work are the same, to the
    /// bit, as those of the same point with every step handed to the observer (no free run),
    /// for one load and two (on a 2-DOF model), with `c_f = 0` and not (generalized-α), and
    /// for transients that end in free flight and in contact.
    #[test]
    fn a_free_transient_gives_the_same_summary() {
        let two_dof = |frequency: f64| {
            let m = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, 0.5]);
            let k = DMatrix::from_row_slice(2, 2, &[60.0, -20.0, -20.0, 40.0]);
            let c = &m * 0.3 + &k * 1e-3;
            let gap = Gap {
                dofs: vec![1],
                coefficients: vec![1.0],
                clearance: 0.01,
                side: Side::Both,
                law: Law::KelvinVoigt(KelvinVoigt::new(1e3, 2.0).unwrap()),
            };
            let load = |dof: usize, amplitude: f64, frequency: f64, phase: f64| Load {
                dofs: vec![dof],
                amplitude,
                history: LoadHistory::Harmonic { frequency, phase },
            };
            let loads = vec![
                load(0, 4.0, frequency, 0.0),
                load(1, 2.0, 1.7 * frequency, 0.4),
            ];
            let structure = LinearStructure::new(m, c, k).unwrap();
            System::new(structure, vec![gap], loads).unwrap()
        };
        let generalized_alpha = NewmarkFamily {
            alpha_m: -0.2,
            alpha_f: 0.1,
            gamma: 0.8,
            beta: 0.4225,
        };
        let mut ends_in_contact = [false, false];
        for (m, system) in [oscillator(0.8, 0.02), two_dof(0.8)]
            .into_iter()
            .enumerate()
        {
            let n = system.n_dof();
            let system = Arc::new(system);
            for method in [
                Method::Newmark(NewmarkFamily::average_acceleration()),
                Method::GeneralizedAlpha(generalized_alpha),
            ] {
                for transient in 1..=8 {
                    let mut j = job(0.8, 0.02);
                    (j.system, j.method) = (system.clone(), method);
                    (j.x0, j.v0) = (DVector::zeros(n), DVector::zeros(n));
                    // (a sampling period off the forcing's: the transients end at many phases)
                    j.sampling.transient = transient;
                    j.sampling.period *= 1.0 + 0.09 * transient as f64;
                    j.sampling.dofs = (0..n).collect();
                    let sampling = &j.sampling;
                    let mut settings = j.settings.clone();
                    settings.t_end = sampling.t_end();
                    settings.every = usize::MAX;
                    settings.record_dofs = sampling.dofs.clone();
                    settings.dt = sampling.period / (sampling.period / settings.dt - 1e-9).ceil();
                    let run = |every_step: bool| {
                        let mut reducer =
                            Reducer::new(sampling, 1, j.x0.as_slice(), j.v0.as_slice());
                        let mut unquiet = Unquiet {
                            every: EveryStep(&mut reducer),
                            in_contact_at_start: false,
                        };
                        let observer: &mut dyn StepObserver = if every_step {
                            &mut unquiet
                        } else {
                            unquiet.every.0
                        };
                        let (sys, x0, v0) = (&*j.system, j.x0.clone(), j.v0.clone());
                        let out = simulate_observed(
                            sys,
                            j.method,
                            &settings,
                            x0,
                            v0,
                            Some(observer),
                            Outputs::Observed,
                        )
                        .unwrap();
                        let in_contact = unquiet.in_contact_at_start;
                        let mut summary = reducer.finish();
                        (summary.stats, summary.error) = (out.stats, out.error);
                        (summary, out.rows.energy.external_work, in_contact)
                    };
                    let (free, free_work, _) = run(false);
                    let (general, general_work, in_contact) = run(true);
                    assert!(free.error.is_none() && free.impact_count[0] > 0);
                    assert!(same(&free, &general), "{m} {method:?} {transient}");
                    let bits = |w: Vec<f64>| w.iter().map(|w| w.to_bits()).collect::<Vec<_>>();
                    assert_eq!(bits(free_work), bits(general_work));
                    ends_in_contact[usize::from(in_contact)] = true;
                }
            }
        }
        assert_eq!(ends_in_contact, [true, true]);
    }

    #[test]
    fn parallel_equals_serial_and_chains_carry_the_state() {
        let jobs: Vec<SweepJob> = [0.6, 0.8, 1.0, 1.2].iter().map(|&f| job(f, 0.02)).collect();
        let one = run_sweep(&jobs, None, Some(1)).unwrap();
        let two = run_sweep(&jobs, None, Some(2)).unwrap();
        for ((j, a), b) in jobs.iter().zip(&one).zip(&two) {
            assert!(same(a, b));
            assert!(same(&run_point(j, None), a));
        }
        let chains = vec![vec![0, 1], vec![3, 2]];
        let cont = run_sweep(&jobs, Some(&chains), None).unwrap();
        assert!(same(&cont[0], &one[0]));
        assert!(same(&cont[3], &one[3]));
        let x = &cont[0].final_displacement;
        let v = &cont[0].final_velocity;
        assert!(same(&cont[1], &run_point(&jobs[1], Some((x, v)))));
        assert!(!same(&cont[1], &one[1]));
        assert!(run_sweep(&jobs, Some(&[vec![0, 1]]), None).is_err());
    }

    #[test]
    fn far_wall_no_impacts_and_rms_of_a_sine() {
        // linear response amplitude F/|k − mω² + icω| ≪ clearance: no impacts, RMS = A/√2
        let mut j = job(0.3, 10.0);
        j.sampling.transient = 40;
        j.sampling.samples = 10;
        let p = run_point(&j, None);
        assert_eq!(p.impact_count[0], 0);
        assert!(p.impact_velocity_max[0].is_nan());
        let w = 2.0 * std::f64::consts::PI;
        let om = w * 0.3;
        let amp = 1.0 / ((w * w - om * om).powi(2) + (0.1 * w * om).powi(2)).sqrt();
        assert!((p.displacement_rms[0] - amp / 2f64.sqrt()).abs() < 2e-3 * amp);
        assert!((p.displacement_max[0] - amp).abs() < 2e-3 * amp);
        assert!((p.displacement_min[0] + amp).abs() < 2e-3 * amp);
        // period-1: every sample the same
        let s = &p.poincare_displacement;
        assert!(s.iter().all(|&x| (x - s[0]).abs() < 1e-6 * amp));
    }
}
