//! Real roots of low-degree polynomials in an interval, robustly.
//!
//! Quadratics use the cancellation-free formula. Higher degrees (the torus quartic) use
//! derivative bracketing (Yuksel 2022, "High-Performance Polynomial Root Finding for Graphics"):
//! the roots of the derivative split the interval into pieces on which the polynomial is
//! monotonic, so each piece holds at most one root, found by safeguarded Newton iteration. This
//! never misses a sign-changing root and never diverges, unlike closed-form quartic formulas.

/// Real roots of `a t^2 + b t + c`, ascending. Degenerates gracefully to the linear case.
pub fn solve_quadratic(a: f64, b: f64, c: f64) -> ([f64; 2], usize) {
    if a == 0.0 {
        if b == 0.0 {
            return ([0.0; 2], 0);
        }
        return ([-c / b, 0.0], 1);
    }
    let discriminant = b * b - 4.0 * a * c;
    if discriminant < 0.0 || !discriminant.is_finite() {
        return ([0.0; 2], 0);
    }
    let root = discriminant.sqrt();
    let q = if b < 0.0 { -0.5 * (b - root) } else { -0.5 * (b + root) };
    if q == 0.0 {
        // b == 0 and c == 0: a double root at zero.
        return ([0.0, 0.0], 2);
    }
    let (t0, t1) = (q / a, c / q);
    if t0 <= t1 { ([t0, t1], 2) } else { ([t1, t0], 2) }
}

/// Evaluates a polynomial given by ascending coefficients (`c[0] + c[1] t + ...`).
#[inline]
fn eval(c: &[f64], t: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, &k| acc * t + k)
}

#[inline]
fn eval_with_derivative(c: &[f64], t: f64) -> (f64, f64) {
    let mut p = 0.0;
    let mut dp = 0.0;
    for &k in c.iter().rev() {
        dp = dp * t + p;
        p = p * t + k;
    }
    (p, dp)
}

/// The single root of a polynomial that is monotonic on `[lo, hi]` with `p(lo)` and `p(hi)` of
/// opposite signs: Newton steps kept inside a shrinking bracket, bisection when Newton leaves it.
fn bracketed_root(c: &[f64], mut lo: f64, mut hi: f64, p_lo: f64) -> f64 {
    let increasing = p_lo < 0.0;
    let mut t = 0.5 * (lo + hi);
    for _ in 0..100 {
        let (p, dp) = eval_with_derivative(c, t);
        if p == 0.0 {
            return t;
        }
        if (p < 0.0) == increasing {
            lo = t;
        } else {
            hi = t;
        }
        let newton = t - p / dp;
        let next = if dp != 0.0 && newton > lo && newton < hi { newton } else { 0.5 * (lo + hi) };
        if (next - t).abs() <= 1e-15 * t.abs().max(hi - lo) || hi - lo <= f64::EPSILON * t.abs() {
            return next;
        }
        t = next;
    }
    t
}

/// Real roots of the polynomial with ascending coefficients `c` (degree `c.len() - 1`, at most 4)
/// inside `[lo, hi]`, ascending. Roots where the polynomial touches zero without changing sign
/// (tangencies) may be reported once or not at all.
pub fn roots_in_interval(c: &[f64], lo: f64, hi: f64, out: &mut Vec<f64>) {
    out.clear();
    // Trim leading zero coefficients so the degree is honest.
    let mut n = c.len();
    while n > 0 && c[n - 1] == 0.0 {
        n -= 1;
    }
    let c = &c[..n];
    if n <= 1 || !(lo <= hi) {
        return;
    }
    if n == 2 {
        let t = -c[0] / c[1];
        if t >= lo && t <= hi {
            out.push(t);
        }
        return;
    }
    if n == 3 {
        let (r, k) = solve_quadratic(c[2], c[1], c[0]);
        out.extend(r[..k].iter().copied().filter(|t| *t >= lo && *t <= hi));
        return;
    }
    // Critical points from the derivative, recursively.
    let mut derivative = [0.0f64; 4];
    for i in 1..n {
        derivative[i - 1] = c[i] * i as f64;
    }
    let mut critical = Vec::with_capacity(4);
    roots_in_interval(&derivative[..n - 1], lo, hi, &mut critical);
    let mut a = lo;
    let mut p_a = eval(c, a);
    if p_a == 0.0 {
        out.push(a);
    }
    for &b in critical.iter().chain(std::iter::once(&hi)) {
        let p_b = eval(c, b);
        if p_b == 0.0 {
            if out.last() != Some(&b) {
                out.push(b);
            }
        } else if p_a != 0.0 && (p_a < 0.0) != (p_b < 0.0) {
            out.push(bracketed_root(c, a, b, p_a));
        }
        a = b;
        p_a = p_b;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quadratic_roots() {
        let (r, n) = solve_quadratic(1.0, -3.0, 2.0);
        assert_eq!(n, 2);
        assert!((r[0] - 1.0).abs() < 1e-15 && (r[1] - 2.0).abs() < 1e-15);
        // Cancellation-prone case: roots 1e-9 and 1e9.
        let (r, _) = solve_quadratic(1.0, -(1e9 + 1e-9), 1.0);
        assert!((r[0] - 1e-9).abs() < 1e-22);
        assert_eq!(solve_quadratic(1.0, 0.0, 1.0).1, 0);
        assert_eq!(solve_quadratic(0.0, 2.0, -4.0), ([2.0, 0.0], 1));
    }

    #[test]
    fn quartic_roots() {
        // (t-1)(t-2)(t-3)(t-4) = t^4 - 10 t^3 + 35 t^2 - 50 t + 24
        let c = [24.0, -50.0, 35.0, -10.0, 1.0];
        let mut out = Vec::new();
        roots_in_interval(&c, 0.0, 10.0, &mut out);
        assert_eq!(out.len(), 4, "{out:?}");
        for (i, r) in out.iter().enumerate() {
            assert!((r - (i + 1) as f64).abs() < 1e-12, "{out:?}");
        }
        roots_in_interval(&c, 2.5, 3.5, &mut out);
        assert_eq!(out.len(), 1);
        assert!((out[0] - 3.0).abs() < 1e-12);
        // Close roots: (t - 1)(t - 1.000001)(t^2 + 1).
        let (a, b) = (1.0, 1.000001);
        let c = [a * b, -(a + b), 1.0 + a * b, -(a + b), 1.0];
        roots_in_interval(&c, -5.0, 5.0, &mut out);
        assert_eq!(out.len(), 2, "{out:?}");
        assert!((out[0] - a).abs() < 1e-9 && (out[1] - b).abs() < 1e-9);
    }
}
