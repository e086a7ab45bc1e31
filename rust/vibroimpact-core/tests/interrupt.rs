//! The interrupt flag (`vibroimpact_core::interrupt`) stops a run with its results up to
//! then. In its own test binary: the flag is process-wide, and other tests run in parallel.

use nalgebra::{DMatrix, DVector};
use vibroimpact_core::contact::{Hysteretic, Law};
use vibroimpact_core::gap::{Gap, Side};
use vibroimpact_core::integrators::{NewmarkFamily, NewtonSettings};
use vibroimpact_core::interrupt;
use vibroimpact_core::simulate::{simulate, Method, RunSettings};
use vibroimpact_core::structure::LinearStructure;
use vibroimpact_core::system::System;
use vibroimpact_core::SimError;

/// The flag is process-wide: the tests of this binary take turns.
static FLAG: std::sync::Mutex<()> = std::sync::Mutex::new(());

#[test]
fn a_requested_interrupt_stops_the_run_with_its_results_up_to_then() {
    let _turn = FLAG.lock().unwrap_or_else(|e| e.into_inner());
    let s = LinearStructure::new(
        DMatrix::from_element(1, 1, 100.0),
        DMatrix::zeros(1, 1),
        DMatrix::zeros(1, 1),
    )
    .unwrap();
    let gap = Gap {
        dofs: vec![0],
        coefficients: vec![1.0],
        clearance: 0.005,
        side: Side::Both,
        law: Law::Hysteretic(Hysteretic::new("lankarani-nikravesh", 1.5e11, 1.5, 0.9).unwrap()),
    };
    let sys = System::new(s, vec![gap], vec![]).unwrap();
    let settings = RunSettings {
        t_end: 1.0,
        dt: 1e-6,
        every: 100,
        record_dofs: vec![0],
        newton: NewtonSettings::default(),
        adaptive: None,
    };
    let method = Method::Newmark(NewmarkFamily::average_acceleration());
    let x0 = DVector::zeros(1);
    let v0 = DVector::from_element(1, 8.0);

    interrupt::request();
    assert!(interrupt::requested());
    let out = simulate(&sys, method, &settings, x0.clone(), v0.clone()).unwrap();
    interrupt::clear();
    assert!(!interrupt::requested());
    // stopped at the first poll, after interrupt::CHECK_EVERY steps
    let t_stop = interrupt::CHECK_EVERY as f64 * 1e-6;
    match out.error {
        Some(SimError::Interrupted { t }) => assert!((t - t_stop).abs() < 1e-12, "{t}"),
        ref other => panic!("expected an interrupt, got {other:?}"),
    }
    assert!(out
        .error
        .as_ref()
        .unwrap()
        .to_string()
        .contains("interrupted at t = "));
    assert_eq!(out.stats.steps, interrupt::CHECK_EVERY);
    assert!((out.rows.time.last().unwrap() - t_stop).abs() < 1e-12);
    assert_eq!(out.rows.displacement.len(), out.rows.time.len());
    // the recorded samples are those of an uninterrupted run
    let short = RunSettings {
        t_end: t_stop,
        ..settings
    };
    let full = simulate(&sys, method, &short, x0, v0).unwrap();
    assert!(full.error.is_none());
    assert_eq!(full.rows.time.len(), out.rows.time.len());
    assert_eq!(full.rows.displacement, out.rows.displacement);
}

/// The impulsive methods poll the flag as the others do.
#[test]
fn impulsive_methods_stop_on_an_interrupt() {
    let _turn = FLAG.lock().unwrap_or_else(|e| e.into_inner());
    use vibroimpact_core::contact::Rigid;
    use vibroimpact_core::impulsive::{EventDriven, MoreauJean};
    let s = LinearStructure::new(
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::zeros(1, 1),
        DMatrix::from_element(1, 1, 100.0),
    )
    .unwrap();
    let gap = Gap {
        dofs: vec![0],
        coefficients: vec![1.0],
        clearance: 0.01,
        side: Side::Both,
        law: Law::Rigid(Rigid::new(0.9).unwrap()),
    };
    let sys = System::new(s, vec![gap], vec![]).unwrap();
    let settings = RunSettings {
        t_end: 1.0,
        dt: 1e-3,
        every: 1,
        record_dofs: vec![0],
        newton: NewtonSettings::default(),
        adaptive: None,
    };
    for method in [
        Method::EventDriven(EventDriven::default()),
        Method::MoreauJean(MoreauJean::default()),
    ] {
        interrupt::request();
        let out = simulate(
            &sys,
            method,
            &settings,
            DVector::zeros(1),
            DVector::from_element(1, 1.0),
        );
        interrupt::clear();
        let out = out.unwrap();
        // at the first poll, after interrupt::CHECK_EVERY committed steps (event-driven: a
        // flight between impacts is one), with the row of that instant
        let t_poll = interrupt::CHECK_EVERY as f64 * 1e-3;
        let t = match out.error {
            Some(SimError::Interrupted { t }) => t,
            ref other => panic!("expected an interrupt, got {other:?}"),
        };
        assert!(t > 0.5 * t_poll && t <= t_poll + 1e-12, "{t}");
        if matches!(method, Method::MoreauJean(_)) {
            assert!((t - t_poll).abs() < 1e-12, "{t}");
        }
        assert_eq!(out.stats.steps, interrupt::CHECK_EVERY);
        assert_eq!(*out.rows.time.last().unwrap(), t);
    }
}
