//! The world scene builder (pure, no GPU): which primitives a known world produces under which
//! View-menu settings, picking, subscriptions for visualisation, and every Stage world.

mod common;

use viewer::View;
use viewer::scene::{Layer, Rgba8, Scene};
use viewer::world_scene::{self, VisOptions, WorldGui};

fn view() -> View {
    View {
        center: [0.0, 0.0],
        scale: 40.0,
        yaw: 0.0,
        size: [400.0, 320.0],
    }
}

fn has_color(scene: &Scene, layer: Layer, c: Rgba8) -> bool {
    scene.layer(layer).triangles.iter().any(|v| v.color == c)
}

#[test]
fn bodies_and_rays_follow_the_view_menu() {
    let (world, gui) = common::known_world();
    let mut scene = Scene::default();
    let off = VisOptions::default();
    assert!(!off.data, "show_data is off by default, as in Stage");
    world_scene::build(&world, &gui, &off, &view(), &[], &mut scene);
    assert!(has_color(&scene, Layer::Bodies, Rgba8::rgb(255, 0, 0)));
    assert!(has_color(&scene, Layer::Bodies, Rgba8::rgb(0, 0, 0)));
    assert!(scene.layer(Layer::Data).segments.is_empty());
    assert!(scene.layer(Layer::Footprints).fans.is_empty());
    // grid lines every metre over the visible floor
    assert!(!scene.layer(Layer::Grid).segments.is_empty());

    let on = VisOptions {
        data: true,
        ranger_beams: true,
        ranger_strikes: true,
        ..VisOptions::default()
    };
    // zoomed in (400 px/m) every ray lands more than a pixel from its neighbour: all are drawn
    let close = View {
        scale: 400.0,
        center: [1.0, 0.0],
        ..view()
    };
    world_scene::build(&world, &gui, &on, &close, &[], &mut scene);
    let rays = scene.layer(Layer::Data).segments.clone();
    assert_eq!(rays.len(), 181, "one segment per ray");
    // every ray starts at the laser and the straight-ahead one ends on the top wall's face
    for r in &rays {
        assert!((r.a[0] - 1.0).abs() < 1e-4 && (r.a[1] + 1.0).abs() < 1e-4);
    }
    let ahead = rays[90];
    assert!(
        (ahead.b[0] - 1.0).abs() < 1e-3 && (ahead.b[1] - 3.0).abs() < 1e-3,
        "{ahead:?}"
    );
    // strikes: a dot for every ray that hit something (the ones to the right escape the world)
    assert!(!scene.layer(Layer::Data).triangles.is_empty());

    // at 5 px/m rays ending within a pixel of the previous one drawn are left out, and the
    // footprint fan keeps only the rim points that matter at half a pixel (straight walls need
    // their ends only): fewer primitives, the same picture
    let distant = View {
        scale: 5.0,
        ..view()
    };
    world_scene::build(&world, &gui, &on, &distant, &[], &mut scene);
    let far = scene.layer(Layer::Data).segments.clone();
    assert!(far.len() < 181 && far.len() > 30, "{} rays", far.len());
    // the first ray is always drawn
    assert!((far[0].b[0] - rays[0].b[0]).abs() < 1e-4 && (far[0].b[1] - rays[0].b[1]).abs() < 1e-4);
    let px = 1.0 / 5.0;
    for w in far.windows(2) {
        let gap = (w[0].b[0] - w[1].b[0]).hypot(w[0].b[1] - w[1].b[1]) as f64;
        assert!(gap >= px * 0.999, "rays drawn {gap} m apart");
    }
    let fp = scene.layer(Layer::Footprints);
    assert_eq!(fp.fans.len(), 1);
    let fan = fp.fans[0].points(fp);
    // the centre, then a rim thinned from 180 ray ends (but at least two)
    assert!(
        fan.len() >= 3 && fan.len() < 181,
        "{} fan points",
        fan.len()
    );
    assert!((fan[0][0] - 1.0).abs() < 1e-4 && (fan[0][1] + 1.0).abs() < 1e-4);
    // drawn as triangles, consecutive ones share their rim edge, so the footprint has no gaps
    let mut tris = Vec::new();
    fp.fan_triangles(&mut tris);
    assert_eq!(tris.len(), 3 * (fan.len() - 2));
    for w in tris.chunks(3).collect::<Vec<_>>().windows(2) {
        assert_eq!(w[0][2].pos, w[1][1].pos);
    }

    let no_grid = VisOptions {
        grid: false,
        blocks: false,
        ..VisOptions::default()
    };
    world_scene::build(&world, &gui, &no_grid, &view(), &[], &mut scene);
    assert!(scene.layer(Layer::Grid).segments.is_empty());
    assert!(scene.layer(Layer::Bodies).triangles.is_empty());
}

#[test]
fn visualised_sensors_are_the_ones_shown() {
    let (world, _) = common::known_world();
    let laser = world.model_by_name("laser").unwrap();
    let mut vis = VisOptions::default();
    assert!(world_scene::visualised_sensors(&world, &vis).is_empty());
    vis.data = true;
    assert_eq!(world_scene::visualised_sensors(&world, &vis), vec![laser]);
    vis.ranger_ranges = false;
    vis.ranger_beams = false;
    vis.ranger_strikes = false;
    assert!(world_scene::visualised_sensors(&world, &vis).is_empty());
}

