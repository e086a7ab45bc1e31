//! Contact stiffness from geometry and material (paper eq. 4; Johnson, Contact Mechanics,
//! 1985). `1/E* = (1−ν1²)/E1 + (1−ν2²)/E2` throughout.
//!
//! | kind | stiffness | exponent |
//! |---|---|---|
//! | sphere–sphere, ball in socket, sphere–plane | `K = (4/3) E* √R*` (Hertz, Johnson §4.2) | 1.5 |
//! | cylinder in a cylindrical hole | secant of Johnson's relation at a reference load | 1 |
//! | rigid flat circular punch | `K = 2 a E*` (Boussinesq; Johnson ch. 3) | 1 |

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

/// Combined modulus `E*`, `1/E* = (1−ν1²)/E1 + (1−ν2²)/E2`, Pa.
pub fn combined_modulus(body1: Material, body2: Material) -> Result<f64, SimError> {
    body1.check("body 1")?;
    body2.check("body 2")?;
    Ok(1.0
        / ((1.0 - body1.poisson.powi(2)) / body1.youngs_modulus
            + (1.0 - body2.poisson.powi(2)) / body2.youngs_modulus))
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
    /// A pin of radius `radius1` in a cylindrical hole of radius `radius2 > radius1` (the
    /// journal-bearing clearance joint), contact length `length`, linearised at the
    /// reference force `load` (see [`johnson_cylinder_in_hole_approach`]).
    CylinderInHole {
        radius1: f64,
        radius2: f64,
        length: f64,
        load: f64,
    },
    /// A rigid flat-ended circular punch of radius `radius` on an elastic body.
    FlatPunch { radius: f64 },
}

fn positive(name: &str, value: f64, unit: &str, what: &str) -> Result<(), SimError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        invalid(format!(
            "geometry: {name} = {value} is not valid; expected {what} > 0 in {unit}"
        ))
    }
}

/// Johnson's approach of a long pin pressed into a cylindrical hole (Johnson, Contact
/// Mechanics, 1985, ch. 5, conforming cylinders; as used for revolute clearance joints in the
/// review of Skrinjar et al. 2018):
/// `δ = F/(π L E*) · [ln(4π L E* ΔR / F) − 1]`, `ΔR = R_hole − R_pin`. It is implicit in `F`
/// for a given `δ`. Valid for elastic, long (plane-strain) cylinders whose contact half-width
/// `a = √(4 F R1 R2/(π L E* ΔR))` stays small against the radii (non-conformal contact);
/// `δ` grows with `F` only while `ln(4π L E* ΔR / F) > 2`.
pub fn johnson_cylinder_in_hole_approach(
    force: f64,
    length: f64,
    clearance: f64,
    combined_modulus: f64,
) -> f64 {
    let c = std::f64::consts::PI * length * combined_modulus;
    force / c * ((4.0 * c * clearance / force).ln() - 1.0)
}

