//! Statistical tools used by the tests and the experiments: goodness-of-fit
//! testing of samplers and special functions they need.

pub mod chi2;
