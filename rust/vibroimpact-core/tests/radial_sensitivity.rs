//! The state-transition matrix of a rotor rubbing in a radial gap (DOP853) against central
//! differences of the simulated map: a Jeffcott rotor (1 kg, 1e4 N/m, 10 N·s/m, 150 rad/s,
//! unbalance 1e-4 kg·m) thrown against a 0.1 mm seal (a linear stator of 1e6 N/m), over three
//! spin periods with several contacts, without and with friction (its normal turns with the
//! state; the friction opposes the sliding speed `R Ω + ρ θ̇`).

use std::f64::consts::{FRAC_PI_2, PI};

use nalgebra::{DMatrix, DVector};
use vibroimpact_core::contact::{Hertz, Law};
use vibroimpact_core::gap::{FrictionLaw, Gap, Radial, Side};
use vibroimpact_core::integrators::NewtonSettings;
use vibroimpact_core::sensitivity::Parameter;
use vibroimpact_core::settings::Adaptive;
use vibroimpact_core::simulate::{simulate, simulate_with_sensitivity, Method, RunSettings};
use vibroimpact_core::structure::{LinearStructure, Load, LoadHistory};
use vibroimpact_core::system::System;

const SPIN: f64 = 150.0;
const CLEARANCE: f64 = 1e-4;

fn rotor(friction: f64, friction_law: FrictionLaw, clearance: f64) -> System {
    let eye = DMatrix::<f64>::identity(2, 2);
    let st = LinearStructure::new(eye.clone(), &eye * 10.0, &eye * 1e4)
        .unwrap()
        .spinning(None, SPIN)
        .unwrap();
    let gap = Gap {
        dofs: vec![0, 1],
        coefficients: vec![1.0, 1.0],
        clearance,
        side: Side::Radial(Radial {
            center: [0.0, 0.0],
            friction,
            radius: 0.01,
            friction_law,
            partner: 0,
        }),
        law: Law::Hertz(Hertz::new(1e6, 1.0).unwrap()),
    };
    let unbalance = |dof: usize, phase: f64| Load {
        dofs: vec![dof],
        amplitude: 1e-4 * SPIN * SPIN,
        history: LoadHistory::Harmonic {
            frequency: SPIN / (2.0 * PI),
            phase,
        },
    };
    let loads = vec![unbalance(0, 0.0), unbalance(1, -FRAC_PI_2)];
    System::new(st, vec![gap], loads).unwrap()
}

fn settings() -> RunSettings {
    RunSettings {
        t_end: 3.0 * 2.0 * PI / SPIN,
        dt: 1e-5,
        every: 1_000_000,
        record_dofs: vec![0, 1],
        newton: NewtonSettings::default(),
        adaptive: Some(Adaptive {
            rtol: 1e-12,
            atol: 1e-17,
            dt_min: 1e-14,
            dt_max: 1e-3,
        }),
    }
}

/// The state `(x, y, ẋ, ẏ)` at the end of the run from `z`.
fn map(sys: &System, z: &[f64; 4]) -> [f64; 4] {
    let out = simulate(
        sys,
        Method::Dop853,
        &settings(),
        DVector::from_column_slice(&z[..2]),
        DVector::from_column_slice(&z[2..]),
    )
    .unwrap();
    assert!(out.error.is_none(), "{:?}", out.error);
    let (d, v) = (&out.rows.displacement, &out.rows.velocity);
    let k = d.len() - 2;
    [d[k], d[k + 1], v[k], v[k + 1]]
}

/// `Φ` against central differences in the scaled state `(x, y, ẋ/Ω, ẏ/Ω)` to 1e-6 of its
/// largest entry; the clearance's column too. Returns `Φ` and the number of contacts.
fn check(friction: f64, friction_law: FrictionLaw) -> (DMatrix<f64>, usize) {
    let sys = rotor(friction, friction_law, CLEARANCE);
    // outside the seal, whirling forward into it faster than the steady orbit
    let z = [0.6e-4, -0.3e-4, 0.5e-4 * SPIN, 1.4e-4 * SPIN];
    let out = simulate_with_sensitivity(
        &sys,
        Method::Dop853,
        &settings(),
        DVector::from_column_slice(&z[..2]),
        DVector::from_column_slice(&z[2..]),
        Some(Parameter::Clearance(0)),
        None,
    )
    .unwrap();
    assert!(out.error.is_none(), "{:?}", out.error);
    let contacts = out.impacts.len();
    let phi = out.state_transition.expect("asked for").matrix;
    let scale = [1.0, 1.0, SPIN, SPIN];
    // 3e-6 of the clearance: the differences' truncation (1.8e-6 of Φ with friction at 1e-5 of
    // it, falling as its square) and their round-off (rtol / eps) both below 2e-7
    let eps = 3e-10;
    let mut fd = DMatrix::zeros(4, 5);
    for j in 0..4 {
        let (mut up, mut down) = (z, z);
        up[j] += eps * scale[j];
        down[j] -= eps * scale[j];
        let (p, m) = (map(&sys, &up), map(&sys, &down));
        for i in 0..4 {
            fd[(i, j)] = (p[i] - m[i]) / (2.0 * eps * scale[j]);
        }
    }
    let (p, m) = (
        map(&rotor(friction, friction_law, CLEARANCE + eps), &z),
        map(&rotor(friction, friction_law, CLEARANCE - eps), &z),
    );
    for i in 0..4 {
        fd[(i, 4)] = (p[i] - m[i]) / (2.0 * eps);
    }
    // in the scaled state: S⁻¹ Φ S, S = diag(1, 1, Ω, Ω) (and ∂z/∂c: S⁻¹ ∂z/∂c)
    let scaled = |a: &DMatrix<f64>| {
        DMatrix::from_fn(4, 5, |i, j| {
            a[(i, j)] / scale[i] * if j < 4 { scale[j] } else { 1.0 }
        })
    };
    let (phi_s, fd_s) = (scaled(&phi), scaled(&fd));
    let worst = (&phi_s - &fd_s).amax();
    assert!(
        worst <= 1e-6 * phi_s.amax(),
        "{contacts} contacts: worst |Φ − FD| = {worst:e} of {:e}; Φ = {phi_s}, FD = {fd_s}",
        phi_s.amax()
    );
    (phi_s, contacts)
}

#[test]
fn frictionless_rub_matches_finite_differences() {
    let (_, contacts) = check(0.0, FrictionLaw::Coulomb);
    assert!(contacts >= 3, "{contacts} contacts");
}

#[test]
fn rub_with_friction_matches_finite_differences() {
    let (phi, contacts) = check(0.1, FrictionLaw::Coulomb);
    assert!(contacts >= 3, "{contacts} contacts");
    let (regularised, _) = check(0.1, FrictionLaw::Regularised { speed: 2.0 });
    // the friction is felt: Φ differs from the frictionless one
    let (frictionless, _) = check(0.0, FrictionLaw::Coulomb);
    assert!((&phi - &frictionless).amax() > 1e-2 * phi.amax());
    assert!((&regularised - &frictionless).amax() > 1e-2 * phi.amax());
}
