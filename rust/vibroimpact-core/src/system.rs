//! The model the integrators advance: linear structure + gaps + loads (paper eq. 2),
//! and the state of a run at one instant.

use nalgebra::DVector;

use crate::contact::{Law, MIN_IMPACT_SPEED};
use crate::error::{invalid, SimError};
use crate::gap::{
    contact_state, evaluate_wall, radial_contact, write_closed_state, Gap, Radial,
    RadialKinematics, Side, Wall, WallState,
};
use crate::structure::{LinearStructure, Load};

pub use crate::integrators::sized::Inline;

/// `M x'' + C x' + K x = F(t) − Σ_g φ_g b_gᵀ`, with `φ_g = Σ_walls s F` the generalized
/// contact force on gap coordinate `u_g = b_g · x` (it pushes the coordinate out of the wall).
///
/// `gaps` are the gap coordinates: the user's gaps in their order (a radial gap as its x
/// coordinate, which owns its wall), then the y coordinate of each radial gap
/// ([`Side::RadialY`], no wall). Results have one column per user gap (`n_gaps`).
#[derive(Debug, Clone)]
pub struct System {
    pub structure: LinearStructure,
    pub gaps: Vec<Gap>,
    pub loads: Vec<Load>,
    pub walls: Vec<Wall>,
    pub has_damping: bool,
    /// The user's gaps (the first `n_gaps` gap coordinates).
    pub n_gaps: usize,
    /// Per gap coordinate, the other coordinate of its radial gap, if any.
    pub partner: Vec<Option<usize>>,
    /// Some gap is radial (the Newton tangent then couples the pairs).
    pub has_radial: bool,
    /// The loads that are an unbalance's forces at a constant spin (harmonic, `m e Ω²` at
    /// `|Ω|/2π`: [`crate::structure::Load::unbalance`]), which `structure.spin_speed` moves
    /// ([`System::with_unbalance`]; none by default).
    pub unbalance: Vec<usize>,
    /// Per gap coordinate its one DOF, when every coordinate is one DOF with coefficient 1
    /// (`u_g = x[d_g]`, the gaps of most small models and each coordinate of a radial gap):
    /// the step then reads `u_g` without a row product (the same values: `-0.0 + 1·y = y`).
    /// `None` when some coordinate is a combination.
    pub unit_dofs: Option<Vec<usize>>,
}

/// The contact forces' derivatives per gap coordinate: the diagonal `∂φ_g/∂u_g`,
/// `∂φ_g/∂u̇_g` and, for the coordinates of a radial gap, the coupling to its partner `p`:
/// `cross_u[g] = ∂φ_p/∂u_g`, `cross_rate[g] = ∂φ_p/∂u̇_g` (0 elsewhere).
#[derive(Debug, Clone)]
pub struct Tangent {
    pub d_u: Vec<f64>,
    pub d_rate: Vec<f64>,
    pub cross_u: Vec<f64>,
    pub cross_rate: Vec<f64>,
}

impl Tangent {
    pub fn new(n_coordinates: usize) -> Self {
        Self {
            d_u: vec![0.0; n_coordinates],
            d_rate: vec![0.0; n_coordinates],
            cross_u: vec![0.0; n_coordinates],
            cross_rate: vec![0.0; n_coordinates],
        }
    }
}

