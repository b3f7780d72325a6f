//! `render`: recorded episodes become GIFs; a trajectories file of another format or
//! version, a truncated one and an episode index out of range are refused by name.

mod common;

use common::scratch;
use foosball_rl::env::layout::{ACTION_DIM, OBS_DIM};
use foosball_rl::evaluation::{PlayedEpisode, Trajectory};
use foosball_rl::metrics::EpisodeSummary;
use foosball_rl::run_dir::{read_trajectories, trajectories_bytes};
use std::process::Command;

/// Two recorded episodes of 3 and 7 steps, the second with the higher return.
fn episodes() -> Vec<PlayedEpisode> {
    (0..2u64)
        .map(|k| {
            let steps = if k == 0 { 3 } else { 7 };
            let mut obs = vec![0.0; steps * OBS_DIM];
            for (t, row) in obs.chunks_exact_mut(OBS_DIM).enumerate() {
                row[..3].copy_from_slice(&[t as f32, 10.0 * k as f32, 1.73355]);
            }
            PlayedEpisode {
                seed: 40 + k,
                summary: EpisodeSummary::default(),
                trajectory: Some(Trajectory {
                    obs,
                    actions: vec![0.5; steps * ACTION_DIM],
                    rewards: vec![100.0 * (k + 1) as f32; steps],
                }),
            }
        })
        .collect()
}

fn render(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_render"))
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn recorded_episodes_read_back_and_become_gifs() {
    let dir = scratch("render");
    let path = dir.join("trajectories.bin");
    let played = episodes();
    std::fs::write(&path, trajectories_bytes(&played, OBS_DIM, ACTION_DIM)).unwrap();
    let back = read_trajectories(&path).unwrap();
    assert_eq!(back.len(), 2);
    for (b, p) in back.iter().zip(&played) {
        assert_eq!(b.seed, p.seed);
        assert_eq!(Some(&b.trajectory), p.trajectory.as_ref());
    }
    let out = dir.join("gifs");
    let o = render(&[
        "--trajectories",
        path.to_str().unwrap(),
        "--best",
        "1",
        "--every",
        "2",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let gif = std::fs::read(out.join("episode-1.gif")).unwrap();
    assert_eq!(&gif[..6], b"GIF89a");
    // Width and height at the default 3 px/cm: the table's 72 x 138.24 cm frame.
    assert_eq!(u16::from_le_bytes([gif[6], gif[7]]), 216);
    assert_eq!(u16::from_le_bytes([gif[8], gif[9]]), 415);

    let e = render(&["--trajectories", path.to_str().unwrap(), "--episodes", "5"]);
    assert_eq!(e.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&e.stderr).contains("episode 5 is out of range (2 episodes"));

    let bytes = std::fs::read(&path).unwrap();
    std::fs::write(&path, &bytes[..bytes.len() - 10]).unwrap();
    let err = read_trajectories(&path).unwrap_err();
    assert!(err.contains("truncated at byte"), "{err}");
    let mut other = bytes.clone();
    other[4] = 2;
    std::fs::write(&path, &other).unwrap();
    let err = read_trajectories(&path).unwrap_err();
    assert!(
        err.contains("format version 2; this build reads version 1"),
        "{err}"
    );
    std::fs::write(&path, b"PNG....").unwrap();
    assert!(
        read_trajectories(&path)
            .unwrap_err()
            .contains("not a trajectories file")
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
