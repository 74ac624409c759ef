//! Headless render tests: a known world and a playerv view of a known ranger scan are drawn
//! offscreen with wgpu (Mesa's software Vulkan where there is no GPU), read back, and the
//! pixels where the world puts walls, robots and ray ends are checked. Without any adapter the
//! tests skip with a note, unless `PLAYERSTAGE_REQUIRE_GPU=1`.

mod common;

use viewer::View;
use viewer::offscreen::{self, Pixels};
use viewer::playerv::state::{
    DeviceData, DeviceKey, Hypothesis, MapGrid, PlannerView, PlayervState, Pose2, Scan, Subscribed,
};
use viewer::scene::{Layer, Rgba8, Scene};
use viewer::world_scene::{self, VisOptions};

fn pixel_at(px: &Pixels, view: &View, p: [f64; 2]) -> [u8; 4] {
    let s = view.to_screen(p);
    px.get(s[0].floor() as i64, s[1].floor() as i64)
        .expect("point inside the image")
}

/// Pixels within `r` pixels of world point `p`.
fn around(px: &Pixels, view: &View, p: [f64; 2], r: i64) -> Vec<[u8; 4]> {
    let s = view.to_screen(p);
    let (x, y) = (s[0].floor() as i64, s[1].floor() as i64);
    let mut v = Vec::new();
    for dy in -r..=r {
        for dx in -r..=r {
            if let Some(c) = px.get(x + dx, y + dy) {
                v.push(c);
            }
        }
    }
    v
}

/// Saves the render under `$PLAYERSTAGE_RENDER_DUMP` (for looking at a failure).
fn dump(px: &Pixels, name: &str) {
    if let Some(dir) = std::env::var_os("PLAYERSTAGE_RENDER_DUMP") {
        let path = std::path::Path::new(&dir).join(format!("{name}.png"));
        viewer::world_window::save_png(&path, px.width, px.height, &px.rgba).expect("dump");
    }
}

fn rgb(c: [u8; 4]) -> [u8; 3] {
    [c[0], c[1], c[2]]
}

fn bluish(c: [u8; 4]) -> bool {
    let [r, g, b, _] = c.map(i32::from);
    b >= 180 && b > r + 60 && b > g + 60
}

/// Data on, ranger rays and footprints shown.
fn rays_shown() -> VisOptions {
    VisOptions {
        data: true,
        ranger_beams: true,
        ranger_ranges: true,
        ..VisOptions::default()
    }
}

fn world_view() -> View {
    View {
        center: [0.0, 0.0],
        scale: 40.0,
        yaw: 0.0,
        size: [400.0, 320.0],
    }
}

#[test]
fn known_world_renders_walls_robot_and_rays_where_the_world_puts_them() {
    let Some(mut gpu) = offscreen::for_tests() else {
        return;
    };
    eprintln!("adapter: {:?}", gpu.adapter_info());
    let (world, gui) = common::known_world();
    let vis = rays_shown();
    let view = world_view();
    let mut scene = Scene::default();
    world_scene::build(&world, &gui, &vis, &view, &[], &mut scene);
    let px = gpu.render(&scene, &view).expect("render");
    dump(&px, "known_world");
    assert_eq!((px.width, px.height), (400, 320));

    // walls: black inside the top and left walls
    for p in [
        [0.0, 3.1],
        [-3.0, 3.1],
        [3.5, 3.15],
        [-3.9, 0.5],
        [-3.9, -2.5],
    ] {
        assert_eq!(rgb(pixel_at(&px, &view, p)), [0, 0, 0], "wall at {p:?}");
    }
    // the robot's body: red behind its laser (whose rays cover its front half), off its nose
    for p in [[1.2, -1.2], [0.8, -1.2], [0.75, -1.25]] {
        assert_eq!(rgb(pixel_at(&px, &view, p)), [255, 0, 0], "robot at {p:?}");
    }
    // the straight-ahead ray ends at the top wall: ray colour just before it, wall after
    assert!(
        around(&px, &view, [1.0, 2.9], 1).into_iter().any(bluish),
        "a ray reaches (1, 2.9)"
    );
    // the leftmost ray ends at the left wall's face x = -3.8
    assert!(
        around(&px, &view, [-3.7, -1.0], 1).into_iter().any(bluish),
        "a ray reaches (-3.7, -1)"
    );
    // rays do not pass through walls: beyond the top wall is the canvas background
    assert_eq!(
        rgb(pixel_at(&px, &view, [1.0, 3.5])),
        rgb(world_scene::BACKGROUND.0),
        "outside the world's extent"
    );
    // behind the robot (the laser covers only its front half): the plain floor
    assert_eq!(rgb(pixel_at(&px, &view, [1.5, -2.5])), [255, 255, 255]);
    // in front, between rays, the floor is tinted by the translucent scan footprint
    let tinted = pixel_at(&px, &view, [2.5, 0.4]);
    assert!(
        tinted[2] > tinted[0] && tinted[0] < 255,
        "footprint tint at (2.5, 0.4): {tinted:?}"
    );
    // and outside the canvas' world: background in the corners
    assert_eq!(rgb(px.get(2, 2).unwrap()), rgb(world_scene::BACKGROUND.0));
}

