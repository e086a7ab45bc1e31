//! Rigid impacts (massless bar): event-driven and Moreau–Jean against the closed-form
//! bouncing mass, simultaneous impacts, and the refusal of mixed law/method pairs.

use nalgebra::{DMatrix, DVector};
use vibroimpact_core::contact::{Hertz, Law, Rigid};
use vibroimpact_core::gap::{Gap, Side};
use vibroimpact_core::impulsive::{EventDriven, MoreauJean};
use vibroimpact_core::integrators::NewmarkFamily;
use vibroimpact_core::simulate::{simulate, Method, RunSettings};
use vibroimpact_core::structure::{LinearStructure, Load, LoadHistory};
use vibroimpact_core::system::System;

mod common;
use common::{largest_displacement_error, run, settings};

const G: f64 = 9.81;

/// A unit mass under gravity above a rigid floor at u = 0 (negative wall, clearance 0).
fn bouncing(restitution: f64, law: Option<Law>) -> System {
    let s = LinearStructure::new(
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::zeros(1, 1),
        DMatrix::zeros(1, 1),
    )
    .unwrap();
    let gap = Gap {
        dofs: vec![0],
        coefficients: vec![1.0],
        clearance: 0.0,
        side: Side::Negative,
        law: law.unwrap_or(Law::Rigid(Rigid::new(restitution).unwrap())),
    };
    let load = Load {
        dofs: vec![0],
        amplitude: -G,
        history: LoadHistory::Constant,
    };
    System::new(s, vec![gap], vec![load]).unwrap()
}

/// Closed form from height H at rest: t₁ = √(2H/g), v₁ = g t₁; impact k (k ≥ 1) at
/// `t_k = t₁ + 2 v₁ (e − e^k)/(g (1 − e))` with approach speed `e^{k−1} v₁`; accumulation
/// at `t∞ = t₁ + 2 e v₁ /(g (1 − e))`.
fn closed_form(h: f64, e: f64, k: usize) -> (f64, f64) {
    let t1 = (2.0 * h / G).sqrt();
    let v1 = G * t1;
    let ek = e.powi(k as i32 - 1);
    (t1 + 2.0 * v1 * (e - ek * e) / (G * (1.0 - e)), ek * v1)
}

#[test]
fn event_driven_bouncing_mass_matches_closed_form_and_sticks_at_accumulation_point() {
    let (h, e, dt) = (1.0, 0.8, 1e-3);
    let t1 = (2.0 * h / G).sqrt();
    let t_inf = t1 + 2.0 * e * G * t1 / (G * (1.0 - e));
    let method = EventDriven::default();
    let out = run(
        &bouncing(e, None),
        Method::EventDriven(method),
        t_inf + 0.5,
        dt,
        h,
        0.0,
    );
    assert!(out.error.is_none(), "{:?}", out.error);
    let n = out.impacts.len();
    assert!(n > 30, "{n} impacts");
    // Every impact before the chattering rule, against the closed form.
    for (k, imp) in out.impacts.iter().enumerate().take(n - 1) {
        let (t, v) = closed_form(h, e, k + 1);
        assert!(
            (imp.t_start - t).abs() < 1e-10,
            "impact {k}: {} vs {t}",
            imp.t_start
        );
        assert_eq!(imp.t_start, imp.t_end);
        assert!(
            (imp.v_in - v).abs() < 1e-9 * v + 1e-12,
            "impact {k}: {} vs {v}",
            imp.v_in
        );
        assert!((imp.v_out - e * imp.v_in).abs() < 1e-12 * v + 1e-13);
        assert!((imp.impulse - (1.0 + e) * imp.v_in).abs() < 1e-9);
        assert!(imp.force_max.is_nan() && imp.delta_max == 0.0);
    }
    // The chattering rule: the last impact starts sticking near t∞ (bound of the rule).
    let last = &out.impacts[n - 1];
    let bound = method.chatter_fraction * dt / (1.0 - e);
    assert!(
        last.t_start <= t_inf && t_inf - last.t_start < bound,
        "{} vs {t_inf}",
        last.t_start
    );
    assert!(last.t_end.is_nan(), "still stuck at the end");
    assert!(
        (last.force_max - G).abs() < 1e-9,
        "contact force while stuck = weight"
    );
    let k = out.rows.time.len() - 1;
    assert!(out.rows.displacement[k].abs() < 1e-12 && out.rows.velocity[k].abs() < 1e-12);
    // Energy: what the impacts dissipate balances the work of gravity.
    let balance = out.rows.energy.relative_balance_error();
    assert!(balance < 1e-9, "energy balance {balance}");
    assert!(out.rows.gap_penetration.iter().all(|&p| p <= 1e-12));
}

