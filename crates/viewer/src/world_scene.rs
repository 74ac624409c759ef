//! A simulated world as a [`Scene`]: floor and grid, every model's blocks in their colours with
//! outlines, noses and model grids (`gui_nose`, `gui_grid`, `gui_outline`), and the sensor
//! visualisations of Stage's View menu (ranger footprints, rays, strikes, fields of view;
//! fiducial links; blobfinder images; gripper beams; camera frustums; blinkenlights; speech
//! bubbles). Pure: the same world, settings and view give the same primitives.

use stage_sim::{KindDesc, ModelId, ModelType, Pose, World, WorldDesc};
use worldfile::{WindowSpec, WorldSpec};

use crate::lod;
use crate::scene::{Layer, Rgba8, Scene};
use crate::view::View;

/// Why the per-model world calls here cannot refuse: every id the scene draws, hashes or picks
/// comes from the world it is given (its `models()`, or tree links of those).
const SAME_WORLD: &str = "the scene's model ids come from the world it draws";

/// Stage's canvas clear colour (outside the floor).
pub const BACKGROUND: Rgba8 = Rgba8::rgb(179, 179, 204);
/// Floor colour inside the world's extent.
pub const FLOOR: Rgba8 = Rgba8::WHITE;
/// Grid line colour.
pub const GRID: Rgba8 = Rgba8::rgb(216, 216, 216);
/// Selection highlight.
pub const SELECTED: Rgba8 = Rgba8::rgb(255, 0, 255);

/// The GUI-only properties of one model (the simulator does not keep them).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ModelGui {
    /// `gui_nose`: draw a heading line.
    pub nose: bool,
    /// `gui_grid`: draw a 1 m grid over the model.
    pub grid: bool,
    /// `gui_outline`: draw the bounding box.
    pub outline: bool,
    /// `gui_move`: the user may drag and turn it.
    pub movable: bool,
    /// A gripper's `paddle_size` (for its break beams).
    pub paddle_size: Option<[f64; 3]>,
    /// A camera's horizontal field of view, pan (rad) and far clip (m), for its frustum.
    pub camera: Option<[f64; 3]>,
}

/// GUI properties of every model, indexed like the world's models.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WorldGui {
    /// Per model, in creation order (the world's [`ModelId`] index).
    pub models: Vec<ModelGui>,
}

impl WorldGui {
    /// From the resolved worldfile the world was built from (same model order).
    pub fn from_spec(spec: &WorldSpec) -> WorldGui {
        WorldGui {
            models: spec
                .models
                .iter()
                .map(|m| ModelGui {
                    nose: m.common.gui_nose,
                    grid: m.common.gui_grid,
                    outline: m.common.gui_outline,
                    movable: m.gui_move,
                    paddle_size: match &m.spec {
                        worldfile::models::TypeSpec::Gripper(g) => Some(g.paddle_size),
                        _ => None,
                    },
                    // the worldfile keeps Stage's raw camera degrees
                    camera: match &m.spec {
                        worldfile::models::TypeSpec::Camera(c) => {
                            Some([c.fov[0].to_radians(), c.pantilt[0].to_radians(), c.range[1]])
                        }
                        _ => None,
                    },
                })
                .collect(),
        }
    }

    /// For a world built from a description: top-level models movable (Stage's default),
    /// noses on position models.
    pub fn from_desc(desc: &WorldDesc) -> WorldGui {
        WorldGui {
            models: desc
                .models
                .iter()
                .map(|m| ModelGui {
                    nose: matches!(m.kind, KindDesc::Position(_)),
                    grid: false,
                    outline: false,
                    movable: m.parent.is_none(),
                    paddle_size: match &m.kind {
                        KindDesc::Gripper(g) => Some(g.paddle_size),
                        _ => None,
                    },
                    camera: match &m.kind {
                        KindDesc::Camera(c) => Some([c.fov[0], c.pantilt[0], c.range[1]]),
                        _ => None,
                    },
                })
                .collect(),
        }
    }

