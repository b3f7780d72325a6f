//! Adam against PyTorch's update written out by hand, global-norm clipping, polyak
//! averaging and record round trips.

use burn::module::{Module, Param};
use foosball_nets::params::host_params;
use foosball_nets::store::{load_module, save_module};
use foosball_nets::{
    Activation, Adam, AdamConfig, Backend, Device, Mlp, Snapshot, Tensor, TensorData, polyak_update,
};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

#[derive(Module, Debug)]
struct TwoParams {
    a: Param<Tensor<1>>,
    b: Param<Tensor<2>>,
}

fn device() -> Device {
    Backend::default_cpu().unwrap().device().unwrap()
}

fn two_params(a: [f32; 2], b: [f32; 4], device: &Device) -> TwoParams {
    TwoParams {
        a: Param::from_tensor(Tensor::from_data(TensorData::new(a.to_vec(), [2]), device)),
        b: Param::from_tensor(Tensor::from_data(
            TensorData::new(b.to_vec(), [2, 2]),
            device,
        )),
    }
}

/// `loss = sum(w_a * a^2) / 2 + sum(w_b * b^2) / 2`, gradient `w * p`.
const W: [f64; 6] = [1.0, -2.0, 0.5, 3.0, -1.0, 4.0];

fn loss(m: &TwoParams, device: &Device) -> Tensor<1> {
    let wa = Tensor::<1>::from_data(TensorData::new(vec![1.0f32, -2.0], [2]), device);
    let wb = Tensor::<2>::from_data(
        TensorData::new(vec![0.5f32, 3.0, -1.0, 4.0], [2, 2]),
        device,
    );
    let la = (m.a.val().square() * wa).sum();
    let lb = (m.b.val().square() * wb).sum();
    (la + lb).mul_scalar(0.5)
}

/// torch.optim.Adam + clip_grad_norm_ in f64.
fn reference(mut p: Vec<f64>, steps: usize, lr: f64, max_norm: Option<f64>) -> Vec<f64> {
    let (b1, b2, eps) = (0.9f64, 0.999f64, 1e-8f64);
    let mut m = vec![0.0; p.len()];
    let mut v = vec![0.0; p.len()];
    for t in 1..=steps {
        let mut g: Vec<f64> = p.iter().zip(W).map(|(p, w)| p * w).collect();
        let norm = g.iter().map(|x| x * x).sum::<f64>().sqrt();
        if let Some(max) = max_norm {
            let c = (max / (norm + 1e-6)).min(1.0);
            g.iter_mut().for_each(|x| *x *= c);
        }
        for i in 0..p.len() {
            m[i] = b1 * m[i] + (1.0 - b1) * g[i];
            v[i] = b2 * v[i] + (1.0 - b2) * g[i] * g[i];
            let m_hat = m[i] / (1.0 - b1.powi(t as i32));
            let v_hat = v[i] / (1.0 - b2.powi(t as i32));
            p[i] -= lr * m_hat / (v_hat.sqrt() + eps);
        }
    }
    p
}

/// Where Adam runs: its fused host loop on flex, or its tensor ops (the GPU path, which
/// never reads the device) on flex and on every GPU backend compiled in.
#[derive(Clone, Copy, Debug)]
enum Path {
    Host,
    TensorOps(Backend),
}

fn paths() -> Vec<Path> {
    let mut paths = vec![Path::Host, Path::TensorOps(Backend::Flex)];
    paths.extend(
        [Backend::Wgpu, Backend::Vulkan]
            .into_iter()
            .filter(|b| b.is_compiled())
            .map(Path::TensorOps),
    );
    paths
}

impl Path {
    fn device(self) -> Device {
        match self {
            Path::Host => device(),
            Path::TensorOps(b) => b.device().unwrap(),
        }
    }

    fn adam(self, config: AdamConfig) -> Adam {
        match self {
            Path::Host => Adam::new(config),
            Path::TensorOps(_) => Adam::new(config).without_host_fast_path(),
        }
    }
}

