//! 1D vertex distributions for tensor-product meshes: uniform or graded toward a point.

/// Vertex coordinates of a 1D partition `v[0] < v[1] < … < v[n]` (n elements).
#[derive(Debug, Clone, PartialEq)]
pub struct Axis {
    /// Element vertex coordinates, strictly increasing.
    pub vertices: Vec<f64>,
}

impl Axis {
    /// `n` equal elements on [a, b].
    ///
    /// # Panics
    /// Panics if `n == 0` or `b <= a` (contract: callers validate their specs first).
    pub fn uniform(a: f64, b: f64, n: usize) -> Self {
        assert!(n > 0 && b > a, "Axis::uniform needs n > 0 and b > a");
        Self {
            vertices: (0..=n).map(|i| a + (b - a) * i as f64 / n as f64).collect(),
        }
    }

    /// `n` elements on [a, b], graded smoothly toward `focus` ∈ [a, b] by the map
    /// x(s) = focus + c·sinh(k (s − s₀)), s ∈ [0, 1]: element sizes grow geometrically-like
    /// away from `focus`, the ratio of the largest to the smallest element being about cosh(k)
    /// for a focus at an end. `k = 0` gives the uniform axis.
    ///
    /// # Panics
    /// Panics if `n == 0`, `b <= a`, `k < 0` or `focus` outside [a, b].
    pub fn graded(a: f64, b: f64, n: usize, focus: f64, k: f64) -> Self {
        assert!(n > 0 && b > a && k >= 0.0, "Axis::graded: bad arguments");
        assert!(
            (a..=b).contains(&focus),
            "Axis::graded: focus outside [a, b]"
        );
        if k < 1e-12 {
            return Self::uniform(a, b, n);
        }
        // Find s0 with (focus − a)/(b − focus) = sinh(k s0)/sinh(k (1 − s0)), by bisection.
        let f = |s0: f64| (focus - a) * (k * (1.0 - s0)).sinh() - (b - focus) * (k * s0).sinh();
        let (mut lo, mut hi) = (0.0, 1.0);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if f(mid) > 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let s0 = 0.5 * (lo + hi);
        let c = (b - a) / ((k * (1.0 - s0)).sinh() + (k * s0).sinh());
        let mut vertices: Vec<f64> = (0..=n)
            .map(|i| focus + c * (k * (i as f64 / n as f64 - s0)).sinh())
            .collect();
        vertices[0] = a;
        vertices[n] = b;
        Self { vertices }
    }

    /// `n` elements on [a, b], finest at the centre and graded symmetrically toward both ends so
    /// that the largest element is about `ratio` times the smallest ([`graded`](Self::graded)
    /// with k = 2 acosh(ratio)); `ratio = 1` is uniform.
    ///
    /// # Panics
    /// Panics if `ratio < 1` or as [`graded`](Self::graded).
    pub fn centred(a: f64, b: f64, n: usize, ratio: f64) -> Self {
        assert!(ratio >= 1.0, "Axis::centred: ratio {ratio} < 1");
        Self::graded(a, b, n, 0.5 * (a + b), 2.0 * ratio.acosh())
    }

    /// Uniform elements of size ≈ `h` on the band [lo, hi] ⊂ [a, b], and outside it elements
    /// growing geometrically by `growth` (≥ 1) toward the ends, scaled to end exactly at a and b.
    /// For resolving a region (a particle's neighbourhood) without refining the whole domain.
    ///
    /// # Panics
    /// Panics unless a ≤ lo < hi ≤ b, h > 0 and growth ≥ 1.
    pub fn banded(a: f64, b: f64, lo: f64, hi: f64, h: f64, growth: f64) -> Self {
        Self::banded_capped(a, b, lo, hi, h, growth, f64::INFINITY)
    }

