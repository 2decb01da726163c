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
//!   [`crate::lights::sample_light`]);
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
mod quadrature;
mod roulette;
mod uniform;

pub use distribution::{Distribution1D, LinearRamp, Lorentzian, Sampler1D, UniformDensity};
pub use estimators::{
    combined, control, importance, primary, russian_roulette, secondary, secondary_of, stratified,
};
pub use experiment::{run, CheckOutcome, Report, Row, Section, Settings};
pub use integrands::{integrands, Integrand};
pub use predict::{balance_bound, cumulants, lecture_variance, Cumulants, Estimator};
pub use quadrature::{gauss_legendre, integrate};
pub use roulette::{roulette, roulette_f32};
pub use uniform::{KeyedUniforms, Uniform};

#[cfg(test)]
mod tests;
