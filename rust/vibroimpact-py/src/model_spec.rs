//! The model as a typed object: `ModelSpec` holds a model spec's structure (dense or CSR
//! matrices, a rotor's spin), gaps (each law's catalog entry and the parameters given), loads
//! and initial state as read once from its dict, and compiles the core's `System` from them
//! at its first run. `with_value` sets one number by the parameter paths of `sweep --param`
//! and `continue --param` (their one implementation; the sweeps, the periodic orbits and
//! `vibroimpact.sweeps.apply` go through it); `to_dict` gives back the spec dict.

use std::sync::{Arc, OnceLock};

use nalgebra::{DMatrix, DVector};
use numpy::{PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2, ToPyArray};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};

use crate::convert::{csr, item, opt};
use crate::{to_py_err, ModelError};
use vibroimpact_core::contact::{law_entry, Law, ParameterValue, ParameterValues, ValueKind, LAWS};
use vibroimpact_core::gap::{FrictionLaw, Gap, Radial, Side};
use vibroimpact_core::linalg::Csr;
use vibroimpact_core::model_catalog::{
    Field, AMPLITUDE, CENTER, CLEARANCE, FREQUENCY, FRICTION, FRICTION_LAW, LOADS, MAGNITUDE,
    PHASE, RADIUS, REGULARISATION_SPEED, RUN_UP_TIME, SCALE, SIDE, SPIN_PROFILE, SPIN_SPEED,
    SPIN_SPEED_END,
};
use vibroimpact_core::structure::{LinearStructure, Load, LoadHistory};
use vibroimpact_core::system::System;

/// A structure matrix: a dense 2-D array, or a SciPy CSR matrix (read through its `indptr`,
/// `indices`, `data` and `shape` without densifying).
#[derive(Clone)]
enum Matrix {
    Dense(DMatrix<f64>),
    Sparse(Csr),
}

impl Matrix {
    fn read(d: &Bound<'_, PyDict>, key: &str) -> PyResult<Self> {
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

    fn to_csr(&self) -> Csr {
        match self {
            Matrix::Dense(a) => Csr::from_dense(a),
            Matrix::Sparse(a) => a.clone(),
        }
    }

    fn n(&self) -> usize {
        match self {
            Matrix::Dense(a) => a.nrows(),
            Matrix::Sparse(a) => a.n(),
        }
    }

    /// Entries `(i, j)` and `(j, i)` set to `value` (a sparse one: a zero is not stored).
    fn set_symmetric(&mut self, i: usize, j: usize, value: f64) {
        match self {
            Matrix::Dense(a) => {
                a[(i, j)] = value;
                a[(j, i)] = value;
            }
            Matrix::Sparse(a) => {
                *a = csr_set(&csr_set(a, i, j, value), j, i, value);
            }
        }
    }

    /// A numpy array, or a SciPy `csr_array`.
    fn to_py<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        match self {
            Matrix::Dense(a) => Ok(PyArray2::from_vec2(
                py,
                &a.row_iter()
                    .map(|r| r.iter().copied().collect())
                    .collect::<Vec<Vec<f64>>>(),
            )?
            .into_any()),
            Matrix::Sparse(a) => {
                let (row_start, cols, vals) = a.parts();
                let index = |v: &[usize]| {
                    PyArray1::from_vec(py, v.iter().map(|&k| k as i64).collect::<Vec<_>>())
                };
                let parts = (vals.to_pyarray(py), index(cols), index(row_start));
                py.import("scipy.sparse")?
                    .getattr("csr_array")?
                    .call1((parts, (a.n(), a.n())))
            }
        }
    }
}

