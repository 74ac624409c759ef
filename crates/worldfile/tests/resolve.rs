//! The resolved level: defaults, units, names, bodies, bitmaps and resolution errors.

mod common;

use std::f64::consts::PI;
use std::path::Path;

use common::Scratch;
use worldfile::body::BlockOrigin;
use worldfile::models::{ActuatorType, Drive, Lift, Localization, Paddles};
use worldfile::{
    BitmapRows, ColorSpec, Error, ErrorKind, LoadOptions, ModelType, Rgba, TypeSpec, WorldSpec,
};

fn world(src: &str) -> Result<WorldSpec, Error> {
    WorldSpec::parse(Path::new("t.world"), src, &LoadOptions::default())
}

fn ok(src: &str) -> WorldSpec {
    world(src).unwrap_or_else(|e| panic!("{e}"))
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-9
}

#[test]
fn generated_names_follow_stage() {
    let w = ok(
        "model ( )\nmodel ( name \"a\" )\nmodel ( )\nposition ( ranger ( ) ranger ( ) model ( ) )\nposition ( name \"p\" ranger ( ) )\n",
    );
    let names: Vec<(&str, &str)> = w
        .models
        .iter()
        .map(|m| (m.name.as_str(), m.generated_name.as_str()))
        .collect();
    assert_eq!(
        names,
        [
            // The ground model takes "model:0".
            ("model:1", "model:1"),
            ("a", "model:2"),
            ("model:3", "model:3"),
            ("position:0", "position:0"),
            ("position:0.ranger:0", "position:0.ranger:0"),
            ("position:0.ranger:1", "position:0.ranger:1"),
            ("position:0.model:0", "position:0.model:0"),
            ("p", "position:1"),
            ("p.ranger:0", "p.ranger:0"),
        ]
    );
    // Both names are registered.
    assert_eq!(w.find_model("model:2"), Some(1));
    assert_eq!(w.find_model("a"), Some(1));
    assert_eq!(w.find_model("position:1"), Some(7));
    assert_eq!(w.model(3).children, [4, 5, 6]);
    assert_eq!(w.model(4).parent, Some(3));
}

#[test]
fn duplicate_names_resolve_to_the_last() {
    let w = ok("model ( name \"x\" ) model ( name \"x\" )\n");
    assert_eq!(w.find_model("x"), Some(1));
}

