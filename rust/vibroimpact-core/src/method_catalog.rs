//! The catalog of methods: for each method its name (one name for Python's integrator, the
//! model file's `solver.method`, a spec's `kind` and the catalog), the name of its Python class,
//! its parameters (units, defaults, checks), whether it iterates Newton and how it steps; and
//! the settings of Newton ([`NEWTON`]) and of adaptive stepping ([`ADAPTIVE`]). Everything that
//! lists a method's settings derives from here: the schemes' `Default`s and checks (below), the
//! Python integrators' fields, defaults and checks (`vibroimpact.integrators`, through
//! `_core.method_catalog` and `_core.method_spec`), the model-file schema and
//! docs/integrators.md.
//!
//! A run's method crosses from Python as one typed [`MethodSpec`], built once per integrator by
//! [`MethodEntry::spec`].

use crate::error::{invalid, SimError};
use crate::impulsive::{EventDriven, MoreauJean};
use crate::integrators::{Bathe, NewmarkFamily, NewtonSettings, PreciseIntegration};
use crate::method::Method;
use crate::number_rule::NumberRule;
use crate::settings::Adaptive;

/// What a setting holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SettingKind {
    /// A number (an `int` or a `float` in Python, never a `bool`).
    Number,
    /// A whole number (an `int` in Python, never a `bool`).
    Integer,
    /// `true` or `false` (a `bool` in Python).
    Flag,
}

/// A setting of a method, of Newton or of adaptive stepping.
#[derive(Debug, Clone, Copy)]
pub struct Setting {
    /// Its name: the Python field, the model file's `[solver]` key (Newton's with `newton_`
    /// before `rtol` and `atol`) and the message's `solver.<name>`.
    pub name: &'static str,
    pub kind: SettingKind,
    /// Its value when not given (a flag as 0 or 1); `None` when it follows from the run
    /// (`computed` says how).
    pub default: Option<f64>,
    /// How a setting without a default is computed ("" for the others).
    pub computed: &'static str,
    /// Unit ("" for a number without one).
    pub unit: &'static str,
    /// What it is, one line.
    pub doc: &'static str,
    /// What a valid value is, and its wording.
    pub rule: NumberRule,
}

impl Setting {
    /// Whether `value` is valid (a whole number for an integer, 0 or 1 for a flag).
    pub fn accepts(&self, value: f64) -> bool {
        let shape = match self.kind {
            SettingKind::Number => true,
            SettingKind::Integer => value.fract() == 0.0,
            SettingKind::Flag => value == 0.0 || value == 1.0,
        };
        shape && self.rule.accepts(value)
    }

    /// `value`, or the one-line refusal naming the setting (`solver.{name}`).
    pub fn check(&self, value: f64) -> Result<f64, SimError> {
        if self.accepts(value) {
            Ok(value)
        } else {
            self.rule
                .refuse(format_args!("solver.{}", self.name), value)
        }
    }

    /// The default (a setting with one).
    fn value(&self) -> f64 {
        self.default
            .expect("a setting read for its default has one")
    }
}

const fn setting(
    name: &'static str,
    kind: SettingKind,
    default: f64,
    unit: &'static str,
    doc: &'static str,
    expected: &'static str,
    valid: fn(f64) -> bool,
) -> Setting {
    Setting {
        name,
        kind,
        default: Some(default),
        computed: "",
        unit,
        doc,
        rule: NumberRule::new(expected, valid),
    }
}

/// How a method steps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Stepping {
    /// Fixed steps only.
    Fixed,
    /// Fixed steps, or adaptive ones when asked for.
    AdaptiveOnRequest,
    /// Adaptive steps unless fixed ones are asked for, with these `rtol` and `atol`.
    AdaptiveByDefault { rtol: f64, atol: f64 },
}

/// A method of the catalog.
#[derive(Debug)]
pub struct MethodEntry {
    /// Kebab-case name: `[solver] method`, the CLI, a spec's `kind`, JSON.
    pub name: &'static str,
    /// Name of its class in `vibroimpact.integrators`.
    pub class_name: &'static str,
    pub parameters: &'static [Setting],
    /// Whether it iterates Newton on the gap forces (and so takes [`NEWTON`]).
    pub newton: bool,
    pub stepping: Stepping,
    /// Rigid gaps only (`crate::impulsive`).
    pub impulsive: bool,
    /// The method from its parameters' values, in the order of `parameters` (each checked).
    build: fn(&[f64]) -> Method,
}

