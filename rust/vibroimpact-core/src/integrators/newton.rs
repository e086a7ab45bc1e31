//! Newton–Raphson on the active gap coordinates (paper eqs. 22–27; docs/architecture.md).
//!
//! With the linear part factorised, a step's unknown is the increment of the gap coordinates
//! `Δu` only: `r(Δu) = Δu − Δu_lin + W φ(Δu) = 0`, `W = B K̃⁻¹ Bᵀ`. The Jacobian is
//! `I + W diag(∂φ/∂u + c_v ∂φ/∂u̇)`, a c×c system on the gaps in contact.
//!
//! [`GapNewton`] is that loop, shared by every implicit integrator (Newmark family, Bathe,
//! the precise method's predictor–corrector): each integrator only states its step's
//! [`GapProblem`] (`W`, `Δu_lin`, and how the gap rates follow `Δu`).

use super::StepFailure;
use crate::gap::{Wall, WallState};
use crate::system::{System, Tangent};

/// Stopping rule and limits of the Newton iterations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewtonSettings {
    /// Relative tolerance on the increment and on the residual of the gap coordinates
    /// (paper eq. 27, with `e` as a fraction rather than a percentage).
    pub rtol: f64,
    /// Absolute tolerance on them, m.
    pub atol: f64,
    /// Iterations allowed per step before the step is cut.
    pub max_iterations: usize,
    /// Times a step may be halved (recursively) before the run fails.
    pub max_step_cuts: usize,
}

/// How the gap rates follow the gap increments inside one step: `u̇ = rate_lin + S Δu`.
#[derive(Debug, Clone, Copy)]
pub(crate) enum RateMap<'a> {
    /// `S = c_v I`: each gap's rate follows its own increment (Newmark family: `c_v = γ/(βh)`;
    /// Bathe's backward sub-step: `c_v = c₃`). Newton then works on the gaps in contact only.
    Diagonal(f64),
    /// A full `S`, row-major gaps × gaps (the precise method's corrector, where the rates come
    /// from the contact forces through the Duhamel matrices: `S = V W⁻¹`).
    Full(&'a [f64]),
}

/// One step's nonlinear problem on the gap coordinates:
/// `r(Δu) = Δu − Δu_lin + W φ(u₀ + Δu, rate_lin + S Δu) = 0`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct GapProblem<'a> {
    /// `W`, row-major gaps × gaps: how the gap coordinates at the end of the step move per
    /// unit generalized contact force at the end of the step (`B K̃⁻¹ Bᵀ` for Newmark).
    pub w: &'a [f64],
    /// Gap coordinates at the start of the step.
    pub u0: &'a [f64],
    /// Increment of the gap coordinates with no contact force at the end of the step.
    pub du_lin: &'a [f64],
    pub rate_lin: &'a [f64],
    pub rate: RateMap<'a>,
    /// Wall states at the start of the step (the crossing and `v_imp` are located between
    /// them and the iterate) and the step's length, s.
    pub start: &'a [WallState],
    pub h: f64,
}

/// A [`GapProblem`] on one 1-D gap coordinate with `S = c_v` ([`RateMap::Diagonal`]): its
/// numbers by value, for [`GapNewton::solve_one`].
#[derive(Debug, Clone, Copy)]
pub(crate) struct OneGap<'a> {
    pub w: f64,
    pub u0: f64,
    pub du_lin: f64,
    pub rate_lin: f64,
    pub c_v: f64,
    pub start: &'a [WallState],
    pub h: f64,
}

/// Newton–Raphson on the gap coordinates, with its preallocated work space.
#[derive(Debug, Clone)]
pub(crate) struct GapNewton {
    /// Unknown `Δu`: the caller writes the initial guess here.
    pub du: Vec<f64>,
    /// Gap coordinates `u₀ + Δu` and rates of the last iterate (the solution on success).
    pub u: Vec<f64>,
    pub u_rate: Vec<f64>,
    residual: Vec<f64>,
    tangent: Tangent,
    stiffness: Vec<f64>,
    /// A radial gap's coupling `K[p][g]` of coordinate `g` to its partner `p` (with `K` as
    /// `stiffness` is its diagonal).
    coupling: Vec<f64>,
    jacobian: Vec<f64>,
    step: Vec<f64>,
    increment: Vec<f64>,
    active: Vec<usize>,
}

