//! `World`: a Stage world simulated in-process, for batch experiments and learning loops.
//!
//! It is `stage-sim` itself (the engine the `player` server's stage driver runs), loaded from a
//! worldfile and stepped on demand: no server, no sockets, no clock. Models are addressed by
//! name; every position and sensor model except cameras (costly ray fans) is subscribed at
//! load so it updates from the first step, as if a client had subscribed to each.

use player_server::stage::convert as player_view;
use std::path::PathBuf;
use std::sync::Mutex;

use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::{PyByteArray, PyBytes, PyDict, PyList};
use rayon::prelude::*;
use stage_sim::fork::PerProcess;
use stage_sim::{Body, GripperCmd, ModelId, Pose, on_sim_threads};
use worldfile::models::Drive;

use crate::convert;
use crate::errors::WorldError;
use crate::explore::ExploreMap;

/// A loaded world: `World(path, seed=0)`.
#[pyclass(module = "playerstage._native")]
pub struct World {
    pub(crate) world: stage_sim::World,
    path: PathBuf,
    /// The worldfile's `window` (default size, what to draw) for `render`.
    window: worldfile::WindowSpec,
    /// Model colours and outlines as the viewer draws them, for `render`.
    gui: viewer::world_scene::WorldGui,
    /// The last rendered scene: its static layer is reused while the walls stay put.
    scene: viewer::Scene,
    /// Position models whose travel, stalls and collisions every step accumulates (`track`).
    pub(crate) tracks: Vec<Track>,
    /// The explore task's maps of this episode, one per robot (`explore_begin`; several
    /// agents of a `parallel_env` share the world), scored after every step.
    pub(crate) explore: Vec<(String, ExploreMap)>,
}

/// What `World.track` accumulates for one position model, step by step, in native code: a
/// sweep's per-robot metrics need every step's pose and stall flag, which read from Python
/// after each step would cost more than the step of a small world.
pub(crate) struct Track {
    model: ModelId,
    name: String,
    /// The global pose after the last step seen.
    last: Pose,
    /// Metres travelled: the sum of each step's straight-line move of the global pose.
    distance: f64,
    /// Simulated microseconds spent stalled (a step counts when the flag is set after it).
    stalled_us: u64,
    /// How many times the stall flag went from clear to set: the contacts begun.
    collisions: u64,
    stalled: bool,
}

impl Track {
    /// Reads the model's pose and stall flag after a step of `dt_us` microseconds.
    fn update(&mut self, world: &stage_sim::World, dt_us: u64) -> stage_sim::Result<()> {
        let pose = world.global_pose(self.model)?;
        // sqrt of the sum: a step's move is far from overflowing, and hypot costs several
        // times more in this loop run for every robot at every step
        let (dx, dy) = (pose.x - self.last.x, pose.y - self.last.y);
        self.distance += (dx * dx + dy * dy).sqrt();
        self.last = pose;
        let stall = world.position_state(self.model)?.stall;
        if stall {
            self.stalled_us += dt_us;
            if !self.stalled {
                self.collisions += 1;
            }
        }
        self.stalled = stall;
        Ok(())
    }
}

/// The one offscreen renderer of the process, opened by the first `render`: opening a device
/// takes far longer than a frame, and every episode's reset makes a new `World`. Per process:
/// a child forked after its parent rendered (an `AsyncVectorEnv` worker) would hang in the
/// parent's device, whose driver threads it does not have, so it opens its own.
static OFFSCREEN: PerProcess<Mutex<Option<viewer::Offscreen>>> = PerProcess::new();

pub(crate) fn sim_err(e: stage_sim::Error) -> PyErr {
    WorldError::new_err(e.to_string())
}

/// A world window error as Python sees it: RuntimeError with a first sentence that says what
/// to do.
fn window_err(e: viewer::ViewerError) -> PyErr {
    match e {
        viewer::ViewerError::NoDisplay => PyRuntimeError::new_err(
            "no display for the world window: neither DISPLAY nor WAYLAND_DISPLAY is set \
             (render_mode=\"rgb_array\" draws without one; under Xvfb, set DISPLAY)",
        ),
        e => PyRuntimeError::new_err(format!("the world window cannot open: {e}")),
    }
}

/// Whether a display is announced for the world window (`DISPLAY` or `WAYLAND_DISPLAY` set).
#[pyfunction]
pub fn display_available() -> bool {
    viewer::world_window::display_available()
}

/// Closes the process's world window if it is open (`World.show_window` opens it again), and
/// waits until it is gone.
#[pyfunction]
pub fn close_window(py: Python<'_>) {
    py.allow_threads(|| viewer::scene_window::SceneWindow::global().hide());
}

/// `(open, frames painted)` of the process's world window: whether it is up, and how many
/// frames it has painted since the process started (frames reaching the screen).
#[pyfunction]
pub fn window_state() -> (bool, u64) {
    let w = viewer::scene_window::SceneWindow::global();
    (w.is_open(), w.frames_painted())
}

/// `n` steps of `world`, stopping at its `quit_time`: false once reached. Each of `tracks`
/// is updated after every step.
pub(crate) fn step_n(world: &mut stage_sim::World, tracks: &mut [Track], n: u64) -> bool {
    let mut running = true;
    for _ in 0..n {
        let before = world.sim_time();
        running = world.step();
        let dt = world.sim_time() - before;
        for t in tracks.iter_mut() {
            // a tracked model was checked to be a position model: its reads cannot fail
            let _ = t.update(world, dt);
        }
        if !running {
            break;
        }
    }
    running
}