/// `steps` Adam steps on every path; the paths agree to 2e-6 relative (the tensor-ops
/// path computes `t`'s bias corrections as `exp(t ln b)` in f32 and the norm in f32,
/// the host path `b^t` by `powi` and the norm in f64). Returns the host path's parameters
/// and reported gradient norms.
fn run(steps: usize, lr: f64, max_grad_norm: Option<f32>) -> (Vec<f32>, Vec<f32>) {
    let (host, norms) = run_resumed(steps, lr, max_grad_norm, Path::Host, None);
    for path in paths() {
        let (other, other_norms) = run_resumed(steps, lr, max_grad_norm, path, None);
        for (a, b) in host
            .iter()
            .zip(&other)
            .chain(norms.iter().zip(&other_norms))
        {
            assert!(
                (a - b).abs() <= 2e-6 * a.abs().max(1.0),
                "host {host:?} {norms:?} vs {path:?} {other:?} {other_norms:?}"
            );
        }
    }
    (host, norms)
}

/// `steps` Adam steps; with `resume_at = Some(k)` the optimiser's state is written to a
/// file after step `k` and a fresh optimiser goes on from it.
fn run_resumed(
    steps: usize,
    lr: f64,
    max_grad_norm: Option<f32>,
    path: Path,
    resume_at: Option<usize>,
) -> (Vec<f32>, Vec<f32>) {
    let device = path.device();
    let mut module = two_params([0.3, -1.5], [2.0, 0.1, -0.7, 1.2], &device);
    let fresh = || {
        path.adam(AdamConfig {
            max_grad_norm,
            ..AdamConfig::default()
        })
    };
    let mut adam = fresh();
    let mut norms = Vec::new();
    for k in 0..steps {
        if resume_at == Some(k) {
            let file = std::env::temp_dir()
                .join(format!("foosball-adam-{}-{path:?}.bin", std::process::id()));
            let mut snap = Snapshot::new();
            adam.save_state(&mut snap, "adam");
            snap.write(&file).unwrap();
            adam = fresh();
            adam.load_state(&Snapshot::read(&file).unwrap(), "adam", &device)
                .unwrap();
            std::fs::remove_file(file).unwrap();
        }
        let mut grads = loss(&module, &device).backward();
        let (m, report) = adam.step(module, &mut grads, lr);
        assert_eq!(report.applied.read(), 1.0);
        norms.push(report.grad_norm.read() as f32);
        module = m;
    }
    assert_eq!(adam.steps(), steps as u64);
    (host_params(&module).concat(), norms)
}

#[test]
fn adam_restored_from_its_saved_state_goes_on_bit_for_bit() {
    for path in paths() {
        let straight = run_resumed(6, 0.1, Some(0.5), path, None);
        let resumed = run_resumed(6, 0.1, Some(0.5), path, Some(3));
        assert_eq!(straight, resumed, "{path:?}");
    }
}

fn assert_close(got: &[f32], want: &[f64], tol: f64) {
    for (g, w) in got.iter().zip(want) {
        assert!(
            (f64::from(*g) - w).abs() <= tol * w.abs().max(1.0),
            "{got:?} vs {want:?}"
        );
    }
}

#[test]
fn adam_matches_pytorchs_update_with_eps_1e_8() {
    let start = vec![0.3, -1.5, 2.0, 0.1, -0.7, 1.2];
    let (got, norms) = run(5, 0.1, None);
    assert_close(&got, &reference(start.clone(), 5, 0.1, None), 1e-5);
    // First gradient is w * p0; its norm is reported before any clipping.
    let g0: f64 = start
        .iter()
        .zip(W)
        .map(|(p, w)| (p * w).powi(2))
        .sum::<f64>()
        .sqrt();
    assert!((f64::from(norms[0]) - g0).abs() < 1e-5);
}