#[test]
fn picking_finds_the_top_model_or_its_movable_ancestor() {
    let (world, gui) = common::known_world();
    let robot = world.model_by_name("robot").unwrap();
    let laser = world.model_by_name("laser").unwrap();
    let walls = world.model_by_name("walls").unwrap();
    assert_eq!(
        world_scene::pick(&world, &gui, [1.2, -1.2], true),
        Some(robot)
    );
    // the laser sits on top of the robot: it is hit, the robot is what moves
    assert_eq!(
        world_scene::pick(&world, &gui, [1.0, -1.0], false),
        Some(laser)
    );
    assert_eq!(
        world_scene::pick(&world, &gui, [1.0, -1.0], true),
        Some(robot)
    );
    assert_eq!(
        world_scene::pick(&world, &gui, [0.0, 3.1], true),
        Some(walls)
    );
    assert_eq!(world_scene::pick(&world, &gui, [0.0, 0.0], true), None);
    // a model that is not movable and has no movable ancestor is not picked for dragging
    let mut fixed = gui.clone();
    fixed.models[walls.index()].movable = false;
    assert_eq!(world_scene::pick(&world, &fixed, [0.0, 3.1], true), None);
}

#[test]
fn selection_and_speech_are_drawn_on_top() {
    let (mut world, gui) = common::known_world();
    let robot = world.model_by_name("robot").unwrap();
    world.say(robot, "hello").unwrap();
    let mut scene = Scene::default();
    world_scene::build(
        &world,
        &gui,
        &VisOptions::default(),
        &view(),
        &[robot],
        &mut scene,
    );
    assert!(
        scene
            .layer(Layer::Overlay)
            .segments
            .iter()
            .any(|s| s.color == world_scene::SELECTED)
    );
    assert_eq!(scene.labels.len(), 1);
    assert_eq!(scene.labels[0].text, "hello");
    assert!(scene.labels[0].bubble.is_some());
    // an out-of-range selection (an id from a bigger world) is ignored
    let mut big = stage_sim::WorldDesc::default();
    for i in 0..1000 {
        big.add(
            stage_sim::ModelDesc::new(&format!("m{i}"), stage_sim::KindDesc::Model),
            None,
        );
    }
    let big = stage_sim::World::from_desc(&big, 1).expect("plain models build");
    world_scene::build(
        &world,
        &gui,
        &VisOptions::default(),
        &view(),
        &[big.model_id(999).expect("the big world has 1000 models")],
        &mut scene,
    );
}

#[test]
fn every_stage_world_builds_a_scene() {
    let Some(shared) = common::shared_dir() else {
        return;
    };
    let dir = shared.join("stage-worlds");
    let mut worlds: Vec<_> = std::fs::read_dir(&dir)
        .expect("stage-worlds")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "world"))
        .collect();
    worlds.sort();
    assert!(!worlds.is_empty());
    let mut built = 0;
    for path in &worlds {
        let Ok((mut world, spec)) = stage_sim::World::load(path, 1) else {
            continue;
        };
        for _ in 0..3 {
            world.step();
        }
        let gui = WorldGui::from_spec(&spec);
        assert_eq!(gui.models.len(), world.model_count());
        let vis = VisOptions {
            data: true,
            ..VisOptions::from_window(&spec.window.clone().unwrap_or_default())
        };
        let mut v = View::from_window(&spec.window.clone().unwrap_or_default());
        let (min, max) = world_scene::world_extent(&world);
        v.fit(min, max);
        let mut scene = Scene::default();
        world_scene::build(&world, &gui, &vis, &v, &[], &mut scene);
        assert!(
            scene.triangle_count() > 0,
            "{} draws bodies",
            path.display()
        );
        built += 1;
    }
    eprintln!("{built} of {} Stage worlds drawn", worlds.len());
    assert!(built * 2 >= worlds.len());
}

/// The static layer is kept from the last frame while nothing it depends on changed, and the
/// kept scene is exactly what a fresh build gives; a recoloured wall or a moved view rebuilds it.
#[test]
fn static_layer_is_reused_only_while_unchanged() {
    let (mut world, gui) = common::known_world();
    let vis = VisOptions::default();
    let walls = world.model_by_name("walls").expect("walls");
    let fresh = |world: &stage_sim::World, view: &View| {
        let mut s = Scene::default();
        world_scene::build(world, &gui, &vis, view, &[], &mut s);
        s
    };
    let v = view();
    let mut reused = Scene::default();
    world_scene::build(&world, &gui, &vis, &v, &[], &mut reused);
    let key = reused.static_key.expect("a key for the static layer");
    assert!(
        has_color(&reused, Layer::Static, Rgba8::BLACK),
        "the walls are in the static layer"
    );
    for _ in 0..5 {
        world.step();
    }
    // a robot moved: only the dynamic layers change
    world_scene::build(&world, &gui, &vis, &v, &[], &mut reused);
    assert_eq!(reused.static_key, Some(key));
    assert_eq!(reused, fresh(&world, &v));

    // a recoloured wall must show
    world
        .set_color(walls, stage_sim::Color::rgb(0.0, 1.0, 0.0))
        .unwrap();
    world_scene::build(&world, &gui, &vis, &v, &[], &mut reused);
    assert_ne!(reused.static_key, Some(key));
    assert!(has_color(&reused, Layer::Static, Rgba8::rgb(0, 255, 0)));
    assert_eq!(reused, fresh(&world, &v));

    // and so must a new view
    let moved = View {
        center: [v.center[0] + 1.0, v.center[1]],
        ..v
    };
    world_scene::build(&world, &gui, &vis, &moved, &[], &mut reused);
    assert_eq!(reused, fresh(&world, &moved));
}
