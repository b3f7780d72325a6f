//! `render`: recorded episodes become GIFs, live play of a policy goes to the named file,
//! MP4 goes through ffmpeg (refused by name where it is missing); a trajectories file of
//! another format or version, a truncated one and an episode index out of range are
//! refused by name.

use crate::common;

use common::scratch;
use foosball_rl::env::layout::{ACTION_DIM, OBS_DIM};
use foosball_rl::play::trajectories::{Trajectory, read_trajectories, trajectories_bytes};
use std::process::Command;

/// Two recorded episodes of 3 and 7 steps, the second with the higher return.
fn episodes() -> Vec<(u64, Trajectory)> {
    (0..2u64)
        .map(|k| {
            let steps = if k == 0 { 3 } else { 7 };
            let mut obs = vec![0.0; steps * OBS_DIM];
            for (t, row) in obs.chunks_exact_mut(OBS_DIM).enumerate() {
                row[..3].copy_from_slice(&[t as f32, 10.0 * k as f32, 1.73355]);
            }
            let trajectory = Trajectory {
                obs,
                actions: vec![0.5; steps * ACTION_DIM],
                rewards: vec![100.0 * (k + 1) as f32; steps],
            };
            (40 + k, trajectory)
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
    let refs: Vec<(u64, &Trajectory)> = played.iter().map(|(s, t)| (*s, t)).collect();
    std::fs::write(&path, trajectories_bytes(&refs, OBS_DIM, ACTION_DIM)).unwrap();
    let back = read_trajectories(&path).unwrap();
    assert_eq!(back.len(), 2);
    for (b, (seed, trajectory)) in back.iter().zip(&played) {
        assert_eq!(b.seed, *seed);
        assert_eq!(&b.trajectory, trajectory);
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
    // Width and height at the default 3 px/cm: the table's 72 x 138.24 cm frame below a
    // caption band of two 13 px lines.
    assert_eq!(u16::from_le_bytes([gif[6], gif[7]]), 216);
    assert_eq!(u16::from_le_bytes([gif[8], gif[9]]), 415 + 32);
    let bare = dir.join("bare.gif");
    let o = render(&[
        "--trajectories",
        path.to_str().unwrap(),
        "--no-caption",
        "--out",
        bare.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let gif = std::fs::read(&bare).unwrap();
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

#[test]
fn a_policy_played_live_goes_to_the_named_file() {
    let dir = scratch("render-live");
    let out = dir.join("best.gif");
    let o = render(&[
        "--policy",
        "shooter",
        "--play",
        "3",
        "--best",
        "1",
        "--every",
        "10",
        "--out",
        out.to_str().unwrap(),
    ]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        text.contains("3 test episodes of shooter under reference"),
        "{text}"
    );
    assert_eq!(&std::fs::read(&out).unwrap()[..6], b"GIF89a");
    // Several episodes into one named file: numbered siblings.
    let o = render(
        &[
            "--policy",
            "zero",
            "--play",
            "2",
            "--episodes",
            "0,1",
            "--out",
        ]
        .into_iter()
        .chain([out.to_str().unwrap()])
        .collect::<Vec<_>>(),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(dir.join("best-0.gif").is_file() && dir.join("best-1.gif").is_file());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn mp4_goes_through_ffmpeg_and_is_refused_by_name_without_it() {
    let dir = scratch("render-mp4");
    let out = dir.join("zero.mp4");
    let args = [
        "--policy",
        "zero",
        "--play",
        "1",
        "--out",
        out.to_str().unwrap(),
    ];
    let empty = dir.join("no-programs");
    std::fs::create_dir_all(&empty).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_render"))
        .args(args)
        .env("PATH", &empty)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("ffmpeg is not installed"), "{err}");
    assert!(!out.exists());
    // Where ffmpeg is installed (not in CI), the same command writes an MP4.
    if Command::new("ffmpeg").arg("-version").output().is_ok() {
        let o = render(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert_eq!(&std::fs::read(&out).unwrap()[4..8], b"ftyp");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
