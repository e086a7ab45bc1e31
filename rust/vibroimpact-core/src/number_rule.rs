//! What a valid number is and how a refusal words it: one home for the checks of the three
//! catalogs — methods' settings (`method_catalog`), model fields (`model_catalog`) and contact
//! laws' parameters (`contact::catalog`) — which the core's checks, the binding and Python's
//! messages all read.

use crate::error::{invalid, SimError};
use std::fmt::Display;

/// A range of valid numbers and its wording.
#[derive(Debug, Clone, Copy)]
pub struct NumberRule {
    /// What a valid value is, as messages word it (`expected ...`).
    pub expected: &'static str,
    /// Whether a finite number is valid.
    valid: fn(f64) -> bool,
}

impl NumberRule {
    pub const fn new(expected: &'static str, valid: fn(f64) -> bool) -> Self {
        NumberRule { expected, valid }
    }

    /// Whether `value` is valid: finite, and in range.
    pub fn accepts(&self, value: f64) -> bool {
        value.is_finite() && (self.valid)(value)
    }

    /// `value`, or the one-line refusal `{subject}: {value} is not valid; expected ...`.
    pub fn check(&self, subject: impl Display, value: f64) -> Result<f64, SimError> {
        if self.accepts(value) {
            Ok(value)
        } else {
            self.refuse(subject, value)
        }
    }

    /// The one-line refusal of `value` for `subject` (a field, a setting).
    pub fn refuse<T>(&self, subject: impl Display, value: f64) -> Result<T, SimError> {
        invalid(format!(
            "{subject}: {value} is not valid; expected {}",
            self.expected
        ))
    }
}

/// Every finite number.
pub(crate) fn any(_: f64) -> bool {
    true
}

pub(crate) fn non_negative(v: f64) -> bool {
    v >= 0.0
}

pub(crate) fn positive(v: f64) -> bool {
    v > 0.0
}