impl ContactGeometry {
    /// Kebab-case name used in model files and the CLI.
    pub fn name(&self) -> &'static str {
        match self {
            ContactGeometry::SphereSphere { .. } => "sphere-sphere",
            ContactGeometry::BallInSocket { .. } => "ball-in-socket",
            ContactGeometry::SpherePlane { .. } => "sphere-plane",
            ContactGeometry::CylinderInHole { .. } => "cylinder-in-hole",
            ContactGeometry::FlatPunch { .. } => "flat-punch",
        }
    }

    /// Exponent `n` of the law `K δⁿ` the stiffness belongs to.
    pub fn exponent(&self) -> f64 {
        match self {
            ContactGeometry::SphereSphere { .. }
            | ContactGeometry::BallInSocket { .. }
            | ContactGeometry::SpherePlane { .. } => 1.5,
            ContactGeometry::CylinderInHole { .. } | ContactGeometry::FlatPunch { .. } => 1.0,
        }
    }

    /// Effective radius `R*` of the Hertzian point contacts, m.
    pub fn effective_radius(&self) -> Result<f64, SimError> {
        let check = |name: &str, r: f64| positive(name, r, "m", "a radius");
        match *self {
            ContactGeometry::SphereSphere { radius1, radius2 } => {
                check("radius1", radius1)?;
                check("radius2", radius2)?;
                Ok(radius1 * radius2 / (radius1 + radius2))
            }
            ContactGeometry::BallInSocket { radius1, radius2 } => {
                check("radius1", radius1)?;
                check("radius2", radius2)?;
                if radius1 == radius2 {
                    return invalid(format!(
                        "geometry: radius1 = radius2 = {radius1} is not valid for ball-in-socket; \
                         expected different radii (conformal contact is not Hertzian)"
                    ));
                }
                Ok(radius1 * radius2 / (radius1 - radius2).abs())
            }
            ContactGeometry::SpherePlane { radius } => {
                check("radius", radius)?;
                Ok(radius)
            }
            ContactGeometry::CylinderInHole { .. } | ContactGeometry::FlatPunch { .. } => {
                invalid(format!(
                    "geometry: {} is not a Hertzian point contact; it has no effective radius",
                    self.name()
                ))
            }
        }
    }

    /// Contact stiffness `K` of the law `K δⁿ` with `n =` [`Self::exponent`]: N/m^1.5 for the
    /// point contacts, N/m for the cylinder in a hole and the flat punch.
    pub fn stiffness(&self, body1: Material, body2: Material) -> Result<f64, SimError> {
        let e_star = combined_modulus(body1, body2)?;
        match *self {
            ContactGeometry::SphereSphere { .. }
            | ContactGeometry::BallInSocket { .. }
            | ContactGeometry::SpherePlane { .. } => {
                Ok(4.0 / 3.0 * e_star * self.effective_radius()?.sqrt())
            }
            ContactGeometry::CylinderInHole {
                radius1,
                radius2,
                length,
                load,
            } => {
                positive("radius1", radius1, "m", "a pin radius")?;
                positive("radius2", radius2, "m", "a hole radius")?;
                positive("length", length, "m", "a contact length")?;
                positive("load", load, "N", "a reference force")?;
                if radius2 <= radius1 {
                    return invalid(format!(
                        "geometry: radius2 = {radius2} is not valid for cylinder-in-hole; \
                         expected a hole radius > the pin radius radius1 = {radius1} in m"
                    ));
                }
                let clearance = radius2 - radius1;
                let c = std::f64::consts::PI * length * e_star;
                let limit = 4.0 * c * clearance / std::f64::consts::E.powi(2);
                if load >= limit {
                    return invalid(format!(
                        "geometry: load = {load} is not valid for cylinder-in-hole; expected a \
                         reference force < 4π L E* ΔR / e² = {limit:.6e} N, where Johnson's \
                         relation still stiffens with the load"
                    ));
                }
                let approach = johnson_cylinder_in_hole_approach(load, length, clearance, e_star);
                Ok(load / approach)
            }
            ContactGeometry::FlatPunch { radius } => {
                positive("radius", radius, "m", "a punch radius")?;
                Ok(2.0 * radius * e_star)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const STEEL: Material = Material {
        youngs_modulus: 207e9,
        poisson: 0.3,
    };

    /// The paper's eq. 4 written with σ = (1 − ν²)/(π E): K = 4/(3π(σ1+σ2)) √R*.
    #[test]
    fn ball_in_socket_matches_paper_equation_4() {
        let g = ContactGeometry::BallInSocket {
            radius1: 0.010,
            radius2: 0.0099,
        };
        let sigma = (1.0 - 0.3_f64.powi(2)) / (std::f64::consts::PI * 207e9);
        let r = 0.010 * 0.0099 / (0.010 - 0.0099);
        let paper = 4.0 / (3.0 * std::f64::consts::PI * 2.0 * sigma) * f64::sqrt(r);
        let k = g.stiffness(STEEL, STEEL).unwrap();
        assert!((k - paper).abs() <= 1e-12 * paper);
        assert!((k - 1.5087e11).abs() < 1e8, "{k}");
        assert_eq!(g.exponent(), 1.5);
    }

    #[test]
    fn flat_punch_is_two_a_e_star() {
        let g = ContactGeometry::FlatPunch { radius: 0.002 };
        let e_star = 207e9 / (2.0 * (1.0 - 0.09));
        let k = g.stiffness(STEEL, STEEL).unwrap();
        assert!((k - 2.0 * 0.002 * e_star).abs() <= 1e-12 * k);
        assert_eq!(g.exponent(), 1.0);
    }

    /// The secant stiffness reproduces Johnson's approach at the reference load, and the
    /// approach is the integral of the compliance dδ/dF = [ln(4πLE*ΔR/F) − 2]/(πLE*).
    #[test]
    fn cylinder_in_hole_secant_of_johnson() {
        let (r1, r2, l, load) = (0.0095, 0.01, 0.02, 2000.0);
        let g = ContactGeometry::CylinderInHole {
            radius1: r1,
            radius2: r2,
            length: l,
            load,
        };
        let e_star = combined_modulus(STEEL, STEEL).unwrap();
        let k = g.stiffness(STEEL, STEEL).unwrap();
        let delta = johnson_cylinder_in_hole_approach(load, l, r2 - r1, e_star);
        assert!((k * delta - load).abs() <= 1e-9 * load);
        let c = std::f64::consts::PI * l * e_star;
        let h = load * 1e-6;
        let fd = (johnson_cylinder_in_hole_approach(load + h, l, r2 - r1, e_star)
            - johnson_cylinder_in_hole_approach(load - h, l, r2 - r1, e_star))
            / (2.0 * h);
        let compliance = ((4.0 * c * (r2 - r1) / load).ln() - 2.0) / c;
        assert!((fd - compliance).abs() <= 1e-6 * compliance);
        assert_eq!(g.exponent(), 1.0);
    }

    #[test]
    fn bad_geometry_is_refused() {
        let g = ContactGeometry::SpherePlane { radius: -1.0 };
        assert!(g.stiffness(STEEL, STEEL).is_err());
        let bad = Material {
            youngs_modulus: 207e9,
            poisson: 0.7,
        };
        let g = ContactGeometry::SpherePlane { radius: 0.01 };
        assert!(g.stiffness(STEEL, bad).is_err());
        let hole = |radius2: f64, load: f64| ContactGeometry::CylinderInHole {
            radius1: 0.01,
            radius2,
            length: 0.02,
            load,
        };
        assert!(hole(0.009, 100.0).stiffness(STEEL, STEEL).is_err());
        assert!(hole(0.0101, 1e12).stiffness(STEEL, STEEL).is_err());
        assert!(hole(0.0101, 100.0).stiffness(STEEL, STEEL).is_ok());
        let punch = ContactGeometry::FlatPunch { radius: 0.0 };
        assert!(punch.stiffness(STEEL, STEEL).is_err());
    }
}
