//! Densities on [0, 1) for importance sampling by CDF inversion (lecture, "PDF (density) p(x)":
//! "cumulative distribution function P(x) is known and invertible"; ξ = P⁻¹(τ)). Each comes as
//! a triple, sample x = P⁻¹(u), pdf p(x) with respect to length, and inverse u = P(x).

use anyhow::{bail, Result};

/// The largest f64 below 1, so that a sample stays inside [0, 1).
const ONE_MINUS_EPSILON: f64 = 1.0 - f64::EPSILON / 2.0;

/// A density on [0, 1) that can be sampled by inverting its CDF.
pub trait Sampler1D {
    /// x = P⁻¹(u) for u in [0, 1).
    fn sample(&self, u: f64) -> f64;
    /// p(x), density with respect to length on [0, 1).
    fn pdf(&self, x: f64) -> f64;
    /// u = P(x) = ∫₀ˣ p(t) dt, the u that [`Sampler1D::sample`] maps to x.
    fn invert(&self, x: f64) -> f64;
    /// What the density is, for the tables of `wavetrace estimators`.
    fn name(&self) -> String;
}

/// p(x) = 1: the primary estimate's own sampling.
#[derive(Clone, Copy, Debug)]
pub struct UniformDensity;

impl Sampler1D for UniformDensity {
    fn sample(&self, u: f64) -> f64 {
        u
    }
    fn pdf(&self, _x: f64) -> f64 {
        1.0
    }
    fn invert(&self, x: f64) -> f64 {
        x
    }
    fn name(&self) -> String {
        "uniform".into()
    }
}

/// p(x) = 2x: P(x) = x², so P⁻¹(u) = √u (the lecture's analytic inversion; the same warp
/// places points on a triangle in [`crate::sampling::sample_uniform_triangle`]).
#[derive(Clone, Copy, Debug)]
pub struct LinearRamp;

impl Sampler1D for LinearRamp {
    fn sample(&self, u: f64) -> f64 {
        u.sqrt()
    }
    fn pdf(&self, x: f64) -> f64 {
        2.0 * x
    }
    fn invert(&self, x: f64) -> f64 {
        x * x
    }
    fn name(&self) -> String {
        "2x (P⁻¹ = √u)".into()
    }
}

/// The Cauchy (Lorentzian) density of centre `c` and half width `w`, truncated to [0, 1):
/// p(x) = w / (Z (w² + (x − c)²)), P(x) = [atan((x − c)/w) − atan(−c/w)] / Z with
/// Z = atan((1 − c)/w) − atan(−c/w), so P⁻¹(u) = c + w tan(atan(−c/w) + u Z).
#[derive(Clone, Copy, Debug)]
pub struct Lorentzian {
    pub centre: f64,
    pub width: f64,
}

impl Lorentzian {
    /// atan(−c/w) and Z.
    fn angles(&self) -> (f64, f64) {
        let lo = (-self.centre / self.width).atan();
        let hi = ((1.0 - self.centre) / self.width).atan();
        (lo, hi - lo)
    }
}

impl Sampler1D for Lorentzian {
    fn sample(&self, u: f64) -> f64 {
        let (lo, z) = self.angles();
        (self.centre + self.width * (lo + u * z).tan()).clamp(0.0, ONE_MINUS_EPSILON)
    }
    fn pdf(&self, x: f64) -> f64 {
        let (_, z) = self.angles();
        let d = x - self.centre;
        self.width / (z * (self.width * self.width + d * d))
    }
    fn invert(&self, x: f64) -> f64 {
        let (lo, z) = self.angles();
        (((x - self.centre) / self.width).atan() - lo) / z
    }
    fn name(&self) -> String {
        format!("Lorentzian(c = {}, w = {})", self.centre, self.width)
    }
}

/// A piecewise-constant density on n equal bins of [0, 1), tabulated from non-negative values,
/// with its CDF inverted by binary search (pbrt-v3 §13.3.1 `Distribution1D`). The renderer's
/// emitter selection ([`crate::lights::sample_light`], `sample_light` in
/// `shaders/inc/scene.glsl`) is the discrete form of the same search over the light table's CDF.
#[derive(Clone, Debug)]
pub struct Distribution1D {
    /// The tabulated values.
    values: Vec<f64>,
    /// cdf[k] = Σ_{j<k} values[j] / Σ values; cdf[n] = 1.
    cdf: Vec<f64>,
    /// Σ values / n = ∫ of the step function.
    integral: f64,
    /// What the values came from.
    label: String,
}

impl Distribution1D {
    /// The density proportional to `values` (one per bin). Errors if a value is negative or not
    /// finite, or if all are 0.
    pub fn new(values: Vec<f64>, label: &str) -> Result<Self> {
        if values.is_empty() {
            bail!("{label}: a tabulated distribution needs at least one bin");
        }
        if let Some((k, v)) = values
            .iter()
            .enumerate()
            .find(|(_, v)| !(v.is_finite() && **v >= 0.0))
        {
            bail!("{label}: bin {k} has value {v}; values must be finite and non-negative");
        }
        let total: f64 = values.iter().sum();
        if total <= 0.0 {
            bail!(
                "{label}: all {} bins are 0, nothing to sample",
                values.len()
            );
        }
        let mut cdf = Vec::with_capacity(values.len() + 1);
        let mut running = 0.0;
        cdf.push(0.0);
        for v in &values {
            running += v;
            cdf.push(running / total);
        }
        *cdf.last_mut().expect("n + 1 entries") = 1.0;
        let integral = total / values.len() as f64;
        Ok(Distribution1D {
            values,
            cdf,
            integral,
            label: label.to_string(),
        })
    }

