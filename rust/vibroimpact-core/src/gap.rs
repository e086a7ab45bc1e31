//! Gap elements (docs/conventions.md §Gaps): a clearance on a gap coordinate `u = b · x`, one
//! or two walls, a contact law; and the per-wall contact state and impact log.

use crate::contact::{ContactLaw, Law, MIN_IMPACT_SPEED};
use crate::error::{invalid, SimError};
use crate::interpolation::{parabola_peak, HermiteSegment};
use crate::model_catalog;
use crate::system::System;

/// Which wall(s) the gap coordinate can hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Side {
    /// Wall at `u = +d`: penetration `δ = u − d`.
    Positive,
    /// Wall at `u = −d`: penetration `δ = −u − d`.
    Negative,
    /// Both walls (bilateral clearance).
    Both,
    /// A circular stator around two DOFs (docs/rotors.md §Radial gaps): given by the user on a
    /// gap with `dofs = [ix, iy]`; [`System::new`] splits it into its two gap coordinates, this
    /// one (x, which owns the wall) and a [`Side::RadialY`] one appended after the user's gaps.
    Radial(Radial),
    /// The y coordinate of a radial gap: no wall of its own.
    RadialY,
}

impl Side {
    /// Signs `s` of the walls, with `δ = s u − d`; `0` for a radial gap's one wall (its normal
    /// turns with the state, [`radial_contact`]).
    pub fn signs(self) -> &'static [f64] {
        match self {
            Side::Positive => &[1.0],
            Side::Negative => &[-1.0],
            Side::Both => &[1.0, -1.0],
            Side::Radial(_) => &[0.0],
            Side::RadialY => &[],
        }
    }
}

/// How a radial gap's friction force `F_T` follows the sliding speed `v_rel` at the contact.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FrictionLaw {
    /// `F_T = μ F_N sign(v_rel)`; a crossing of `v_rel = 0` in contact stops the run
    /// (sticking is not modelled).
    Coulomb,
    /// `F_T = μ F_N tanh(v_rel / v_reg)`, smooth through `v_rel = 0`; `v_reg` in m/s.
    Regularised { speed: f64 },
}

/// A radial gap's stator and friction (docs/rotors.md §Radial gaps).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Radial {
    /// Stator centre `(x_s, y_s)`, m.
    pub center: [f64; 2],
    /// Coulomb coefficient μ (0: frictionless).
    pub friction: f64,
    /// Rotor radius `R` at the contact, m (the spin's sliding speed is `R Ω`).
    pub radius: f64,
    pub friction_law: FrictionLaw,
    /// Index of the y gap coordinate (set by [`System::new`]).
    pub partner: usize,
}

/// A radial wall's contact at gap coordinates `p = (x − x_s, y − y_s)` and rates `q`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RadialKinematics {
    /// `ρ = |p|`, m, the outward normal `n = p/ρ` and the tangent `t = (−n_y, n_x)`.
    pub rho: f64,
    pub normal: [f64; 2],
    pub tangent: [f64; 2],
    /// `δ̇ = n·q` and `ρ θ̇ = t·q`, m/s.
    pub rate: f64,
    pub slide: f64,
}

