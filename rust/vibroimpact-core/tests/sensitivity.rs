//! The state-transition matrix of a run (`simulate_with_sensitivity`) against central
//! differences of the simulated map, over one forcing period of a forced oscillator that hits
//! its stop: DOP853 with Hertz and Lankarani–Nikravesh (its force depends on the approach
//! speed), laws stiff at first touch (a linear spring, exponent-1 Hunt–Crossley) and
//! Kelvin–Voigt (its force jumps at the onset and is clamped before the wall opens: the
//! saltation at both switches), the event-driven method with a rigid stop (restitution:
//! velocity jump and saltation).

use nalgebra::{DMatrix, DVector};
use vibroimpact_core::contact::{Hertz, Hysteretic, KelvinVoigt, Law, Rigid};
use vibroimpact_core::gap::{Gap, Side};
use vibroimpact_core::impulsive::EventDriven;
use vibroimpact_core::integrators::NewtonSettings;
use vibroimpact_core::sensitivity::Parameter;
use vibroimpact_core::settings::Adaptive;
use vibroimpact_core::simulate::{simulate, simulate_with_sensitivity, Method, RunSettings};
use vibroimpact_core::structure::{LinearStructure, Load, LoadHistory};
use vibroimpact_core::system::System;

/// `x'' + 0.1 x' + x = cos(0.8 t)` with a stop at `x = 0.5`.
fn oscillator(law: Law) -> System {
    with_clearance(law, 0.5)
}

fn with_clearance(law: Law, clearance: f64) -> System {
    let s = LinearStructure::new(
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::from_element(1, 1, 0.1),
        DMatrix::from_element(1, 1, 1.0),
    )
    .unwrap();
    let gap = Gap {
        dofs: vec![0],
        coefficients: vec![1.0],
        clearance,
        side: Side::Positive,
        law,
    };
    let load = Load {
        dofs: vec![0],
        amplitude: 1.0,
        history: LoadHistory::Harmonic {
            frequency: 0.8 / (2.0 * std::f64::consts::PI),
            phase: std::f64::consts::FRAC_PI_2,
        },
    };
    System::new(s, vec![gap], vec![load]).unwrap()
}

const PERIOD: f64 = 2.0 * std::f64::consts::PI / 0.8;

fn settings(method: Method) -> RunSettings {
    let explicit = matches!(method, Method::Dop853);
    RunSettings {
        t_end: PERIOD,
        dt: if explicit { 1e-3 } else { PERIOD / 2000.0 },
        every: 1000,
        record_dofs: vec![0],
        newton: NewtonSettings::default(),
        adaptive: explicit.then_some(Adaptive {
            rtol: 1e-12,
            atol: 1e-14,
            dt_min: 1e-12,
            dt_max: 0.05,
        }),
    }
}

/// The state at the end of the period from `z`.
fn map(sys: &System, method: Method, z: [f64; 2]) -> [f64; 2] {
    end_state(sys, method, &settings(method), z)
}

/// The state at the end of the run `settings` from `z`.
fn end_state(sys: &System, method: Method, settings: &RunSettings, z: [f64; 2]) -> [f64; 2] {
    let (x0, v0) = (
        DVector::from_element(1, z[0]),
        DVector::from_element(1, z[1]),
    );
    let out = simulate(sys, method, settings, x0, v0).unwrap();
    assert!(out.error.is_none(), "{:?}", out.error);
    let rows = &out.rows;
    [
        *rows.displacement.last().unwrap(),
        *rows.velocity.last().unwrap(),
    ]
}

