//! Pendulum-v1 reproduces Gymnasium 1.4.0's trajectories (`shared/reference/pendulum`).

use crate::common;

use foosball_rl::env::{Env, Pendulum};
use serde::Deserialize;

#[derive(Deserialize)]
struct Fixture {
    trajectories: Vec<Trajectory>,
}

#[derive(Deserialize)]
struct Trajectory {
    theta0: f64,
    theta_dot0: f64,
    actions: Vec<f64>,
    observations: Vec<[f64; 3]>,
    rewards: Vec<f64>,
    truncated: Vec<bool>,
}

#[test]
fn pendulum_matches_gymnasium_trajectories() {
    let Some(path) = common::reference_file("pendulum/pendulum_v1.json") else {
        return;
    };
    let text = std::fs::read_to_string(&path).unwrap();
    let fixture: Fixture = serde_json::from_str(&text).unwrap();
    assert_eq!(fixture.trajectories.len(), 5);
    let mut clipped = 0;
    for (k, traj) in fixture.trajectories.iter().enumerate() {
        let mut env = Pendulum::new();
        env.reset_to(traj.theta0, traj.theta_dot0);
        for (i, &u) in traj.actions.iter().enumerate() {
            // Gymnasium applies the action as float32; our action space is [-1, 1] = u / 2,
            // exact in binary floating point.
            let u = u as f32;
            clipped += usize::from(u.abs() > 2.0);
            let (obs, t) = env.step(&[u / 2.0]).unwrap();
            for (j, (&got, &want)) in obs.iter().zip(&traj.observations[i]).enumerate() {
                assert!(
                    (f64::from(got) - want).abs() < 1e-5,
                    "trajectory {k} step {i} obs[{j}]: {got} vs {want}"
                );
            }
            let want = traj.rewards[i];
            assert!(
                (f64::from(t.reward) - want).abs() < 1e-5 * want.abs().max(1.0),
                "trajectory {k} step {i} reward: {} vs {want}",
                t.reward
            );
            assert_eq!(
                t.truncated, traj.truncated[i],
                "trajectory {k} step {i} truncation"
            );
            assert!(!t.terminated);
        }
        assert!(
            env.step(&[0.0]).is_err(),
            "stepping past the time limit must be refused"
        );
    }
    assert!(
        clipped > 100,
        "the fixture should exercise torque clipping ({clipped} clipped actions)"
    );
}
