//! Russian roulette for a single integral (lecture "Russian roulette for single integral"), and
//! the form the path tracer's stopping criterion takes ([`roulette_f32`], lecture "Russian
//! roulette for integral equations").

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
