//! The state-transition matrix of a run, `Φ(t) = ∂z(t)/∂z₀` with `z = [x; v]`: what shooting
//! for periodic orbits needs (its monodromy matrix is `Φ` over the orbit's period, whose
//! eigenvalues are the Floquet multipliers; docs/periodic-orbits.md).
//!
//! The step policies that compute it (DOP853: the derivative of each Runge–Kutta stage; the
//! event-driven method: the exact `exp(A h)` of its flights; the Newmark family at fixed
//! steps: the derivative of each converged step of its discrete map,
//! `integrators::newmark_variational`) carry `Φ` from the run's start; the first two compose
//! it, at every located event where the vector field or the state jumps, with the saltation
//! matrix ([`saltation`]; DOP853 to first order: it differentiates the landing condition of
//! the step that ends on the switch — a wall's onset or end, a force's release inside the wall
//! — `integrators::dop853_variational`). [`crate::simulate::simulate_with_sensitivity`] returns
//! it in [`crate::output::RunOutput::state_transition`].
//!
//! Asked for a model [`Parameter`] too (a load's amplitude, frequency or phase, a gap's
//! clearance), DOP853, the Newmark family and the event-driven method carry its column `∂z/∂p`
//! beside `Φ`: the same variational (or discrete) equations with the parameter's forcing term
//! `∂f/∂p` (the event-driven flights: the derivative of their exponential), the same
//! saltation with the switch's `∂δ/∂p`. A load's frequency also scales the run's time (its
//! length and steps are a fixed number of forcing periods and of steps), so its column is that
//! of the map over the forcing period ([`Parameter::time_scale`]).

use nalgebra::{DMatrix, DVector};

use crate::error::{invalid, SimError};
use crate::integrators::MAX_TRANSITION_DOFS;
use crate::method::Method;
use crate::system::System;

/// `Φ(t) = ∂(x(t), v(t))/∂(x₀, v₀)`, `2n × 2n`: from the run's start to the end of the last
/// advance of its step policy; with a [`Parameter`], `[Φ | ∂z/∂p]`, `2n × (2n + 1)`.
#[derive(Debug, Clone, PartialEq)]
pub struct StateTransition {
    pub matrix: DMatrix<f64>,
}

impl StateTransition {
    /// `Φ = I` for `n` DOFs (the run's start).
    pub fn identity(n: usize) -> Self {
        Self::start(n, false)
    }

    /// `Φ = I`, and with `parameter` the column `∂z₀/∂p = 0` beside it.
    pub fn start(n: usize, parameter: bool) -> Self {
        Self {
            matrix: DMatrix::identity(2 * n, 2 * n + usize::from(parameter)),
        }
    }

    /// `Φ` (the first `2n` columns).
    pub fn monodromy(&self) -> DMatrix<f64> {
        let m = self.matrix.nrows();
        self.matrix.columns(0, m).into_owned()
    }

    /// `∂z/∂p`, if the run carries a parameter.
    pub fn parameter_column(&self) -> Option<DVector<f64>> {
        let m = self.matrix.nrows();
        (self.matrix.ncols() > m).then(|| self.matrix.column(m).into_owned())
    }

    /// `Φ ← S Φ` for the saltation matrix `S` of an event ([`saltation`]) given as the rank-one
    /// update `S = R + u ∇hᵀ` with `R` the jump map's Jacobian (`None`: the state does not
    /// jump, `R = I`), `u = (f⁺ − R f⁻)/(∇hᵀ f⁻)`; the parameter's column (if carried) takes
    /// the switching function's own `∂h/∂p` too: `∂z⁺/∂p = R ∂z⁻/∂p + u (∇hᵀ ∂z⁻/∂p + ∂h/∂p)`.
    pub fn compose_event(
        &mut self,
        jump: Option<&DMatrix<f64>>,
        u: &DVector<f64>,
        grad_h: &DVector<f64>,
        dh_dp: f64,
    ) {
        let mut row = grad_h.transpose() * &self.matrix;
        let m = self.matrix.nrows();
        if self.matrix.ncols() > m {
            row[m] += dh_dp;
        }
        if let Some(r) = jump {
            self.matrix = r * &self.matrix;
        }
        self.matrix += u * row;
    }
}

