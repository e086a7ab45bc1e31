//! Gap elements (docs/conventions.md §Gaps): a clearance on a gap coordinate `u = b · x`, one
//! or two walls, a contact law; and the per-wall contact state and impact log.

use crate::contact::{ContactLaw, Law, MIN_IMPACT_SPEED};
use crate::error::{invalid, SimError};
use crate::interpolation::{parabola_peak, HermiteSegment};
use crate::system::System;

/// Which wall(s) the gap coordinate can hit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// Wall at `u = +d`: penetration `δ = u − d`.
    Positive,
    /// Wall at `u = −d`: penetration `δ = −u − d`.
    Negative,
    /// Both walls (bilateral clearance).
    Both,
}

impl Side {
    /// Signs `s` of the walls, with `δ = s u − d`.
    pub fn signs(self) -> &'static [f64] {
        match self {
            Side::Positive => &[1.0],
            Side::Negative => &[-1.0],
            Side::Both => &[1.0, -1.0],
        }
    }
}

/// A clearance between a linear combination of DOFs and a rigid wall.
#[derive(Debug, Clone, PartialEq)]
pub struct Gap {
    /// DOFs in the gap coordinate `u = Σ c_i x_{dof_i}`.
    pub dofs: Vec<usize>,
    /// Coefficients `c_i` (1 for a single DOF, `[1, −1]` for a relative coordinate).
    pub coefficients: Vec<f64>,
    /// Clearance `d ≥ 0`, m.
    pub clearance: f64,
    pub side: Side,
    pub law: Law,
}

impl Gap {
    pub fn validate(&self, index: usize, n_dof: usize) -> Result<(), SimError> {
        let field = format!("gaps[{index}]");
        if self.dofs.is_empty() || self.dofs.len() != self.coefficients.len() {
            return invalid(format!(
                "{field}.dof: {} DOFs and {} coefficients; expected one coefficient per DOF",
                self.dofs.len(),
                self.coefficients.len()
            ));
        }
        if let Some(d) = self.dofs.iter().find(|&&d| d >= n_dof) {
            return invalid(format!(
                "{field}.dof: {d} is out of range; expected 0 <= dof < {n_dof}"
            ));
        }
        if self.coefficients.iter().all(|&c| c == 0.0)
            || self.coefficients.iter().any(|c| !c.is_finite())
        {
            return invalid(format!(
                "{field}.coefficients: {:?} is not valid; expected finite values, not all zero",
                self.coefficients
            ));
        }
        if !(self.clearance.is_finite() && self.clearance >= 0.0) {
            return invalid(format!(
                "{field}.clearance: {} is not valid; expected a value >= 0 in m",
                self.clearance
            ));
        }
        Ok(())
    }
}

/// One wall of one gap.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wall {
    pub gap: usize,
    /// `+1` for the positive wall, `−1` for the negative one.
    pub sign: f64,
    pub clearance: f64,
}

/// State of one wall at one time.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct WallState {
    /// Penetration `δ`, m (negative: open by that distance).
    pub penetration: f64,
    /// `δ̇`, m/s.
    pub rate: f64,
    /// Contact force `F ≥ 0`, N.
    pub force: f64,
    /// Conservative part of the force, N, and its potential, J.
    pub elastic_force: f64,
    pub potential: f64,
    /// `∂F/∂δ`, `∂F/∂δ̇` (zero when open or clamped).
    pub d_penetration: f64,
    pub d_rate: f64,
    /// Approach speed of the current impact (valid while closed), m/s.
    pub impact_speed: f64,
    /// Largest penetration of the current contact at the ends of its steps (valid while
    /// closed), m: where a tabulated law's unloading curve starts.
    pub max_penetration: f64,
}

impl WallState {
    #[inline]
    pub fn closed(&self) -> bool {
        self.penetration > 0.0
    }
}

/// Evaluates a wall at the end of a step of length `h`, given its state at the start.
/// A wall that opens→closes inside the step gets `v_imp` from the located crossing.
#[inline]
pub fn evaluate_wall(
    law: &Law,
    wall: &Wall,
    start: &WallState,
    u: f64,
    u_rate: f64,
    h: f64,
) -> WallState {
    let penetration = wall.sign * u - wall.clearance;
    let rate = wall.sign * u_rate;
    let mut s = WallState {
        penetration,
        rate,
        ..WallState::default()
    };
    if penetration <= 0.0 {
        return s;
    }
    s.impact_speed = if start.closed() {
        start.impact_speed
    } else if law.uses_impact_speed() {
        let seg = HermiteSegment {
            y0: start.penetration,
            dy0: start.rate,
            y1: penetration,
            dy1: rate,
            h,
        };
        seg.rate(seg.crossing()).max(MIN_IMPACT_SPEED)
    } else {
        0.0
    };
    s.max_penetration = if start.closed() {
        start.max_penetration.max(penetration)
    } else {
        penetration
    };
    let f = law.force_in_contact(penetration, rate, s.impact_speed, s.max_penetration);
    s.force = f.force;
    s.d_penetration = f.d_penetration;
    s.d_rate = f.d_rate;
    s.elastic_force = f.elastic;
    s.potential = f.potential;
    s
}

