//! Times the paper's SDOF case (0.02 s at dt = 1 µs) in the core alone, without Python:
//! `cargo run --release --example sdof_bench -p vibroimpact-core`; `METHOD=dop853` times
//! adaptive DOP853 (rtol 1e-8) instead of Newmark, `METHOD=floor` the benchmark's floor
//! (`vibroimpact_core::floor`: the same Newmark steps as a bare loop), `METHOD=precise` precise
//! integration (Adams; `METHOD=precise-pc` its predictor–corrector), `SCHEME=generalized-alpha`
//! generalized-α (ρ∞ = 0.8) instead of average acceleration; `SWEEP=1` times two points of the
//! fixed-step sweep benchmark instead ([`sweep_points`]).

use std::sync::Arc;
use std::time::Instant;

#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

use nalgebra::{DMatrix, DVector};
use vibroimpact_core::contact::{Hertz, Hysteretic, Law};
use vibroimpact_core::floor::{self, FloorCase};
use vibroimpact_core::gap::{Gap, Side};
use vibroimpact_core::integrators::{NewmarkFamily, NewtonSettings, PreciseIntegration};
use vibroimpact_core::settings::Adaptive;
use vibroimpact_core::simulate::{simulate, Method, RunSettings};
use vibroimpact_core::structure::{LinearStructure, Load, LoadHistory};
use vibroimpact_core::sweep::{run_point, Sampling, SweepJob};
use vibroimpact_core::system::System;

fn main() {
    if std::env::var("SWEEP").is_ok() {
        let runs = std::env::var("RUNS").map_or(20, |s| s.parse().unwrap());
        sweep_points(runs);
        return;
    }
    let k = 1.5087e11;
    for law in [
        Law::Hertz(Hertz::new(k, 1.5).unwrap()),
        Law::Hysteretic(Hysteretic::new("lankarani-nikravesh", k, 1.5, 0.9).unwrap()),
    ] {
        let name = law.name();
        let s = LinearStructure::new(
            DMatrix::from_element(1, 1, 100.0),
            DMatrix::zeros(1, 1),
            DMatrix::zeros(1, 1),
        )
        .unwrap();
        let gap = Gap {
            dofs: vec![0],
            coefficients: vec![1.0],
            clearance: std::env::var("CLEARANCE")
                .map(|s| s.parse().unwrap())
                .unwrap_or(0.005),
            side: Side::Both,
            law,
        };
        let runs: usize = std::env::var("RUNS")
            .map(|s| s.parse().unwrap())
            .unwrap_or(200);
        if std::env::var("METHOD").is_ok_and(|m| m == "floor") {
            let (k, n, chi) = match &gap.law {
                Law::Hertz(l) => (l.stiffness, l.exponent, 0.0),
                Law::Hysteretic(l) => (l.stiffness, l.exponent, l.hysteresis_factor()),
                _ => unreachable!(),
            };
            let case = FloorCase {
                mass: 100.0,
                stiffness: 0.0,
                damping: 0.0,
                clearance: gap.clearance,
                contact_stiffness: k,
                exponent: n,
                hysteresis: chi,
                v0: 8.0,
                dt: 1e-6,
                steps: 20_000,
                rtol: 1e-10,
            };
            let mut times: Vec<f64> = (0..runs)
                .map(|_| {
                    let t0 = Instant::now();
                    assert!(floor::newmark_sdof(&case).is_some());
                    t0.elapsed().as_secs_f64()
                })
                .collect();
            times.sort_by(|a, b| a.partial_cmp(b).unwrap());
            println!(
                "{name} floor: median {:.3} ms",
                times[times.len() / 2] * 1e3
            );
            continue;
        }
        let sys = System::new(s, vec![gap], vec![]).unwrap();
        let method_name = std::env::var("METHOD").unwrap_or_default();
        let dop853 = method_name == "dop853";
        let (method, adaptive) = if let Some(pc) = match method_name.as_str() {
            "precise" => Some(false),
            "precise-pc" => Some(true),
            _ => None,
        } {
            let variant = PreciseIntegration {
                predictor_corrector: pc,
            };
            (Method::Precise(variant), None)
        } else if dop853 {
            let tol = Adaptive {
                rtol: 1e-8,
                atol: 1e-12,
                dt_min: 1e-12,
                dt_max: 1e-3,
            };
            (Method::Dop853, Some(tol))
        } else {
            // SCHEME=generalized-alpha: ρ∞ = 0.8, as `vibroimpact bench`'s integrator table
            let scheme = if std::env::var("SCHEME").is_ok_and(|s| s == "generalized-alpha") {
                let (alpha_m, alpha_f) = (0.6 / 1.8, 0.8 / 1.8);
                NewmarkFamily {
                    alpha_m,
                    alpha_f,
                    gamma: 0.5 - alpha_m + alpha_f,
                    beta: 0.25 * (1.0 - alpha_m + alpha_f).powi(2),
                }
            } else {
                NewmarkFamily::average_acceleration()
            };
            (Method::Newmark(scheme), None)
        };
        let settings = RunSettings {
            t_end: 0.02,
            dt: if dop853 { 1e-5 } else { 1e-6 },
            every: 1,
            record_dofs: vec![0],
            newton: NewtonSettings::default(),
            adaptive,
        };
        let mut times = vec![];
        let mut stats = None;
        for _ in 0..runs {
            let t0 = Instant::now();
            let out = simulate(
                &sys,
                method,
                &settings,
                DVector::zeros(1),
                DVector::from_element(1, 8.0),
            )
            .unwrap();
            times.push(t0.elapsed().as_secs_f64());
            assert!(out.error.is_none());
            stats = Some(out.stats);
        }
        times.sort_by(|a, b| a.partial_cmp(b).unwrap());
        let stats = stats.unwrap();
        println!(
            "{name}: median {:.3} ms, {} steps, {} rejected",
            times[times.len() / 2] * 1e3,
            stats.steps,
            stats.rejected_steps
        );
    }
}

