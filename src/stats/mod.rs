//! Statistics for verification: special functions, p-values, Welch's t test, Pearson's χ² test,
//! and the per-tile two-sample comparison of two films (DESIGN.md, Verification 1–3).
//!
//! The special functions come from `statrs` (Γ, incomplete gamma and beta, the normal, Student
//! t and χ² distributions); a Numerical Recipes implementation (`stats/nr3.rs`) cross-checks
//! them in the tests.

mod compare;
mod distributions;
mod power;

pub use compare::{
    compare_films, film_mean, image_error, Comparison, ImageError, TileFailure,
    RELATIVE_MSE_EPSILON,
};
pub use distributions::{
    chi_square_gof, chi_square_p, chi_square_quantile_upper, incomplete_beta, incomplete_gamma_p,
    incomplete_gamma_q, ln_gamma, normal_quantile_upper, sidak, student_t_two_sided_p,
    welch_t_test,
};
pub use power::PowerModel;

#[cfg(test)]
mod nr3;
#[cfg(test)]
mod tests;