#[test]
fn type_defaults() {
    let w = ok(
        "model ( ) position ( ) ranger ( ) blobfinder ( ) fiducial ( ) gripper ( ) camera ( ) actuator ( ) blinkenlight ( ) lightindicator ( )\n",
    );
    let get = |i: usize| &w.models[i];
    assert_eq!(get(0).size, [0.4, 0.4, 1.0]);
    assert_eq!(get(0).color, ColorSpec::Rgba(Rgba::RED));
    assert_eq!(get(0).blocks.len(), 1);
    assert_eq!(get(0).blocks[0].origin, BlockOrigin::Default);
    assert_eq!(get(0).blocks[0].z, [0.0, 1.0]);
    assert_eq!(
        get(0).blocks[0].points,
        [[-0.2, -0.2], [0.2, -0.2], [0.2, 0.2], [-0.2, 0.2]]
    );
    assert!(get(0).common.obstacle_return && get(0).gui_move);
    assert_eq!(get(0).common.update_interval, 100);
    assert_eq!(
        (get(0).common.ranger_return, get(0).common.mass),
        (1.0, 0.0)
    );

    let p = get(1).position().unwrap();
    assert_eq!((p.drive, p.localization), (Drive::Diff, Localization::Gps));
    assert_eq!(p.odom_error, None);
    assert!(close(p.velocity_bounds[7], PI / 2.0));

    assert_eq!(get(2).size, [0.15, 0.15, 0.2]);
    assert_eq!(get(2).color, ColorSpec::Rgba(Rgba::rgb(0.0, 0.0, 0.5)));
    assert!(get(2).blocks.is_empty());
    match &get(3).spec {
        TypeSpec::Blobfinder(b) => {
            assert_eq!((b.image, b.range), ([80, 60], 12.0));
            assert!(close(b.fov, PI / 3.0) && b.colors.is_empty());
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(get(4).size, [0.0, 0.0, 0.0]);
    match &get(4).spec {
        TypeSpec::Fiducial(f) => assert_eq!((f.range_max, f.range_max_id, f.fov), (8.0, 5.0, PI)),
        other => panic!("{other:?}"),
    }
    assert_eq!(get(5).size, [0.2, 0.3, 0.2]);
    assert_eq!(get(5).blocks.len(), 3);
    match &get(6).spec {
        TypeSpec::Camera(c) => assert_eq!(
            (c.resolution, c.fov, c.range),
            ([32, 32], [70.0, 40.0], [0.2, 8.0])
        ),
        other => panic!("{other:?}"),
    }
    assert_eq!(get(7).common.watts, 2.0);
    assert_eq!(get(8).color, ColorSpec::Rgba(Rgba::rgb(0.0, 1.0, 0.0)));
    assert_eq!(get(9).model_type, ModelType::Lightindicator);
}

#[test]
fn units_apply_to_exactly_the_converted_properties() {
    let w = ok(
        "unit_length \"cm\"\nunit_angle \"radians\"\nresolution 0.05\n\
                position ( pose [100 200 10 1] size [50 50 20] wheelbase 30 velocity_bounds [-100 100 0 0 0 0 -1 1] )\n\
                blobfinder ( range 5 fov 0.5 )\ncamera ( fov [ 60 30 ] range [ 10 20 ] )\n",
    );
    let p = &w.models[0];
    assert!(close(p.pose[0], 1.0) && close(p.pose[1], 2.0) && close(p.pose[2], 0.1));
    assert!(close(p.pose[3], 1.0));
    assert!(close(p.size[0], 0.5) && close(p.size[2], 0.2));
    let pos = p.position().unwrap();
    assert!(close(pos.wheelbase, 0.3) && close(pos.velocity_bounds[1], 1.0));
    assert!(close(pos.velocity_bounds[7], 1.0));
    // World resolution and the blobfinder range are never unit-converted; camera fov is degrees.
    assert_eq!(w.settings.resolution, 0.05);
    match (&w.models[1].spec, &w.models[2].spec) {
        (TypeSpec::Blobfinder(b), TypeSpec::Camera(c)) => {
            assert_eq!(b.range, 5.0);
            assert!(close(b.fov, 0.5));
            assert_eq!(c.fov, [60.0, 30.0]);
            assert!(close(c.range[0], 0.1));
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn world_settings() {
    let w = ok("interval_sim 50.5\nquit_time 2.5\nthreads 0\nspeedup -1\n");
    assert_eq!(w.settings.interval_sim_usec(), 50_500);
    assert_eq!(w.settings.quit_time_usec(), 2_500_000);
    assert_eq!(w.settings.threads, 1);
    assert_eq!(w.settings.name, "t.world");
    assert_eq!(w.settings.ppm(), 50.0);
    let e = world("resolution 0\n").unwrap_err();
    assert!(matches!(e.kind, ErrorKind::OutOfRange { .. }));
}

#[test]
fn window_first_only() {
    let w = ok("window ( size [ 800 600 ] scale 30 show_data 1 )\nwindow ( scale 2 )\n");
    let win = w.window.unwrap();
    assert_eq!(
        (win.size, win.scale, win.show_data),
        ([800, 600], 30.0, true)
    );
    assert!(
        w.warnings
            .iter()
            .any(|x| x.message.contains("only the first `window`"))
    );
    assert!(w.models.is_empty());
}

#[test]
fn macros_give_each_instance_its_own_children_in_order() {
    let src = "define sonar ranger ( sensor ( pose [0 0 0 0] ) sensor ( pose [0 0 0 90] ) )\n\
               define bot position ( sonar ( ) )\n\
               bot ( name \"a\" ranger ( sensor ( samples 180 fov 180 ) ) )\n\
               bot ( name \"b\" )\n";
    let w = ok(src);
    let a = w.find_model("a").unwrap();
    let kids: Vec<&str> = w
        .model(a)
        .children
        .iter()
        .map(|c| w.model(*c).name.as_str())
        .collect();
    assert_eq!(kids, ["a.ranger:0", "a.ranger:1"]);
    assert_eq!(
        w.model(w.find_model("a.ranger:0").unwrap())
            .sensors()
            .unwrap()
            .len(),
        2
    );
    let laser = &w
        .model(w.find_model("a.ranger:1").unwrap())
        .sensors()
        .unwrap()[0];
    assert!(laser.samples == 180 && close(laser.fov, PI));
    let s = &w
        .model(w.find_model("b.ranger:0").unwrap())
        .sensors()
        .unwrap()[1];
    assert!(close(s.pose[3], PI / 2.0));
    assert_eq!(s.size, [0.02, 0.02, 0.02]);
    assert_eq!(w.model(a).macro_name.as_deref(), Some("bot"));
}

#[test]
fn blocks_replace_the_default_body_and_scale_to_size() {
    let w = ok(
        "model ( size [2 1 0.5] block ( points 3 point[0] [0 0] point[1] [10 0] point[2] [10 5] z [0 1] ) \
                block ( points 4 point[0] [2 1] point[1] [2 2] point[2] [3 2] point[3] [3 1] z [2 4] color \"blue\" ) )\n",
    );
    let m = &w.models[0];
    assert_eq!(m.blocks.len(), 2);
    assert_eq!(m.blocks[0].points, [[-1.0, -0.5], [1.0, -0.5], [1.0, 0.5]]);
    assert_eq!(m.blocks[0].z, [0.0, 0.125]);
    assert_eq!(m.blocks[1].z, [0.25, 0.5]);
    // The second block was written clockwise; it comes out counter-clockwise.
    assert_eq!(m.blocks[1].raw_points[0], [3.0, 1.0]);
    assert_eq!(m.blocks[1].color, Some(Rgba::rgb(0.0, 0.0, 1.0)));
    assert_eq!(m.blocks[0].color, None);
}

#[test]
fn noblocks_and_boundary() {
    let w = ok("model ( noblocks 1 ) model ( boundary 1 size [4 4 1] )\n");
    assert!(w.models[0].blocks.is_empty());
    let b = &w.models[1].blocks;
    assert_eq!(b.len(), 5);
    assert!(b[1..].iter().all(|x| x.origin == BlockOrigin::Boundary));
}

#[test]
fn bitmaps_become_rectangles() {
    let s = Scratch::new();
    // A 4x4 image: one black pixel plus a red one (free: only the first channel counts).
    let mut img = image::RgbaImage::from_pixel(4, 4, image::Rgba([255, 255, 255, 255]));
    img.put_pixel(1, 1, image::Rgba([0, 0, 0, 0]));
    img.put_pixel(2, 2, image::Rgba([255, 0, 0, 255]));
    img.put_pixel(3, 1, image::Rgba([0, 0, 255, 255]));
    std::fs::create_dir_all(s.dir.join("maps")).unwrap();
    img.save(s.dir.join("maps/m.png")).unwrap();
    let top = s.file(
        "w.world",
        "model ( bitmap \"maps/m.png\" size [8 2 1] boundary 1 )\n",
    );
    let w = WorldSpec::load(&top, &LoadOptions::default()).unwrap();
    let m = &w.models[0];
    let bitmap: Vec<_> = m
        .blocks
        .iter()
        .filter(|b| b.origin == BlockOrigin::Bitmap)
        .collect();
    assert_eq!(bitmap.len(), 2);
    // The occupied pixels' bounding box (x 1..4) is stretched to the model's 8 m.
    let xs: Vec<f64> = m
        .blocks
        .iter()
        .flat_map(|b| b.points.iter().map(|p| p[0]))
        .collect();
    assert_eq!(xs.iter().cloned().fold(f64::INFINITY, f64::min), -4.0);
    assert_eq!(xs.iter().cloned().fold(f64::NEG_INFINITY, f64::max), 4.0);
    assert_eq!(
        m.blocks
            .iter()
            .filter(|b| b.origin == BlockOrigin::Boundary)
            .count(),
        4
    );

    // Missing bitmap: located error naming the path tried.
    let top = s.file("bad.world", "model (\n bitmap \"nope.png\" )\n");
    let e = WorldSpec::load(&top, &LoadOptions::default()).unwrap_err();
    assert!(matches!(e.kind, ErrorKind::Io { what: "bitmap", .. }));
    assert_eq!(e.location.as_ref().unwrap().line, 2);
    // Found through STAGEPATH.
    let top = s.file("other/w.world", "model ( bitmap \"maps/m.png\" )\n");
    let opts = LoadOptions {
        stage_path: vec![s.dir.clone()],
        ..LoadOptions::default()
    };
    assert!(WorldSpec::load(&top, &opts).is_ok());
    // Not an image.
    s.file("maps/junk.png", "not a png");
    let top = s.file("junk.world", "model ( bitmap \"maps/junk.png\" )\n");
    let e = WorldSpec::load(&top, &LoadOptions::default()).unwrap_err();
    assert!(matches!(e.kind, ErrorKind::BadBitmap { .. }), "{e}");
}

#[test]
fn bitmap_row_modes_differ_only_in_the_last_row() {
    let s = Scratch::new();
    let img = image::GrayImage::from_pixel(3, 3, image::Luma([0]));
    img.save(s.dir.join("black.png")).unwrap();
    let top = s.file("w.world", "model ( bitmap \"black.png\" size [3 3 1] )\n");
    let stage = WorldSpec::load(&top, &LoadOptions::default()).unwrap();
    let exact = WorldSpec::load(
        &top,
        &LoadOptions {
            bitmap_rows: BitmapRows::Exact,
            ..LoadOptions::default()
        },
    )
    .unwrap();
    // Stage: a 3x2 block and a zero-height sliver; exact: one 3x3 block.
    assert_eq!(stage.models[0].blocks.len(), 2);
    assert_eq!(stage.models[0].blocks[0].raw_points[2], [3.0, 2.0]);
    assert_eq!(exact.models[0].blocks.len(), 1);
    assert_eq!(exact.models[0].blocks[0].raw_points[2], [3.0, 3.0]);
}

#[test]
fn gripper_paddles_and_actuator_axis() {
    let w = ok(
        "gripper ( paddle_state [ \"closed\" \"up\" ] autosnatch 1 )\nactuator ( axis [ 0 3 4 ] start_position 2 pose [1 0 0 0] )\nactuator ( type \"rotational\" start_position 0.5 )\n",
    );
    match &w.models[0].spec {
        TypeSpec::Gripper(g) => {
            assert_eq!(g.paddle_state.paddles, Paddles::Closed);
            assert_eq!(g.paddle_state.lift, Lift::Up);
            assert!(g.autosnatch);
        }
        other => panic!("{other:?}"),
    }
    // Closed and up: the paddles meet in the middle at the top of the gripper.
    let paddle = &w.models[0].blocks[1];
    assert!(close(paddle.z[1], 0.2));
    match &w.models[1].spec {
        TypeSpec::Actuator(a) => {
            assert_eq!(a.actuator_type, ActuatorType::Linear);
            assert!(close(a.axis[1], 0.6) && close(a.axis[2], 0.8));
        }
        other => panic!("{other:?}"),
    }
    let p = w.models[1].pose;
    assert!(close(p[0], 1.0) && close(p[1], 1.2) && close(p[2], 1.6));
    assert!(close(w.models[2].pose[3], 0.5));
}

#[test]
fn localization_origin_defaults_to_the_global_pose_at_load() {
    let w = ok(
        "model ( pose [1 2 0 90] size [1 1 0.5] position ( pose [1 0 0 0] ) position ( localization_origin [0 0 0 0] ) )\n",
    );
    let p = w.models[1].position().unwrap();
    assert!(close(p.localization_origin[0], 1.0) && close(p.localization_origin[1], 3.0));
    // Stacked on the parent's top.
    assert!(close(p.localization_origin[2], 0.5));
    assert!(close(p.localization_origin[3], PI / 2.0));
    assert_eq!(
        w.models[2].position().unwrap().localization_origin,
        [0.0; 4]
    );
    let g = w.global_pose(1);
    assert!(close(g[1], 3.0) && close(g[2], 0.5));
}

#[test]
fn colours_random_and_unknown() {
    let mut w = ok(
        "model ( color \"random\" ) model ( color \"NoSuchColour\" ) model ( color_rgba [0 0 1 0.5] )\n",
    );
    assert_eq!(w.models[0].color, ColorSpec::Random);
    assert_eq!(w.models[1].color, ColorSpec::Rgba(Rgba::RED));
    assert!(
        w.warnings
            .iter()
            .any(|x| x.message.contains("unknown colour name"))
    );
    let mut again = w.clone();
    w.resolve_random_colors(42);
    again.resolve_random_colors(42);
    assert_eq!(w.models[0].color, again.models[0].color);
    assert!(matches!(w.models[0].color, ColorSpec::Rgba(_)));
}

#[test]
fn unused_properties_warn_per_type() {
    let w = ok("ranger ( samples 5 ) position ( drive \"diff\" ) model ( drive \"omni\" )\n");
    let unused: Vec<&str> = w
        .warnings
        .iter()
        .filter(|x| x.message.contains("not used"))
        .map(|x| x.message.as_str())
        .collect();
    assert_eq!(unused.len(), 2, "{unused:?}");
    assert!(unused[0].contains("`samples`"));
    assert!(unused[1].contains("`drive` in `model`"));
}

#[test]
fn legacy_types_load_with_a_warning() {
    let w = ok("position ( laser ( ) wifi ( ip \"1.2.3.4\" power 30 ) )\nmap ( )\n");
    assert_eq!(w.models[1].model_type, ModelType::Laser);
    match &w.models[1].spec {
        TypeSpec::Laser(l) => assert_eq!((l.samples, l.range_max), (180, 8.0)),
        other => panic!("{other:?}"),
    }
    assert_eq!(w.models[1].size, [0.15, 0.15, 0.2]);
    match &w.models[2].spec {
        TypeSpec::Wifi(wifi) => assert_eq!(wifi.properties["ip"], ["1.2.3.4"]),
        other => panic!("{other:?}"),
    }
    assert!(!w.models[2].common.obstacle_return);
    assert_eq!(
        (w.models[3].model_type, w.models[3].type_word.as_str()),
        (ModelType::Model, "map")
    );
    assert_eq!(w.warnings.len(), 3, "{:#?}", w.warnings);
}

#[test]
fn resolution_errors_are_located() {
    let e = world("\n  robot ( )\n").unwrap_err();
    assert_eq!(e.kind, ErrorKind::UnknownModelType("robot".into()));
    assert_eq!(
        (
            e.location.as_ref().unwrap().line,
            e.location.as_ref().unwrap().col
        ),
        (2, 3)
    );
    assert_eq!(
        world("block ( points 3 )\n").unwrap_err().kind,
        ErrorKind::BlockOutsideModel
    );
    assert_eq!(
        world("position ( sensor ( ) )\n").unwrap_err().kind,
        ErrorKind::SensorOutsideRanger
    );
    assert_eq!(
        world("model ( block ( points 1 point[0] [0 0] ) )\n")
            .unwrap_err()
            .kind,
        ErrorKind::TooFewPoints(1)
    );
    assert!(matches!(
        world("model ( block ( points -1 ) )\n").unwrap_err().kind,
        ErrorKind::OutOfRange { .. }
    ));
    assert!(matches!(
        world("model ( size [1 1 \"big\"] )\n").unwrap_err().kind,
        ErrorKind::NotANumber { .. }
    ));
    assert!(matches!(
        world("model ( pose [1 2] )\n").unwrap_err().kind,
        ErrorKind::TupleTooShort {
            needed: 4,
            found: 2,
            ..
        }
    ));
    assert!(matches!(
        world("blobfinder ( colors_count 3 colors [ \"red\" ] )\n")
            .unwrap_err()
            .kind,
        ErrorKind::TupleTooShort {
            needed: 3,
            found: 1,
            ..
        }
    ));
    // The definition of a macro is reached through the include chain of its instance.
    let e = world("define bot position ( pose [ 1 ] )\nbot ( )\n").unwrap_err();
    assert_eq!(e.location.as_ref().unwrap().line, 1);
}

#[test]
fn power_packs() {
    let w = ok("model ( joules 100 joules_capacity 400 ) model ( kjoules 2 ) model ( )\n");
    let p = w.models[0].power_pack.unwrap();
    assert_eq!((p.stored, p.capacity), (100.0, 400.0));
    assert_eq!(w.models[1].power_pack.unwrap().capacity, 2000.0);
    assert!(w.models[2].power_pack.is_none());
}

#[test]
fn dump_is_json() {
    let w = ok("position ( name \"r\" color \"random\" ranger ( sensor ( ) ) )\n");
    let json = serde_json::to_value(&w).unwrap();
    assert_eq!(json["models"][0]["name"], "r");
    assert_eq!(json["models"][0]["spec"]["type"], "position");
    assert_eq!(json["models"][0]["color"], "Random");
    assert_eq!(json["models"][1]["location"], "t.world:1:36");
}

/// Numbers beyond what the reads hold (issue 41): an integer past 64 bits is an error naming
/// its place (Stage's `atoi`, glibc's `(int) strtol`, reads it as -1 or 0, so no reading
/// agrees with the file); a float past the largest double is read as infinity, as Stage's
/// `atof` reads it, with a warning naming its place (stage-sim then refuses to build a model
/// whose pose or size is not finite).
#[test]
fn numbers_beyond_their_type_are_named_at_their_place() {
    let e =
        world("interval_sim 100\nmodel ( block ( points 99999999999999999999 ) )\n").unwrap_err();
    assert!(
        matches!(&e.kind, ErrorKind::IntegerOverflow { name, text }
            if name == "points" && text == "99999999999999999999"),
        "{e}"
    );
    let text = e.to_string();
    assert!(text.contains("t.world:2:24"), "{text}");
    assert!(text.contains("does not fit in a 64-bit integer"), "{text}");
    // the largest value reads as written (and is out of range there); one past the most
    // negative is refused too
    assert!(
        world("model ( block ( points 9223372036854775807 ) )\n")
            .is_err_and(|e| matches!(e.kind, ErrorKind::OutOfRange { .. }))
    );
    assert!(matches!(
        world("model ( block ( points -9223372036854775809 ) )\n")
            .unwrap_err()
            .kind,
        ErrorKind::IntegerOverflow { .. }
    ));

    let spec = ok("model ( name \"m\" pose [1e999 0 0 0] )\n");
    let w = spec
        .warnings
        .iter()
        .map(ToString::to_string)
        .find(|w| w.contains("beyond the largest double"))
        .expect("a warning for 1e999");
    assert!(w.starts_with("t.world:1:"), "{w}");
    assert!(
        w.contains("`pose` value `1e999`") && w.contains("read as inf"),
        "{w}"
    );
}
