//! Binding of `vibroimpact_core::sweep`: a list of point specs (run spec dicts with the point's
//! `ModelSpec`, as for `simulate`, each with a `sweep` dict saying what to keep) → core jobs →
//! a parallel run with the GIL released → stacked numpy arrays, one row per point.

use numpy::{PyArray1, PyArrayMethods};
use pyo3::exceptions::PyKeyboardInterrupt;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::convert::job_from_spec;
use crate::{to_py_err, ModelError};
use vibroimpact_core::sweep::{run_sweep, PointSummary, Sampling, SweepJob};
use vibroimpact_core::SimError;

fn field<'py, T: FromPyObjectOwned<'py>>(d: &Bound<'py, PyDict>, key: &str) -> PyResult<T> {
    let v = d
        .get_item(key)?
        .ok_or_else(|| ModelError::new_err(format!("sweep.{key}: missing")))?;
    v.extract::<T>().map_err(|e| {
        let e: PyErr = e.into();
        ModelError::new_err(format!("sweep.{key}: {e}"))
    })
}

fn sampling(spec: &Bound<'_, PyDict>) -> PyResult<Sampling> {
    let d: Bound<'_, PyDict> = spec
        .get_item("sweep")?
        .ok_or_else(|| ModelError::new_err("sweep: missing; expected a dict of sweep settings"))?
        .cast_into::<PyDict>()?;
    Ok(Sampling {
        period: field(&d, "period")?,
        transient: field(&d, "transient")?,
        samples: field(&d, "samples")?,
        per_period: match d.get_item("per_period")? {
            Some(v) => v
                .extract()
                .map_err(|e| ModelError::new_err(format!("sweep.per_period: {e}")))?,
            None => 1,
        },
        dofs: field(&d, "dofs")?,
        max_impacts: field(&d, "max_impacts")?,
    })
}

fn point_job(py: Python<'_>, spec: &Bound<'_, PyAny>, label: &str) -> PyResult<SweepJob> {
    let prefix = |e: PyErr| -> PyErr {
        if e.is_instance_of::<ModelError>(py) {
            ModelError::new_err(format!("sweep point {label}: {}", e.value(py)))
        } else {
            e
        }
    };
    let spec = spec.cast::<PyDict>().map_err(|e| prefix(e.into()))?;
    let sampling = sampling(spec).map_err(prefix)?;
    let job = job_from_spec(spec, Some(sampling.period)).map_err(prefix)?;
    Ok(SweepJob {
        system: job.system,
        method: job.method,
        settings: job.settings,
        x0: job.x0,
        v0: job.v0,
        sampling,
    })
}

/// Converts the point specs as `sweep` would and runs nothing: refuses a bad point before a
/// long sweep starts (`ModelError` naming the point, by its label if given, and the field).
#[pyfunction]
#[pyo3(signature = (specs, labels = None))]
pub(crate) fn sweep_check(
    py: Python<'_>,
    specs: &Bound<'_, PyList>,
    labels: Option<Vec<String>>,
) -> PyResult<()> {
    for (i, s) in specs.iter().enumerate() {
        let label = labels
            .as_ref()
            .and_then(|l| l.get(i).cloned())
            .unwrap_or_else(|| i.to_string());
        point_job(py, &s, &label)?;
    }
    Ok(())
}

