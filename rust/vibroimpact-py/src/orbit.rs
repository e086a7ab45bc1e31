//! The flow map of a model with its state-transition matrix (`_core.flow_map`): what
//! `vibroimpact.orbits` shoots with.

use pyo3::prelude::*;
use pyo3::types::PyDict;

use numpy::PyArray1;
use vibroimpact_core::observe::{StepObserver, Turn};
use vibroimpact_core::sensitivity::parameter_for;
use vibroimpact_core::simulate::simulate_with_sensitivity;
use vibroimpact_core::system::{State, System};

use crate::{convert, output_to_dict, to_numpy, to_py_err};

/// Each DOF's smallest and largest displacement over every accepted step's end (the impact
/// instants of the event-driven method included) and the turning points inside the steps.
struct Extremes {
    low: Vec<f64>,
    high: Vec<f64>,
}

impl StepObserver for Extremes {
    fn accepted(
        &mut self,
        _sys: &System,
        _s0: &State,
        s1: &State,
        _h: f64,
        turns: Option<&[Option<Turn>]>,
    ) {
        for (d, &x) in s1.x.iter().enumerate() {
            let inside = turns.and_then(|t| t[d]).map_or(x, |(_, value)| value);
            self.low[d] = self.low[d].min(x).min(inside);
            self.high[d] = self.high[d].max(x).max(inside);
        }
    }
}

/// Runs one model spec (as `_core.start` takes it) carrying the state-transition matrix:
/// the output dict of `Running.finish` plus `state_transition`, `∂(x, v)(t_end)/∂(x₀, v₀)`
/// (`2n × 2n`; None if the run stopped early), `displacement_min`, `displacement_max`
/// (per DOF, over every step: [`Extremes`]) and, for the path `sensitivity_parameter` of the
/// spec (optional), `parameter_column` (`∂(x, v)(t_end)/∂p`, or None) and
/// `parameter_column_note` (why it is None: the method or the parameter has no column; "" if
/// it is there or was not asked for).
#[pyfunction]
pub(crate) fn flow_map<'py>(
    py: Python<'py>,
    spec: &Bound<'py, PyDict>,
) -> PyResult<Bound<'py, PyDict>> {
    let convert::Job {
        system,
        method,
        settings,
        x0,
        v0,
    } = convert::job_from_spec(spec, None)?;
    // the column of the parameter at this path, if the method carries it (else why not)
    let path: Option<String> = spec
        .get_item("sensitivity_parameter")?
        .filter(|p| !p.is_none())
        .map(|p| p.extract())
        .transpose()?;
    let parameter = path.map(|p| parameter_for(&system, method, &p));
    let n_gaps = system.n_gaps;
    let mut extremes = Extremes {
        low: x0.iter().copied().collect(),
        high: x0.iter().copied().collect(),
    };
    let mut out = py
        .detach(|| {
            let parameter = parameter.as_ref().and_then(|p| p.as_ref().ok().copied());
            simulate_with_sensitivity(
                &system,
                method,
                &settings,
                x0,
                v0,
                parameter,
                Some(&mut extremes),
            )
        })
        .map_err(to_py_err)?;
    let transition = out.state_transition.take().filter(|_| out.error.is_none());
    let rows = std::mem::take(&mut out.rows);
    let balance = rows.energy.relative_balance_error();
    let d = output_to_dict(py, out, rows, n_gaps, balance)?;
    let column = transition
        .as_ref()
        .and_then(|t| t.parameter_column())
        .map(|c| PyArray1::from_vec(py, c.as_slice().to_vec()));
    let matrix = transition
        .map(|t| to_numpy(py, &t.monodromy()))
        .transpose()?;
    d.set_item("state_transition", matrix)?;
    d.set_item("parameter_column", column)?;
    d.set_item(
        "parameter_column_note",
        parameter.and_then(|p| p.err()).unwrap_or_default(),
    )?;
    d.set_item("displacement_min", PyArray1::from_vec(py, extremes.low))?;
    d.set_item("displacement_max", PyArray1::from_vec(py, extremes.high))?;
    Ok(d)
}