#[test]
fn moving_the_view_moves_the_picture() {
    let Some(mut gpu) = offscreen::for_tests() else {
        return;
    };
    let (world, gui) = common::known_world();
    let vis = VisOptions::default();
    // rotated a quarter turn and zoomed: the top wall is now on the left of the canvas
    let view = View {
        center: [0.5, 1.0],
        scale: 50.0,
        yaw: std::f64::consts::FRAC_PI_2,
        size: [300.0, 300.0],
    };
    let mut scene = Scene::default();
    world_scene::build(&world, &gui, &vis, &view, &[], &mut scene);
    let px = gpu.render(&scene, &view).expect("render");
    dump(&px, "rotated");
    let s = view.to_screen([0.0, 3.1]);
    assert!(s[0] < 150.0, "the wall is left of centre");
    assert_eq!(rgb(pixel_at(&px, &view, [0.0, 3.1])), [0, 0, 0]);
    assert_eq!(rgb(pixel_at(&px, &view, [1.2, -1.2])), [255, 0, 0]);
    // no data shown (show_data defaults to off): the floor in front of the robot is plain
    assert_eq!(rgb(pixel_at(&px, &view, [1.5, 1.5])), [255, 255, 255]);
}

/// A playerv state with a base and one 181-ray ranger: 2 m everywhere, 1 m between bearings
/// 35° and 55°.
fn playerv_state() -> PlayervState {
    let mut st = PlayervState::new("localhost:6665", player_client::DataMode::Pull, 5.0);
    let bearings: Vec<f64> = (0..181).map(|i| (i as f64 - 90.0).to_radians()).collect();
    let ranges: Vec<f64> = (0..181i32)
        .map(|i| {
            let deg = i - 90;
            if (35..=55).contains(&deg) { 1.0 } else { 2.0 }
        })
        .collect();
    st.subscribed.insert(
        DeviceKey::parse("position2d:0").unwrap(),
        Subscribed {
            driver: "stage".into(),
            data: DeviceData::Position2d {
                pose: Pose2::default(),
                velocity: Pose2::default(),
                stall: false,
                size: [0.5, 0.5],
            },
            datatime: 0.0,
        },
    );
    st.subscribed.insert(
        DeviceKey::parse("ranger:0").unwrap(),
        Subscribed {
            driver: "stage".into(),
            data: DeviceData::Ranges {
                scans: vec![Scan {
                    origin: Pose2::default(),
                    bearings,
                    ranges,
                    max_range: 4.0,
                    cone: 0.0,
                }],
            },
            datatime: 0.0,
        },
    );
    st
}

