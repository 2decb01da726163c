//! The lecture's other half: light tracing ("next event estimation for light tracing") and
//! bidirectional path tracing (Veach & Guibas 1995; Veach 1997, ch. 10), on the CPU.
//!
//! Both build subpaths of [`Vertex`]es. A camera subpath starts at the pinhole with the path
//! tracer's primary ray and scatters with the path tracer's random numbers; a light subpath
//! starts on an emitter chosen by power (a uniform point on its triangle and a cosine-weighted
//! direction, or a punctual light's position and a uniform direction in its cone) and scatters
//! with the adjoint BSDF. Every (s, t) pair — s light vertices, t camera vertices — is one
//! strategy; `light` uses the t = 1 strategies alone (every light vertex joined to the camera,
//! weight 1), `bdpt` all of them, weighted by `--mis` over all strategies that can make the path.
//!
//! ## The measurement, stated once
//! With x₀ the emitter end and the path's vertices joined by the geometric term
//! G(a, b) = |cos_a| |cos_b| / r² (cosines of the geometric normals; 1 at a point light, the angle
//! to the view axis at the camera), a path contributes
//! Le · G · φ(x₁) · G · … · φ(x_k) · G · W_e, where a scattering vertex's factor is
//! φ(ω_c, ω_l) = f(ω_c, ω_l) |n_s·ω_l| / |n_g·ω_l|, f the path tracer's BSDF seen from the
//! camera side ω_c (`BsdfFrame::new_shading(…, ω_c)`, radiance mode) and n_s its shading normal.
//! That is exactly what the path tracer integrates, so every integrator has the same
//! expectation. A light subpath's throughput picks up φ·|n_g·ω_c| / p(ω_c) per vertex: Veach's
//! adjoint BSDF with the shading-normal correction (1997, §5.3, eq. 5.20), no η² for importance.
//!
//! The pinhole's importance is film-wide: W_e(ω) = 1 / (A cos⁴θ) in area measure, with
//! A = 4 tan²(fov/2)·aspect the film's area at unit distance and θ the angle to the view axis;
//! its direction pdf is 1 / (A cos³θ). Each sample index runs one light subpath per pixel, so a
//! batch of W·H light subpaths splats onto the film, and the sum of a batch's splats in a pixel
//! is one estimate of the pixel (film-wide importance is W·H times smaller than a pixel's). A
//! pixel's sample i is its own camera-path estimate plus the splats of batch i: the film keeps
//! its spp samples per pixel, with an honest variance.
//!
//! Splats are gathered per image row in parallel and added in row order, so the image is the
//! same bit for bit on every run whatever the thread count.

mod bdpt;
mod light_tracing;
mod samples;

pub use bdpt::{Bidir, Vertex};
pub use samples::{render_samples, write_strategies, StrategyFilms};

#[cfg(test)]
mod tests;
