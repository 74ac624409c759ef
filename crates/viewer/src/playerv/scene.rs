//! A playerv client state as a [`Scene`]: a 1 m grid, the base with its velocity,
//! ranger/laser/sonar scans as rays and footprints, fiducials, the gripper, the blobfinder image
//! with its blob boxes, the camera image, and the bull's-eye target of position control; and for
//! a navigation stack the map (under everything), the planner's path, waypoint and goal, and
//! the localiser's hypotheses with their covariance ellipses and its particles.
//!
//! Without a map-frame device the scene is the robot's frame (the robot at the origin facing
//! +x, as playerv draws it). With a map, planner or localize device it is the map's frame, and
//! everything the robot carries is drawn at the pose it is believed to be at
//! ([`PlayervState::robot_in_map`]).

use crate::scene::{ImagePrim, Layer, Rgba8, Scene};
use crate::view::View;

use super::state::{
    CommandMode, DeviceData, Hypothesis, MapGrid, PlannerView, PlayervState, Pose2,
};

/// Canvas background.
pub const BACKGROUND: Rgba8 = Rgba8::rgb(240, 240, 240);
/// Grid lines.
pub const GRID: Rgba8 = Rgba8::rgb(205, 205, 205);
/// The robot body.
pub const BASE: Rgba8 = Rgba8::rgb(200, 60, 60);
/// Ranger footprints (translucent).
pub const FOOTPRINT: Rgba8 = Rgba8([0, 110, 255, 60]);
/// Ranger rays.
pub const RAY: Rgba8 = Rgba8([0, 70, 200, 255]);
/// The bull's-eye.
pub const TARGET: Rgba8 = Rgba8::rgb(220, 0, 0);
/// Free map cells (the rest of the map is drawn over them).
pub const MAP_FREE: Rgba8 = Rgba8::rgb(255, 255, 255);
/// Unknown map cells.
pub const MAP_UNKNOWN: Rgba8 = Rgba8::rgb(160, 160, 160);
/// Occupied map cells.
pub const MAP_OCCUPIED: Rgba8 = Rgba8::rgb(0, 0, 0);
/// The planner's path and waypoints.
pub const PATH: Rgba8 = Rgba8::rgb(0, 170, 0);
/// The planner's goal.
pub const GOAL: Rgba8 = Rgba8::rgb(200, 0, 200);
/// Localisation hypotheses: ellipses and headings.
pub const HYPOTHESIS: Rgba8 = Rgba8::rgb(0, 0, 220);
/// Localisation particles.
pub const PARTICLE: Rgba8 = Rgba8::rgb(255, 120, 0);

/// How many standard deviations a hypothesis ellipse spans on each side of its mean.
pub const ELLIPSE_SIGMAS: f64 = 2.0;

fn at(p: Pose2, x: f64, y: f64) -> [f64; 2] {
    let (x, y) = p.frame().transform_xy(x, y);
    [x, y]
}

/// Pose `b` (given in `a`'s frame) in the frame `a` is given in.
pub fn compose(a: Pose2, b: Pose2) -> Pose2 {
    Pose2::of_frame(a.frame().compose(&b.frame()))
}

/// Pose `p` (in the frame `frame` is given in) in `frame`'s own frame: [`compose`] undone.
pub fn relative(frame: Pose2, p: Pose2) -> Pose2 {
    Pose2::of_frame(frame.frame().relative(&p.frame()))
}

/// The map's cells as rectangles in [`Layer::Static`], which the renderer keeps as a texture
/// while the map and the view stay the same.
fn draw_map(map: &MapGrid, scene: &mut Scene) {
    let s = map.scale;
    let o = map.origin;
    scene.fill_rect(Layer::Static, o, map.far_corner(), MAP_FREE);
    for &(j, i, n, v) in &map.runs {
        let min = [o[0] + f64::from(i) * s, o[1] + f64::from(j) * s];
        let max = [min[0] + f64::from(n) * s, min[1] + s];
        let c = if v > 0 { MAP_OCCUPIED } else { MAP_UNKNOWN };
        scene.fill_rect(Layer::Static, min, max, c);
    }
}

/// A key that changes when the map drawn in [`Layer::Static`] does.
fn map_key(map: &MapGrid) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    (map.width, map.height, map.runs.len()).hash(&mut h);
    map.scale.to_bits().hash(&mut h);
    map.origin[0].to_bits().hash(&mut h);
    map.origin[1].to_bits().hash(&mut h);
    std::ptr::from_ref(map).hash(&mut h);
    h.finish()
}

