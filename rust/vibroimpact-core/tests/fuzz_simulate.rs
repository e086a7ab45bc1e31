//! Fuzz-style property test of the core's entry point: random small models (1–3 DOFs, random
//! masses, springs, dampers, gaps, laws, loads, step sizes, methods) never make `simulate`
//! panic. It returns either `Err(InvalidModel)` or an output whose error, if any, explains a
//! partial result, and whose recorded arrays are consistent and finite.

use nalgebra::{DMatrix, DVector};
use std::sync::atomic::{AtomicUsize, Ordering};

use proptest::prelude::*;
use vibroimpact_core::contact::{Hertz, Hysteretic, KelvinVoigt, Law};
use vibroimpact_core::gap::{Gap, Side};
use vibroimpact_core::integrators::{Bathe, NewmarkFamily, NewtonSettings, PreciseIntegration};
use vibroimpact_core::settings::Adaptive;
use vibroimpact_core::simulate::{simulate, Method, RunSettings};
use vibroimpact_core::structure::{LinearStructure, Load, LoadHistory};
use vibroimpact_core::system::System;
use vibroimpact_core::SimError;

#[derive(Debug, Clone)]
struct GapSpec {
    dof: usize,
    other: Option<usize>,
    coefficient: f64,
    clearance: f64,
    side: u8,
    law: u8,
    stiffness: f64,
    exponent: f64,
    restitution: f64,
}

fn gap_spec() -> impl Strategy<Value = GapSpec> {
    (
        0usize..3,
        proptest::option::of(0usize..3),
        prop_oneof![Just(1.0), Just(-1.0), -2.0..2.0f64],
        prop_oneof![4 => Just(0.0), 14 => 0.0..0.01f64, 1 => Just(-1e-3)],
        0u8..3,
        0u8..4,
        prop_oneof![18 => 1e3..1e12f64, 1 => Just(0.0), 1 => Just(f64::NAN)],
        prop_oneof![Just(1.0), Just(1.5), 1.0..3.0f64],
        prop_oneof![4 => Just(1.0), 14 => 0.05..1.0f64, 1 => Just(0.0), 1 => Just(1.5)],
    )
        .prop_map(
            |(dof, other, coefficient, clearance, side, law, stiffness, exponent, restitution)| {
                GapSpec {
                    dof,
                    other,
                    coefficient,
                    clearance,
                    side,
                    law,
                    stiffness,
                    exponent,
                    restitution,
                }
            },
        )
}

fn law(g: &GapSpec) -> Option<Law> {
    Some(match g.law {
        0 => Law::Hertz(Hertz::new(g.stiffness, g.exponent).ok()?),
        1 => Law::KelvinVoigt(KelvinVoigt::new(g.stiffness, g.stiffness.sqrt()).ok()?),
        2 => Law::Hysteretic(
            Hysteretic::new(
                "lankarani-nikravesh",
                g.stiffness,
                g.exponent,
                g.restitution,
            )
            .ok()?,
        ),
        _ => {
            Law::Hysteretic(Hysteretic::new("flores", g.stiffness, g.exponent, g.restitution).ok()?)
        }
    })
}

#[derive(Debug, Clone)]
struct Case {
    n: usize,
    mass: Vec<f64>,
    stiffness: Vec<f64>,
    damping: Vec<f64>,
    gaps: Vec<GapSpec>,
    load: Option<(usize, f64, f64)>,
    x0: Vec<f64>,
    v0: Vec<f64>,
    t_end: f64,
    steps: f64,
    method: u8,
    adaptive: bool,
    max_step_cuts: usize,
}

fn case() -> impl Strategy<Value = Case> {
    (1usize..=3).prop_flat_map(|n| {
        (
            Just(n),
            proptest::collection::vec(
                prop_oneof![18 => 1e-3..1e3f64, 1 => Just(0.0), 1 => Just(-1.0)],
                n,
            ),
            proptest::collection::vec(prop_oneof![0.0..1e8f64, Just(0.0)], n),
            proptest::collection::vec(prop_oneof![0.0..1e3f64, Just(0.0)], n),
            proptest::collection::vec(gap_spec(), 0..=3),
            proptest::option::of((0usize..3, -1e4..1e4f64, 0.0..1e3f64)),
            proptest::collection::vec(-1e-2..1e-2f64, n),
            proptest::collection::vec(-10.0..10.0f64, n),
            prop_oneof![18 => 1e-4..1e-2f64, 1 => Just(0.0), 1 => Just(-1.0)],
            prop_oneof![19 => 1.0..600.0f64, 1 => Just(0.5)],
            (0u8..5, any::<bool>(), 0usize..6),
        )
            .prop_map(
                |(n, mass, stiffness, damping, gaps, load, x0, v0, t_end, steps, (m, a, c))| Case {
                    n,
                    mass,
                    stiffness,
                    damping,
                    gaps,
                    load,
                    x0,
                    v0,
                    t_end,
                    steps,
                    method: m,
                    adaptive: a,
                    max_step_cuts: c,
                },
            )
    })
}

/// A chain of masses with springs and dampers to ground and between neighbours.
fn chain(values: &[f64], n: usize, ground: bool) -> DMatrix<f64> {
    let mut m = DMatrix::zeros(n, n);
    for (i, &v) in values.iter().enumerate() {
        if ground || i == 0 {
            m[(i, i)] += v;
        }
        if i + 1 < n {
            m[(i, i)] += v;
            m[(i + 1, i + 1)] += v;
            m[(i, i + 1)] -= v;
            m[(i + 1, i)] -= v;
        }
    }
    m
}