fn check(law: Law, method: Method, impacts_expected: usize) {
    let sys = oscillator(law);
    let z = [0.2, 1.0];
    let (x0, v0) = (
        DVector::from_element(1, z[0]),
        DVector::from_element(1, z[1]),
    );
    let out =
        simulate_with_sensitivity(&sys, method, &settings(method), x0, v0, None, None).unwrap();
    assert!(out.error.is_none(), "{:?}", out.error);
    assert_eq!(out.impacts.len(), impacts_expected, "{:?}", out.impacts);
    let phi = out.state_transition.expect("asked for").matrix;
    let eps = 1e-5;
    let mut worst: f64 = 0.0;
    let mut fd_matrix = DMatrix::zeros(2, 2);
    for j in 0..2 {
        let (mut up, mut down) = (z, z);
        up[j] += eps;
        down[j] -= eps;
        let (p, m) = (map(&sys, method, up), map(&sys, method, down));
        for i in 0..2 {
            let fd = (p[i] - m[i]) / (2.0 * eps);
            fd_matrix[(i, j)] = fd;
            worst = worst.max((fd - phi[(i, j)]).abs());
        }
    }
    let scale = phi.amax().max(1.0);
    assert!(
        worst <= 1e-6 * scale,
        "worst |Φ − FD| = {worst:e} (|Φ| = {scale}); Φ = {phi}, FD = {fd_matrix}"
    );
    // the sensitivity is not the free flow's: the impacts change it
    let free = simulate_with_sensitivity(
        &with_clearance(Law::Hertz(Hertz::new(1e3, 1.5).unwrap()), 100.0),
        Method::Dop853,
        &settings(Method::Dop853),
        DVector::from_element(1, z[0]),
        DVector::from_element(1, z[1]),
        None,
        None,
    )
    .unwrap();
    assert!(free.impacts.is_empty());
    let free_phi = free.state_transition.unwrap().matrix;
    assert!((free_phi - &phi).amax() > 1e-2, "{phi}");
}

#[test]
fn dop853_hertz_stop_matches_finite_differences() {
    check(Law::Hertz(Hertz::new(1e4, 1.5).unwrap()), Method::Dop853, 2);
}

/// Stiff at first touch: the force's slope jumps at the wall.
#[test]
fn dop853_linear_spring_and_exponent_one_stops_match_finite_differences() {
    check(Law::Hertz(Hertz::new(1e4, 1.0).unwrap()), Method::Dop853, 2);
    let law = Hysteretic::new("hunt-crossley", 1e4, 1.0, 0.5).unwrap();
    check(Law::Hysteretic(law), Method::Dop853, 2);
}

/// Kelvin–Voigt: the force `c δ̇` jumps at the onset (the saltation `S ≠ I`) and is clamped
/// before the wall opens (its switching function is the force there), with a large and a
/// vanishing dashpot.
#[test]
fn dop853_kelvin_voigt_stop_matches_finite_differences() {
    for damping in [20.0, 1e-9] {
        let law = Law::KelvinVoigt(KelvinVoigt::new(1e4, damping).unwrap());
        check(law, Method::Dop853, 2);
    }
}

#[test]
fn dop853_lankarani_nikravesh_stop_matches_finite_differences() {
    let law = Hysteretic::new("lankarani-nikravesh", 1e4, 1.5, 0.7).unwrap();
    check(Law::Hysteretic(law), Method::Dop853, 2);
}

#[test]
fn event_driven_rigid_stop_matches_finite_differences() {
    let method = Method::EventDriven(EventDriven::default());
    check(Law::Rigid(Rigid::new(0.8).unwrap()), method, 2);
}

#[test]
fn methods_without_a_state_transition_are_refused() {
    let sys = oscillator(Law::Hertz(Hertz::new(1e4, 1.5).unwrap()));
    let method = Method::Bathe(vibroimpact_core::integrators::Bathe { gamma: 0.5 });
    let err = simulate_with_sensitivity(
        &sys,
        method,
        &settings(method),
        DVector::zeros(1),
        DVector::zeros(1),
        None,
        None,
    )
    .unwrap_err();
    assert!(err.to_string().contains("solver.method"), "{err}");
    // DOP853 at fixed steps: refused with its reason
    let fixed = RunSettings {
        adaptive: None,
        ..settings(Method::Dop853)
    };
    let err = simulate_with_sensitivity(
        &sys,
        Method::Dop853,
        &fixed,
        DVector::zeros(1),
        DVector::zeros(1),
        None,
        None,
    )
    .unwrap_err();
    assert!(
        err.to_string()
            .starts_with("solver.adaptive: false is not valid for DOP853's"),
        "{err}"
    );
}

