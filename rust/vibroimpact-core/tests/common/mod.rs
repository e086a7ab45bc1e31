//! What several integration tests build and measure: a one-DOF oscillator, its run with every
//! step recorded, and the largest error of its displacement against a closed form.

// Each test crate uses the part it needs.
#![allow(dead_code)]

use nalgebra::{DMatrix, DVector};
use vibroimpact_core::gap::Gap;
use vibroimpact_core::integrators::NewtonSettings;
use vibroimpact_core::simulate::{simulate, Method, RunOutput, RunSettings};
use vibroimpact_core::structure::{LinearStructure, Load};
use vibroimpact_core::system::System;

/// `m ẍ + c ẋ + k x = Σ loads + gap forces` on one DOF (kg, N s/m, N/m).
pub fn sdof(mass: f64, damping: f64, stiffness: f64, gaps: Vec<Gap>, loads: Vec<Load>) -> System {
    let s = LinearStructure::new(
        DMatrix::from_element(1, 1, mass),
        DMatrix::from_element(1, 1, damping),
        DMatrix::from_element(1, 1, stiffness),
    )
    .unwrap();
    System::new(s, gaps, loads).unwrap()
}

/// A run to `t_end` at fixed `dt`, every step of DOF 0 recorded.
pub fn settings(t_end: f64, dt: f64) -> RunSettings {
    RunSettings {
        t_end,
        dt,
        every: 1,
        record_dofs: vec![0],
        newton: NewtonSettings::default(),
        adaptive: None,
    }
}

/// A one-DOF run at fixed `dt` from `x0`, `v0`, every step recorded.
pub fn run(sys: &System, method: Method, t_end: f64, dt: f64, x0: f64, v0: f64) -> RunOutput {
    simulate(
        sys,
        method,
        &settings(t_end, dt),
        DVector::from_element(1, x0),
        DVector::from_element(1, v0),
    )
    .unwrap()
}

/// `max_t |x(t) − exact(t)|` over the recorded rows of a one-DOF run, m.
pub fn largest_displacement_error(out: &RunOutput, exact: impl Fn(f64) -> f64) -> f64 {
    out.rows
        .time
        .iter()
        .zip(&out.rows.displacement)
        .map(|(&t, &x)| (x - exact(t)).abs())
        .fold(0.0, f64::max)
}