impl System {
    pub fn new(
        structure: LinearStructure,
        gaps: Vec<Gap>,
        loads: Vec<Load>,
    ) -> Result<Self, SimError> {
        let n = structure.n_dof();
        for (i, g) in gaps.iter().enumerate() {
            if g.side == Side::RadialY {
                return invalid(format!(
                    "gaps[{i}].side: the y coordinate of a radial gap is not a gap of its own"
                ));
            }
            g.validate(i, n)?;
            if let Side::Radial(r) = &g.side {
                if r.friction > 0.0 && !structure.spin.is_constant() {
                    return invalid(format!(
                        "gaps[{i}].friction: {} on a radial gap during a run-up is not available \
                         yet (its sliding speed R Ω would change with Ω(t)); expected friction = \
                         0 or structure.spin_profile = 'constant'",
                        r.friction
                    ));
                }
            }
        }
        let n_gaps = gaps.len();
        let mut gaps = gaps;
        let mut partner = vec![None; n_gaps];
        for i in 0..n_gaps {
            if let Side::Radial(r) = gaps[i].side {
                let y = gaps.len();
                let (ix, iy) = (gaps[i].dofs[0], gaps[i].dofs[1]);
                gaps.push(Gap {
                    dofs: vec![iy],
                    coefficients: vec![1.0],
                    side: Side::RadialY,
                    ..gaps[i].clone()
                });
                let g = &mut gaps[i];
                (g.dofs, g.coefficients) = (vec![ix], vec![1.0]);
                g.side = Side::Radial(Radial { partner: y, ..r });
                partner[i] = Some(y);
                partner.push(Some(i));
            }
        }
        let has_radial = gaps.len() > n_gaps;
        for (i, l) in loads.iter().enumerate() {
            l.validate(i, n)?;
        }
        let walls = gaps
            .iter()
            .enumerate()
            .flat_map(|(i, g)| {
                g.side.signs().iter().map(move |&sign| Wall {
                    gap: i,
                    sign,
                    clearance: g.clearance,
                })
            })
            .collect();
        let has_damping = structure.damping.values().iter().any(|&c| c != 0.0);
        let unit_dofs = gaps
            .iter()
            .map(|g| (g.coefficients[..] == [1.0]).then_some(g.dofs[0]))
            .collect();
        Ok(Self {
            structure,
            gaps,
            loads,
            walls,
            has_damping,
            n_gaps,
            partner,
            has_radial,
            unbalance: Vec::new(),
            unit_dofs,
        })
    }

    /// The system whose loads `loads` are an unbalance's forces at its constant spin
    /// ([`System::unbalance`]).
    pub fn with_unbalance(mut self, loads: Vec<usize>) -> Self {
        self.unbalance = loads;
        self
    }

    pub fn n_dof(&self) -> usize {
        self.structure.n_dof()
    }

    /// The user's gap a gap coordinate belongs to (a radial gap's y coordinate: its gap).
    pub fn gap_of(&self, coordinate: usize) -> usize {
        if coordinate < self.n_gaps {
            coordinate
        } else {
            self.partner[coordinate].unwrap_or(coordinate)
        }
    }

    /// The radial gap `g`'s kinematics at gap coordinates `u`, `u̇`.
    #[inline]
    pub fn radial_kinematics(
        &self,
        r: &Radial,
        g: usize,
        u: &[f64],
        u_rate: &[f64],
    ) -> RadialKinematics {
        RadialKinematics::new(
            [u[g] - r.center[0], u[r.partner] - r.center[1]],
            [u_rate[g], u_rate[r.partner]],
        )
    }

    /// The radial gap `g`'s kinematics at DOF displacements `x` and velocities `v`.
    #[inline(always)]
    pub fn radial_at_dofs(&self, r: &Radial, g: usize, x: &[f64], v: &[f64]) -> RadialKinematics {
        let (ix, iy) = (self.gaps[g].dofs[0], self.gaps[r.partner].dofs[0]);
        RadialKinematics::new([x[ix] - r.center[0], x[iy] - r.center[1]], [v[ix], v[iy]])
    }

    /// Wall `j`'s penetration `δ` and rate `δ̇` at gap coordinates `u`, `u̇`.
    #[inline]
    pub fn wall_motion(&self, j: usize, u: &[f64], u_rate: &[f64]) -> (f64, f64) {
        let wall = &self.walls[j];
        let g = wall.gap;
        match &self.gaps[g].side {
            Side::Radial(r) => {
                let k = self.radial_kinematics(r, g, u, u_rate);
                (k.rho - wall.clearance, k.rate)
            }
            _ => (wall.sign * u[g] - wall.clearance, wall.sign * u_rate[g]),
        }
    }

    /// `u_g = b_g · y` for every gap.
    #[inline]
    pub fn gap_coordinates(&self, y: &[f64], out: &mut [f64]) {
        for (o, g) in out.iter_mut().zip(&self.gaps) {
            *o = g.coordinate(y);
        }
    }