/// The rays of the ranger `m`'s readings as `World.ranger_rays` describes them: `[x, y,
/// heading]` in the world frame, one per reading (the explore task's map casts along them).
pub(crate) fn ranger_rays(
    world: &stage_sim::World,
    m: ModelId,
) -> stage_sim::Result<Vec<[f64; 3]>> {
    let r = world.ranger_scans(m)?;
    let origin = world.node(m)?.origin;
    let frame = world.global_pose(m)?.compose(&origin);
    let one = r.scans().len() == 1;
    let mut out = Vec::with_capacity(if one {
        r.bearings().len()
    } else {
        r.sensors.len()
    });
    for (sensor, scan) in r.sensors.iter().zip(r.scans()) {
        let at = frame.compose(&Pose {
            z: 0.0,
            ..sensor.pose
        });
        let bearings = if one {
            scan.bearings
        } else {
            // Player's reading of a transducer in a ring: its first sample
            &scan.bearings[..scan.bearings.len().min(1)]
        };
        out.extend(bearings.iter().map(|b| [at.x, at.y, at.a + b]));
    }
    Ok(out)
}

/// `robot`'s explore map among `maps` (`World::explore`).
pub(crate) fn explore_map<'m>(
    maps: &'m mut [(String, ExploreMap)],
    robot: &str,
) -> Option<&'m mut ExploreMap> {
    maps.iter_mut().find(|(r, _)| r == robot).map(|(_, m)| m)
}

fn pose_list(p: &Pose) -> [f64; 3] {
    [p.x, p.y, p.a]
}

impl World {
    fn model(&self, name: &str) -> PyResult<ModelId> {
        self.world.model_by_name(name).ok_or_else(|| {
            WorldError::new_err(format!("{}: no model named `{name}`", self.path.display()))
        })
    }

    fn wrong_type(&self, name: &str, want: &str) -> PyErr {
        WorldError::new_err(format!(
            "{}: model `{name}` is not a {want}",
            self.path.display()
        ))
    }

    /// What `read` gives of the model `name`, a `kind` of sensor; an error naming the model
    /// when there is none or it is not one.
    pub(crate) fn sensor<'w, T>(
        &'w self,
        name: &str,
        kind: &str,
        read: impl FnOnce(&'w stage_sim::World, ModelId) -> stage_sim::Result<T>,
    ) -> PyResult<T> {
        let m = self.model(name)?;
        read(&self.world, m).map_err(|e| match e {
            stage_sim::Error::BadModel { .. } => self.wrong_type(name, kind),
            e => sim_err(e),
        })
    }
}

/// Whether the point `p` lies inside the closed polygon `pts` (crossing number; a point on an
/// edge may go either way, which the edge test of [`blocks_overlap`] covers).
fn point_in_polygon(p: [f64; 2], pts: &[[f64; 2]]) -> bool {
    let mut inside = false;
    let mut j = pts.len().wrapping_sub(1);
    for (i, &a) in pts.iter().enumerate() {
        let b = pts[j];
        if (a[1] > p[1]) != (b[1] > p[1])
            && p[0] < (b[0] - a[0]) * (p[1] - a[1]) / (b[1] - a[1]) + a[0]
        {
            inside = !inside;
        }
        j = i;
    }
    inside
}

/// Whether block `i` of body `a` and block `j` of body `b` share a point: their z intervals
/// overlap and their outlines cross, or one lies inside the other.
fn blocks_overlap(a: &Body, i: usize, b: &Body, j: usize) -> bool {
    let (ba, bb) = (&a.blocks[i], &b.blocks[j]);
    if ba.zmax <= bb.zmin || bb.zmax <= ba.zmin {
        return false;
    }
    let (x, y) = (ba.aabb, bb.aabb);
    if x.max[0] < y.min[0] || y.max[0] < x.min[0] || x.max[1] < y.min[1] || y.max[1] < x.min[1] {
        return false;
    }
    let crossing = a.edges(i).any(|(p1, p2)| {
        b.edges(j)
            .any(|(q1, q2)| stage_sim::geom::segments_intersect(p1, p2, q1, q2))
    });
    let (pa, pb) = (a.block_pts(i), b.block_pts(j));
    crossing
        || pa
            .first()
            .is_some_and(|&p| pb.len() > 2 && point_in_polygon(p, pb))
        || pb
            .first()
            .is_some_and(|&p| pa.len() > 2 && point_in_polygon(p, pa))
}

impl World {
    /// What `World(path, seed, text)` loads (see `new`), without the GIL: `load_worlds` makes
    /// several at once on the simulator's threads.
    fn open(path: PathBuf, seed: u64, text: Option<String>) -> PyResult<Self> {
        let load_path = path.clone();
        let load = move || -> stage_sim::Result<_> {
            match text {
                None => stage_sim::World::load(&load_path, seed),
                Some(text) => {
                    let opts = worldfile::LoadOptions::from_env();
                    let spec = worldfile::WorldSpec::parse(&load_path, &text, &opts)?;
                    let world = stage_sim::World::from_spec(&spec, seed)?;
                    Ok((world, spec))
                }
            }
        };
        let (mut world, spec) = load().map_err(sim_err)?;
        let models: Vec<ModelId> = world.models().collect();
        for m in models {
            use stage_sim::ModelType as T;
            match world.model_type(m).map_err(sim_err)? {
                T::Position
                | T::Ranger
                | T::Blobfinder
                | T::Fiducial
                | T::Gripper
                | T::Actuator => world.subscribe(m).map_err(sim_err)?,
                _ => {}
            }
        }
        Ok(World {
            window: spec.window.clone().unwrap_or_default(),
            gui: viewer::world_scene::WorldGui::from_spec(&spec),
            scene: viewer::Scene::default(),
            tracks: Vec::new(),
            explore: Vec::new(),
            world,
            path,
        })
    }
}

