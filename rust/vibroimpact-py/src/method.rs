//! A run's method as a typed object: `method_spec` reads a Python integrator against the core's
//! method catalog once (its parameters, `newton` and `adaptive`, each checked there) into a
//! `MethodSpec`, which each run's spec carries as `spec["method"]`. `method_catalog` gives
//! Python the catalog (names, parameters, defaults, units, checks); `check_settings` checks a
//! `NewtonOptions` or an `Adaptive` on its own. Messages word the user's value by its `repr`.

use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt};

use crate::{to_py_err, ModelError};
use vibroimpact_core::integrators::NewtonSettings;
use vibroimpact_core::method_catalog::{
    method_entry, AdaptiveRequest, MethodSpec, Setting, SettingKind, Stepping, ADAPTIVE, METHODS,
    NEWTON,
};

/// A run's method, checked: built by `method_spec`, read by every run of its integrator.
#[pyclass(module = "vibroimpact._core", name = "MethodSpec", frozen)]
pub(crate) struct PyMethodSpec(pub MethodSpec);

#[pymethods]
impl PyMethodSpec {
    /// The method's name in the catalog.
    #[getter]
    fn kind(&self) -> &'static str {
        self.0.entry.name
    }

    /// `alpha_m`, `alpha_f`, `gamma`, `beta` of a Newmark-family method as the core steps it
    /// (`None` for the others).
    fn newmark_parameters<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some(s) = self.0.method.newmark_family() else {
            return Ok(None);
        };
        let d = PyDict::new(py);
        d.set_item("alpha_m", s.alpha_m)?;
        d.set_item("alpha_f", s.alpha_f)?;
        d.set_item("gamma", s.gamma)?;
        d.set_item("beta", s.beta)?;
        Ok(Some(d))
    }

    fn __repr__(&self) -> String {
        let MethodSpec {
            entry,
            method,
            newton,
            adaptive,
        } = &self.0;
        format!(
            "MethodSpec(kind={:?}, method={method:?}, newton={newton:?}, adaptive={adaptive:?})",
            entry.name
        )
    }

    /// Equal when the core would run the same method with the same settings.
    fn __eq__(&self, other: &Self) -> bool {
        self.0 == other.0
    }
}

/// The value of `setting` in `obj`, checked against the catalog: a `bool` for a flag, an `int`
/// for an integer, an `int` or a `float` for a number (never a `bool`).
fn setting_value(obj: &Bound<'_, PyAny>, setting: &Setting) -> PyResult<f64> {
    let is_bool = obj.is_instance_of::<PyBool>();
    let typed = match setting.kind {
        SettingKind::Flag => is_bool,
        SettingKind::Integer => obj.is_instance_of::<PyInt>() && !is_bool,
        SettingKind::Number => {
            (obj.is_instance_of::<PyInt>() || obj.is_instance_of::<PyFloat>()) && !is_bool
        }
    };
    match typed.then(|| obj.extract::<f64>().ok()).flatten() {
        Some(v) if setting.accepts(v) => Ok(v),
        _ => Err(ModelError::new_err(format!(
            "solver.{}: {} is not valid; expected {}",
            setting.name,
            obj.repr()?,
            setting.rule.expected
        ))),
    }
}

fn attribute_value(obj: &Bound<'_, PyAny>, setting: &Setting) -> PyResult<f64> {
    setting_value(&obj.getattr(setting.name)?, setting)
}

/// Newton's settings of a `NewtonOptions`.
fn newton_settings(obj: &Bound<'_, PyAny>) -> PyResult<NewtonSettings> {
    let mut values = [0.0; 4];
    for (v, s) in values.iter_mut().zip(&NEWTON) {
        *v = attribute_value(obj, s)?;
    }
    NewtonSettings::from_values(values).map_err(to_py_err)
}

/// Adaptive stepping of an `Adaptive`.
fn adaptive_request(obj: &Bound<'_, PyAny>) -> PyResult<AdaptiveRequest> {
    let [rtol, atol, dt_min, dt_max] = &ADAPTIVE;
    let limit = |s: &Setting| -> PyResult<Option<f64>> {
        let v = obj.getattr(s.name)?;
        if v.is_none() {
            Ok(None)
        } else {
            setting_value(&v, s).map(Some)
        }
    };
    AdaptiveRequest::new(
        attribute_value(obj, rtol)?,
        attribute_value(obj, atol)?,
        limit(dt_min)?,
        limit(dt_max)?,
    )
    .map_err(to_py_err)
}

