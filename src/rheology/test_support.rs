//! Deterministic random samples for the rheology tests (no random-number crate in the build).

use super::tensor::{Sym2, VelocityGradient};

/// SplitMix64 (Steele, Lea & Flood 2014): tiny, deterministic, good enough for test inputs.
pub struct TestRng(u64);

impl TestRng {
    pub fn new(seed: u64) -> Self {
        TestRng(seed)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[lo, hi)`.
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        let u = (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        lo + (hi - lo) * u
    }

    /// SPD tensor with a uniformly random eigenbasis and log-eigenvalues uniform in `[−r, r]`.
    pub fn spd(&mut self, r: f64) -> Sym2 {
        let theta = self.uniform(0.0, std::f64::consts::PI);
        let e = crate::rheology::tensor::SymEigen {
            values: [0.0, 0.0],
            cos: theta.cos(),
            sin: theta.sin(),
        };
        e.compose([self.uniform(-r, r).exp(), self.uniform(-r, r).exp()])
    }

    /// Velocity gradient with entries uniform in `[−a, a]`.
    pub fn gradient(&mut self, a: f64) -> VelocityGradient {
        VelocityGradient::new(
            self.uniform(-a, a),
            self.uniform(-a, a),
            self.uniform(-a, a),
            self.uniform(-a, a),
        )
    }
}

/// `|a − b| / max(|b|, 1)` in the Frobenius norm: relative for large tensors, absolute near zero.
pub fn rel_diff(a: Sym2, b: Sym2) -> f64 {
    (a - b).norm() / b.norm().max(1.0)
}