#[pymethods]
impl World {
    /// Loads `path` (Stage's `STAGEPATH` honoured for includes and bitmaps) with `seed` for
    /// every random choice: the same file, seed and commands give the same run. A bad file
    /// raises `WorldError` naming file:line. With `text`, that text is the worldfile, read
    /// as if it were the file at `path` (which need not exist: includes and bitmaps resolve
    /// against its directory, messages name it): how a sweep loads a template filled in for
    /// one run without writing it to disk first.
    #[new]
    #[pyo3(signature = (path, seed=0, text=None))]
    fn new(py: Python<'_>, path: PathBuf, seed: u64, text: Option<String>) -> PyResult<Self> {
        py.allow_threads(move || World::open(path, seed, text))
    }

    /// The whole world drawn top-down by the viewer's offscreen renderer (what the world
    /// window shows, fitted to every model's blocks, with the `window` entity's View
    /// settings): `(width, height, rgb bytes)`, rows from the top. `width`/`height` default
    /// to the `window` entity's `size`. The renderer (any wgpu adapter, Mesa's software
    /// Vulkan included) is opened once per process; without one this raises RuntimeError
    /// starting "no graphics adapter".
    #[pyo3(signature = (width=None, height=None))]
    fn render<'py>(
        &mut self,
        py: Python<'py>,
        width: Option<u32>,
        height: Option<u32>,
    ) -> PyResult<(u32, u32, Bound<'py, PyBytes>)> {
        let mut view = viewer::View::from_window(&self.window);
        let size = [
            width.unwrap_or(view.size[0] as u32),
            height.unwrap_or(view.size[1] as u32),
        ];
        if !(1..=8192).contains(&size[0]) || !(1..=8192).contains(&size[1]) {
            return Err(WorldError::new_err(format!(
                "render size {}x{}: width and height must be 1..=8192 pixels",
                size[0], size[1]
            )));
        }
        view.size = [size[0] as f64, size[1] as f64];
        let (min, max) = viewer::world_scene::world_extent(&self.world);
        view.fit(min, max);
        let vis = viewer::world_scene::VisOptions::from_window(&self.window);
        viewer::world_scene::build(&self.world, &self.gui, &vis, &view, &[], &mut self.scene);
        let scene = &self.scene;
        let pixels = py.allow_threads(|| {
            let mut slot = OFFSCREEN
                .get_or_make(|| Mutex::new(None))
                .lock()
                .unwrap_or_else(|e| e.into_inner());
            if slot.is_none() {
                *slot = Some(viewer::Offscreen::new()?);
            }
            slot.as_mut().expect("opened above").render(scene, &view)
        });
        let pixels = pixels.map_err(|e| match e {
            viewer::ViewerError::NoAdapter => PyRuntimeError::new_err(
                "no graphics adapter for offscreen rendering (wgpu found no Vulkan or GL \
                 adapter); install Mesa's Vulkan driver (lavapipe, e.g. mesa-vulkan-drivers)",
            ),
            e => PyRuntimeError::new_err(format!("offscreen rendering failed: {e}")),
        })?;
        let rgb: Vec<u8> = pixels
            .rgba
            .chunks_exact(4)
            .flat_map(|p| [p[0], p[1], p[2]])
            .collect();
        Ok((pixels.width, pixels.height, PyBytes::new(py, &rgb)))
    }

    /// Shows the world in the process's world window (opened on first use with the `window`
    /// entity's `size`, titled `title`; one window per process, showing whichever world was
    /// shown last): the whole world fitted to the window's canvas, as `render` draws it, with
    /// the simulated time in the status bar. Returns once the frame is handed to the window's
    /// thread. Raises RuntimeError starting "no display" when neither `DISPLAY` nor
    /// `WAYLAND_DISPLAY` is set, and one naming the cause when the window cannot open.
    fn show_window(&mut self, py: Python<'_>, title: &str) -> PyResult<()> {
        let window = viewer::scene_window::SceneWindow::global();
        let mut view = viewer::View::from_window(&self.window);
        let size = view.size;
        py.allow_threads(|| window.show(title, size))
            .map_err(window_err)?;
        view.size = window.canvas_size();
        let (min, max) = viewer::world_scene::world_extent(&self.world);
        view.fit(min, max);
        let vis = viewer::world_scene::VisOptions::from_window(&self.window);
        viewer::world_scene::build(&self.world, &self.gui, &vis, &view, &[], &mut self.scene);
        let status = format!(
            "{}  (step {})",
            viewer::world_window::clock_text(self.world.sim_time()),
            self.world.updates()
        );
        window.present(std::sync::Arc::new(self.scene.clone()), view, status);
        Ok(())
    }

    /// Advances `n` steps of `interval_sim` each (GIL released); returns False once the
    /// world's `quit_time` is reached.
    #[pyo3(signature = (n=1))]
    fn step(&mut self, py: Python<'_>, n: u64) -> bool {
        let (world, tracks) = (&mut self.world, &mut self.tracks);
        py.allow_threads(|| on_sim_threads(|| step_n(world, tracks, n)))
    }

    /// Starts accumulating, from now and at every step, each named position model's distance
    /// travelled (metres, its global pose's straight-line move per step), time stalled
    /// (simulated seconds after which its stall flag was set) and collisions (how many times
    /// the flag went from clear to set); `tracked()` reads them. Replaces the models tracked
    /// before and starts their counts at zero; an empty list stops tracking. A name that is
    /// not a position model raises, leaving the tracking as it was.
    fn track(&mut self, names: Vec<String>) -> PyResult<()> {
        let mut tracks = Vec::with_capacity(names.len());
        for name in names {
            let m = self.model(&name)?;
            let stalled = self
                .sensor(&name, "position model", |w, m| w.position_state(m))?
                .stall;
            let last = self.world.global_pose(m).map_err(sim_err)?;
            tracks.push(Track {
                model: m,
                name,
                last,
                distance: 0.0,
                stalled_us: 0,
                collisions: 0,
                stalled,
            });
        }
        self.tracks = tracks;
        Ok(())
    }

    /// What `track` accumulated, per model in the order given: `(name, [x, y, a] global pose
    /// now, distance m, stalled s, collisions)`.
    #[allow(clippy::type_complexity)]
    fn tracked(&self) -> Vec<(String, [f64; 3], f64, f64, u64)> {
        self.tracks
            .iter()
            .map(|t| {
                (
                    t.name.clone(),
                    pose_list(&t.last),
                    t.distance,
                    t.stalled_us as f64 / 1e6,
                    t.collisions,
                )
            })
            .collect()
    }

    /// Simulated time in seconds.
    #[getter]
    fn time(&self) -> f64 {
        self.world.sim_time() as f64 / 1e6
    }

    /// Simulated time in microseconds.
    #[getter]
    fn time_us(&self) -> u64 {
        self.world.sim_time()
    }

    /// Steps taken so far.
    #[getter]
    fn steps(&self) -> u64 {
        self.world.updates()
    }

    /// Simulated seconds per step (`interval_sim`).
    #[getter]
    fn interval(&self) -> f64 {
        self.world.config().interval_sim_us as f64 / 1e6
    }

    /// The world's `quit_time` in seconds (0: never); `step` stops there.
    #[getter]
    fn get_quit_time(&self) -> f64 {
        self.world.config().quit_time_us as f64 / 1e6
    }

    /// Overrides `quit_time` (seconds; 0 = never), e.g. for runs longer than the file's.
    #[setter]
    fn set_quit_time(&mut self, seconds: f64) -> PyResult<()> {
        if !(seconds >= 0.0 && seconds.is_finite()) {
            return Err(WorldError::new_err(format!(
                "quit_time {seconds}: not a finite number of seconds >= 0"
            )));
        }
        self.world.set_quit_time_us((seconds * 1e6).round() as u64);
        Ok(())
    }

    /// The seed the world was loaded with.
    #[getter]
    fn seed(&self) -> u64 {
        self.world.seed()
    }

    /// What loading the world warned about and went on (an unused property, a `ctrl` that
    /// is not built in or could not attach, ...), in order: a sweep refuses a plan whose
    /// controllers did not attach before anything runs.
    fn warnings(&self) -> Vec<String> {
        self.world.warnings().to_vec()
    }

    /// A digest of every model's state: equal digests mean identical runs.
    fn digest(&self) -> u64 {
        self.world.state_digest()
    }

    /// The models as `(name, type)` pairs, in creation order.
    fn models(&self) -> PyResult<Vec<(String, &'static str)>> {
        self.world
            .models()
            .map(|m| {
                let name = self.world.name(m).map_err(sim_err)?;
                Ok((name.to_string(), self.world.type_name(m).map_err(sim_err)?))
            })
            .collect()
    }

    /// Starts updating a model that is not updated by default (a camera).
    fn subscribe(&mut self, name: &str) -> PyResult<()> {
        let m = self.model(name)?;
        self.world.subscribe(m).map_err(sim_err)
    }

    /// The model's pose in its parent's frame, `[x, y, a]`.
    fn pose(&self, name: &str) -> PyResult<[f64; 3]> {
        let pose = self.world.pose(self.model(name)?).map_err(sim_err)?;
        Ok(pose_list(&pose))
    }

    /// The model's pose in the world frame, `[x, y, a]`.
    fn global_pose(&self, name: &str) -> PyResult<[f64; 3]> {
        let pose = self.world.global_pose(self.model(name)?).map_err(sim_err)?;
        Ok(pose_list(&pose))
    }

    /// Moves the model (parent frame, no collision test), as the simulation interface's
    /// SET_POSE2D does.
    fn set_pose(&mut self, name: &str, x: f64, y: f64, a: f64) -> PyResult<()> {
        let m = self.model(name)?;
        let z = self.world.pose(m).map_err(sim_err)?.z;
        self.world.set_pose(m, Pose { x, y, z, a }).map_err(sim_err)
    }

    /// Velocity command for a position model (m/s, m/s, rad/s).
    fn set_velocity(&mut self, name: &str, vx: f64, vy: f64, va: f64) -> PyResult<()> {
        let m = self.model(name)?;
        self.world.position_cmd_vel(m, vx, vy, va).map_err(sim_err)
    }

    /// Position command for a position model (its odometry frame).
    fn set_goal(&mut self, name: &str, x: f64, y: f64, a: f64) -> PyResult<()> {
        let m = self.model(name)?;
        self.world.position_cmd_pos(m, x, y, a).map_err(sim_err)
    }

    /// A position model's data: `{px, py, pa, vx, vy, va, stall, time}` (odometry frame, as
    /// Player's position2d), or None before its first update.
    fn position<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Option<Bound<'py, PyDict>>> {
        let s = self.sensor(name, "position model", |w, m| w.position_state(m))?;
        let d = PyDict::new(py);
        let (pos, vel) = (&s.pose, &s.velocity);
        convert::odometry(&d, [pos.x, pos.y, pos.a], [vel.x, vel.y, vel.a], s.stall)?;
        d.set_item("time", s.time_us as f64 / 1e6)?;
        Ok(Some(d))
    }

    /// A position model's drive (`"diff"`, `"omni"` or `"car"`) and its `velocity_bounds`
    /// `[xmin, xmax, ymin, ymax, zmin, zmax, amin, amax]` (m/s, rad/s) as resolved from the
    /// worldfile: what a controller may command (Stage clamps commands to them), e.g. the
    /// bounds of a learning agent's action space.
    fn position_config(&self, name: &str) -> PyResult<(&'static str, [f64; 8])> {
        let p = self.sensor(name, "position model", |w, m| w.position_model(m))?;
        let drive = match p.cfg.drive {
            Drive::Diff => "diff",
            Drive::Omni => "omni",
            Drive::Car => "car",
        };
        Ok((drive, p.cfg.velocity_bounds))
    }

    /// The rangers in the model's tree (the model and its descendants, parents first) as
    /// `[(name, samples, range_max)]`: `samples` is the length of `ranger(name)["ranges"]`
    /// (one transducer: its samples; several: one reading each) and `range_max` the largest
    /// reach of its transducers (m), so a caller can size its buffers before the first step.
    fn rangers(&self, name: &str) -> PyResult<Vec<(String, usize, f64)>> {
        let m = self.model(name)?;
        let mut out = Vec::new();
        for s in self.world.subtree(m).map_err(sim_err)? {
            if self.world.model_type(s).map_err(sim_err)? != stage_sim::ModelType::Ranger {
                continue;
            }
            let sensors = &self.world.ranger_scans(s).map_err(sim_err)?.sensors;
            let samples = match sensors.as_slice() {
                [one] => one.samples as usize,
                all => all.len(),
            };
            let range_max = sensors.iter().map(|d| d.range[1]).fold(0.0, f64::max);
            out.push((
                self.world.name(s).map_err(sim_err)?.to_string(),
                samples,
                range_max,
            ));
        }
        Ok(out)
    }

    /// Whether the model's tree, at its current pose, overlaps a block of any model outside
    /// its tree (outlines crossing or one inside the other, z intervals overlapping,
    /// whatever their `obstacle_return`). False means the pose is in free space: used to draw
    /// start and goal poses that need no step to test.
    fn overlaps(&self, name: &str) -> PyResult<bool> {
        let m = self.model(name)?;
        let mine = self.world.subtree(m).map_err(sim_err)?;
        let mut bodies = Vec::with_capacity(mine.len());
        for &s in &mine {
            bodies.push(self.world.body(s).map_err(sim_err)?);
        }
        for other in self.world.models() {
            if self.world.related(m, other).map_err(sim_err)? {
                continue;
            }
            let ob = self.world.body(other).map_err(sim_err)?;
            for body in &bodies {
                for i in 0..body.blocks.len() {
                    if (0..ob.blocks.len()).any(|j| blocks_overlap(body, i, ob, j)) {
                        return Ok(true);
                    }
                }
            }
        }
        Ok(false)
    }

    /// The world-axis-aligned box around every model's blocks as they are now, `[xmin, ymin,
    /// xmax, ymax]` (m), where random start and goal poses are drawn; None for a world
    /// without blocks.
    fn extent(&self) -> PyResult<Option<[f64; 4]>> {
        let mut out: Option<[f64; 4]> = None;
        for m in self.world.models() {
            let body = self.world.body(m).map_err(sim_err)?;
            if body.is_empty() {
                continue;
            }
            let (lo, hi) = (body.aabb.min, body.aabb.max);
            out = Some(match out {
                None => [lo[0], lo[1], hi[0], hi[1]],
                Some(e) => [
                    e[0].min(lo[0]),
                    e[1].min(lo[1]),
                    e[2].max(hi[0]),
                    e[3].max(hi[1]),
                ],
            });
        }
        Ok(out)
    }

    /// A ranger's data as Player publishes it: `{ranges, intensities, bearings, time}`
    /// (one sensor: all its samples; several: the first sample of each).
    fn ranger<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyDict>> {
        let r = self.sensor(name, "ranger", |w, m| w.ranger_scans(m))?;
        let d = PyDict::new(py);
        d.set_item("ranges", player_view::ranger_ranges(r))?;
        d.set_item("intensities", player_view::ranger_intensities(r))?;
        let bearings = r.bearings().to_vec();
        d.set_item("bearings", bearings)?;
        d.set_item("time", r.time_us as f64 / 1e6)?;
        Ok(d)
    }

    /// Where each of a ranger's readings was cast from, in the world frame, as the ranger now
    /// stands: `[(x, y, heading)]`, one per reading, laid out as `ranger(name)["ranges"]`
    /// (one transducer: each sample; several, e.g. a sonar ring: each transducer's first
    /// sample). `(x, y)` is the transducer's own position on the ranger (its `pose` in the
    /// `sensor` entity, through the model's `origin`), as the simulator casts from it; the
    /// heading adds the transducer's own heading and the sample's bearing. Empty before the
    /// ranger's first update (no readings yet). The explore task maps free space with it.
    fn ranger_rays(&self, name: &str) -> PyResult<Vec<[f64; 3]>> {
        let m = self.model(name)?;
        self.sensor(name, "ranger", |w, m| w.ranger_scans(m))?;
        ranger_rays(&self.world, m).map_err(sim_err)
    }

    /// Starts `robot`'s explore task map (see `StageEnv`'s "explore" task) over `extent`
    /// (`[x0, y0, x1, y1]`, the world's at the episode's start) of `cell`-metre cells, seen by
    /// the rangers `rangers` (`[(name, range_max)]`), and marks what they show now (the
    /// start's view, which earns no reward); returns the area seen (m^2). Replaces the robot's
    /// map before, if any; other robots' maps are their own.
    fn explore_begin(
        &mut self,
        robot: String,
        rangers: Vec<(String, f64)>,
        extent: [f64; 4],
        cell: f64,
    ) -> PyResult<f64> {
        let mut ids = Vec::with_capacity(rangers.len());
        for (name, reach) in &rangers {
            ids.push((
                self.sensor(name, "ranger", |w, r| w.ranger_scans(r).map(|_| r))?,
                *reach,
            ));
        }
        if ids.is_empty() || !(cell > 0.0 && cell.is_finite()) {
            return Err(WorldError::new_err(format!(
                "explore_begin: {} rangers, cell {cell}: expected at least one ranger and a \
                 positive cell",
                ids.len()
            )));
        }
        let mut map = ExploreMap::new(ids, extent, cell).ok_or_else(|| {
            WorldError::new_err(format!(
                "explore_begin: a grid of {cell} m cells over {extent:?} is too large"
            ))
        })?;
        let cells = map.see(&self.world).map_err(sim_err)?;
        let area = map.area(cells);
        self.explore.retain(|(r, _)| *r != robot);
        self.explore.push((robot, map));
        Ok(area)
    }

    /// Marks on `robot`'s explore map what its rangers show now; returns the area (m^2) seen
    /// for the first time. Raises `WorldError` when the robot has no map (`explore_begin`).
    fn explore_see(&mut self, robot: &str) -> PyResult<f64> {
        let world = &self.world;
        let map = explore_map(&mut self.explore, robot).ok_or_else(|| {
            WorldError::new_err(format!(
                "explore_see: no explore map for `{robot}` (explore_begin)"
            ))
        })?;
        let cells = map.see(world).map_err(sim_err)?;
        Ok(map.area(cells))
    }

    /// The area (m^2) `robot`'s explore map has seen so far, None without a map.
    fn explored(&mut self, robot: &str) -> Option<f64> {
        explore_map(&mut self.explore, robot).map(|m| m.explored())
    }

    /// A blobfinder's data: `{width, height, blobs: [{color, x, y, left, right, top, bottom,
    /// range, area}], time}` with Player's blob fields.
    fn blobfinder<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyDict>> {
        let b = self.sensor(name, "blobfinder", |w, m| w.blobfinder_blobs(m))?;
        let d = PyDict::new(py);
        d.set_item("width", b.width)?;
        d.set_item("height", b.height)?;
        let blobs = PyList::empty(py);
        for blob in &b.blobs {
            let e = PyDict::new(py);
            e.set_item("color", blob.color.packed_rgb())?;
            e.set_item("x", player_view::blob_x(blob))?;
            e.set_item("y", player_view::blob_y(blob))?;
            e.set_item("left", blob.left)?;
            e.set_item("right", blob.right)?;
            e.set_item("top", blob.top)?;
            e.set_item("bottom", blob.bottom)?;
            e.set_item("range", blob.range)?;
            e.set_item("area", player_view::blob_area(blob))?;
            blobs.append(e)?;
        }
        d.set_item("blobs", blobs)?;
        d.set_item("time", b.time_us as f64 / 1e6)?;
        Ok(d)
    }

    /// A fiducial finder's detections: `[{id, range, bearing, heading}]`.
    fn fiducials<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyList>> {
        let f = self.sensor(name, "fiducial finder", |w, m| w.fiducials(m))?;
        let out = PyList::empty(py);
        for item in &f.fiducials {
            let e = PyDict::new(py);
            e.set_item("id", item.id)?;
            e.set_item("range", item.range)?;
            e.set_item("bearing", item.bearing)?;
            e.set_item("heading", item.heading)?;
            out.append(e)?;
        }
        Ok(out)
    }

    /// A gripper's state: `{paddles, lift, beams, holding}` (paddle/lift states by name,
    /// `beams` how many break beams see an object).
    fn gripper<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyDict>> {
        let g = self.sensor(name, "gripper", |w, m| w.gripper_state(m))?;
        let d = PyDict::new(py);
        d.set_item("paddles", format!("{:?}", g.paddles).to_lowercase())?;
        d.set_item("lift", format!("{:?}", g.lift).to_lowercase())?;
        d.set_item("beams", g.beams.iter().filter(|b| b.is_some()).count())?;
        d.set_item("time", g.time_us as f64 / 1e6)?;
        Ok(d)
    }

    /// Gripper command: `open`, `close`, `up` or `down`.
    fn gripper_cmd(&mut self, name: &str, what: &str) -> PyResult<()> {
        let m = self.model(name)?;
        let cmd = match what {
            "open" => GripperCmd::Open,
            "close" => GripperCmd::Close,
            "up" => GripperCmd::Up,
            "down" => GripperCmd::Down,
            other => {
                return Err(WorldError::new_err(format!(
                    "unknown gripper command `{other}` (open, close, up, down)"
                )));
            }
        };
        self.world.gripper_cmd(m, cmd).map_err(sim_err)
    }

    /// A camera's latest image: `(width, height, rgba bytes)`, or None before its first
    /// update (call `subscribe(name)` first: cameras are not updated by default).
    fn camera<'py>(
        &self,
        py: Python<'py>,
        name: &str,
    ) -> PyResult<Option<(u32, u32, Bound<'py, PyBytes>)>> {
        let c = self.sensor(name, "camera", |w, m| w.camera_image(m))?;
        Ok((c.width > 0).then(|| (c.width, c.height, PyBytes::new(py, &c.rgba))))
    }

    /// What the model says (its speech bubble).
    fn said(&self, name: &str) -> PyResult<String> {
        let said = self.world.said(self.model(name)?).map_err(sim_err)?;
        Ok(said.to_string())
    }

    /// Sets the model's speech bubble text.
    fn say(&mut self, name: &str, text: &str) -> PyResult<()> {
        let m = self.model(name)?;
        self.world.say(m, text).map_err(sim_err)
    }
}

