//! Timing for the benches that include this file (`#[path]`): the median of repeated
//! timings of a closure.

use std::time::Instant;

/// Milliseconds per call of `f`, the median of 7 timings of 50 calls after 20 warm-ups.
pub fn time_ms(mut f: impl FnMut()) -> f64 {
    for _ in 0..20 {
        f();
    }
    let mut samples: Vec<f64> = (0..7)
        .map(|_| {
            let t = Instant::now();
            for _ in 0..50 {
                f();
            }
            t.elapsed().as_secs_f64() * 1e3 / 50.0
        })
        .collect();
    samples.sort_by(f64::total_cmp);
    samples[3]
}
