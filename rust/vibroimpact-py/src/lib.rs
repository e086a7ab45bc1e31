//! Thin PyO3 binding of `vibroimpact-core`: converts the model spec built by the Python package
//! (plain data for the model, a typed `MethodSpec` for the method) into core types, runs with
//! the GIL released, and returns numpy arrays.

mod convert;
mod factor;
mod method;
mod model_catalog;
mod model_spec;
mod orbit;
mod running;
mod sweep;

#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

use nalgebra::DMatrix;
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray2};
use pyo3::create_exception;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::intern;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use vibroimpact_core::contact::{
    alternatives_fault, curve_fault, law_entry, ContactGeometry, ContactLaw, Material, Requirement,
    ValueKind, LAWS, ONE_OF_RESTITUTION_OR_DAMPING,
};
use vibroimpact_core::gap::ImpactRecord;
use vibroimpact_core::integrators;
use vibroimpact_core::simulate::{Rows, RunOutput};
use vibroimpact_core::structure::LinearStructure;
use vibroimpact_core::SimError;

create_exception!(
    _core,
    ModelError,
    PyValueError,
    "The model or settings are invalid."
);
// The solver's failures raise the package's own `vibroimpact.SolverError` (with its
// `partial` results), so that `except vi.SolverError` catches every failure of the core: one
// hierarchy, defined once, in Python.
pyo3::import_exception!(vibroimpact.errors, SolverError);

pub(crate) fn to_py_err(e: SimError) -> PyErr {
    match e {
        SimError::InvalidModel(msg) => ModelError::new_err(msg),
        other => SolverError::new_err(other.to_string()),
    }
}

/// Asks the runs in progress (`simulate`, `sweep`) to stop at their next poll (every ~1000
/// steps); they return the results up to then with an "interrupted" error. Safe to call from a
/// signal handler or another thread.
#[pyfunction]
fn request_interrupt() {
    vibroimpact_core::interrupt::request();
}

/// The floor of a Newmark step's cost on the run `spec` (benchmarks): its effective
/// stiffness for steps of `spec["dt"]` factorised as the run (of `spec["t_end"]`) would, and `solves` bare solves
/// timed. A dict: `solver`, `dofs`, `bandwidth`, `stored_values`, `solve_s` (per solve).
#[pyfunction]
fn substitution_time<'py>(
    py: Python<'py>,
    spec: &Bound<'py, PyDict>,
    solves: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let job = convert::job_from_spec(spec, None)?;
    let Some(scheme) = job.method.newmark_family() else {
        return Err(ModelError::new_err(
            "solver.method: expected a Newmark-family method for the substitution floor",
        ));
    };
    let (factor, solve_s) = py
        .detach(|| {
            let (t_end, dt) = (job.settings.t_end, job.settings.dt);
            let steps = (t_end / dt).round().max(1.0) as usize;
            integrators::substitution_time(&job.system, scheme, dt, steps, solves)
        })
        .map_err(to_py_err)?;
    let d = PyDict::new(py);
    d.set_item("solver", factor.solver)?;
    d.set_item("dofs", factor.dofs)?;
    d.set_item("bandwidth", factor.bandwidth)?;
    d.set_item("stored_values", factor.stored_values)?;
    d.set_item("solve_s", solve_s)?;
    Ok(d)
}

/// Withdraws an interrupt request (before starting a new run).
#[pyfunction]
fn clear_interrupt() {
    vibroimpact_core::interrupt::clear();
}

/// Whether an interrupt has been requested and not cleared.
#[pyfunction]
fn interrupt_requested() -> bool {
    vibroimpact_core::interrupt::requested()
}