    /// `W = B G` (row-major, gaps × gaps) from the gap shapes `G_h = K̃⁻¹ b_hᵀ`: how each gap
    /// coordinate moves per unit generalized contact force on each gap.
    pub fn gap_flexibility(&self, shapes: &[Vec<f64>]) -> Vec<f64> {
        let ng = shapes.len();
        let mut w = vec![0.0; ng * ng];
        let mut row = vec![0.0; ng];
        for (hi, col) in shapes.iter().enumerate() {
            self.gap_coordinates(col, &mut row);
            for (gi, &v) in row.iter().enumerate() {
                w[gi * ng + hi] = v;
            }
        }
        w
    }

    /// Adds `−scale Σ_g φ_g b_gᵀ` (the contact force on the structure, scaled) to `out`.
    #[inline]
    pub fn add_contact_force_scaled(&self, phi: &[f64], scale: f64, out: &mut [f64]) {
        for (g, &p) in self.gaps.iter().zip(phi) {
            if p != 0.0 {
                for (&d, &c) in g.dofs.iter().zip(&g.coefficients) {
                    out[d] -= scale * c * p;
                }
            }
        }
    }

    /// Adds `scale Σ_l g_l b_l` (the external loads with values `g_l`) to `out`.
    #[inline]
    pub fn add_loads(&self, values: &[f64], scale: f64, out: &mut [f64]) {
        for (load, &g) in self.loads.iter().zip(values) {
            for &d in &load.dofs {
                out[d] += scale * g;
            }
        }
    }

    /// Evaluates every wall at gap coordinates `u`, `u̇` at the end of a step of length `h`
    /// that started from `start`; writes wall states and the generalized forces `φ` with
    /// their derivatives ([`Tangent`]).
    // In line in each Newton iteration: on a 1-DOF model its call, frame and reloads cost as
    // much as its body (callgrind, the paper case: −19 instructions a step).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn evaluate_contacts(
        &self,
        start: &[WallState],
        u: &[f64],
        u_rate: &[f64],
        h: f64,
        walls: &mut [WallState],
        phi: &mut [f64],
        tangent: &mut Tangent,
    ) {
        if !self.has_radial {
            if let ([gap], [u], [u_rate], [phi], [d_u], [d_rate]) = (
                self.gaps.as_slice(),
                u,
                u_rate,
                &mut *phi,
                tangent.d_u.as_mut_slice(),
                tangent.d_rate.as_mut_slice(),
            ) {
                [*phi, *d_u, *d_rate] =
                    self.one_gap_walls::<true>(&gap.law, start, *u, *u_rate, h, walls);
                return;
            }
            // Every gap has one or two walls, adjacent in `walls` and in the gaps' order: one
            // pass over the gaps with their coordinates and sums (no index into them)
            let states = self.walls.iter().zip(start).zip(walls.iter_mut());
            let mut states = states.peekable();
            let sums = phi
                .iter_mut()
                .zip(&mut tangent.d_u)
                .zip(&mut tangent.d_rate);
            let gaps = self.gaps.iter().zip(u).zip(u_rate).zip(sums);
            for (g, (((gap, &u), &u_rate), ((phi, d_u), d_rate))) in gaps.enumerate() {
                let walls = std::iter::from_fn(|| states.next_if(|((w, _), _)| w.gap == g));
                [*phi, *d_u, *d_rate] = gap_walls::<true>(&gap.law, walls, u, u_rate, h);
            }
            return;
        }
        phi.fill(0.0);
        tangent.d_u.fill(0.0);
        tangent.d_rate.fill(0.0);
        tangent.cross_u.fill(0.0);
        tangent.cross_rate.fill(0.0);
        for ((wall, start), s) in self.walls.iter().zip(start).zip(walls.iter_mut()) {
            let g = wall.gap;
            let gap = &self.gaps[g];
            if let Side::Radial(r) = &gap.side {
                *s = self.radial_wall(r, g, wall, start, u, u_rate, h, phi, tangent);
                continue;
            }
            evaluate_wall(&gap.law, wall, start, u[g], u_rate[g], h, s);
            phi[g] += wall.sign * s.force;
            tangent.d_u[g] += s.d_penetration;
            tangent.d_rate[g] += s.d_rate;
        }
    }

    /// The walls of a model's one gap (no radial gap), `law` its law, evaluated at its
    /// coordinate `u` and rate `u_rate` (as [`Self::evaluate_contacts`]): its generalized force
    /// `φ` and `∂φ/∂u`, `∂φ/∂u̇`. Every wall is the gap's: no pass over the gaps and no test of
    /// each wall's gap. `OPEN`: the open walls' states are written too; without it only the
    /// closed walls' are (a Newton iterate that is not the last: the caller writes the open
    /// ones at its last iterate by [`Self::open_gap_walls`]).
    #[inline(always)]
    pub(crate) fn one_gap_walls<const OPEN: bool>(
        &self,
        law: &Law,
        start: &[WallState],
        u: f64,
        u_rate: f64,
        h: f64,
        walls: &mut [WallState],
    ) -> [f64; 3] {
        let states = self.walls.iter().zip(start).zip(walls.iter_mut());
        gap_walls::<OPEN>(law, states, u, u_rate, h)
    }

    /// The open walls' states of a model's one gap (no radial gap) at its coordinate `u` and
    /// rate `u_rate`: what [`Self::one_gap_walls`] without `OPEN` left out.
    #[inline(always)]
    pub(crate) fn open_gap_walls(&self, u: f64, u_rate: f64, walls: &mut [WallState]) {
        for (wall, s) in self.walls.iter().zip(walls) {
            let (penetration, rate) = wall.motion(u, u_rate);
            if penetration > 0.0 {
                continue; // closed: written at this iterate by `one_gap_walls`
            }
            s.set_open(penetration, rate);
        }
    }

    /// A radial wall's state, its force added to `φ` and its 2×2 tangent to `tangent`.
    #[allow(clippy::too_many_arguments)]
    fn radial_wall(
        &self,
        r: &Radial,
        g: usize,
        wall: &Wall,
        start: &WallState,
        u: &[f64],
        u_rate: &[f64],
        h: f64,
        phi: &mut [f64],
        tangent: &mut Tangent,
    ) -> WallState {
        let k = self.radial_kinematics(r, g, u, u_rate);
        let mut s = contact_state(&self.gaps[g].law, start, k.rho - wall.clearance, k.rate, h);
        let spin = r.radius * self.structure.spin.start;
        s.slide = k.slide;
        s.slip = spin + k.slide;
        if !s.closed() {
            return s;
        }
        let f = radial_contact(r, &k, &s, spin);
        s.friction = f.friction;
        let p = r.partner;
        phi[g] += f.phi[0];
        phi[p] += f.phi[1];
        tangent.d_u[g] += f.d_u[0][0];
        tangent.d_u[p] += f.d_u[1][1];
        tangent.cross_u[g] += f.d_u[1][0];
        tangent.cross_u[p] += f.d_u[0][1];
        tangent.d_rate[g] += f.d_rate[0][0];
        tangent.d_rate[p] += f.d_rate[1][1];
        tangent.cross_rate[g] += f.d_rate[1][0];
        tangent.cross_rate[p] += f.d_rate[0][1];
        s
    }
}

