//! What a run returns: the recorded rows, the energy account, the solver statistics
//! (docs/conventions.md).

use crate::error::SimError;
use crate::gap::ImpactRecord;
use crate::sensitivity::StateTransition;

/// Solver statistics.
#[derive(Debug, Clone, Copy, PartialEq)]
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
    /// Which step ran: `"fixed-size N=…"` for the Newmark family's step compiled for a model
    /// of that many DOFs (up to four), `"general"` otherwise (`--verbose`, `Result.stats`).
    pub step_path: &'static str,
}

impl Default for Stats {
    fn default() -> Self {
        Self {
            steps: 0,
            newton_iterations: 0,
            rejected_steps: 0,
            step_cuts: 0,
            wall_time_s: 0.0,
            step_path: "general",
        }
    }
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

    pub(crate) fn with_capacity(n: usize) -> Self {
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
    /// Largest |x| of each recorded DOF over every step (not only the recorded ones), m
    /// (empty in a run that keeps only its observer's, `Outputs::Observed`).
    pub max_abs_displacement: Vec<f64>,
    pub impacts: Vec<ImpactRecord>,
    pub stats: Stats,
    /// Step size actually used, s.
    pub dt: f64,
    /// Why the run stopped early; the arrays then hold the results up to that time.
    pub error: Option<SimError>,
    /// `∂(x, v)(t_end)/∂(x₀, v₀)`, when asked for (`simulate_with_sensitivity`).
    pub state_transition: Option<StateTransition>,
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
    pub(crate) fn with_capacity(n_rec: usize, n_dofs: usize, n_gaps: usize) -> Self {
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