/// Force of a law (spec dict as in a gap's `law`) at penetration δ (m), rate δ̇ (m/s) and
/// approach speed v_imp (m/s): `(F, ∂F/∂δ, ∂F/∂δ̇)`, clamped to be compressive; inside a
/// contact that reached `max_penetration` (m) if given (the tabulated law depends on it).
#[pyfunction]
#[pyo3(signature = (law, penetration, rate, impact_speed, max_penetration = None))]
fn contact_force(
    law: &Bound<'_, PyDict>,
    penetration: f64,
    rate: f64,
    impact_speed: f64,
    max_penetration: Option<f64>,
) -> PyResult<(f64, f64, f64)> {
    let law = convert::law(law, "law")?;
    let f = match max_penetration {
        Some(m) => law.force_in_contact(penetration, rate, impact_speed, m),
        None => law.force(penetration, rate, impact_speed),
    };
    Ok((f.force, f.d_penetration, f.d_rate))
}

/// Whether the core accepts the number `value` for parameter `name` of law `kind` (finite, and
/// in the parameter's range: the check its constructor applies).
#[pyfunction]
fn law_parameter_accepts(kind: &str, name: &str, value: f64) -> PyResult<bool> {
    law_entry(kind)
        .and_then(|law| law.parameter(name))
        .map(|p| p.accepts(value))
        .ok_or_else(|| {
            ModelError::new_err(format!(
                "law_parameter_accepts: no parameter {name} of {kind}"
            ))
        })
}

/// The core's rule for a law with alternatives (hunt-crossley): `None` when exactly one of
/// `restitution` or `damping` is given, else the parameter to name and what it expects.
#[pyfunction]
fn law_alternatives_fault(
    restitution: bool,
    damping: bool,
) -> Option<(&'static str, &'static str)> {
    alternatives_fault(restitution, damping).map(|field| (field, ONE_OF_RESTITUTION_OR_DAMPING))
}

/// The core's rule for curve `which` (`loading` or `unloading`) of the tabulated law: `None`
/// when the points make a curve, else the parameter to name and what it expects.
#[pyfunction]
fn tabulated_curve_fault(
    which: &str,
    penetration: Vec<f64>,
    force: Vec<f64>,
) -> Option<(String, String)> {
    curve_fault(which, &penetration, &force)
}

/// The core's catalog of contact laws, in its order: for each a dict with `name`, `class_name`,
/// `family`, `source`, `damping`, `doc` (empty when the Python class is written by hand) and
/// `parameters`, each a dict with `name`, `unit`, `doc`, `expected` (what a valid value is,
/// as messages word it), `list` (a list of numbers),
/// `required` and `default` (`None` when required or one of alternatives).
#[pyfunction]
fn law_catalog(py: Python<'_>) -> PyResult<Vec<Bound<'_, PyDict>>> {
    LAWS.iter()
        .map(|law| {
            let parameters = law
                .parameters
                .iter()
                .map(|p| {
                    let d = PyDict::new(py);
                    d.set_item("name", p.name)?;
                    d.set_item("unit", p.unit)?;
                    d.set_item("doc", p.doc)?;
                    d.set_item("expected", p.rule.expected)?;
                    d.set_item("list", p.kind == ValueKind::Numbers)?;
                    d.set_item("required", p.requirement == Requirement::Required)?;
                    let default = match p.requirement {
                        Requirement::Default(v) => Some(v),
                        _ => None,
                    };
                    d.set_item("default", default)?;
                    Ok(d)
                })
                .collect::<PyResult<Vec<_>>>()?;
            let d = PyDict::new(py);
            d.set_item("name", law.name)?;
            d.set_item("class_name", law.class_name)?;
            d.set_item("family", law.family.name())?;
            d.set_item("source", law.source)?;
            d.set_item("damping", law.damping)?;
            d.set_item("doc", law.doc)?;
            d.set_item("parameters", parameters)?;
            Ok(d)
        })
        .collect()
}

/// A law evaluated at arrays of states (same length): `(F, ∂F/∂δ, ∂F/∂δ̇)` as arrays, the
/// raw formula (`clamp=False`: may be tensile; for derivative checks and plots) or clamped
/// to be compressive as in a run (`clamp=True`); inside contacts that reached
/// `max_penetration` (m, an array of the same length) if given.
#[pyfunction]
#[pyo3(signature = (law, penetration, rate, impact_speed, clamp = false, max_penetration = None))]
#[allow(clippy::type_complexity)]
fn contact_law_evaluate<'py>(
    py: Python<'py>,
    law: &Bound<'py, PyDict>,
    penetration: numpy::PyReadonlyArray1<'py, f64>,
    rate: numpy::PyReadonlyArray1<'py, f64>,
    impact_speed: numpy::PyReadonlyArray1<'py, f64>,
    clamp: bool,
    max_penetration: Option<numpy::PyReadonlyArray1<'py, f64>>,
) -> PyResult<(
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<f64>>,
)> {
    let law = convert::law(law, "law")?;
    let (pen, rate, speed) = (
        penetration.as_array(),
        rate.as_array(),
        impact_speed.as_array(),
    );
    if rate.len() != pen.len() || speed.len() != pen.len() {
        return Err(ModelError::new_err(format!(
            "contact_law_evaluate: {} penetrations, {} rates and {} impact speeds; expected \
             arrays of the same length",
            pen.len(),
            rate.len(),
            speed.len()
        )));
    }
    let n = pen.len();
    let max_pen = max_penetration.as_ref().map(|m| m.as_array());
    if let Some(m) = &max_pen {
        if m.len() != n {
            return Err(ModelError::new_err(format!(
                "contact_law_evaluate: {} max penetrations for {n} penetrations; expected arrays \
                 of the same length",
                m.len()
            )));
        }
    }
    let (mut f, mut dp, mut dr) = (
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
    );
    for i in 0..n {
        let c = match (&max_pen, clamp) {
            (Some(m), true) => law.force_in_contact(pen[i], rate[i], speed[i], m[i]),
            (Some(m), false) => law.evaluate_in_contact(pen[i], rate[i], speed[i], m[i]),
            (None, true) => law.force(pen[i], rate[i], speed[i]),
            (None, false) => law.evaluate(pen[i], rate[i], speed[i]),
        };
        f.push(c.force);
        dp.push(c.d_penetration);
        dr.push(c.d_rate);
    }
    Ok((
        PyArray1::from_vec(py, f),
        PyArray1::from_vec(py, dp),
        PyArray1::from_vec(py, dr),
    ))
}