/// `a` with entry `(i, j)` set to `value`: replaced, inserted in its row's order, or removed
/// when `value` is 0 (as SciPy's LIL assignment does).
fn csr_set(a: &Csr, i: usize, j: usize, value: f64) -> Csr {
    let (row_start, cols, vals) = a.parts();
    let (mut row_start, mut cols, mut vals) = (row_start.to_vec(), cols.to_vec(), vals.to_vec());
    let row = row_start[i]..row_start[i + 1];
    match cols[row.clone()].binary_search(&j) {
        Ok(k) if value == 0.0 => {
            cols.remove(row.start + k);
            vals.remove(row.start + k);
            row_start[i + 1..].iter_mut().for_each(|r| *r -= 1);
        }
        Ok(k) => vals[row.start + k] = value,
        Err(_) if value == 0.0 => {}
        Err(k) => {
            cols.insert(row.start + k, j);
            vals.insert(row.start + k, value);
            row_start[i + 1..].iter_mut().for_each(|r| *r += 1);
        }
    }
    Csr::from_parts(a.n(), row_start, cols, vals).expect("an entry set in a valid CSR matrix")
}

/// A gap as given: a linear gap's side, or a radial gap's stator.
#[derive(Clone)]
enum GapSide {
    Linear(Option<String>),
    Radial {
        center: Option<Vec<f64>>,
        friction: Option<f64>,
        radius: Option<f64>,
        friction_law: Option<String>,
        regularisation_speed: Option<f64>,
    },
}

#[derive(Clone)]
struct GapSpec {
    name: Option<String>,
    dofs: Vec<usize>,
    coefficients: Vec<f64>,
    clearance: Option<f64>,
    side: GapSide,
    /// The law's catalog name and the parameters given (in the order of the spec).
    law: &'static str,
    law_values: ParameterValues,
}

#[derive(Clone)]
struct LoadSpec {
    kind: String,
    dofs: Vec<usize>,
    amplitude: Option<f64>,
    frequency: Option<f64>,
    phase: Option<f64>,
    magnitude: Option<f64>,
    time: Option<Vec<f64>>,
    value: Option<Vec<f64>>,
}

/// The parts of a model spec, as given (the defaults and checks apply when compiled).
#[derive(Clone)]
struct Parts {
    mass: Arc<Matrix>,
    damping: Arc<Matrix>,
    stiffness: Arc<Matrix>,
    gyroscopic: Option<Arc<Matrix>>,
    spin_speed: Option<f64>,
    spin_profile: Option<String>,
    spin_speed_end: Option<f64>,
    run_up_time: Option<f64>,
    gaps: Vec<GapSpec>,
    loads: Vec<LoadSpec>,
    x0: DVector<f64>,
    v0: DVector<f64>,
}

/// The number of catalog field `f` (its default when not given), checked.
fn number(value: Option<f64>, f: &Field, ctx: &str) -> PyResult<f64> {
    let value = match value {
        Some(v) => v,
        None => f
            .default_number()
            .ok_or_else(|| ModelError::new_err(format!("{ctx}.{}: missing", f.name)))?,
    };
    f.check(ctx, value).map_err(to_py_err)
}

/// The word of catalog choice field `f` (its default when not given), checked.
fn choice(value: Option<&str>, f: &Field, ctx: &str) -> PyResult<String> {
    let value = value
        .unwrap_or_else(|| f.default_choice().expect("a choice field has a default"))
        .to_string();
    if !f.accepts_choice(&value) {
        return Err(ModelError::new_err(format!(
            "{ctx}.{}: '{value}' is not valid; expected {}",
            f.name, f.rule.expected
        )));
    }
    Ok(value)
}

fn vector(d: &Bound<'_, PyDict>, key: &str) -> PyResult<DVector<f64>> {
    let a: PyReadonlyArray1<f64> = item(d, key, "initial")?;
    Ok(DVector::from_iterator(
        a.len()?,
        a.as_array().iter().copied(),
    ))
}

/// A law's catalog name and the parameters given in its spec dict (`None`: left out).
pub(crate) fn law_parts(
    d: &Bound<'_, PyDict>,
    ctx: &str,
) -> PyResult<(&'static str, ParameterValues)> {
    let kind: String = item(d, "kind", ctx)?;
    let entry = law_entry(&kind).ok_or_else(|| {
        let names: Vec<_> = LAWS.iter().map(|e| e.name).collect();
        ModelError::new_err(format!(
            "{ctx}.kind: '{kind}' is not a known contact law; expected one of {}",
            names.join(", ")
        ))
    })?;
    let mut values = ParameterValues::default();
    for (key, _) in d.iter() {
        let Ok(key) = key.extract::<String>() else {
            continue;
        };
        let Some(p) = entry.parameters.iter().find(|p| p.name == key) else {
            continue;
        };
        let value = match p.kind {
            ValueKind::Number => opt(d, p.name, ctx)?.map(ParameterValue::Number),
            ValueKind::Numbers => opt(d, p.name, ctx)?.map(ParameterValue::Numbers),
        };
        if let Some(v) = value {
            values.set(p.name, v);
        }
    }
    Ok((entry.name, values))
}

