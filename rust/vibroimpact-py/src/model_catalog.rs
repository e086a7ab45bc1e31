//! The core's catalog of a model's fields (`vibroimpact_core::model_catalog`) for Python: the
//! defaults the classes of `vibroimpact.model`, the model-file schema and its docs show, and
//! the checks those classes ask the core for (Python words the messages).

use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::ModelError;
use vibroimpact_core::model_catalog::{field, parts, Field, FieldDefault};

fn field_dict<'py>(py: Python<'py>, f: &Field) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("name", f.name)?;
    let default = match f.default {
        None => py.None().into_bound(py),
        Some(FieldDefault::Number(v)) => v.into_pyobject(py)?.into_any(),
        Some(FieldDefault::Numbers(v)) => v.to_vec().into_pyobject(py)?.into_any(),
        Some(FieldDefault::Choice(c)) => c.into_pyobject(py)?.into_any(),
    };
    d.set_item("default", default)?;
    d.set_item("unit", f.unit)?;
    d.set_item("expected", f.rule.expected)?;
    d.set_item("choices", f.choices.to_vec())?;
    Ok(d)
}

/// The catalog: a dict of parts (`structure`, `gap`, `radial-gap`, `load.<kind>`), each a dict
/// of its fields by name, each a dict with `name`, `default` (a `float`, a list of them, a word
/// or `None`: none), `unit`, `expected` and `choices` (the words a choice field takes).
#[pyfunction]
pub(crate) fn model_catalog(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let out = PyDict::new(py);
    for (part, fields) in parts() {
        let d = PyDict::new(py);
        for f in fields {
            d.set_item(f.name, field_dict(py, f)?)?;
        }
        out.set_item(part, d)?;
    }
    Ok(out)
}

/// Whether the core accepts `value` for field `name` of `part` (a number: finite and in range;
/// a word: one of the choices).
#[pyfunction]
pub(crate) fn model_field_accepts(
    part: &str,
    name: &str,
    value: &Bound<'_, PyAny>,
) -> PyResult<bool> {
    let f = field(part, name).ok_or_else(|| {
        ModelError::new_err(format!("model_field_accepts: no field {name} of {part}"))
    })?;
    Ok(if f.choices.is_empty() {
        value.extract::<f64>().is_ok_and(|v| f.accepts(v))
    } else {
        value
            .extract::<String>()
            .is_ok_and(|v| f.accepts_choice(&v))
    })
}