/// Runs the points of a sweep in parallel (the GIL released) and returns one row per point:
/// `poincare_displacement`, `poincare_velocity` (points × samples × dofs),
/// `displacement_max/min/rms` (points × dofs), `impact_count`, `impact_velocity_max` (points ×
/// gaps), `impact_velocity`, `impact_phase` (points × gaps × max_impacts),
/// `final_displacement`, `final_velocity` (points × n_dof), `final_time`, `steps`,
/// `newton_iterations`, `rejected_steps`, `wall_time` (points) and `error` (a list of str or
/// None). `chains`: lists of point indices run one after the other, each from the final state
/// of the previous (continuation); `threads`: thread-pool size (default all cores).
#[pyfunction]
#[pyo3(signature = (specs, chains = None, threads = None))]
pub(crate) fn sweep<'py>(
    py: Python<'py>,
    specs: &Bound<'py, PyList>,
    chains: Option<Vec<Vec<usize>>>,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyDict>> {
    let jobs = specs
        .iter()
        .enumerate()
        .map(|(i, s)| point_job(py, &s, &i.to_string()))
        .collect::<PyResult<Vec<_>>>()?;
    if let Some(first) = jobs.first() {
        let shape = |j: &SweepJob| {
            (
                j.sampling.samples,
                j.sampling.dofs.len(),
                j.sampling.max_impacts,
                j.system.n_gaps,
                j.system.n_dof(),
            )
        };
        if let Some(i) = jobs.iter().position(|j| shape(j) != shape(first)) {
            return Err(ModelError::new_err(format!(
                "sweep point {i}: samples, sampled DOFs, max_impacts, gaps or DOFs differ from \
                 point 0; expected every point to keep the same shapes"
            )));
        }
    }
    let points = py
        .detach(|| run_sweep(&jobs, chains.as_deref(), threads))
        .map_err(to_py_err)?;
    // An interrupt request (Ctrl-C) stopped some points: not a result to keep or resume from.
    if points
        .iter()
        .any(|p| matches!(p.error, Some(SimError::Interrupted { .. })))
    {
        return Err(PyKeyboardInterrupt::new_err(
            "sweep interrupted: the chunk's points were not all run",
        ));
    }
    let (ns, nd, ni, ng, n) = jobs.first().map_or((0, 0, 0, 0, 0), |j| {
        (
            j.sampling.samples,
            j.sampling.dofs.len(),
            j.sampling.max_impacts,
            j.system.n_gaps,
            j.system.n_dof(),
        )
    });
    summaries_to_dict(py, &points, [ns, nd, ni, ng, n])
}

fn summaries_to_dict<'py>(
    py: Python<'py>,
    points: &[PointSummary],
    [ns, nd, ni, ng, n]: [usize; 5],
) -> PyResult<Bound<'py, PyDict>> {
    let np = points.len();
    let d = PyDict::new(py);
    let stack = |f: &dyn Fn(&PointSummary) -> &[f64]| -> Vec<f64> {
        points.iter().flat_map(|p| f(p).iter().copied()).collect()
    };
    let put = |key: &str, v: Vec<f64>, shape: &[usize]| -> PyResult<()> {
        d.set_item(key, PyArray1::from_vec(py, v).reshape(shape)?)
    };
    put(
        "poincare_displacement",
        stack(&|p| &p.poincare_displacement),
        &[np, ns, nd],
    )?;
    put(
        "poincare_velocity",
        stack(&|p| &p.poincare_velocity),
        &[np, ns, nd],
    )?;
    put(
        "displacement_max",
        stack(&|p| &p.displacement_max),
        &[np, nd],
    )?;
    put(
        "displacement_min",
        stack(&|p| &p.displacement_min),
        &[np, nd],
    )?;
    put(
        "displacement_rms",
        stack(&|p| &p.displacement_rms),
        &[np, nd],
    )?;
    put(
        "impact_velocity_max",
        stack(&|p| &p.impact_velocity_max),
        &[np, ng],
    )?;
    put(
        "impact_velocity",
        stack(&|p| &p.impact_velocity),
        &[np, ng, ni],
    )?;
    put("impact_phase", stack(&|p| &p.impact_phase), &[np, ng, ni])?;
    put(
        "final_displacement",
        stack(&|p| &p.final_displacement),
        &[np, n],
    )?;
    put("final_velocity", stack(&|p| &p.final_velocity), &[np, n])?;
    put(
        "final_time",
        points.iter().map(|p| p.final_time).collect(),
        &[np],
    )?;
    put(
        "wall_time",
        points.iter().map(|p| p.stats.wall_time_s).collect(),
        &[np],
    )?;
    let ints = |f: &dyn Fn(&PointSummary) -> Vec<i64>, shape: &[usize]| -> PyResult<_> {
        let v: Vec<i64> = points.iter().flat_map(f).collect();
        PyArray1::from_vec(py, v).reshape(shape)
    };
    d.set_item(
        "impact_count",
        ints(
            &|p| p.impact_count.iter().map(|&c| c as i64).collect(),
            &[np, ng],
        )?,
    )?;
    d.set_item("steps", ints(&|p| vec![p.stats.steps as i64], &[np])?)?;
    d.set_item(
        "newton_iterations",
        ints(&|p| vec![p.stats.newton_iterations as i64], &[np])?,
    )?;
    d.set_item(
        "rejected_steps",
        ints(&|p| vec![p.stats.rejected_steps as i64], &[np])?,
    )?;
    let errors = PyList::empty(py);
    for p in points {
        match &p.error {
            None => errors.append(py.None())?,
            Some(e) => errors.append(e.to_string())?,
        }
    }
    d.set_item("error", errors)?;
    Ok(d)
}