/// Contact stiffness from geometry and material, `(K, n)` for the law `K δⁿ`: the Hertz point
/// contacts (n = 1.5, paper eq. 4), a pin in a cylindrical hole linearised at `load` (Johnson)
/// and a flat punch (n = 1).
#[pyfunction]
#[pyo3(signature = (kind, radius1, radius2, length, load, youngs_modulus1, poisson1, youngs_modulus2, poisson2))]
#[allow(clippy::too_many_arguments)]
fn geometry_stiffness(
    kind: &str,
    radius1: f64,
    radius2: Option<f64>,
    length: Option<f64>,
    load: Option<f64>,
    youngs_modulus1: f64,
    poisson1: f64,
    youngs_modulus2: f64,
    poisson2: f64,
) -> PyResult<(f64, f64)> {
    let need = |name: &str, v: Option<f64>| {
        v.ok_or_else(|| ModelError::new_err(format!("geometry.{name}: missing; {kind} needs it")))
    };
    let geometry = match kind {
        "sphere-sphere" => ContactGeometry::SphereSphere {
            radius1,
            radius2: need("radius2", radius2)?,
        },
        "ball-in-socket" => ContactGeometry::BallInSocket {
            radius1,
            radius2: need("radius2", radius2)?,
        },
        "sphere-plane" => ContactGeometry::SpherePlane { radius: radius1 },
        "cylinder-in-hole" => ContactGeometry::CylinderInHole {
            radius1,
            radius2: need("radius2", radius2)?,
            length: need("length", length)?,
            load: need("load", load)?,
        },
        "flat-punch" => ContactGeometry::FlatPunch { radius: radius1 },
        other => {
            return Err(ModelError::new_err(format!(
                "geometry.kind: '{other}' is not known; expected one of sphere-sphere, \
                 ball-in-socket, sphere-plane, cylinder-in-hole, flat-punch"
            )))
        }
    };
    let k = geometry
        .stiffness(
            Material {
                youngs_modulus: youngs_modulus1,
                poisson: poisson1,
            },
            Material {
                youngs_modulus: youngs_modulus2,
                poisson: poisson2,
            },
        )
        .map_err(to_py_err)?;
    Ok((k, geometry.exponent()))
}