    /// The density proportional to the averages of `f` over `bins` equal bins (each average by
    /// Gauss–Legendre quadrature).
    pub fn from_function(f: impl Fn(f64) -> f64, bins: usize, label: &str) -> Result<Self> {
        let h = 1.0 / bins as f64;
        let values = (0..bins)
            .map(|k| super::quadrature::integrate(&f, k as f64 * h, (k + 1) as f64 * h, 4) / h)
            .collect();
        Self::new(values, label)
    }

    /// Number of bins.
    pub fn bins(&self) -> usize {
        self.values.len()
    }

    /// The bin k with cdf[k] ≤ u < cdf[k + 1] (binary search; bins of probability 0 are never
    /// returned since their two CDF entries are equal).
    fn find_bin(&self, u: f64) -> usize {
        let (mut lo, mut hi) = (0usize, self.values.len() - 1);
        while lo < hi {
            let mid = (lo + hi) / 2;
            if self.cdf[mid + 1] > u {
                hi = mid;
            } else {
                lo = mid + 1;
            }
        }
        lo
    }

    /// The bin holding x.
    fn bin_of(&self, x: f64) -> usize {
        ((x * self.values.len() as f64) as usize).min(self.values.len() - 1)
    }
}

impl Sampler1D for Distribution1D {
    fn sample(&self, u: f64) -> f64 {
        let k = self.find_bin(u);
        let (a, b) = (self.cdf[k], self.cdf[k + 1]);
        let t = if b > a { (u - a) / (b - a) } else { 0.0 };
        ((k as f64 + t) / self.values.len() as f64).min(ONE_MINUS_EPSILON)
    }
    fn pdf(&self, x: f64) -> f64 {
        if !(0.0..1.0).contains(&x) {
            return 0.0;
        }
        self.values[self.bin_of(x)] / self.integral
    }
    fn invert(&self, x: f64) -> f64 {
        let k = self.bin_of(x);
        let t = x * self.values.len() as f64 - k as f64;
        self.cdf[k] + t * (self.cdf[k + 1] - self.cdf[k])
    }
    fn name(&self) -> String {
        format!("table of {}, {} bins", self.label, self.bins())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mc::{integrate, KeyedUniforms, Uniform};
    use crate::stats::{chi_square_gof, sidak};

    fn samplers() -> Vec<Box<dyn Sampler1D>> {
        vec![
            Box::new(UniformDensity),
            Box::new(LinearRamp),
            Box::new(Lorentzian {
                centre: 0.3,
                width: 0.01,
            }),
            Box::new(Distribution1D::new(vec![0.5, 0.0, 2.0, 1.0, 0.0, 0.25], "steps").unwrap()),
        ]
    }

    #[test]
    fn pdfs_integrate_to_one_and_are_the_cdf_derivative() {
        for s in samplers() {
            let total = integrate(|x| s.pdf(x), 0.0, 1.0, 6000);
            assert!((total - 1.0).abs() < 1e-9, "{}: ∫p = {total}", s.name());
            // P(b) − P(a) = ∫ₐᵇ p on panels that do not straddle a bin edge of the table.
            for (a, b) in [(0.01, 0.15), (0.34, 0.49), (0.2, 0.31), (0.7, 0.83)] {
                let mass = integrate(|x| s.pdf(x), a, b, 2000);
                let diff = s.invert(b) - s.invert(a);
                assert!((mass - diff).abs() < 1e-9, "{}: {mass} vs {diff}", s.name());
            }
        }
    }

    #[test]
    fn inverse_round_trips() {
        for s in samplers() {
            let mut u = KeyedUniforms::new(1, 0, 0);
            for _ in 0..10_000 {
                let v = u.next();
                let x = s.sample(v);
                assert!((0.0..1.0).contains(&x), "{}: {v} -> {x}", s.name());
                assert!(s.pdf(x) > 0.0, "{}: sampled x = {x} of density 0", s.name());
                let back = s.invert(x);
                assert!(
                    (back - v).abs() < 1e-9,
                    "{}: {v} -> {x} -> {back}",
                    s.name()
                );
            }
        }
    }

    #[test]
    fn samples_follow_their_pdf() {
        // χ² on 60 equal cells (their edges hold the table's bin edges), expected mass by
        // quadrature of the pdf, α = 0.01 Šidák-corrected over the samplers.
        let list = samplers();
        let (cells, n) = (60usize, 200_000u32);
        for (i, s) in list.iter().enumerate() {
            let mut observed = vec![0f64; cells];
            let mut u = KeyedUniforms::new(2, i as u32, 0);
            for _ in 0..n {
                let x = s.sample(u.next());
                observed[((x * cells as f64) as usize).min(cells - 1)] += 1.0;
            }
            let h = 1.0 / cells as f64;
            let expected: Vec<f64> = (0..cells)
                .map(|k| n as f64 * integrate(|x| s.pdf(x), k as f64 * h, (k + 1) as f64 * h, 64))
                .collect();
            let (_, _, p) = chi_square_gof(&observed, &expected);
            assert!(
                p > sidak(0.01, list.len()),
                "{} does not sample its pdf: p = {p}",
                s.name()
            );
        }
    }

    #[test]
    fn bad_tables_are_errors() {
        assert!(Distribution1D::new(vec![], "empty").is_err());
        assert!(Distribution1D::new(vec![0.0, 0.0], "zeros").is_err());
        let e = Distribution1D::new(vec![1.0, -2.0], "neg").unwrap_err();
        assert!(e.to_string().contains("bin 1"), "{e}");
        assert!(Distribution1D::new(vec![1.0, f64::NAN], "nan").is_err());
    }
}
