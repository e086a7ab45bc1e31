//! The flow map of a model with its state-transition matrix (`_core.flow_map`): what
//! `vibroimpact.orbits` shoots with.

use pyo3::prelude::*;
use pyo3::types::PyDict;

use vibroimpact_core::simulate::simulate_with_sensitivity;

use crate::{convert, output_to_dict, to_numpy, to_py_err};

/// Runs one model spec (as `_core.start` takes it) carrying the state-transition matrix:
/// the output dict of `Running.finish` plus `state_transition`, `∂(x, v)(t_end)/∂(x₀, v₀)`
/// (`2n × 2n`; None if the run stopped early).
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
    } = convert::job_from_spec(spec)?;
    let n_gaps = system.gaps.len();
    let mut out = py
        .detach(|| simulate_with_sensitivity(&system, method, &settings, x0, v0))
        .map_err(to_py_err)?;
    let transition = out.state_transition.take().filter(|_| out.error.is_none());
    let rows = std::mem::take(&mut out.rows);
    let balance = rows.energy.relative_balance_error();
    let d = output_to_dict(py, out, rows, n_gaps, balance)?;
    let matrix = transition.map(|t| to_numpy(py, &t.matrix)).transpose()?;
    d.set_item("state_transition", matrix)?;
    Ok(d)
}