impl GapNewton {
    /// Initial guess `Δu = Δu_lin − W φ`: the linear predictor moved by given contact forces
    /// (those of the start of the step, or of an earlier sub-step). In line in each step, as
    /// before it had a path for one coordinate (out of line, the rotor's Newmark run costs
    /// +0.7 %).
    #[inline(always)]
    pub fn start_from(&mut self, w: &[f64], du_lin: &[f64], phi: &[f64]) {
        if let ([du], [w], [du_lin], [phi]) = (self.du.as_mut_slice(), w, du_lin, phi) {
            // one coordinate: the one term of the sum below (from −0.0: the term itself)
            *du = du_lin - w * phi;
            return;
        }
        let ng = du_lin.len();
        for (gi, du) in self.du.iter_mut().enumerate() {
            let wrow = &w[gi * ng..(gi + 1) * ng];
            let wphi: f64 = wrow.iter().zip(phi).map(|(w, p)| w * p).sum();
            *du = du_lin[gi] - wphi;
        }
    }

    /// Whether no wall closes in the step: every wall open at its start `start` (so no contact
    /// force there, and Newton's first iterate is the linear predictor `Δu_lin` itself) and
    /// still open at `self.u`, which the caller has set to `u₀ + Δu_lin` (so that iterate has
    /// no force either: zero residual, what [`Self::solve`] would return after evaluating every
    /// wall). The step's gap coordinates are then `self.u`, its forces zero and its walls open
    /// (`State::finish_free_flight`); `solve` sets `self.u` itself before it reads it.
    #[inline(always)]
    pub fn free_flight(&self, sys: &System, start: &[WallState]) -> bool {
        let u = &self.u;
        let open = |(wall, start): (&Wall, &WallState)| {
            !start.closed() && wall.sign * u[wall.gap] <= wall.clearance
        };
        sys.walls.iter().zip(start).all(open) && (!sys.has_radial || self.radial_open(sys))
    }

    /// Every radial wall stays open at the linear predictor `self.u` (the 1-D walls are
    /// checked by [`Self::free_flight`]; a radial wall's sign 0 passes that check; its
    /// penetration depends on `self.u` only, not on the rates).
    fn radial_open(&self, sys: &System) -> bool {
        (0..sys.walls.len())
            .filter(|&j| sys.walls[j].sign == 0.0)
            .all(|j| sys.wall_motion(j, &self.u, &self.u_rate).0 <= 0.0)
    }

    pub fn new(n_gaps: usize) -> Self {
        let ng = n_gaps;
        Self {
            du: vec![0.0; ng],
            u: vec![0.0; ng],
            u_rate: vec![0.0; ng],
            residual: vec![0.0; ng],
            tangent: Tangent::new(ng),
            stiffness: vec![0.0; ng],
            coupling: vec![0.0; ng],
            jacobian: vec![0.0; ng * ng],
            step: vec![0.0; ng],
            increment: vec![0.0; ng],
            active: Vec::with_capacity(ng),
        }
    }

    /// Solves `p` from the guess in `self.du`. Stops when the residual is within
    /// `rtol |u| + atol` and (after the first iteration) so is the increment (paper eq. 27).
    /// On success, `walls` and `phi` hold the contact state at `self.u`, `self.u_rate`, and
    /// the number of iterations is returned.
    // Inlined into each integrator's step, as the loop was before it was shared: called
    // out of line it costs the Newmark step ~6 % more instructions, inlined ~2 %.
    #[inline(always)]
    pub fn solve(
        &mut self,
        sys: &System,
        settings: &NewtonSettings,
        p: &GapProblem<'_>,
        walls: &mut [WallState],
        phi: &mut [f64],
    ) -> Result<usize, StepFailure> {
        match p.rate {
            // one 1-D gap coordinate (a radial gap has two)
            RateMap::Diagonal(c_v) if self.du.len() == 1 && !sys.has_radial => {
                let g = OneGap {
                    w: p.w[0],
                    u0: p.u0[0],
                    du_lin: p.du_lin[0],
                    rate_lin: p.rate_lin[0],
                    c_v,
                    start: p.start,
                    h: p.h,
                };
                self.solve_one(sys, settings, &g, self.du[0], walls, &mut phi[0])
            }
            _ => self.solve_general(sys, settings, p, walls, phi),
        }
    }