#[test]
fn moreau_jean_converges_to_the_closed_form() {
    let (h, e) = (1.0, 0.8);
    // Reference: the exact height at the recorded instants over the first three bounces.
    let t1 = (2.0 * h / G).sqrt();
    let exact = |t: f64| -> f64 {
        if t <= t1 {
            return h - 0.5 * G * t * t;
        }
        let mut k = 1;
        loop {
            let (tk, vk) = closed_form(h, e, k);
            let (tn, _) = closed_form(h, e, k + 1);
            if t <= tn {
                let (s, v) = (t - tk, e * vk);
                return v * s - 0.5 * G * s * s;
            }
            k += 1;
        }
    };
    let t_end = closed_form(h, e, 4).0;
    let mut errors = Vec::new();
    let dts = [2e-3, 1e-3, 5e-4, 2.5e-4, 1.25e-4];
    for dt in dts {
        let out = run(
            &bouncing(e, None),
            Method::MoreauJean(MoreauJean::default()),
            t_end,
            dt,
            h,
            0.0,
        );
        assert!(out.error.is_none());
        errors.push(largest_displacement_error(&out, exact));
        // Energy identity of θ = 1/2.
        assert!(out.rows.energy.relative_balance_error() < 1e-9);
    }
    let slope = (errors[0] / errors[4]).ln() / (dts[0] / dts[4]).ln();
    eprintln!("Moreau-Jean errors {errors:?}, order {slope:.3}");
    assert!(slope > 0.8, "order {slope}, errors {errors:?}");
    assert!(errors[4] < 5e-3, "{errors:?}");
    // Long run, past t∞ = 4.07 s: ends at rest on the floor.
    let out = run(
        &bouncing(e, None),
        Method::MoreauJean(MoreauJean::default()),
        5.0,
        1e-3,
        h,
        0.0,
    );
    let k = out.rows.time.len() - 1;
    assert!(
        out.rows.displacement[k].abs() < 1e-5 && out.rows.velocity[k].abs() < 1e-9,
        "{} {}",
        out.rows.displacement[k],
        out.rows.velocity[k]
    );
    let last = out.impacts.last().unwrap();
    assert!(last.t_end.is_nan(), "still in contact at the end");
}