/// Cases that reached `simulate` with a valid model and ran.
static RAN: AtomicUsize = AtomicUsize::new(0);

fn run_case(c: &Case) -> Result<(), TestCaseError> {
    let n = c.n;
    let Ok(structure) = LinearStructure::new(
        DMatrix::from_diagonal(&DVector::from_vec(c.mass.clone())),
        chain(&c.damping, n, true),
        chain(&c.stiffness, n, false),
    ) else {
        if std::env::var_os("FUZZ_DEBUG").is_some() {
            eprintln!("structure refused");
        }
        return Ok(()); // refused: that is allowed
    };
    let mut gaps = Vec::new();
    for g in &c.gaps {
        let Some(law) = law(g) else {
            if std::env::var_os("FUZZ_DEBUG").is_some() {
                eprintln!("law refused: {g:?}");
            }
            return Ok(());
        };
        // DOF indices mostly in range (one case in 8 out of range, refused)
        let wrap = |d: usize| if c.steps as usize % 8 == 7 { d } else { d % n };
        let (dofs, coefficients) = match g.other.map(wrap) {
            Some(o) if o != wrap(g.dof) => (vec![wrap(g.dof), o], vec![g.coefficient, -1.0]),
            _ => (vec![wrap(g.dof)], vec![g.coefficient]),
        };
        let side = [Side::Positive, Side::Negative, Side::Both][g.side as usize];
        gaps.push(Gap {
            dofs,
            coefficients,
            clearance: g.clearance,
            side,
            law,
        });
    }
    let loads = c
        .load
        .iter()
        .map(|&(dof, amplitude, frequency)| Load {
            dofs: vec![dof % n],
            amplitude,
            history: LoadHistory::Harmonic {
                frequency,
                phase: 0.0,
            },
        })
        .collect();
    let sys = match System::new(structure, gaps, loads) {
        Ok(s) => s,
        Err(SimError::InvalidModel(msg)) => {
            if std::env::var_os("FUZZ_DEBUG").is_some() {
                eprintln!("System::new refused: {msg}");
            }
            return Ok(());
        }
        Err(e) => return Err(TestCaseError::fail(format!("System::new: {e:?}"))),
    };
    let method = match c.method {
        0 => Method::Newmark(NewmarkFamily::average_acceleration()),
        1 => Method::GeneralizedAlpha(NewmarkFamily {
            beta: 0.3025,
            gamma: 0.6,
            alpha_m: -0.1,
            alpha_f: 0.1,
        }),
        2 => Method::Precise(PreciseIntegration {
            predictor_corrector: false,
        }),
        3 => Method::Precise(PreciseIntegration {
            predictor_corrector: true,
        }),
        _ => Method::Bathe(Bathe::default()),
    };
    let dt = c.t_end / c.steps;
    let settings = RunSettings {
        t_end: c.t_end,
        dt,
        every: 1 + (c.steps as usize) % 3,
        record_dofs: (0..n).collect(),
        newton: NewtonSettings {
            max_step_cuts: c.max_step_cuts,
            ..NewtonSettings::default()
        },
        adaptive: (c.adaptive && c.method < 2).then_some(Adaptive {
            rtol: 1e-4,
            atol: 1e-9,
            dt_min: dt / 64.0,
            dt_max: (dt * 4.0).min(c.t_end),
        }),
    };
    let x0 = DVector::from_vec(c.x0.clone());
    let v0 = DVector::from_vec(c.v0.clone());
    match simulate(&sys, method, &settings, x0, v0) {
        Err(SimError::InvalidModel(msg)) => {
            if std::env::var_os("FUZZ_DEBUG").is_some() {
                eprintln!("simulate refused: {msg}");
            }
            prop_assert!(!msg.is_empty());
        }
        Err(e) => return Err(TestCaseError::fail(format!("simulate: Err({e:?})"))),
        Ok(out) => {
            RAN.fetch_add(1, Ordering::Relaxed);
            let nt = out.rows.time.len();
            prop_assert!(nt >= 1);
            prop_assert_eq!(out.rows.displacement.len(), nt * n);
            prop_assert_eq!(out.rows.gap_force.len(), nt * sys.gaps.len());
            prop_assert!(out.rows.time.windows(2).all(|w| w[0] <= w[1]));
            prop_assert!(out.rows.displacement.iter().all(|v| v.is_finite()));
            prop_assert!(
                out.rows.gap_force.iter().all(|&f| f >= 0.0),
                "a tensile contact force"
            );
            match &out.error {
                None => prop_assert!((out.rows.time[nt - 1] - c.t_end).abs() <= 1e-9 * c.t_end),
                Some(e) => prop_assert!(!e.to_string().contains('\n')),
            }
        }
    }
    Ok(())
}

#[test]
fn simulate_never_panics_on_small_random_models() {
    // FUZZ_CASES=N for a longer hunt; 64 in CI
    let cases = std::env::var("FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(64);
    let config = ProptestConfig {
        cases,
        failure_persistence: None,
        ..ProptestConfig::default()
    };
    let mut runner = proptest::test_runner::TestRunner::new(config);
    runner.run(&case(), |c| run_case(&c)).unwrap();
    // most cases are valid models that really run (the rest exercise the refusals)
    let ran = RAN.load(Ordering::Relaxed);
    assert!(ran >= cases as usize / 4, "only {ran} of {cases} cases ran");
    if std::env::var_os("FUZZ_DEBUG").is_some() {
        eprintln!("{ran} of {cases} cases ran");
    }
}
