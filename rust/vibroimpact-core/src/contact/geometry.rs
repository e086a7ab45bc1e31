//! Hertzian contact stiffness from geometry and material (paper eq. 4; Johnson, Contact
//! Mechanics, 1985, §4.2): `K = (4/3) E* √R*`, `1/E* = (1−ν1²)/E1 + (1−ν2²)/E2`.

use crate::error::{invalid, SimError};

/// Elastic constants of one body.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Material {
    /// Young's modulus `E`, Pa.
    pub youngs_modulus: f64,
    /// Poisson's ratio `ν`.
    pub poisson: f64,
}

impl Material {
    fn check(&self, which: &str) -> Result<(), SimError> {
        if !(self.youngs_modulus.is_finite() && self.youngs_modulus > 0.0) {
            return invalid(format!(
                "geometry: {which} youngs_modulus = {} is not valid; expected a value > 0 in Pa",
                self.youngs_modulus
            ));
        }
        if !(self.poisson > -1.0 && self.poisson < 0.5) {
            return invalid(format!(
                "geometry: {which} poisson = {} is not valid; expected -1 < poisson < 0.5",
                self.poisson
            ));
        }
        Ok(())
    }
}

/// Shape of the two surfaces that touch.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ContactGeometry {
    /// Two spheres touching from outside: `R* = R1 R2 / (R1 + R2)`.
    SphereSphere { radius1: f64, radius2: f64 },
    /// A ball inside a spherical socket (paper eq. 4): `R* = R1 R2 / |R1 − R2|`.
    BallInSocket { radius1: f64, radius2: f64 },
    /// A sphere on a flat surface: `R* = R`.
    SpherePlane { radius: f64 },
}

impl ContactGeometry {
    /// Effective radius `R*`, m.
    pub fn effective_radius(&self) -> Result<f64, SimError> {
        let positive = |name: &str, r: f64| -> Result<(), SimError> {
            if r.is_finite() && r > 0.0 {
                Ok(())
            } else {
                invalid(format!(
                    "geometry: {name} = {r} is not valid; expected a radius > 0 in m"
                ))
            }
        };
        match *self {
            ContactGeometry::SphereSphere { radius1, radius2 } => {
                positive("radius1", radius1)?;
                positive("radius2", radius2)?;
                Ok(radius1 * radius2 / (radius1 + radius2))
            }
            ContactGeometry::BallInSocket { radius1, radius2 } => {
                positive("radius1", radius1)?;
                positive("radius2", radius2)?;
                if radius1 == radius2 {
                    return invalid(format!(
                        "geometry: radius1 = radius2 = {radius1} is not valid for ball-in-socket; \
                         expected different radii (conformal contact is not Hertzian)"
                    ));
                }
                Ok(radius1 * radius2 / (radius1 - radius2).abs())
            }
            ContactGeometry::SpherePlane { radius } => {
                positive("radius", radius)?;
                Ok(radius)
            }
        }
    }

    /// Hertz stiffness `K = (4/3) E* √R*`, N/m^1.5.
    pub fn stiffness(&self, body1: Material, body2: Material) -> Result<f64, SimError> {
        body1.check("body 1")?;
        body2.check("body 2")?;
        let inv_e = (1.0 - body1.poisson.powi(2)) / body1.youngs_modulus
            + (1.0 - body2.poisson.powi(2)) / body2.youngs_modulus;
        Ok(4.0 / 3.0 / inv_e * self.effective_radius()?.sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The paper's eq. 4 written with σ = (1 − ν²)/(π E): K = 4/(3π(σ1+σ2)) √R*.
    #[test]
    fn ball_in_socket_matches_paper_equation_4() {
        let steel = Material {
            youngs_modulus: 207e9,
            poisson: 0.3,
        };
        let g = ContactGeometry::BallInSocket {
            radius1: 0.010,
            radius2: 0.0099,
        };
        let sigma = (1.0 - 0.3_f64.powi(2)) / (std::f64::consts::PI * 207e9);
        let r = 0.010 * 0.0099 / (0.010 - 0.0099);
        let paper = 4.0 / (3.0 * std::f64::consts::PI * 2.0 * sigma) * f64::sqrt(r);
        let k = g.stiffness(steel, steel).unwrap();
        assert!((k - paper).abs() <= 1e-12 * paper);
        assert!((k - 1.5087e11).abs() < 1e8, "{k}");
    }

    #[test]
    fn bad_geometry_is_refused() {
        let steel = Material {
            youngs_modulus: 207e9,
            poisson: 0.3,
        };
        let g = ContactGeometry::SpherePlane { radius: -1.0 };
        assert!(g.stiffness(steel, steel).is_err());
        let bad = Material {
            youngs_modulus: 207e9,
            poisson: 0.7,
        };
        let g = ContactGeometry::SpherePlane { radius: 0.01 };
        assert!(g.stiffness(steel, bad).is_err());
    }
}
