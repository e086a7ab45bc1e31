//! Cubic Hermite interpolation of a gap's penetration inside one step, used to locate the
//! instants where a gap closes or opens and the speed at those instants (docs/conventions.md
//! §Approach speed: `v_imp` is the speed at the crossing, never the speed at the first step
//! inside the wall).

/// Penetration and its time derivative at both ends of a step of length `h`.
#[derive(Debug, Clone, Copy)]
pub struct HermiteSegment {
    pub y0: f64,
    pub dy0: f64,
    pub y1: f64,
    pub dy1: f64,
    pub h: f64,
}

impl HermiteSegment {
    /// Value at the fraction `s ∈ [0, 1]` of the step.
    #[inline]
    pub fn value(&self, s: f64) -> f64 {
        let s2 = s * s;
        let s3 = s2 * s;
        (2.0 * s3 - 3.0 * s2 + 1.0) * self.y0
            + (s3 - 2.0 * s2 + s) * self.h * self.dy0
            + (-2.0 * s3 + 3.0 * s2) * self.y1
            + (s3 - s2) * self.h * self.dy1
    }

    /// Time derivative at the fraction `s` of the step.
    #[inline]
    pub fn rate(&self, s: f64) -> f64 {
        let s2 = s * s;
        ((6.0 * s2 - 6.0 * s) * self.y0 + (-6.0 * s2 + 6.0 * s) * self.y1) / self.h
            + (3.0 * s2 - 4.0 * s + 1.0) * self.dy0
            + (3.0 * s2 - 2.0 * s) * self.dy1
    }

    /// Fraction of the step at which the interpolant crosses zero, given that the end values
    /// have opposite signs (or `y0 == 0`). Safeguarded Newton inside the bracket.
    pub fn crossing(&self) -> f64 {
        if self.y0 == 0.0 {
            return 0.0;
        }
        if self.y1 == 0.0 {
            return 1.0;
        }
        self.crossing_between(0.0, 1.0)
    }

    /// Largest value inside the step and where it is, if the interpolant has an interior
    /// maximum (rate positive at the start and negative at the end).
    pub fn interior_peak(&self) -> Option<(f64, f64)> {
        if !(self.dy0 > 0.0 && self.dy1 < 0.0) {
            return None;
        }
        // rate(s)·h = A s² + B s + C, with C = h·dy0 > 0 and A + B + C = h·dy1 < 0:
        // exactly one root in (0, 1).
        let (y0, y1, m0, m1) = (self.y0, self.y1, self.h * self.dy0, self.h * self.dy1);
        let a = 6.0 * y0 - 6.0 * y1 + 3.0 * m0 + 3.0 * m1;
        let b = -6.0 * y0 + 6.0 * y1 - 4.0 * m0 - 2.0 * m1;
        let c = m0;
        let s = if a.abs() < 1e-14 * (b.abs() + c.abs()) {
            -c / b
        } else {
            let disc = (b * b - 4.0 * a * c).max(0.0).sqrt();
            // the root in (0, 1), computed without cancellation
            let q = -0.5 * (b + b.signum() * disc);
            let (r1, r2) = (q / a, c / q);
            if (0.0..=1.0).contains(&r1) {
                r1
            } else {
                r2
            }
        };
        let s = s.clamp(0.0, 1.0);
        Some((s, self.value(s)))
    }

    /// Zero of the interpolant in `[lo, hi]`, where its values have opposite signs.
    pub fn crossing_between(&self, lo: f64, hi: f64) -> f64 {
        let (mut lo, mut hi) = (lo, hi);
        let (f_lo, f_hi) = (self.value(lo), self.value(hi));
        if !(f_lo.is_finite() && f_hi.is_finite()) || f_lo == f_hi {
            // a diverged state (the driver reports it) or no crossing to locate
            return lo;
        }
        if f_lo == 0.0 {
            return lo;
        }
        if f_hi == 0.0 {
            return hi;
        }
        let rising = f_hi > f_lo;
        let mut s = lo + (hi - lo) * f_lo / (f_lo - f_hi);
        for _ in 0..60 {
            let f = self.value(s);
            if (f < 0.0) == rising {
                lo = s;
            } else {
                hi = s;
            }
            if f == 0.0 || hi - lo < 1e-15 {
                break;
            }
            let df = self.rate(s) * self.h;
            let newton = if df != 0.0 { s - f / df } else { f64::NAN };
            s = if newton > lo && newton < hi {
                newton
            } else {
                0.5 * (lo + hi)
            };
            if (self.value(s)).abs() <= 1e-16 * (f_lo.abs() + f_hi.abs()) {
                break;
            }
        }
        if s.is_nan() {
            return lo;
        }
        s.clamp(lo, hi)
    }
}

