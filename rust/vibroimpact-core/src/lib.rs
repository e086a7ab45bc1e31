//! vibroimpact-core: the dynamic response of linear structures with clearances.
//!
//! `M x'' + C x' + K x = F(t) + Σ_g b_gᵀ f_g` (paper eq. 2): a linear structure
//! ([`structure`]), gap elements with contact-force laws ([`gap`], [`contact`]), and time
//! integrators ([`integrators`]) driven by [`simulate::simulate`]. No Python here; the
//! `vibroimpact-py` crate binds it.

pub mod contact;
pub(crate) mod driver;
pub mod error;
pub mod factor;
pub mod floor;
pub mod gap;
pub mod impulsive;
pub mod integrators;
pub mod interpolation;
pub mod interrupt;
pub mod linalg;
pub mod method;
pub mod method_catalog;
pub mod model_catalog;
pub mod number_rule;
pub mod observe;
pub mod output;
pub mod sensitivity;
pub mod settings;
pub mod simulate;
pub mod step_control;
#[cfg(test)]
mod step_cut_tests;
pub mod structure;
pub mod sweep;
pub mod system;

pub use error::SimError;