#[test]
fn playerv_view_of_a_known_scan_puts_rays_where_the_ranges_say() {
    let Some(mut gpu) = offscreen::for_tests() else {
        return;
    };
    let st = playerv_state();
    let view = View {
        center: [0.0, 0.0],
        scale: 50.0,
        yaw: 0.0,
        size: [400.0, 400.0],
    };
    let mut scene = Scene::default();
    viewer::playerv::scene::build(&st, None, &view, &mut scene);
    let px = gpu.render(&scene, &view).expect("render");
    dump(&px, "playerv");
    let at = |deg: f64, r: f64| {
        let a = deg.to_radians();
        [r * a.cos(), r * a.sin()]
    };
    // the short rays end at 1 m: ray colour before, untouched background beyond
    assert!(
        around(&px, &view, at(45.0, 0.95), 1)
            .into_iter()
            .any(bluish)
    );
    assert_eq!(
        rgb(pixel_at(&px, &view, at(45.0, 1.5))),
        rgb(viewer::playerv::scene::BACKGROUND.0),
        "nothing beyond the short rays"
    );
    // the long rays reach 2 m and stop there
    assert!(
        around(&px, &view, at(-45.0, 1.9), 1)
            .into_iter()
            .any(bluish)
    );
    assert_eq!(
        rgb(pixel_at(&px, &view, at(-45.0, 2.4))),
        rgb(viewer::playerv::scene::BACKGROUND.0)
    );
    // the robot's body behind the sensor (rays cover the front half only)
    assert_eq!(
        rgb(pixel_at(&px, &view, [-0.15, -0.15])),
        rgb(viewer::playerv::scene::BASE.0)
    );
    // a camera image is drawn where the scene puts it
    let mut st2 = st.clone();
    st2.subscribed.insert(
        DeviceKey::parse("camera:0").unwrap(),
        Subscribed {
            driver: "stage".into(),
            data: DeviceData::Camera {
                width: 4,
                height: 2,
                rgba: [[0u8, 255, 0, 255]; 8].concat(),
            },
            datatime: 0.0,
        },
    );
    viewer::playerv::scene::build(&st2, None, &view, &mut scene);
    let px = gpu.render(&scene, &view).expect("render");
    // the inset sits at the top right, 10 px in
    let c = px.get(400 - 10 - 60, 10 + 30).unwrap();
    assert_eq!(rgb(c), [0, 255, 0], "camera image pixel");
    let _ = Rgba8::WHITE;
}

/// A navigation stack as playerv shows it: a 10 x 8 m map at 0.1 m (origin (-5, -4)) that is
/// free but for a wall x ∈ [1, 1.5], y ∈ [-4, 2] and an unknown strip y ∈ [3.5, 4]; a plan from
/// (-3, -2) over the top of the wall to (3, -2); amcl's hypothesis at (-3, -2) facing +x with
/// a 0.5 m (x) by 0.25 m (y) standard deviation; a base there (odometry elsewhere: the
/// localiser's pose is the one drawn); and a particle cloud.
fn nav_state() -> PlayervState {
    let mut st = PlayervState::new("localhost:6665", player_client::DataMode::Pull, 5.0);
    let (w, h) = (100u32, 80u32);
    let cells: Vec<i8> = (0..w * h)
        .map(|k| {
            let (i, j) = (k % w, k / w);
            let (x, y) = (
                -5.0 + (f64::from(i) + 0.5) * 0.1,
                -4.0 + (f64::from(j) + 0.5) * 0.1,
            );
            if (1.0..1.5).contains(&x) && y < 2.0 {
                1
            } else if y > 3.5 {
                0
            } else {
                -1
            }
        })
        .collect();
    let grid = MapGrid::new(w, h, 0.1, [-5.0, -4.0], &cells).unwrap();
    let sub = |data| Subscribed {
        driver: "test".into(),
        data,
        datatime: 1.0,
    };
    st.subscribed.insert(
        DeviceKey::parse("map:0").unwrap(),
        sub(DeviceData::Map(std::sync::Arc::new(grid))),
    );
    let robot = Pose2 {
        x: -3.0,
        y: -2.0,
        a: 0.0,
    };
    st.subscribed.insert(
        DeviceKey::parse("planner:0").unwrap(),
        sub(DeviceData::Planner(PlannerView {
            valid: true,
            done: false,
            pos: robot,
            goal: Pose2 {
                x: 3.0,
                y: -2.0,
                a: 0.0,
            },
            waypoint: Pose2 {
                x: 1.25,
                y: 3.0,
                a: 0.0,
            },
            waypoint_idx: 1,
            waypoints: vec![[-3.0, -2.0], [1.25, 3.0], [3.0, -2.0]],
        })),
    );
    st.subscribed.insert(
        DeviceKey::parse("localize:0").unwrap(),
        sub(DeviceData::Localize {
            hypotheses: vec![Hypothesis {
                mean: robot,
                cov: [0.25, 0.0625, 0.01],
                weight: 1.0,
            }],
            particles: (0..5000)
                .map(|k| {
                    let t = f64::from(k) * 0.7;
                    (
                        Pose2 {
                            x: 3.5 + 0.3 * t.cos(),
                            y: 1.0 + 0.3 * t.sin(),
                            a: 0.0,
                        },
                        1.0 / 5000.0,
                    )
                })
                .collect(),
        }),
    );
    st.subscribed.insert(
        DeviceKey::parse("position2d:0").unwrap(),
        sub(DeviceData::Position2d {
            pose: Pose2 {
                x: 40.0,
                y: 40.0,
                a: 1.0,
            },
            velocity: Pose2::default(),
            stall: false,
            size: [0.4, 0.4],
        }),
    );
    st
}