/// Quintic Hermite interpolant of a gap's penetration over one step from its value, rate and
/// acceleration at both ends (error `O(h⁶)`): where the high-order integrators locate events.
#[derive(Debug, Clone, Copy)]
pub struct QuinticSegment {
    /// Coefficients of `p(s) = Σ c_k s^k`, `s ∈ [0, 1]` the fraction of the step.
    c: [f64; 6],
}

impl QuinticSegment {
    /// From `(y, y', y'')` at the start and at the end of a step of length `h`.
    pub fn new(start: [f64; 3], end: [f64; 3], h: f64) -> Self {
        let (c0, c1, c2) = (start[0], start[1] * h, 0.5 * start[2] * h * h);
        let d = end[0] - (c0 + c1 + c2);
        let e = end[1] * h - (c1 + 2.0 * c2);
        let f = end[2] * h * h - 2.0 * c2;
        Self {
            c: [
                c0,
                c1,
                c2,
                10.0 * d - 4.0 * e + 0.5 * f,
                -15.0 * d + 7.0 * e - f,
                6.0 * d - 3.0 * e + 0.5 * f,
            ],
        }
    }

    /// The Bernstein coefficients `b_i` of `p(s) = Σ b_i C(5,i) sⁱ (1 − s)^(5−i)`:
    /// `b_i = Σ_{k≤i} [C(i,k)/C(5,k)] c_k`.
    fn bernstein(&self) -> [f64; 6] {
        let [c0, c1, c2, c3, c4, c5] = self.c;
        [
            c0,
            c0 + 0.2 * c1,
            c0 + 0.4 * c1 + 0.1 * c2,
            c0 + 0.6 * c1 + 0.3 * c2 + 0.1 * c3,
            c0 + 0.8 * c1 + 0.6 * c2 + 0.4 * c3 + 0.2 * c4,
            c0 + c1 + c2 + c3 + c4 + c5,
        ]
    }

    /// `p(s)`.
    #[inline]
    pub fn value(&self, s: f64) -> f64 {
        let c = &self.c;
        c[0] + s * (c[1] + s * (c[2] + s * (c[3] + s * (c[4] + s * c[5]))))
    }

    /// `dp/ds` (the rate times the step length).
    #[inline]
    pub fn slope(&self, s: f64) -> f64 {
        let c = &self.c;
        c[1] + s * (2.0 * c[2] + s * (3.0 * c[3] + s * (4.0 * c[4] + s * 5.0 * c[5])))
    }

    /// `d²p/ds²`.
    #[inline]
    fn curvature(&self, s: f64) -> f64 {
        let c = &self.c;
        2.0 * c[2] + s * (6.0 * c[3] + s * (12.0 * c[4] + s * 20.0 * c[5]))
    }

    /// First `s ∈ (0, 1]` where `p` (`rate = false`) or `dp/ds` (`rate = true`) passes from
    /// `≤ 0` to `> 0` (`rising`) or from `≥ 0` to `< 0`, searched on `samples` equal
    /// sub-intervals and refined by safeguarded Newton; the start counts as on the near side.
    pub fn first_crossing(&self, rate: bool, rising: bool, samples: usize) -> Option<f64> {
        let sign = if rising { 1.0 } else { -1.0 };
        // p on [0, 1] lies in the convex hull of its Bernstein coefficients b_i, and p' in
        // that of 5 (b_{i+1} − b_i): no crossing when sign·p (or sign·p') stays ≤ 0 at all of
        // them (most steps, cheaply)
        let b = self.bernstein();
        let bound = if rate {
            (0..5)
                .map(|i| sign * (b[i + 1] - b[i]))
                .fold(f64::MIN, f64::max)
        } else {
            b.iter().map(|&bi| sign * bi).fold(f64::MIN, f64::max)
        };
        if bound <= 0.0 {
            return None;
        }
        let g = |s: f64| sign * if rate { self.slope(s) } else { self.value(s) };
        let dg = |s: f64| {
            sign * if rate {
                self.curvature(s)
            } else {
                self.slope(s)
            }
        };
        let mut lo = 0.0;
        for k in 1..=samples {
            let hi = k as f64 / samples as f64;
            if g(hi) > 0.0 {
                return Some(refine_root(g, dg, lo, hi));
            }
            lo = hi;
        }
        None
    }
}