    /// [`banded`](Self::banded) with the growth stopped at the element size `coarsest` (before
    /// the scaling to the ends): uniform ≈ `coarsest` far from the band, e.g. a mesh refined at
    /// one place that keeps a given resolution everywhere else.
    ///
    /// # Panics
    /// As [`banded`](Self::banded), and unless `coarsest` ≥ h.
    pub fn banded_capped(
        a: f64,
        b: f64,
        lo: f64,
        hi: f64,
        h: f64,
        growth: f64,
        coarsest: f64,
    ) -> Self {
        assert!(
            a <= lo && lo < hi && hi <= b && h > 0.0 && growth >= 1.0 && coarsest >= h,
            "Axis::banded: bad arguments"
        );
        let nb = ((hi - lo) / h).round().max(1.0) as usize;
        let hb = (hi - lo) / nb as f64;
        let outer = |len: f64| -> Vec<f64> {
            // sizes hb·g, hb·g², … (at most `coarsest`) until they cover `len`, then scaled to
            // sum to `len`
            if len <= 0.0 {
                return Vec::new();
            }
            let mut sizes = Vec::new();
            let (mut size, mut sum) = (hb, 0.0);
            while sum < len {
                size = (size * growth).min(coarsest);
                sizes.push(size);
                sum += size;
                if sum >= len && sum - len > 0.5 * size && sizes.len() > 1 {
                    // dropping the last element leaves the smaller relative stretch
                    let last = sizes.pop().unwrap_or(size);
                    sum -= last;
                    break;
                }
            }
            let scale = len / sum;
            sizes.iter().map(|s| s * scale).collect()
        };
        let left = outer(lo - a);
        let right = outer(b - hi);
        let mut vertices = vec![a];
        let mut x = a;
        for s in left.iter().rev() {
            x += s;
            vertices.push(x);
        }
        let lo_idx = vertices.len() - 1;
        vertices[lo_idx] = lo;
        for i in 1..=nb {
            vertices.push(lo + hb * i as f64);
        }
        x = hi;
        for s in &right {
            x += s;
            vertices.push(x);
        }
        let n = vertices.len() - 1;
        vertices[n] = b;
        Self { vertices }
    }

    /// Number of elements.
    pub fn len(&self) -> usize {
        self.vertices.len() - 1
    }

    /// True if the axis has no elements (never, for a constructed axis).
    pub fn is_empty(&self) -> bool {
        self.vertices.len() < 2
    }

    /// Coordinate of Q2 node `i` (even: vertex `i/2`, odd: midpoint of element `i/2`).
    #[inline]
    pub fn q2_coord(&self, i: usize) -> f64 {
        if i.is_multiple_of(2) {
            self.vertices[i / 2]
        } else {
            0.5 * (self.vertices[i / 2] + self.vertices[i / 2 + 1])
        }
    }

    /// Smallest element size.
    pub fn min_size(&self) -> f64 {
        self.vertices
            .windows(2)
            .map(|w| w[1] - w[0])
            .fold(f64::INFINITY, f64::min)
    }

    /// The continuous element index of `x`: `e + (x − x_e)/(x_{e+1} − x_e)` in element `e`
    /// (0 at the first vertex, `len()` at the last; linear extrapolation beyond the ends). The
    /// difference of two values is the number of elements between the points, fractions
    /// included.
    pub fn index_coordinate(&self, x: f64) -> f64 {
        let e = self.locate(x);
        let (a, b) = (self.vertices[e], self.vertices[e + 1]);
        e as f64 + (x - a) / (b - a)
    }