#[test]
fn playerv_draws_the_map_the_plan_and_the_hypotheses_where_they_are() {
    let Some(mut gpu) = offscreen::for_tests() else {
        return;
    };
    let st = nav_state();
    assert_eq!(
        st.robot_in_map(),
        Some(Pose2 {
            x: -3.0,
            y: -2.0,
            a: 0.0
        })
    );
    let view = View {
        center: [0.0, 0.0],
        scale: 40.0,
        yaw: 0.0,
        size: [480.0, 400.0],
    };
    let mut scene = Scene::default();
    viewer::playerv::scene::build(&st, None, &view, &mut scene);
    let px = gpu.render(&scene, &view).expect("render");
    dump(&px, "playerv-nav");
    use viewer::playerv::scene::{
        BACKGROUND, BASE, GOAL, HYPOTHESIS, MAP_FREE, MAP_OCCUPIED, MAP_UNKNOWN, PARTICLE, PATH,
    };
    let close = |c: [u8; 4], want: Rgba8| {
        c.iter()
            .zip(want.0)
            .take(3)
            .all(|(a, b)| (i32::from(*a) - i32::from(b)).abs() <= 40)
    };
    // The map: the wall, the unknown strip, free floor, and nothing outside the map.
    assert_eq!(rgb(pixel_at(&px, &view, [1.25, -1.0])), rgb(MAP_OCCUPIED.0));
    assert_eq!(rgb(pixel_at(&px, &view, [-1.0, 3.8])), rgb(MAP_UNKNOWN.0));
    assert_eq!(rgb(pixel_at(&px, &view, [0.0, -3.0])), rgb(MAP_FREE.0));
    assert_eq!(rgb(pixel_at(&px, &view, [5.5, 0.0])), rgb(BACKGROUND.0));
    // The path: halfway along its first leg, and the waypoint being driven to.
    assert!(
        around(&px, &view, [-0.875, 0.5], 1)
            .into_iter()
            .any(|c| close(c, PATH))
    );
    assert!(
        around(&px, &view, [2.125, 0.5], 1)
            .into_iter()
            .any(|c| close(c, PATH))
    );
    // The goal's ring, 8 pixels round (3, -2).
    assert!(
        around(&px, &view, [3.0 + 8.0 / 40.0, -2.0], 1)
            .into_iter()
            .any(|c| close(c, GOAL))
    );
    // The hypothesis ellipse: 2 standard deviations, 1 m along x and 0.5 m along y.
    assert!(
        around(&px, &view, [-2.0, -2.0], 1)
            .into_iter()
            .any(|c| close(c, HYPOTHESIS))
    );
    assert!(
        around(&px, &view, [-3.0, -1.5], 1)
            .into_iter()
            .any(|c| close(c, HYPOTHESIS))
    );
    assert!(
        !around(&px, &view, [-3.0, -1.2], 1)
            .into_iter()
            .any(|c| close(c, HYPOTHESIS))
    );
    // The robot is drawn at the hypothesis, not at its odometry.
    assert_eq!(rgb(pixel_at(&px, &view, [-3.1, -2.1])), rgb(BASE.0));
    // The particle cloud, a ring of 0.3 m round (3.5, 1).
    assert!(
        around(&px, &view, [3.8, 1.0], 2)
            .into_iter()
            .any(|c| close(c, PARTICLE))
    );
    assert_eq!(rgb(pixel_at(&px, &view, [3.5, 1.0])), rgb(MAP_FREE.0));
    // The map stays in the static layer from frame to frame.
    let before = scene.layer(Layer::Static).triangles.len();
    assert!(before > 0);
    viewer::playerv::scene::build(&st, None, &view, &mut scene);
    assert_eq!(scene.layer(Layer::Static).triangles.len(), before);
}

