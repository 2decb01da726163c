//! `wavetrace estimators`: the lecture's Monte Carlo estimators on 1-D integrals with known
//! values.

use super::options::parse_alpha;
use anyhow::Result;
use clap::Args;

#[derive(Args, Debug, Clone)]
pub struct EstimatorsArgs {
    /// N: samples per estimate (per strategy for combined sampling, strata for stratified).
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=65_536))]
    pub samples: u32,
    /// T: independent estimates per estimator, whose variance is measured.
    #[arg(long, default_value_t = 2000, value_parser = clap::value_parser!(u32).range(2..=1_000_000))]
    pub trials: u32,
    /// Random seed of the keyed random numbers.
    #[arg(long, default_value_t = 0)]
    pub seed: u32,
    /// Family-wise significance level of all checks, Šidák-corrected.
    #[arg(long, default_value_t = 0.01, value_parser = parse_alpha)]
    pub alpha: f64,
}

/// `wavetrace estimators`: prints the tables; true if every check passed.
pub(crate) fn estimators(args: &EstimatorsArgs) -> Result<bool> {
    let report = wavetrace::mc::run(wavetrace::mc::Settings {
        samples: args.samples as usize,
        trials: args.trials as usize,
        seed: args.seed,
        alpha: args.alpha,
    })?;
    print!("{report}");
    Ok(report.failures() == 0)
}