/// One contact of one wall: a row of the impact table (docs/conventions.md).
#[derive(Debug, Clone, PartialEq)]
pub struct ImpactRecord {
    pub gap: usize,
    /// `+1` positive wall, `−1` negative wall.
    pub side: f64,
    /// Instant the gap closed, s.
    pub t_start: f64,
    /// Instant it opened again, s (NaN while still closed at the end of the run).
    pub t_end: f64,
    /// Approach speed at closing, m/s (positive).
    pub v_in: f64,
    /// Separation speed at opening, m/s (positive; NaN while closed).
    pub v_out: f64,
    /// Largest penetration, m.
    pub delta_max: f64,
    /// Largest contact force, N.
    pub force_max: f64,
    /// `∫ F dt`, N·s.
    pub impulse: f64,
}

impl ImpactRecord {
    /// Effective restitution `v_out / v_in` (NaN while closed).
    pub fn restitution(&self) -> f64 {
        self.v_out / self.v_in
    }
    pub fn complete(&self) -> bool {
        !self.t_end.is_nan()
    }
}

/// What an integrator knows of each wall inside a step, beyond the step's ends.
pub(crate) struct WallInterior<'a> {
    /// The impulse `∫F dt` over the step, N·s.
    pub impulse: &'a [f64],
    /// The largest force inside the step, N.
    pub force_max: &'a [f64],
    /// The penetration's peak inside the step (0 if it does not peak inside it), m.
    pub delta_max: &'a [f64],
}

/// One wall's [`WallInterior`].
#[derive(Debug, Clone, Copy)]
struct Known {
    impulse: f64,
    force_max: f64,
    delta_max: f64,
}

/// Tracks contacts across committed steps and writes the impact table.
#[derive(Debug, Clone, Default)]
pub struct ImpactLog {
    pub records: Vec<ImpactRecord>,
    /// Per wall: index of the open record and the two previous force samples `(t, F)`.
    open: Vec<Option<usize>>,
    history: Vec<[(f64, f64); 2]>,
}

impl ImpactLog {
    pub fn new(n_walls: usize) -> Self {
        Self {
            records: Vec::new(),
            open: vec![None; n_walls],
            history: vec![[(0.0, 0.0); 2]; n_walls],
        }
    }

    /// Opens records for walls already closed at the initial time.
    pub fn start(&mut self, walls: &[Wall], states: &[WallState], t: f64) {
        for (j, (wall, s)) in walls.iter().zip(states).enumerate() {
            if s.closed() {
                self.open[j] = Some(self.records.len());
                self.history[j] = [(t, s.force), (t, s.force)];
                self.records.push(ImpactRecord {
                    gap: wall.gap,
                    side: wall.sign,
                    t_start: t,
                    t_end: f64::NAN,
                    v_in: s.impact_speed,
                    v_out: f64::NAN,
                    delta_max: s.penetration,
                    force_max: s.force,
                    impulse: 0.0,
                });
            }
        }
    }

