//! Model ids at the public boundary: a foreign id is an error from every per-model function
//! (never a panic), a model of the wrong type is an error from every type-specific one, and
//! [`World::model_id`] checks numbers.

use std::panic::{AssertUnwindSafe, catch_unwind};

use crate::controller::{self, Command, Idle};
use crate::desc::{Color, KindDesc, ModelDesc, ModelType, PositionDesc, SensorDesc, WorldDesc};
use crate::error::{Error, Result};
use crate::models::gripper::GripperCmd;
use crate::pose::Pose;
use crate::rng::SimRng;
use crate::space::RayQuery;

use super::{ModelId, Sensors, World};

/// A robot carrying a ranger, and a wall: three models of three types.
fn small_world() -> World {
    let mut d = WorldDesc::default();
    let mut wall = ModelDesc::new("wall", KindDesc::Model);
    wall.pose = Pose::new(2.0, 0.0, 0.0, 0.0);
    wall.size = [0.1, 2.0, 1.0];
    d.add(wall, None);
    let mut robot = ModelDesc::new("robot", KindDesc::Position(PositionDesc::default()));
    robot.size = [0.4, 0.4, 0.5];
    let r = d.add(robot, None);
    let mut ranger = ModelDesc::new(
        "ranger",
        KindDesc::Ranger(vec![SensorDesc {
            samples: 3,
            ..SensorDesc::default()
        }]),
    );
    ranger.size = [0.1, 0.1, 0.1];
    d.add(ranger, Some(r));
    World::from_desc(&d, 1).expect("the small world is valid")
}

/// A per-model call reduced to its error (the answer itself is not looked at).
type Call = fn(&mut World, ModelId) -> Result<()>;

/// Every public function that takes a model id, by name, with the model type it needs (`None`:
/// any), called with the id as its only id (calls with two ids appear once per position). A
/// new per-model function must be added here: [`every_per_model_function_is_in_the_table`]
/// reads the sources to make sure.
fn per_model_calls() -> Vec<(&'static str, Option<ModelType>, Call)> {
    use ModelType as T;
    fn ray() -> RayQuery {
        RayQuery {
            x: 0.0,
            y: 0.0,
            a: 0.0,
            range: 5.0,
            z: None,
        }
    }
    let calls: Vec<(&'static str, Option<ModelType>, Call)> = vec![
        ("subscribe", None, |w, m| w.subscribe(m)),
        ("unsubscribe", None, |w, m| w.unsubscribe(m)),
        ("subscriptions", None, |w, m| w.subscriptions(m).map(drop)),
        ("last_update", None, |w, m| w.last_update(m).map(drop)),
        ("pose", None, |w, m| w.pose(m).map(drop)),
        ("set_pose", None, |w, m| w.set_pose(m, Pose::ZERO)),
        ("global_pose", None, |w, m| w.global_pose(m).map(drop)),
        ("color", None, |w, m| w.color(m).map(drop)),
        ("set_color", None, |w, m| {
            w.set_color(m, Color::rgb(1.0, 0.0, 0.0))
        }),
        ("block_color", None, |w, m| w.block_color(m, 0).map(drop)),
        ("body", None, |w, m| w.body(m).map(drop)),
        ("is_static", None, |w, m| w.is_static(m).map(drop)),
        ("rasterize", None, |w, m| {
            w.rasterize(m, 0.1, 1000).map(drop)
        }),
        ("raycast", None, |w, m| w.raycast(&ray(), Some(m)).map(drop)),
        ("said", None, |w, m| w.said(m).map(drop)),
        ("say", None, |w, m| w.say(m, "hello")),
        ("position_cmd_vel", Some(T::Position), |w, m| {
            w.position_cmd_vel(m, 0.1, 0.0, 0.0)
        }),
        ("position_cmd_pos", Some(T::Position), |w, m| {
            w.position_cmd_pos(m, 1.0, 0.0, 0.0)
        }),
        ("position_cmd_car", Some(T::Position), |w, m| {
            w.position_cmd_car(m, 0.1, 0.0)
        }),
        ("position_cmd_accel", Some(T::Position), |w, m| {
            w.position_cmd_accel(m, 0.1, 0.0, 0.0)
        }),
        ("position_state", Some(T::Position), |w, m| {
            w.position_state(m).map(drop)
        }),
        ("position_model", Some(T::Position), |w, m| {
            w.position_model(m).map(drop)
        }),
        ("set_odom", Some(T::Position), |w, m| {
            w.set_odom(m, Pose::ZERO)
        }),
        ("reset_odom", Some(T::Position), |w, m| w.reset_odom(m)),
        ("set_stall", Some(T::Position), |w, m| w.set_stall(m, false)),
        ("ranger_scans", Some(T::Ranger), |w, m| {
            w.ranger_scans(m).map(drop)
        }),
        ("blobfinder_blobs", Some(T::Blobfinder), |w, m| {
            w.blobfinder_blobs(m).map(drop)
        }),
        ("blobfinder_config", Some(T::Blobfinder), |w, m| {
            w.blobfinder_config(m).map(drop)
        }),
        ("fiducials", Some(T::Fiducial), |w, m| {
            w.fiducials(m).map(drop)
        }),
        ("fiducial_config", Some(T::Fiducial), |w, m| {
            w.fiducial_config(m).map(drop)
        }),
        ("fiducial_id", None, |w, m| w.fiducial_id(m).map(drop)),
        ("set_fiducial_id", None, |w, m| w.set_fiducial_id(m, 7)),
        ("gripper_state", Some(T::Gripper), |w, m| {
            w.gripper_state(m).map(drop)
        }),
        ("gripper_cmd", Some(T::Gripper), |w, m| {
            w.gripper_cmd(m, GripperCmd::Close)
        }),
        ("camera_image", Some(T::Camera), |w, m| {
            w.camera_image(m).map(drop)
        }),
        ("camera_config", Some(T::Camera), |w, m| {
            w.camera_config(m).map(drop)
        }),
        ("actuator", Some(T::Actuator), |w, m| {
            w.actuator(m).map(drop)
        }),
        ("actuator_cmd", Some(T::Actuator), |w, m| {
            w.actuator_cmd(m, true, 0.5)
        }),
        ("light_on", Some(T::Blinkenlight), |w, m| {
            w.light_on(m).map(drop)
        }),
        ("set_light", Some(T::Blinkenlight), |w, m| {
            w.set_light(m, true)
        }),
        ("node", None, |w, m| w.node(m).map(drop)),
        ("name", None, |w, m| w.name(m).map(drop)),
        ("model_type", None, |w, m| w.model_type(m).map(drop)),
        ("type_name", None, |w, m| w.type_name(m).map(drop)),
        ("parent", None, |w, m| w.parent(m).map(drop)),
        ("children", None, |w, m| w.children(m).map(drop)),
        ("subtree", None, |w, m| w.subtree(m).map(drop)),
        ("related", None, |w, m| w.related(m, ModelId(0)).map(drop)),
        ("related", None, |w, m| w.related(ModelId(0), m).map(drop)),
        ("add_controller", None, |w, m| {
            w.add_controller(m, ModelId(0), Box::new(Idle))
        }),
        ("add_controller", None, |w, m| {
            w.add_controller(ModelId(0), m, Box::new(Idle))
        }),
        ("apply", Some(T::Position), |w, m| {
            w.apply(Command::Velocity(m, 0.1, 0.0, 0.0))
        }),
        ("apply", None, |w, m| w.apply(Command::Subscribe(m))),
        ("apply", None, |w, m| w.apply(Command::Unsubscribe(m))),
        ("apply", None, |w, m| {
            w.apply(Command::SetColor(m, Color::rgb(0.0, 1.0, 0.0)))
        }),
        ("apply", None, |w, m| w.apply(Command::Say(m, "hi".into()))),
        ("apply", Some(T::Ranger), |w, m| {
            w.apply(Command::RangerNoise(m, 0.1))
        }),
        ("builtin", None, |w, m| {
            match controller::builtin("wander", w, m, "", SimRng::new(1, 0)) {
                Err(controller::CtrlError::Model(e)) => Err(e),
                _ => Ok(()),
            }
        }),
    ];
    calls
}