/// The saltation matrix of an event `h(z) = 0` crossed with the vector field `f⁻` before it
/// and `f⁺` after it, the state jumping by a map of Jacobian `R` (`I` when it does not jump):
/// `S = R + (f⁺ − R f⁻) ∇hᵀ / (∇hᵀ f⁻)` (Müller 1995; Leine & Nijmeijer 2004, §7.2), returned
/// as `u = (f⁺ − R f⁻)/(∇hᵀ f⁻)` for [`StateTransition::compose_event`].
/// `None` if the event is grazing (`∇hᵀ f⁻ = 0`: the derivative does not exist).
pub fn saltation_update(
    jump: Option<&DMatrix<f64>>,
    f_minus: &DVector<f64>,
    f_plus: &DVector<f64>,
    grad_h: &DVector<f64>,
) -> Option<DVector<f64>> {
    let transversal = grad_h.dot(f_minus);
    if transversal == 0.0 || !transversal.is_finite() {
        return None;
    }
    let r_f = match jump {
        Some(r) => r * f_minus,
        None => f_minus.clone(),
    };
    Some((f_plus - r_f) / transversal)
}

/// The full saltation matrix `S` (for tests and the docs' derivation; the policies apply it as
/// a rank-one update).
pub fn saltation(
    jump: Option<&DMatrix<f64>>,
    f_minus: &DVector<f64>,
    f_plus: &DVector<f64>,
    grad_h: &DVector<f64>,
) -> Option<DMatrix<f64>> {
    let u = saltation_update(jump, f_minus, f_plus, grad_h)?;
    let m = f_minus.len();
    let r = jump.cloned().unwrap_or_else(|| DMatrix::identity(m, m));
    Some(r + u * grad_h.transpose())
}

/// A model parameter whose column `∂z/∂p` a run carries beside `Φ` (the paths of
/// `sweep --param`: `loads.K.amplitude`, `loads.K.frequency`, `loads.K.phase`,
/// `gaps.K.clearance`, `structure.spin_speed`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Parameter {
    LoadAmplitude(usize),
    LoadFrequency(usize),
    LoadPhase(usize),
    Clearance(usize),
    /// `structure.spin_speed` Ω: it moves the unbalance loads (`m e Ω² (cos, sin)(Ωt + φ)`),
    /// the gyroscopic forces `Ω G ẋ`, a radial gap's sliding speed `R Ω + ρθ̇`, and the run's
    /// time, a multiple of the spin period `2π/|Ω|`.
    SpinSpeed,
}

impl Parameter {
    /// The parameter at `path` of `sys`, or why its column is not carried (the path names
    /// another number, or a load without that number, or a frequency that is not the only one).
    pub fn of_path(sys: &System, path: &str) -> Result<Self, String> {
        let parts: Vec<&str> = path.split('.').collect();
        let index = |count: usize| -> Result<usize, String> {
            match parts.get(1).and_then(|p| p.parse::<usize>().ok()) {
                Some(k) if k < count => Ok(k),
                _ => Err(format!("'{path}' names no item of the model")),
            }
        };
        let parameter = match (parts.first(), parts.get(2), parts.len()) {
            (Some(&"structure"), None, 2) if parts[1] == "spin_speed" => {
                let spin = sys.structure.spin.start;
                let periodic = sys.loads.iter().enumerate().all(|(i, l)| {
                    sys.unbalance.contains(&i)
                        || !matches!(l.history,
                            crate::structure::LoadHistory::Harmonic { frequency, .. } if frequency != 0.0)
                });
                if spin == 0.0 || sys.unbalance.is_empty() || !periodic {
                    return Err(format!(
                        "'{path}': the forcing period is not the spin period (no unbalance at a \
                         spin speed != 0, or another load is harmonic)"
                    ));
                }
                Self::SpinSpeed
            }
            (Some(&"loads"), Some(&name), 3) => {
                let k = index(sys.loads.len())?;
                let harmonic = matches!(
                    sys.loads[k].history,
                    crate::structure::LoadHistory::Harmonic { .. }
                );
                match name {
                    "amplitude" => Self::LoadAmplitude(k),
                    "frequency" | "phase" if !harmonic => {
                        return Err(format!("'{path}': load {k} is not harmonic"))
                    }
                    "frequency" => Self::LoadFrequency(k),
                    "phase" => Self::LoadPhase(k),
                    _ => return Err(format!("'{path}' has no exact column")),
                }
            }
            (Some(&"gaps"), Some(&"clearance"), 3) => Self::Clearance(index(sys.gaps.len())?),
            _ => {
                return Err(format!(
                    "'{path}' has no exact column (only a load's amplitude, frequency or phase                      and a gap's clearance have)"
                ))
            }
        };
        if let Self::LoadFrequency(k) = parameter {
            let others = sys.loads.iter().enumerate().any(|(i, l)| {
                i != k
                    && matches!(l.history,
                    crate::structure::LoadHistory::Harmonic { frequency, .. } if frequency != 0.0)
            });
            if others || parameter.frequency(sys) <= 0.0 {
                return Err(format!(
                    "'{path}': the forcing period is not that load's alone (another load is                      harmonic, or its frequency is not > 0)"
                ));
            }
        }
        Ok(parameter)
    }

