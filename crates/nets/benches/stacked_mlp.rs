//! K small MLPs trained side by side (SAC's twin critics, K = 2; K seeds of a
//! multi-seed learner): K separate 2-D networks against one network whose weights are
//! stacked along a leading axis (`[K, in, out]`, Burn's batched matmul). Times one
//! forward and backward pass of all K (batch 256, input 46 = foosball's observation and
//! action, two hidden layers, one output) on the default CPU backend, and checks that
//! the stacked outputs and gradients equal the separate ones bit for bit.
//!
//! `cargo bench -p foosball-nets --bench stacked_mlp` (`RAYON_NUM_THREADS` sets the
//! threads); the figures also go to `target/bench/stacked_mlp.json`
//! (`separate_ms_k2_64x64`, `stacked_ms_k2_64x64`, ...).

use burn::tensor::activation::relu;
use foosball_nets::init::uniform_tensor;
use foosball_nets::{Backend, Device, Tensor};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

#[path = "../../../benches/figures.rs"]
mod figures;
#[path = "../../../benches/timing.rs"]
mod timing;
use timing::time_ms;

#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

const BATCH: usize = 256;
const INPUT: usize = 46;

/// One MLP's layers: weight `[in, out]` and bias `[out]`, trainable.
type Layers = Vec<(Tensor<2>, Tensor<1>)>;

/// A trainable leaf holding `t`'s values.
fn leaf<const D: usize>(t: Tensor<D>, device: &Device) -> Tensor<D> {
    Tensor::from_data(t.into_data(), device).require_grad()
}

/// `x [batch, in] -> [batch, 1]`, ReLU between layers.
fn separate(x: &Tensor<2>, layers: &Layers) -> Tensor<2> {
    let last = layers.len() - 1;
    layers.iter().enumerate().fold(x.clone(), |y, (i, (w, b))| {
        let y = y.matmul(w.clone()) + b.clone().unsqueeze::<2>();
        if i < last { relu(y) } else { y }
    })
}

/// `x [batch, in]` through all K stacked networks at once: `[K, batch, 1]`.
fn stacked(x: &Tensor<2>, layers: &[(Tensor<3>, Tensor<3>)], k: usize) -> Tensor<3> {
    let last = layers.len() - 1;
    let x: Tensor<3> = x.clone().unsqueeze::<3>().expand([k, BATCH, INPUT]);
    layers.iter().enumerate().fold(x, |y, (i, (w, b))| {
        let y = y.matmul(w.clone()) + b.clone();
        if i < last { relu(y) } else { y }
    })
}

fn host<const D: usize>(t: Tensor<D>) -> Vec<f32> {
    t.into_data().try_into_vec::<f32>().expect("f32 values")
}

fn main() {
    let device = Backend::default_cpu().unwrap().device().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let x = uniform_tensor([BATCH, INPUT], 1.0, &mut rng, &device);
    let mut figures = Vec::new();
    for hidden in [64, 256] {
        for k in [2, 5] {
            let widths = [INPUT, hidden, hidden, 1];
            let nets: Vec<Layers> = (0..k)
                .map(|_| {
                    widths
                        .windows(2)
                        .map(|w| {
                            let bound = 1.0 / (w[0] as f32).sqrt();
                            (
                                uniform_tensor([w[0], w[1]], bound, &mut rng, &device)
                                    .require_grad(),
                                uniform_tensor([w[1]], bound, &mut rng, &device).require_grad(),
                            )
                        })
                        .collect()
                })
                .collect();
            let stack: Vec<(Tensor<3>, Tensor<3>)> = (0..widths.len() - 1)
                .map(|l| {
                    let w = Tensor::stack::<3>(nets.iter().map(|n| n[l].0.clone()).collect(), 0);
                    let b = Tensor::stack::<2>(nets.iter().map(|n| n[l].1.clone()).collect(), 0);
                    (leaf(w, &device), leaf(b.unsqueeze_dim::<3>(1), &device))
                })
                .collect();

            // Same numbers: outputs and the first layer's weight gradients.
            let outs: Vec<Tensor<2>> = nets.iter().map(|n| separate(&x, n)).collect();
            let grads = outs
                .iter()
                .cloned()
                .reduce(|a, b| a + b)
                .unwrap()
                .sum()
                .backward();
            let out = stacked(&x, &stack, k);
            let stacked_out = host(out.clone());
            let stacked_grad = host(stack[0].0.grad(&out.sum().backward()).unwrap());
            let separate_out: Vec<f32> = outs.into_iter().flat_map(host).collect();
            let separate_grad: Vec<f32> = nets
                .iter()
                .flat_map(|n| host(n[0].0.grad(&grads).unwrap()))
                .collect();
            let same = stacked_out == separate_out && stacked_grad == separate_grad;

            let t_separate = time_ms(|| {
                let total = nets
                    .iter()
                    .map(|n| separate(&x, n))
                    .reduce(|a, b| a + b)
                    .unwrap();
                drop(total.sum().backward());
            });
            let t_stacked = time_ms(|| drop(stacked(&x, &stack, k).sum().backward()));
            println!(
                "K = {k}, {hidden}x{hidden}: separate {t_separate:.3} ms, stacked {t_stacked:.3} ms \
                 ({:.2}x), bit for bit the same: {same}",
                t_separate / t_stacked
            );
            let size = format!("k{k}_{hidden}x{hidden}");
            figures.push((format!("separate_ms_{size}"), t_separate));
            figures.push((format!("stacked_ms_{size}"), t_stacked));
        }
    }
    let path = figures::write_figures("stacked_mlp", &figures);
    println!("figures in {}", path.display());
}