/// Calls `call`, naming it when it panics.
fn call_named(name: &str, call: Call, w: &mut World, m: ModelId) -> Result<()> {
    catch_unwind(AssertUnwindSafe(|| call(w, m)))
        .unwrap_or_else(|_| panic!("`{name}` panicked on model id {m}"))
}

#[test]
fn a_foreign_model_id_is_an_error_from_every_per_model_function() {
    let mut w = small_world();
    let models = w.model_count();
    for foreign in [ModelId(models as u32), ModelId(99), ModelId(u32::MAX)] {
        for (name, _, call) in per_model_calls() {
            match call_named(name, call, &mut w, foreign) {
                Err(Error::ForeignModel { id, models: n }) => {
                    assert_eq!((id, n), (foreign, models), "`{name}`");
                }
                other => panic!("`{name}` on foreign id {foreign}: {other:?}"),
            }
        }
    }
    let message = w.pose(ModelId(99)).unwrap_err().to_string();
    assert_eq!(
        message,
        "model id 99 does not belong to this world (it has 3 models)"
    );
}

#[test]
fn a_foreign_model_id_changes_nothing() {
    let mut w = small_world();
    let before = w.state_digest();
    for (name, _, call) in per_model_calls() {
        let _ = call_named(name, call, &mut w, ModelId(3));
    }
    assert_eq!(w.state_digest(), before);
    w.step();
    let mut fresh = small_world();
    fresh.step();
    assert_eq!(w.state_digest(), fresh.state_digest());
}