/// The planner's plan: the path through its waypoints, the waypoint being driven to, the goal
/// with its heading, and its state.
fn draw_planner(key: &str, p: &PlannerView, px: f64, scene: &mut Scene) {
    if p.waypoints.len() >= 2 {
        scene.polyline(Layer::Data, &p.waypoints, 2.0, PATH);
    }
    for w in &p.waypoints {
        scene.fill_circle(Layer::Data, *w, 3.0 * px, PATH);
    }
    if p.valid && !p.done && p.waypoint_idx >= 0 {
        scene.circle(
            Layer::Overlay,
            [p.waypoint.x, p.waypoint.y],
            7.0 * px,
            2.0,
            PATH,
        );
    }
    let g = [p.goal.x, p.goal.y];
    scene.circle(Layer::Overlay, g, 8.0 * px, 2.0, GOAL);
    scene.line(Layer::Overlay, g, at(p.goal, 20.0 * px, 0.0), 2.0, GOAL);
    let state = if p.done {
        "done"
    } else if p.valid {
        "driving"
    } else {
        "no path"
    };
    scene.label(at(p.goal, 0.0, -14.0 * px), format!("{key}: {state}"), GOAL);
}

/// One hypothesis: its ellipse of [`ELLIPSE_SIGMAS`] standard deviations (axis-aligned: Player's
/// localize covariance is diagonal), a heading line and an optional label; `px` is the size of
/// a pixel (m).
pub fn draw_hypothesis(scene: &mut Scene, h: &Hypothesis, label: Option<String>, px: f64) {
    let c = [h.mean.x, h.mean.y];
    let rx = ELLIPSE_SIGMAS * h.cov[0].max(0.0).sqrt();
    let ry = ELLIPSE_SIGMAS * h.cov[1].max(0.0).sqrt();
    let ring: Vec<[f64; 2]> = (0..48)
        .map(|k| {
            let t = std::f64::consts::TAU * f64::from(k) / 48.0;
            [c[0] + rx.max(px) * t.cos(), c[1] + ry.max(px) * t.sin()]
        })
        .collect();
    scene.outline(Layer::Overlay, &ring, 2.0, HYPOTHESIS);
    scene.line(
        Layer::Overlay,
        c,
        at(h.mean, (rx.max(ry) + 10.0 * px).max(0.3), 0.0),
        2.0,
        HYPOTHESIS,
    );
    if let Some(text) = label {
        scene.label(
            [c[0] + rx + 4.0 * px, c[1] + ry + 4.0 * px],
            text,
            HYPOTHESIS,
        );
    }
}

/// Hypotheses as ellipses of [`ELLIPSE_SIGMAS`] standard deviations (Player's localize
/// covariance is diagonal: x and y variances, so the ellipse is axis-aligned) with a heading
/// line, the heaviest labelled; particles as small squares over the sensor data.
fn draw_localize(
    key: &str,
    hypotheses: &[Hypothesis],
    particles: &[(Pose2, f64)],
    px: f64,
    scene: &mut Scene,
) {
    let half = 1.5 * px;
    for (p, _) in particles {
        scene.fill_rect(
            Layer::Overlay,
            [p.x - half, p.y - half],
            [p.x + half, p.y + half],
            PARTICLE,
        );
    }
    for (i, h) in hypotheses.iter().enumerate() {
        let label = (i == 0).then(|| {
            format!(
                "{key}: ({:.2}, {:.2}, {:.0}°) w {:.2}",
                h.mean.x,
                h.mean.y,
                h.mean.a.to_degrees(),
                h.weight
            )
        });
        draw_hypothesis(scene, h, label, px);
    }
}

/// Builds the playerv scene into `scene` (cleared first). `target` is the bull's-eye position
/// in the robot's frame when position control is on. Returns where the next image inset goes
/// (for [`add_robot`]).
pub fn build(
    state: &PlayervState,
    target: Option<(CommandMode, Pose2)>,
    view: &View,
    scene: &mut Scene,
) -> f64 {
    let map = state.subscribed.values().find_map(|s| match &s.data {
        DeviceData::Map(m) => Some(m.clone()),
        _ => None,
    });
    let map_static = map.as_deref().map(map_key);
    scene.clear_keeping_static(map_static.is_some() && scene.static_key == map_static);
    if let Some(m) = &map {
        if scene.static_key != map_static {
            draw_map(m, scene);
            scene.static_key = map_static;
        }
    }
    scene.background = BACKGROUND;
    // grid over the visible area, 1 m (10 m when zoomed far out)
    let (min, max) = view.visible_world();
    let mut step = 1.0;
    while step * view.scale < 6.0 {
        step *= 10.0;
    }
    let mut x = (min[0] / step).ceil() * step;
    while x <= max[0] {
        let c = if x == 0.0 { GRID.darker(0.8) } else { GRID };
        scene.line(Layer::Grid, [x, min[1]], [x, max[1]], 1.0, c);
        x += step;
    }
    let mut y = (min[1] / step).ceil() * step;
    while y <= max[1] {
        let c = if y == 0.0 { GRID.darker(0.8) } else { GRID };
        scene.line(Layer::Grid, [min[0], y], [max[0], y], 1.0, c);
        y += step;
    }
    draw_devices(state, target, view, scene, 10.0)
}

