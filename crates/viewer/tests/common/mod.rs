//! Shared fixtures: a small world whose geometry the tests know, and the shared-material lookup.
#![allow(dead_code)]

use stage_sim::{
    BlockDesc, Color, KindDesc, ModelDesc, Pose, PositionDesc, SensorDesc, World, WorldDesc,
};
use viewer::world_scene::WorldGui;

#[allow(unused_imports)] // test binaries each use a different subset
pub use test_support::shared_dir;

/// Laser colour in the known world.
pub const LASER: Color = Color::rgb(0.0, 0.0, 1.0);

/// A known world: black walls along y ∈ [3, 3.2] (x ∈ [-4, 4]) and x ∈ [-4, -3.8]
/// (y ∈ [-3, 3]); a red 0.6 m robot at (1, -1) facing +y with a 181-ray, 180° blue laser of
/// 8 m (a 0.1 m body on top). The laser is subscribed and the world stepped once, so its scan
/// is there: straight ahead it hits the top wall at (1, 3), to its left the left wall at
/// (-3.8, -1).
pub fn known_world() -> (World, WorldGui) {
    let mut d = WorldDesc::default();
    let mut walls = ModelDesc::new("walls", KindDesc::Model);
    walls.color = Color::rgb(0.0, 0.0, 0.0);
    walls.size = [8.0, 6.2, 0.5];
    walls.default_body = false;
    walls.blocks = vec![
        BlockDesc::rect(-4.0, 3.0, 8.0, 0.2, 0.5),
        BlockDesc::rect(-4.0, -3.0, 0.2, 6.0, 0.5),
    ];
    d.add(walls, None);
    let mut robot = ModelDesc::new("robot", KindDesc::Position(PositionDesc::default()));
    robot.color = Color::rgb(1.0, 0.0, 0.0);
    robot.size = [0.6, 0.6, 0.3];
    robot.pose = Pose::new(1.0, -1.0, 0.0, std::f64::consts::FRAC_PI_2);
    let r = d.add(robot, None);
    let laser = SensorDesc {
        range: [0.0, 8.0],
        fov: std::f64::consts::PI,
        samples: 181,
        color: LASER,
        ..SensorDesc::default()
    };
    let mut ranger = ModelDesc::new("laser", KindDesc::Ranger(vec![laser]));
    ranger.size = [0.1, 0.1, 0.1];
    ranger.default_body = true;
    ranger.color = Color::rgb(0.0, 0.0, 0.0);
    let l = d.add(ranger, Some(r));
    let gui = WorldGui::from_desc(&d);
    let mut w = World::from_desc(&d, 1).expect("known world builds");
    let laser = w.model_id(l).expect("the laser was just added");
    w.subscribe(laser).expect("an id from this world");
    for _ in 0..2 {
        w.step();
    }
    (w, gui)
}