#[test]
fn type_specific_calls_on_another_type_are_bad_model_errors() {
    let mut w = small_world();
    let wall = w.model_by_name("wall").expect("the wall is named");
    for (name, needs, call) in per_model_calls() {
        if needs.is_none() {
            continue;
        }
        match call_named(name, call, &mut w, wall) {
            Err(Error::BadModel {
                id,
                found,
                expected,
            }) => {
                assert_eq!((id, found), (wall, ModelType::Model), "`{name}`");
                assert!(expected.starts_with("a"), "`{name}`: {expected}");
            }
            other => panic!("`{name}` on a plain model: {other:?}"),
        }
    }
    assert_eq!(
        w.ranger_scans(wall).unwrap_err().to_string(),
        "model 0 is a `model` model, not a ranger"
    );
    // A block the model does not have.
    assert!(matches!(
        w.block_color(wall, 1),
        Err(Error::NoBlock {
            block: 1,
            blocks: 1,
            ..
        })
    ));
}

#[test]
fn every_per_model_call_succeeds_on_a_model_of_its_type() {
    // The table's calls are real calls: each one answers Ok on a model of the type it needs
    // (the robot, its ranger), and the untyped ones on the robot.
    let mut w = small_world();
    let robot = w.model_by_name("robot").expect("named");
    let ranger = w.model_by_name("ranger").expect("named");
    for (name, needs, call) in per_model_calls() {
        let m = match needs {
            None | Some(ModelType::Position) => robot,
            Some(ModelType::Ranger) => ranger,
            Some(_) => continue, // no such model in the small world
        };
        let answer = call_named(name, call, &mut w, m);
        assert!(answer.is_ok(), "`{name}`: {answer:?}");
    }
}

#[test]
fn model_id_checks_a_number() {
    let w = small_world();
    let n = w.model_count();
    for m in w.models() {
        assert_eq!(w.model_id(m.index()).expect("in range"), m);
    }
    for index in [n, n + 1, u32::MAX as usize, usize::MAX] {
        match w.model_id(index) {
            Err(Error::ForeignModel { models, .. }) => assert_eq!(models, n),
            other => panic!("model_id({index}): {other:?}"),
        }
    }
}

/// The names of the `pub fn`s in `src` that take a [`ModelId`] parameter.
/// What controllers read (`Sensors`) checks ids as the world's own queries do: a foreign id
/// and a model of another type are errors, with the world's messages.
#[test]
fn sensors_check_ids_as_the_world_does() {
    let w = small_world();
    let s = Sensors::new(&w.states);
    let id = |name: &str| w.model_by_name(name).expect("named");
    let (wall, robot, ranger) = (id("wall"), id("robot"), id("ranger"));
    assert_eq!(s.ranger_scans(ranger).unwrap().sensors.len(), 1);
    for foreign in [ModelId(3), ModelId(u32::MAX)] {
        for got in [
            s.ranger_scans(foreign).map(drop),
            s.fiducials(foreign).map(drop),
        ] {
            match got {
                Err(Error::ForeignModel { id, models: 3 }) => assert_eq!(id, foreign),
                other => panic!("foreign id {foreign}: {other:?}"),
            }
        }
    }
    for (m, found) in [(robot, ModelType::Position), (wall, ModelType::Model)] {
        match s.ranger_scans(m) {
            Err(Error::BadModel {
                id,
                found: f,
                expected: "a ranger",
            }) => assert_eq!((id, f), (m, found)),
            other => panic!("ranger_scans on {m}: {other:?}"),
        }
    }
    assert!(matches!(
        s.fiducials(ranger),
        Err(Error::BadModel {
            found: ModelType::Ranger,
            expected: "a fiducial finder",
            ..
        })
    ));
    assert_eq!(
        s.ranger_scans(wall).unwrap_err().to_string(),
        w.ranger_scans(wall).unwrap_err().to_string()
    );
}

fn per_model_functions(src: &str) -> Vec<String> {
    let mut names = Vec::new();
    let mut rest = src;
    while let Some(at) = rest.find("pub fn ") {
        rest = &rest[at + "pub fn ".len()..];
        let name_end = rest.find(['(', '<']).expect("a function name ends");
        let name = &rest[..name_end];
        let params_start = rest.find('(').expect("parameters");
        let params_end = params_start + rest[params_start..].find(')').expect("closed");
        let params = &rest[params_start..params_end];
        if params.contains("ModelId") {
            names.push(name.to_string());
        }
    }
    names
}

#[test]
fn every_per_model_function_is_in_the_table() {
    let sources = [
        include_str!("mod.rs"),
        include_str!("build.rs"),
        include_str!("step.rs"),
        include_str!("tree.rs"),
        include_str!("query.rs"),
        include_str!("moves.rs"),
        include_str!("../controller.rs"),
        include_str!("../space/mod.rs"),
    ];
    let table: Vec<&str> = per_model_calls().iter().map(|(n, _, _)| *n).collect();
    let mut found = Vec::new();
    for src in sources {
        found.extend(per_model_functions(src));
    }
    // Constructors that only store an id check nothing: the id is checked where it is used
    // (a `Commands` queue's commands through `apply`, a controller's ranger by `ranger_scans`).
    let stores_only = ["new", "pioneer", "swarm"];
    assert!(found.len() >= 40, "the scan found too little: {found:?}");
    for name in found
        .into_iter()
        .filter(|n| !stores_only.contains(&n.as_str()))
    {
        assert!(
            table.contains(&name.as_str()),
            "public per-model function `{name}` is missing from per_model_calls()"
        );
    }
}