/// One gap's walls evaluated in turn at its coordinate `u` and rate `u_rate` into their
/// states (an open wall's only with `OPEN`), and the gap's generalized force `φ = Σ s F` with
/// its derivatives `Σ ∂F/∂δ`, `Σ ∂F/∂δ̇`, the sums from 0.0 at its first wall (the same values
/// as zeroing them first). An open wall's terms are left out: they are +0.0 (an open 1-D
/// wall's state has its other fields zero), and a sum from 0.0 of terms that are not −0.0 is
/// never −0.0, so adding ±0.0 to it leaves it as it is.
#[inline(always)]
fn gap_walls<'s, const OPEN: bool>(
    law: &Law,
    walls: impl Iterator<Item = ((&'s Wall, &'s WallState), &'s mut WallState)>,
    u: f64,
    u_rate: f64,
    h: f64,
) -> [f64; 3] {
    let (mut force, mut d_penetration, mut d_rate) = (0.0, 0.0, 0.0);
    for ((wall, start), s) in walls {
        let (penetration, rate) = wall.motion(u, u_rate);
        if penetration > 0.0 {
            write_closed_state(s, law, start, penetration, rate, h);
            force += wall.sign * s.force;
            d_penetration += s.d_penetration;
            d_rate += s.d_rate;
        } else if OPEN {
            s.set_open(penetration, rate);
        }
    }
    [force, d_penetration, d_rate]
}

