//! The arithmetic floor under a small-network update on this machine's core: its peak f32
//! rate and the matrix-product FLOPs of one SAC or TD3 update on the host MLP path, so an
//! update time can be read against what the core can do at all (issue 51's targets were
//! set from a core with a 162 GFLOP/s floor).
//!
//! - **Peak**: independent fused multiply-adds on twelve accumulators (no loads), 256-bit
//!   (AVX2 + FMA) and, where the CPU has it, 512-bit (AVX-512F) vectors; the larger is
//!   the core's f32 peak. A 512-bit FMA counts 32 FLOPs, whatever the core's datapath
//!   width (some cores split it in two halves: then both widths give one rate).
//! - **gemm**: one `[n, n] x [n, n]` product through the host MLP path's `gemm` on one
//!   thread, n = 1024, for how near a real product comes to the peak.
//! - **FLOPs of an update**, batch 256, 38-dim observations and 8-dim actions, counted
//!   from the layer shapes as the host path computes them (`host_critic`, `host_actor`,
//!   the algorithms' `*_networks` steps): every forward pass, every weight gradient, and
//!   the input gradients of every layer that has one to pass down (the first layer's only
//!   where the critic is walked back to its action input). SAC: the actor on `s'`, both
//!   target critics on `(s', a')`, both critics forward and back, the actor on `s`, both
//!   critics on `(s, a~)` walked back to `a~`, the actor back. TD3: the target actor on
//!   `s'`, both target critics, both critics forward and back, and every second step
//!   (`policy_delay` 2) the actor on `s`, the first critic walked back to its action, the
//!   actor back. Element-wise math, Adam and Polyak are not counted (they are not
//!   products and cost more than their FLOPs say).
//! - **Floor**: FLOPs / peak, the update's time if its products ran at the peak and
//!   nothing else took any time.
//!
//! `cargo bench -p foosball-nets --bench flop_floor` (one thread; an idle machine, or the
//! figure is what is left of a core); figures also go to `target/bench/flop_floor.json`
//! (`fma_peak_gflops`, `fma256_gflops`, `fma512_gflops`, `gemm_1024_gflops`,
//! `sac_update_mflop_64x64`, `sac_floor_ms_64x64`, the same for TD3 and for 256x256).

use foosball_nets::{Activation, HostMlp, MlpTape};
use std::time::Instant;

#[path = "../../../benches/figures.rs"]
mod figures;

const BATCH: usize = 256;
const OBS: usize = 38;
const ACT: usize = 8;
/// Independent accumulators: enough to cover the FMA latency on two pipes.
const LANES_ACC: usize = 12;

/// Per-sample multiply-adds of a two-hidden-layer MLP `input -> h -> h -> output`: its
/// forward pass (a weight gradient costs the same), the input gradients of layers 1 and 2,
/// and those of layer 0 (needed only where a critic is walked back to its action input).
struct Passes {
    forward: usize,
    inputs_above_first: usize,
    first_inputs: usize,
}

fn passes(input: usize, hidden: usize, output: usize) -> Passes {
    let layers = [input * hidden, hidden * hidden, hidden * output];
    Passes {
        forward: layers.iter().sum(),
        inputs_above_first: layers[1] + layers[2],
        first_inputs: layers[0],
    }
}

/// FLOPs of one SAC update at batch 256 (see the module docs for what is counted).
fn sac_flops(hidden: usize) -> f64 {
    let actor = passes(OBS, hidden, 2 * ACT);
    let critic = passes(OBS + ACT, hidden, 1);
    let per_sample = actor.forward // a' on s'
        + 2 * critic.forward // target critics on (s', a')
        + 2 * (2 * critic.forward + critic.inputs_above_first) // critics' loss
        + actor.forward // a~ on s
        + 2 * (critic.forward + critic.inputs_above_first + critic.first_inputs) // to a~
        + actor.forward // the actor's weight gradients
        + actor.inputs_above_first;
    2.0 * (per_sample * BATCH) as f64
}

/// FLOPs of one TD3 update at batch 256, the actor's step every second update averaged in.
fn td3_flops(hidden: usize) -> f64 {
    let actor = passes(OBS, hidden, ACT);
    let critic = passes(OBS + ACT, hidden, 1);
    let every = actor.forward // target actor on s'
        + 2 * critic.forward // target critics
        + 2 * (2 * critic.forward + critic.inputs_above_first);
    let delayed = actor.forward
        + critic.forward
        + critic.inputs_above_first
        + critic.first_inputs
        + actor.forward // the actor's weight gradients
        + actor.inputs_above_first;
    2.0 * (every * BATCH) as f64 + (delayed * BATCH) as f64
}

