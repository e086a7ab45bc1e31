//! The model the integrators advance: linear structure + gaps + loads (paper eq. 2),
//! and the state of a run at one instant.

use nalgebra::DVector;

use crate::contact::MIN_IMPACT_SPEED;
use crate::error::{invalid, SimError};
use crate::gap::{evaluate_wall, Gap, Wall, WallState};
use crate::structure::{LinearStructure, Load};

/// `M x'' + C x' + K x = F(t) − Σ_g φ_g b_gᵀ`, with `φ_g = Σ_walls s F` the generalized
/// contact force on gap coordinate `u_g = b_g · x` (it pushes the coordinate out of the wall).
#[derive(Debug, Clone)]
pub struct System {
    pub structure: LinearStructure,
    pub gaps: Vec<Gap>,
    pub loads: Vec<Load>,
    pub walls: Vec<Wall>,
    pub has_damping: bool,
}

impl System {
    pub fn new(
        structure: LinearStructure,
        gaps: Vec<Gap>,
        loads: Vec<Load>,
    ) -> Result<Self, SimError> {
        let n = structure.n_dof();
        for (i, g) in gaps.iter().enumerate() {
            g.validate(i, n)?;
        }
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
        Ok(Self {
            structure,
            gaps,
            loads,
            walls,
            has_damping,
        })
    }

    pub fn n_dof(&self) -> usize {
        self.structure.n_dof()
    }

    /// `u_g = b_g · y` for every gap.
    #[inline]
    pub fn gap_coordinates(&self, y: &[f64], out: &mut [f64]) {
        for (o, g) in out.iter_mut().zip(&self.gaps) {
            *o = g
                .dofs
                .iter()
                .zip(&g.coefficients)
                .map(|(&d, &c)| c * y[d])
                .sum();
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
    /// their derivatives `∂φ/∂u`, `∂φ/∂u̇`.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn evaluate_contacts(
        &self,
        start: &[WallState],
        u: &[f64],
        u_rate: &[f64],
        h: f64,
        walls: &mut [WallState],
        phi: &mut [f64],
        d_phi_du: &mut [f64],
        d_phi_drate: &mut [f64],
    ) {
        phi.fill(0.0);
        d_phi_du.fill(0.0);
        d_phi_drate.fill(0.0);
        for (j, wall) in self.walls.iter().enumerate() {
            let g = wall.gap;
            let s = evaluate_wall(&self.gaps[g].law, wall, &start[j], u[g], u_rate[g], h);
            phi[g] += wall.sign * s.force;
            d_phi_du[g] += s.d_penetration;
            d_phi_drate[g] += s.d_rate;
            walls[j] = s;
        }
    }
}

/// Everything the integrators carry from one step to the next.
#[derive(Debug, Clone)]
pub struct State {
    pub t: f64,
    pub x: Vec<f64>,
    pub v: Vec<f64>,
    pub a: Vec<f64>,
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
    pub fn finish_gaps(&mut self, sys: &System, u: &[f64]) {
        self.u.copy_from_slice(u);
        for ((g, rate), accel) in sys.gaps.iter().zip(&mut self.u_rate).zip(&mut self.u_accel) {
            let (mut r, mut acc) = (-0.0, -0.0); // as `Iterator::sum`
            for (&d, &c) in g.dofs.iter().zip(&g.coefficients) {
                r += c * self.v[d];
                acc += c * self.a[d];
            }
            (*rate, *accel) = (r, acc);
        }
        for (wall, state) in sys.walls.iter().zip(self.walls.iter_mut()) {
            state.rate = wall.sign * self.u_rate[wall.gap];
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
        let start: Vec<WallState> = sys
            .walls
            .iter()
            .map(|w| WallState {
                penetration: w.sign * u[w.gap] - w.clearance,
                rate: w.sign * u_rate[w.gap],
                impact_speed: (w.sign * u_rate[w.gap]).abs().max(MIN_IMPACT_SPEED),
                ..WallState::default()
            })
            .collect();
        let mut walls = vec![WallState::default(); sys.walls.len()];
        let mut phi = vec![0.0; ng];
        let (mut du, mut dv) = (vec![0.0; ng], vec![0.0; ng]);
        sys.evaluate_contacts(
            &start, &u, &u_rate, 1.0, &mut walls, &mut phi, &mut du, &mut dv,
        );
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
            x: x0.as_slice().to_vec(),
            v: v0.as_slice().to_vec(),
            a,
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
