//! Restarted GMRES with right preconditioning, used to polish direct solves whose factorization
//! is inaccurate (and, later, to reuse an older factorization as a preconditioner).

/// Outcome of a GMRES run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GmresResult {
    /// Final relative residual ‖b − A x‖/‖b‖ (estimated by the Arnoldi recurrence, exact at restarts).
    pub residual: f64,
    /// Iterations (matrix–vector products) used.
    pub iterations: usize,
}

/// Solves A x = b by GMRES(`restart`) with right preconditioner M⁻¹, starting from `x`, until the
/// relative residual is below `tol` or `max_iter` iterations. `apply_a(v, out)` computes out = A v,
/// `apply_m(v)` replaces v by M⁻¹ v.
pub fn gmres<E>(
    apply_a: &dyn Fn(&[f64], &mut [f64]),
    apply_m: &mut dyn FnMut(&mut [f64]) -> Result<(), E>,
    b: &[f64],
    x: &mut [f64],
    tol: f64,
    max_iter: usize,
    restart: usize,
) -> Result<GmresResult, E> {
    let n = b.len();
    let bnorm = norm(b).max(f64::MIN_POSITIVE);
    let mut r = vec![0.0; n];
    let mut w = vec![0.0; n];
    let mut v: Vec<Vec<f64>> = Vec::with_capacity(restart + 1);
    let mut z = vec![0.0; n];
    let mut iterations = 0;
    loop {
        apply_a(x, &mut r);
        r.iter_mut().zip(b).for_each(|(ri, bi)| *ri = bi - *ri);
        let beta = norm(&r);
        let mut rel = beta / bnorm;
        if rel <= tol || iterations >= max_iter {
            return Ok(GmresResult {
                residual: rel,
                iterations,
            });
        }
        v.clear();
        v.push(r.iter().map(|ri| ri / beta).collect());
        let mut h = vec![vec![0.0; restart]; restart + 1];
        let (mut cs, mut sn) = (vec![0.0; restart], vec![0.0; restart]);
        let mut g = vec![0.0; restart + 1];
        g[0] = beta;
        let mut k_used = 0;
        for k in 0..restart {
            z.copy_from_slice(&v[k]);
            apply_m(&mut z)?;
            apply_a(&z, &mut w);
            iterations += 1;
            for (i, vi) in v.iter().enumerate() {
                h[i][k] = dot(&w, vi);
                w.iter_mut()
                    .zip(vi)
                    .for_each(|(wj, vj)| *wj -= h[i][k] * vj);
            }
            h[k + 1][k] = norm(&w);
            for i in 0..k {
                let t = cs[i] * h[i][k] + sn[i] * h[i + 1][k];
                h[i + 1][k] = -sn[i] * h[i][k] + cs[i] * h[i + 1][k];
                h[i][k] = t;
            }
            let d = h[k][k].hypot(h[k + 1][k]);
            (cs[k], sn[k]) = if d > 0.0 {
                (h[k][k] / d, h[k + 1][k] / d)
            } else {
                (1.0, 0.0)
            };
            h[k][k] = d;
            h[k + 1][k] = 0.0;
            g[k + 1] = -sn[k] * g[k];
            g[k] *= cs[k];
            k_used = k + 1;
            rel = g[k + 1].abs() / bnorm;
            let breakdown = d == 0.0 || !rel.is_finite();
            if rel <= tol || iterations >= max_iter || breakdown {
                break;
            }
            let wn = norm(&w);
            v.push(w.iter().map(|wj| wj / wn).collect());
        }
        // y = H⁻¹ g, x += M⁻¹ V y
        let mut y = vec![0.0; k_used];
        for i in (0..k_used).rev() {
            let s: f64 = (i + 1..k_used).map(|j| h[i][j] * y[j]).sum();
            y[i] = (g[i] - s) / h[i][i];
        }
        z.iter_mut().for_each(|zi| *zi = 0.0);
        for (j, yj) in y.iter().enumerate() {
            z.iter_mut().zip(&v[j]).for_each(|(zi, vi)| *zi += yj * vi);
        }
        apply_m(&mut z)?;
        x.iter_mut().zip(&z).for_each(|(xi, zi)| *xi += zi);
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gmres_solves_a_nonsymmetric_system_with_a_rough_preconditioner() {
        // tridiag(−1.3, 3, −0.7), n = 50, preconditioned by the diagonal only
        let n = 50;
        let a = |v: &[f64], out: &mut [f64]| {
            for i in 0..n {
                out[i] = 3.0 * v[i]
                    - if i > 0 { 1.3 * v[i - 1] } else { 0.0 }
                    - if i + 1 < n { 0.7 * v[i + 1] } else { 0.0 };
            }
        };
        let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.3).sin()).collect();
        let mut x = vec![0.0; n];
        let mut m = |v: &mut [f64]| -> Result<(), ()> {
            v.iter_mut().for_each(|vi| *vi /= 3.0);
            Ok(())
        };
        // tolerance of the solve; the check below recomputes the true residual
        const TOL: f64 = 1e-12;
        let res = gmres(&a, &mut m, &b, &mut x, TOL, 200, 20).unwrap();
        let mut r = vec![0.0; n];
        a(&x, &mut r);
        let true_res = r
            .iter()
            .zip(&b)
            .map(|(ri, bi)| (bi - ri).powi(2))
            .sum::<f64>()
            .sqrt()
            / b.iter().map(|v| v * v).sum::<f64>().sqrt();
        assert!(
            res.residual <= TOL && true_res <= 10.0 * TOL,
            "{res:?} true {true_res:e}"
        );
        assert!(res.iterations < 60);
    }
}
