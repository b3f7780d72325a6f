//! Physical behaviour of the simulated table, at the level of the rapier world.

use foosball_rl::env::geometry::{self, BALL_RADIUS, RODS, foosman};
use foosball_rl::env::table::{PhysicsParams, Table};
use foosball_rl::env::{FoosballConfig, Preset, RodMount};

/// Black's goalie in the global rod order.
const BLACK_GOALIE: usize = 4;
/// Yellow's attack in the global rod order.
const YELLOW_ATTACK: usize = 3;

/// The rolling ball's nominal physics (the `*_v1` presets): 2 ms steps, 0.1 kg ball,
/// friction 0.3, restitution 0.6, rolling resistance 0.015 g; rods held by `mount` (every
/// test runs under both mounts, naming the one it is in on stderr). The code's sliding
/// ball is measured against the reference model in `reference_parity.rs`.
fn params(mount: RodMount) -> PhysicsParams {
    params_of(Preset::PaperV1, mount)
}

/// The nominal physics of `preset` with the rods held by `mount`.
fn params_of(preset: Preset, mount: RodMount) -> PhysicsParams {
    eprintln!("{preset:?}, rod mount {mount:?}");
    PhysicsParams {
        rod_mount: mount,
        ..PhysicsParams::nominal(&FoosballConfig::preset(preset))
    }
}