impl GapSpec {
    fn read(d: &Bound<'_, PyDict>, i: usize) -> PyResult<Self> {
        let ctx = format!("gaps[{i}]");
        let side: Option<String> = opt(d, SIDE.name, &ctx)?;
        let side = if side.as_deref() == Some("radial") {
            GapSide::Radial {
                center: opt(d, CENTER.name, &ctx)?,
                friction: opt(d, FRICTION.name, &ctx)?,
                radius: opt(d, RADIUS.name, &ctx)?,
                friction_law: opt(d, FRICTION_LAW.name, &ctx)?,
                regularisation_speed: opt(d, REGULARISATION_SPEED.name, &ctx)?,
            }
        } else {
            GapSide::Linear(side)
        };
        let law_dict: Bound<'_, PyDict> = item(d, "law", &ctx)?;
        let (law, law_values) = law_parts(&law_dict, &format!("{ctx}.law"))?;
        Ok(GapSpec {
            name: opt(d, "name", &ctx)?,
            dofs: item(d, "dofs", &ctx)?,
            coefficients: item(d, "coefficients", &ctx)?,
            clearance: opt(d, CLEARANCE.name, &ctx)?,
            side,
            law,
            law_values,
        })
    }

    fn compile(&self, i: usize) -> PyResult<Gap> {
        let ctx = format!("gaps[{i}]");
        let side = match &self.side {
            GapSide::Radial {
                center,
                friction,
                radius,
                friction_law,
                regularisation_speed,
            } => {
                let center = center
                    .clone()
                    .unwrap_or_else(|| CENTER.default_numbers().expect("a default").to_vec());
                let center: [f64; 2] = center.try_into().map_err(|c: Vec<f64>| {
                    ModelError::new_err(format!(
                        "{ctx}.center: {c:?} is not valid; expected {}",
                        CENTER.rule.expected
                    ))
                })?;
                let friction_law =
                    match choice(friction_law.as_deref(), &FRICTION_LAW, &ctx)?.as_str() {
                        "regularised" => FrictionLaw::Regularised {
                            speed: number(*regularisation_speed, &REGULARISATION_SPEED, &ctx)?,
                        },
                        _ => FrictionLaw::Coulomb,
                    };
                Side::Radial(Radial {
                    center,
                    friction: number(*friction, &FRICTION, &ctx)?,
                    // 0: none given (read only with friction, where `Gap::validate` requires one)
                    radius: radius.unwrap_or(0.0),
                    friction_law,
                    partner: 0,
                })
            }
            GapSide::Linear(side) => match choice(side.as_deref(), &SIDE, &ctx)?.as_str() {
                "negative" => Side::Negative,
                "both" => Side::Both,
                _ => Side::Positive,
            },
        };
        Ok(Gap {
            dofs: self.dofs.clone(),
            coefficients: self.coefficients.clone(),
            clearance: number(self.clearance, &CLEARANCE, &ctx)?,
            side,
            law: Law::from_parameters(self.law, &self.law_values).map_err(to_py_err)?,
        })
    }

    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("dofs", &self.dofs)?;
        d.set_item("coefficients", &self.coefficients)?;
        d.set_item("clearance", self.clearance)?;
        match &self.side {
            GapSide::Linear(side) => d.set_item("side", side)?,
            GapSide::Radial {
                center,
                friction,
                radius,
                friction_law,
                regularisation_speed,
            } => {
                d.set_item("side", "radial")?;
                d.set_item("center", center)?;
                d.set_item("friction", friction)?;
                d.set_item("radius", radius)?;
                d.set_item("friction_law", friction_law)?;
                d.set_item("regularisation_speed", regularisation_speed)?;
            }
        }
        let law = PyDict::new(py);
        law.set_item("kind", self.law)?;
        for (name, value) in self.law_values.iter() {
            match value {
                ParameterValue::Number(v) => law.set_item(*name, v)?,
                ParameterValue::Numbers(v) => law.set_item(*name, v)?,
            }
        }
        d.set_item("law", law)?;
        if let Some(name) = &self.name {
            d.set_item("name", name)?;
        }
        Ok(d)
    }
}