    /// Index of the element containing `x` (clamped to the ends).
    pub fn locate(&self, x: f64) -> usize {
        let n = self.len();
        match self
            .vertices
            .binary_search_by(|v| v.partial_cmp(&x).unwrap_or(std::cmp::Ordering::Less))
        {
            Ok(i) => i.min(n - 1),
            Err(i) => i.saturating_sub(1).min(n - 1),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn graded_axis_is_monotone_refined_at_focus_and_spans_interval() {
        let ax = Axis::graded(-15.0, 15.0, 60, 0.0, 3.0);
        assert_eq!(ax.len(), 60);
        assert_eq!(ax.vertices[0], -15.0);
        assert_eq!(ax.vertices[60], 15.0);
        assert!(ax.vertices.windows(2).all(|w| w[1] > w[0]));
        let h: Vec<f64> = ax.vertices.windows(2).map(|w| w[1] - w[0]).collect();
        // symmetric focus: smallest elements in the middle, ratio ≈ cosh(k·1/2)·… > 2
        assert!(h[30] < h[0] / 2.0);
        assert!((h[29] - h[30]).abs() < 1e-12, "symmetric about the focus");
        let end = Axis::graded(1.0, 4.0, 20, 1.0, 2.0);
        let he: Vec<f64> = end.vertices.windows(2).map(|w| w[1] - w[0]).collect();
        assert!(he.windows(2).all(|w| w[1] > w[0]));
        assert!((he[19] / he[0] - 2.0f64.cosh()).abs() / 2.0f64.cosh() < 0.2);
    }

    #[test]
    fn banded_axis_is_uniform_in_band_and_grows_outside() {
        let ax = Axis::banded(-15.0, 15.0, -1.5, 1.5, 0.05, 1.1);
        assert_eq!(ax.vertices[0], -15.0);
        assert_eq!(*ax.vertices.last().unwrap(), 15.0);
        assert!(ax.vertices.windows(2).all(|w| w[1] > w[0]));
        let h: Vec<f64> = ax.vertices.windows(2).map(|w| w[1] - w[0]).collect();
        let i = ax.locate(0.0);
        assert!((h[i] - 0.05).abs() < 1e-12);
        // outside the band sizes grow by at most the growth factor (after scaling, ±20 %)
        assert!(h
            .windows(2)
            .all(|w| w[1] / w[0] < 1.1 * 1.2 && w[0] / w[1] < 1.1 * 1.2));
        let whole = Axis::banded(0.0, 1.0, 0.0, 1.0, 0.1, 1.2);
        assert_eq!(whole.len(), 10);
        // capped: the same band, sizes growing to ≈ 0.2 and no further (scaling: ±5 %)
        let capped = Axis::banded_capped(-15.0, 15.0, -1.5, 1.5, 0.05, 1.1, 0.2);
        let hc: Vec<f64> = capped.vertices.windows(2).map(|w| w[1] - w[0]).collect();
        assert!((hc[capped.locate(0.0)] - 0.05).abs() < 1e-12);
        assert!(hc.iter().all(|&s| s < 0.2 * 1.05), "capped at 0.2");
        assert!((hc[0] - 0.2).abs() < 0.2 * 0.05 && (hc[hc.len() - 1] - 0.2).abs() < 0.01);
        assert!(capped.len() > ax.len());
        let uncapped = Axis::banded_capped(-15.0, 15.0, -1.5, 1.5, 0.05, 1.1, f64::INFINITY);
        assert_eq!(uncapped.vertices, ax.vertices);
    }

    #[test]
    fn locate_finds_the_containing_element() {
        let ax = Axis::graded(0.0, 1.0, 10, 0.3, 2.0);
        for i in 0..10 {
            let mid = 0.5 * (ax.vertices[i] + ax.vertices[i + 1]);
            assert_eq!(ax.locate(mid), i);
        }
        assert_eq!(ax.locate(1.0), 9);
        assert_eq!(ax.locate(0.0), 0);
    }

    #[test]
    fn centred_axis_is_symmetric_with_the_requested_size_ratio() {
        let ax = Axis::centred(-0.5, 0.5, 40, 3.0);
        let sizes: Vec<f64> = ax.vertices.windows(2).map(|w| w[1] - w[0]).collect();
        for (a, b) in sizes.iter().zip(sizes.iter().rev()) {
            assert!((a - b).abs() < 1e-12, "symmetric");
        }
        let (lo, hi) = sizes.iter().fold((f64::INFINITY, 0.0_f64), |(lo, hi), &s| {
            (lo.min(s), hi.max(s))
        });
        assert!((sizes[19] - lo).abs() < 1e-15, "finest at the centre");
        // the continuous map's ratio is exactly 3; 40 elements sample it to within 5 %
        assert!((hi / lo - 3.0).abs() < 0.15, "ratio {}", hi / lo);
        assert_eq!(
            Axis::centred(0.0, 1.0, 8, 1.0).vertices,
            Axis::uniform(0.0, 1.0, 8).vertices
        );
    }
}