impl RadialKinematics {
    /// The kinematics at `p`, `q` (a rotor exactly at the centre takes `n = (1, 0)`).
    #[inline(always)]
    pub fn new(p: [f64; 2], q: [f64; 2]) -> Self {
        // not `hypot`, which guards against an overflow no displacement in metres reaches and
        // costs as much as the rest of the contact force
        let rho = (p[0] * p[0] + p[1] * p[1]).sqrt();
        let normal = if rho > 0.0 {
            [p[0] / rho, p[1] / rho]
        } else {
            [1.0, 0.0]
        };
        let tangent = [-normal[1], normal[0]];
        Self {
            rho,
            normal,
            tangent,
            rate: normal[0] * q[0] + normal[1] * q[1],
            slide: tangent[0] * q[0] + tangent[1] * q[1],
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
    /// The gap coordinate `u = Σ c_i y_{dof_i}` of a vector of the DOFs' values.
    #[inline(always)]
    pub fn coordinate(&self, y: &[f64]) -> f64 {
        self.dofs
            .iter()
            .zip(&self.coefficients)
            .map(|(&d, &c)| c * y[d])
            .sum()
    }

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
        model_catalog::CLEARANCE.check(&field, self.clearance)?;
        if let Side::Radial(r) = self.side {
            r.validate(&field, self)?;
        }
        Ok(())
    }
}

impl Radial {
    fn validate(&self, field: &str, gap: &Gap) -> Result<(), SimError> {
        if gap.dofs.len() != 2 {
            return invalid(format!(
                "{field}.dof: {:?} is not valid for kind = 'radial'; expected two DOFs [ix, iy]",
                gap.dofs
            ));
        }
        if gap.dofs[0] == gap.dofs[1] {
            return invalid(format!(
                "{field}.dof: {:?} names one DOF twice; expected two different DOFs [ix, iy]",
                gap.dofs
            ));
        }
        if gap.law.is_rigid() {
            return invalid(format!(
                "{field}.law.kind: 'rigid' is not available on a radial gap; expected a force law"
            ));
        }
        if !self
            .center
            .iter()
            .all(|&c| model_catalog::CENTER.accepts(c))
        {
            return invalid(format!(
                "{field}.center: {:?} is not valid; expected {}",
                self.center,
                model_catalog::CENTER.rule.expected
            ));
        }
        model_catalog::FRICTION.check(field, self.friction)?;
        if self.friction > 0.0 {
            model_catalog::RADIUS.check(field, self.radius)?;
        }
        if let FrictionLaw::Regularised { speed } = self.friction_law {
            model_catalog::REGULARISATION_SPEED.check(field, speed)?;
        }
        Ok(())
    }

    /// `F_T / (μ F_N)` at sliding speed `v` and its derivative in `v`.
    #[inline]
    pub fn friction_factor(&self, v: f64) -> (f64, f64) {
        match self.friction_law {
            FrictionLaw::Coulomb => (
                if v > 0.0 {
                    1.0
                } else if v < 0.0 {
                    -1.0
                } else {
                    0.0
                },
                0.0,
            ),
            FrictionLaw::Regularised { speed } => {
                let th = (v / speed).tanh();
                (th, (1.0 - th * th) / speed)
            }
        }
    }
}

/// A radial wall's generalized force `φ = F_N n + F_T t` on its two gap coordinates (it
/// pushes the rotor back into the stator, and `F_T = μ F_N s(v_rel)` along `t` opposes
/// the sliding at the contact, `v_rel = R Ω + ρ θ̇`) and its tangent: `d_u[r][c] = ∂φ_r/∂p_c`,
/// `d_rate[r][c] = ∂φ_r/∂q_c` (docs/rotors.md §Radial gaps). `state`: the wall's state with
/// its normal force from the law ([`contact_state`]); `spin`: `R Ω`, m/s.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RadialForce {
    pub phi: [f64; 2],
    /// `F_T` along `t`, N (`φ·t`).
    pub friction: f64,
    pub d_u: [[f64; 2]; 2],
    pub d_rate: [[f64; 2]; 2],
}

/// [`RadialForce`] of a closed wall (zero force: zero everything).
#[inline]
pub fn radial_contact(r: &Radial, k: &RadialKinematics, s: &WallState, spin: f64) -> RadialForce {
    let mut out = RadialForce::default();
    if s.force == 0.0 && s.d_penetration == 0.0 && s.d_rate == 0.0 {
        return out;
    }
    let (n, t, rho) = (k.normal, k.tangent, k.rho);
    let (fs, dfs) = friction_coefficient(r, k, spin);
    let f_n = s.force;
    (out.phi, out.friction) = radial_phi(k, f_n, fs);
    // direction of φ per unit F_N
    let e = [n[0] + fs * t[0], n[1] + fs * t[1]];
    // dF_N/dp = F_δ nᵀ + F_δ̇ (ρθ̇/ρ) tᵀ, dF_N/dq = F_δ̇ nᵀ
    let dfn_dp = [
        s.d_penetration * n[0] + s.d_rate * k.slide / rho * t[0],
        s.d_penetration * n[1] + s.d_rate * k.slide / rho * t[1],
    ];
    let dfn_dq = [s.d_rate * n[0], s.d_rate * n[1]];
    for a in 0..2 {
        for b in 0..2 {
            // F_N (dn + fs dt)/dp = F_N (t tᵀ − fs n tᵀ)/ρ; F_N μ s' t dv/dp, dv/dp = −(δ̇/ρ) tᵀ
            let turn = f_n * (t[a] - fs * n[a]) * t[b] / rho;
            let slip = -f_n * dfs * t[a] * k.rate / rho * t[b];
            out.d_u[a][b] = e[a] * dfn_dp[b] + turn + slip;
            out.d_rate[a][b] = e[a] * dfn_dq[b] + f_n * dfs * t[a] * t[b];
        }
    }
    out
}