    /// The model's properties (defaults for an unknown model).
    pub fn get(&self, m: ModelId) -> ModelGui {
        self.models.get(m.index()).copied().unwrap_or_default()
    }
}

/// The View menu: what the world window draws. Defaults and worldfile names are Stage's
/// (`window` entity, stage-worldfile.md §11).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct VisOptions {
    /// `show_data`: draw sensor data at all.
    pub data: bool,
    /// `show_blocks`: draw model bodies.
    pub blocks: bool,
    /// `show_grid`: the floor grid.
    pub grid: bool,
    /// `show_boundingboxes`: each body's bounding box.
    pub bounding_boxes: bool,
    /// `show_clock`: the clock in the status line.
    pub clock: bool,
    /// `show_ranger_ranges`: the filled area each ranger scan sees (its footprint).
    pub ranger_ranges: bool,
    /// `show_ranger_beams`: one line per ray.
    pub ranger_beams: bool,
    /// `show_ranger_strikes`: a dot where a ray hit something.
    pub ranger_strikes: bool,
    /// `show_ranger_fov`: the field of view at maximum range.
    pub ranger_fov: bool,
    /// `show_ranger_transducers`: the transducers' boxes.
    pub ranger_transducers: bool,
    /// `show_fiducial`: links from finders to the fiducials they see.
    pub fiducial: bool,
    /// `show_fiducial_fov`: fiducial finders' fields of view.
    pub fiducial_fov: bool,
    /// `blobfinder_vis`: blobfinder images with their blobs.
    pub blobfinder: bool,
    /// `show_gripper_data`: gripper break beams.
    pub gripper: bool,
    /// `show_camera`: camera frustums.
    pub camera: bool,
    /// `show_blinken`: blinkenlights.
    pub blinken: bool,
    /// `show_position_coords`: odometry pose text at each position model.
    pub position_coords: bool,
    /// Speech bubbles (`say`).
    pub speech: bool,
}

impl Default for VisOptions {
    fn default() -> Self {
        VisOptions::from_window(&WindowSpec::default())
    }
}

impl VisOptions {
    /// The toggles a worldfile `window` sets.
    pub fn from_window(w: &WindowSpec) -> VisOptions {
        VisOptions {
            data: w.show_data,
            blocks: w.show_blocks,
            grid: w.show_grid,
            bounding_boxes: w.show_boundingboxes,
            clock: w.show_clock,
            ranger_ranges: w.ranger_vis && w.show_ranger_ranges,
            ranger_beams: w.ranger_vis && w.show_ranger_beams,
            ranger_strikes: w.ranger_vis && w.show_ranger_strikes,
            ranger_fov: w.ranger_vis && w.show_ranger_fov,
            ranger_transducers: w.ranger_vis && w.show_ranger_transducers,
            fiducial: w.show_fiducial,
            fiducial_fov: w.show_fiducial_fov,
            blobfinder: w.blobfinder_vis,
            gripper: w.show_gripper_data,
            camera: w.show_camera,
            blinken: w.show_blinken,
            position_coords: w.show_position_coords,
            speech: true,
        }
    }

    fn ranger_any(&self) -> bool {
        self.ranger_ranges || self.ranger_beams || self.ranger_strikes
    }

    /// Whether model type `t`'s data is drawn, so it is worth subscribing to: the simulator
    /// only updates subscribed sensors (spec §5.4), so the window subscribes the sensors it
    /// shows.
    pub fn shows_data_of(&self, t: ModelType) -> bool {
        self.data
            && match t {
                ModelType::Ranger => self.ranger_any(),
                ModelType::Fiducial => self.fiducial,
                ModelType::Blobfinder => self.blobfinder,
                ModelType::Gripper => self.gripper,
                _ => false,
            }
    }
}

/// The sensors whose data the options show (each deserves one subscription from the window).
pub fn visualised_sensors(world: &World, vis: &VisOptions) -> Vec<ModelId> {
    world
        .models()
        .filter(|&m| vis.shows_data_of(world.model_type(m).expect(SAME_WORLD)))
        .collect()
}