/// Root of `g` in `[lo, hi]` with `g(hi) > 0` and `g` taken as `≤ 0` at `lo`: Newton steps
/// kept inside the shrinking bracket, bisection otherwise.
fn refine_root(g: impl Fn(f64) -> f64, dg: impl Fn(f64) -> f64, lo: f64, hi: f64) -> f64 {
    let (mut lo, mut hi) = (lo, hi);
    let mut s = hi;
    for _ in 0..60 {
        let f = g(s);
        if f > 0.0 {
            hi = s;
        } else {
            lo = s;
        }
        if f == 0.0 || hi - lo < 1e-15 {
            break;
        }
        let d = dg(s);
        let newton = s - f / d;
        s = if newton > lo && newton < hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
    }
    s.clamp(lo, hi)
}

/// Vertex of the parabola through three samples `(t, y)`; returns the largest of the samples
/// and the vertex value when the middle sample is a local maximum.
pub fn parabola_peak(t: [f64; 3], y: [f64; 3]) -> f64 {
    let max_sample = y[0].max(y[1]).max(y[2]);
    if !(y[1] >= y[0] && y[1] >= y[2]) {
        return max_sample;
    }
    let (h0, h1) = (t[1] - t[0], t[2] - t[1]);
    if h0 <= 0.0 || h1 <= 0.0 {
        return max_sample;
    }
    // Divided differences: y(τ) = y1 + b τ + c τ², τ = t − t1.
    let d0 = (y[1] - y[0]) / h0;
    let d1 = (y[2] - y[1]) / h1;
    let c = (d1 - d0) / (h0 + h1);
    if c >= 0.0 {
        return max_sample;
    }
    let b = d0 + c * h0;
    let tau = (-b / (2.0 * c)).clamp(-h0, h1);
    (y[1] + b * tau + c * tau * tau).max(max_sample)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hermite_is_exact_for_cubics() {
        let f = |t: f64| 0.3 * t * t * t - 0.2 * t * t + 0.5 * t - 0.01;
        let df = |t: f64| 0.9 * t * t - 0.4 * t + 0.5;
        let (t0, h) = (0.1, 0.3);
        let seg = HermiteSegment {
            y0: f(t0),
            dy0: df(t0),
            y1: f(t0 + h),
            dy1: df(t0 + h),
            h,
        };
        for &s in &[0.0, 0.2, 0.5, 0.9, 1.0] {
            assert!((seg.value(s) - f(t0 + s * h)).abs() < 1e-15);
            assert!((seg.rate(s) - df(t0 + s * h)).abs() < 1e-14);
        }
    }

    #[test]
    fn crossing_of_a_cubic() {
        // y = (t - 0.37)(1 + t²) crosses zero at t = 0.37.
        let f = |t: f64| (t - 0.37) * (1.0 + t * t);
        let df = |t: f64| (1.0 + t * t) + 2.0 * t * (t - 0.37);
        let seg = HermiteSegment {
            y0: f(0.0),
            dy0: df(0.0),
            y1: f(1.0),
            dy1: df(1.0),
            h: 1.0,
        };
        assert!((seg.crossing() - 0.37).abs() < 1e-14);
        let down = HermiteSegment {
            y0: -seg.y0,
            dy0: -seg.dy0,
            y1: -seg.y1,
            dy1: -seg.dy1,
            h: 1.0,
        };
        assert!((down.crossing() - 0.37).abs() < 1e-14);
    }

    #[test]
    fn bernstein_form_equals_the_polynomial() {
        let seg = QuinticSegment::new([0.3, -1.2, 4.0], [-0.5, 2.5, -7.0], 0.8);
        let b = seg.bernstein();
        let binomial = [1.0, 5.0, 10.0, 10.0, 5.0, 1.0];
        for s in [0.0_f64, 0.17, 0.5, 0.91, 1.0] {
            let bernstein: f64 = (0..6)
                .map(|i| b[i] * binomial[i] * s.powi(i as i32) * (1.0 - s).powi(5 - i as i32))
                .sum();
            assert!((bernstein - seg.value(s)).abs() < 1e-14, "{s}");
        }
        // the hull bounds the polynomial, and the search finds no crossing outside it
        let (lo, hi) = b
            .iter()
            .fold((f64::MAX, f64::MIN), |(l, h), &x| (l.min(x), h.max(x)));
        assert!((0..=100).all(|k| (lo..=hi).contains(&seg.value(k as f64 / 100.0))));
    }

    #[test]
    fn interior_peak_of_a_cubic() {
        // y = 1e-3 - (t - 0.3)² + 0.1 (t - 0.3)³: peak at t = 0.3 (rate 0 there).
        let f = |t: f64| 1e-3 - (t - 0.3).powi(2) + 0.1 * (t - 0.3).powi(3);
        let df = |t: f64| -2.0 * (t - 0.3) + 0.3 * (t - 0.3).powi(2);
        let seg = HermiteSegment {
            y0: f(0.0),
            dy0: df(0.0),
            y1: f(1.0),
            dy1: df(1.0),
            h: 1.0,
        };
        let (s, peak) = seg.interior_peak().unwrap();
        assert!((s - 0.3).abs() < 1e-12);
        assert!((peak - 1e-3).abs() < 1e-15);
        let up = seg.crossing_between(0.0, s);
        assert!(f(up).abs() < 1e-15 && up < 0.3);
    }

    #[test]
    fn quintic_is_exact_for_quintics_and_finds_the_first_crossing() {
        // y = (t − 0.2)(t − 0.7)(t + 1)(t² + 1)/10, lowest power first
        let c = [
            0.013999999999999999,
            -0.07599999999999998,
            0.024000000000000007,
            0.02400000000000001,
            0.010000000000000009,
            0.1,
        ];
        let poly = |t: f64, k: usize| -> f64 {
            (k..6)
                .map(|p| {
                    let falling: f64 = (p + 1 - k..=p).map(|q| q as f64).product();
                    c[p] * falling * t.powi((p - k) as i32)
                })
                .sum()
        };
        let ends = |t: f64| [poly(t, 0), poly(t, 1), poly(t, 2)];
        let q = QuinticSegment::new(ends(0.0), ends(1.0), 1.0);
        for &s in &[0.0, 0.3, 0.55, 1.0] {
            assert!((q.value(s) - poly(s, 0)).abs() < 1e-15, "{s}");
            assert!((q.slope(s) - poly(s, 1)).abs() < 1e-14, "{s}");
        }
        // from +: down through 0.2; the rate turns (− to +) between the roots
        let down = q.first_crossing(false, false, 16).unwrap();
        assert!((down - 0.2).abs() < 1e-14, "{down}");
        let turn = q.first_crossing(true, true, 16).unwrap();
        assert!(
            poly(turn, 1).abs() < 1e-15 && turn > 0.2 && turn < 0.7,
            "{turn}"
        );
        // from − at t = 0.3 over a step of 0.9: up through 0.7, at s = 0.4 / 0.9
        let q = QuinticSegment::new(ends(0.3), ends(1.2), 0.9);
        let up = q.first_crossing(false, true, 16).unwrap();
        assert!((0.3 + 0.9 * up - 0.7).abs() < 1e-14, "{up}");
    }

    #[test]
    fn parabola_vertex() {
        let f = |t: f64| 2.0 - 3.0 * (t - 0.123).powi(2);
        let t = [0.0, 0.1, 0.25];
        let peak = parabola_peak(t, [f(t[0]), f(t[1]), f(t[2])]);
        assert!((peak - 2.0).abs() < 1e-14);
    }
}