/// The oscillator with one of its numbers changed: `(parameter path, value)`, with
/// `method`'s settings; the run's length one forcing period (and its first step the same
/// fraction of it).
fn varied(method: Method, law: &Law, path: &str, value: f64) -> (System, RunSettings) {
    let mut sys = oscillator(law.clone());
    let mut settings = settings(method);
    match path {
        "loads.0.amplitude" => sys.loads[0].amplitude = value,
        "loads.0.phase" | "loads.0.frequency" => {
            let LoadHistory::Harmonic { frequency, phase } = &mut sys.loads[0].history else {
                unreachable!()
            };
            if path.ends_with("phase") {
                *phase = value;
            } else {
                let scale = *frequency / value;
                *frequency = value;
                settings.t_end *= scale;
                settings.dt *= scale;
            }
        }
        "gaps.0.clearance" => {
            sys = with_clearance(law.clone(), value);
        }
        _ => unreachable!("{path}"),
    }
    (sys, settings)
}

/// DOP853's column `∂P/∂p` of a load's amplitude, frequency (the map over its forcing period)
/// and phase and of the stop's clearance equals the central differences of the simulated map,
/// over a period with two contacts of a Hertz, a Lankarani–Nikravesh and a Kelvin–Voigt stop.
#[test]
fn dop853_parameter_columns_match_finite_differences() {
    let laws = [
        Law::Hertz(Hertz::new(1e4, 1.5).unwrap()),
        Law::Hysteretic(Hysteretic::new("lankarani-nikravesh", 1e4, 1.5, 0.7).unwrap()),
        Law::KelvinVoigt(KelvinVoigt::new(1e4, 20.0).unwrap()),
    ];
    let f0 = 0.8 / (2.0 * std::f64::consts::PI);
    let nominal = [
        ("loads.0.amplitude", 1.0),
        ("loads.0.frequency", f0),
        ("loads.0.phase", std::f64::consts::FRAC_PI_2),
        ("gaps.0.clearance", 0.5),
    ];
    for law in &laws {
        check_parameter_columns(Method::Dop853, law, &nominal, 1e-5);
    }
}

/// `method`'s column `∂P/∂p` at each `(path, p)` of `nominal` equals the central difference
/// (step `relative_step · p`) of the map from `z = (0.2, 1.0)` over a period with two
/// contacts, is not negligible, and leaves the monodromy as it is without it.
fn check_parameter_columns(method: Method, law: &Law, nominal: &[(&str, f64)], relative_step: f64) {
    let z = [0.2, 1.0];
    let run = |sys: &System, settings: &RunSettings, parameter| {
        simulate_with_sensitivity(
            sys,
            method,
            settings,
            DVector::from_element(1, z[0]),
            DVector::from_element(1, z[1]),
            parameter,
            None,
        )
        .unwrap()
    };
    for &(path, p) in nominal {
        let (sys, settings) = varied(method, law, path, p);
        let parameter = Parameter::of_path(&sys, path).unwrap();
        let out = run(&sys, &settings, Some(parameter));
        assert_eq!(out.impacts.len(), 2, "{path}: {:?}", out.impacts);
        let transition = out.state_transition.unwrap();
        let column = transition.parameter_column().expect("asked for");
        let h = relative_step * p;
        let end = |value: f64| {
            let (sys, settings) = varied(method, law, path, value);
            end_state(&sys, method, &settings, z)
        };
        let (up, down) = (end(p + h), end(p - h));
        for i in 0..2 {
            let fd = (up[i] - down[i]) / (2.0 * h);
            assert!(
                (fd - column[i]).abs() <= 1e-6 * column.amax().max(1.0),
                "{law:?} {path}: ∂P/∂p[{i}] = {}, FD {fd}",
                column[i]
            );
        }
        assert!(column.amax() > 0.1, "{path}: {column}");
        // the monodromy is the one without the column
        let plain = run(&sys, &settings, None);
        assert_eq!(
            plain.state_transition.unwrap().matrix,
            transition.monodromy()
        );
    }
}

