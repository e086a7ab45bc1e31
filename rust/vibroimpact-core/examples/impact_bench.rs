//! Times the event-driven method on the classic impact oscillator (1 Hz, 5 % damping, a rigid
//! stop at 5 mm with e = 0.8, forced at 1.5 Hz; tests/test_impulsive_driver.py) in the core
//! alone: `cargo run --release --example impact_bench -p vibroimpact-core`; `STEPS` steps of
//! 2 ms (default 50 000), `RUNS` runs (default 20).

use std::time::Instant;

#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

use nalgebra::{DMatrix, DVector};
use vibroimpact_core::contact::{Law, Rigid};
use vibroimpact_core::gap::{Gap, Side};
use vibroimpact_core::impulsive::EventDriven;
use vibroimpact_core::integrators::NewtonSettings;
use vibroimpact_core::simulate::{simulate, Method, RunSettings};
use vibroimpact_core::structure::{LinearStructure, Load, LoadHistory};
use vibroimpact_core::system::System;

fn env(name: &str, default: usize) -> usize {
    std::env::var(name).map_or(default, |s| s.parse().unwrap())
}

fn main() {
    let k = (2.0 * std::f64::consts::PI).powi(2);
    let s = LinearStructure::new(
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::from_element(1, 1, 0.1 * k.sqrt()),
        DMatrix::from_element(1, 1, k),
    )
    .unwrap();
    let gap = Gap {
        dofs: vec![0],
        coefficients: vec![1.0],
        clearance: 0.005,
        side: Side::Positive,
        law: Law::Rigid(Rigid::new(0.8).unwrap()),
    };
    let load = Load {
        dofs: vec![0],
        amplitude: 1.0,
        history: LoadHistory::Harmonic {
            frequency: 1.5,
            phase: 0.0,
        },
    };
    let sys = System::new(s, vec![gap], vec![load]).unwrap();
    let dt = 2e-3;
    let steps = env("STEPS", 50_000);
    let settings = RunSettings {
        t_end: steps as f64 * dt,
        dt,
        every: 1,
        record_dofs: vec![0],
        newton: NewtonSettings::default(),
        adaptive: None,
    };
    let mut times = vec![];
    let mut impacts = 0;
    for _ in 0..env("RUNS", 20) {
        let t0 = Instant::now();
        let out = simulate(
            &sys,
            Method::EventDriven(EventDriven::default()),
            &settings,
            DVector::zeros(1),
            DVector::zeros(1),
        )
        .unwrap();
        times.push(t0.elapsed().as_secs_f64());
        assert!(out.error.is_none());
        impacts = out.impacts.len();
    }
    times.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let median = times[times.len() / 2];
    println!(
        "event-driven: median {:.3} ms, {steps} steps ({:.3} us a step), {impacts} impacts",
        median * 1e3,
        median / steps as f64 * 1e6
    );
}