/// The bounds of every body (the world's extent), or a 16 m square around the origin.
pub fn world_extent(world: &World) -> ([f64; 2], [f64; 2]) {
    let mut min = [f64::INFINITY; 2];
    let mut max = [f64::NEG_INFINITY; 2];
    for m in world.models() {
        let b = world.body(m).expect(SAME_WORLD);
        if b.is_empty() {
            continue;
        }
        for k in 0..2 {
            min[k] = min[k].min(b.aabb.min[k]);
            max[k] = max[k].max(b.aabb.max[k]);
        }
    }
    if min[0] > max[0] {
        ([-8.0, -8.0], [8.0, 8.0])
    } else {
        (min, max)
    }
}

fn transform(p: &Pose, q: [f64; 2]) -> [f64; 2] {
    let (x, y) = p.transform_xy(q[0], q[1]);
    [x, y]
}

/// The model's body frame (pose composed with its origin offset).
fn body_frame(world: &World, m: ModelId) -> Pose {
    world
        .global_pose(m)
        .expect(SAME_WORLD)
        .compose(&world.node(m).expect(SAME_WORLD).origin)
}

/// The rectangle `size` covers in the model's body frame, in world coordinates.
fn size_rect(world: &World, m: ModelId) -> [[f64; 2]; 4] {
    let f = body_frame(world, m);
    let [sx, sy, _] = world.node(m).expect(SAME_WORLD).size;
    let (hx, hy) = (sx / 2.0, sy / 2.0);
    [[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]].map(|q| transform(&f, q))
}

/// Builds the scene of `world` as seen through `view` into `scene` (cleared first).
pub fn build(
    world: &World,
    gui: &WorldGui,
    vis: &VisOptions,
    view: &View,
    selected: &[ModelId],
    scene: &mut Scene,
) {
    // the static models are drawn again only when they or the view changed
    let static_key = vis.blocks.then(|| static_key(world, gui, view));
    let keep_static = static_key.is_some() && scene.static_key == static_key;
    scene.clear_keeping_static(keep_static);
    scene.background = BACKGROUND;
    let px = view.pixel();
    let (emin, emax) = world_extent(world);
    scene.fill_rect(Layer::Grid, emin, emax, FLOOR);
    if vis.grid {
        grid(scene, view, emin, emax);
    }
    if vis.blocks {
        bodies(world, gui, px, view.visible_world(), !keep_static, scene);
        scene.static_key = static_key;
    }
    if vis.bounding_boxes {
        for m in world.models() {
            let b = world.body(m).expect(SAME_WORLD);
            if !b.is_empty() {
                let (a, c) = (b.aabb.min, b.aabb.max);
                let pts = [a, [c[0], a[1]], c, [a[0], c[1]]];
                scene.outline(Layer::Overlay, &pts, 1.0, Rgba8::rgb(0, 200, 0));
            }
        }
    }
    if vis.data {
        let visible = view.visible_world();
        for m in world.models() {
            data(world, gui, vis, view, visible, m, scene);
        }
    }
    if vis.speech {
        for m in world.models() {
            let text = world.said(m).expect(SAME_WORLD);
            if !text.is_empty() {
                let g = world.global_pose(m).expect(SAME_WORLD);
                let [sx, sy, _] = world.node(m).expect(SAME_WORLD).size;
                let off = 0.5 * sx.max(sy) + 8.0 * px;
                scene.labels.push(crate::scene::Label {
                    pos: [(g.x + off) as f32, (g.y + off) as f32],
                    text: text.to_string(),
                    color: Rgba8::BLACK,
                    bubble: Some(Rgba8::rgb(255, 255, 224)),
                });
            }
        }
    }
    for &m in selected {
        // a selection kept from another world may name no model of this one: not drawn
        if world.node(m).is_ok() {
            let r = size_rect(world, m);
            scene.outline(Layer::Overlay, &r, 2.0, SELECTED);
        }
    }
}