/// Two masses joined by a spring, each against its own wall, moving symmetrically: the two
/// impacts are simultaneous, and with decoupled walls the LCP gives each wall its own
/// Newton impact; the motion stays antisymmetric.
#[test]
fn simultaneous_impacts_of_two_gaps() {
    let k = 100.0;
    let s = LinearStructure::new(
        DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, 1.0]),
        DMatrix::zeros(2, 2),
        DMatrix::from_row_slice(2, 2, &[k, -k, -k, k]),
    )
    .unwrap();
    let gap = |dof: usize, side: Side, e: f64| Gap {
        dofs: vec![dof],
        coefficients: vec![1.0],
        clearance: 0.01,
        side,
        law: Law::Rigid(Rigid::new(e).unwrap()),
    };
    let sys = System::new(
        s,
        vec![gap(0, Side::Positive, 0.7), gap(1, Side::Negative, 0.7)],
        vec![],
    )
    .unwrap();
    for method in [
        Method::EventDriven(EventDriven::default()),
        Method::MoreauJean(MoreauJean::default()),
    ] {
        let out = simulate(
            &sys,
            method,
            &RunSettings {
                record_dofs: vec![0, 1],
                ..settings(0.3, 1e-4)
            },
            DVector::zeros(2),
            DVector::from_row_slice(&[1.0, -1.0]),
        )
        .unwrap();
        assert!(out.error.is_none());
        let imps = &out.impacts;
        assert!(imps.len() >= 2);
        assert_eq!(imps[0].gap, 0);
        assert_eq!(imps[1].gap, 1);
        assert_eq!(imps[0].t_start, imps[1].t_start, "simultaneous");
        if let Method::EventDriven(_) = method {
            // x₀ = −x₁ = sin(ωt)/ω, ω = √(2k): the walls at 0.01 are reached together.
            let w = (2.0 * k).sqrt();
            let t = (0.01 * w).asin() / w;
            assert!(
                (imps[0].t_start - t).abs() < 1e-12,
                "{} vs {t}",
                imps[0].t_start
            );
            for imp in &imps[..2] {
                assert!((imp.v_in - (w * t).cos()).abs() < 1e-10);
                assert!((imp.v_out - 0.7 * imp.v_in).abs() < 1e-12);
            }
        }
        // Moreau–Jean lets a wall be passed by up to about one step's travel.
        let tol = if let Method::EventDriven(_) = method {
            1e-12
        } else {
            2e-4
        };
        for i in 0..out.rows.time.len() {
            let (a, b) = (
                out.rows.displacement[2 * i],
                out.rows.displacement[2 * i + 1],
            );
            assert!(
                (a + b).abs() < 1e-9,
                "antisymmetric at {}",
                out.rows.time[i]
            );
            assert!(a <= 0.01 + tol && b >= -0.01 - tol, "{a} {b}");
        }
    }
}

/// Coupled walls (a gap on x0 and one on x0 − x1, both closing at once): the impulse LCP
/// leaves no wall approaching, and the energy account balances.
#[test]
fn coupled_simultaneous_impact_leaves_no_wall_approaching() {
    let s = LinearStructure::new(
        DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, 2.0]),
        DMatrix::zeros(2, 2),
        DMatrix::zeros(2, 2),
    )
    .unwrap();
    let sys = System::new(
        s,
        vec![
            Gap {
                dofs: vec![0],
                coefficients: vec![1.0],
                clearance: 0.01,
                side: Side::Positive,
                law: Law::Rigid(Rigid::new(0.5).unwrap()),
            },
            Gap {
                dofs: vec![0, 1],
                coefficients: vec![1.0, -1.0],
                clearance: 0.01,
                side: Side::Positive,
                law: Law::Rigid(Rigid::new(0.5).unwrap()),
            },
        ],
        vec![],
    )
    .unwrap();
    let out = simulate(
        &sys,
        Method::EventDriven(EventDriven::default()),
        &RunSettings {
            record_dofs: vec![0, 1],
            ..settings(0.05, 1e-3)
        },
        DVector::from_row_slice(&[0.0, 0.005]),
        DVector::from_row_slice(&[1.0, -0.5]),
    )
    .unwrap();
    assert!(out.error.is_none());
    // Both walls close at t = 0.01 (u₀ = x₀ = t, u₁ = x₀ − x₁ = 1.5 t − 0.005). The LCP
    // (W = [[1, 1], [1, 1.5]], q = −1.5 [1, 1.5]) gives P = (0, 1.5): the impulse on the
    // relative gap alone stops the first wall exactly (δ̇₀⁺ = 0) and rebounds the second.
    let first = &out.impacts[0];
    assert_eq!(first.gap, 1, "{:?}", out.impacts);
    assert!((first.t_start - 0.01).abs() < 1e-12);
    assert!((first.impulse - 1.5).abs() < 1e-9 && (first.v_out - 0.75).abs() < 1e-9);
    // No penetration later.
    assert!(out.rows.gap_penetration.iter().all(|&p| p <= 1e-9));
    assert!(out.rows.energy.relative_balance_error() < 1e-9);
}