/// Whether a DOF's displacement `x` and velocity `v` are both finite: 0·x is ±0 for a finite
/// x, NaN for an infinite or NaN one, so one test in floating point for both values, where
/// `is_finite` tests each in the integer registers.
#[inline(always)]
pub(crate) fn finite_motion(x: f64, v: f64) -> bool {
    x * 0.0 + v * 0.0 == 0.0
}

/// Everything the integrators carry from one step to the next. The motion is held at a small
/// model's size ([`Inline`]): the Newmark step of a model of up to four DOFs reads and writes
/// it at constant places.
#[derive(Debug, Clone)]
pub struct State {
    pub t: f64,
    pub x: Inline<f64>,
    pub v: Inline<f64>,
    pub a: Inline<f64>,
    /// Value of each load at `t`, N.
    pub load: Vec<f64>,
    /// Generalized contact force per gap.
    pub phi: Vec<f64>,
    /// Gap coordinates and their rates.
    pub u: Vec<f64>,
    pub u_rate: Vec<f64>,
    pub u_accel: Vec<f64>,
    pub walls: Vec<WallState>,
}

impl State {
    /// Sets the gap coordinates from Newton's converged `u` and the gap rates and
    /// accelerations from the state's own `v`, `a` (the Newton iterate's rates differ from them
    /// by a residual within tolerance amplified by 2/h), and the walls' rates to match.
    // (this and the next in line in the step: no second frame, no reload of the vectors)
    #[inline(always)]
    pub fn finish_gaps(&mut self, sys: &System, u: &[f64]) {
        self.finish::<false, 0>(sys, u);
    }

    /// [`Self::finish_gaps`] after a step in free flight (no wall closed at either end, found
    /// without evaluating a wall: `GapNewton::free_flight`): also the zero contact forces and
    /// each wall's whole state, open, its penetration from `u`. `N`: the DOF count of a step
    /// compiled for it ([`by_size`](crate::integrators::sized)), else 0. Returns whether the
    /// motion is finite ([`Self::motion_finite`], here at the step's size: the free commit
    /// takes it from [`Stepper::last_step_free`](crate::integrators::Stepper)).
    #[inline(always)]
    #[must_use]
    pub fn finish_free_flight<const N: usize>(&mut self, sys: &System, u: &[f64]) -> bool {
        self.finish::<true, N>(sys, u);
        self.motion_finite::<N>()
    }

    /// Whether the displacements and velocities are finite, read at `N` of them (as
    /// [`Self::finish_free_flight`]).
    #[inline(always)]
    pub(crate) fn motion_finite<const N: usize>(&self) -> bool {
        self.x
            .sized::<N>()
            .iter()
            .zip(self.v.sized::<N>())
            .all(|(&x, &v)| finite_motion(x, v))
    }

    #[inline(always)]
    fn finish<const FREE: bool, const N: usize>(&mut self, sys: &System, u: &[f64]) {
        let State {
            x: _,
            v,
            a,
            phi,
            u: gap_u,
            u_rate,
            u_accel,
            walls,
            ..
        } = self;
        let (v, a) = (v.sized::<N>(), a.sized::<N>());
        // (u copied in the same loop: no memcpy call for a few values)
        let gaps = u.iter().zip(gap_u.iter_mut()).zip(u_rate.iter_mut());
        let gaps = gaps.zip(u_accel.iter_mut().zip(phi.iter_mut()));
        if let Some(dofs) = &sys.unit_dofs {
            for ((((&u, u_g), rate), (accel, phi)), &d) in gaps.zip(dofs) {
                (*u_g, *rate, *accel) = (u, v[d], a[d]);
                if FREE {
                    *phi = 0.0;
                }
            }
        } else {
            for ((((&u, u_g), rate), (accel, phi)), g) in gaps.zip(&sys.gaps) {
                let (mut r, mut acc) = (-0.0, -0.0); // as `Iterator::sum`
                for (&d, &c) in g.dofs.iter().zip(&g.coefficients) {
                    r += c * v[d];
                    acc += c * a[d];
                }
                (*u_g, *rate, *accel) = (u, r, acc);
                if FREE {
                    *phi = 0.0;
                }
            }
        }
        let (u, u_rate) = (&*gap_u, &*u_rate);
        let one_d = |wall: &Wall, state: &mut WallState| {
            let rate = wall.sign * u_rate[wall.gap];
            if FREE {
                state.set_open(wall.sign * u[wall.gap] - wall.clearance, rate);
            } else {
                state.rate = rate;
            }
        };
        let walls = sys.walls.iter().zip(walls.iter_mut());
        // (a model without radial gaps, every free step of the fixed-step loop: no test per wall)
        if !sys.has_radial {
            walls.for_each(|(wall, state)| one_d(wall, state));
            return;
        }
        for (wall, state) in walls {
            if wall.sign == 0.0 {
                let Side::Radial(r) = &sys.gaps[wall.gap].side else {
                    unreachable!("a wall of sign 0 is radial")
                };
                let k = sys.radial_kinematics(r, wall.gap, u, u_rate);
                if FREE {
                    *state = WallState {
                        penetration: k.rho - wall.clearance,
                        ..WallState::default()
                    };
                }
                state.rate = k.rate;
                state.slide = k.slide;
                state.slip = r.radius * sys.structure.spin.start + k.slide;
            } else {
                one_d(wall, state);
            }
        }
    }