impl PartialEq for MethodEntry {
    /// Entries are equal when they are the same method (names are unique in [`METHODS`]).
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name
    }
}

/// What a run's method is, as it crosses from Python: the method, its Newton settings and the
/// tolerances of adaptive stepping (`None`: fixed steps), checked.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MethodSpec {
    pub entry: &'static MethodEntry,
    pub method: Method,
    pub newton: NewtonSettings,
    pub adaptive: Option<AdaptiveRequest>,
}

/// Adaptive stepping as asked for: the tolerances, and the step limits if given.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdaptiveRequest {
    pub rtol: f64,
    pub atol: f64,
    pub dt_min: Option<f64>,
    pub dt_max: Option<f64>,
}

impl AdaptiveRequest {
    /// The tolerances and limits checked (each against [`ADAPTIVE`]).
    pub fn new(
        rtol: f64,
        atol: f64,
        dt_min: Option<f64>,
        dt_max: Option<f64>,
    ) -> Result<Self, SimError> {
        let [r, a, lo, hi] = &ADAPTIVE;
        let request = Self {
            rtol: r.check(rtol)?,
            atol: a.check(atol)?,
            dt_min: dt_min.map(|v| lo.check(v)).transpose()?,
            dt_max: dt_max.map(|v| hi.check(v)).transpose()?,
        };
        if rtol == 0.0 && atol == 0.0 {
            return invalid("solver.rtol: 0 is not valid; expected rtol > 0 or atol > 0");
        }
        Ok(request)
    }

    /// The limits of a run of `t_end` whose first step is `dt`, and the first step: `dt_max`
    /// defaults to `t_end / 50` (a sweep's, sampling at `period`: `min(period / 16, t_end)`,
    /// and its first step is at most `dt_max`), `dt_min` to `min(dt, dt_max) / 1e4`.
    pub fn resolve(
        &self,
        t_end: f64,
        dt: f64,
        sweep_period: Option<f64>,
    ) -> Result<(Adaptive, f64), SimError> {
        let dt_max = match (self.dt_max, sweep_period) {
            (Some(v), _) => v,
            (None, None) => t_end / 50.0,
            (None, Some(period)) => (period / 16.0).min(t_end),
        };
        let dt = if sweep_period.is_some() {
            dt.min(dt_max)
        } else {
            dt
        };
        let dt_min = self.dt_min.unwrap_or(dt.min(dt_max) / 1e4);
        if dt_min > dt_max {
            return invalid(format!(
                "solver.dt_min: {dt_min:e} is not valid; expected dt_min <= dt_max = {dt_max:e}"
            ));
        }
        if dt_max > t_end {
            return invalid(format!(
                "solver.dt_max: {dt_max:e} is not valid; expected dt_max <= t_end = {t_end:e}"
            ));
        }
        let adaptive = Adaptive {
            rtol: self.rtol,
            atol: self.atol,
            dt_min,
            dt_max,
        };
        Ok((adaptive, dt))
    }
}

