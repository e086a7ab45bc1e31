//! What the fixed-step loop's free runs share ([`super::Stepper::free_run`]: the Newmark
//! family's and precise integration's Adams steps, taken in one tight loop while every wall
//! stays open): the walls (and the loads) held in local arrays and the test that ends a run where a wall would
//! close. A run ends with [`crate::driver::Run::end_free_run`].

use crate::system::{State, System};

/// The most walls (and so gaps) of a model whose free flight runs in one loop: its walls and
/// gap coordinates are held in local arrays.
pub(crate) const FREE_RUN_WALLS: usize = 8;

/// The most loads of a model whose free flight runs in one loop (without rows: a sweep's
/// transient): their values and predictor columns are held in local arrays.
pub(crate) const FREE_RUN_LOADS: usize = 4;

/// A model's walls in locals, for a free run: the rows' writes cannot alias them, so they are
/// not reloaded from the model every step.
pub(crate) struct FreeWalls {
    /// Each wall's gap, sign and clearance (the walls of a gap adjacent).
    walls: [(usize, f64, f64); FREE_RUN_WALLS],
    count: usize,
    /// Each gap's DOF when every gap is one DOF's displacement (`System::unit_dofs`).
    pub unit_dofs: Option<[usize; FREE_RUN_WALLS]>,
}

impl FreeWalls {
    /// `None`: more than [`FREE_RUN_WALLS`] walls (no free run for the model).
    pub(crate) fn new(sys: &System) -> Option<Self> {
        let count = sys.walls.len();
        if count > FREE_RUN_WALLS {
            return None;
        }
        let mut walls = [(0, 0.0, 0.0); FREE_RUN_WALLS];
        for (local, wall) in walls.iter_mut().zip(&sys.walls) {
            *local = (wall.gap, wall.sign, wall.clearance);
        }
        let unit_dofs = sys.unit_dofs.as_ref().map(|dofs| {
            let mut unit = [0; FREE_RUN_WALLS];
            unit[..dofs.len()].copy_from_slice(dofs);
            unit
        });
        Some(Self {
            walls,
            count,
            unit_dofs,
        })
    }

    /// Each wall's gap, sign and clearance.
    #[inline(always)]
    pub(crate) fn walls(&self) -> &[(usize, f64, f64)] {
        &self.walls[..self.count]
    }

    /// Whether a wall, open at the step's start, closes at the gap coordinates `u(g)` of its
    /// end (or `u` is NaN); `depth`: each wall's penetration `s u − c` there. As
    /// `GapNewton::free_flight` with every wall open at the start: `s u <= c` is `s u − c <= 0`,
    /// the difference of two floats being 0 only when they are equal. (Only the first walls'
    /// and gaps' entries are read: the arrays need no clearing per step.)
    #[inline(always)]
    pub(crate) fn closing(&self, u: impl Fn(usize) -> f64, depth: &mut [f64]) -> bool {
        self.walls()
            .iter()
            .zip(depth)
            .any(|(&(g, sign, c), depth)| {
                *depth = sign * u(g) - c;
                *depth > 0.0 || depth.is_nan()
            })
    }
}

/// The motion `[x, v, a]` of `state`'s `N` DOFs in locals: where a free run starts.
#[inline(always)]
pub(crate) fn local_motion<const N: usize>(state: &State) -> [[f64; N]; 3] {
    let local = |values: &[f64]| std::array::from_fn(|i| values[i]);
    [
        local(state.x.sized::<N>()),
        local(state.v.sized::<N>()),
        local(state.a.sized::<N>()),
    ]
}