/// Adds the devices of another server (another robot on the same map, as playernav takes
/// several `host:port`s) to a scene [`build`] made; its map, if it has one, is not drawn again.
/// `inset_y` is where its image insets start (below those already drawn); the next free place
/// is returned.
pub fn add_robot(
    state: &PlayervState,
    target: Option<(CommandMode, Pose2)>,
    view: &View,
    scene: &mut Scene,
    inset_y: f64,
) -> f64 {
    draw_devices(state, target, view, scene, inset_y)
}

/// Every subscribed device of `state` but its map, in the robot's frame placed at its believed
/// pose; returns where the next image inset would go.
fn draw_devices(
    state: &PlayervState,
    target: Option<(CommandMode, Pose2)>,
    view: &View,
    scene: &mut Scene,
    mut inset_y: f64,
) -> f64 {
    let px = view.pixel();
    // Where the robot's own frame sits in the scene: the origin, or its pose on the map.
    let frame = state.robot_in_map().unwrap_or_default();
    let tf = |x: f64, y: f64| at(frame, x, y);
    for (key, sub) in &state.subscribed {
        match &sub.data {
            DeviceData::Position2d {
                pose,
                velocity,
                stall,
                size,
            } => {
                let (hx, hy) = (size[0] / 2.0, size[1] / 2.0);
                let body = [tf(-hx, -hy), tf(hx, -hy), tf(hx, hy), tf(-hx, hy)];
                let color = if *stall { BASE.darker(0.6) } else { BASE };
                scene.fill(Layer::Bodies, &body, color);
                scene.stroke_outline(Layer::Bodies, &body, px, Rgba8::BLACK);
                scene.stroke(
                    Layer::Bodies,
                    tf(0.0, 0.0),
                    tf(hx, 0.0),
                    2.0 * px,
                    Rgba8::BLACK,
                );
                // velocity: where the base would be in one second
                let v = [velocity.x, velocity.y];
                if v[0] != 0.0 || v[1] != 0.0 {
                    scene.line(
                        Layer::Overlay,
                        tf(0.0, 0.0),
                        tf(v[0], v[1]),
                        2.0,
                        Rgba8::rgb(0, 150, 0),
                    );
                }
                scene.label(
                    tf(-hx, -hy - 14.0 * px),
                    format!(
                        "{key}: ({:.2}, {:.2}, {:.0}°) v ({:.2}, {:.2}, {:.0}°/s){}",
                        pose.x,
                        pose.y,
                        pose.a.to_degrees(),
                        velocity.x,
                        velocity.y,
                        velocity.a.to_degrees(),
                        if *stall { " STALL" } else { "" }
                    ),
                    Rgba8::BLACK,
                );
            }
            DeviceData::Ranges { scans } => {
                for s in scans {
                    let origin = compose(frame, s.origin);
                    let o = [origin.x, origin.y];
                    let n = s.ranges.len().min(s.bearings.len());
                    if s.cone > 0.0 && n == 1 {
                        let r = s.ranges[0];
                        let rim: Vec<[f64; 2]> = (0..=8)
                            .map(|i| {
                                let a = origin.a + s.bearings[0] - s.cone / 2.0
                                    + s.cone * i as f64 / 8.0;
                                [o[0] + r * a.cos(), o[1] + r * a.sin()]
                            })
                            .collect();
                        scene.fan(Layer::Footprints, o, &rim, FOOTPRINT);
                    }
                    let ends: Vec<[f64; 2]> = (0..n)
                        .map(|i| {
                            let a = origin.a + s.bearings[i];
                            let r = s.ranges[i];
                            [o[0] + r * a.cos(), o[1] + r * a.sin()]
                        })
                        .collect();
                    if n > 1 {
                        scene.fan(Layer::Footprints, o, &ends, FOOTPRINT);
                    }
                    for e in &ends {
                        scene.line(Layer::Data, o, *e, 1.0, RAY);
                    }
                }
            }
            DeviceData::Fiducials { origin, items } => {
                let origin = &compose(frame, *origin);
                let c = Rgba8::rgb(0, 150, 0);
                for (id, p) in items {
                    let t = at(*origin, p.x, p.y);
                    scene.line(Layer::Data, [origin.x, origin.y], t, 1.0, c);
                    let d = 0.1;
                    let q = Pose2 {
                        x: t[0],
                        y: t[1],
                        a: origin.a + p.a,
                    };
                    let r = [at(q, -d, -d), at(q, d, -d), at(q, d, d), at(q, -d, d)];
                    scene.outline(Layer::Data, &r, 2.0, c);
                    scene.label(t, id.to_string(), c);
                }
            }
            DeviceData::Gripper {
                state,
                beams,
                pose,
                size,
                num_beams,
            } => {
                let pose = &compose(frame, *pose);
                // paddles at the sides of the gripper box, closer when closed
                let closed = *state == player_proto::constants::PLAYER_GRIPPER_STATE_CLOSED;
                let (hx, hy) = (size[0] / 2.0, size[1] / 2.0);
                let gap = if closed { hy * 0.2 } else { hy * 0.8 };
                let c = Rgba8::rgb(60, 60, 60);
                for side in [-1.0, 1.0] {
                    let y0 = side * gap;
                    let y1 = side * (gap + hy * 0.2);
                    let paddle = [
                        at(*pose, -hx, y0),
                        at(*pose, hx, y0),
                        at(*pose, hx, y1),
                        at(*pose, -hx, y1),
                    ];
                    scene.fill(Layer::Data, &paddle, c);
                }
                for b in 0..(*num_beams).min(32) {
                    let x = -hx + size[0] * (b as f64 + 1.0) / (*num_beams as f64 + 1.0);
                    let broken = beams & (1 << b) != 0;
                    let bc = if broken {
                        Rgba8::rgb(255, 0, 0)
                    } else {
                        Rgba8::rgb(0, 200, 0)
                    };
                    scene.line(Layer::Data, at(*pose, x, -gap), at(*pose, x, gap), 2.0, bc);
                }
            }
            DeviceData::Blobs { size, blobs } => {
                let (w, h) = (size[0].clamp(1, 640) as f64, size[1].clamp(1, 480) as f64);
                let k = (160.0 / w).min(1.0);
                let tl = [view.size[0] - 10.0 - w * k, inset_y];
                let boxes = blobs.iter().map(|(color, [l, t, r, b])| {
                    let edges = [*l as f64, *t as f64, *r as f64, *b as f64];
                    (Rgba8::from_packed_rgb(*color), edges)
                });
                let background = Rgba8::rgb(30, 30, 30);
                let bottom_left =
                    scene.blob_inset(Layer::Overlay, view, tl, k, [w, h], background, boxes);
                scene.label(bottom_left, key.to_string(), Rgba8::BLACK);
                inset_y += h * k + 24.0;
            }
            DeviceData::Camera {
                width,
                height,
                rgba,
            } => {
                let (w, h) = (*width as f64, *height as f64);
                // every camera inset is 240 pixels wide
                let k = 240.0 / w;
                let tl = [view.size[0] - 10.0 - w * k, inset_y];
                let corner = |x: f64, y: f64| {
                    let p = view.to_world([tl[0] + x * k, tl[1] + y * k]);
                    [p[0] as f32, p[1] as f32]
                };
                scene.image(
                    Layer::Overlay,
                    ImagePrim {
                        corners: [
                            corner(0.0, 0.0),
                            corner(w, 0.0),
                            corner(w, h),
                            corner(0.0, h),
                        ],
                        width: *width,
                        height: *height,
                        rgba: rgba.clone(),
                    },
                );
                let bl = view.to_world([tl[0], tl[1] + h * k]);
                scene.label(bl, key.to_string(), Rgba8::BLACK);
                inset_y += h * k + 24.0;
            }
            DeviceData::Planner(p) => draw_planner(&key.to_string(), p, px, scene),
            DeviceData::Localize {
                hypotheses,
                particles,
            } => draw_localize(&key.to_string(), hypotheses, particles, px, scene),
            DeviceData::Map(_) | DeviceData::Log { .. } | DeviceData::Other => {}
        }
    }
    if let Some((mode, t)) = target {
        if mode != CommandMode::Off {
            let c = tf(t.x, t.y);
            for (i, r) in [6.0, 12.0, 18.0].iter().enumerate() {
                scene.circle(
                    Layer::Overlay,
                    c,
                    r * px,
                    if i == 0 { 3.0 } else { 1.5 },
                    TARGET,
                );
            }
            scene.line(Layer::Overlay, tf(0.0, 0.0), c, 1.0, TARGET.with_alpha(120));
        }
    }
    inset_y
}