/// Floor grid: 1 m lines (10 m when 1 m would be under 6 pixels) over the visible part of the
/// world's extent.
fn grid(scene: &mut Scene, view: &View, emin: [f64; 2], emax: [f64; 2]) {
    let (vmin, vmax) = view.visible_world();
    let min = [emin[0].max(vmin[0]), emin[1].max(vmin[1])];
    let max = [emax[0].min(vmax[0]), emax[1].min(vmax[1])];
    if min[0] >= max[0] || min[1] >= max[1] {
        return;
    }
    let mut step = 1.0;
    while step * view.scale < 6.0 {
        step *= 10.0;
    }
    let lines = |lo: f64, hi: f64| {
        let first = (lo / step).ceil() as i64;
        let last = (hi / step).floor() as i64;
        (first..=last).map(move |k| k as f64 * step)
    };
    for x in lines(min[0], max[0]) {
        scene.line(Layer::Grid, [x, min[1]], [x, max[1]], 1.0, GRID);
    }
    for y in lines(min[1], max[1]) {
        scene.line(Layer::Grid, [min[0], y], [max[0], y], 1.0, GRID);
    }
}

/// Model bodies, lowest first (Stage draws in 3D: what is higher covers what is lower), each
/// block filled in its colour with a darker outline, plus noses, model grids and outlines.
/// Bodies narrower than this many pixels are drawn as one dot (their box, grown by the
/// outline's half width, in the outline colour): at that size the ten triangles of fill,
/// outline and nose cover the same one or two pixels, and a software rasteriser pays per
/// triangle (1,000 swarmbots: 10,000 triangles → 2,000).
const BODY_DOT_PX: f64 = 2.0;

fn bodies(
    world: &World,
    gui: &WorldGui,
    px: f64,
    visible: ([f64; 2], [f64; 2]),
    draw_static: bool,
    scene: &mut Scene,
) {
    let mut order: Vec<(f64, ModelId)> = world
        .models()
        .filter_map(|m| {
            let b = world.body(m).expect(SAME_WORLD);
            let top = b
                .blocks
                .iter()
                .map(|k| k.zmax)
                .fold(f64::NEG_INFINITY, f64::max);
            (!b.is_empty()).then_some((top, m))
        })
        .collect();
    order.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (vmin, vmax) = visible;
    for (_, m) in order {
        let body = world.body(m).expect(SAME_WORLD);
        let g = gui.get(m);
        let (bmin, bmax) = (body.aabb.min, body.aabb.max);
        // off screen (with a margin for outlines and noses): nothing to draw
        let margin = 4.0 * px;
        if bmax[0] < vmin[0] - margin
            || bmax[1] < vmin[1] - margin
            || bmin[0] > vmax[0] + margin
            || bmin[1] > vmax[1] + margin
        {
            continue;
        }
        // what never moves is drawn under everything that does (the renderer caches it); only
        // a moving model passing under a taller static one, which collisions rule out for
        // everything solid, would be stacked differently from Stage
        let layer = if world.is_static(m).expect(SAME_WORLD) {
            if !draw_static {
                continue;
            }
            Layer::Static
        } else {
            Layer::Bodies
        };
        if (bmax[0] - bmin[0]).max(bmax[1] - bmin[1]) < BODY_DOT_PX * px && !g.grid && !g.outline {
            let h = 0.5 * px;
            let color = Rgba8::from_color(&world.block_color(m, 0).expect(SAME_WORLD)).darker(0.5);
            scene.fill_rect(
                layer,
                [bmin[0] - h, bmin[1] - h],
                [bmax[0] + h, bmax[1] + h],
                color,
            );
            continue;
        }
        for k in 0..body.blocks.len() {
            let pts = body.block_pts(k);
            let color = Rgba8::from_color(&world.block_color(m, k).expect(SAME_WORLD));
            scene.outlined_fill(layer, pts, color, px, color.darker(0.5));
        }
        if g.grid {
            model_grid(world, m, layer, px, scene);
        }
        if g.outline {
            let r = size_rect(world, m);
            scene.stroke_outline(layer, &r, px, Rgba8::BLACK);
        }
        if g.nose {
            let f = body_frame(world, m);
            let sx = world.node(m).expect(SAME_WORLD).size[0];
            let a = transform(&f, [0.0, 0.0]);
            let b = transform(&f, [sx / 2.0, 0.0]);
            let c = Rgba8::from_color(&world.color(m).expect(SAME_WORLD)).darker(0.4);
            scene.stroke(layer, a, b, 2.0 * px, c);
        }
    }
}

