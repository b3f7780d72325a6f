use foosball_rl::algos::*;
use foosball_rl::env::{Pendulum, VecEnv, Env};
use foosball_rl::nets::Backend;
use std::time::Instant;

fn main() {
    let algo = std::env::args().nth(1).unwrap_or("sac".into());
    let steps: u64 = std::env::args().nth(2).map(|s| s.parse().unwrap()).unwrap_or(20_000);
    let hidden: Vec<usize> = std::env::args().nth(3).map(|s| s.split(',').map(|x| x.parse().unwrap()).collect()).unwrap_or(vec![64, 64]);
    let device = Backend::default_cpu().unwrap().device().unwrap();
    let n_envs = if algo == "ppo" { 4 } else { 1 };
    let mut agent: Box<dyn Agent> = match algo.as_str() {
        "sac" => { let mut c = SacConfig::default(); c.net.hidden = hidden; c.off_policy.learning_starts = 1000; Box::new(Sac::agent(3, 1, c, 1, &device)) }
        "td3" => { let mut c = Td3Config::default(); c.net.hidden = hidden; c.off_policy.learning_starts = 1000; Box::new(Td3::agent(3, 1, c, 1, &device)) }
        _ => { let mut c = PpoConfig::default(); c.net.hidden = hidden; c.n_steps = 1024; c.gamma = 0.9; c.net.lr = LrSchedule::Constant(1e-3); Box::new(Ppo::new(3, 1, c, 1, &device)) }
    };
    let envs = VecEnv::new((0..n_envs).map(|_| Pendulum::new()).collect(), 1).unwrap();
    let mut col = Collector::new(envs, 7);
    let t0 = Instant::now();
    let mut rets = vec![];
    let mut vsteps = 0u64;
    while agent.env_steps() < steps {
        vsteps += 1;
        let m = col.step(agent.as_mut(), 1.0 - agent.env_steps() as f64 / steps as f64, |_, ep, _| rets.push(ep.ret)).unwrap();
        if agent.env_steps() % 2000 < n_envs as u64 {
            let mut env = Pendulum::new();
            let ev: f64 = (0..5).map(|k| play_episode(agent.as_mut(), &mut env, 1000 + k).unwrap().0.ret).sum::<f64>() / 5.0;
            let last: f64 = rets.iter().rev().take(10).sum::<f64>() / rets.len().clamp(1, 10) as f64;
            println!("{:>7} steps {:>6.1}s train(last10) {:>8.1} eval {:>8.1} {:?}", agent.env_steps(), t0.elapsed().as_secs_f64(), last, ev, m.map(|m| m.0.iter().map(|(n, v)| format!("{n}={v:.3}")).collect::<Vec<_>>()));
        }
    }
    let _ = vsteps;
    let _ = Env::obs_dim(&Pendulum::new());
}
