//! The floor of the benchmark (`vibroimpact bench`): the fixed-step scheme of the paper's SDOF
//! case written as a bare loop — average-acceleration Newmark, Newton on both walls of a
//! bilateral Hertzian gap with hysteresis damping (`K δⁿ (1 + χ δ̇ / v_imp)`, Hertz for
//! `χ = 0`; `v_imp` at the crossing located on the step's cubic Hermite interpolant, as the
//! engine does), every step's `x`, `v`, `a` and contact force stored — and nothing else: no
//! impact table, no energy account, no peaks, no watchers, no step cuts. It takes the same
//! steps as [`crate::simulate::simulate`] (a test compares them), so the ratio of the two
//! times is what the engine's generality costs beyond the scheme's own arithmetic. Not an
//! engine: only for measuring.

use crate::contact::MIN_IMPACT_SPEED;
use crate::interpolation::HermiteSegment;

/// A mass on a spring and damper between two walls at `±clearance`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FloorCase {
    /// kg, N/m, N s/m.
    pub mass: f64,
    pub stiffness: f64,
    pub damping: f64,
    /// m.
    pub clearance: f64,
    /// `K`, N/mⁿ, the exponent `n` and the hysteresis factor `χ`.
    pub contact_stiffness: f64,
    pub exponent: f64,
    pub hysteresis: f64,
    /// Initial velocity, m/s (the mass starts at `x = 0`).
    pub v0: f64,
    pub dt: f64,
    pub steps: usize,
    /// Newton's relative tolerance on the gap coordinate (the engine's default: 1e-10).
    pub rtol: f64,
}

/// Every step's state, from `t = 0`: `steps + 1` values each.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FloorRun {
    pub displacement: Vec<f64>,
    pub velocity: Vec<f64>,
    pub acceleration: Vec<f64>,
    /// Contact force magnitude, N.
    pub force: Vec<f64>,
}

/// Newton's absolute tolerance and iteration limit, as the engine's defaults.
const ATOL: f64 = 1e-15;
const MAX_ITERATIONS: usize = 30;