/// A fingerprint of everything the static models' drawing depends on: the view, and per
/// static model its id, gui flags, colours, heights and outline. Cheap next to drawing them.
fn static_key(world: &World, gui: &WorldGui, view: &View) -> u64 {
    let mut h = WordHash::default();
    for v in [
        view.center[0],
        view.center[1],
        view.scale,
        view.yaw,
        view.size[0],
        view.size[1],
    ] {
        h.f(v);
    }
    for m in world.models() {
        if !world.is_static(m).expect(SAME_WORLD) {
            continue;
        }
        let g = gui.get(m);
        h.u((m.index() as u64) << 3
            | u64::from(g.nose) << 2
            | u64::from(g.grid) << 1
            | u64::from(g.outline));
        let body = world.body(m).expect(SAME_WORLD);
        h.u(body.blocks.len() as u64);
        for (k, blk) in body.blocks.iter().enumerate() {
            let c = world.block_color(m, k).expect(SAME_WORLD);
            h.f(c.r);
            h.f(c.g);
            h.f(c.b);
            h.f(c.a);
            h.f(blk.zmax);
            h.u(body.block_pts(k).len() as u64);
        }
        for p in &body.pts {
            h.f(p[0]);
            h.f(p[1]);
        }
        let f = body_frame(world, m);
        h.f(f.x);
        h.f(f.y);
        h.f(f.a);
        let n = world.node(m).expect(SAME_WORLD).size;
        h.f(n[0]);
        h.f(n[1]);
        let color = world.color(m).expect(SAME_WORLD);
        h.f(color.r);
        h.f(color.g);
        h.f(color.b);
    }
    h.0
}

/// A fast multiply–rotate word hash (a cache key, not a defence against crafted input).
#[derive(Default)]
struct WordHash(u64);

impl WordHash {
    fn u(&mut self, v: u64) {
        self.0 = (self.0.rotate_left(5) ^ v).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }

    fn f(&mut self, v: f64) {
        self.u(v.to_bits());
    }
}

/// `gui_grid`: 1 m lines across the model's size rectangle, in its frame.
fn model_grid(world: &World, m: ModelId, layer: Layer, px: f64, scene: &mut Scene) {
    let f = body_frame(world, m);
    let [sx, sy, _] = world.node(m).expect(SAME_WORLD).size;
    let (hx, hy) = (sx / 2.0, sy / 2.0);
    if sx / 1.0 > 10_000.0 || sy / 1.0 > 10_000.0 {
        return;
    }
    let c = Rgba8::rgb(160, 160, 160);
    let mut x = (-hx).ceil();
    while x <= hx {
        scene.stroke(
            layer,
            transform(&f, [x, -hy]),
            transform(&f, [x, hy]),
            px,
            c,
        );
        x += 1.0;
    }
    let mut y = (-hy).ceil();
    while y <= hy {
        scene.stroke(
            layer,
            transform(&f, [-hx, y]),
            transform(&f, [hx, y]),
            px,
            c,
        );
        y += 1.0;
    }
}