fn square(a: &PyReadonlyArray2<'_, f64>, name: &str) -> PyResult<DMatrix<f64>> {
    let a = a.as_array();
    let (r, c) = a.dim();
    if r != c {
        return Err(ModelError::new_err(format!(
            "{name}: shape {r}x{c}; expected a square matrix"
        )));
    }
    Ok(DMatrix::from_fn(r, c, |i, j| a[[i, j]]))
}

fn to_numpy<'py>(py: Python<'py>, a: &DMatrix<f64>) -> PyResult<Bound<'py, PyArray2<f64>>> {
    PyArray1::from_vec(py, a.transpose().as_slice().to_vec()).reshape([a.nrows(), a.ncols()])
}

/// `exp(A)` by the core's 2^N algorithm (precise integration's `Φ`), for tests.
#[pyfunction]
fn expm<'py>(
    py: Python<'py>,
    a: PyReadonlyArray2<'py, f64>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let a = square(&a, "a")?;
    to_numpy(py, &integrators::expm::expm(&a))
}

/// The benchmark's floor (`vibroimpact_core::floor`, only for `vibroimpact bench`): the
/// paper's SDOF scheme as a bare loop, a mass between walls at `±clearance` from `x = 0` at
/// velocity `v0`; every step's `displacement`, `velocity`, `acceleration` and `force`.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
fn newmark_floor_sdof<'py>(
    py: Python<'py>,
    mass: f64,
    stiffness: f64,
    damping: f64,
    clearance: f64,
    contact_stiffness: f64,
    exponent: f64,
    hysteresis: f64,
    v0: f64,
    dt: f64,
    steps: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let case = vibroimpact_core::floor::FloorCase {
        mass,
        stiffness,
        damping,
        clearance,
        contact_stiffness,
        exponent,
        hysteresis,
        v0,
        dt,
        steps,
        rtol: vibroimpact_core::integrators::NewtonSettings::default().rtol,
    };
    let run = py
        .detach(|| vibroimpact_core::floor::newmark_sdof(&case))
        .ok_or_else(|| PyRuntimeError::new_err("floor: Newton did not converge in a step"))?;
    let out = PyDict::new(py);
    out.set_item("displacement", PyArray1::from_vec(py, run.displacement))?;
    out.set_item("velocity", PyArray1::from_vec(py, run.velocity))?;
    out.set_item("acceleration", PyArray1::from_vec(py, run.acceleration))?;
    out.set_item("force", PyArray1::from_vec(py, run.force))?;
    Ok(out)
}

/// The precise integration method's matrices for a step `dt` (paper eqs. 36–41): `H`,
/// `Φ = exp(H dt)` and the Duhamel columns `D_m = dt^{m+1} Φ_m(dt) [0; I]`, m = 0, 1, 2.
#[pyfunction]
fn precise_matrices<'py>(
    py: Python<'py>,
    mass: PyReadonlyArray2<'py, f64>,
    damping: PyReadonlyArray2<'py, f64>,
    stiffness: PyReadonlyArray2<'py, f64>,
    dt: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let structure = LinearStructure::new(
        square(&mass, "mass")?,
        square(&damping, "damping")?,
        square(&stiffness, "stiffness")?,
    )
    .map_err(to_py_err)?;
    let m = integrators::precise_matrices(&structure, dt).map_err(to_py_err)?;
    let out = PyDict::new(py);
    out.set_item("hamiltonian", to_numpy(py, &m.hamiltonian)?)?;
    out.set_item("phi", to_numpy(py, &m.phi)?)?;
    let list = m
        .duhamel
        .iter()
        .map(|m| to_numpy(py, m))
        .collect::<PyResult<Vec<_>>>()?;
    out.set_item("duhamel", list)?;
    Ok(out)
}