    /// [`Self::solve`] on one 1-D gap coordinate with `S = c_v` (the contact step of the
    /// Newmark family, Bathe and the precise corrector on a model with one 1-D gap): the
    /// arithmetic of [`Self::solve_general`] on one coordinate in the same order, its iterate
    /// held in registers rather than in the work vectors (they get `Δu`, `u`, `u̇` on return)
    /// and the gap's walls evaluated without [`System::evaluate_contacts`]' tests of the
    /// model's shape per iteration. An open wall's state is written at the last iterate only
    /// (the iterates before it need the closed walls' forces alone). `du`: the first iterate
    /// (what [`Self::solve`] reads from `self.du`); `phi`: the gap's contact force. The
    /// Newmark step calls it with its numbers by value, without a [`GapProblem`]'s slices.
    #[inline(always)]
    pub(crate) fn solve_one(
        &mut self,
        sys: &System,
        settings: &NewtonSettings,
        g: &OneGap<'_>,
        mut du: f64,
        walls: &mut [WallState],
        phi: &mut f64,
    ) -> Result<usize, StepFailure> {
        let OneGap {
            w,
            u0,
            du_lin,
            rate_lin,
            c_v,
            start,
            h,
        } = *g;
        let law = &sys.gaps[0].law;
        // cut to the walls' count once: each pass over the walls then has one length
        let n_walls = sys.walls.len();
        let (start, walls) = (&start[..n_walls], &mut walls[..n_walls]);
        let mut iterations = 0;
        let mut increment_large = true;
        // `None`: converged; `Some(exhausted)`: stopped (see `Self::failure`)
        let (stopped, u, u_rate, force, r) = loop {
            let u = u0 + du;
            let u_rate = c_v * du + rate_lin;
            let [force, d_u, d_rate] = sys.one_gap_walls::<false>(law, start, u, u_rate, h, walls);
            // `W φ` as the one term of `Iterator::sum` (which starts at −0.0: the term itself)
            let r = du - du_lin + w * force;
            let stiffness = d_u + c_v * d_rate;
            let residual_large = r.abs() > settings.rtol * u.abs() + settings.atol;
            let done = !residual_large && (iterations == 0 || !increment_large);
            if done || iterations >= settings.max_iterations {
                break ((!done).then_some(true), u, u_rate, force, r);
            }
            // `(1 + W K) d = −r` when the coordinate is active, else `d = −(the empty sum)`
            let d = if r != 0.0 || stiffness != 0.0 {
                let j = w * stiffness + 1.0;
                if j == 0.0 {
                    break (Some(false), u, u_rate, force, r);
                }
                -r / j
            } else {
                0.0
            };
            iterations += 1;
            du += d;
            increment_large = d.abs() > settings.rtol * (u0 + du).abs() + settings.atol;
        };
        sys.open_gap_walls(u, u_rate, walls);
        (self.du[0], self.u[0], self.u_rate[0], *phi) = (du, u, u_rate, force);
        let Some(exhausted) = stopped else {
            return Ok(iterations);
        };
        self.residual[0] = r;
        Err(self.failure(sys, settings, walls, iterations, exhausted))
    }

