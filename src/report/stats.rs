//! Aggregates over seeds, the rliable way (Agarwal et al., 2021): the mean and the
//! interquartile mean (IQM) of per-seed scores, each with a 95 % percentile-bootstrap
//! interval from resampling seeds with replacement. rliable's bootstrap is stratified by
//! task; a group here is one task (one table preset), so its only stratum is its seeds.

use crate::play::metrics::Estimate;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Bootstrap resamples per interval (rliable's default is 50,000 for its figures and
/// 2,000 in its examples).
pub const RESAMPLES: usize = 5_000;

/// Seed of the bootstrap's own random stream: reports are reproducible.
const BOOTSTRAP_SEED: u64 = 0x5EED_B007;

/// Arithmetic mean (NaN for no values).
pub fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / x.len() as f64
}

/// Interquartile mean: the mean of the values left after cutting `floor(n / 4)` from each
/// end of the sorted values (`scipy.stats.trim_mean(x, 0.25)`, rliable's IQM).
pub fn iqm(x: &[f64]) -> f64 {
    let mut sorted = x.to_vec();
    sorted.sort_by(f64::total_cmp);
    let cut = x.len() / 4;
    mean(&sorted[cut..x.len() - cut])
}

/// The `q`-quantile (`q` in [0, 1]) of sorted values, linearly interpolated
/// (`numpy.percentile`'s default).
pub fn quantile(sorted: &[f64], q: f64) -> f64 {
    let pos = q * (sorted.len() - 1) as f64;
    let (lo, hi) = (pos.floor() as usize, pos.ceil() as usize);
    sorted[lo] + (sorted[hi] - sorted[lo]) * (pos - lo as f64)
}

/// 95 % percentile interval of `statistic(samples...)` over `resamples` bootstrap draws,
/// each sample set resampled with replacement on its own (independent groups).
pub fn bootstrap_ci(
    samples: &[&[f64]],
    statistic: impl Fn(&[Vec<f64>]) -> f64,
    resamples: usize,
) -> [f64; 2] {
    let mut rng = ChaCha8Rng::seed_from_u64(BOOTSTRAP_SEED);
    let mut draws: Vec<Vec<f64>> = samples.iter().map(|s| vec![0.0; s.len()]).collect();
    let mut stats: Vec<f64> = (0..resamples)
        .map(|_| {
            for (draw, sample) in draws.iter_mut().zip(samples) {
                for v in draw.iter_mut() {
                    *v = sample[rng.random_range(0..sample.len())];
                }
            }
            statistic(&draws)
        })
        .collect();
    stats.sort_by(f64::total_cmp);
    [quantile(&stats, 0.025), quantile(&stats, 0.975)]
}

/// `stat` of per-seed values with its bootstrap interval.
pub fn over_seeds(x: &[f64], stat: fn(&[f64]) -> f64) -> Estimate {
    Estimate {
        mean: stat(x),
        ci95: bootstrap_ci(&[x], |d| stat(&d[0]), RESAMPLES),
    }
}

/// `stat(a) / stat(b)` with its bootstrap interval (a and b resampled independently).
pub fn ratio_over_seeds(a: &[f64], b: &[f64], stat: fn(&[f64]) -> f64) -> Estimate {
    Estimate {
        mean: stat(a) / stat(b),
        ci95: bootstrap_ci(&[a, b], |d| stat(&d[0]) / stat(&d[1]), RESAMPLES),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn iqm_trims_a_quarter_from_each_end() {
        // n = 6: cut 1 each side -> mean(2, 3, 4, 5).
        assert_eq!(iqm(&[5.0, 1.0, 100.0, 3.0, 2.0, 4.0]), 3.5);
        // n = 5: cut 1 -> mean(2, 3, 4); n = 3: nothing cut.
        assert_eq!(iqm(&[1.0, 2.0, 3.0, 4.0, 50.0]), 3.0);
        assert_eq!(iqm(&[1.0, 2.0, 6.0]), 3.0);
        // n = 8: cut 2 -> mean(3, 4, 5, 6).
        assert_eq!(iqm(&[8.0, 7.0, 6.0, 5.0, 4.0, 3.0, 2.0, 1.0]), 4.5);
    }

    #[test]
    fn quantiles_interpolate_like_numpy() {
        let x = [1.0, 2.0, 3.0, 4.0];
        assert_eq!(quantile(&x, 0.0), 1.0);
        assert_eq!(quantile(&x, 1.0), 4.0);
        // numpy.percentile([1, 2, 3, 4], 25) = 1.75, 97.5 -> 3.925.
        assert!((quantile(&x, 0.25) - 1.75).abs() < 1e-12);
        assert!((quantile(&x, 0.975) - 3.925).abs() < 1e-12);
    }

    #[test]
    fn bootstrap_of_two_seeds_spans_both_values() {
        // Means of resamples of {0, 1}: 0 (p 1/4), 0.5 (1/2), 1 (1/4): the 2.5 and 97.5
        // percentiles are 0 and 1.
        let e = over_seeds(&[0.0, 1.0], mean);
        assert_eq!(e.mean, 0.5);
        assert_eq!(e.ci95, [0.0, 1.0]);
        // No spread, no interval.
        assert_eq!(over_seeds(&[0.3; 5], iqm).ci95, [0.3, 0.3]);
    }

    #[test]
    fn bootstrap_intervals_cover_the_estimate_and_are_reproducible() {
        let x = [0.1, 0.4, 0.35, 0.2, 0.3];
        let a = over_seeds(&x, mean);
        assert!(a.ci95[0] < a.mean && a.mean < a.ci95[1], "{a:?}");
        assert!(a.ci95[0] >= 0.1 && a.ci95[1] <= 0.4);
        assert_eq!(a, over_seeds(&x, mean));
        let r = ratio_over_seeds(&[2.0, 2.0], &[1.0, 1.0], mean);
        assert_eq!((r.mean, r.ci95), (2.0, [2.0, 2.0]));
    }
}
