//! Times the rotor-rub benchmark's case (python/vibroimpact/benchmarks/rotor_rub.py: a
//! Jeffcott rotor rubbing on a linear stator with regularised friction) in the core alone,
//! without Python, by DOP853 at rtol 1e-10 (`RTOL` sets another) or, with `METHOD=newmark`,
//! by Newmark average acceleration at 200 fixed steps a revolution: `cargo run --release
//! --example rotor_bench -p vibroimpact-core`; `REVOLUTIONS` (default 1000) and `RUNS`
//! (default 5) set the work, and the steps, rejections, contacts and the fastest run's time
//! are printed (for callgrind, `RUNS=1`).

use std::f64::consts::{FRAC_PI_2, PI};
use std::time::Instant;

#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

use nalgebra::{DMatrix, DVector};
use vibroimpact_core::contact::{Hertz, Law};
use vibroimpact_core::gap::{FrictionLaw, Gap, Radial, Side};
use vibroimpact_core::integrators::{NewmarkFamily, NewtonSettings};
use vibroimpact_core::settings::Adaptive;
use vibroimpact_core::simulate::{simulate, Method, RunSettings};
use vibroimpact_core::structure::{LinearStructure, Load, LoadHistory};
use vibroimpact_core::system::System;

fn env(name: &str, default: usize) -> usize {
    std::env::var(name).map_or(default, |s| s.parse().expect("a count"))
}

fn main() {
    let spin = 150.0;
    let eye = DMatrix::<f64>::identity(2, 2);
    let st = LinearStructure::new(eye.clone(), &eye * 10.0, &eye * 1e4)
        .unwrap()
        .spinning(None, spin)
        .unwrap();
    let gap = Gap {
        dofs: vec![0, 1],
        coefficients: vec![1.0, 1.0],
        clearance: 1e-4,
        side: Side::Radial(Radial {
            center: [0.0, 0.0],
            friction: 0.05,
            radius: 0.01,
            friction_law: FrictionLaw::Regularised { speed: 0.05 },
            partner: 0,
        }),
        law: Law::Hertz(Hertz::new(1e6, 1.0).unwrap()),
    };
    let unbalance = |dof: usize, phase: f64| Load {
        dofs: vec![dof],
        amplitude: 1e-4 * spin * spin,
        history: LoadHistory::Harmonic {
            frequency: spin / (2.0 * PI),
            phase,
        },
    };
    let loads = vec![unbalance(0, 0.0), unbalance(1, -FRAC_PI_2)];
    let sys = System::new(st, vec![gap], loads).unwrap();
    let period = 2.0 * PI / spin;
    let t_end = env("REVOLUTIONS", 1000) as f64 * period;
    let newmark = match std::env::var("METHOD").as_deref() {
        Ok("newmark") => true,
        Ok("dop853") | Err(_) => false,
        Ok(other) => panic!("METHOD: {other}; expected dop853 or newmark"),
    };
    let rtol = std::env::var("RTOL").map_or(1e-10, |s| s.parse().expect("a tolerance"));
    // the Python API's defaults: dt_min = dt / 1e4, dt_max = t_end / 50
    let (method, settings) = if newmark {
        let settings = RunSettings {
            t_end,
            dt: period / 200.0,
            every: 1_000_000,
            record_dofs: vec![0, 1],
            newton: NewtonSettings::default(),
            adaptive: None,
        };
        (
            Method::Newmark(NewmarkFamily::average_acceleration()),
            settings,
        )
    } else {
        let settings = RunSettings {
            t_end,
            dt: period / 100.0,
            every: 1_000_000,
            record_dofs: vec![0, 1],
            newton: NewtonSettings::default(),
            adaptive: Some(Adaptive {
                rtol,
                atol: 1e-14_f64.min(rtol * 1e-4),
                dt_min: period / 1e6,
                dt_max: t_end / 50.0,
            }),
        };
        (Method::Dop853, settings)
    };
    let mut best = f64::INFINITY;
    for _ in 0..env("RUNS", 5) {
        let t0 = Instant::now();
        let out = simulate(
            &sys,
            method,
            &settings,
            DVector::zeros(2),
            DVector::zeros(2),
        )
        .unwrap();
        best = best.min(t0.elapsed().as_secs_f64());
        assert!(out.error.is_none(), "{:?}", out.error);
        let s = &out.stats;
        println!(
            "steps {} rejected {} contacts {}",
            s.steps,
            s.rejected_steps,
            out.impacts.len()
        );
    }
    println!("fastest {:.2} ms", 1e3 * best);
}