    /// [`Self::solve`] on any number of gap coordinates.
    #[inline(always)]
    fn solve_general(
        &mut self,
        sys: &System,
        settings: &NewtonSettings,
        p: &GapProblem<'_>,
        walls: &mut [WallState],
        phi: &mut [f64],
    ) -> Result<usize, StepFailure> {
        let ng = self.du.len();
        let (w, u0, du_lin, rate_lin) = (
            &p.w[..ng * ng],
            &p.u0[..ng],
            &p.du_lin[..ng],
            &p.rate_lin[..ng],
        );
        let c_v = match p.rate {
            RateMap::Diagonal(c) => c,
            RateMap::Full(_) => 0.0,
        };
        let mut iterations = 0;
        let mut increment_small = false;
        loop {
            // the work vectors sliced to the count once per phase, not checked per access
            let (du, u, u_rate) = (&self.du[..ng], &mut self.u[..ng], &mut self.u_rate[..ng]);
            match p.rate {
                RateMap::Diagonal(c) => {
                    for gi in 0..ng {
                        u[gi] = u0[gi] + du[gi];
                        u_rate[gi] = c * du[gi] + rate_lin[gi];
                    }
                }
                RateMap::Full(s) => {
                    for gi in 0..ng {
                        u[gi] = u0[gi] + du[gi];
                        let srow = &s[gi * ng..(gi + 1) * ng];
                        let sdu: f64 = srow.iter().zip(du).map(|(a, b)| a * b).sum();
                        u_rate[gi] = rate_lin[gi] + sdu;
                    }
                }
            }
            sys.evaluate_contacts(
                p.start,
                &self.u,
                &self.u_rate,
                p.h,
                walls,
                phi,
                &mut self.tangent,
            );
            let mut residual_small = true;
            self.active.clear();
            let (du, u, phi) = (&self.du[..ng], &self.u[..ng], &phi[..ng]);
            let (residual, stiffness, coupling) = (
                &mut self.residual[..ng],
                &mut self.stiffness[..ng],
                &mut self.coupling[..ng],
            );
            let t = &self.tangent;
            let (d_u, d_rate, cross_u, cross_rate) = (
                &t.d_u[..ng],
                &t.d_rate[..ng],
                &t.cross_u[..ng],
                &t.cross_rate[..ng],
            );
            for gi in 0..ng {
                let wrow = &w[gi * ng..(gi + 1) * ng];
                let wphi: f64 = wrow.iter().zip(phi).map(|(w, p)| w * p).sum();
                let r = du[gi] - du_lin[gi] + wphi;
                residual[gi] = r;
                stiffness[gi] = d_u[gi] + c_v * d_rate[gi];
                let tol = settings.rtol * u[gi].abs() + settings.atol;
                if r.abs() > tol {
                    residual_small = false;
                }
                let coupled = sys.has_radial && {
                    coupling[gi] = cross_u[gi] + c_v * cross_rate[gi];
                    coupling[gi] != 0.0
                };
                if r != 0.0 || stiffness[gi] != 0.0 || coupled {
                    self.active.push(gi);
                }
            }
            if residual_small && (iterations == 0 || increment_small) {
                return Ok(iterations);
            }
            if iterations >= settings.max_iterations {
                return Err(self.failure(sys, settings, walls, iterations, true));
            }
            let solved = match p.rate {
                RateMap::Diagonal(_) if sys.has_radial => {
                    self.diagonal_step::<true>(ng, w, &sys.partner)
                }
                RateMap::Diagonal(_) => self.diagonal_step::<false>(ng, w, &[]),
                RateMap::Full(s) => self.full_step(w, s),
            };
            if !solved {
                return Err(self.failure(sys, settings, walls, iterations, false));
            }
            iterations += 1;
            increment_small = self.apply_increment(settings, ng, u0);
        }
    }

    /// Why Newton stopped at the iterate in the work vectors and `walls`: `exhausted`, the
    /// iterations allowed ran out (with the deepest penetration of the worst gap's walls),
    /// else its matrix was singular.
    #[cold]
    fn failure(
        &self,
        sys: &System,
        settings: &NewtonSettings,
        walls: &[WallState],
        iterations: usize,
        exhausted: bool,
    ) -> StepFailure {
        let gap = sys.gap_of(self.worst_gap(settings));
        let penetration = if exhausted {
            sys.walls
                .iter()
                .zip(walls)
                .filter(|(w, _)| w.gap == gap)
                .map(|(_, s)| s.penetration)
                .fold(f64::NEG_INFINITY, f64::max)
        } else {
            0.0
        };
        StepFailure {
            gap,
            penetration,
            iterations,
            singular: false,
        }
    }

    /// `Δu += d` on the `ng` gap coordinates; whether every `|d|` is within `rtol |u| + atol`
    /// (paper eq. 27).
    #[inline(always)]
    fn apply_increment(&mut self, settings: &NewtonSettings, ng: usize, u0: &[f64]) -> bool {
        let mut small = true;
        let (du, increment, u0) = (&mut self.du[..ng], &self.increment[..ng], &u0[..ng]);
        for ((du, &d), &u0) in du.iter_mut().zip(increment).zip(u0) {
            *du += d;
            if d.abs() > settings.rtol * (u0 + *du).abs() + settings.atol {
                small = false;
            }
        }
        small
    }