#[test]
fn rigid_and_force_laws_are_refused_by_the_other_methods() {
    let rigid = bouncing(0.5, None);
    let err = simulate(
        &rigid,
        Method::Newmark(NewmarkFamily::average_acceleration()),
        &settings(0.1, 1e-3),
        DVector::from_element(1, 1.0),
        DVector::zeros(1),
    )
    .unwrap_err()
    .to_string();
    assert!(
        err.starts_with("gaps[0].law.kind: 'rigid' needs solver.method"),
        "{err}"
    );
    assert!(!err.contains('\n'));
    let hertz = bouncing(0.5, Some(Law::Hertz(Hertz::new(1e9, 1.5).unwrap())));
    for m in [
        Method::EventDriven(EventDriven::default()),
        Method::MoreauJean(MoreauJean::default()),
    ] {
        let err = simulate(
            &hertz,
            m,
            &settings(0.1, 1e-3),
            DVector::from_element(1, 1.0),
            DVector::zeros(1),
        )
        .unwrap_err()
        .to_string();
        assert!(
            err.starts_with("gaps[0].law.kind: 'hertz' is a force law"),
            "{err}"
        );
    }
    // An initial state inside a rigid wall is refused.
    let err = simulate(
        &rigid,
        Method::EventDriven(EventDriven::default()),
        &settings(0.1, 1e-3),
        DVector::from_element(1, -0.01),
        DVector::zeros(1),
    )
    .unwrap_err()
    .to_string();
    assert!(err.starts_with("initial.displacement"), "{err}");
}

/// An undamped oscillator (ω = 2π·1.3 rad/s) from rest under a table load that ramps to F at
/// `t₁` and holds, a wall out of reach: `x = F/(k t₁) (t − sin ωt/ω)` up to `t₁`, then
/// `x = F/k (1 − (sin ωt − sin ω(t − t₁))/(ω t₁))`. With `t₁` inside a step the flight is
/// split there and each piece is integrated exactly: round-off at every step end, also on
/// the step that holds the kink (the quadratic through a step's ends and middle was 1e-6
/// off there).
#[test]
fn event_driven_table_load_is_exact_across_its_breakpoints() {
    let w = 2.0 * std::f64::consts::PI * 1.3;
    let k = w * w;
    let (f, t1) = (2.0, 0.023_7);
    let s = LinearStructure::new(
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::zeros(1, 1),
        DMatrix::from_element(1, 1, k),
    )
    .unwrap();
    let gap = Gap {
        dofs: vec![0],
        coefficients: vec![1.0],
        clearance: 1.0,
        side: Side::Positive,
        law: Law::Rigid(Rigid::new(0.5).unwrap()),
    };
    let load = Load {
        dofs: vec![0],
        amplitude: 1.0,
        history: LoadHistory::Table {
            time: vec![0.0, t1, 10.0],
            value: vec![0.0, f, f],
        },
    };
    let sys = System::new(s, vec![gap], vec![load]).unwrap();
    let method = Method::EventDriven(EventDriven::default());
    let out = run(&sys, method, 1.0, 1e-2, 0.0, 0.0);
    assert!(out.error.is_none() && out.impacts.is_empty());
    let exact = |t: f64| {
        if t <= t1 {
            f / (k * t1) * (t - (w * t).sin() / w)
        } else {
            f / k * (1.0 - ((w * t).sin() - (w * (t - t1)).sin()) / (w * t1))
        }
    };
    let scale = f / k;
    let worst = largest_displacement_error(&out, exact);
    assert!(worst < 1e-13 * scale, "{worst:e} of {scale:e}");
}