/// Two robots on one map, as `playerv HOST:PORT HOST:PORT` shows them: the second server's
/// robot (no map of its own) is drawn at its own localiser's pose, with its own hypothesis, on
/// the first one's map.
#[test]
fn a_second_robot_is_drawn_on_the_first_ones_map_at_its_own_pose() {
    let Some(mut gpu) = offscreen::for_tests() else {
        return;
    };
    let first = nav_state();
    let mut second = PlayervState::new("localhost:6666", player_client::DataMode::Pull, 5.0);
    let at = Pose2 {
        x: 3.0,
        y: 2.0,
        a: 0.0,
    };
    second.subscribed.insert(
        DeviceKey::parse("localize:0").unwrap(),
        Subscribed {
            driver: "amcl".into(),
            data: DeviceData::Localize {
                hypotheses: vec![Hypothesis {
                    mean: at,
                    cov: [0.04, 0.04, 0.01],
                    weight: 1.0,
                }],
                particles: Vec::new(),
            },
            datatime: 1.0,
        },
    );
    second.subscribed.insert(
        DeviceKey::parse("position2d:0").unwrap(),
        Subscribed {
            driver: "stage".into(),
            data: DeviceData::Position2d {
                pose: Pose2::default(),
                velocity: Pose2::default(),
                stall: false,
                size: [0.4, 0.4],
            },
            datatime: 1.0,
        },
    );
    let view = View {
        center: [0.0, 0.0],
        scale: 40.0,
        yaw: 0.0,
        size: [480.0, 400.0],
    };
    let mut scene = Scene::default();
    let inset = viewer::playerv::scene::build(&first, None, &view, &mut scene);
    viewer::playerv::scene::add_robot(&second, None, &view, &mut scene, inset);
    let px = gpu.render(&scene, &view).expect("render");
    dump(&px, "playerv-two-robots");
    use viewer::playerv::scene::{BASE, MAP_FREE, MAP_OCCUPIED};
    // Both robots' bodies, each where its localiser puts it, on the first one's map.
    assert_eq!(rgb(pixel_at(&px, &view, [-3.1, -2.1])), rgb(BASE.0));
    assert_eq!(rgb(pixel_at(&px, &view, [2.9, 1.9])), rgb(BASE.0));
    assert_eq!(rgb(pixel_at(&px, &view, [1.25, -1.0])), rgb(MAP_OCCUPIED.0));
    assert_eq!(rgb(pixel_at(&px, &view, [0.0, -3.0])), rgb(MAP_FREE.0));
    // The second robot's hypothesis ellipse: 2 sigma = 0.4 m to its right.
    assert!(
        around(&px, &view, [3.4, 2.0], 1)
            .into_iter()
            .any(|c| c[2] > 150 && c[0] < 80 && c[1] < 80)
    );
}