impl MethodEntry {
    /// The method with `values` of its parameters, in their order (each checked).
    pub fn method(&self, values: &[f64]) -> Result<Method, SimError> {
        if values.len() != self.parameters.len() {
            return invalid(format!(
                "solver.method: {} values for method '{}'; expected {} ({})",
                values.len(),
                self.name,
                self.parameters.len(),
                self.parameters
                    .iter()
                    .map(|p| p.name)
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        for (p, &v) in self.parameters.iter().zip(values) {
            p.check(v)?;
        }
        Ok((self.build)(values))
    }

    /// Refuses adaptive stepping (`adaptive`) for a method that takes fixed steps only: one
    /// line naming the method and those that step adaptively.
    pub fn check_adaptive(&self, adaptive: bool) -> Result<(), SimError> {
        if adaptive && self.stepping == Stepping::Fixed {
            let adaptive: Vec<_> = METHODS
                .iter()
                .filter(|m| m.stepping != Stepping::Fixed)
                .map(|m| m.name)
                .collect();
            return invalid(format!(
                "solver.adaptive: true is not valid; expected false for method '{}'; adaptive \
                 stepping is available for {}",
                self.name,
                adaptive.join(", ")
            ));
        }
        Ok(())
    }

    /// The method with every parameter at its default.
    pub fn default_method(&self) -> Method {
        let values: Vec<f64> = self.parameters.iter().map(Setting::value).collect();
        (self.build)(&values)
    }

    /// The run's method spec: the method with `values` of its parameters, the Newton
    /// settings (the defaults for a method without Newton iterations) and adaptive stepping
    /// if asked for (a method that steps adaptively only on request takes it then).
    pub fn spec(
        &'static self,
        values: &[f64],
        newton: NewtonSettings,
        adaptive: Option<AdaptiveRequest>,
    ) -> Result<MethodSpec, SimError> {
        let method = self.method(values)?;
        if !self.newton && newton != NewtonSettings::default() {
            let NewtonSettings {
                rtol,
                atol,
                max_iterations,
                max_step_cuts,
            } = newton;
            return invalid(format!(
                "solver.newton: rtol = {rtol}, atol = {atol}, max_iterations = {max_iterations}, \
                 max_step_cuts = {max_step_cuts} is not valid; expected the defaults: {} is \
                 explicit and runs no Newton iterations",
                self.name
            ));
        }
        self.check_adaptive(adaptive.is_some())?;
        Ok(MethodSpec {
            entry: self,
            method,
            newton,
            adaptive,
        })
    }
}

/// The entry of `method`: the one whose methods are of its variant (each variant of
/// [`Method`] has one entry, `every_method_has_one_entry_and_its_name`).
pub fn entry_of(method: &Method) -> &'static MethodEntry {
    let variant = std::mem::discriminant(method);
    METHODS
        .iter()
        .find(|e| std::mem::discriminant(&e.default_method()) == variant)
        .expect("every variant of Method has its entry in METHODS")
}

/// The method called `name`, if the catalog has one.
pub fn method_entry(name: &str) -> Option<&'static MethodEntry> {
    METHODS.iter().find(|m| m.name == name)
}

/// Newton's settings, in the order of [`NewtonSettings`]' fields.
pub static NEWTON: [Setting; 4] = [
    setting(
        "rtol",
        SettingKind::Number,
        1e-10,
        "",
        "relative tolerance on the increment and the residual of the gap coordinates (paper eq. 27's e, as a fraction)",
        "0 < rtol < 1",
        |v| v > 0.0 && v < 1.0,
    ),
    setting(
        "atol",
        SettingKind::Number,
        1e-15,
        "m",
        "absolute tolerance on them",
        "atol >= 0 in m",
        |v| v >= 0.0,
    ),
    setting(
        "max_iterations",
        SettingKind::Integer,
        30.0,
        "",
        "Newton iterations allowed per step before the step is cut",
        "an integer >= 1",
        |v| v >= 1.0 && v <= u32::MAX as f64,
    ),
    setting(
        "max_step_cuts",
        SettingKind::Integer,
        12.0,
        "",
        "times a failing step may be halved before the run fails",
        "an integer from 0 to 40",
        |v| (0.0..=40.0).contains(&v),
    ),
];

impl NewtonSettings {
    /// Newton's settings from their values in the order of [`NEWTON`] (each checked).
    pub fn from_values(values: [f64; 4]) -> Result<Self, SimError> {
        for (s, v) in NEWTON.iter().zip(values) {
            s.check(v)?;
        }
        let [rtol, atol, max_iterations, max_step_cuts] = values;
        Ok(Self {
            rtol,
            atol,
            max_iterations: max_iterations as usize,
            max_step_cuts: max_step_cuts as usize,
        })
    }
}

impl Default for NewtonSettings {
    fn default() -> Self {
        let [rtol, atol, iterations, cuts] = &NEWTON;
        Self {
            rtol: rtol.value(),
            atol: atol.value(),
            max_iterations: iterations.value() as usize,
            max_step_cuts: cuts.value() as usize,
        }
    }
}

/// The settings of adaptive stepping (`vibroimpact.Adaptive`), in the order of
/// [`AdaptiveRequest::new`]'s arguments.
pub static ADAPTIVE: [Setting; 4] = [
    setting(
        "rtol",
        SettingKind::Number,
        1e-6,
        "",
        "relative tolerance on the local error",
        "a tolerance >= 0",
        |v| v >= 0.0,
    ),
    setting(
        "atol",
        SettingKind::Number,
        1e-10,
        "m",
        "absolute tolerance on the local displacement error",
        "a tolerance >= 0",
        |v| v >= 0.0,
    ),
    Setting {
        default: None,
        computed: "min(dt, dt_max) / 1e4",
        ..setting(
            "dt_min",
            SettingKind::Number,
            0.0,
            "s",
            "smallest step",
            "a step > 0 in s",
            |v| v > 0.0,
        )
    },
    Setting {
        default: None,
        computed: "t_end / 50 (a sweep's: min(period / 16, t_end))",
        ..setting(
            "dt_max",
            SettingKind::Number,
            0.0,
            "s",
            "largest step",
            "a step > 0 in s",
            |v| v > 0.0,
        )
    },
];

const NEWMARK_GAMMA: Setting = setting(
    "gamma",
    SettingKind::Number,
    0.5,
    "",
    "Newmark γ",
    "gamma >= 0.5 (paper eq. 16)",
    |v| v >= 0.5,
);
const NEWMARK_BETA: Setting = setting(
    "beta",
    SettingKind::Number,
    0.25,
    "",
    "Newmark β",
    "beta > 0",
    |v| v > 0.0,
);
const BATHE_GAMMA: Setting = setting(
    "gamma",
    SettingKind::Number,
    0.5,
    "",
    "fraction γ of the step taken by the trapezoidal sub-step",
    "0 < gamma < 1",
    |v| v > 0.0 && v < 1.0,
);
const CHATTER_FRACTION: Setting = setting(
    "chatter_fraction",
    SettingKind::Number,
    1e-3,
    "",
    "a wall sticks when the flight after an impact would be shorter than chatter_fraction · dt",
    "0 <= chatter_fraction < 1",
    |v| (0.0..1.0).contains(&v),
);
const MAX_EVENTS_PER_STEP: Setting = setting(
    "max_events_per_step",
    SettingKind::Integer,
    1000.0,
    "",
    "events allowed in one step before every further impact in it is made plastic",
    "an integer >= 1",
    |v| v >= 1.0 && v <= u32::MAX as f64,
);
const THETA: Setting = setting(
    "theta",
    SettingKind::Number,
    0.5,
    "",
    "θ of the θ-method: 1/2 the trapezoidal rule, 1 backward Euler",
    "0.5 <= theta <= 1",
    |v| (0.5..=1.0).contains(&v),
);

/// Generalized-α's parameters for a spectral radius at infinity `ρ∞` (Chung & Hulbert 1993).
fn generalized_alpha(rho_inf: f64) -> NewmarkFamily {
    let (alpha_m, alpha_f) = (
        (2.0 * rho_inf - 1.0) / (rho_inf + 1.0),
        rho_inf / (rho_inf + 1.0),
    );
    NewmarkFamily {
        alpha_m,
        alpha_f,
        gamma: 0.5 - alpha_m + alpha_f,
        beta: 0.25 * square(1.0 - alpha_m + alpha_f),
    }
}

/// `x²` by the C library's `pow`, as Python's `x ** 2` computes it (these parameters were
/// computed in Python before; `x * x` differs from it in the last bit for some `x`). The
/// exponent is hidden from the optimiser, which would make `pow(x, 2)` into `x * x`.
fn square(x: f64) -> f64 {
    x.powf(std::hint::black_box(2.0))
}

/// HHT-α's parameters for `α_f = alpha` (Hilber, Hughes & Taylor 1977).
fn hht(alpha: f64) -> NewmarkFamily {
    NewmarkFamily {
        alpha_m: 0.0,
        alpha_f: alpha,
        gamma: 0.5 + alpha,
        beta: 0.25 * square(1.0 + alpha),
    }
}

/// Every method, in the order Python lists them: the methods of force laws, then the
/// impulsive ones.
pub static METHODS: &[MethodEntry] = &[
    MethodEntry {
        name: "newmark",
        class_name: "Newmark",
        parameters: &[NEWMARK_GAMMA, NEWMARK_BETA],
        newton: true,
        stepping: Stepping::AdaptiveOnRequest,
        impulsive: false,
        build: |v| {
            Method::Newmark(NewmarkFamily {
                gamma: v[0],
                beta: v[1],
                alpha_m: 0.0,
                alpha_f: 0.0,
            })
        },
    },
    MethodEntry {
        name: "generalized-alpha",
        class_name: "GeneralizedAlpha",
        parameters: &[setting(
            "rho_inf",
            SettingKind::Number,
            0.8,
            "",
            "spectral radius at infinity ρ∞",
            "0 <= rho_inf <= 1",
            |v| (0.0..=1.0).contains(&v),
        )],
        newton: true,
        stepping: Stepping::AdaptiveOnRequest,
        impulsive: false,
        build: |v| Method::GeneralizedAlpha(generalized_alpha(v[0])),
    },
    MethodEntry {
        name: "hht",
        class_name: "HHT",
        parameters: &[setting(
            "alpha",
            SettingKind::Number,
            0.1,
            "",
            "α_f = alpha (HHT's own α is −alpha)",
            "0 <= alpha <= 1/3",
            |v| (0.0..=1.0 / 3.0).contains(&v),
        )],
        newton: true,
        stepping: Stepping::AdaptiveOnRequest,
        impulsive: false,
        build: |v| Method::Hht(hht(v[0])),
    },
    MethodEntry {
        name: "precise",
        class_name: "PreciseIntegration",
        parameters: &[setting(
            "predictor_corrector",
            SettingKind::Flag,
            0.0,
            "",
            "correct each Adams step with the contact force treated implicitly",
            "true or false",
            |_| true,
        )],
        newton: true,
        stepping: Stepping::Fixed,
        impulsive: false,
        build: |v| {
            Method::Precise(PreciseIntegration {
                predictor_corrector: v[0] == 1.0,
            })
        },
    },
    MethodEntry {
        name: "bathe",
        class_name: "Bathe",
        parameters: &[BATHE_GAMMA],
        newton: true,
        stepping: Stepping::Fixed,
        impulsive: false,
        build: |v| Method::Bathe(Bathe { gamma: v[0] }),
    },
    MethodEntry {
        name: "dop853",
        class_name: "Dop853",
        parameters: &[],
        newton: false,
        stepping: Stepping::AdaptiveByDefault {
            rtol: 1e-8,
            atol: 1e-12,
        },
        impulsive: false,
        build: |_| Method::Dop853,
    },
    MethodEntry {
        name: "event-driven",
        class_name: "EventDriven",
        parameters: &[CHATTER_FRACTION, MAX_EVENTS_PER_STEP],
        newton: false,
        stepping: Stepping::Fixed,
        impulsive: true,
        build: |v| {
            Method::EventDriven(EventDriven {
                chatter_fraction: v[0],
                max_events_per_step: v[1] as usize,
            })
        },
    },
    MethodEntry {
        name: "moreau-jean",
        class_name: "MoreauJean",
        parameters: &[THETA],
        newton: false,
        stepping: Stepping::Fixed,
        impulsive: true,
        build: |v| Method::MoreauJean(MoreauJean { theta: v[0] }),
    },
];

// The checks of the schemes built in Rust (the steppers' constructors call them): each
// parameter against its setting above, so that every check lives once.

impl NewmarkFamily {
    /// `γ` and `β` against Newmark's settings, and `α_m < 1`, `0 <= α_f < 1` (the α-form's
    /// weights; generalized-α and HHT derive them within this range).
    pub fn validate(&self) -> Result<(), SimError> {
        NEWMARK_GAMMA.check(self.gamma)?;
        NEWMARK_BETA.check(self.beta)?;
        if !(self.alpha_f >= 0.0 && self.alpha_f < 1.0 && self.alpha_m < 1.0) {
            return invalid(format!(
                "solver: alpha_m = {}, alpha_f = {} are not valid; expected alpha_m < 1 and 0 <= \
                 alpha_f < 1",
                self.alpha_m, self.alpha_f
            ));
        }
        Ok(())
    }
}

impl Bathe {
    /// `γ` against [`BATHE_GAMMA`].
    pub fn validate(&self) -> Result<(), SimError> {
        BATHE_GAMMA.check(self.gamma).map(|_| ())
    }
}

impl EventDriven {
    /// Its settings against [`CHATTER_FRACTION`] and [`MAX_EVENTS_PER_STEP`].
    pub fn validate(&self) -> Result<(), SimError> {
        CHATTER_FRACTION.check(self.chatter_fraction)?;
        MAX_EVENTS_PER_STEP.check(self.max_events_per_step as f64)?;
        Ok(())
    }
}

impl MoreauJean {
    /// `θ` against [`THETA`].
    pub fn validate(&self) -> Result<(), SimError> {
        THETA.check(self.theta).map(|_| ())
    }
}

impl Default for Bathe {
    fn default() -> Self {
        Self {
            gamma: BATHE_GAMMA.value(),
        }
    }
}

impl Default for EventDriven {
    fn default() -> Self {
        Self {
            chatter_fraction: CHATTER_FRACTION.value(),
            max_events_per_step: MAX_EVENTS_PER_STEP.value() as usize,
        }
    }
}

impl Default for MoreauJean {
    fn default() -> Self {
        Self {
            theta: THETA.value(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_unique_and_every_default_is_valid() {
        for (i, m) in METHODS.iter().enumerate() {
            assert!(METHODS[..i].iter().all(|o| o.name != m.name), "{}", m.name);
            assert_eq!(method_entry(m.name), Some(m));
            let defaults: Vec<f64> = m.parameters.iter().map(Setting::value).collect();
            assert_eq!(
                m.method(&defaults).unwrap(),
                m.default_method(),
                "{}",
                m.name
            );
        }
        for s in NEWTON.iter().chain(&ADAPTIVE) {
            if let Some(v) = s.default {
                assert!(s.accepts(v), "{}", s.name);
            }
        }
    }

    #[test]
    fn every_method_has_one_entry_and_its_name() {
        for m in METHODS {
            let method = m.default_method();
            assert_eq!(entry_of(&method), m);
            assert_eq!(method.name(), m.name);
        }
        // a Newmark-family scheme keeps the name it was asked for, even where the parameters
        // coincide (HHT at α = 0 is average acceleration, generalized-α at ρ∞ = 1/2 is HHT at
        // α = 1/3)
        let entry = |name| method_entry(name).unwrap();
        assert_eq!(entry("hht").method(&[0.0]).unwrap().name(), "hht");
        let alpha = entry("generalized-alpha").method(&[0.5]).unwrap();
        assert_eq!(alpha.name(), "generalized-alpha");
        assert_eq!(
            alpha.newmark_family(),
            entry("hht").method(&[1.0 / 3.0]).unwrap().newmark_family()
        );
        assert_eq!(entry("bathe").default_method().newmark_family(), None);
    }

    #[test]
    fn the_defaults_are_those_the_schemes_take() {
        let scheme = |name| method_entry(name).unwrap().default_method();
        assert_eq!(
            scheme("newmark"),
            Method::Newmark(NewmarkFamily::newmark(0.5, 0.25).unwrap())
        );
        assert_eq!(scheme("bathe"), Method::Bathe(Bathe { gamma: 0.5 }));
        assert_eq!(
            scheme("event-driven"),
            Method::EventDriven(EventDriven {
                chatter_fraction: 1e-3,
                max_events_per_step: 1000
            })
        );
        assert_eq!(
            scheme("moreau-jean"),
            Method::MoreauJean(MoreauJean { theta: 0.5 })
        );
        assert_eq!(
            scheme("precise"),
            Method::Precise(PreciseIntegration {
                predictor_corrector: false
            })
        );
        let newton = NewtonSettings::default();
        assert_eq!((newton.rtol, newton.atol), (1e-10, 1e-15));
        assert_eq!((newton.max_iterations, newton.max_step_cuts), (30, 12));
    }

    #[test]
    fn generalized_alpha_and_hht_are_chung_and_hulberts_and_hilbers_schemes() {
        let scheme = |name, v: f64| match method_entry(name).unwrap().method(&[v]).unwrap() {
            m @ (Method::GeneralizedAlpha(s) | Method::Hht(s)) => {
                assert_eq!(m.name(), name);
                (s.alpha_m, s.alpha_f, s.gamma, s.beta)
            }
            other => panic!("{name} is generalized-α or HHT, not {other:?}"),
        };
        // ρ∞ = 1: α_m = α_f = 1/2, the trapezoidal rule; ρ∞ = 0: α_m = −1, γ = 3/2, β = 1
        assert_eq!(scheme("generalized-alpha", 1.0), (0.5, 0.5, 0.5, 0.25));
        assert_eq!(scheme("generalized-alpha", 0.0), (-1.0, 0.0, 1.5, 1.0));
        // HHT at α = 0 is average acceleration, at α = 1/4: γ = 3/4, β = 25/64
        assert_eq!(scheme("hht", 0.0), (0.0, 0.0, 0.5, 0.25));
        assert_eq!(scheme("hht", 0.25), (0.0, 0.25, 0.75, 25.0 / 64.0));
    }

    #[test]
    fn bad_values_are_refused_naming_the_setting() {
        let newmark = method_entry("newmark").unwrap();
        let e = newmark.method(&[0.4, 0.25]).unwrap_err().to_string();
        assert!(
            e.contains("solver.gamma: 0.4 is not valid; expected gamma >= 0.5"),
            "{e}"
        );
        let e = method_entry("event-driven")
            .unwrap()
            .method(&[1e-3, 2.5])
            .unwrap_err()
            .to_string();
        assert!(e.contains("solver.max_events_per_step"), "{e}");
        let e = NewtonSettings::from_values([1e-10, 1e-15, 30.0, 41.0])
            .unwrap_err()
            .to_string();
        assert!(e.contains("solver.max_step_cuts: 41"), "{e}");
        let e = AdaptiveRequest::new(0.0, 0.0, None, None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("solver.rtol"), "{e}");
        let bathe = method_entry("bathe").unwrap();
        let adaptive = AdaptiveRequest::new(1e-6, 1e-10, None, None).ok();
        let e = bathe
            .spec(&[0.5], NewtonSettings::default(), adaptive)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("solver.adaptive") && e.contains("newmark"),
            "{e}"
        );
    }

    #[test]
    fn a_scheme_built_in_rust_is_checked_by_the_catalogs_settings() {
        let refusal = |name: &str, values: &[f64]| {
            method_entry(name)
                .unwrap()
                .method(values)
                .unwrap_err()
                .to_string()
        };
        let message = |r: Result<(), SimError>| r.unwrap_err().to_string();
        assert_eq!(
            message(NewmarkFamily::newmark(0.5, 0.0).map(|_| ())),
            refusal("newmark", &[0.5, 0.0])
        );
        assert_eq!(
            message(Bathe { gamma: 1.0 }.validate()),
            refusal("bathe", &[1.0])
        );
        let chatter = EventDriven {
            chatter_fraction: 1.0,
            ..EventDriven::default()
        };
        assert_eq!(
            message(chatter.validate()),
            refusal("event-driven", &[1.0, 1000.0])
        );
        let events = EventDriven {
            max_events_per_step: 0,
            ..EventDriven::default()
        };
        assert_eq!(
            message(events.validate()),
            refusal("event-driven", &[1e-3, 0.0])
        );
        assert_eq!(
            message(MoreauJean { theta: 0.4 }.validate()),
            refusal("moreau-jean", &[0.4])
        );
        // the α-form's weights, which no setting of the catalog holds
        let weights = NewmarkFamily {
            alpha_f: 1.0,
            ..NewmarkFamily::average_acceleration()
        };
        assert!(message(weights.validate()).starts_with("solver: alpha_m = 0, alpha_f = 1"));
    }

    #[test]
    fn adaptive_limits_default_to_the_run_and_the_sweep() {
        let request = AdaptiveRequest::new(1e-6, 1e-10, None, None).unwrap();
        let (a, dt) = request.resolve(0.02, 1e-5, None).unwrap();
        assert_eq!((a.dt_max, a.dt_min, dt), (0.02 / 50.0, 1e-5 / 1e4, 1e-5));
        let (a, dt) = request.resolve(1.0, 0.1, Some(0.5)).unwrap();
        assert_eq!(
            (a.dt_max, dt, a.dt_min),
            (0.5 / 16.0, 0.5 / 16.0, 0.5 / 16.0 / 1e4)
        );
        let tight = AdaptiveRequest::new(1e-6, 1e-10, Some(1e-3), Some(1e-4)).unwrap();
        let e = tight.resolve(1.0, 1e-5, None).unwrap_err().to_string();
        assert!(e.contains("solver.dt_min"), "{e}");
    }
}
