//! The algorithm math against numbers produced by Stable-Baselines3's own code
//! (`../shared/reference/sb3/sb3_math.json`): GAE, the squashed and plain diagonal
//! Gaussian log-densities, and PPO's clipped objective.

use crate::common;

use foosball_rl::algos::ppo::{clipped_surrogate, normalize_advantages};
use foosball_rl::algos::rollout_buffer::gae;
use foosball_rl::algos::rows::{DeviceRows, Rows};
use foosball_rl::algos::tensors::{host, matrix};
use foosball_rl::nets::distributions::{
    diag_gaussian_entropy, diag_gaussian_log_prob, squashed_gaussian_log_prob,
};
use foosball_rl::nets::{Backend, Device};
use serde_json::Value;

fn cases() -> Option<Value> {
    let path = common::reference_file("sb3/sb3_math.json")?;
    let text = std::fs::read_to_string(path).unwrap();
    Some(serde_json::from_str::<Value>(&text).unwrap()["cases"].clone())
}

fn floats(v: &Value) -> Vec<f32> {
    match v {
        Value::Array(items) => items.iter().flat_map(floats).collect(),
        x => vec![x.as_f64().unwrap() as f32],
    }
}

fn width(v: &Value) -> usize {
    v[0].as_array().unwrap().len()
}

fn device() -> Device {
    Backend::default_cpu().unwrap().device().unwrap()
}

/// `|got - want| <= tol * max(|want|, 1)`.
fn assert_close(got: &[f32], want: &[f32], tol: f32, what: &str) {
    assert_eq!(got.len(), want.len(), "{what}: lengths");
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        assert!(
            (g - w).abs() <= tol * w.abs().max(1.0),
            "{what}[{i}]: {g} vs {w}"
        );
    }
}

#[test]
fn gae_matches_sb3_with_episode_starts_and_last_done() {
    let Some(cases) = cases() else { return };
    for name in ["gae_a", "gae_b"] {
        let c = &cases[name];
        let f = |k: &str| c[k].as_f64().unwrap() as f32;
        let (adv, ret) = gae(
            &floats(&c["rewards"]),
            &floats(&c["values"]),
            &floats(&c["episode_starts"]),
            &[f("last_value")],
            &[f("last_done")],
            f("gamma"),
            f("gae_lambda"),
        );
        assert_close(&adv, &floats(&c["advantages"]), 1e-5, name);
        assert_close(&ret, &floats(&c["returns"]), 1e-5, name);
    }
}

#[test]
fn squashed_gaussian_log_prob_matches_sb3_including_near_saturation() {
    let Some(cases) = cases() else { return };
    let c = &cases["squashed_gaussian"];
    let d = device();
    let a = width(&c["mean"]);
    let log_prob = squashed_gaussian_log_prob(
        matrix(&floats(&c["mean"]), a, &d),
        matrix(&floats(&c["log_std"]), a, &d),
        matrix(&floats(&c["gaussian_actions"]), a, &d),
    );
    let got = host(log_prob);
    let want = floats(&c["log_prob"]);
    // Rows 0-3 are ordinary; row 4 has |tanh(u)| within 1e-4 of 1.
    assert_close(&got[..4], &want[..4], 1e-5, "ordinary rows");
    assert_close(&got[4..], &want[4..], 1e-4, "saturated row");
    assert!(got.iter().all(|x| x.is_finite()));
}

#[test]
fn diag_gaussian_log_prob_and_entropy_match_sb3() {
    let Some(cases) = cases() else { return };
    let c = &cases["diag_gaussian"];
    let d = device();
    let a = width(&c["mean"]);
    let log_std = matrix(&floats(&c["log_std"]), a, &d);
    let log_prob = diag_gaussian_log_prob(
        matrix(&floats(&c["mean"]), a, &d),
        log_std.clone(),
        matrix(&floats(&c["actions"]), a, &d),
    );
    assert_close(&host(log_prob), &floats(&c["log_prob"]), 1e-5, "log_prob");
    assert_close(
        &host(diag_gaussian_entropy(log_std)),
        &floats(&c["entropy"]),
        1e-5,
        "entropy",
    );
}

#[test]
fn ppo_clipped_objective_matches_sb3() {
    let Some(cases) = cases() else { return };
    let c = &cases["ppo_clip"];
    assert!(c["normalize_advantage"].as_bool().unwrap());
    let r = DeviceRows {
        device: device().without_autodiff(),
    };
    let advantages = normalize_advantages(&floats(&c["advantages"]));
    let s = clipped_surrogate(
        &r,
        (
            &r.vector(&floats(&c["log_prob_new"])),
            &r.vector(&floats(&c["log_prob_old"])),
        ),
        &r.vector(&advantages),
        c["clip_range"].as_f64().unwrap() as f32,
        advantages.len(),
    );
    let loss = host(s.loss)[0];
    assert_close(
        &[loss],
        &[c["policy_loss"].as_f64().unwrap() as f32],
        1e-5,
        "policy_loss",
    );
    let clip_fraction = f64::from(host(s.clip_fraction)[0]);
    assert_eq!(clip_fraction, c["clip_fraction"].as_f64().unwrap());
    let kl = c["approx_kl"].as_f64().unwrap();
    let approx_kl = f64::from(host(s.approx_kl)[0]);
    assert!(
        (approx_kl - kl).abs() <= 1e-5 * kl.abs().max(1e-3),
        "{approx_kl} vs {kl}"
    );
}