/// A click on the canvas goes through the same function the mouse's does: a click at a map
/// pixel asks the planner for a goal at that pixel's world point, facing away from the robot;
/// a right drag gives the localiser a pose at its start facing along it.
#[test]
fn playernav_clicks_become_goals_and_poses_at_the_clicked_point() {
    use viewer::playerv::worker::Request;
    use viewer::playerv::{NavAction, SET_POSE_COV, nav_request};
    let st = nav_state();
    let view = View {
        center: [0.0, 0.0],
        scale: 40.0,
        yaw: 0.0,
        size: [480.0, 400.0],
    };
    let px = view.to_screen([2.0, 1.0]);
    let Some(Request::SetGoal(k, g)) = nav_request(&st, &view, NavAction::Goal, px, px) else {
        panic!("no goal");
    };
    assert_eq!(k, DeviceKey::parse("planner:0").unwrap());
    assert!(
        (g.x - 2.0).abs() < 1e-9 && (g.y - 1.0).abs() < 1e-9,
        "{g:?}"
    );
    assert!(
        (g.a - 3f64.atan2(5.0)).abs() < 1e-9,
        "heading from the robot: {g:?}"
    );
    // A drag to the north sets the heading to 90°.
    let up = view.to_screen([2.0, 2.0]);
    let Some(Request::SetGoal(_, g)) = nav_request(&st, &view, NavAction::Goal, px, up) else {
        panic!("no goal");
    };
    assert!((g.a - std::f64::consts::FRAC_PI_2).abs() < 1e-9);
    let Some(Request::SetPose(k, p, cov)) = nav_request(&st, &view, NavAction::Pose, px, up) else {
        panic!("no pose");
    };
    assert_eq!(k, DeviceKey::parse("localize:0").unwrap());
    assert!((p.x - 2.0).abs() < 1e-9 && (p.y - 1.0).abs() < 1e-9);
    assert!((p.a - std::f64::consts::FRAC_PI_2).abs() < 1e-9);
    assert_eq!(cov, SET_POSE_COV);
    // Outside the map frame there is nothing to click on.
    let mut bare = st.clone();
    bare.subscribed
        .retain(|k, _| k.interf == player_proto::InterfaceCode::POSITION2D);
    assert_eq!(nav_request(&bare, &view, NavAction::Goal, px, px), None);
}

/// The layer cache (grid and static models drawn once into a texture, then blitted) must not
/// change a single pixel: a cached frame, a reused cached frame and an uncached frame agree,
/// and a moved view redraws the cache rather than showing the old picture.
#[test]
fn layer_cache_reuses_static_layers_without_changing_the_picture() {
    let Some(mut gpu) = offscreen::for_tests() else {
        return;
    };
    let (world, gui) = common::known_world();
    let vis = rays_shown();
    let views = [
        world_view(),
        View {
            center: [0.7, -0.4],
            scale: 55.0,
            yaw: 0.6,
            size: [400.0, 320.0],
        },
    ];
    for (i, view) in views.iter().enumerate() {
        let mut scene = Scene::default();
        world_scene::build(&world, &gui, &vis, view, &[], &mut scene);
        gpu.renderer_mut().set_layer_cache(true);
        let hits0 = gpu.renderer_mut().layer_cache_hits();
        let first = gpu.render(&scene, view).expect("render");
        // a new view (or the first frame) redraws the cache: no hit
        assert_eq!(
            gpu.renderer_mut().layer_cache_hits(),
            hits0,
            "view {i}: miss"
        );
        let second = gpu.render(&scene, view).expect("render");
        assert_eq!(
            gpu.renderer_mut().layer_cache_hits(),
            hits0 + 1,
            "view {i}: the unchanged static layers are reused"
        );
        gpu.renderer_mut().set_layer_cache(false);
        let uncached = gpu.render(&scene, view).expect("render");
        assert_eq!(
            gpu.renderer_mut().layer_cache_hits(),
            hits0 + 1,
            "view {i}: no cache, no hit"
        );
        dump(&first, &format!("cache_{i}"));
        dump(&uncached, &format!("nocache_{i}"));
        assert!(first.rgba == second.rgba, "view {i}: reused cache differs");
        let differing = first
            .rgba
            .chunks(4)
            .zip(uncached.rgba.chunks(4))
            .filter(|(a, b)| a != b)
            .count();
        assert_eq!(
            differing, 0,
            "view {i}: cached and uncached pictures differ"
        );
        // the picture really holds the static walls (so the comparison is not of two blanks)
        assert_eq!(rgb(pixel_at(&first, view, [0.0, 3.1])), [0, 0, 0]);
    }
}