    /// Newton step with `S = c_v I` on `ng` gap coordinates: solves `(I + W_AA K_A) d_A = −r_A`
    /// on the active gaps;
    /// the others follow, `d_N = −W_NA K_A d_A` (their `r_N` is zero), with
    /// `K = ∂φ/∂u + c_v ∂φ/∂u̇`. Writes `d` for every gap into `self.increment`. `RADIAL`:
    /// `K` has the 2×2 blocks of the radial gaps' coordinate pairs, so
    /// `(W K)[g][h] = W[g][h] K[h][h] + W[g][p] K[p][h]` (`p` the partner of `h`); without
    /// radial gaps (the constant `false`) the partner terms are compiled out.
    #[inline(always)]
    fn diagonal_step<const RADIAL: bool>(
        &mut self,
        ng: usize,
        w: &[f64],
        partner: &[Option<usize>],
    ) -> bool {
        let m = self.active.len();
        let wk = |gi: usize, hi: usize, stiffness: &[f64], coupling: &[f64]| {
            let direct = w[gi * ng + hi] * stiffness[hi];
            if RADIAL {
                direct + partner[hi].map_or(0.0, |p| w[gi * ng + p] * coupling[hi])
            } else {
                direct
            }
        };
        for (ia, &gi) in self.active.iter().enumerate() {
            for (ib, &hi) in self.active.iter().enumerate() {
                self.jacobian[ia * m + ib] =
                    wk(gi, hi, &self.stiffness, &self.coupling) + if ia == ib { 1.0 } else { 0.0 };
            }
            self.step[ia] = -self.residual[gi];
        }
        if !solve_small(&mut self.jacobian[..m * m], &mut self.step[..m], m) {
            return false;
        }
        for gi in 0..ng {
            self.increment[gi] = match self.active.iter().position(|&a| a == gi) {
                Some(ia) => self.step[ia],
                None => -self
                    .active
                    .iter()
                    .enumerate()
                    .map(|(ia, &hi)| wk(gi, hi, &self.stiffness, &self.coupling) * self.step[ia])
                    .sum::<f64>(),
            };
        }
        true
    }

    /// Newton step with a full `S`: `(I + W (D_u + D_v S)) d = −r` on every gap.
    fn full_step(&mut self, w: &[f64], s: &[f64]) -> bool {
        let ng = self.du.len();
        for gi in 0..ng {
            for bi in 0..ng {
                let mut j = w[gi * ng + bi] * self.tangent.d_u[bi];
                for hi in 0..ng {
                    j += w[gi * ng + hi] * self.tangent.d_rate[hi] * s[hi * ng + bi];
                }
                self.jacobian[gi * ng + bi] = j + if gi == bi { 1.0 } else { 0.0 };
            }
            self.increment[gi] = -self.residual[gi];
        }
        solve_small(&mut self.jacobian[..ng * ng], &mut self.increment, ng)
    }

    /// Gap with the largest residual relative to its tolerance (for failure reports).
    fn worst_gap(&self, settings: &NewtonSettings) -> usize {
        let scaled = |gi: usize| {
            self.residual[gi].abs() / (settings.rtol * self.u[gi].abs() + settings.atol)
        };
        (0..self.residual.len())
            .max_by(|&a, &b| scaled(a).total_cmp(&scaled(b)))
            .unwrap_or(0)
    }
}