/// The time-history columns of `rows` (`n_dofs` recorded DOFs, `n_gaps` gaps) into `d`. (The
/// keys here and in [`output_to_dict`] are interned: a run's output is built in a few µs.)
pub(crate) fn rows_to_dict(
    d: &Bound<'_, PyDict>,
    rows: Rows,
    n_dofs: usize,
    n_gaps: usize,
) -> PyResult<()> {
    let py = d.py();
    let nt = rows.time.len();
    // made 2-D at once (a reshape would make a second array object)
    let mat = |v: Vec<f64>, cols: usize| -> PyResult<Bound<'_, PyArray2<f64>>> {
        Array2::from_shape_vec((nt, cols), v)
            .map(|a| a.into_pyarray(py))
            .map_err(|e| PyRuntimeError::new_err(format!("rows of {cols} columns: {e}")))
    };
    d.set_item(intern!(py, "time"), PyArray1::from_vec(py, rows.time))?;
    d.set_item(intern!(py, "displacement"), mat(rows.displacement, n_dofs)?)?;
    d.set_item(intern!(py, "velocity"), mat(rows.velocity, n_dofs)?)?;
    d.set_item(intern!(py, "acceleration"), mat(rows.acceleration, n_dofs)?)?;
    d.set_item(
        intern!(py, "gap_penetration"),
        mat(rows.gap_penetration, n_gaps)?,
    )?;
    d.set_item(intern!(py, "gap_force"), mat(rows.gap_force, n_gaps)?)?;
    let e = rows.energy;
    let energy = PyDict::new(py);
    for (key, column) in [
        (intern!(py, "kinetic"), e.kinetic),
        (intern!(py, "strain"), e.strain),
        (intern!(py, "contact_potential"), e.contact_potential),
        (intern!(py, "external_work"), e.external_work),
        (intern!(py, "damping_dissipated"), e.damping_dissipated),
        (intern!(py, "contact_dissipated"), e.contact_dissipated),
    ] {
        energy.set_item(key, PyArray1::from_vec(py, column))?;
    }
    d.set_item(intern!(py, "energy"), energy)
}