/// Scene colours are sRGB-encoded and a target that stores linear colour (an `Srgb` format, as
/// a window surface may be) gets them decoded, so the stored bytes are the same on both kinds of
/// target (opaque shapes; translucent blends are computed in the target's space).
#[test]
fn colours_come_out_the_same_on_srgb_targets() {
    let Some(mut plain) = offscreen::for_tests() else {
        return;
    };
    let Some(mut srgb) = offscreen::for_tests_with_format(wgpu::TextureFormat::Rgba8UnormSrgb)
    else {
        return;
    };
    let mut scene = Scene::new(Rgba8([200, 180, 160, 255]));
    scene.fill_rect(
        Layer::Static,
        [-1.0, -1.0],
        [0.0, 0.0],
        Rgba8([40, 120, 220, 255]),
    );
    scene.fan(
        Layer::Footprints,
        [0.5, 0.5],
        &[[1.5, 0.5], [1.2, 1.2], [0.5, 1.5]],
        Rgba8([90, 10, 60, 255]),
    );
    scene.line(
        Layer::Data,
        [-1.5, 1.0],
        [1.5, 1.0],
        3.0,
        Rgba8([10, 200, 70, 255]),
    );
    let view = View {
        center: [0.0, 0.0],
        scale: 60.0,
        yaw: 0.0,
        size: [240.0, 200.0],
    };
    let a = plain.render(&scene, &view).expect("render");
    let b = srgb.render(&scene, &view).expect("render");
    dump(&b, "srgb");
    // the shapes are there (not just the background) ...
    assert_eq!(pixel_at(&a, &view, [-0.5, -0.5]), [40, 120, 220, 255]);
    assert_eq!(pixel_at(&a, &view, [0.9, 0.8]), [90, 10, 60, 255]);
    // ... and shapes, line and background agree to within rounding
    for p in [[-0.5, -0.5], [0.9, 0.8], [0.0, 1.0], [1.8, -1.2]] {
        let (x, y) = (pixel_at(&a, &view, p), pixel_at(&b, &view, p));
        assert!(
            x.iter().zip(&y).all(|(u, v)| u.abs_diff(*v) <= 1),
            "at {p:?}: {x:?} on a plain target, {y:?} on an sRGB one"
        );
    }
}

