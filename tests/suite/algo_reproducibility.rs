//! Same seed => the same parameters after 200 gradient steps, whatever the rayon thread
//! count of the backend's matmuls and of the env workers.

use foosball_rl::algos::{Agent, Collector, Ppo, PpoConfig, Sac, SacConfig, Td3, Td3Config};
use foosball_rl::env::{Pendulum, VecEnv};
use foosball_rl::nets::burn::module::Module;
use foosball_rl::nets::params::host_params;
use foosball_rl::nets::{Backend, Device};

fn device() -> Device {
    Backend::default_cpu().unwrap().device().unwrap()
}

/// Drives `agent` on 2 Pendulums until it has taken `updates` training rounds, inside a
/// rayon pool of `threads` threads.
fn run<A: Agent + Send>(mut agent: A, updates: usize, threads: usize) -> A {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let envs = VecEnv::new(vec![Pendulum::new(), Pendulum::new()], threads).unwrap();
        let mut collector = Collector::new(envs, 11);
        let mut rounds = 0;
        while rounds < updates {
            if collector
                .step(&mut agent, 1.0, |_, _, _| {})
                .unwrap()
                .is_some()
            {
                rounds += 1;
            }
        }
    });
    agent
}

fn sac_config() -> SacConfig {
    let mut c = SacConfig::default();
    // Wide enough for the matmuls to split across threads.
    c.net.hidden = vec![256, 256];
    c.off_policy.learning_starts = 64;
    c.off_policy.batch_size = 128;
    c.net.adam.max_grad_norm = Some(1.0);
    c
}

fn params_of<M: Module>(m: &M) -> Vec<Vec<u32>> {
    host_params(m)
        .into_iter()
        .map(|p| p.into_iter().map(f32::to_bits).collect())
        .collect()
}

#[test]
fn sac_is_bit_identical_across_runs_and_thread_counts_on_both_paths() {
    for host_path in [false, true] {
        let make = || {
            let mut agent = Sac::agent(3, 1, sac_config(), 5, &device());
            if host_path {
                agent.learner_mut().on_host_path().unwrap();
            }
            agent
        };
        let a = run(make(), 200, 1);
        let b = run(make(), 200, 1);
        let c = run(make(), 200, 2);
        let (pa, pc) = (
            params_of(&a.learner().actor()),
            params_of(&c.learner().actor()),
        );
        assert_eq!(pa, params_of(&b.learner().actor()), "host path {host_path}");
        assert_eq!(
            pa, pc,
            "actor differs between 1 and 2 threads (host path {host_path})"
        );
        assert_eq!(
            params_of(&a.learner().critic()),
            params_of(&c.learner().critic())
        );
        assert_eq!(a.learner().alpha(), c.learner().alpha());
        // And training did move the parameters.
        assert_ne!(pa, params_of(&make().learner().actor()));
    }
}

#[test]
fn td3_is_bit_identical_across_thread_counts_on_both_paths() {
    let mut config = Td3Config::default();
    config.net.hidden = vec![256, 256];
    config.off_policy.learning_starts = 64;
    for host_path in [false, true] {
        let make = || {
            let mut agent = Td3::agent(3, 1, config.clone(), 5, &device());
            if host_path {
                agent.learner_mut().on_host_path().unwrap();
            }
            agent
        };
        let a = run(make(), 200, 1);
        let c = run(make(), 200, 2);
        let pa = params_of(&a.learner().actor());
        assert_eq!(pa, params_of(&c.learner().actor()), "host path {host_path}");
        assert_eq!(
            params_of(&a.learner().critic()),
            params_of(&c.learner().critic()),
            "host path {host_path}"
        );
        assert_ne!(pa, params_of(&make().learner().actor()));
    }
}

#[test]
fn ppo_is_bit_identical_across_thread_counts_on_both_paths() {
    // 2 envs x 64 steps = 128 rows, 4 minibatches x 10 epochs = 40 gradient steps per
    // round; 5 rounds = 200 gradient steps.
    let config = PpoConfig {
        n_steps: 64,
        batch_size: 32,
        ..PpoConfig::default()
    };
    for host_path in [false, true] {
        let make = || {
            let mut ppo = Ppo::new(3, 1, config.clone(), 5, &device());
            if host_path {
                ppo.on_host_path().unwrap();
            }
            ppo
        };
        let a = run(make(), 5, 1);
        let c = run(make(), 5, 2);
        let pa = params_of(&a.model());
        assert_eq!(pa, params_of(&c.model()), "host path {host_path}");
        assert_ne!(pa, params_of(&make().model()));
    }
}