    fn frequency(&self, sys: &System) -> f64 {
        match self {
            Self::LoadFrequency(k) => match sys.loads[*k].history {
                crate::structure::LoadHistory::Harmonic { frequency, .. } => frequency,
                _ => 0.0,
            },
            _ => 0.0,
        }
    }

    /// `(dT/dp)/T` of the run's time `T` (its length, its steps): `−1/f` for the frequency `f`
    /// of the forcing period, 0 otherwise.
    pub fn time_scale(&self, sys: &System) -> f64 {
        match self {
            Self::LoadFrequency(_) => -1.0 / self.frequency(sys),
            Self::SpinSpeed => -1.0 / sys.structure.spin.start,
            _ => 0.0,
        }
    }

    /// `∂F_ext/∂p` at time `t` (at fixed `t`), `n` entries.
    pub fn load_derivative(&self, sys: &System, t: f64) -> DVector<f64> {
        let mut out = DVector::zeros(sys.n_dof());
        let (k, g) = match *self {
            Self::LoadAmplitude(k) => (k, sys.loads[k].shape(t)),
            Self::LoadFrequency(k) | Self::LoadPhase(k) => {
                let load = &sys.loads[k];
                let crate::structure::LoadHistory::Harmonic { frequency, phase } = load.history
                else {
                    return out;
                };
                let tau = 2.0 * std::f64::consts::PI * t;
                let c = load.amplitude * (tau * frequency + phase).cos();
                (
                    k,
                    if matches!(self, Self::LoadPhase(_)) {
                        c
                    } else {
                        c * tau
                    },
                )
            }
            Self::Clearance(_) => return out,
            Self::SpinSpeed => {
                // A sin(|Ω| t + φ) with A ∝ Ω²: (2/Ω) A sin + A cos · t · sign(Ω)
                let spin = sys.structure.spin.start;
                for &k in &sys.unbalance {
                    let load = &sys.loads[k];
                    let crate::structure::LoadHistory::Harmonic { frequency, phase } = load.history
                    else {
                        continue;
                    };
                    let angle = 2.0 * std::f64::consts::PI * frequency * t + phase;
                    let (sin, cos) = angle.sin_cos();
                    let g = load.amplitude * (2.0 / spin * sin + cos * t * spin.signum());
                    for &d in &load.dofs {
                        out[d] += g;
                    }
                }
                return out;
            }
        };
        for &d in &sys.loads[k].dofs {
            out[d] += g;
        }
        out
    }

    /// `∂δ/∂p` of wall `wall` (`δ = s u − d`: −1 for a wall of the gap whose clearance it is).
    pub fn penetration_derivative(&self, sys: &System, wall: usize) -> f64 {
        match *self {
            Self::Clearance(g) if sys.walls[wall].gap == g => -1.0,
            _ => 0.0,
        }
    }
}

/// Whether `method` carries `parameter`'s column in `sys`: DOP853 every [`Parameter`]; the
/// Newmark family every one but the spin speed (its gyroscopic and friction terms are
/// DOP853's only); the event-driven method a gap's clearance (its flights do not depend on
/// it; its impacts' saltation takes `∂δ/∂p`) and, where every load is constant or harmonic
/// (the output of the flight's load oscillator), a load's amplitude, frequency and phase (the
/// derivative of the flight's exponential, `impulsive::event_driven`).
pub fn carries_parameter(sys: &System, method: Method, parameter: Parameter) -> bool {
    match (method, parameter) {
        (Method::Dop853, _) => true,
        (Method::EventDriven(_), Parameter::Clearance(_)) => true,
        (Method::EventDriven(_), Parameter::SpinSpeed) => false,
        (Method::EventDriven(_), _) => sys.loads.iter().all(|l| {
            matches!(
                l.history,
                crate::structure::LoadHistory::Constant
                    | crate::structure::LoadHistory::Harmonic { .. }
            )
        }),
        _ => method.newmark_family().is_some() && parameter != Parameter::SpinSpeed,
    }
}