/// Steps every world of `worlds` `n` times, side by side on the simulation's thread pool with
/// the GIL released (each world's own steps stay sequential, so each ends exactly as if
/// stepped alone); returns, per world, False once its `quit_time` was reached (its steps stop
/// there, as `World.step` does). `VectorStageEnv` steps its copies with it. A world listed
/// twice raises (it cannot be stepped twice at once).
#[pyfunction]
#[pyo3(signature = (worlds, n=1))]
pub fn step_worlds(py: Python<'_>, worlds: Vec<Bound<'_, World>>, n: u64) -> PyResult<Vec<bool>> {
    let mut held = borrow_each(&worlds, "step_worlds")?;
    let mut sims: Vec<(&mut stage_sim::World, &mut Vec<Track>)> = held
        .iter_mut()
        .map(|w| {
            let w = &mut **w;
            (&mut w.world, &mut w.tracks)
        })
        .collect();
    Ok(py.allow_threads(|| {
        on_sim_threads(|| {
            sims.par_iter_mut()
                .map(|(world, tracks)| step_n(world, tracks, n))
                .collect()
        })
    }))
}

/// Every world of `worlds` borrowed for stepping, or an error naming the call (`what`) when
/// one is listed twice or in use elsewhere (it cannot be stepped twice at once).
fn borrow_each<'py>(
    worlds: &[Bound<'py, World>],
    what: &str,
) -> PyResult<Vec<PyRefMut<'py, World>>> {
    worlds
        .iter()
        .map(|w| {
            w.try_borrow_mut().map_err(|_| {
                WorldError::new_err(format!(
                    "{what}: a world is listed twice or is in use elsewhere"
                ))
            })
        })
        .collect()
}

