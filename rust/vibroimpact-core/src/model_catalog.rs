//! The catalog of a model's fields besides its matrices and contact laws (the laws have their
//! own, `contact::catalog`): for each part — the structure's spin, a gap, a radial gap, each
//! kind of load — its fields' names (the keys of a model spec and of a model file), defaults,
//! units and checks. Everything that shows a default or checks one of these fields derives from
//! here: the core's checks ([`Gap::validate`](crate::gap::Gap::validate), `Load::validate`,
//! `LinearStructure::spinning` and `run_up`), the binding that reads a model spec, the Python
//! classes' defaults and checks (`vibroimpact.model`, through `_core.model_catalog`), the
//! model-file schema and docs/model-file.md.

use crate::error::SimError;
use crate::number_rule::{any, non_negative, positive, NumberRule};

/// A field's default.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FieldDefault {
    Number(f64),
    Numbers(&'static [f64]),
    /// One of the field's `choices`.
    Choice(&'static str),
}

/// A field of a part of the model.
#[derive(Debug, Clone, Copy)]
pub struct Field {
    /// Its key in a model spec and a model file, and its Python attribute.
    pub name: &'static str,
    /// Its value when left out; `None`: it must be given (or, for a field that only some
    /// settings use, given with them: a radial gap's `radius` with friction).
    pub default: Option<FieldDefault>,
    /// Unit ("" for a number without one).
    pub unit: &'static str,
    /// What a valid number (each number of a list) is, and its wording.
    pub rule: NumberRule,
    /// The words a choice field takes (empty for numbers).
    pub choices: &'static [&'static str],
}

impl Field {
    /// Whether the number `value` is valid (finite, and in range).
    pub fn accepts(&self, value: f64) -> bool {
        self.rule.accepts(value)
    }

    /// Whether the word `value` is one of the field's choices.
    pub fn accepts_choice(&self, value: &str) -> bool {
        self.choices.contains(&value)
    }

    /// `value`, or the one-line refusal naming `{part}.{name}` (e.g. `gaps[0].clearance`).
    pub fn check(&self, part: &str, value: f64) -> Result<f64, SimError> {
        self.rule.check(format_args!("{part}.{}", self.name), value)
    }

    /// The default number (a number field with one).
    pub fn default_number(&self) -> Option<f64> {
        match self.default {
            Some(FieldDefault::Number(v)) => Some(v),
            _ => None,
        }
    }

    /// The default list of numbers (a list field with one).
    pub fn default_numbers(&self) -> Option<&'static [f64]> {
        match self.default {
            Some(FieldDefault::Numbers(v)) => Some(v),
            _ => None,
        }
    }

    /// The default word (a choice field with one).
    pub fn default_choice(&self) -> Option<&'static str> {
        match self.default {
            Some(FieldDefault::Choice(v)) => Some(v),
            _ => None,
        }
    }
}

const fn number(
    name: &'static str,
    default: Option<f64>,
    unit: &'static str,
    expected: &'static str,
    valid: fn(f64) -> bool,
) -> Field {
    Field {
        name,
        default: match default {
            Some(v) => Some(FieldDefault::Number(v)),
            None => None,
        },
        unit,
        rule: NumberRule::new(expected, valid),
        choices: &[],
    }
}

const fn choice(
    name: &'static str,
    default: &'static str,
    choices: &'static [&'static str],
    expected: &'static str,
) -> Field {
    Field {
        name,
        default: Some(FieldDefault::Choice(default)),
        unit: "",
        rule: NumberRule::new(expected, any),
        choices,
    }
}

/// `structure.spin_speed`: Ω of a rotor (a run-up's start).
pub const SPIN_SPEED: Field = number(
    "spin_speed",
    Some(0.0),
    "rad/s",
    "a spin speed in rad/s",
    any,
);
/// `structure.spin_profile`: a constant speed or a linear run-up.
pub const SPIN_PROFILE: Field = choice(
    "spin_profile",
    "constant",
    &["constant", "linear"],
    "constant or linear",
);
/// `structure.spin_speed_end`: a run-up's final speed.
pub const SPIN_SPEED_END: Field = number(
    "spin_speed_end",
    None,
    "rad/s",
    "a spin speed in rad/s",
    any,
);
/// `structure.run_up_time`: a run-up's duration.
pub const RUN_UP_TIME: Field = number("run_up_time", None, "s", "a duration > 0 in s", positive);

/// The structure's fields of this catalog (its matrices are checked by `LinearStructure`).
pub static STRUCTURE: &[Field] = &[SPIN_SPEED, SPIN_PROFILE, SPIN_SPEED_END, RUN_UP_TIME];