/// The visualisation of one model's data.
fn data(
    world: &World,
    gui: &WorldGui,
    vis: &VisOptions,
    view: &View,
    visible: ([f64; 2], [f64; 2]),
    m: ModelId,
    scene: &mut Scene,
) {
    let px = view.pixel();
    let frame = body_frame(world, m);
    // The type-specific getters double as type tests here: an error means "not that type".
    if let Ok(r) = world.ranger_scans(m) {
        ranger(&frame, r, vis, px, visible, scene);
    }
    if let Ok(f) = world.fiducials(m) {
        if vis.fiducial {
            let g = world.global_pose(m).expect(SAME_WORLD);
            let c = Rgba8::rgb(0, 160, 0);
            for fd in &f.fiducials {
                let t = [fd.pose.x, fd.pose.y];
                scene.line(Layer::Data, [g.x, g.y], t, 1.0, c);
                let (hx, hy) = (fd.geom[0] / 2.0, fd.geom[1] / 2.0);
                let r =
                    [[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]].map(|q| transform(&fd.pose, q));
                scene.outline(Layer::Data, &r, 1.0, c);
                scene.label(t, fd.id.to_string(), c);
            }
        }
        if vis.fiducial_fov {
            if let Ok(cfg) = world.fiducial_config(m) {
                wedge(
                    scene,
                    &frame,
                    cfg.fov,
                    cfg.range_max,
                    Rgba8::rgb(0, 160, 0).with_alpha(128),
                );
            }
        }
    }
    if vis.blobfinder {
        if let (Ok(d), Ok(cfg)) = (world.blobfinder_blobs(m), world.blobfinder_config(m)) {
            blob_image(world, m, d, cfg.image, view, scene);
            let pan = frame.compose(&Pose::new(0.0, 0.0, 0.0, cfg.pan));
            wedge(
                scene,
                &pan,
                cfg.fov,
                cfg.range,
                Rgba8::rgb(200, 200, 0).with_alpha(100),
            );
        }
    }
    if vis.gripper {
        if let (Ok(d), Some(ps)) = (world.gripper_state(m), gui.get(m).paddle_size) {
            let [sx, sy, _] = world.node(m).expect(SAME_WORLD).size;
            let pos = d.paddle_pos;
            let gap_y = (1.0 - pos) * (sy / 2.0 - sy * ps[1]);
            for (i, inset) in [0.75 * ps[0], 0.25 * ps[0]].into_iter().enumerate() {
                let x = sx * (1.0 - inset) - sx / 2.0;
                let a = transform(&frame, [x, gap_y]);
                let b = transform(&frame, [x, -gap_y]);
                let c = if d.beams[i].is_some() {
                    Rgba8::rgb(255, 0, 0)
                } else {
                    Rgba8::rgb(0, 200, 0)
                };
                scene.line(Layer::Data, a, b, 2.0, c);
            }
        }
    }
    if vis.camera {
        if let Some([fov, pan, far]) = gui.get(m).camera {
            // the horizontal extent of the camera's view volume (Stage draws the frustum)
            let f = frame.compose(&Pose::new(0.0, 0.0, 0.0, pan));
            wedge(scene, &f, fov, far, Rgba8::rgb(0, 0, 0).with_alpha(90));
        }
    }
    if vis.blinken {
        if let (Ok(on), ModelType::Blinkenlight) =
            (world.light_on(m), world.model_type(m).expect(SAME_WORLD))
        {
            let g = world.global_pose(m).expect(SAME_WORLD);
            let c = if on {
                Rgba8::from_color(&world.color(m).expect(SAME_WORLD))
            } else {
                Rgba8::from_color(&world.color(m).expect(SAME_WORLD)).darker(0.3)
            };
            let r = 0.5
                * world.node(m).expect(SAME_WORLD).size[0]
                    .max(world.node(m).expect(SAME_WORLD).size[1])
                    .max(4.0 * px);
            scene.fill_circle(Layer::Data, [g.x, g.y], r, c);
        }
    }
    if vis.position_coords {
        if let Ok(p) = world.position_state(m) {
            let g = world.global_pose(m).expect(SAME_WORLD);
            scene.label(
                [g.x, g.y],
                format!(
                    "({:.2}, {:.2}, {:.0}°)",
                    p.pose.x,
                    p.pose.y,
                    p.pose.a.to_degrees()
                ),
                Rgba8::rgb(0, 0, 120),
            );
        }
    }
}