/// Solves `A z = b` in place for a small dense system (row-major `A`, size m), by Gaussian
/// elimination with partial pivoting. Returns false if `A` is singular.
pub(crate) fn solve_small(a: &mut [f64], b: &mut [f64], m: usize) -> bool {
    if m == 1 {
        if a[0] == 0.0 {
            return false;
        }
        b[0] /= a[0];
        return true;
    }
    for col in 0..m {
        let mut piv = col;
        for row in col + 1..m {
            if a[row * m + col].abs() > a[piv * m + col].abs() {
                piv = row;
            }
        }
        if a[piv * m + col] == 0.0 {
            return false;
        }
        if piv != col {
            for k in 0..m {
                a.swap(col * m + k, piv * m + k);
            }
            b.swap(col, piv);
        }
        let d = a[col * m + col];
        for row in col + 1..m {
            let f = a[row * m + col] / d;
            if f != 0.0 {
                for k in col..m {
                    a[row * m + k] -= f * a[col * m + k];
                }
                b[row] -= f * b[col];
            }
        }
    }
    for col in (0..m).rev() {
        let mut s = b[col];
        for k in col + 1..m {
            s -= a[col * m + k] * b[k];
        }
        b[col] = s / a[col * m + col];
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gap::Side;
    use crate::integrators::newmark::tests::small_chain;

    /// Newton on one 1-D gap coordinate (`solve_one`) gives the general solve's bits: the
    /// result (iterations or failure), `Δu`, `u`, `u̇`, the walls and `φ`, on a two-sided stop
    /// from open and closed starts, over increments that close one wall or the other, and
    /// with too few iterations allowed (the failure's report).
    #[test]
    fn one_coordinate_equals_the_general_solve() {
        let sys = small_chain(1, 2.0, &[(&[(0, 1.0)], 1e-3, Side::Both)]);
        let h = 1e-5;
        let (w, c_v) = (2.5e-11, 2.0 / h);
        let (mut cases, mut failed, mut closed) = (0, 0, 0);
        for max_iterations in [1, 2, 30] {
            let settings = NewtonSettings {
                max_iterations,
                ..NewtonSettings::default()
            };
            for (u_start, rate_start) in [(0.0, 0.5), (1.0005e-3, 0.3), (-1.0002e-3, -0.2)] {
                let mut start = vec![WallState::default(); sys.walls.len()];
                let (mut phi0, mut tangent) = (vec![0.0], Tangent::new(1));
                let open = start.clone();
                sys.evaluate_contacts(
                    &open,
                    &[u_start],
                    &[rate_start],
                    h,
                    &mut start,
                    &mut phi0,
                    &mut tangent,
                );
                for du_lin in [-3e-6, -1e-7, 0.0, 2e-7, 4e-6, 1e-4] {
                    let rate_lin = [rate_start - c_v * 1e-7];
                    let problem = GapProblem {
                        w: &[w],
                        u0: &[u_start],
                        du_lin: &[du_lin],
                        rate_lin: &rate_lin,
                        rate: RateMap::Diagonal(c_v),
                        start: &start,
                        h,
                    };
                    let solved = [true, false].map(|one| {
                        let mut newton = GapNewton::new(1);
                        newton.start_from(problem.w, problem.du_lin, &phi0);
                        let (mut walls, mut phi) = (open.clone(), vec![0.0]);
                        let result = if one {
                            newton.solve(&sys, &settings, &problem, &mut walls, &mut phi)
                        } else {
                            newton.solve_general(&sys, &settings, &problem, &mut walls, &mut phi)
                        };
                        let motion = [newton.du[0], newton.u[0], newton.u_rate[0], phi[0]];
                        failed += usize::from(one && result.is_err());
                        closed += usize::from(one && walls.iter().any(WallState::closed));
                        format!("{result:?} {:?} {walls:?}", motion.map(f64::to_bits))
                    });
                    assert_eq!(solved[0], solved[1], "{u_start} {du_lin} {max_iterations}");
                    cases += 1;
                }
            }
        }
        assert_eq!(cases, 54);
        assert!(
            failed > 0 && failed < cases && closed > 0,
            "{failed} {closed}"
        );
    }

    #[test]
    fn small_solver_matches_nalgebra() {
        let a = [4.0, 1.0, 2.0, 0.5, 3.0, 1.0, 2.0, 1.0, 5.0];
        let b = [1.0, -2.0, 3.0];
        let (mut aa, mut bb) = (a, b);
        assert!(solve_small(&mut aa, &mut bb, 3));
        let m = nalgebra::Matrix3::from_row_slice(&a);
        let x = m
            .lu()
            .solve(&nalgebra::Vector3::from_row_slice(&b))
            .unwrap();
        for i in 0..3 {
            assert!((bb[i] - x[i]).abs() < 1e-14);
        }
    }
}
