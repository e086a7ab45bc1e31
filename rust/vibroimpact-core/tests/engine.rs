//! End-to-end checks of the engine against closed forms.

use vibroimpact_core::contact::{Hertz, Hysteretic, Law};
use vibroimpact_core::gap::{Gap, Side};
use vibroimpact_core::integrators::NewmarkFamily;
use vibroimpact_core::simulate::Method;

mod common;
use common::{largest_displacement_error, run, sdof};

fn newmark() -> Method {
    Method::Newmark(NewmarkFamily::average_acceleration())
}

/// Hertz impact on a wall touched at t = 0: δ_max = (5 m v0² / 4K)^(2/5) and
/// duration = 2·(2/5)·B(2/5, 1/2)·δ_max/v0 (Johnson 1985, §11.4).
#[test]
fn hertz_impact_matches_closed_form() {
    let (m, k, v0) = (0.04, 1.5087e11, 0.3);
    let gap = Gap {
        dofs: vec![0],
        coefficients: vec![1.0],
        clearance: 0.0,
        side: Side::Positive,
        law: Law::Hertz(Hertz::new(k, 1.5).unwrap()),
    };
    let sys = sdof(m, 0.0, 0.0, vec![gap], vec![]);
    let delta_max = (5.0 * m * v0 * v0 / (4.0 * k)).powf(0.4);
    // 2·(2/5)·B(2/5, 1/2) = 2.9432752 (Γ(2/5)Γ(1/2)/Γ(9/10) = B(2/5, 1/2))
    let duration = 2.943_275_2 * delta_max / v0;
    let out = run(&sys, newmark(), 1.2 * duration, duration / 4000.0, 0.0, v0);
    assert!(out.error.is_none());
    assert_eq!(out.impacts.len(), 1);
    let imp = &out.impacts[0];
    assert_eq!(imp.t_start, 0.0);
    assert!((imp.v_in - v0).abs() < 1e-12);
    let rel = |a: f64, b: f64| (a - b).abs() / b.abs();
    assert!(
        rel(imp.delta_max, delta_max) < 1e-5,
        "{} {}",
        imp.delta_max,
        delta_max
    );
    assert!(
        rel(imp.t_end - imp.t_start, duration) < 2e-6,
        "{}",
        rel(imp.t_end - imp.t_start, duration)
    );
    assert!(rel(imp.force_max, k * delta_max.powf(1.5)) < 1e-5);
    assert!(
        (imp.restitution() - 1.0).abs() < 1e-6,
        "{}",
        imp.restitution()
    );
    assert!(rel(imp.impulse, 2.0 * m * v0) < 1e-5);
    assert!(out.rows.energy.relative_balance_error() < 1e-6);
}

/// Undamped and damped free vibration against the exact solution; second-order convergence.
#[test]
fn newmark_free_vibration_converges_at_second_order() {
    let (m, k, c): (f64, f64, f64) = (2.0, 800.0, 4.0);
    let wn = (k / m).sqrt();
    let zeta = c / (2.0 * (k * m).sqrt());
    let wd = wn * (1.0 - zeta * zeta).sqrt();
    let (x0, v0) = (0.01, 0.3);
    let exact = |t: f64| {
        (-zeta * wn * t).exp() * (x0 * (wd * t).cos() + (v0 + zeta * wn * x0) / wd * (wd * t).sin())
    };
    let sys = sdof(m, c, k, vec![], vec![]);
    let t_end = 1.0;
    let mut errors = vec![];
    for &dt in &[2e-3, 1e-3, 5e-4] {
        let out = run(&sys, newmark(), t_end, dt, x0, v0);
        errors.push(largest_displacement_error(&out, exact));
    }
    let slope1 = (errors[0] / errors[1]).log2();
    let slope2 = (errors[1] / errors[2]).log2();
    assert!((slope1 - 2.0).abs() < 0.05, "{slope1}");
    assert!((slope2 - 2.0).abs() < 0.05, "{slope2}");
    let amplitude = x0.hypot(v0 / wn);
    assert!(errors[2] < 5e-4 * amplitude, "{errors:?}");
}

/// The paper's SDOF case with Lankarani–Nikravesh: bounces between the walls lose energy,
/// and the energy account balances.
#[test]
fn bilateral_clearance_energy_account_balances() {
    let k = 1.5087e11;
    let gap = Gap {
        dofs: vec![0],
        coefficients: vec![1.0],
        clearance: 0.005,
        side: Side::Both,
        law: Law::Hysteretic(Hysteretic::new("lankarani-nikravesh", k, 1.5, 0.9).unwrap()),
    };
    let sys = sdof(100.0, 0.0, 0.0, vec![gap], vec![]);
    let out = run(&sys, newmark(), 0.02, 1e-6, 0.0, 8.0);
    assert!(out.error.is_none());
    assert!(out.impacts.len() >= 8);
    for w in out.impacts.windows(2) {
        assert_ne!(w[0].side, w[1].side);
        if w[1].complete() {
            assert!(
                (w[1].v_in - w[0].v_out).abs() < 1e-6 * w[0].v_out,
                "{:?}",
                w
            );
        }
    }
    let first = &out.impacts[0];
    assert!((first.t_start - 0.005 / 8.0).abs() < 1e-12);
    assert!(first.restitution() < 0.95 && first.restitution() > 0.85);
    assert!(out.rows.energy.relative_balance_error() < 1e-4);
}
