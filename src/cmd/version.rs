//! What `wavetrace --version` and the reports say wavetrace is: the package version and the
//! commit it was built from (`build.rs`).

/// "0.1.0 (commit 1a2b3c4d5e6f)", "-dirty" where the checkout had uncommitted changes.
pub(crate) const LONG: &str = concat!(
    env!("CARGO_PKG_VERSION"),
    " (commit ",
    env!("WAVETRACE_COMMIT"),
    ")"
);