    /// Initial state: contact forces at `x0, v0` and the acceleration from equilibrium.
    pub fn initial(
        sys: &System,
        x0: DVector<f64>,
        v0: DVector<f64>,
        t0: f64,
    ) -> Result<Self, SimError> {
        let n = sys.n_dof();
        check_initial_state(sys, &x0, &v0)?;
        let ng = sys.gaps.len();
        let (mut u, mut u_rate) = (vec![0.0; ng], vec![0.0; ng]);
        sys.gap_coordinates(x0.as_slice(), &mut u);
        sys.gap_coordinates(v0.as_slice(), &mut u_rate);
        // A wall already closed at t0: its approach speed is the current closing speed.
        let start: Vec<WallState> = (0..sys.walls.len())
            .map(|j| {
                let (penetration, rate) = sys.wall_motion(j, &u, &u_rate);
                WallState {
                    penetration,
                    rate,
                    impact_speed: rate.abs().max(MIN_IMPACT_SPEED),
                    ..WallState::default()
                }
            })
            .collect();
        let mut walls = vec![WallState::default(); sys.walls.len()];
        let mut phi = vec![0.0; ng];
        let mut tangent = Tangent::new(ng);
        sys.evaluate_contacts(&start, &u, &u_rate, 1.0, &mut walls, &mut phi, &mut tangent);
        let load: Vec<f64> = sys.loads.iter().map(|l| l.value(t0)).collect();
        let st = &sys.structure;
        let mut a = vec![0.0; n];
        sys.add_loads(&load, 1.0, &mut a);
        sys.add_contact_force_scaled(&phi, 1.0, &mut a);
        st.damping.mul_add(-1.0, v0.as_slice(), &mut a);
        st.stiffness.mul_add(-1.0, x0.as_slice(), &mut a);
        st.solve_mass(&mut a);
        let mut u_accel = vec![0.0; ng];
        sys.gap_coordinates(&a, &mut u_accel);
        Ok(State {
            t: t0,
            x: x0.as_slice().into(),
            v: v0.as_slice().into(),
            a: a.as_slice().into(),
            load,
            phi,
            u,
            u_rate,
            u_accel,
            walls,
        })
    }
}