impl LoadSpec {
    fn read(d: &Bound<'_, PyDict>, i: usize) -> PyResult<Self> {
        let ctx = format!("loads[{i}]");
        let kind: String = item(d, "kind", &ctx)?;
        if !LOADS.iter().any(|(k, _)| *k == kind) {
            let kinds: Vec<_> = LOADS.iter().map(|(k, _)| *k).collect();
            return Err(ModelError::new_err(format!(
                "{ctx}.kind: '{kind}' is not valid; expected one of {}",
                kinds.join(", ")
            )));
        }
        let dofs = if kind == "unbalance" {
            item::<[usize; 2]>(d, "dofs", &ctx)?.to_vec()
        } else {
            item(d, "dofs", &ctx)?
        };
        let table = kind == "table";
        Ok(LoadSpec {
            dofs,
            amplitude: opt(d, AMPLITUDE.name, &ctx)?,
            frequency: opt(d, FREQUENCY.name, &ctx)?,
            phase: opt(d, PHASE.name, &ctx)?,
            magnitude: opt(d, MAGNITUDE.name, &ctx)?,
            time: if table {
                Some(item(d, "time", &ctx)?)
            } else {
                None
            },
            value: if table {
                Some(item(d, "value", &ctx)?)
            } else {
                None
            },
            kind,
        })
    }

    /// The core's loads: one, or an unbalance's two (x and y) at the structure's spin
    /// profile. A table's `amplitude` is its scale.
    fn compile(&self, i: usize, structure: &LinearStructure) -> PyResult<Vec<Load>> {
        let ctx = format!("loads[{i}]");
        let (amplitude, history) = match self.kind.as_str() {
            "constant" => (
                number(self.amplitude, &AMPLITUDE, &ctx)?,
                LoadHistory::Constant,
            ),
            "harmonic" => (
                number(self.amplitude, &AMPLITUDE, &ctx)?,
                LoadHistory::Harmonic {
                    frequency: number(self.frequency, &FREQUENCY, &ctx)?,
                    phase: number(self.phase, &PHASE, &ctx)?,
                },
            ),
            "table" => (
                self.amplitude
                    .unwrap_or(SCALE.default_number().expect("a default")),
                LoadHistory::Table {
                    time: self.time.clone().unwrap_or_default(),
                    value: self.value.clone().unwrap_or_default(),
                },
            ),
            _ => {
                let magnitude = number(self.magnitude, &MAGNITUDE, &ctx)?;
                let phase = number(self.phase, &PHASE, &ctx)?;
                let dofs = [self.dofs[0], self.dofs[1]];
                return Ok(Load::unbalance(dofs, magnitude, phase, structure.spin).into());
            }
        };
        Ok(vec![Load {
            dofs: self.dofs.clone(),
            amplitude,
            history,
        }])
    }

    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("kind", &self.kind)?;
        d.set_item("dofs", &self.dofs)?;
        for (key, v) in self.numbers() {
            if let Some(v) = v {
                d.set_item(key, v)?;
            }
        }
        if let (Some(t), Some(v)) = (&self.time, &self.value) {
            d.set_item("time", t)?;
            d.set_item("value", v)?;
        }
        Ok(d)
    }

    /// The numbers a path can set (`loads.L.KEY`), given or not.
    fn numbers(&self) -> [(&'static str, Option<f64>); 4] {
        [
            ("amplitude", self.amplitude),
            ("frequency", self.frequency),
            ("phase", self.phase),
            ("magnitude", self.magnitude),
        ]
    }

    /// Its frequency (Hz): a harmonic load's, or an unbalance's `|Ω| / 2π` at a constant
    /// spin speed `Ω`; 0 for any other (a constant load, a table, an unbalance during a run-up:
    /// none that is periodic).
    fn frequency(&self, spin_speed: Option<f64>, spin_profile: Option<&str>) -> f64 {
        let constant = spin_profile
            .or(SPIN_PROFILE.default_choice())
            .is_some_and(|p| p == "constant");
        match self.kind.as_str() {
            "harmonic" => self.frequency.or(FREQUENCY.default_number()).unwrap_or(0.0),
            "unbalance" if constant => {
                let spin = spin_speed.or(SPIN_SPEED.default_number()).unwrap_or(0.0);
                spin.abs() / (2.0 * std::f64::consts::PI)
            }
            _ => 0.0,
        }
    }

    fn number_mut(&mut self, key: &str) -> Option<&mut Option<f64>> {
        match key {
            "amplitude" => Some(&mut self.amplitude),
            "frequency" => Some(&mut self.frequency),
            "phase" => Some(&mut self.phase),
            "magnitude" => Some(&mut self.magnitude),
            _ => None,
        }
    }
}

