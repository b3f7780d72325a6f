//! The paper's five test metrics with 95 % confidence intervals: they live beside the
//! table ([`foosball_env::test_metrics`]) so that the Python front's test computes them
//! with the same code.

pub use foosball_env::test_metrics::*;