/// Ranger scans: footprint fans, rays, strikes, fields of view and transducers.
///
/// Level of detail keeps 1,000 lasers cheap without changing the picture by more than half a
/// pixel: sensors whose reach is off screen are skipped, footprint rims are thinned to the
/// points that matter at that tolerance ([`lod::simplify_rim`]), sonar cones get as many chords
/// as their arc needs, and a ray or strike landing within a pixel of the previous one drawn is
/// left out (rays share their origin, so the two lines are within a pixel all along).
fn ranger(
    frame: &Pose,
    r: &stage_sim::RangerData,
    vis: &VisOptions,
    px: f64,
    (vmin, vmax): ([f64; 2], [f64; 2]),
    scene: &mut Scene,
) {
    let tol = 0.5 * px;
    // reused from sensor to sensor
    let (mut keep, mut dirs, mut ends, mut rim) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (k, sensor) in r.sensors.iter().enumerate() {
        let origin = frame.compose(&sensor.pose);
        let o = [origin.x, origin.y];
        let reach = sensor.range[1].max(sensor.size[0].hypot(sensor.size[1]));
        if !lod::disc_touches_box(o, reach, vmin, vmax) {
            continue;
        }
        let color = Rgba8::from_color(&sensor.color);
        if vis.ranger_transducers {
            let (hx, hy) = (sensor.size[0] / 2.0, sensor.size[1] / 2.0);
            let q = [[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]].map(|q| transform(&origin, q));
            scene.outline(Layer::Data, &q, 1.0, color);
        }
        if vis.ranger_fov {
            wedge(
                scene,
                &origin,
                sensor.fov,
                sensor.range[1],
                color.with_alpha(90),
            );
        }
        let Some(scan) = r.scan(k) else { continue };
        let n = scan.ranges.len().min(scan.bearings.len());
        if n == 0 {
            continue;
        }
        lod::ray_directions(origin.a, &scan.bearings[..n], &mut dirs);
        ends.clear();
        ends.extend(
            (dirs.iter().zip(scan.ranges)).map(|(d, rr)| [o[0] + rr * d[0], o[1] + rr * d[1]]),
        );
        if vis.ranger_ranges {
            if n == 1 {
                // a single-sample transducer (sonar): its cone at the measured range
                let half = sensor.fov / 2.0;
                let rr = scan.ranges[0];
                let chords = lod::arc_segments(rr, sensor.fov, tol, 32);
                let start = origin.a + scan.bearings[0] - half;
                dirs.clear();
                lod::turned_directions(start, sensor.fov / chords as f64, chords + 1, &mut dirs);
                rim.clear();
                rim.extend(dirs.iter().map(|d| [o[0] + rr * d[0], o[1] + rr * d[1]]));
                scene.fan(Layer::Footprints, o, &rim, color.with_alpha(40));
            } else {
                lod::simplify_rim(&ends, tol, &mut keep);
                rim.clear();
                rim.extend(keep.iter().map(|&i| ends[i]));
                scene.fan(Layer::Footprints, o, &rim, color.with_alpha(40));
            }
        }
        if vis.ranger_beams {
            let c = color.with_alpha(150);
            let mut last: Option<[f64; 2]> = None;
            for e in &ends {
                if last.is_some_and(|l| near(*e, l, px)) {
                    continue;
                }
                scene.line(Layer::Data, o, *e, 1.0, c);
                last = Some(*e);
            }
        }
        if vis.ranger_strikes {
            let d = 1.5 * px;
            let mut last: Option<[f64; 2]> = None;
            for (i, e) in ends.iter().enumerate() {
                if scan.ranges[i] < sensor.range[1] && !last.is_some_and(|l| near(*e, l, px)) {
                    scene.fill_rect(
                        Layer::Data,
                        [e[0] - d, e[1] - d],
                        [e[0] + d, e[1] + d],
                        color,
                    );
                    last = Some(*e);
                }
            }
        }
    }
}