/// `SWEEP=1`: one point of the fixed-step sweep benchmark
/// (`vibroimpact.benchmarks.sweep.fixed_step_sweep_benchmark`) per forcing frequency of 20
/// and 50 Hz: the 1-DOF damped oscillator (1 kg, 20 Hz, 5 %, 10 N harmonic) with a
/// Lankarani–Nikravesh stop 1 mm away, fixed-step Newmark at dt = 1e-4 s, 200 transient and
/// 100 sampled periods, reduced while it runs by the sweep's observer (no rows kept).
fn sweep_points(runs: usize) {
    let law = Hysteretic::new("lankarani-nikravesh", 1.5e10, 1.5, 0.8).unwrap();
    let s = LinearStructure::new(
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::from_element(1, 1, 12.566371),
        DMatrix::from_element(1, 1, 15791.367),
    )
    .unwrap();
    let gap = Gap {
        dofs: vec![0],
        coefficients: vec![1.0],
        clearance: 0.001,
        side: Side::Positive,
        law: Law::Hysteretic(law),
    };
    let mut times = vec![];
    let mut steps = 0;
    for _ in 0..runs {
        let t0 = Instant::now();
        steps = 0;
        for frequency in [20.0, 50.0] {
            let load = Load {
                dofs: vec![0],
                amplitude: 10.0,
                history: LoadHistory::Harmonic {
                    frequency,
                    phase: 0.0,
                },
            };
            let sys = System::new(s.clone(), vec![gap.clone()], vec![load]).unwrap();
            let job = SweepJob {
                system: Arc::new(sys),
                method: Method::Newmark(NewmarkFamily::average_acceleration()),
                settings: RunSettings {
                    t_end: 0.0,
                    dt: 1e-4,
                    every: 1,
                    record_dofs: vec![0],
                    newton: NewtonSettings::default(),
                    adaptive: None,
                },
                x0: DVector::zeros(1),
                v0: DVector::zeros(1),
                sampling: Sampling {
                    period: 1.0 / frequency,
                    transient: 200,
                    samples: 100,
                    per_period: 1,
                    dofs: vec![0],
                    max_impacts: 10,
                },
            };
            let point = run_point(&job, None);
            assert!(point.error.is_none());
            steps += point.stats.steps;
        }
        times.push(t0.elapsed().as_secs_f64());
    }
    times.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let median = times[times.len() / 2];
    println!(
        "sweep points: median {:.3} ms, {steps} steps, {:.1} ns a step",
        median * 1e3,
        median / steps as f64 * 1e9
    );
}