/// Runs `case`; `None` if Newton does not converge in a step (the floor does not cut steps).
pub fn newmark_sdof(case: &FloorCase) -> Option<FloorRun> {
    let FloorCase {
        mass: m,
        stiffness: k,
        damping: c,
        clearance: d,
        contact_stiffness: kc,
        exponent: n,
        hysteresis: chi,
        v0,
        dt: h,
        steps,
        rtol,
    } = *case;
    // β = 1/4, γ = 1/2: a₀ = 4/h², the gap rate u̇₁ = (2/h) Δu − u̇₀.
    let (a0, c_v) = (4.0 / (h * h), 2.0 / h);
    let w = 1.0 / (k + a0 * m + c_v * c);
    let (mut x, mut v) = (0.0, v0);
    let mut a = -c * v / m;
    // Per wall (+, −): penetration and rate at the start of the step, the approach speed.
    let (mut pen, mut rate, mut v_imp) = ([-d; 2], [v, -v], [0.0; 2]);
    let mut phi = 0.0;
    let mut out = FloorRun {
        displacement: Vec::with_capacity(steps + 1),
        velocity: Vec::with_capacity(steps + 1),
        acceleration: Vec::with_capacity(steps + 1),
        force: Vec::with_capacity(steps + 1),
    };
    let store = |out: &mut FloorRun, x, v, a, f| {
        out.displacement.push(x);
        out.velocity.push(v);
        out.acceleration.push(a);
        out.force.push(f);
    };
    store(&mut out, x, v, a, 0.0);
    for _ in 0..steps {
        let d_tilde = h * v + 0.25 * h * h * a;
        let e_lin = -w * (k * (x + d_tilde) + c * (v + 0.5 * h * a));
        let du_lin = e_lin + d_tilde;
        let mut du = du_lin - w * phi;
        let mut increment_small = false;
        let mut iterations = 0;
        let (mut pen1, mut rate1, mut v_imp1) = ([0.0; 2], [0.0; 2], v_imp);
        let force = loop {
            let (u, u_rate) = (x + du, c_v * du - v);
            let (mut f_u, mut f_total) = (0.0, 0.0);
            phi = 0.0;
            for (j, sign) in [1.0, -1.0].into_iter().enumerate() {
                let (delta, delta_rate) = (sign * u - d, sign * u_rate);
                pen1[j] = delta;
                rate1[j] = delta_rate;
                if delta <= 0.0 {
                    continue;
                }
                if pen[j] <= 0.0 {
                    let seg = HermiteSegment {
                        y0: pen[j],
                        dy0: rate[j],
                        y1: delta,
                        dy1: delta_rate,
                        h,
                    };
                    v_imp1[j] = seg.rate(seg.crossing()).max(MIN_IMPACT_SPEED);
                }
                let root = if n == 1.5 {
                    delta.sqrt()
                } else {
                    delta.powf(n - 1.0)
                };
                let elastic = kc * root * delta;
                let damping = 1.0 + chi / v_imp1[j].max(MIN_IMPACT_SPEED) * delta_rate;
                let f = elastic * damping;
                if f > 0.0 {
                    phi += sign * f;
                    f_total += f;
                    f_u += kc * n * root * damping
                        + c_v * elastic * chi / v_imp1[j].max(MIN_IMPACT_SPEED);
                }
            }
            let r = du - du_lin + w * phi;
            let residual_small = r.abs() <= rtol * u.abs() + ATOL;
            if residual_small && (iterations == 0 || increment_small) {
                break f_total;
            }
            if iterations == MAX_ITERATIONS {
                return None;
            }
            let step = -r / (1.0 + w * f_u);
            du += step;
            increment_small = step.abs() <= rtol * (x + du).abs() + ATOL;
            iterations += 1;
        };
        let e = e_lin - w * phi;
        let a1 = a0 * e;
        x += d_tilde + e;
        v += h * (0.5 * a + 0.5 * a1);
        a = a1;
        pen = pen1;
        rate = [v, -v];
        v_imp = v_imp1;
        store(&mut out, x, v, a, force);
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use nalgebra::{DMatrix, DVector};

    use super::*;
    use crate::contact::{Hysteretic, Law};
    use crate::gap::{Gap, Side};
    use crate::integrators::{NewmarkFamily, NewtonSettings};
    use crate::simulate::{simulate, Method, RunSettings};
    use crate::structure::LinearStructure;
    use crate::system::System;

    /// The floor takes the engine's steps: on the paper's SDOF case (Lankarani–Nikravesh,
    /// ce = 0.9, 0.02 s at 1 µs, nine contacts) and on a damped, sprung variant it agrees
    /// with `simulate` to the last bit when Newton converges to round-off, and to the
    /// tolerance's accumulated effect at the default tolerance.
    #[test]
    fn floor_takes_the_engines_steps() {
        for (k, c, rtol, tol) in [
            (0.0, 0.0, 1e-13, 1e-15),
            (4e5, 30.0, 1e-13, 1e-15),
            (0.0, 0.0, 1e-10, 1e-7),
        ] {
            let law = Hysteretic::new("lankarani-nikravesh", 1.5087e11, 1.5, 0.9).unwrap();
            let case = FloorCase {
                mass: 100.0,
                stiffness: k,
                damping: c,
                clearance: 0.005,
                contact_stiffness: law.stiffness,
                exponent: law.exponent,
                hysteresis: law.hysteresis_factor(),
                v0: 8.0,
                dt: 1e-6,
                steps: 20_000,
                rtol,
            };
            let floor = newmark_sdof(&case).unwrap();
            let one = |v: f64| DMatrix::from_element(1, 1, v);
            let s = LinearStructure::new(one(100.0), one(c), one(k)).unwrap();
            let gap = Gap {
                dofs: vec![0],
                coefficients: vec![1.0],
                clearance: 0.005,
                side: Side::Both,
                law: Law::Hysteretic(law),
            };
            let sys = System::new(s, vec![gap], vec![]).unwrap();
            let settings = RunSettings {
                t_end: 0.02,
                dt: 1e-6,
                every: 1,
                record_dofs: vec![0],
                newton: NewtonSettings {
                    rtol,
                    ..Default::default()
                },
                adaptive: None,
            };
            let method = Method::Newmark(NewmarkFamily::average_acceleration());
            let (x0, v0) = (DVector::zeros(1), DVector::from_element(1, 8.0));
            let ours = simulate(&sys, method, &settings, x0, v0).unwrap();
            assert!(ours.impacts.len() >= 4, "{} contacts", ours.impacts.len());
            let rows = &ours.rows;
            for (a, b) in [
                (&rows.displacement, &floor.displacement),
                (&rows.velocity, &floor.velocity),
                (&rows.acceleration, &floor.acceleration),
                (&rows.gap_force, &floor.force),
            ] {
                assert_eq!(a.len(), b.len());
                let scale = a.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
                let worst = a
                    .iter()
                    .zip(b)
                    .map(|(p, q)| (p - q).abs())
                    .fold(0.0, f64::max);
                assert!(
                    worst <= tol * scale,
                    "k {k}, rtol {rtol}: {worst:e} of {scale:e}"
                );
            }
        }
    }
}