#[test]
fn clipping_uses_one_norm_over_all_parameters() {
    let start = vec![0.3, -1.5, 2.0, 0.1, -0.7, 1.2];
    // Plain Adam is invariant to a constant gradient scale on the first step, so look at
    // three steps with a norm (about 5.9) clipped to 0.5: the global and per-tensor rules
    // then give different parameters.
    let (got, _) = run(3, 0.05, Some(0.5));
    assert_close(&got, &reference(start.clone(), 3, 0.05, Some(0.5)), 1e-5);
    let unclipped = reference(start, 3, 0.05, None);
    assert!(
        got.iter()
            .zip(&unclipped)
            .any(|(g, u)| (f64::from(*g) - u).abs() > 1e-4)
    );
}

/// A non-finite gradient is skipped whole: parameters, moments and the step count stay
/// as they were, so the steps after it are those of a run that never saw it. On the
/// tensor-ops path the skip is decided on the device (no read), which this also checks.
#[test]
fn a_non_finite_gradient_leaves_the_module_and_moments_alone() {
    for path in paths() {
        let device = path.device();
        let train = |bad_step: Option<usize>| {
            let mut module = two_params([0.3, -1.5], [2.0, 0.1, -0.7, 1.2], &device);
            let mut adam = path.adam(AdamConfig {
                max_grad_norm: Some(0.5),
                ..AdamConfig::default()
            });
            let mut applied = Vec::new();
            for k in 0..4 {
                let loss = loss(&module, &device);
                let loss = if bad_step == Some(k) {
                    loss.mul_scalar(f32::NAN)
                } else {
                    loss
                };
                let before = host_params(&module);
                let (m, report) = adam.step(module, &mut loss.backward(), 0.1);
                module = m;
                applied.push(report.applied.read());
                if bad_step == Some(k) {
                    assert!(report.grad_norm.read().is_nan(), "{path:?}");
                    assert_eq!(host_params(&module), before, "{path:?}");
                }
            }
            (host_params(&module).concat(), adam.steps(), applied)
        };
        let (clean, clean_steps, _) = train(None);
        for bad in [0, 2] {
            let (params, steps, applied) = train(Some(bad));
            assert_eq!(steps, 3, "{path:?}");
            let mut want = vec![1.0; 4];
            want[bad] = 0.0;
            assert_eq!(applied, want, "{path:?}");
            // Three good steps from the same start: the clean run's first three.
            let three = {
                let mut module = two_params([0.3, -1.5], [2.0, 0.1, -0.7, 1.2], &device);
                let mut adam = path.adam(AdamConfig {
                    max_grad_norm: Some(0.5),
                    ..AdamConfig::default()
                });
                for _ in 0..3 {
                    let mut grads = loss(&module, &device).backward();
                    module = adam.step(module, &mut grads, 0.1).0;
                }
                host_params(&module).concat()
            };
            // The skipped step changed nothing: three good steps in all.
            assert_eq!(params, three, "{path:?}");
            assert_ne!(params, clean, "{path:?}");
        }
        assert_eq!(clean_steps, 4);
    }
}

/// The GPU path reads nothing back from the device in a step: no host reads counted.
#[test]
fn the_tensor_ops_path_reads_nothing_back_in_a_step() {
    for path in paths() {
        let Path::TensorOps(backend) = path else {
            continue;
        };
        if backend == Backend::Flex {
            continue; // flex is a host device: its scalars are read at once, by design
        }
        let device = path.device();
        let mut module = two_params([0.3, -1.5], [2.0, 0.1, -0.7, 1.2], &device);
        let mut adam = path.adam(AdamConfig {
            max_grad_norm: Some(0.5),
            ..AdamConfig::default()
        });
        let reads = foosball_nets::host::reads();
        for _ in 0..5 {
            let mut grads = loss(&module, &device).backward();
            module = adam.step(module, &mut grads, 0.1).0;
            let mut target = two_params([0.0; 2], [0.0; 4], &device);
            polyak_update(&mut target, &module, 0.1);
        }
        assert_eq!(foosball_nets::host::reads(), reads, "{path:?}");
    }
}