/// The structure matrices a path names (`structure.KEY`), in the order paths are listed.
const MATRICES: [&str; 3] = ["damping", "mass", "stiffness"];
/// The structure's numbers that are not matrices: a rotor's spin.
const SPIN: [&str; 3] = ["spin_speed", "spin_speed_end", "run_up_time"];

impl Parts {
    fn read(d: &Bound<'_, PyDict>) -> PyResult<Self> {
        let gyroscopic = match d.get_item("gyroscopic")? {
            Some(g) if !g.is_none() => Some(Arc::new(Matrix::read(d, "gyroscopic")?)),
            _ => None,
        };
        let gaps: Bound<'_, PyList> = item(d, "gaps", "model")?;
        let loads: Bound<'_, PyList> = item(d, "loads", "model")?;
        Ok(Parts {
            mass: Arc::new(Matrix::read(d, "mass")?),
            damping: Arc::new(Matrix::read(d, "damping")?),
            stiffness: Arc::new(Matrix::read(d, "stiffness")?),
            gyroscopic,
            spin_speed: opt(d, SPIN_SPEED.name, "structure")?,
            spin_profile: opt(d, SPIN_PROFILE.name, "structure")?,
            spin_speed_end: opt(d, SPIN_SPEED_END.name, "structure")?,
            run_up_time: opt(d, RUN_UP_TIME.name, "structure")?,
            gaps: gaps
                .iter()
                .enumerate()
                .map(|(i, g)| GapSpec::read(g.cast::<PyDict>()?, i))
                .collect::<PyResult<_>>()?,
            loads: loads
                .iter()
                .enumerate()
                .map(|(i, l)| LoadSpec::read(l.cast::<PyDict>()?, i))
                .collect::<PyResult<_>>()?,
            x0: vector(d, "x0")?,
            v0: vector(d, "v0")?,
        })
    }

    fn compile(&self) -> PyResult<System> {
        let structure = match (&*self.mass, &*self.damping, &*self.stiffness) {
            // small dense models keep their dense matrices for the dense methods
            (Matrix::Dense(m), Matrix::Dense(c), Matrix::Dense(k)) => {
                LinearStructure::new(m.clone(), c.clone(), k.clone())
            }
            (m, c, k) => LinearStructure::from_sparse(m.to_csr(), c.to_csr(), k.to_csr()),
        }
        .map_err(to_py_err)?;
        // a rotor: the gyroscopic matrix G (optional) and the spin speed Ω (default 0)
        let spin_speed = number(self.spin_speed, &SPIN_SPEED, "structure")?;
        let mut structure = structure
            .spinning(self.gyroscopic.as_ref().map(|g| g.to_csr()), spin_speed)
            .map_err(to_py_err)?;
        // a run-up (`spin_profile = "linear"`)
        if choice(self.spin_profile.as_deref(), &SPIN_PROFILE, "structure")? == "linear" {
            structure = structure
                .run_up(
                    number(self.spin_speed_end, &SPIN_SPEED_END, "structure")?,
                    number(self.run_up_time, &RUN_UP_TIME, "structure")?,
                )
                .map_err(to_py_err)?;
        }
        let gaps = (self.gaps.iter().enumerate())
            .map(|(i, g)| g.compile(i))
            .collect::<PyResult<Vec<_>>>()?;
        let compiled = (self.loads.iter().enumerate())
            .map(|(i, l)| l.compile(i, &structure))
            .collect::<PyResult<Vec<_>>>()?;
        // the core's loads that are an unbalance's at a constant spin (what the spin speed moves)
        let mut unbalance = Vec::new();
        let mut k = 0;
        for (spec, core) in self.loads.iter().zip(&compiled) {
            if spec.kind == "unbalance" && structure.spin.is_constant() {
                unbalance.extend(k..k + core.len());
            }
            k += core.len();
        }
        let system = System::new(structure, gaps, compiled.concat()).map_err(to_py_err)?;
        Ok(system.with_unbalance(unbalance))
    }