/// GFLOP/s of `run(iters)`, which does `flops_per_iter` FLOPs an iteration: best of 5.
fn rate(flops_per_iter: f64, iters: usize, mut run: impl FnMut(usize) -> f32) -> f64 {
    let mut sink = 0.0;
    let best = (0..5)
        .map(|_| {
            let t = Instant::now();
            sink += run(iters);
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min);
    std::hint::black_box(sink);
    flops_per_iter * iters as f64 / best / 1e9
}

#[cfg(target_arch = "x86_64")]
mod fma {
    use super::LANES_ACC;
    use std::arch::x86_64::*;

    /// The multiply-add's factor and addend, hidden from the optimiser (known constants
    /// let it fold the loop away).
    fn opaque_factors() -> (f32, f32) {
        std::hint::black_box((0.999_999, 1e-7))
    }

    /// `iters` rounds of twelve independent 8-wide FMAs; their sum.
    #[target_feature(enable = "avx2,fma")]
    pub fn fma256(iters: usize) -> f32 {
        let (a, b) = opaque_factors();
        let (a, b) = (_mm256_set1_ps(a), _mm256_set1_ps(b));
        let mut acc = [_mm256_set1_ps(1.0); LANES_ACC];
        for _ in 0..iters {
            for v in &mut acc {
                *v = _mm256_fmadd_ps(*v, a, b);
            }
        }
        let mut out = [0.0_f32; 8];
        let sum = acc
            .iter()
            .fold(_mm256_setzero_ps(), |s, v| _mm256_add_ps(s, *v));
        // SAFETY: `out` holds the eight lanes an unaligned store writes.
        unsafe { _mm256_storeu_ps(out.as_mut_ptr(), sum) };
        out.iter().sum()
    }

    /// `iters` rounds of twelve independent 16-wide FMAs; their sum.
    #[target_feature(enable = "avx512f")]
    pub fn fma512(iters: usize) -> f32 {
        let (a, b) = opaque_factors();
        let (a, b) = (_mm512_set1_ps(a), _mm512_set1_ps(b));
        let mut acc = [_mm512_set1_ps(1.0); LANES_ACC];
        for _ in 0..iters {
            for v in &mut acc {
                *v = _mm512_fmadd_ps(*v, a, b);
            }
        }
        _mm512_reduce_add_ps(
            acc.iter()
                .fold(_mm512_setzero_ps(), |s, v| _mm512_add_ps(s, *v)),
        )
    }
}

/// GFLOP/s of one `[n, n] x [n, n]` f32 product on one thread: a one-layer host MLP of
/// `n` inputs and `n` outputs on a batch of `n` rows (its forward pass is that product
/// through `gemm` and a bias row per sample).
fn gemm_rate(n: usize) -> f64 {
    let params: Vec<f32> = (0..(n + 1) * n).map(|i| (i % 7) as f32 * 0.01).collect();
    let layer = HostMlp::new(vec![n, n], Activation::Relu, params).expect("a one-layer MLP");
    let x: Vec<f32> = (0..n * n).map(|i| (i % 5) as f32 * 0.1).collect();
    let mut tape = MlpTape::default();
    rate(2.0 * (n * n * n) as f64, 1, |_| {
        layer.forward(&x, &mut tape)[0]
    })
}

fn main() {
    let mut figures: Vec<(String, f64)> = Vec::new();
    let mut peak = 0.0_f64;
    #[cfg(target_arch = "x86_64")]
    {
        let iters = 20_000_000;
        if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") {
            // SAFETY: the CPU has AVX2 and FMA (checked above).
            let r = rate((LANES_ACC * 8 * 2) as f64, iters, |n| unsafe {
                fma::fma256(n)
            });
            println!("256-bit FMA: {r:.1} GFLOP/s");
            figures.push(("fma256_gflops".into(), r));
            peak = peak.max(r);
        }
        if is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU has AVX-512F (checked above).
            let r = rate((LANES_ACC * 16 * 2) as f64, iters, |n| unsafe {
                fma::fma512(n)
            });
            println!("512-bit FMA: {r:.1} GFLOP/s");
            figures.push(("fma512_gflops".into(), r));
            peak = peak.max(r);
        }
    }
    if peak == 0.0 {
        println!("no x86 FMA measured on this CPU: the floors below are not computed");
    } else {
        println!("peak (the larger): {peak:.1} GFLOP/s");
        figures.push(("fma_peak_gflops".into(), peak));
    }
    let g = gemm_rate(1024);
    println!("gemm 1024 x 1024 x 1024, one thread: {g:.1} GFLOP/s");
    figures.push(("gemm_1024_gflops".into(), g));
    for hidden in [64, 256] {
        let size = format!("{hidden}x{hidden}");
        for (algo, flops) in [("sac", sac_flops(hidden)), ("td3", td3_flops(hidden))] {
            let mflop = flops / 1e6;
            figures.push((format!("{algo}_update_mflop_{size}"), mflop));
            if peak > 0.0 {
                let floor = flops / (peak * 1e9) * 1e3;
                let at_gemm = flops / (g * 1e9) * 1e3;
                println!(
                    "{algo} update {size}: {mflop:.1} MFLOP of products; {floor:.3} ms at the peak, {at_gemm:.3} ms at gemm's large-product rate"
                );
                figures.push((format!("{algo}_floor_ms_{size}"), floor));
            }
        }
    }
    let path = figures::write_figures("flop_floor", &figures);
    println!("figures in {}", path.display());
}