#[derive(Module, Debug)]
struct OneParam {
    a: Param<Tensor<1>>,
}

/// A one-element parameter (SAC's log alpha) driven by a broadcast loss steps as on the
/// host path: on wgpu, burn-fusion 0.22 mixed up its fused outputs when the parameter
/// had the `[1]` shape of the step's scalars (it came back holding a moment).
#[test]
fn a_one_element_parameter_steps_as_on_the_host() {
    let run = |path: Path| {
        let device = path.device();
        let mut module = OneParam {
            a: Param::from_tensor(Tensor::from_data(
                TensorData::new(vec![0.0f32], [1]),
                &device,
            )),
        };
        let mut adam = path.adam(AdamConfig::default());
        (0..3)
            .map(|_| {
                let w =
                    Tensor::<1>::from_data(TensorData::new(vec![3.0f32, -1.0, 2.0], [3]), &device);
                let loss = (module.a.val() * w.add_scalar(-8.0)).mean().neg();
                adam.step_in_place(&mut module, &mut loss.backward(), 0.01);
                host_params(&module)[0][0]
            })
            .collect::<Vec<f32>>()
    };
    let host = run(Path::Host);
    assert!((host[2] + 0.03).abs() < 1e-6, "{host:?}");
    for path in paths() {
        let other = run(path);
        for (a, b) in host.iter().zip(&other) {
            assert!((a - b).abs() < 1e-6, "host {host:?} vs {path:?} {other:?}");
        }
    }
}

#[test]
fn polyak_moves_the_target_by_tau() {
    // Flex (host loop) and every GPU backend compiled in (tensor ops at each rank).
    let mut devices = vec![device()];
    devices.extend(
        [Backend::Wgpu, Backend::Vulkan]
            .into_iter()
            .filter(|b| b.is_compiled())
            .map(|b| b.device().unwrap()),
    );
    for device in devices {
        let online = two_params([1.0, 2.0], [3.0, 4.0, 5.0, 6.0], &device);
        let mut target = two_params([0.0; 2], [10.0; 4], &device);
        polyak_update(&mut target, &online, 0.25);
        let p = host_params(&target);
        assert_eq!(p[0], vec![0.25, 0.5], "{device:?}");
        assert_eq!(p[1], vec![8.25, 8.5, 8.75, 9.0], "{device:?}");
        // The online module is untouched.
        assert_eq!(host_params(&online)[0], vec![1.0, 2.0]);
    }
}

#[test]
fn records_round_trip_through_a_file() {
    let device = device();
    let dir = std::env::temp_dir().join(format!("foosball-nets-store-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("mlp.bpk");
    let saved = Mlp::new(
        5,
        &[7, 3],
        2,
        Activation::Relu,
        &mut ChaCha8Rng::seed_from_u64(1),
        &device,
    );
    save_module(&saved, &path).unwrap();
    let other = Mlp::new(
        5,
        &[7, 3],
        2,
        Activation::Relu,
        &mut ChaCha8Rng::seed_from_u64(2),
        &device,
    );
    assert_ne!(host_params(&other), host_params(&saved));
    let loaded = load_module(other, &path).unwrap();
    assert_eq!(host_params(&loaded), host_params(&saved));

    let wrong_shape = Mlp::new(
        5,
        &[8, 3],
        2,
        Activation::Relu,
        &mut ChaCha8Rng::seed_from_u64(2),
        &device,
    );
    let err = load_module(wrong_shape, &path).unwrap_err();
    assert!(err.to_string().contains("mlp.bpk"), "{err}");
    let missing = load_module(saved, &dir.join("missing.bpk")).unwrap_err();
    assert!(missing.to_string().contains("missing.bpk"), "{missing}");
    std::fs::remove_dir_all(&dir).unwrap();
}
