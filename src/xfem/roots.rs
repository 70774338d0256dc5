//! Bracketed scalar root finding (Illinois variant of regula falsi) for interface points.

/// Iteration cap; the Illinois method gains ≈ 1.44 digits per step on smooth functions, so the cap
/// is only reached for pathological (non-smooth) functions, which end up bisected.
const MAX_ITER: usize = 100;

/// A root of `f` in [a, b] given `fa = f(a)` and `fb = f(b)` with `fa · fb ≤ 0`, to an interval
/// width of `tol`. Returns an end point exactly when it is a zero. Never leaves [a, b], so it
/// cannot produce NaN from a valid bracket.
///
/// # Panics
/// Panics (debug builds) when the values do not bracket a root, a broken contract of the caller.
pub(crate) fn bracketed_root(
    mut f: impl FnMut(f64) -> f64,
    mut a: f64,
    mut b: f64,
    mut fa: f64,
    mut fb: f64,
    tol: f64,
) -> f64 {
    debug_assert!(
        fa * fb <= 0.0,
        "bracketed_root: f({a}) = {fa}, f({b}) = {fb}"
    );
    if fa == 0.0 {
        return a;
    }
    if fb == 0.0 {
        return b;
    }
    // Which end was kept last time (+1: a kept, −1: b kept) for the Illinois halving.
    let mut kept = 0i8;
    for _ in 0..MAX_ITER {
        if (b - a).abs() <= tol {
            break;
        }
        let mut c = (a * fb - b * fa) / (fb - fa);
        // Safeguard: regula falsi must land strictly inside the bracket, else bisect.
        if !(c > a.min(b) && c < a.max(b)) {
            c = 0.5 * (a + b);
        }
        let fc = f(c);
        if fc == 0.0 {
            return c;
        }
        if (fc > 0.0) == (fb > 0.0) {
            b = c;
            fb = fc;
            if kept == 1 {
                fa *= 0.5;
            }
            kept = 1;
        } else {
            a = c;
            fa = fc;
            if kept == -1 {
                fb *= 0.5;
            }
            kept = -1;
        }
    }
    if fa.abs() < fb.abs() {
        a
    } else {
        b
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_roots_of_smooth_and_kinked_functions() {
        // The requested interval width.
        const TOL: f64 = 1e-15;
        let r = bracketed_root(|x| x * x - 2.0, 0.0, 2.0, -2.0, 2.0, TOL);
        assert!((r - 2f64.sqrt()).abs() < 4.0 * TOL);
        // A kinked distance-like function (min of two lines) still converges.
        let g = |x: f64| (x - 0.3).min(0.5 * (x - 0.3));
        let r = bracketed_root(g, 0.0, 1.0, g(0.0), g(1.0), TOL);
        assert!((r - 0.3).abs() < 4.0 * TOL);
        // End points that are zeros are returned exactly.
        assert_eq!(bracketed_root(|x| x, 0.0, 1.0, 0.0, 1.0, TOL), 0.0);
        assert_eq!(bracketed_root(|x| x - 1.0, 0.0, 1.0, -1.0, 0.0, TOL), 1.0);
    }
}
