//! MuJoCo's SDF contact search on the shipped man field (`foosball_env::sdf_search`)
//! against the reference model's own contacts: `tests/data/sdf_contacts.json`, the ball
//! by yellow's centre midfielder at 200 random poses (rod turns in [-1.5, 1.5] rad, the
//! ball around the man), made by `tools/sdf_contact_search.py fixture` with MuJoCo
//! 3.3.2 (only that pair colliding).
//!
//! Asserted: the same poses touch (every one, both ways); at the touching ones, the
//! number of contacts within 3 of the model's at nine poses in ten; the mean depth, the
//! mean normal and the mean place of the patch near the model's (medians within 0.015 cm,
//! 4 degrees and 0.06 cm; nine in ten within 0.08 cm, 15 degrees and 0.2 cm; measured
//! 0.006 cm, 2.4 and 0.034 cm; 0.062 cm, 12.1 and 0.136 cm). The model
//! itself moves those by 0.003 cm, 1 degree and 0.014 cm when its ball moves 0.01 cm
//! (docs/reference-game.md); the rest is the field's sampling.

use foosball_rl::env::man_field::{FieldForm, ManField};
use foosball_rl::env::sdf_search::{DQuat, DVec3, SdfSearch};
use serde::Deserialize;

const FIXTURE: &str = "tests/data/sdf_contacts.json";

#[derive(Deserialize)]
struct Fixture {
    initpoints: usize,
    iterations: usize,
    radius: f64,
    poses: Vec<Pose>,
}

#[derive(Deserialize)]
struct Pose {
    turn: f64,
    ball: [f64; 3],
    contacts: Vec<Contact>,
}

#[derive(Deserialize)]
struct Contact {
    dist: f64,
    point: [f64; 3],
    normal: [f64; 3],
}

/// Mean depth, normal and place of a patch.
fn means(patch: impl Iterator<Item = (f64, DVec3, DVec3)> + Clone) -> (f64, DVec3, DVec3) {
    let n = patch.clone().count() as f64;
    let (d, normal, point) = patch.fold((0.0, DVec3::ZERO, DVec3::ZERO), |a, c| {
        (a.0 + c.0, a.1 + c.1, a.2 + c.2)
    });
    (d / n, normal / n, point / n)
}

fn quantile(mut v: Vec<f64>, q: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q).round() as usize]
}

/// Bounds on a patch's errors: the most differing contact counts at nine poses in ten,
/// then per quantity (depth cm, normal degrees, place cm) the median's and the 90th
/// percentile's.
struct Bounds {
    count: f64,
    depth: [f64; 2],
    normal: [f64; 2],
    place: [f64; 2],
}

#[test]
fn the_search_on_the_plugins_octree_finds_the_models_contacts_exactly() {
    patches_match(
        FieldForm::Octree,
        &Bounds {
            count: 1.0,
            depth: [1e-4, 0.002],
            normal: [0.01, 0.2],
            place: [1e-4, 0.005],
        },
    );
}

#[test]
fn the_search_on_the_sampled_field_finds_them_nearly() {
    patches_match(
        FieldForm::Grid,
        &Bounds {
            count: 3.0,
            depth: [0.015, 0.08],
            normal: [4.0, 15.0],
            place: [0.06, 0.2],
        },
    );
}

/// Every pose of the fixture searched on the man's field in `form`, its patches' errors
/// within `bounds`.
fn patches_match(form: FieldForm, bounds: &Bounds) {
    let text = std::fs::read_to_string(FIXTURE).expect("the fixture is in the repository");
    let fixture: Fixture = serde_json::from_str(&text).expect("the fixture parses");
    let search = SdfSearch {
        initpoints: fixture.initpoints,
        iterations: fixture.iterations,
    };
    assert_eq!(search, SdfSearch::REFERENCE);
    let field = ManField::reference(form);
    let (mut counts, mut depths, mut angles, mut places) = (vec![], vec![], vec![], vec![]);
    for (k, pose) in fixture.poses.iter().enumerate() {
        let ours = search.contacts(
            field,
            DQuat::from_rotation_x(pose.turn),
            DVec3::new(0.0, -7.5, 7.75),
            DVec3::from(pose.ball),
            fixture.radius,
        );
        assert_eq!(
            ours.is_empty(),
            pose.contacts.is_empty(),
            "pose {k}: {} contacts here, {} on the model",
            ours.len(),
            pose.contacts.len()
        );
        if ours.is_empty() {
            continue;
        }
        let (d0, n0, p0) = means(
            pose.contacts
                .iter()
                .map(|c| (c.dist, DVec3::from(c.normal), DVec3::from(c.point))),
        );
        let (d1, n1, p1) = means(ours.iter().map(|c| (c.dist, c.normal, c.point)));
        counts.push((ours.len() as f64 - pose.contacts.len() as f64).abs());
        depths.push((d0 - d1).abs());
        angles.push(n0.angle_between(n1).to_degrees());
        places.push(p0.distance(p1));
    }
    for (what, v) in [
        ("depth (cm)", &depths),
        ("normal (deg)", &angles),
        ("place (cm)", &places),
    ] {
        println!(
            "{form:?}, {what}: median {:.6}, 90th percentile {:.6} over {} touching poses",
            quantile(v.clone(), 0.5),
            quantile(v.clone(), 0.9),
            v.len()
        );
    }
    assert!(depths.len() >= 40, "{} touching poses", depths.len());
    assert!(quantile(counts, 0.9) <= bounds.count);
    for (what, v, [median, ninety]) in [
        ("depth", depths, bounds.depth),
        ("normal", angles, bounds.normal),
        ("place", places, bounds.place),
    ] {
        assert!(quantile(v.clone(), 0.5) < median, "{form:?} {what}: {v:?}");
        assert!(quantile(v.clone(), 0.9) < ninety, "{form:?} {what}: {v:?}");
    }
}