    /// Updates the table for a committed step `[t, t + h]`. `interior`: what the integrator
    /// knows of each wall inside the step (else the trapezoidal rule, the parabola through the
    /// last force samples and the cubic Hermite interpolant of the penetration). The force at
    /// a contact's first instant is always a candidate for its peak (see [`onset_force`]).
    pub(crate) fn commit(
        &mut self,
        sys: &System,
        before: &[WallState],
        after: &[WallState],
        t: f64,
        h: f64,
        interior: Option<&WallInterior>,
    ) {
        for (j, wall) in sys.walls.iter().enumerate() {
            let (s0, s1) = (&before[j], &after[j]);
            if !s0.closed() && !s1.closed() {
                continue;
            }
            let seg = HermiteSegment {
                y0: s0.penetration,
                dy0: s0.rate,
                y1: s1.penetration,
                dy1: s1.rate,
                h,
            };
            let known = interior.map(|i| Known {
                impulse: i.impulse[j],
                force_max: i.force_max[j],
                delta_max: i.delta_max[j],
            });
            match (s0.closed(), s1.closed()) {
                (false, true) => {
                    let theta = seg.crossing();
                    let t_start = t + theta * h;
                    let v_in = seg.rate(theta);
                    let onset = onset_force(&sys.gaps[wall.gap].law, v_in, s1.impact_speed);
                    self.open[j] = Some(self.records.len());
                    self.history[j] = [(t_start, onset), (t_start, onset)];
                    self.records.push(ImpactRecord {
                        gap: wall.gap,
                        side: wall.sign,
                        t_start,
                        t_end: f64::NAN,
                        v_in,
                        v_out: f64::NAN,
                        delta_max: 0.0,
                        force_max: onset,
                        impulse: known.map_or(0.5 * (1.0 - theta) * h * s1.force, |k| k.impulse),
                    });
                    self.update_peaks(j, &seg, s0, s1, t + h, known);
                }
                (true, true) => {
                    if let Some(r) = self.open[j] {
                        self.records[r].impulse +=
                            known.map_or(0.5 * h * (s0.force + s1.force), |k| k.impulse);
                    }
                    self.update_peaks(j, &seg, s0, s1, t + h, known);
                }
                (true, false) => {
                    let theta = seg.crossing();
                    if let Some(r) = self.open[j].take() {
                        let rec = &mut self.records[r];
                        rec.impulse += known.map_or(0.5 * theta * h * s0.force, |k| k.impulse);
                        rec.t_end = t + theta * h;
                        rec.v_out = -seg.rate(theta);
                        let [(ta, fa), (tb, fb)] = self.history[j];
                        rec.force_max = rec.force_max.max(known.map_or_else(
                            || parabola_peak([ta, tb, rec.t_end], [fa, fb, 0.0]),
                            |k| k.force_max,
                        ));
                    }
                }
                (false, false) => unreachable!(),
            }
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn update_peaks(
        &mut self,
        j: usize,
        seg: &HermiteSegment,
        s0: &WallState,
        s1: &WallState,
        t1: f64,
        known: Option<Known>,
    ) {
        let Some(r) = self.open[j] else { return };
        let rec = &mut self.records[r];
        // Penetration peaks where δ̇ changes sign: known inside the step, or the maximum of
        // the Hermite interpolant there.
        let mut delta = s1.penetration;
        if let Some(k) = known {
            delta = delta.max(k.delta_max);
        } else if s0.rate > 0.0 && s1.rate <= 0.0 {
            let s = (s0.rate / (s0.rate - s1.rate)).clamp(0.0, 1.0);
            let s = refine_stationary(seg, s);
            delta = delta.max(seg.value(s));
        }
        rec.delta_max = rec.delta_max.max(delta);
        // Force peaks: known inside the step, or the parabola through the last three samples.
        let [(ta, fa), (tb, fb)] = self.history[j];
        rec.force_max = rec.force_max.max(s1.force).max(known.map_or_else(
            || parabola_peak([ta, tb, t1], [fa, fb, s1.force]),
            |k| k.force_max,
        ));
        self.history[j] = [(tb, fb), (t1, s1.force)];
    }
}

/// The force at a contact's first instant, N: the law at the smallest positive penetration
/// and the closing rate `v_in`, as the integrators evaluate a wall from its closing on. Zero
/// for a power law; Kelvin–Voigt's `c·v_in`, its largest value over the contact when its
/// force only falls (`ζ > 1/2`), where a peak found from the samples inside the contact
/// would miss it (or a parabola through the closing's zero overshoot it).
fn onset_force(law: &Law, v_in: f64, impact_speed: f64) -> f64 {
    let smallest = f64::MIN_POSITIVE;
    law.force_in_contact(smallest, v_in, impact_speed, smallest)
        .force
}

/// Newton on the Hermite interpolant's derivative, from a first guess inside the step.
fn refine_stationary(seg: &HermiteSegment, mut s: f64) -> f64 {
    for _ in 0..8 {
        let eps = 1e-7;
        let d = seg.rate(s);
        let dd = (seg.rate((s + eps).min(1.0)) - seg.rate((s - eps).max(0.0))) / (2.0 * eps);
        if dd == 0.0 {
            break;
        }
        let next = (s - d / dd).clamp(0.0, 1.0);
        if (next - s).abs() < 1e-14 {
            s = next;
            break;
        }
        s = next;
    }
    s
}