/// What [`step_observe`] gives back: per world whether it still runs, each ranger's readings
/// of every world (a bytearray of `len(worlds) * samples` f32, native endian, as the
/// observation has them: clipped to `[0, range_max]`, a world's readings replaced by
/// `range_max` when their count is not `samples`), and per world `px py pa vx vy va stall x y
/// a` (odometry, stall as 0/1, global pose; f64), followed, when goals were given, by the
/// goal's `distance ahead left` ([`goal_view`]).
type Observed<'py> = (Vec<bool>, Vec<Bound<'py, PyByteArray>>, Bound<'py, PyBytes>);

/// One vector step of `VectorStageEnv` in one call: commands `velocities[i]` (`[vx, vy, va]`)
/// to the position model `robot` of `worlds[i]` (None: no command), steps every world `n`
/// times as [`step_worlds`] does, then reads what the observations and the goal task need, in
/// bulk, so Python handles a few arrays instead of dozens of dicts per copy. `rangers` are
/// `(name, samples, range_max)` as `World.rangers` lists them; `goals[i]` is world `i`'s goal
/// `(x, y)` for the goal task's distance and relative position. Readings are exactly those
/// `World.ranger` and `World.position` give. `StageEnv` reads its one world through it too
/// (`n = 0` at a reset), so a lone env and a vector's copy compute the same numbers.
#[pyfunction]
#[pyo3(signature = (worlds, robot, velocities, n, rangers, goals=None))]
pub fn step_observe<'py>(
    py: Python<'py>,
    worlds: Vec<Bound<'py, World>>,
    robot: &str,
    velocities: Option<Vec<[f64; 3]>>,
    n: u64,
    rangers: Vec<(String, usize, f64)>,
    goals: Option<Vec<[f64; 2]>>,
) -> PyResult<Observed<'py>> {
    for (what, len) in [
        ("velocities", velocities.as_ref().map(Vec::len)),
        ("goals", goals.as_ref().map(Vec::len)),
    ] {
        if let Some(len) = len.filter(|&len| len != worlds.len()) {
            return Err(WorldError::new_err(format!(
                "step_observe: {len} {what} for {} worlds",
                worlds.len()
            )));
        }
    }
    let mut held = borrow_each(&worlds, "step_observe")?;
    // every name and type checked before any world changes: a refused call changes nothing
    let mut ids = Vec::with_capacity(held.len());
    // (each name looked up once: the check hands back the id it checked)
    for w in &held {
        let m = w.sensor(robot, "position model", |sim, m| {
            sim.position_state(m).map(|_| m)
        })?;
        let mut rs = Vec::with_capacity(rangers.len());
        for (name, _, _) in &rangers {
            rs.push(w.sensor(name, "ranger", |sim, r| sim.ranger_scans(r).map(|_| r))?);
        }
        ids.push((m, rs));
    }
    for ((w, v), (m, _)) in held.iter_mut().zip(velocities.iter().flatten()).zip(&ids) {
        w.world
            .position_cmd_vel(*m, v[0], v[1], v[2])
            .map_err(sim_err)?;
    }
    // each world is read on its own thread right after its steps: only the copying into the
    // returned buffers is left serial, so a vector step scales with the pool like step_worlds
    type Job<'a> = (
        (&'a mut stage_sim::World, &'a mut Vec<Track>),
        (&'a (ModelId, Vec<ModelId>), Option<[f64; 2]>),
    );
    let goal_of = |i: usize| goals.as_ref().map(|g| g[i]);
    let jobs: Vec<Job<'_>> = held
        .iter_mut()
        .map(|w| {
            let w = &mut **w;
            (&mut w.world, &mut w.tracks)
        })
        .zip(ids.iter().enumerate().map(|(i, id)| (id, goal_of(i))))
        .collect();
    let read: Vec<stage_sim::Result<(bool, Observation)>> = py.allow_threads(|| {
        on_sim_threads(|| {
            jobs.into_par_iter()
                .map(|((world, tracks), ((m, rs), goal))| {
                    let running = step_n(world, tracks, n);
                    observe_one(world, *m, rs, &rangers, goal).map(|obs| (running, obs))
                })
                .collect()
        })
    });
    let mut running = Vec::with_capacity(read.len());
    let mut all = Vec::with_capacity(read.len());
    for r in read {
        let (still, obs) = r.map_err(sim_err)?;
        running.push(still);
        all.push(obs);
    }
    let mut scans = Vec::with_capacity(rangers.len());
    let mut offset = 0;
    for (_, samples, _) in &rangers {
        let mut out: Vec<u8> = Vec::with_capacity(all.len() * samples * 4);
        for obs in &all {
            let part = &obs.scans[offset..offset + samples];
            out.extend(part.iter().flat_map(|v| v.to_ne_bytes()));
        }
        // a bytearray: the arrays numpy makes over it are writable, as observations should be
        scans.push(PyByteArray::new(py, &out));
        offset += samples;
    }
    let mut state: Vec<u8> = Vec::with_capacity(all.len() * 13 * 8);
    for obs in &all {
        state.extend(obs.state.iter().flat_map(|v| v.to_ne_bytes()));
    }
    Ok((running, scans, PyBytes::new(py, &state)))
}