    fn spin(&self, key: &str) -> Option<f64> {
        match key {
            "spin_speed" => self.spin_speed,
            "spin_speed_end" => self.spin_speed_end,
            _ => self.run_up_time,
        }
    }

    fn matrix(&self, key: &str) -> &Arc<Matrix> {
        match key {
            "damping" => &self.damping,
            "mass" => &self.mass,
            _ => &self.stiffness,
        }
    }

    /// Every parameter path that `with_value` can set.
    fn numeric_paths(&self) -> Vec<String> {
        let mut out = Vec::new();
        for name in MATRICES {
            out.push(match self.matrix(name).n() {
                1 => format!("structure.{name}"),
                _ => format!("structure.{name}.I.J"),
            });
        }
        let rotor = self.gyroscopic.is_some()
            || self.spin_speed.is_some_and(|s| s != 0.0)
            || self.loads.iter().any(|l| l.kind == "unbalance");
        if rotor {
            out.extend(
                (SPIN.iter())
                    .filter(|k| self.spin(k).is_some())
                    .map(|k| format!("structure.{k}")),
            );
        }
        for (x, name) in [(&self.x0, "displacement"), (&self.v0, "velocity")] {
            out.push(match x.len() {
                1 => format!("initial.{name}"),
                _ => format!("initial.{name}.I"),
            });
        }
        for (i, g) in self.gaps.iter().enumerate() {
            out.push(format!("gaps.{i}.clearance"));
            out.extend(
                (g.law_values.iter())
                    .filter(|(_, v)| matches!(v, ParameterValue::Number(_)))
                    .map(|(k, _)| format!("gaps.{i}.law.{k}")),
            );
            out.push(format!("gaps.{i}.coefficients.J"));
        }
        for (i, l) in self.loads.iter().enumerate() {
            out.extend(
                (l.numbers().iter())
                    .filter(|(_, v)| v.is_some())
                    .map(|(k, _)| format!("loads.{i}.{k}")),
            );
        }
        out
    }