/// Steps `table` for `seconds`, returning the largest ball y and speed seen.
fn run(table: &mut Table, seconds: f32) -> (f32, f32) {
    let (mut max_y, mut max_speed) = (f32::MIN, 0.0_f32);
    for _ in 0..(seconds / table.dt()).round() as usize {
        table.step();
        let p = table.ball_position();
        let v = table.ball_velocity();
        max_y = max_y.max(p[1]);
        max_speed = max_speed.max((v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt());
    }
    (max_y, max_speed)
}

/// A table with the ball at `xy` rolling along y at `vy` cm/s.
fn rolling(mount: RodMount, xy: [f32; 2], vy: f32) -> Table {
    let mut t = Table::new(&params(mount), xy);
    t.set_ball([xy[0], xy[1], BALL_RADIUS], [0.0, vy, 0.0]);
    t
}

#[test]
fn a_resting_ball_stays_at_rest() {
    for mount in RodMount::ALL {
        let mut t = Table::new(&params(mount), [12.0, 30.0]);
        let (_, max_speed) = run(&mut t, 2.0);
        let p = t.ball_position();
        assert!(max_speed < 0.05, "max speed {max_speed} cm/s");
        assert!(
            (p[0] - 12.0).abs() < 0.01 && (p[1] - 30.0).abs() < 0.01,
            "{p:?}"
        );
        assert!(
            (p[2] - BALL_RADIUS).abs() < 0.01,
            "ball sank or rose: z = {}",
            p[2]
        );
    }
}

#[test]
fn a_rolling_ball_slows_at_the_rolling_resistance() {
    for mount in RodMount::ALL {
        // Set off sliding without spin, a solid ball starts rolling at 5/7 of its speed, then
        // slows at 0.015 g = 14.7 cm/s²: from 100 cm/s, 64.1 cm/s after half a second.
        // x = -30 is clear of every man.
        let mut t = rolling(mount, [-30.0, -30.0], 100.0);
        run(&mut t, 0.5);
        let v = t.ball_velocity()[1];
        let expected = 100.0 * 5.0 / 7.0 - 0.5 * 0.015 * 981.0;
        assert!((v - expected).abs() < 1.0, "v = {v}, expected {expected}");
    }
}

#[test]
fn a_ball_rolled_at_the_open_goal_scores() {
    for mount in RodMount::ALL {
        // x = 5 passes between black's goalie men at 0 and 20.676.
        let mut t = rolling(mount, [5.0, 42.0], 150.0);
        let (max_y, _) = run(&mut t, 1.0);
        assert!(max_y >= geometry::GOAL_LINE_Y, "ball reached y = {max_y}");
    }
}

#[test]
fn a_blocking_goalie_stops_the_ball() {
    for mount in RodMount::ALL {
        let mut t = rolling(mount, [0.0, 42.0], 150.0);
        let (max_y, _) = run(&mut t, 1.0);
        assert!(
            max_y < RODS[0].yellow_y.abs(),
            "ball passed the goalie: y = {max_y}"
        );
        assert!(t.ball_velocity()[1] <= 0.0, "the ball should bounce back");
    }
}

#[test]
fn a_turned_man_lets_the_ball_pass_under() {
    for mount in RodMount::ALL {
        let mut t = rolling(mount, [0.0, 42.0], 150.0);
        t.set_target(BLACK_GOALIE, 0.0, std::f32::consts::FRAC_PI_2);
        let (max_y, _) = run(&mut t, 1.0);
        assert!(max_y >= geometry::GOAL_LINE_Y, "ball reached y = {max_y}");
    }
}

#[test]
fn rods_reach_their_targets_within_60_ms() {
    for mount in RodMount::ALL {
        let mut t = Table::new(&params(mount), [33.0, 0.0]);
        let targets: Vec<[f32; 2]> = (0..8)
            .map(|i| {
                [
                    0.7 * RODS[i % 4].slide_range,
                    if i % 2 == 0 { 1.2 } else { -1.0 },
                ]
            })
            .collect();
        for (i, [s, a]) in targets.iter().enumerate() {
            t.set_target(i, *s, *a);
        }
        for _ in 0..30 {
            t.step();
        }
        for (i, [s, a]) in targets.iter().enumerate() {
            let st = t.rod_state(i);
            assert!(
                (st.slide - s).abs() <= 0.02 * s.abs(),
                "rod {i}: slide {} vs {s}",
                st.slide
            );
            assert!(
                (st.angle - a).abs() <= 0.02 * a.abs(),
                "rod {i}: angle {} vs {a}",
                st.angle
            );
        }
    }
}

#[test]
fn rods_never_leave_their_slide_range() {
    for mount in RodMount::ALL {
        // The ball waits in black's goal pocket, out of every man's reach: a man that hit
        // it could send it into another rod, and a rod hit hard spins past its turn range
        // (the servo holds it, it is not a stop).
        let mut t = Table::new(&params(mount), [0.0, 66.5]);
        let mut worst = 0.0_f32;
        for flip in 0..6 {
            let sign = if flip % 2 == 0 { 1.0 } else { -1.0 };
            for i in 0..8 {
                t.set_target(i, sign * 100.0, sign * 100.0); // clamped to the ranges
            }
            for _ in 0..60 {
                t.step();
                for i in 0..8 {
                    let spec = &RODS[i % 4];
                    let st = t.rod_state(i);
                    worst = worst.max(st.slide.abs() - spec.slide_range);
                    assert!(
                        st.angle.abs() <= spec.turn_range + 0.05,
                        "rod {i}: angle {}",
                        st.angle
                    );
                }
            }
        }
        // The joint limit is a stiff constraint solved to rapier's tolerance (0.5 mm here).
        assert!(
            worst <= 0.05,
            "a rod overshot its slide range by {worst} cm"
        );
    }
}

#[test]
fn a_kick_sends_the_ball_faster_than_300_cm_s() {
    for mount in RodMount::ALL {
        // Ball resting just in front of yellow's central attacker; swing his foot forward.
        // The ball is still short of black's goalie after the 30 ms measured.
        let mut t = Table::new(&params(mount), [0.0, 22.5 + 4.0]);
        t.set_target(YELLOW_ATTACK, 0.0, 2.5);
        let (_, max_speed) = run(&mut t, 0.03);
        assert!(max_speed > 300.0, "kick speed {max_speed} cm/s");
        assert!(t.ball_velocity()[1] > 0.0);
    }
}

#[test]
fn a_fast_ball_does_not_tunnel_through_a_man() {
    for mount in RodMount::ALL {
        // The struck goalie swings back (his rod is free to turn against its servo), but the
        // ball never gets past his leg and comes back out.
        let mut t = rolling(mount, [0.0, 40.0], 1500.0);
        let (max_y, _) = run(&mut t, 0.2);
        let behind = RODS[0].yellow_y.abs() + foosman::LEG_HALF_Y + BALL_RADIUS;
        assert!(
            max_y < behind,
            "ball passed through the goalie: y = {max_y}"
        );
        assert!(t.ball_velocity()[1] < 0.0, "the ball should come back");
    }
}

#[test]
fn on_the_codes_table_a_fast_ball_swings_the_goalie_back_and_is_turned_back() {
    for mount in RodMount::ALL {
        // The dead contact lets the ball push the struck foot up (measured: the goalie turns
        // to -0.92 rad, the ball's centre reaches y = 56.1), but it never reaches the end
        // wall and comes back out.
        let mut t = Table::new(&params_of(Preset::Paper, mount), [0.0, 40.0]);
        t.set_ball([0.0, 40.0, BALL_RADIUS], [0.0, 1500.0, 0.0]);
        let (max_y, _) = run(&mut t, 0.04);
        assert!(
            max_y < geometry::FIELD_HALF_LENGTH - BALL_RADIUS - 1.0,
            "ball got past the goalie: y = {max_y}"
        );
        assert!(t.ball_velocity()[1] < -100.0, "the ball should come back");
    }
}

#[test]
fn a_fast_ball_does_not_tunnel_through_the_walls() {
    for mount in RodMount::ALL {
        // Along x at a side wall, and along y at the end wall beside the goal mouth.
        let mut t = Table::new(&params(mount), [0.0, -20.0]);
        t.set_ball([0.0, -20.0, BALL_RADIUS], [1500.0, 0.0, 0.0]);
        let mut max_x = f32::MIN;
        for _ in 0..100 {
            t.step();
            max_x = max_x.max(t.ball_position()[0]);
        }
        assert!(
            max_x <= geometry::FIELD_HALF_WIDTH - BALL_RADIUS + 0.05,
            "x reached {max_x}"
        );

        let mut t = rolling(mount, [20.0, 45.0], 1500.0);
        let (max_y, _) = run(&mut t, 0.2);
        assert!(
            max_y <= geometry::FIELD_HALF_LENGTH - BALL_RADIUS + 0.05,
            "y reached {max_y}"
        );
    }
}