/// Many overlapping translucent fans in `colours` colours (1 to 3), some running off the
/// picture, over an opaque floor, plus fans in a cached layer and a line over them.
fn crowded_fans(colours: usize) -> Scene {
    let mut scene = Scene::new(Rgba8([230, 230, 230, 255]));
    scene.fill_rect(
        Layer::Static,
        [-3.0, -3.0],
        [0.5, 0.5],
        Rgba8([60, 140, 60, 255]),
    );
    // fans in the cached layer are drawn as triangles whatever the renderer does elsewhere
    scene.fan(
        Layer::Static,
        [1.5, -1.5],
        &[[3.0, -1.5], [2.5, -0.5], [1.5, 0.0]],
        Rgba8([200, 0, 200, 90]),
    );
    let blue = Rgba8([0, 0, 255, 40]);
    let grey = Rgba8([90, 90, 90, 70]);
    let amber = Rgba8([250, 180, 0, 110]);
    for k in 0..60 {
        let c = [-2.6 + 0.09 * k as f64, -1.8 + 0.06 * ((k * 7) % 60) as f64];
        let heading = 0.37 * k as f64;
        // a laser: 91 rays over 180 degrees, blocked here and there
        let rim: Vec<[f64; 2]> = (0..91)
            .map(|i| {
                let a =
                    heading - std::f64::consts::FRAC_PI_2 + std::f64::consts::PI * i as f64 / 90.0;
                let r = if (i / 9 + k) % 4 == 0 { 0.6 } else { 2.2 };
                [c[0] + r * a.cos(), c[1] + r * a.sin()]
            })
            .collect();
        let laser = if colours == 3 && k % 5 == 0 {
            amber
        } else {
            blue
        };
        scene.fan(Layer::Footprints, c, &rim, laser);
        // a sonar cone, reversed (clockwise rim) every other time
        let mut cone: Vec<[f64; 2]> = (0..=6)
            .map(|i| {
                let a = heading + 0.2 * i as f64;
                [c[0] + 1.1 * a.cos(), c[1] + 1.1 * a.sin()]
            })
            .collect();
        if k % 2 == 1 {
            cone.reverse();
        }
        if colours > 1 {
            scene.fan(Layer::Footprints, c, &cone, grey);
        }
    }
    scene.line(
        Layer::Data,
        [-3.0, 0.0],
        [3.0, 0.0],
        2.0,
        Rgba8([200, 30, 30, 255]),
    );
    scene
}

/// On a software rasteriser the renderer counts how many fans cover each pixel on the CPU
/// instead of blending fan after fan; the picture must be the one the triangles give: equal
/// up to the rounding of each 8-bit blend (a few levels where dozens of fans overlap), on plain
/// and sRGB targets, with fans of one, two and three colours, clockwise rims and fans off the
/// picture.
#[test]
fn counted_fans_look_like_blended_triangle_fans() {
    let cases = [1, 2, 3].into_iter().flat_map(|colours| {
        [offscreen::FORMAT, wgpu::TextureFormat::Rgba8UnormSrgb].map(|f| (colours, f))
    });
    for (colours, format) in cases {
        let Some(mut off) = offscreen::for_tests_with_format(format) else {
            return;
        };
        let scene = crowded_fans(colours);
        let view = View {
            center: [0.0, 0.0],
            scale: 70.0,
            yaw: 0.3,
            size: [400.0, 300.0],
        };
        // dense enough that the renderer counts them
        let fill = viewer::render::fan_fill(scene.layer(Layer::Footprints), &view);
        assert!(
            fill >= viewer::render::COVERAGE_MIN_FILL,
            "{fill} views of fans"
        );
        off.renderer_mut().set_fan_coverage(false);
        let blended = off.render(&scene, &view).expect("render");
        off.renderer_mut().set_fan_coverage(true);
        let counted = off.render(&scene, &view).expect("render");
        assert!(off.renderer_mut().counted_fans(), "the fans were counted");
        dump(&blended, "fans-blended");
        dump(&counted, "fans-counted");
        let (mut worst, mut differing, mut tinted) = (0u8, 0usize, 0usize);
        for (a, b) in blended.rgba.chunks(4).zip(counted.rgba.chunks(4)) {
            let d = a
                .iter()
                .zip(b)
                .map(|(x, y)| x.abs_diff(*y))
                .max()
                .unwrap_or(0);
            worst = worst.max(d);
            differing += usize::from(d > 4);
            // pixels the fans tinted at all (the background and floor are grey and green)
            tinted += usize::from(a[2] > a[1].saturating_add(20));
        }
        let n = blended.rgba.len() / 4;
        assert!(
            tinted > n / 4,
            "{tinted} of {n} pixels show fans ({colours} colours, {format:?})"
        );
        // a pixel centre on a fan's edge may fall either side of it on the two paths (one
        // layer's tint, up to ~110 levels at alpha 110), which only a few pixels in this many
        // do; everywhere else the colours agree to the blends' rounding
        assert!(
            worst <= 112,
            "a pixel differs by {worst} ({colours} colours, {format:?})"
        );
        assert!(
            differing < n / 1000,
            "{differing} of {n} pixels differ by more than 4 ({colours} colours, {format:?})"
        );
    }
}