/// A radial wall's generalized force `φ` and friction `F_T` (as in [`radial_contact`]) at
/// the normal force `force` (N), without the tangent: what an explicit integrator applies.
#[inline]
pub fn radial_force(r: &Radial, k: &RadialKinematics, force: f64, spin: f64) -> ([f64; 2], f64) {
    radial_phi(k, force, friction_coefficient(r, k, spin).0)
}

/// `μ s(v_rel)` and its derivative in `v_rel = spin + ρθ̇` (0 without friction).
#[inline]
fn friction_coefficient(r: &Radial, k: &RadialKinematics, spin: f64) -> (f64, f64) {
    if r.friction > 0.0 {
        let (f, d) = r.friction_factor(spin + k.slide);
        (r.friction * f, r.friction * d)
    } else {
        (0.0, 0.0)
    }
}

/// `φ = F_N (n + μ s t)` and `F_T = μ s F_N` at the normal force `f_n` and the friction
/// coefficient `fs = μ s(v_rel)`.
#[inline]
fn radial_phi(k: &RadialKinematics, f_n: f64, fs: f64) -> ([f64; 2], f64) {
    let (n, t) = (k.normal, k.tangent);
    (
        [f_n * (n[0] + fs * t[0]), f_n * (n[1] + fs * t[1])],
        f_n * fs,
    )
}

/// One wall of one gap.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wall {
    pub gap: usize,
    /// `+1` for the positive wall, `−1` for the negative one, `0` for a radial gap's.
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
    /// A radial wall's friction force `F_T` along the tangent `t` (N, signed: `φ·t`) and its
    /// sliding speed `v_rel = R Ω + ρ θ̇` and `ρ θ̇` (m/s); 0 on a 1-D gap's wall.
    pub friction: f64,
    pub slip: f64,
    pub slide: f64,
}

impl WallState {
    #[inline]
    pub fn closed(&self) -> bool {
        self.penetration > 0.0
    }

    /// Makes this an open 1-D wall's state at `penetration` (≤ 0) and `rate`: every other
    /// field zero. An open 1-D wall's state written here or by [`evaluate_wall`] already has
    /// them zero, so a slot that holds one gets its 16 bytes of motion only, and a slot that
    /// holds a closed state is reset whole (the same values as writing the whole state).
    #[inline(always)]
    pub(crate) fn set_open(&mut self, penetration: f64, rate: f64) {
        if self.closed() {
            *self = WallState::default();
        }
        self.penetration = penetration;
        self.rate = rate;
    }

    /// The cubic Hermite interpolant of the penetration over a step of length `h` from this
    /// state to `end`.
    #[inline]
    pub(crate) fn penetration_segment(&self, end: &WallState, h: f64) -> HermiteSegment {
        HermiteSegment {
            y0: self.penetration,
            dy0: self.rate,
            y1: end.penetration,
            dy1: end.rate,
            h,
        }
    }
}

/// Evaluates a wall at the end of a step of length `h`, given its state at the start, into
/// `out` (written in place: no copy of the state per evaluation).
/// A wall that opens→closes inside the step gets `v_imp` from the located crossing.
#[inline]
pub fn evaluate_wall(
    law: &Law,
    wall: &Wall,
    start: &WallState,
    u: f64,
    u_rate: f64,
    h: f64,
    out: &mut WallState,
) {
    let (penetration, rate) = wall.motion(u, u_rate);
    write_contact_state(out, law, start, penetration, rate, h);
}

impl Wall {
    /// A 1-D wall's penetration `δ = s u − c` and rate `δ̇ = s u̇` at its gap's coordinate `u`
    /// and rate `u̇`.
    #[inline(always)]
    pub(crate) fn motion(&self, u: f64, u_rate: f64) -> (f64, f64) {
        (self.sign * u - self.clearance, self.sign * u_rate)
    }
}

