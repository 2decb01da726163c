//! The lecture's one-dimensional Monte Carlo estimators of I = ∫₀¹ f(x) dx (lecture "Monte Carlo
//! methods", from "Monte Carlo quadrature" to "Russian roulette for single integral"), each a
//! small function generic over the integrand `f` and a source of uniform numbers:
//!
//! - `estimators`: primary, secondary and stratified estimates, importance sampling by CDF
//!   inversion (P⁻¹), combined sampling with the weightings of [`crate::mis`], the control
//!   function, and Russian roulette for a single integral;
//! - `distribution`: densities on [0, 1) with their sampler x = P⁻¹(u) and inverse u = P(x),
//!   analytic (linear ramp, truncated Lorentzian) and tabulated ([`Distribution1D`], inverted by
//!   binary search: the continuous form of the renderer's emitter selection,
//!   [`crate::sampling::sample_light`]);
//! - `integrands`: integrands with known integrals, each with its sampling strategies and
//!   control function, and Gauss–Legendre quadrature;
//! - `predict`: the variance each estimator should have, by the lecture's formulas;
//! - `experiment`: T independent estimates per estimator, their measured mean and variance
//!   against the prediction, and the lecture's variance relations (`wavetrace estimators`).
//!
//! [`roulette_f32`] is the form the path tracer's stopping criterion takes (the single-integral
//! roulette applied at every bounce, lecture "Russian roulette for integral equations"), for
//! `src/cpu/path.rs` and its GLSL twin to call.

mod distribution;
mod estimators;
mod experiment;
mod integrands;
mod predict;

pub use distribution::{Distribution1D, LinearRamp, Lorentzian, Sampler1D, UniformDensity};
pub use estimators::{
    combined, control, importance, primary, russian_roulette, secondary, secondary_of, stratified,
};
pub use experiment::{run, CheckOutcome, Report, Row, Section, Settings};
pub use integrands::{gauss_legendre, integrands, integrate, Integrand};
pub use predict::{balance_bound, cumulants, lecture_variance, Cumulants, Estimator};

use crate::sampling::rng_uniform4;

/// A source of uniform random numbers in [0, 1).
pub trait Uniform {
    /// The next number.
    fn next(&mut self) -> f64;
}

/// Any closure that returns numbers in [0, 1) is a source (tests use fixed sequences).
impl<F: FnMut() -> f64> Uniform for F {
    fn next(&mut self) -> f64 {
        self()
    }
}

/// The project's keyed random numbers ([`rng_uniform4`]) as a stream: number k of stream
/// (`seed`, `stream`, `block`) is component k mod 4 of `rng_uniform4(seed, stream, k / 4,
/// block)`. Streams differing in any key are independent; the same keys give the same numbers.
#[derive(Clone, Debug)]
pub struct KeyedUniforms {
    seed: u32,
    stream: u32,
    block: u32,
    index: u32,
}

impl KeyedUniforms {
    /// The stream keyed by (`seed`, `stream`, `block`), from its first number.
    pub fn new(seed: u32, stream: u32, block: u32) -> Self {
        KeyedUniforms {
            seed,
            stream,
            block,
            index: 0,
        }
    }
}

impl Uniform for KeyedUniforms {
    fn next(&mut self) -> f64 {
        let four = rng_uniform4(self.seed, self.stream, self.index / 4, self.block);
        let u = four[(self.index % 4) as usize];
        self.index = self.index.wrapping_add(1);
        u as f64
    }
}

/// Russian roulette (lecture, "Russian roulette for single integral"): with survival
/// probability `p`, the random number `u` survives when u < p and then carries the weight 1/p
/// that keeps the estimate unbiased; otherwise the estimate is 0 (`None`). p ≥ 1 always
/// survives with weight 1; p ≤ 0 or NaN never survives.
pub fn roulette(u: f64, p: f64) -> Option<f64> {
    roulette_in(u, p, 1.0)
}

/// [`roulette`] in f32, for the path tracer: `throughput *= w` for `Some(w)`, the path ends on
/// `None`.
pub fn roulette_f32(u: f32, p: f32) -> Option<f32> {
    roulette_in(u, p, 1.0)
}

/// The case split of [`roulette`] for either precision (`one` is 1 in it).
fn roulette_in<T: Copy + PartialOrd + std::ops::Div<Output = T>>(u: T, p: T, one: T) -> Option<T> {
    if p >= one {
        Some(one)
    } else if u < p {
        Some(one / p)
    } else {
        None
    }
}

#[cfg(test)]
mod tests;