/// A gap's clearance `d`.
pub const CLEARANCE: Field = number(
    "clearance",
    Some(0.0),
    "m",
    "a clearance >= 0 in m",
    non_negative,
);
/// A linear gap's wall(s).
pub const SIDE: Field = choice(
    "side",
    "positive",
    &["positive", "negative", "both"],
    "positive, negative or both",
);
/// A radial gap's stator centre `(x_s, y_s)`.
pub const CENTER: Field = Field {
    name: "center",
    default: Some(FieldDefault::Numbers(&[0.0, 0.0])),
    unit: "m",
    rule: NumberRule::new("two numbers [x_s, y_s] in m", any),
    choices: &[],
};
/// A radial gap's Coulomb coefficient μ.
pub const FRICTION: Field = number(
    "friction",
    Some(0.0),
    "",
    "a Coulomb coefficient >= 0",
    non_negative,
);
/// A radial gap's rotor radius `R` at the contact (needed with friction).
pub const RADIUS: Field = number(
    "radius",
    None,
    "m",
    "the rotor's radius at the contact (> 0, m) when friction > 0",
    positive,
);
/// A radial gap's friction law.
pub const FRICTION_LAW: Field = choice(
    "friction_law",
    "coulomb",
    &["coulomb", "regularised"],
    "coulomb or regularised",
);
/// A radial gap's regularisation speed `v_reg` (needed with `friction_law = "regularised"`).
pub const REGULARISATION_SPEED: Field = number(
    "regularisation_speed",
    None,
    "m/s",
    "a speed > 0 in m/s",
    positive,
);

/// A linear gap's fields of this catalog (its DOFs, coefficients and law are checked by
/// `Gap::validate` and the law's catalog).
pub static GAP: &[Field] = &[CLEARANCE, SIDE];
/// A radial gap's fields of this catalog.
pub static RADIAL_GAP: &[Field] = &[
    CLEARANCE,
    CENTER,
    FRICTION,
    RADIUS,
    FRICTION_LAW,
    REGULARISATION_SPEED,
];

/// A constant or harmonic load's amplitude `A`.
pub const AMPLITUDE: Field = number("amplitude", None, "N", "a force in N", any);
/// A harmonic load's frequency `f`.
pub const FREQUENCY: Field = number(
    "frequency",
    None,
    "Hz",
    "a frequency >= 0 in Hz",
    non_negative,
);
/// A harmonic or unbalance load's phase `φ`.
pub const PHASE: Field = number("phase", Some(0.0), "rad", "an angle in rad", any);
/// A table load's factor on its forces.
pub const SCALE: Field = number("scale", Some(1.0), "", "a finite factor", any);
/// An unbalance `m e`.
pub const MAGNITUDE: Field = number(
    "magnitude",
    None,
    "kg·m",
    "an unbalance m·e >= 0 in kg·m",
    non_negative,
);

/// The numbers of each kind of load (its DOFs and a table's columns are checked by
/// `Load::validate`), by the load's `kind`.
pub static LOADS: &[(&str, &[Field])] = &[
    ("constant", &[AMPLITUDE]),
    ("harmonic", &[AMPLITUDE, FREQUENCY, PHASE]),
    ("table", &[SCALE]),
    ("unbalance", &[MAGNITUDE, PHASE]),
];

/// The parts of the catalog by name (`_core.model_catalog`): `structure`, `gap`, `radial-gap`
/// and `load.<kind>`.
pub fn parts() -> Vec<(String, &'static [Field])> {
    let mut out = vec![
        ("structure".to_string(), STRUCTURE),
        ("gap".to_string(), GAP),
        ("radial-gap".to_string(), RADIAL_GAP),
    ];
    out.extend(LOADS.iter().map(|(kind, f)| (format!("load.{kind}"), *f)));
    out
}

/// The field `name` of the part called `part` (as [`parts`] names it).
pub fn field(part: &str, name: &str) -> Option<&'static Field> {
    let fields = match part {
        "structure" => STRUCTURE,
        "gap" => GAP,
        "radial-gap" => RADIAL_GAP,
        _ => {
            let kind = part.strip_prefix("load.")?;
            LOADS.iter().find(|(k, _)| *k == kind)?.1
        }
    };
    fields.iter().find(|f| f.name == name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_default_is_accepted_and_every_field_named_once_per_part() {
        for (part, fields) in parts() {
            for (i, f) in fields.iter().enumerate() {
                assert!(
                    fields[..i].iter().all(|g| g.name != f.name),
                    "{part}.{}",
                    f.name
                );
                match f.default {
                    Some(FieldDefault::Number(v)) => assert!(f.accepts(v), "{part}.{}", f.name),
                    Some(FieldDefault::Numbers(v)) => {
                        assert!(v.iter().all(|&x| f.accepts(x)), "{part}.{}", f.name)
                    }
                    Some(FieldDefault::Choice(c)) => {
                        assert!(f.accepts_choice(c), "{part}.{}", f.name)
                    }
                    None => {}
                }
            }
        }
    }

    #[test]
    fn every_field_is_found_by_its_part_and_name() {
        for (part, fields) in parts() {
            for f in fields {
                assert_eq!(field(&part, f.name).map(|g| g.name), Some(f.name));
            }
        }
        assert!(field("load.sine", "phase").is_none() && field("gap", "center").is_none());
    }

    #[test]
    fn checks_refuse_out_of_range_and_non_finite_values() {
        assert!(CLEARANCE.check("gaps[0]", -1e-3).is_err());
        assert!(CLEARANCE.check("gaps[0]", 0.0).is_ok());
        assert!(RUN_UP_TIME.check("structure", 0.0).is_err());
        assert!(FREQUENCY.check("loads[1]", f64::NAN).is_err());
        assert!(PHASE.check("loads[1]", f64::INFINITY).is_err());
        let e = FRICTION.check("gaps[2]", -0.1).unwrap_err().to_string();
        assert!(
            e.contains("gaps[2].friction: -0.1 is not valid; expected a Coulomb coefficient >= 0"),
            "{e}"
        );
    }
}