/// One world's part of [`step_observe`]'s answer (see [`observe_one`]).
pub(crate) struct Observation {
    /// Each ranger's readings, one ranger after another, as the observation has them.
    pub(crate) scans: Vec<f32>,
    /// `px py pa vx vy va stall x y a`, then with a goal `distance ahead left`.
    pub(crate) state: Vec<f64>,
}

/// A reading as the observation space has it: rounded to f32 (as numpy's `astype` rounds),
/// then clipped to `[0, range_max]` as `numpy.clip` clips (a NaN stays NaN).
fn observed_range(r: f64, range_max: f32) -> f32 {
    let r = r as f32;
    if r.is_nan() {
        return r;
    }
    let r = if r > 0.0 { r } else { 0.0 };
    if r < range_max { r } else { range_max }
}

/// The goal task's view of the goal `(gx, gy)` from the global pose `(x, y, a)`: the distance
/// to it and its position in the robot's frame (x ahead, y to the left). `StageEnv` and
/// `VectorStageEnv` both take it from here (through [`step_observe`]), so that a lone env and
/// a vector's copy agree to the last bit: CPython's `math.hypot` is not libm's `hypot`.
fn goal_view(goal: [f64; 2], x: f64, y: f64, a: f64) -> [f64; 3] {
    let (dx, dy) = (goal[0] - x, goal[1] - y);
    let (c, s) = (a.cos(), a.sin());
    [dx.hypot(dy), c * dx + s * dy, -s * dx + c * dy]
}

