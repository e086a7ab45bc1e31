//! Spec dict → core types: the model's arrays and lists, and the run's method as the typed
//! `MethodSpec` (crate::method). The fields of the structure's spin, the gaps and the loads are
//! read by their keys in the core's model catalog (`vibroimpact_core::model_catalog`), with its
//! defaults for those left out and its checks; a law's parameters by its law catalog. The
//! Python classes ask the core for the same checks, so a spec of a `vibroimpact.Model` passes.

use std::sync::Arc;

use nalgebra::{DMatrix, DVector};
use numpy::{PyArray2, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::intern;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::method::PyMethodSpec;
use crate::{to_py_err, ModelError};
use vibroimpact_core::contact::{law_entry, Law, ParameterValue, ParameterValues, ValueKind, LAWS};
use vibroimpact_core::gap::{FrictionLaw, Gap, Radial, Side};
use vibroimpact_core::linalg::Csr;
use vibroimpact_core::model_catalog::{
    Field, AMPLITUDE, CENTER, CLEARANCE, FREQUENCY, FRICTION, FRICTION_LAW, LOADS, MAGNITUDE,
    PHASE, RADIUS, REGULARISATION_SPEED, RUN_UP_TIME, SCALE, SIDE, SPIN_PROFILE, SPIN_SPEED,
    SPIN_SPEED_END,
};
use vibroimpact_core::simulate::{Method, RunSettings};
use vibroimpact_core::structure::{LinearStructure, Load, LoadHistory, SpinProfile};
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
trait Key<'py>: IntoPyObject<'py> + Copy + std::fmt::Display {}
impl<'py, K: IntoPyObject<'py> + Copy + std::fmt::Display> Key<'py> for K {}

fn item<'py, T: FromPyObjectOwned<'py>>(
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

fn opt<'py, T: FromPyObjectOwned<'py>>(
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

/// The number of catalog field `f` in `d`: its default when left out or `None` (the
/// refusal of a missing field without one), checked.
fn number_field(d: &Bound<'_, PyDict>, f: &Field, ctx: &str) -> PyResult<f64> {
    let value = match opt(d, f.name, ctx)? {
        Some(v) => v,
        None => f
            .default_number()
            .ok_or_else(|| ModelError::new_err(format!("{ctx}.{}: missing", f.name)))?,
    };
    f.check(ctx, value).map_err(to_py_err)
}

/// The word of catalog choice field `f` in `d` (its default when left out or `None`), checked.
fn choice_field(d: &Bound<'_, PyDict>, f: &Field, ctx: &str) -> PyResult<String> {
    choice(opt(d, f.name, ctx)?, f, ctx)
}

/// `value` of catalog choice field `f` (its default if `None`), checked.
fn choice(value: Option<String>, f: &Field, ctx: &str) -> PyResult<String> {
    let value = value.unwrap_or_else(|| {
        f.default_choice()
            .expect("a choice field has a default")
            .to_string()
    });
    if !f.accepts_choice(&value) {
        return Err(ModelError::new_err(format!(
            "{ctx}.{}: '{value}' is not valid; expected {}",
            f.name, f.expected
        )));
    }
    Ok(value)
}

/// A structure matrix of the spec: a dense 2-D array, or a SciPy CSR matrix (read through
/// its `indptr`, `indices`, `data` and `shape` without densifying).
enum Matrix {
    Dense(DMatrix<f64>),
    Sparse(Csr),
}

impl Matrix {
    fn into_csr(self) -> Csr {
        match self {
            Matrix::Dense(a) => Csr::from_dense(&a),
            Matrix::Sparse(a) => a,
        }
    }
}

fn matrix(d: &Bound<'_, PyDict>, key: &str) -> PyResult<Matrix> {
    let obj = d
        .get_item(key)?
        .ok_or_else(|| ModelError::new_err(format!("structure.{key}: missing")))?;
    // an array first: `hasattr` on one would raise and discard an AttributeError (~1 µs)
    if obj.cast::<PyArray2<f64>>().is_ok() || !obj.hasattr("indptr")? {
        let a: PyReadonlyArray2<f64> = item(d, key, "structure")?;
        let a = a.as_array();
        let (r, c) = a.dim();
        return Ok(Matrix::Dense(DMatrix::from_fn(r, c, |i, j| a[[i, j]])));
    }
    csr(&obj, &format!("structure.{key}")).map(Matrix::Sparse)
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

fn vector<'py>(d: &Bound<'py, PyDict>, key: impl Key<'py>) -> PyResult<DVector<f64>> {
    let a: PyReadonlyArray1<f64> = item(d, key, "initial")?;
    Ok(DVector::from_iterator(
        a.len()?,
        a.as_array().iter().copied(),
    ))
}

/// A law from its spec dict: its kind and the parameters of its catalog entry (the core's
/// defaults for those left out or `None`).
pub(crate) fn law(d: &Bound<'_, PyDict>, ctx: &str) -> PyResult<Law> {
    let kind: String = item(d, "kind", ctx)?;
    let entry = law_entry(&kind).ok_or_else(|| {
        let names: Vec<_> = LAWS.iter().map(|e| e.name).collect();
        ModelError::new_err(format!(
            "{ctx}.kind: '{kind}' is not a known contact law; expected one of {}",
            names.join(", ")
        ))
    })?;
    let mut values = ParameterValues::default();
    for p in entry.parameters {
        let value = match p.kind {
            ValueKind::Number => opt(d, p.name, ctx)?.map(ParameterValue::Number),
            ValueKind::Numbers => opt(d, p.name, ctx)?.map(ParameterValue::Numbers),
        };
        if let Some(v) = value {
            values.set(p.name, v);
        }
    }
    Law::from_parameters(entry.name, &values).map_err(to_py_err)
}

fn gap(d: &Bound<'_, PyDict>, i: usize) -> PyResult<Gap> {
    let ctx = format!("gaps[{i}]");
    // a radial gap's `side` is "radial"; a linear gap's is one of the catalog's (or its default)
    let side: Option<String> = opt(d, SIDE.name, &ctx)?;
    let side = if side.as_deref() == Some("radial") {
        let center: Vec<f64> = match opt(d, CENTER.name, &ctx)? {
            Some(c) => c,
            None => CENTER.default_numbers().expect("a default").to_vec(),
        };
        let center: [f64; 2] = center.try_into().map_err(|c: Vec<f64>| {
            ModelError::new_err(format!(
                "{ctx}.center: {c:?} is not valid; expected {}",
                CENTER.expected
            ))
        })?;
        let friction_law = match choice_field(d, &FRICTION_LAW, &ctx)?.as_str() {
            "regularised" => FrictionLaw::Regularised {
                speed: number_field(d, &REGULARISATION_SPEED, &ctx)?,
            },
            _ => FrictionLaw::Coulomb,
        };
        Side::Radial(Radial {
            center,
            friction: number_field(d, &FRICTION, &ctx)?,
            // 0: none given (read only with friction, where `Gap::validate` requires one)
            radius: opt(d, RADIUS.name, &ctx)?.unwrap_or(0.0),
            friction_law,
            partner: 0,
        })
    } else {
        match choice(side, &SIDE, &ctx)?.as_str() {
            "negative" => Side::Negative,
            "both" => Side::Both,
            _ => Side::Positive,
        }
    };
    let law_dict: Bound<'_, PyDict> = item(d, "law", &ctx)?;
    Ok(Gap {
        dofs: item(d, "dofs", &ctx)?,
        coefficients: item(d, "coefficients", &ctx)?,
        clearance: number_field(d, &CLEARANCE, &ctx)?,
        side,
        law: law(&law_dict, &format!("{ctx}.law"))?,
    })
}

/// The core's loads of a spec's load `i`: one, or an unbalance's two (x and y) at the
/// structure's spin profile. A table's `amplitude` is its scale.
fn load(d: &Bound<'_, PyDict>, i: usize, spin: SpinProfile) -> PyResult<Vec<Load>> {
    let ctx = format!("loads[{i}]");
    let kind: String = item(d, "kind", &ctx)?;
    let (amplitude, history) = match kind.as_str() {
        "constant" => (number_field(d, &AMPLITUDE, &ctx)?, LoadHistory::Constant),
        "harmonic" => (
            number_field(d, &AMPLITUDE, &ctx)?,
            LoadHistory::Harmonic {
                frequency: number_field(d, &FREQUENCY, &ctx)?,
                phase: number_field(d, &PHASE, &ctx)?,
            },
        ),
        "table" => (
            opt(d, AMPLITUDE.name, &ctx)?.unwrap_or(SCALE.default_number().expect("a default")),
            LoadHistory::Table {
                time: item(d, "time", &ctx)?,
                value: item(d, "value", &ctx)?,
            },
        ),
        "unbalance" => {
            let dofs: [usize; 2] = item(d, "dofs", &ctx)?;
            let magnitude = number_field(d, &MAGNITUDE, &ctx)?;
            let phase = number_field(d, &PHASE, &ctx)?;
            return Ok(Load::unbalance(dofs, magnitude, phase, spin).into());
        }
        other => {
            let kinds: Vec<_> = LOADS.iter().map(|(k, _)| *k).collect();
            return Err(ModelError::new_err(format!(
                "{ctx}.kind: '{other}' is not valid; expected one of {}",
                kinds.join(", ")
            )));
        }
    };
    Ok(vec![Load {
        dofs: item(d, "dofs", &ctx)?,
        amplitude,
        history,
    }])
}

/// A model's structure, gaps and loads as the core's `System`, built once by
/// `compile_system` and given to `start` in place of them (`spec["system"]`): what
/// `vibroimpact.Model` keeps for its runs when nothing in it can change.
#[pyclass(module = "vibroimpact._core", frozen)]
pub(crate) struct CompiledSystem(Arc<System>);

/// The structure, gaps and loads of a model spec compiled for `start`.
#[pyfunction]
pub(crate) fn compile_system(spec: &Bound<'_, PyDict>) -> PyResult<CompiledSystem> {
    system(spec).map(|s| CompiledSystem(Arc::new(s)))
}

fn system(spec: &Bound<'_, PyDict>) -> PyResult<System> {
    let structure = match (
        matrix(spec, "mass")?,
        matrix(spec, "damping")?,
        matrix(spec, "stiffness")?,
    ) {
        // small dense models keep their dense matrices for the dense methods
        (Matrix::Dense(m), Matrix::Dense(c), Matrix::Dense(k)) => LinearStructure::new(m, c, k),
        (m, c, k) => LinearStructure::from_sparse(m.into_csr(), c.into_csr(), k.into_csr()),
    }
    .map_err(to_py_err)?;
    // a rotor: the gyroscopic matrix G (optional) and the spin speed Ω (default 0)
    let gyroscopic = match spec.get_item("gyroscopic")? {
        Some(g) if !g.is_none() => Some(matrix(spec, "gyroscopic")?.into_csr()),
        _ => None,
    };
    let spin_speed = number_field(spec, &SPIN_SPEED, "structure")?;
    let mut structure = structure
        .spinning(gyroscopic, spin_speed)
        .map_err(to_py_err)?;
    // a run-up (`spin_profile = "linear"`)
    if choice_field(spec, &SPIN_PROFILE, "structure")? == "linear" {
        structure = structure
            .run_up(
                number_field(spec, &SPIN_SPEED_END, "structure")?,
                number_field(spec, &RUN_UP_TIME, "structure")?,
            )
            .map_err(to_py_err)?;
    }
    let spin = structure.spin;
    let gaps_list: Bound<'_, PyList> = item(spec, "gaps", "model")?;
    let gaps = gaps_list
        .iter()
        .enumerate()
        .map(|(i, g)| gap(g.cast::<PyDict>()?, i))
        .collect::<PyResult<Vec<_>>>()?;
    let loads_list: Bound<'_, PyList> = item(spec, "loads", "model")?;
    let loads = loads_list
        .iter()
        .enumerate()
        .map(|(i, l)| load(l.cast::<PyDict>()?, i, spin))
        .collect::<PyResult<Vec<_>>>()?
        .concat();
    System::new(structure, gaps, loads).map_err(to_py_err)
}

/// The run of a spec: the model's fields (or `system`, compiled), initial state, settings and
/// `method` (a `MethodSpec`); a sweep's point gives the period it samples at (adaptive
/// stepping's default largest step follows from it).
pub(crate) fn job_from_spec(spec: &Bound<'_, PyDict>, sweep_period: Option<f64>) -> PyResult<Job> {
    let py = spec.py();
    let system = match spec.get_item(intern!(py, "system"))? {
        Some(compiled) => compiled.cast::<CompiledSystem>()?.get().0.clone(),
        None => Arc::new(system(spec)?),
    };
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
        x0: vector(spec, intern!(py, "x0"))?,
        v0: vector(spec, intern!(py, "v0"))?,
        system,
    })
}