/// The method spec of a `vibroimpact.integrators.Integrator`: its `name`, its parameters (the
/// catalog's, read as its attributes), `newton` and `adaptive` (`None`: fixed steps).
#[pyfunction]
pub(crate) fn method_spec(integrator: &Bound<'_, PyAny>) -> PyResult<PyMethodSpec> {
    let name: String = integrator.getattr("name")?.extract()?;
    let entry = method_entry(&name).ok_or_else(|| {
        let names: Vec<_> = METHODS.iter().map(|m| m.name).collect();
        ModelError::new_err(format!(
            "solver.method: '{name}' is not valid; expected one of {}",
            names.join(", ")
        ))
    })?;
    let values = entry
        .parameters
        .iter()
        .map(|p| attribute_value(integrator, p))
        .collect::<PyResult<Vec<_>>>()?;
    let newton = newton_settings(&integrator.getattr("newton")?)?;
    let adaptive = integrator.getattr("adaptive")?;
    let adaptive = if adaptive.is_none() {
        None
    } else {
        Some(adaptive_request(&adaptive)?)
    };
    entry
        .spec(&values, newton, adaptive)
        .map(PyMethodSpec)
        .map_err(to_py_err)
}

/// Checks a `NewtonOptions` (`group = "newton"`) or an `Adaptive` (`"adaptive"`) against the
/// catalog: a one-line `ModelError` naming the first bad field.
#[pyfunction]
pub(crate) fn check_settings(group: &str, settings: &Bound<'_, PyAny>) -> PyResult<()> {
    match group {
        "newton" => newton_settings(settings).map(|_| ()),
        "adaptive" => adaptive_request(settings).map(|_| ()),
        other => Err(ModelError::new_err(format!(
            "check_settings: group '{other}' is not valid; expected newton or adaptive"
        ))),
    }
}

/// A setting as a dict: `name`, `kind` (`number`, `integer`, `flag`), `default` (typed: a
/// `float`, an `int` or a `bool`; `None` when computed), `computed`, `unit`, `doc`, `expected`.
fn setting_dict<'py>(py: Python<'py>, s: &Setting) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("name", s.name)?;
    let kind = match s.kind {
        SettingKind::Number => "number",
        SettingKind::Integer => "integer",
        SettingKind::Flag => "flag",
    };
    let default = match (s.kind, s.default) {
        (_, None) => py.None().into_bound(py),
        (SettingKind::Number, Some(v)) => v.into_pyobject(py)?.into_any(),
        (SettingKind::Integer, Some(v)) => (v as i64).into_pyobject(py)?.into_any(),
        (SettingKind::Flag, Some(v)) => PyBool::new(py, v == 1.0).to_owned().into_any(),
    };
    d.set_item("kind", kind)?;
    d.set_item("default", default)?;
    d.set_item("computed", s.computed)?;
    d.set_item("unit", s.unit)?;
    d.set_item("doc", s.doc)?;
    d.set_item("expected", s.rule.expected)?;
    Ok(d)
}

/// The core's catalog of methods: a dict with `methods` (in their order, each a dict with
/// `name`, `class_name`, `newton`, `impulsive`, `adaptive` — `fixed`, `on-request` or
/// `by-default` —, `adaptive_defaults` (`rtol`, `atol`; `None` unless by default) and
/// `parameters`), and the settings of `newton` and `adaptive`.
#[pyfunction]
pub(crate) fn method_catalog(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let settings = |list: &[Setting]| -> PyResult<Vec<Bound<'_, PyDict>>> {
        list.iter().map(|s| setting_dict(py, s)).collect()
    };
    let methods = METHODS
        .iter()
        .map(|m| {
            let d = PyDict::new(py);
            d.set_item("name", m.name)?;
            d.set_item("class_name", m.class_name)?;
            d.set_item("newton", m.newton)?;
            d.set_item("impulsive", m.impulsive)?;
            let (stepping, defaults) = match m.stepping {
                Stepping::Fixed => ("fixed", None),
                Stepping::AdaptiveOnRequest => ("on-request", None),
                Stepping::AdaptiveByDefault { rtol, atol } => {
                    let t = PyDict::new(py);
                    t.set_item("rtol", rtol)?;
                    t.set_item("atol", atol)?;
                    ("by-default", Some(t))
                }
            };
            d.set_item("adaptive", stepping)?;
            d.set_item("adaptive_defaults", defaults)?;
            d.set_item("parameters", settings(m.parameters)?)?;
            Ok(d)
        })
        .collect::<PyResult<Vec<_>>>()?;
    let d = PyDict::new(py);
    d.set_item("methods", methods)?;
    d.set_item("newton", settings(&NEWTON)?)?;
    d.set_item("adaptive", settings(&ADAPTIVE)?)?;
    Ok(d)
}