/// One world's part of [`step_observe`]'s answer: each ranger's `samples` readings as the
/// observation has them ([`observed_range`]; all `range_max` when the count differs), and
/// `px py pa vx vy va stall x y a`, then with a `goal` its [`goal_view`] `distance ahead
/// left`.
pub(crate) fn observe_one(
    world: &stage_sim::World,
    robot: ModelId,
    ids: &[ModelId],
    rangers: &[(String, usize, f64)],
    goal: Option<[f64; 2]>,
) -> stage_sim::Result<Observation> {
    let mut scans = Vec::with_capacity(rangers.iter().map(|r| r.1).sum::<usize>());
    for (&r, (_, samples, range_max)) in ids.iter().zip(rangers) {
        let top = *range_max as f32;
        let ranges = player_view::ranger_ranges(world.ranger_scans(r)?);
        if ranges.len() == *samples {
            scans.extend(ranges.iter().map(|&v| observed_range(v, top)));
        } else {
            scans.extend((0..*samples).map(|_| observed_range(*range_max, top)));
        }
    }
    let mut out = Vec::with_capacity(13);
    let s = world.position_state(robot)?;
    let g = world.global_pose(robot)?;
    let (p, v) = (&s.pose, &s.velocity);
    let stall = if s.stall { 1.0 } else { 0.0 };
    out.extend([p.x, p.y, p.a, v.x, v.y, v.a, stall, g.x, g.y, g.a]);
    if let Some(goal) = goal {
        out.extend(goal_view(goal, g.x, g.y, g.a));
    }
    Ok(Observation { scans, state: out })
}

/// `count` loads of the worldfile `path` with `seed`, made side by side on the simulator's
/// threads with the GIL released: each what `World(path, seed)` gives. `VectorStageEnv`
/// reloads the copies an autoreset restarts with it, so their resets do not load one after
/// another.
#[pyfunction]
pub fn load_worlds(py: Python<'_>, path: PathBuf, seed: u64, count: usize) -> PyResult<Vec<World>> {
    let loaded: Vec<PyResult<World>> = py.allow_threads(|| {
        on_sim_threads(|| {
            (0..count)
                .into_par_iter()
                .map(|_| World::open(path.clone(), seed, None))
                .collect()
        })
    });
    loaded.into_iter().collect()
}
