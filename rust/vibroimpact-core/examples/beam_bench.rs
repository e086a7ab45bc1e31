//! Times a hollow-shaft-like beam (20 Euler–Bernoulli elements, 42 DOFs, consistent mass,
//! sliders with Hertz contact at both ends and the middle, harmonic load at every node) in
//! the core alone: `cargo run --release --example beam_bench -p vibroimpact-core`
//! (env `T_END`, s, default 0.1). For instruction counts run it under callgrind.

use std::time::Instant;

#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

use nalgebra::{DMatrix, DVector};
use vibroimpact_core::contact::{Hertz, Law};
use vibroimpact_core::gap::{Gap, Side};
use vibroimpact_core::integrators::{NewmarkFamily, NewtonSettings};
use vibroimpact_core::simulate::{simulate, Method, RunSettings};
use vibroimpact_core::structure::{LinearStructure, Load, LoadHistory};
use vibroimpact_core::system::System;

fn main() {
    let (elements, length) = (20, 1.0);
    let (e, rho) = (207e9, 34410.0);
    let (ro, ri) = (0.095_f64, 0.090_f64);
    let area = std::f64::consts::PI * (ro * ro - ri * ri);
    let inertia = std::f64::consts::PI / 4.0 * (ro.powi(4) - ri.powi(4));
    let l = length / elements as f64;
    let n = 2 * (elements + 1);
    let (mut k, mut m) = (DMatrix::zeros(n, n), DMatrix::zeros(n, n));
    let ke = DMatrix::from_row_slice(
        4,
        4,
        &[
            12.0,
            6.0 * l,
            -12.0,
            6.0 * l, //
            6.0 * l,
            4.0 * l * l,
            -6.0 * l,
            2.0 * l * l, //
            -12.0,
            -6.0 * l,
            12.0,
            -6.0 * l, //
            6.0 * l,
            2.0 * l * l,
            -6.0 * l,
            4.0 * l * l,
        ],
    ) * (e * inertia / l.powi(3));
    let me = DMatrix::from_row_slice(
        4,
        4,
        &[
            156.0,
            22.0 * l,
            54.0,
            -13.0 * l, //
            22.0 * l,
            4.0 * l * l,
            13.0 * l,
            -3.0 * l * l, //
            54.0,
            13.0 * l,
            156.0,
            -22.0 * l, //
            -13.0 * l,
            -3.0 * l * l,
            -22.0 * l,
            4.0 * l * l,
        ],
    ) * (rho * area * l / 420.0);
    for el in 0..elements {
        for a in 0..4 {
            for b in 0..4 {
                k[(2 * el + a, 2 * el + b)] += ke[(a, b)];
                m[(2 * el + a, 2 * el + b)] += me[(a, b)];
            }
        }
    }
    let s = LinearStructure::new(m, DMatrix::zeros(n, n), k).unwrap();
    let law = Law::Hertz(Hertz::new(1.509e11, 1.5).unwrap());
    let gaps = [0, elements / 2, elements]
        .iter()
        .map(|&node| Gap {
            dofs: vec![2 * node],
            coefficients: vec![1.0],
            clearance: 0.003,
            side: Side::Both,
            law: law.clone(),
        })
        .collect();
    let load = Load {
        dofs: (0..=elements).map(|i| 2 * i).collect(),
        amplitude: 100.0,
        history: LoadHistory::Harmonic {
            frequency: 10.0,
            phase: 0.0,
        },
    };
    let sys = System::new(s, gaps, vec![load]).unwrap();
    let t_end = std::env::var("T_END")
        .map(|s| s.parse().unwrap())
        .unwrap_or(0.1);
    let settings = RunSettings {
        t_end,
        dt: 1e-6,
        every: 1000,
        record_dofs: vec![0, n / 2 - 1, n - 2],
        newton: NewtonSettings::default(),
        adaptive: None,
    };
    let t0 = Instant::now();
    let out = simulate(
        &sys,
        Method::Newmark(NewmarkFamily::average_acceleration()),
        &settings,
        DVector::zeros(n),
        DVector::zeros(n),
    )
    .unwrap();
    let wall = t0.elapsed().as_secs_f64();
    assert!(out.error.is_none());
    println!(
        "{} steps, {:.3} us/step, peak |x| {:?}",
        out.stats.steps,
        wall / out.stats.steps as f64 * 1e6,
        out.max_abs_displacement
    );
}
