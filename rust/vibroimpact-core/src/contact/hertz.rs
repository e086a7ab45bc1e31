use super::catalog::check_parameter;
use super::{ContactForce, ContactLaw};
use crate::error::SimError;

/// Hertz contact, `F = K δⁿ` (Hertz 1882; paper eq. 3). Elastic: no energy is lost.
///
/// With a series `compliance` `c > 0` (m/N; [`Hertz::in_series`]) the law acts through a
/// linear spring: the gap's penetration `δ` splits into the law's `δ_l` and the spring's
/// `c F`, `δ = δ_l + c K δ_lⁿ`, and `F = K δ_lⁿ`, `∂F/∂δ = F'(δ_l)/(1 + c F'(δ_l))`. This is
/// the contact seen by the generalized coordinates of an FE model whose contact node has a
/// part in the null space of its mass (vibroimpact.fe.condensation: the massless modes answer
/// a force statically, as a spring of that compliance).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hertz {
    /// Contact stiffness `K`, N/mⁿ.
    pub stiffness: f64,
    /// Exponent `n` (1.5 for point contact).
    pub exponent: f64,
    /// Compliance `c ≥ 0` of a linear spring in series with the law, m/N (0: none).
    pub compliance: f64,
}

impl Hertz {
    pub fn new(stiffness: f64, exponent: f64) -> Result<Self, SimError> {
        check_parameter("hertz", "stiffness", stiffness)?;
        check_parameter("hertz", "exponent", exponent)?;
        Ok(Self {
            stiffness,
            exponent,
            compliance: 0.0,
        })
    }

    /// The law in series with a linear spring of compliance `c ≥ 0`, m/N.
    pub fn in_series(self, compliance: f64) -> Result<Self, SimError> {
        check_parameter("hertz", "compliance", compliance)?;
        Ok(Self { compliance, ..self })
    }

    /// The law's own penetration `δ_l` at the gap's penetration `δ > 0`: the root of
    /// `δ_l + c K δ_lⁿ = δ`, by Newton from an upper bound (the function is convex and
    /// increasing, so the iterates decrease monotonically onto the root).
    fn law_penetration(&self, penetration: f64) -> f64 {
        let (c, k, n) = (self.compliance, self.stiffness, self.exponent);
        let mut x = penetration.min((penetration / (c * k)).powf(1.0 / n));
        for _ in 0..100 {
            let f = power_law(k, n, x);
            let step = (x + c * f.force - penetration) / (1.0 + c * f.d_penetration);
            let next = x - step;
            if !(next > 0.0 && next < x) {
                break;
            }
            x = next;
            if step <= 1e-15 * x {
                break;
            }
        }
        x
    }
}

/// `K δⁿ` with its derivative and potential `K δⁿ⁺¹/(n+1)`: the elastic backbone shared by
/// the Hertzian laws, for `δ > 0` (one `powf`; a square root for Hertz's n = 3/2, none for a
/// linear spring).
#[inline]
pub(crate) fn power_law(stiffness: f64, exponent: f64, penetration: f64) -> ContactForce {
    let pow_nm1 = if exponent == 1.5 {
        penetration.sqrt()
    } else if exponent == 1.0 {
        1.0
    } else {
        penetration.powf(exponent - 1.0)
    };
    let force = stiffness * pow_nm1 * penetration;
    ContactForce {
        force,
        d_penetration: stiffness * exponent * pow_nm1,
        d_rate: 0.0,
        elastic: force,
        potential: force * penetration / (exponent + 1.0),
    }
}

impl ContactLaw for Hertz {
    #[inline]
    fn evaluate(&self, penetration: f64, _rate: f64, _impact_speed: f64) -> ContactForce {
        if self.compliance == 0.0 {
            return power_law(self.stiffness, self.exponent, penetration);
        }
        let own = power_law(
            self.stiffness,
            self.exponent,
            self.law_penetration(penetration),
        );
        let spring = self.compliance * own.force;
        ContactForce {
            d_penetration: own.d_penetration / (1.0 + self.compliance * own.d_penetration),
            potential: own.potential + 0.5 * spring * own.force,
            ..own
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// In series with a spring, the force at `δ = δ_l + c F(δ_l)` is `F(δ_l)`; the tangent
    /// is the derivative of that force and the potential its integral (finite differences,
    /// Simpson), and `n = 1` gives the two springs' `K/(1 + cK)`.
    #[test]
    fn a_series_spring_splits_the_penetration() {
        let law = Hertz::new(2e9, 1.5).unwrap().in_series(4e-9).unwrap();
        for own in [1e-9, 3e-7, 2e-5] {
            let plain = power_law(2e9, 1.5, own);
            let total = own + 4e-9 * plain.force;
            let f = law.evaluate(total, 0.0, 0.0);
            assert!((f.force / plain.force - 1.0).abs() < 1e-13, "{own}");
            let h = 1e-6 * total;
            let slope = (law.evaluate(total + h, 0.0, 0.0).force
                - law.evaluate(total - h, 0.0, 0.0).force)
                / (2.0 * h);
            assert!((slope / f.d_penetration - 1.0).abs() < 1e-7, "{own}");
            let m = 2000;
            let w = total / m as f64;
            let integral: f64 = (0..=m)
                .map(|i| {
                    let weight = if i == 0 || i == m {
                        1.0
                    } else {
                        2.0 + 2.0 * (i % 2) as f64
                    };
                    let x = i as f64 * w;
                    weight
                        * if x > 0.0 {
                            law.evaluate(x, 0.0, 0.0).force
                        } else {
                            0.0
                        }
                })
                .sum::<f64>()
                * w
                / 3.0;
            assert!((integral / f.potential - 1.0).abs() < 1e-6, "{own}");
        }
        let linear = Hertz::new(5e7, 1.0).unwrap().in_series(1e-8).unwrap();
        let f = linear.evaluate(1e-6, 0.0, 0.0);
        assert!((f.force / (5e7 / 1.5 * 1e-6) - 1.0).abs() < 1e-14);
        assert!(Hertz::new(1.0, 1.5).unwrap().in_series(-1.0).is_err());
    }
}