/// A force that jumps at its wall's onset (Kelvin–Voigt's `c δ̇`) acts from the onset on: the
/// plain run lands on it to round-off, so its map converges with the tolerance (switched up
/// to `1e-5` of a step early, it was 5.6e-7 off in the velocity at `rtol = 1e-11`).
#[test]
fn dop853_kelvin_voigt_map_converges_with_the_tolerance() {
    let sys = oscillator(Law::KelvinVoigt(KelvinVoigt::new(1e4, 20.0).unwrap()));
    let at = |rtol: f64| {
        let mut settings = settings(Method::Dop853);
        settings.adaptive.as_mut().unwrap().rtol = rtol;
        end_state(&sys, Method::Dop853, &settings, [0.2, 1.0])
    };
    let reference = at(1e-13);
    for rtol in [1e-10, 1e-11, 1e-12] {
        let z = at(rtol);
        let error = (z[0] - reference[0]).abs().max((z[1] - reference[1]).abs());
        assert!(
            error < 100.0 * rtol,
            "rtol {rtol:e}: {error:e} off the map at 1e-13"
        );
    }
}

/// The event-driven method's column of the stop's clearance (its flights do not depend on it,
/// its impacts' saltation takes `∂δ/∂d = −1`) equals the central differences of the simulated
/// map over a period with two impacts of a rigid stop; a load's column is refused.
#[test]
fn event_driven_clearance_column_matches_finite_differences() {
    let method = Method::EventDriven(EventDriven::default());
    let law = Law::Rigid(Rigid::new(0.8).unwrap());
    let z = [0.2, 1.0];
    let (x0, v0) = (
        DVector::from_element(1, z[0]),
        DVector::from_element(1, z[1]),
    );
    let sys = with_clearance(law.clone(), 0.5);
    let parameter = Parameter::of_path(&sys, "gaps.0.clearance").unwrap();
    let run = |parameter| {
        simulate_with_sensitivity(
            &sys,
            method,
            &settings(method),
            x0.clone(),
            v0.clone(),
            parameter,
            None,
        )
    };
    let out = run(Some(parameter)).unwrap();
    assert_eq!(out.impacts.len(), 2, "{:?}", out.impacts);
    let column = out.state_transition.unwrap().parameter_column().unwrap();
    let h = 1e-6;
    let at = |d: f64| {
        end_state(
            &with_clearance(law.clone(), d),
            method,
            &settings(method),
            z,
        )
    };
    let (up, down) = (at(0.5 + h), at(0.5 - h));
    for i in 0..2 {
        let fd = (up[i] - down[i]) / (2.0 * h);
        assert!(
            (fd - column[i]).abs() <= 1e-6 * column.amax().max(1.0),
            "∂P/∂d[{i}] = {}, FD {fd}",
            column[i]
        );
    }
    assert!(column.amax() > 0.1, "{column}");
    let mut table = sys.clone();
    table.loads[0].history = LoadHistory::Table {
        time: vec![0.0, PERIOD],
        value: vec![0.0, 1.0],
    };
    let amplitude = Parameter::of_path(&table, "loads.0.amplitude").unwrap();
    let err = simulate_with_sensitivity(
        &table,
        method,
        &settings(method),
        x0.clone(),
        v0.clone(),
        Some(amplitude),
        None,
    )
    .unwrap_err()
    .to_string();
    assert!(
        err.starts_with("solver.method: 'event-driven' does not carry the column"),
        "{err}"
    );
}

/// The event-driven method's column of a load's amplitude, frequency (the map over its
/// forcing period: the run's length and steps scale with `1/f`) and phase, carried through
/// the flights' exponential (Van Loan's block) and the impacts' saltation, equals the central
/// differences of the simulated map over a period with two impacts of a rigid stop.
#[test]
fn event_driven_load_columns_match_finite_differences() {
    let method = Method::EventDriven(EventDriven::default());
    let law = Law::Rigid(Rigid::new(0.8).unwrap());
    let f0 = 0.8 / (2.0 * std::f64::consts::PI);
    let nominal = [
        ("loads.0.amplitude", 1.0),
        ("loads.0.frequency", f0),
        ("loads.0.phase", std::f64::consts::FRAC_PI_2),
    ];
    check_parameter_columns(method, &law, &nominal, 1e-6);
}
