//! Run spec dict → core job: the model as a `ModelSpec` (crate::model_spec: the structure's,
//! gaps' and loads' fields read by their keys in the core's model catalog, with its defaults
//! and checks), the initial state, the settings and the method as the typed `MethodSpec`
//! (crate::method); the dict readers the other modules share.

use std::sync::Arc;

use nalgebra::DVector;
use numpy::PyReadonlyArray1;
use pyo3::intern;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::method::PyMethodSpec;
use crate::model_spec::{law_parts, ModelSpec};
use crate::{to_py_err, ModelError};
use vibroimpact_core::contact::Law;
use vibroimpact_core::linalg::Csr;
use vibroimpact_core::simulate::{Method, RunSettings};
use vibroimpact_core::system::System;

pub(crate) struct Job {
    pub system: Arc<System>,
    pub method: Method,
    pub settings: RunSettings,
    pub x0: DVector<f64>,
    pub v0: DVector<f64>,
}

/// A key of a spec dict: a `&str`, or a string interned once (`intern!`) for the keys read in
/// every run (a `&str` is made into a new Python string at each lookup).
pub(crate) trait Key<'py>: IntoPyObject<'py> + Copy + std::fmt::Display {}
impl<'py, K: IntoPyObject<'py> + Copy + std::fmt::Display> Key<'py> for K {}

pub(crate) fn item<'py, T: FromPyObjectOwned<'py>>(
    d: &Bound<'py, PyDict>,
    key: impl Key<'py>,
    ctx: &str,
) -> PyResult<T> {
    let v = d
        .get_item(key)?
        .ok_or_else(|| ModelError::new_err(format!("{ctx}.{key}: missing")))?;
    v.extract::<T>().map_err(|e| {
        let e: PyErr = e.into();
        ModelError::new_err(format!("{ctx}.{key}: {e}"))
    })
}

pub(crate) fn opt<'py, T: FromPyObjectOwned<'py>>(
    d: &Bound<'py, PyDict>,
    key: impl Key<'py>,
    ctx: &str,
) -> PyResult<Option<T>> {
    match d.get_item(key)? {
        None => Ok(None),
        Some(v) if v.is_none() => Ok(None),
        Some(v) => v.extract::<T>().map(Some).map_err(|e| {
            let e: PyErr = e.into();
            ModelError::new_err(format!("{ctx}.{key}: {e}"))
        }),
    }
}

/// A SciPy sparse matrix (CSR, or anything with `indptr`, `indices`, `data`, `shape` of a
/// CSR array) read without densifying; errors name `field`.
pub(crate) fn csr(obj: &Bound<'_, PyAny>, field: &str) -> PyResult<Csr> {
    let bad = |what: String| ModelError::new_err(format!("{field}: {what}"));
    let (rows, cols): (usize, usize) = obj.getattr("shape")?.extract()?;
    if rows != cols {
        return Err(bad(format!(
            "shape {rows}x{cols} is not square; expected an n x n matrix"
        )));
    }
    let index = |name: &str| -> PyResult<Vec<usize>> {
        let a = obj.getattr(name)?.call_method1("astype", ("int64",))?;
        let a: PyReadonlyArray1<i64> = a.extract().map_err(|e| bad(format!("{name}: {e}")))?;
        a.as_array()
            .iter()
            .map(|&v| usize::try_from(v).map_err(|_| bad(format!("{name} has {v}; expected >= 0"))))
            .collect()
    };
    let (row_start, indices) = (index("indptr")?, index("indices")?);
    let data = obj.getattr("data")?.call_method1("astype", ("float64",))?;
    let data: PyReadonlyArray1<f64> = data.extract().map_err(|e| bad(format!("data: {e}")))?;
    let data = data.as_array().to_vec();
    Csr::from_parts(rows, row_start, indices, data).map_err(bad)
}

/// A law from its spec dict: its kind and the parameters of its catalog entry (the core's
/// defaults for those left out or `None`).
pub(crate) fn law(d: &Bound<'_, PyDict>, ctx: &str) -> PyResult<Law> {
    let (name, values) = law_parts(d, ctx)?;
    Law::from_parameters(name, &values).map_err(to_py_err)
}

/// The run of a spec: `model` (a `ModelSpec`; or the model's fields, read into one), the
/// initial state (`x0`, `v0`: the model's when left out), settings and `method` (a
/// `MethodSpec`); a sweep's point gives the period it samples at (adaptive
/// stepping's default largest step follows from it).
pub(crate) fn job_from_spec(spec: &Bound<'_, PyDict>, sweep_period: Option<f64>) -> PyResult<Job> {
    let py = spec.py();
    let model = match spec.get_item(intern!(py, "model"))? {
        Some(model) => model.cast_into::<ModelSpec>().map_err(|_| {
            ModelError::new_err("model: expected a ModelSpec (_core.ModelSpec of a model spec)")
        })?,
        None => Bound::new(py, ModelSpec::from_dict(spec)?)?,
    };
    let model = model.get();
    let system = model.system()?;
    let (x0, v0) = model.initial_state();
    let x0 = opt_vector(spec, intern!(py, "x0"))?.unwrap_or(x0);
    let v0 = opt_vector(spec, intern!(py, "v0"))?.unwrap_or(v0);
    let method = spec
        .get_item(intern!(py, "method"))?
        .ok_or_else(|| ModelError::new_err("solver.method: missing"))?;
    let method = method
        .cast::<PyMethodSpec>()
        .map_err(|_| {
            ModelError::new_err(
                "solver.method: expected a MethodSpec (_core.method_spec of an integrator)",
            )
        })?
        .get()
        .0;
    let t_end: f64 = item(spec, intern!(py, "t_end"), "solver")?;
    let dt: f64 = item(spec, intern!(py, "dt"), "solver")?;
    let (adaptive, dt) = match method.adaptive {
        None => (None, dt),
        Some(request) => {
            let (adaptive, dt) = request
                .resolve(t_end, dt, sweep_period)
                .map_err(to_py_err)?;
            (Some(adaptive), dt)
        }
    };
    let n = system.n_dof();
    Ok(Job {
        method: method.method,
        settings: RunSettings {
            t_end,
            dt,
            every: item(spec, intern!(py, "every"), "output")?,
            record_dofs: opt(spec, intern!(py, "record_dofs"), "output")?
                .unwrap_or_else(|| (0..n).collect()),
            newton: method.newton,
            adaptive,
        },
        x0,
        v0,
        system,
    })
}

/// An initial state of the spec (`x0`, `v0`), if given.
fn opt_vector<'py>(d: &Bound<'py, PyDict>, key: impl Key<'py>) -> PyResult<Option<DVector<f64>>> {
    let a: Option<PyReadonlyArray1<f64>> = opt(d, key, "initial")?;
    a.map(|a| {
        Ok(DVector::from_iterator(
            a.len()?,
            a.as_array().iter().copied(),
        ))
    })
    .transpose()
}