/// A finished run as the dict `vibroimpact.Result.from_core` reads: `rows` are its time
/// histories (those not handed out in blocks) with `n_gaps` gap columns, `balance` the energy
/// balance error of the whole run. `impacts` and `stats` hold the fields of `ImpactTable`
/// (`side`: 0 for the negative wall, 1 for the positive one, 2 for a radial gap's) and `SolverStats`.
pub(crate) fn output_to_dict<'py>(
    py: Python<'py>,
    out: RunOutput,
    rows: Rows,
    n_gaps: usize,
    balance: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    rows_to_dict(&d, rows, out.record_dofs.len(), n_gaps)?;
    let ints = |v: &mut dyn Iterator<Item = i64>| PyArray1::from_vec(py, v.collect());
    d.set_item(
        intern!(py, "dofs"),
        ints(&mut out.record_dofs.iter().map(|&x| x as i64)),
    )?;
    d.set_item(
        intern!(py, "max_abs_displacement"),
        PyArray1::from_vec(py, out.max_abs_displacement),
    )?;
    let imp = PyDict::new(py);
    let records = &out.impacts;
    imp.set_item(
        intern!(py, "gap"),
        ints(&mut records.iter().map(|r| r.gap as i64)),
    )?;
    imp.set_item(
        intern!(py, "side"),
        ints(&mut records.iter().map(|r| match r.side {
            s if s > 0.0 => 1,
            s if s < 0.0 => 0,
            _ => 2,
        })),
    )?;
    type Column = fn(&ImpactRecord) -> f64;
    let columns: [(_, Column); 9] = [
        (intern!(py, "t_start"), |r| r.t_start),
        (intern!(py, "t_end"), |r| r.t_end),
        (intern!(py, "v_in"), |r| r.v_in),
        (intern!(py, "v_out"), |r| r.v_out),
        (intern!(py, "restitution_effective"), |r| r.restitution()),
        (intern!(py, "delta_max"), |r| r.delta_max),
        (intern!(py, "force_max"), |r| r.force_max),
        (intern!(py, "friction_max"), |r| r.friction_max),
        (intern!(py, "impulse"), |r| r.impulse),
    ];
    for (key, f) in columns {
        imp.set_item(key, PyArray1::from_vec(py, records.iter().map(f).collect()))?;
    }
    d.set_item(intern!(py, "impacts"), imp)?;
    let stats = PyDict::new(py);
    stats.set_item(intern!(py, "steps"), out.stats.steps)?;
    stats.set_item(
        intern!(py, "newton_iterations"),
        out.stats.newton_iterations,
    )?;
    stats.set_item(intern!(py, "rejected_steps"), out.stats.rejected_steps)?;
    stats.set_item(intern!(py, "step_cuts"), out.stats.step_cuts)?;
    stats.set_item(intern!(py, "wall_time_s"), out.stats.wall_time_s)?;
    stats.set_item(intern!(py, "step_path"), out.stats.step_path)?;
    d.set_item(intern!(py, "stats"), stats)?;
    d.set_item(intern!(py, "energy_balance_error"), balance)?;
    d.set_item(intern!(py, "dt"), out.dt)?;
    let (error, kind) = match out.error {
        None => (None, None),
        Some(e) => {
            let kind = match &e {
                SimError::InvalidModel(_) => "invalid-model",
                SimError::NewtonFailed { .. } => "newton-failed",
                SimError::Diverged { .. } => "diverged",
                SimError::EnergyGrowth { .. } => "energy-growth",
                SimError::SingularTangent { .. } => "singular-tangent",
                SimError::Interrupted { .. } => "interrupted",
                SimError::Sticking { .. } => "sticking",
            };
            (Some(e.to_string()), Some(kind))
        }
    };
    d.set_item(intern!(py, "error"), error)?;
    d.set_item(intern!(py, "error_kind"), kind)?;
    Ok(d)
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(running::start, m)?)?;
    m.add_class::<running::Running>()?;
    m.add_class::<model_spec::ModelSpec>()?;
    m.add_function(wrap_pyfunction!(model_spec::load_frequency, m)?)?;
    m.add_class::<factor::CholeskyFactor>()?;
    m.add_function(wrap_pyfunction!(expm, m)?)?;
    m.add_function(wrap_pyfunction!(substitution_time, m)?)?;
    m.add_function(wrap_pyfunction!(request_interrupt, m)?)?;
    m.add_function(wrap_pyfunction!(clear_interrupt, m)?)?;
    m.add_function(wrap_pyfunction!(interrupt_requested, m)?)?;
    m.add_function(wrap_pyfunction!(precise_matrices, m)?)?;
    m.add_function(wrap_pyfunction!(newmark_floor_sdof, m)?)?;
    m.add_function(wrap_pyfunction!(sweep::sweep, m)?)?;
    m.add_function(wrap_pyfunction!(orbit::flow_map, m)?)?;
    m.add_function(wrap_pyfunction!(sweep::sweep_check, m)?)?;
    m.add_function(wrap_pyfunction!(contact_force, m)?)?;
    m.add_function(wrap_pyfunction!(law_catalog, m)?)?;
    m.add_function(wrap_pyfunction!(law_parameter_accepts, m)?)?;
    m.add_function(wrap_pyfunction!(law_alternatives_fault, m)?)?;
    m.add_function(wrap_pyfunction!(tabulated_curve_fault, m)?)?;
    m.add_function(wrap_pyfunction!(method::method_catalog, m)?)?;
    m.add_function(wrap_pyfunction!(model_catalog::model_catalog, m)?)?;
    m.add_function(wrap_pyfunction!(model_catalog::model_field_accepts, m)?)?;
    m.add_function(wrap_pyfunction!(method::method_spec, m)?)?;
    m.add_function(wrap_pyfunction!(method::check_settings, m)?)?;
    m.add_class::<method::PyMethodSpec>()?;
    m.add_function(wrap_pyfunction!(contact_law_evaluate, m)?)?;
    m.add_function(wrap_pyfunction!(geometry_stiffness, m)?)?;
    m.add("ModelError", m.py().get_type::<ModelError>())?;
    m.add(
        "build_profile",
        if cfg!(debug_assertions) {
            "debug"
        } else {
            "release"
        },
    )?;
    Ok(())
}