    /// The number at `path` (canonical: `gaps.0.law.restitution`) set to `value`; the
    /// refusal names the path, why, and the paths that exist.
    fn set(&mut self, path: &str, value: f64) -> PyResult<()> {
        let fail = |parts: &Parts, why: String| {
            ModelError::new_err(format!(
                "--param {path}: {why}; expected one of {}",
                parts.numeric_paths().join(", ")
            ))
        };
        let index = |parts: &Parts, part: &str, size: usize| -> PyResult<usize> {
            match part.parse::<usize>() {
                Ok(k) if k < size && part.bytes().all(|b| b.is_ascii_digit()) => Ok(k),
                _ => Err(fail(
                    parts,
                    format!("'{part}' is not an index below {size}"),
                )),
            }
        };
        let p: Vec<&str> = path.split('.').collect();
        match p[0] {
            "structure" if p.len() == 2 && SPIN.contains(&p[1]) => {
                let slot = match p[1] {
                    "spin_speed" => &mut self.spin_speed,
                    "spin_speed_end" => &mut self.spin_speed_end,
                    _ => &mut self.run_up_time,
                };
                if slot.is_none() {
                    return Err(fail(
                        self,
                        format!(
                            "the structure has no {} (spin_speed_end and run_up_time: a \
                             run-up, spin_profile = 'linear')",
                            p[1]
                        ),
                    ));
                }
                *slot = Some(value);
            }
            "structure" => {
                if p.len() < 2 || !MATRICES.contains(&p[1]) {
                    return Err(fail(self, "not a structure matrix".into()));
                }
                let n = self.matrix(p[1]).n();
                let (i, j) = match p.len() {
                    2 if n != 1 => {
                        return Err(fail(
                            self,
                            format!("the structure has {n} DOFs; name an entry I.J"),
                        ))
                    }
                    2 => (0, 0),
                    4 => (index(self, p[2], n)?, index(self, p[3], n)?),
                    _ => return Err(fail(self, "not a matrix entry".into())),
                };
                let matrix = match p[1] {
                    "damping" => &mut self.damping,
                    "mass" => &mut self.mass,
                    _ => &mut self.stiffness,
                };
                Arc::make_mut(matrix).set_symmetric(i, j, value);
            }
            "initial" => {
                let size = match p.get(1) {
                    Some(&"displacement") => self.x0.len(),
                    Some(&"velocity") => self.v0.len(),
                    _ => return Err(fail(self, "not an initial state".into())),
                };
                let i = match p.len() {
                    2 if size != 1 => {
                        return Err(fail(
                            self,
                            format!("the structure has {size} DOFs; name a DOF"),
                        ))
                    }
                    2 => 0,
                    3 => index(self, p[2], size)?,
                    _ => return Err(fail(self, "not an initial-state entry".into())),
                };
                match p[1] {
                    "displacement" => self.x0[i] = value,
                    _ => self.v0[i] = value,
                }
            }
            head @ ("gaps" | "loads") => {
                if p.len() < 3 {
                    return Err(fail(self, format!("incomplete {head} path")));
                }
                let size = if head == "gaps" {
                    self.gaps.len()
                } else {
                    self.loads.len()
                };
                let k = index(self, p[1], size)?;
                let rest = &p[2..];
                if head == "gaps" {
                    let gap = &self.gaps[k];
                    match rest {
                        ["law", key] => {
                            if !matches!(gap.law_values.get(key), Some(ParameterValue::Number(_))) {
                                let why =
                                    format!("gap {k}'s {} law has no number '{key}'", gap.law);
                                return Err(fail(self, why));
                            }
                            let name = (gap.law_values.iter())
                                .find(|(n, _)| n == key)
                                .map(|(n, _)| *n)
                                .expect("a given parameter");
                            self.gaps[k]
                                .law_values
                                .set(name, ParameterValue::Number(value));
                        }
                        ["coefficients", j] => {
                            let j = index(self, j, gap.coefficients.len())?;
                            self.gaps[k].coefficients[j] = value;
                        }
                        ["clearance"] => {
                            if gap.clearance.is_none() {
                                return Err(fail(self, format!("gap {k} has no clearance")));
                            }
                            self.gaps[k].clearance = Some(value);
                        }
                        _ => return Err(fail(self, "not a numeric parameter".into())),
                    }
                } else {
                    let [key] = rest else {
                        return Err(fail(self, "not a numeric parameter".into()));
                    };
                    match self.loads[k].number_mut(key) {
                        None => return Err(fail(self, "not a numeric parameter".into())),
                        Some(None) => return Err(fail(self, format!("load {k} has no {key}"))),
                        Some(slot) => *slot = Some(value),
                    }
                }
            }
            _ => return Err(fail(self, "not a model parameter".into())),
        }
        Ok(())
    }
}

/// A model spec as the core's typed parts; its `System` is compiled at its first run and kept
/// (a bad value is refused then, `ModelError` naming its field). `ModelSpec(spec)` reads a
/// spec dict (`vibroimpact.Model.to_spec`).
#[pyclass(module = "vibroimpact._core", frozen)]
pub(crate) struct ModelSpec {
    parts: Parts,
    system: OnceLock<Arc<System>>,
}

impl ModelSpec {
    /// The compiled system (compiled at the first call).
    pub(crate) fn system(&self) -> PyResult<Arc<System>> {
        if let Some(s) = self.system.get() {
            return Ok(s.clone());
        }
        let s = Arc::new(self.parts.compile()?);
        Ok(self.system.get_or_init(|| s).clone())
    }