/// One finite value per DOF in the initial displacement and velocity.
pub(crate) fn check_initial_state(
    sys: &System,
    x0: &DVector<f64>,
    v0: &DVector<f64>,
) -> Result<(), SimError> {
    let n = sys.n_dof();
    for (name, vec) in [("initial.displacement", x0), ("initial.velocity", v0)] {
        if vec.len() != n {
            return invalid(format!(
                "{name}: {} values; expected {n} (one per DOF)",
                vec.len()
            ));
        }
        if vec.iter().any(|v| !v.is_finite()) {
            return invalid(format!("{name}: contains a non-finite value"));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use nalgebra::DMatrix;

    use super::*;
    use crate::contact::Hysteretic;

    /// `State::motion_finite` (its test in floating point) is `is_finite` of every x and v,
    /// at the compiled size and in general, for the values at the edges of finiteness.
    #[test]
    fn motion_finite_is_every_value_finite() {
        let law = Law::Hysteretic(Hysteretic::new("lankarani-nikravesh", 1e9, 1.5, 0.8).unwrap());
        let gap = Gap {
            dofs: vec![0],
            coefficients: vec![1.0],
            clearance: 1.0,
            side: Side::Both,
            law,
        };
        let i = DMatrix::identity(2, 2);
        let structure = LinearStructure::new(i.clone(), DMatrix::zeros(2, 2), i).unwrap();
        let sys = System::new(structure, vec![gap], vec![]).unwrap();
        let mut s = State::initial(&sys, DVector::zeros(2), DVector::zeros(2), 0.0).unwrap();
        let values = [
            0.0,
            -0.0,
            f64::MIN_POSITIVE / 4.0,
            f64::MAX,
            f64::MIN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            -f64::NAN,
        ];
        for (x, v) in values
            .iter()
            .flat_map(|&x| values.iter().map(move |&v| (x, v)))
        {
            for slot in 0..2 {
                s.x[slot] = x;
                s.v[1 - slot] = v;
                let expected = s.x.iter().chain(s.v.iter()).all(|z| z.is_finite());
                assert_eq!(s.motion_finite::<2>(), expected, "{x} {v}");
                assert_eq!(s.motion_finite::<0>(), expected, "{x} {v}");
                s.x[slot] = 0.0;
                s.v[1 - slot] = 0.0;
            }
        }
    }

    /// A model's one gap (its walls evaluated without the pass over the gaps) gives the same
    /// wall states, force and tangent to the bit as the same gap first among others (the pass).
    #[test]
    fn one_gap_equals_the_same_gap_among_others() {
        let law = Law::Hysteretic(Hysteretic::new("lankarani-nikravesh", 1e9, 1.5, 0.8).unwrap());
        let gap = |dof: usize, clearance: f64| Gap {
            dofs: vec![dof],
            coefficients: vec![1.0],
            clearance,
            side: Side::Both,
            law: law.clone(),
        };
        let structure = |n: usize| {
            let i = DMatrix::identity(n, n);
            LinearStructure::new(i.clone(), DMatrix::zeros(n, n), i).unwrap()
        };
        let one = System::new(structure(1), vec![gap(0, 1e-3)], vec![]).unwrap();
        let two = System::new(structure(2), vec![gap(0, 1e-3), gap(1, 1.0)], vec![]).unwrap();
        let wall = |penetration: f64, rate: f64| WallState {
            penetration,
            rate,
            impact_speed: rate.abs(),
            max_penetration: penetration.max(0.0),
            ..WallState::default()
        };
        // closing on the positive wall, in contact with the negative one, open between them
        for (u, rate, start) in [
            (1.2e-3, 0.3, [wall(-1e-5, 0.3), wall(-2e-3, -0.3)]),
            (-1.1e-3, -0.2, [wall(-2e-3, 0.2), wall(2e-5, 0.2)]),
            (0.5e-3, 0.1, [wall(-1e-4, 0.1), wall(-1.9e-3, -0.1)]),
        ] {
            let (mut walls, mut phi, mut t) = ([WallState::default(); 2], [0.0], Tangent::new(1));
            one.evaluate_contacts(&start, &[u], &[rate], 1e-6, &mut walls, &mut phi, &mut t);
            let start_two = [start[0], start[1], wall(-1.0, 0.0), wall(-1.0, 0.0)];
            let (mut walls_two, mut phi_two, mut t_two) =
                ([WallState::default(); 4], [0.0; 2], Tangent::new(2));
            two.evaluate_contacts(
                &start_two,
                &[u, 0.0],
                &[rate, 0.0],
                1e-6,
                &mut walls_two,
                &mut phi_two,
                &mut t_two,
            );
            assert_eq!(walls, walls_two[..2]);
            for (a, b) in [
                (phi[0], phi_two[0]),
                (t.d_u[0], t_two.d_u[0]),
                (t.d_rate[0], t_two.d_rate[0]),
            ] {
                assert_eq!(a.to_bits(), b.to_bits());
            }
            assert!(walls.iter().any(|w| w.closed()) == (u.abs() > 1e-3));
        }
    }
}