/// The parameter at `path` whose column `method` carries in `sys`, or why it does not (then
/// the caller differentiates the map another way, e.g. by central differences).
pub fn parameter_for(sys: &System, method: Method, path: &str) -> Result<Parameter, String> {
    let parameter = Parameter::of_path(sys, path)?;
    if !carries_parameter(sys, method, parameter) {
        return Err(format!(
            "method '{}' does not carry the column of '{path}' (DOP853 carries every one with \
             a column, the Newmark family every one but the spin speed's, the event-driven \
             method a gap's clearance and, with constant and harmonic loads only, a load's)",
            method.name()
        ));
    }
    Ok(parameter)
}

/// Refuses a run whose state-transition matrix the `method` (with adaptive steps if
/// `adaptive`) does not compute, or whose laws it cannot differentiate, before it starts.
pub(crate) fn check_supported(
    sys: &System,
    method: Method,
    adaptive: bool,
) -> Result<(), SimError> {
    if let (Some(i), false) = (
        sys.gaps
            .iter()
            .position(|g| matches!(g.side, crate::gap::Side::Radial(_))),
        matches!(method, Method::Dop853),
    ) {
        return invalid(format!(
            "gaps[{i}].kind: 'radial' has no state-transition matrix with method '{}' yet; \
             expected solver.method = 'dop853'",
            method.name()
        ));
    }
    let newmark = method.newmark_family().is_some();
    if !(newmark || matches!(method, Method::Dop853 | Method::EventDriven(_))) {
        return invalid(format!(
            "solver.method: '{}' does not compute the state-transition matrix; expected \
             'dop853' or the Newmark family (compliant contact laws) or 'event-driven' (rigid \
             stops)",
            method.name()
        ));
    }
    if newmark && adaptive {
        return invalid(
            "solver.adaptive: true is not valid for the Newmark family's state-transition \
             matrix (its landed steps' lengths depend on the state); expected adaptive = false",
        );
    }
    if matches!(method, Method::Dop853) && !adaptive && !sys.gaps.is_empty() {
        return invalid(
            "solver.adaptive: false is not valid for DOP853's state-transition matrix (at fixed \
             steps, landed on the contacts, it is 3e-6 off central differences of the map at \
             2,000 steps a period, where adaptive steps are within 1e-6); expected adaptive \
             steps",
        );
    }
    let n = sys.n_dof();
    if !sys.structure.spin.is_constant() {
        return invalid(
            "structure.spin_profile: a run-up has no state-transition matrix (it is not \
             periodic); expected spin_profile = 'constant'",
        );
    }
    if newmark && n > MAX_TRANSITION_DOFS {
        return invalid(format!(
            "structure: {n} DOFs is more than the Newmark family's state-transition matrix \
             takes (dense, at most {MAX_TRANSITION_DOFS}); expected a reduced model \
             (vibroimpact.fe.reduction)"
        ));
    }
    if let Some((i, g)) = sys.gaps.iter().enumerate().find(|(_, g)| {
        matches!(g.law, crate::contact::Law::Tabulated(_)) || (newmark && g.law.uses_impact_speed())
    }) {
        return invalid(format!(
            "gaps[{i}].law: '{}' has no state-transition matrix with method '{}' yet (its force \
             depends on the contact's history); expected a law of the penetration and its rate",
            g.law.name(),
            method.name()
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The 1-DOF rigid stop with restitution `e` (`x'' + c x' + k x = F`, wall at `x = d`):
    /// the general formula gives `[[−e, 0], [(1+e)(F − k d)/v⁻, −e]]` (docs/periodic-orbits.md).
    #[test]
    fn rigid_stop_saltation_is_the_closed_form() {
        let (c, k, f, d, v, e) = (0.1, 1.0, 0.3, 0.5, 0.7, 0.8);
        let accel = |v: f64| f - c * v - k * d;
        let f_minus = DVector::from_vec(vec![v, accel(v)]);
        let f_plus = DVector::from_vec(vec![-e * v, accel(-e * v)]);
        let jump = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, -e]);
        let grad = DVector::from_vec(vec![1.0, 0.0]);
        let s = saltation(Some(&jump), &f_minus, &f_plus, &grad).unwrap();
        let expected = [-e, 0.0, (1.0 + e) * (f - k * d) / v, -e];
        for (i, want) in expected.iter().enumerate() {
            let got = s[(i / 2, i % 2)];
            assert!(
                (got - want).abs() < 1e-15,
                "S[{i}] = {got}, expected {want}"
            );
        }
        assert!(saltation(None, &DVector::from_vec(vec![0.0, 1.0]), &f_plus, &grad).is_none());
    }
}