    pub(crate) fn initial_state(&self) -> (DVector<f64>, DVector<f64>) {
        (self.parts.x0.clone(), self.parts.v0.clone())
    }

    /// The spec of a dict (read; compiled at its first run).
    pub(crate) fn from_dict(spec: &Bound<'_, PyDict>) -> PyResult<Self> {
        Ok(ModelSpec {
            parts: Parts::read(spec)?,
            system: OnceLock::new(),
        })
    }
}

#[pymethods]
impl ModelSpec {
    #[new]
    fn new(spec: &Bound<'_, PyDict>) -> PyResult<Self> {
        Self::from_dict(spec)
    }

    /// A copy with the number at parameter path `path` (canonical, `gaps.0.law.restitution`;
    /// the paths of `sweep --param`) set to `value`; checked with the rest at its first run.
    fn with_value(&self, path: &str, value: f64) -> PyResult<ModelSpec> {
        let mut parts = self.parts.clone();
        parts.set(path, value)?;
        Ok(ModelSpec {
            parts,
            system: OnceLock::new(),
        })
    }

    /// Compiles it now (if not yet): a bad value is refused here, not at the first run.
    fn check(&self) -> PyResult<()> {
        self.system().map(|_| ())
    }

    /// Every parameter path that `with_value` sets for this model.
    fn numeric_paths(&self) -> Vec<String> {
        self.parts.numeric_paths()
    }

    /// The frequency (Hz) of each load (`load_frequency`).
    fn load_frequencies(&self) -> Vec<f64> {
        let p = &self.parts;
        (p.loads.iter())
            .map(|l| l.frequency(p.spin_speed, p.spin_profile.as_deref()))
            .collect()
    }

    /// The spec dict (`vibroimpact.Model.to_spec`'s keys; a CSR matrix as a SciPy
    /// `csr_array`).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let p = &self.parts;
        let d = PyDict::new(py);
        d.set_item("mass", p.mass.to_py(py)?)?;
        d.set_item("damping", p.damping.to_py(py)?)?;
        d.set_item("stiffness", p.stiffness.to_py(py)?)?;
        let gaps = (p.gaps.iter())
            .map(|g| g.to_dict(py))
            .collect::<PyResult<Vec<_>>>()?;
        d.set_item("gaps", gaps)?;
        let loads = (p.loads.iter())
            .map(|l| l.to_dict(py))
            .collect::<PyResult<Vec<_>>>()?;
        d.set_item("loads", loads)?;
        match &p.gyroscopic {
            Some(g) => d.set_item("gyroscopic", g.to_py(py)?)?,
            None => d.set_item("gyroscopic", py.None())?,
        }
        d.set_item("spin_speed", p.spin_speed)?;
        d.set_item("spin_profile", &p.spin_profile)?;
        d.set_item("spin_speed_end", p.spin_speed_end)?;
        d.set_item("run_up_time", p.run_up_time)?;
        d.set_item("x0", p.x0.as_slice().to_pyarray(py))?;
        d.set_item("v0", p.v0.as_slice().to_pyarray(py))?;
        Ok(d)
    }

    /// Pickled as its dict.
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyTuple>> {
        let py = slf.py();
        let d = slf.get().to_dict(py)?;
        PyTuple::new(
            py,
            [slf.get_type().into_any(), PyTuple::new(py, [d])?.into_any()],
        )
    }
}

/// The frequency (Hz) of load spec `load` (a dict of `vibroimpact.Model.to_spec`'s `loads`)
/// of a structure spinning at `spin_speed` with `spin_profile`: a harmonic load's, or an
/// unbalance's `|Ω| / 2π` at a constant spin speed; 0 for any other.
#[pyfunction]
#[pyo3(signature = (load, spin_speed = None, spin_profile = None))]
pub(crate) fn load_frequency(
    load: &Bound<'_, PyDict>,
    spin_speed: Option<f64>,
    spin_profile: Option<String>,
) -> PyResult<f64> {
    Ok(LoadSpec::read(load, 0)?.frequency(spin_speed, spin_profile.as_deref()))
}