/// A wall's state at penetration `δ` and rate `δ̇` at the end of a step of length `h` from
/// `start`: `v_imp` latched at the located onset (Hermite on `δ`), the law's normal force.
#[inline]
pub fn contact_state(
    law: &Law,
    start: &WallState,
    penetration: f64,
    rate: f64,
    h: f64,
) -> WallState {
    let mut s = WallState::default();
    write_contact_state(&mut s, law, start, penetration, rate, h);
    s
}

/// [`contact_state`] written into `s`: an open wall's motion (the far wall of a two-sided gap
/// in contact is evaluated at each Newton iterate), a closed one's whole state by
/// [`write_closed_state`].
#[inline(always)]
fn write_contact_state(
    s: &mut WallState,
    law: &Law,
    start: &WallState,
    penetration: f64,
    rate: f64,
    h: f64,
) {
    if penetration > 0.0 {
        write_closed_state(s, law, start, penetration, rate, h);
    } else {
        s.set_open(penetration, rate);
    }
}

/// A closed wall's whole state at penetration `δ > 0` and rate `δ̇`, each field stored once:
/// those known before the law's call first (the call then keeps none of them in a register:
/// no register preserves a float across it), the law's after it. (Zeroed whole first and
/// then set, the state cost five stores more; built as a value and stored after the call, its
/// fields were spilled and copied.) In line (a closed wall is evaluated at each Newton
/// iterate of a contact step): called, it cost the call and the spills of the caller's
/// registers around it (callgrind: the paper's case −18 instructions a step in line, the
/// rotor's Newmark run −0.6 %).
#[inline(always)]
pub(crate) fn write_closed_state(
    s: &mut WallState,
    law: &Law,
    start: &WallState,
    penetration: f64,
    rate: f64,
    h: f64,
) {
    s.penetration = penetration;
    s.rate = rate;
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
    (s.friction, s.slip, s.slide) = (0.0, 0.0, 0.0);
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
    /// Largest friction force `|F_T|` of a radial gap's contact, N (0 on a 1-D gap).
    pub friction_max: f64,
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
                    friction_max: s.friction.abs(),
                    impulse: 0.0,
                });
            }
        }
    }

    /// Updates the table for a committed step `[t, t + h]` at wall `j` (`wall`), closed at
    /// either end of it (`s0` to `s1`). `interior`: what the integrator knows of each wall
    /// inside the step (else the trapezoidal rule, the parabola through the last force
    /// samples and the cubic Hermite interpolant of the penetration). The force at a
    /// contact's first instant is always a candidate for its peak (see [`onset_force`]).
    // (in line in `Run::commit_step`'s one pass over the walls closed in the step)
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn commit_wall(
        &mut self,
        sys: &System,
        j: usize,
        wall: &Wall,
        s0: &WallState,
        s1: &WallState,
        t: f64,
        h: f64,
        interior: Option<&WallInterior>,
    ) {
        let seg = s0.penetration_segment(s1, h);
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
                    friction_max: 0.0,
                    impulse: known.map_or(0.5 * (1.0 - theta) * h * s1.force, |k| k.impulse),
                });
                let rec = self.records.last_mut().expect("the record just opened");
                update_peaks(rec, &mut self.history[j], &seg, s0, s1, t + h, known);
            }
            (true, true) => {
                if let Some(r) = self.open[j] {
                    let rec = &mut self.records[r];
                    rec.impulse += known.map_or(0.5 * h * (s0.force + s1.force), |k| k.impulse);
                    update_peaks(rec, &mut self.history[j], &seg, s0, s1, t + h, known);
                }
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

/// A closed wall's step `[t1 − h, t1]` in its open record `rec`, with the wall's last two
/// force samples `history`: the penetration's and the forces' peaks. In line in
/// [`ImpactLog::commit_wall`], with the record it found (called with the log, the call and the
/// tests of the wall's open record and of its index, made again, cost a closed wall's step
/// ~25 instructions).
#[inline(always)]
fn update_peaks(
    rec: &mut ImpactRecord,
    history: &mut [(f64, f64); 2],
    seg: &HermiteSegment,
    s0: &WallState,
    s1: &WallState,
    t1: f64,
    known: Option<Known>,
) {
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
    rec.friction_max = rec.friction_max.max(s1.friction.abs());
    // Force peaks: known inside the step, or the parabola through the last three samples.
    let [(ta, fa), (tb, fb)] = *history;
    rec.force_max = rec.force_max.max(s1.force).max(known.map_or_else(
        || parabola_peak([ta, tb, t1], [fa, fb, s1.force]),
        |k| k.force_max,
    ));
    *history = [(tb, fb), (t1, s1.force)];
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

#[cfg(test)]
mod tests {
    use nalgebra::DMatrix;

    use super::*;
    use crate::contact::HuntCrossley;
    use crate::structure::LinearStructure;
    use crate::system::Tangent;

    /// A Jeffcott rotor (DOFs 0, 1 of three) spinning at 300 rad/s in a radial gap with a
    /// damped law and regularised friction, off-centre stator.
    fn rotor(friction_law: FrictionLaw) -> System {
        let m = DMatrix::identity(3, 3);
        let k = DMatrix::identity(3, 3) * 1e4;
        let c = DMatrix::zeros(3, 3);
        let s = LinearStructure::new(m, c, k)
            .unwrap()
            .spinning(None, 300.0)
            .unwrap();
        let gap = Gap {
            dofs: vec![2, 0],
            coefficients: vec![1.0, 1.0],
            clearance: 1e-3,
            side: Side::Radial(Radial {
                center: [1e-4, -2e-4],
                friction: 0.3,
                radius: 0.02,
                friction_law,
                partner: 0,
            }),
            law: Law::HuntCrossley(HuntCrossley::new(1e7, 1.5, 3e4).unwrap()),
        };
        System::new(s, vec![gap], vec![]).unwrap()
    }

    fn evaluate(sys: &System, u: &[f64], rate: &[f64]) -> (Vec<f64>, Tangent, WallState) {
        // a contact under way (its v_imp latched at the start of the step)
        let start = [WallState {
            penetration: 1e-6,
            rate: 0.1,
            impact_speed: 0.2,
            max_penetration: 1e-6,
            ..WallState::default()
        }];
        let (mut walls, mut phi, mut t) = ([WallState::default()], vec![0.0; 2], Tangent::new(2));
        sys.evaluate_contacts(&start, u, rate, 1e-5, &mut walls, &mut phi, &mut t);
        (phi, t, walls[0])
    }

    /// `∂φ/∂u`, `∂φ/∂u̇` of [`radial_contact`] (the rotation of the normal, the law's rate
    /// through `δ̇ = n·q`, the friction through `v_rel`) equal central differences of `φ`.
    #[test]
    fn radial_tangent_matches_finite_differences() {
        for law in [
            FrictionLaw::Regularised { speed: 0.5 },
            FrictionLaw::Coulomb,
        ] {
            let sys = rotor(law);
            // coordinate 0: x (DOF 2), coordinate 1: y (DOF 0); rotor 2 µm into the stator
            let dir = [0.6f64, 0.8];
            let rho = 1e-3 + 2e-6;
            let u = [1e-4 + rho * dir[0], -2e-4 + rho * dir[1]];
            let rate = [0.05, -0.03];
            let (phi, t, wall) = evaluate(&sys, &u, &rate);
            assert!(wall.closed() && wall.force > 0.0 && wall.friction != 0.0);
            let full = |d: &[f64], cross: &[f64], row: usize, col: usize| {
                if row == col {
                    d[col]
                } else {
                    cross[col]
                }
            };
            for col in 0..2 {
                for (which, base, h) in [(0, u, 1e-10), (1, rate, 1e-6)] {
                    let (mut plus, mut minus) = (base, base);
                    plus[col] += h;
                    minus[col] -= h;
                    let (pp, pm) = if which == 0 {
                        (
                            evaluate(&sys, &plus, &rate).0,
                            evaluate(&sys, &minus, &rate).0,
                        )
                    } else {
                        (evaluate(&sys, &u, &plus).0, evaluate(&sys, &u, &minus).0)
                    };
                    for row in 0..2 {
                        let fd = (pp[row] - pm[row]) / (2.0 * h);
                        let exact = if which == 0 {
                            full(&t.d_u, &t.cross_u, row, col)
                        } else {
                            full(&t.d_rate, &t.cross_rate, row, col)
                        };
                        let scale = if which == 0 {
                            wall.force / 2e-6
                        } else {
                            wall.force / 0.05
                        };
                        assert!(
                            (fd - exact).abs() <= 1e-6 * scale,
                            "{law:?} d phi[{row}]/d {}[{col}]: {exact} vs differences {fd}",
                            ["u", "u'"][which]
                        );
                    }
                }
            }
            // φ = F_N n + F_T t, with |F_T| = μ F_N tanh(v_rel / v_reg) (or μ F_N)
            let v_rel = 0.02 * 300.0 + (-dir[1] * rate[0] + dir[0] * rate[1]);
            let factor = match law {
                FrictionLaw::Regularised { speed } => (v_rel / speed).tanh(),
                FrictionLaw::Coulomb => 1.0,
            };
            assert!((wall.slip - v_rel).abs() < 1e-12);
            let f_t = 0.3 * wall.force * factor;
            for a in 0..2 {
                let t_a = [-dir[1], dir[0]][a];
                let want = wall.force * dir[a] + f_t * t_a;
                assert!((phi[a] - want).abs() < 1e-9 * wall.force, "phi[{a}]");
            }
        }
    }

    /// An open wall's state written over a closed one's ([`WallState::set_open`], which
    /// writes only the motion over an open one) is the whole open state: no field of the
    /// contact is left behind.
    #[test]
    fn open_state_over_a_closed_one_is_whole() {
        // a law that latches the impact speed: every field of a closed state set
        let law = Law::Hysteretic(
            crate::contact::Hysteretic::new("lankarani-nikravesh", 1e9, 1.5, 0.8).unwrap(),
        );
        let wall = Wall {
            gap: 0,
            sign: -1.0,
            clearance: 1e-3,
        };
        let open = |u: f64, rate: f64| WallState {
            penetration: wall.sign * u - wall.clearance,
            rate: wall.sign * rate,
            ..WallState::default()
        };
        let mut slot = WallState::default();
        evaluate_wall(
            &law,
            &wall,
            &open(-0.9e-3, -0.5),
            -1.01e-3,
            -0.5,
            1e-6,
            &mut slot,
        );
        assert!(slot.closed() && slot.force > 0.0);
        assert!(slot.impact_speed > 0.0 && slot.max_penetration > 0.0 && slot.potential > 0.0);
        let closed = slot;
        evaluate_wall(&law, &wall, &closed, -0.99e-3, 0.4, 1e-6, &mut slot);
        assert_eq!(slot, open(-0.99e-3, 0.4));
        let moved = WallState {
            penetration: -2e-4,
            rate: 0.1,
            ..WallState::default()
        };
        for mut slot in [slot, closed] {
            slot.set_open(-2e-4, 0.1);
            assert_eq!(slot, moved);
        }
    }

    #[test]
    fn radial_gap_refuses_bad_input() {
        let sys = |dofs: Vec<usize>, clearance: f64, friction: f64, radius: f64| {
            let s = LinearStructure::new(
                DMatrix::identity(2, 2),
                DMatrix::zeros(2, 2),
                DMatrix::identity(2, 2),
            )
            .unwrap();
            let n = dofs.len();
            let gap = Gap {
                dofs,
                coefficients: vec![1.0; n],
                clearance,
                side: Side::Radial(Radial {
                    center: [0.0, 0.0],
                    friction,
                    radius,
                    friction_law: FrictionLaw::Coulomb,
                    partner: 0,
                }),
                law: Law::Hertz(crate::contact::Hertz::new(1e6, 1.0).unwrap()),
            };
            System::new(s, vec![gap], vec![])
                .err()
                .map(|e| e.to_string())
                .unwrap_or_default()
        };
        assert!(sys(vec![0], 1e-3, 0.0, 0.0).starts_with("gaps[0].dof: [0] is not valid"));
        assert!(sys(vec![0, 0], 1e-3, 0.0, 0.0).contains("names one DOF twice"));
        assert!(sys(vec![0, 1], -1e-3, 0.0, 0.0).starts_with("gaps[0].clearance: -0.001"));
        assert!(sys(vec![0, 1], 1e-3, 0.2, 0.0).starts_with("gaps[0].radius: 0 is not valid"));
        assert!(sys(vec![0, 1], 1e-3, 0.0, 0.0).is_empty());
    }
}