/// Whether `a` and `b` are less than `d` apart.
fn near(a: [f64; 2], b: [f64; 2], d: f64) -> bool {
    let (x, y) = (a[0] - b[0], a[1] - b[1]);
    x * x + y * y < d * d
}

/// A field-of-view wedge outline from `frame` (centred on its heading).
fn wedge(scene: &mut Scene, frame: &Pose, fov: f64, range: f64, color: Rgba8) {
    if !(fov.is_finite() && range.is_finite() && range > 0.0) {
        return;
    }
    let o = [frame.x, frame.y];
    let steps = 24;
    let mut pts = vec![o];
    for i in 0..=steps {
        let a = frame.a - fov / 2.0 + fov * i as f64 / steps as f64;
        pts.push([o[0] + range * a.cos(), o[1] + range * a.sin()]);
    }
    scene.outline(Layer::Data, &pts, 1.0, color);
}

/// A blobfinder's image: a dark frame of the camera's size in screen pixels next to the model
/// (screen-aligned, like an inset), each blob a box in its colour.
fn blob_image(
    world: &World,
    m: ModelId,
    d: &stage_sim::BlobfinderData,
    image: [u32; 2],
    view: &View,
    scene: &mut Scene,
) {
    let (w, h) = (image[0].clamp(1, 640) as f64, image[1].clamp(1, 480) as f64);
    // half-size inset in screen pixels, anchored above-right of the model
    let k = 0.5;
    let g = world.global_pose(m).expect(SAME_WORLD);
    let anchor = view.to_screen([g.x, g.y]);
    let top_left = [anchor[0] + 10.0, anchor[1] - 10.0 - h * k];
    let boxes = d.blobs.iter().map(|b| {
        let edges = [b.left as f64, b.top as f64, b.right as f64, b.bottom as f64];
        (Rgba8::from_color(&b.color), edges)
    });
    let background = Rgba8::rgb(40, 40, 40).with_alpha(200);
    scene.blob_inset(Layer::Data, view, top_left, k, [w, h], background, boxes);
}

/// The topmost model under world point `p`, or its nearest movable ancestor when `movable`
/// (Stage selects the model the user may drag).
pub fn pick(world: &World, gui: &WorldGui, p: [f64; 2], movable: bool) -> Option<ModelId> {
    let mut best: Option<(f64, ModelId)> = None;
    for m in world.models() {
        let b = world.body(m).expect(SAME_WORLD);
        if b.is_empty()
            || p[0] < b.aabb.min[0]
            || p[0] > b.aabb.max[0]
            || p[1] < b.aabb.min[1]
            || p[1] > b.aabb.max[1]
        {
            continue;
        }
        for k in 0..b.blocks.len() {
            if point_in_polygon(p, b.block_pts(k)) {
                let top = b.blocks[k].zmax;
                if best.is_none_or(|(z, _)| top >= z) {
                    best = Some((top, m));
                }
            }
        }
    }
    let (_, mut m) = best?;
    if !movable {
        return Some(m);
    }
    loop {
        if gui.get(m).movable {
            return Some(m);
        }
        m = world.parent(m).expect(SAME_WORLD)?;
    }
}

/// Even-odd point-in-polygon test.
pub fn point_in_polygon(p: [f64; 2], poly: &[[f64; 2]]) -> bool {
    let n = poly.len();
    if n < 3 {
        return false;
    }
    let mut inside = false;
    let mut j = n - 1;
    for i in 0..n {
        let (a, b) = (poly[i], poly[j]);
        if (a[1] > p[1]) != (b[1] > p[1])
            && p[0] < (b[0] - a[0]) * (p[1] - a[1]) / (b[1] - a[1]) + a[0]
        {
            inside = !inside;
        }
        j = i;
    }
    inside
}
