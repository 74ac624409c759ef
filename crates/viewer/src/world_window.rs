//! The Stage world window: the world drawn from a [`WorldHandle`], Stage's View menu, pause/run,
//! the simulated clock, pan/zoom, and dragging and turning models with `gui_move`.
//!
//! # Use from a binary
//!
//! ```no_run
//! # fn demo(world: stage_sim::World, spec: &worldfile::WorldSpec) -> Result<(), viewer::ViewerError> {
//! use viewer::handle::{Pacing, WorldHandle, spawn_simulation};
//! let handle = WorldHandle::from_spec(world, spec);
//! let sim = spawn_simulation(vec![handle.clone()], Pacing { speedup: 1.0 }, |_, _| {})
//!     .expect("a thread");
//! viewer::world_window::run(handle.clone(), viewer::world_window::WindowOptions::default())?;
//! handle.request_quit(); // run returns when the window closes (it also requests the quit)
//! sim.join().ok();
//! # Ok(()) }
//! ```
//!
//! A server that owns and steps the world itself (the `player` binary's stage driver, which
//! keeps it as an `Arc<RwLock<World>>` and honours a pause flag) shares it with
//! [`WorldHandle::from_shared`] and calls [`run`] on the main thread while its core runs on
//! other threads:
//!
//! ```no_run
//! # use std::sync::{Arc, RwLock, atomic::AtomicBool};
//! # fn demo(world: Arc<RwLock<stage_sim::World>>, spec: &worldfile::WorldSpec,
//! #         paused: Arc<AtomicBool>) -> Result<(), viewer::ViewerError> {
//! let handle = viewer::WorldHandle::from_shared(world, spec, paused);
//! viewer::world_window::run(handle.clone(), viewer::world_window::WindowOptions::default())?;
//! assert!(handle.quit_requested()); // the window was closed: shut the server down
//! # Ok(()) }
//! ```
//!
//! [`run`] returns [`ViewerError::NoDisplay`] at once when no display is announced and an error
//! when the window cannot be created; the caller then goes on headless.
//!
//! Controls: wheel zooms at the pointer; left-drag on a movable model moves it, elsewhere pans;
//! right-drag on a movable model turns it, elsewhere turns the view; middle-drag pans; `P` or
//! the Run menu pauses/resumes; `F` fits the world in the window.

use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use egui::{Key, PointerButton, Sense};
use stage_sim::{ModelId, Pose, World};

use crate::canvas;
use crate::error::ViewerError;
use crate::handle::{WorldCommand, WorldHandle};
use crate::scene::Scene;
use crate::view::View;
use crate::world_scene::{self, VisOptions};

/// Why the world calls on the selected or dragged model cannot refuse: it was picked from the
/// world this window shows, which keeps every model for its whole life.
const PICKED: &str = "the selected model was picked from this window's world";

/// Options of [`run`].
#[derive(Clone, Debug, Default)]
pub struct WindowOptions {
    /// Save a PNG of the whole window to this file after `screenshot_after` and close.
    pub screenshot: Option<PathBuf>,
    /// How long to run before the screenshot (wall time).
    pub screenshot_after: Duration,
}

/// Whether a display server is announced (`DISPLAY` or `WAYLAND_DISPLAY`). A window may still
/// fail to open; [`run`] then returns an error and the caller can go on headless.
pub fn display_available() -> bool {
    ["DISPLAY", "WAYLAND_DISPLAY"]
        .iter()
        .any(|v| std::env::var_os(v).is_some_and(|s| !s.is_empty()))
}

/// The native options shared by both windows: wgpu on Vulkan or GL (software ones included).
pub(crate) fn native_options(title: &str, size: [f32; 2]) -> eframe::NativeOptions {
    let mut wgpu_options = egui_wgpu::WgpuConfiguration::default();
    if let egui_wgpu::WgpuSetup::CreateNew(c) = &mut wgpu_options.wgpu_setup {
        if std::env::var_os("WGPU_BACKEND").is_none() {
            c.instance_descriptor.backends = wgpu::Backends::VULKAN | wgpu::Backends::GL;
        }
    }
    eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_title(title)
            .with_inner_size(size)
            .with_app_id("playerstage"),
        renderer: eframe::Renderer::Wgpu,
        wgpu_options,
        ..Default::default()
    }
}

/// Opens the world window on the calling thread (the main thread on most platforms) and runs
/// it until it is closed; closing it calls [`WorldHandle::request_quit`]. The world keeps being
/// stepped by its owner meanwhile.
pub fn run(handle: WorldHandle, options: WindowOptions) -> Result<(), ViewerError> {
    if !display_available() {
        return Err(ViewerError::NoDisplay);
    }
    let w = handle.window().clone();
    let view = View::from_window(&w);
    // the canvas gets the window's `size`; the menu and status bars come on top
    let size = [view.size[0] as f32, view.size[1] as f32 + 48.0];
    let title = format!("{} - Stage (playerstage-rs)", handle.title());
    let result = Arc::new(Mutex::new(None));
    let res2 = result.clone();
    let h2 = handle.clone();
    let run = eframe::run_native(
        &title,
        native_options(&title, size),
        Box::new(move |cc| {
            canvas::install(cc)?;
            Ok(Box::new(WorldApp::new(h2, view, options, res2)))
        }),
    );
    handle.request_quit();
    run.map_err(|e| ViewerError::Window(e.to_string()))?;
    let r = result.lock().unwrap_or_else(|p| p.into_inner()).take();
    r.unwrap_or(Ok(()))
}

/// What a pointer drag on the canvas is doing.
#[derive(Clone, Copy, Debug)]
enum Drag {
    Pan,
    RotateView {
        last: [f64; 2],
    },
    Move {
        model: ModelId,
        grab: [f64; 2],
        start: Pose,
    },
    Turn {
        model: ModelId,
        last_angle: f64,
    },
}

struct WorldApp {
    handle: WorldHandle,
    /// Draw the localisers' estimates ([`WorldHandle::set_estimates`]).
    show_estimates: bool,
    view: View,
    vis: VisOptions,
    selected: Option<ModelId>,
    drag: Option<Drag>,
    scene: Arc<Scene>,
    held: Vec<ModelId>,
    vis_applied: Option<VisOptions>,
    interval: Duration,
    fit_pending: bool,
    frame_times: Vec<f64>,
    options: WindowOptions,
    started: Instant,
    shot_requested: bool,
    result: Arc<Mutex<Option<Result<(), ViewerError>>>>,
}

/// Each estimate as playerv draws a hypothesis (its covariance ellipse, heading and label),
/// over the world, where the robot it belongs to is drawn at its true pose.
fn draw_estimates(estimates: &[crate::handle::Estimate], view: &View, scene: &mut Scene) {
    use crate::playerv::{scene::draw_hypothesis, state::Hypothesis, state::Pose2};
    for e in estimates {
        let h = Hypothesis {
            mean: Pose2 {
                x: e.pose[0],
                y: e.pose[1],
                a: e.pose[2],
            },
            cov: e.cov,
            weight: 1.0,
        };
        draw_hypothesis(scene, &h, Some(e.label.clone()), view.pixel());
    }
}

/// Stage's clock format (`[Stage: 0m 01s 300msec]` without the brackets).
pub fn clock_text(us: u64) -> String {
    let ms = us / 1000;
    let (h, m, s, ms) = (
        ms / 3_600_000,
        (ms / 60_000) % 60,
        (ms / 1000) % 60,
        ms % 1000,
    );
    if h > 0 {
        format!("{h}h{m}m {s:02}s {ms:03}msec")
    } else {
        format!("{m}m {s:02}s {ms:03}msec")
    }
}

impl WorldApp {
    fn new(
        handle: WorldHandle,
        view: View,
        options: WindowOptions,
        result: Arc<Mutex<Option<Result<(), ViewerError>>>>,
    ) -> WorldApp {
        let w = handle.window().clone();
        let fit = w == worldfile::WindowSpec::default();
        WorldApp {
            show_estimates: true,
            vis: VisOptions::from_window(&w),
            interval: Duration::from_millis(w.interval.clamp(1, 1000) as u64),
            handle,
            view,
            selected: None,
            drag: None,
            scene: Arc::new(Scene::default()),
            held: Vec::new(),
            vis_applied: None,
            // the worldfile's view, or the whole world when it has no window entity
            fit_pending: fit,
            frame_times: Vec::new(),
            options,
            started: Instant::now(),
            shot_requested: false,
            result,
        }
    }

    /// Keeps one subscription on every sensor whose data is shown, none on the others.
    fn sync_subscriptions(&mut self, world: &World) {
        if self.vis_applied == Some(self.vis) {
            return;
        }
        let want = world_scene::visualised_sensors(world, &self.vis);
        for m in &self.held {
            if !want.contains(m) {
                self.handle.send(WorldCommand::Unsubscribe(*m));
            }
        }
        for m in &want {
            if !self.held.contains(m) {
                self.handle.send(WorldCommand::Subscribe(*m));
            }
        }
        self.held = want;
        self.vis_applied = Some(self.vis);
    }

    fn menus(&mut self, ui: &mut egui::Ui) {
        egui::MenuBar::new().ui(ui, |ui| {
            ui.menu_button("File", |ui| {
                if ui.button("Quit").clicked() {
                    ui.ctx().send_viewport_cmd(egui::ViewportCommand::Close);
                }
            });
            ui.menu_button("View", |ui| {
                let v = &mut self.vis;
                ui.checkbox(&mut v.data, "Data");
                ui.checkbox(&mut v.blocks, "Blocks");
                ui.checkbox(&mut v.grid, "Grid");
                ui.checkbox(&mut v.bounding_boxes, "Bounding boxes");
                ui.checkbox(&mut v.clock, "Clock");
                ui.checkbox(&mut v.speech, "Speech bubbles");
                ui.separator();
                ui.label("Ranger");
                ui.checkbox(&mut v.ranger_ranges, "Footprints (ranges)");
                ui.checkbox(&mut v.ranger_beams, "Rays (beams)");
                ui.checkbox(&mut v.ranger_strikes, "Strikes");
                ui.checkbox(&mut v.ranger_fov, "Field of view");
                ui.checkbox(&mut v.ranger_transducers, "Transducers");
                ui.separator();
                ui.checkbox(&mut v.fiducial, "Fiducial links");
                ui.checkbox(&mut v.fiducial_fov, "Fiducial field of view");
                ui.checkbox(&mut v.blobfinder, "Blobfinder images");
                ui.checkbox(&mut v.gripper, "Gripper beams");
                ui.checkbox(&mut v.camera, "Camera frustums");
                ui.checkbox(&mut v.blinken, "Blinkenlights");
                ui.checkbox(&mut v.position_coords, "Position coordinates");
                ui.checkbox(
                    &mut self.show_estimates,
                    "Localisation estimates (beside the true pose)",
                );
                ui.separator();
                if ui.button("Fit world (F)").clicked() {
                    self.fit_pending = true;
                }
                if ui.button("Reset view").clicked() {
                    let size = self.view.size;
                    self.view = View::from_window(self.handle.window());
                    self.view.size = size;
                }
            });
            ui.menu_button("Run", |ui| {
                let paused = self.handle.paused();
                if ui
                    .button(if paused { "Run (P)" } else { "Pause (P)" })
                    .clicked()
                {
                    self.handle.set_paused(!paused);
                }
            });
        });
    }

    fn status(&mut self, ui: &mut egui::Ui, world: &World) {
        ui.horizontal(|ui| {
            if self.vis.clock {
                ui.monospace(format!("[Stage: {}]", clock_text(world.sim_time())));
            }
            if self.handle.paused() {
                ui.colored_label(egui::Color32::from_rgb(200, 0, 0), "[Paused]");
            }
            if let Some(m) = self.selected {
                let p = world.global_pose(m).expect(PICKED);
                ui.label(format!(
                    "{}  ({:.2}, {:.2}, {:.1}°)",
                    world.name(m).expect(PICKED),
                    p.x,
                    p.y,
                    p.a.to_degrees()
                ));
            }
            let n = self.frame_times.len();
            if n > 1 {
                let span = self.frame_times[n - 1] - self.frame_times[0];
                if span > 0.0 {
                    ui.label(format!("{:.0} fps", (n - 1) as f64 / span));
                }
            }
        });
    }

    fn interact(&mut self, ui: &egui::Ui, resp: &egui::Response, world: &World) {
        let rect = resp.rect;
        let to_local = |p: egui::Pos2| canvas::local(rect, p);
        canvas::zoom_on_scroll(&mut self.view, ui, resp);
        let gui = self.handle.gui();
        let pressed = |b| resp.drag_started_by(b);
        if let Some(pos) = resp.interact_pointer_pos() {
            let local = to_local(pos);
            let wp = self.view.to_world(local);
            if pressed(PointerButton::Primary) {
                let hit = world_scene::pick(world, gui, wp, true);
                self.selected = hit;
                self.drag = Some(match hit {
                    Some(m) => Drag::Move {
                        model: m,
                        grab: wp,
                        start: world.global_pose(m).expect(PICKED),
                    },
                    None => Drag::Pan,
                });
            } else if pressed(PointerButton::Secondary) {
                let hit = world_scene::pick(world, gui, wp, true);
                self.drag = Some(match hit {
                    Some(m) => {
                        self.selected = Some(m);
                        let g = world.global_pose(m).expect(PICKED);
                        Drag::Turn {
                            model: m,
                            last_angle: (wp[1] - g.y).atan2(wp[0] - g.x),
                        }
                    }
                    None => Drag::RotateView { last: local },
                });
            } else if pressed(PointerButton::Middle) {
                self.drag = Some(Drag::Pan);
            }
            if resp.dragged() {
                let d = resp.drag_delta();
                match self.drag {
                    Some(Drag::Pan) => self.view.pan_pixels(d.x as f64, d.y as f64),
                    Some(Drag::RotateView { last }) => {
                        let c = [self.view.size[0] / 2.0, self.view.size[1] / 2.0];
                        let a0 = (last[1] - c[1]).atan2(last[0] - c[0]);
                        let a1 = (local[1] - c[1]).atan2(local[0] - c[0]);
                        // screen y points down: a clockwise screen turn is a positive yaw
                        self.view.rotate(-(a1 - a0));
                        self.drag = Some(Drag::RotateView { last: local });
                    }
                    Some(Drag::Move { model, grab, start }) => {
                        let target = Pose::new(
                            start.x + wp[0] - grab[0],
                            start.y + wp[1] - grab[1],
                            start.z,
                            start.a,
                        );
                        self.set_global(world, model, target);
                    }
                    Some(Drag::Turn { model, last_angle }) => {
                        let g = world.global_pose(model).expect(PICKED);
                        let a = (wp[1] - g.y).atan2(wp[0] - g.x);
                        let target = Pose::new(g.x, g.y, g.z, g.a + (a - last_angle));
                        self.set_global(world, model, target);
                        self.drag = Some(Drag::Turn {
                            model,
                            last_angle: a,
                        });
                    }
                    None => {}
                }
            }
        }
        if resp.drag_stopped() {
            self.drag = None;
        }
        if resp.clicked() {
            let wp = resp
                .interact_pointer_pos()
                .map(|p| self.view.to_world(to_local(p)));
            if let Some(wp) = wp {
                self.selected = world_scene::pick(world, gui, wp, true);
            }
        }
    }

    /// Moves `m` so its global pose becomes `target` (in its parent's frame for children).
    fn set_global(&self, world: &World, m: ModelId, target: Pose) {
        let z = world.pose(m).expect(PICKED).z;
        let local = match world.parent(m).expect(PICKED) {
            None => Pose::new(target.x, target.y, z, target.a),
            Some(p) => {
                let mut l = world.global_pose(p).expect(PICKED).relative(&target);
                l.z = z;
                l
            }
        };
        self.handle.send(WorldCommand::SetPose(m, local));
    }

    fn screenshot(&mut self, ctx: &egui::Context) {
        let Some(path) = self.options.screenshot.clone() else {
            return;
        };
        if self.shot_requested || self.started.elapsed() < self.options.screenshot_after {
            return;
        }
        self.shot_requested = true;
        let result = self.result.clone();
        let ctx2 = ctx.clone();
        ctx.request_screenshot(move |img| {
            let r = save_png(&path, img.size[0] as u32, img.size[1] as u32, img.as_raw());
            *result.lock().unwrap_or_else(|p| p.into_inner()) = Some(r);
            ctx2.send_viewport_cmd(egui::ViewportCommand::Close);
            ctx2.request_repaint();
        });
    }
}

/// Writes RGBA pixels as a PNG.
pub fn save_png(path: &std::path::Path, w: u32, h: u32, rgba: &[u8]) -> Result<(), ViewerError> {
    let io = |e: std::io::Error| ViewerError::Io {
        path: path.display().to_string(),
        source: e,
    };
    let img = image::RgbaImage::from_raw(w, h, rgba.to_vec())
        .ok_or_else(|| ViewerError::Gpu("screenshot size does not match its pixels".into()))?;
    img.save(path)
        .map_err(|e| io(std::io::Error::other(e.to_string())))
}

impl eframe::App for WorldApp {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        let now = self.started.elapsed().as_secs_f64();
        self.frame_times.push(now);
        if self.frame_times.len() > 60 {
            self.frame_times.remove(0);
        }
        if ctx.input(|i| i.key_pressed(Key::P)) {
            self.handle.set_paused(!self.handle.paused());
        }
        if ctx.input(|i| i.key_pressed(Key::F)) {
            self.fit_pending = true;
        }
        egui::Panel::top("menu").show(ui, |ui| self.menus(ui));
        let handle = self.handle.clone();
        // last frame's edits (drags, visualisation subscriptions) before this frame's read
        handle.apply_pending();
        // one short read lock per frame: scene build, status and picking
        {
            let world = handle.read();
            egui::Panel::bottom("status").show(ui, |ui| self.status(ui, &world));
            self.sync_subscriptions(&world);
            egui::CentralPanel::no_frame().show(ui, |ui| {
                let (rect, resp) =
                    ui.allocate_exact_size(ui.available_size(), Sense::click_and_drag());
                self.view.size = [rect.width() as f64, rect.height() as f64];
                if self.fit_pending {
                    let (min, max) = world_scene::world_extent(&world);
                    self.view.fit(min, max);
                    self.fit_pending = false;
                }
                self.interact(ui, &resp, &world);
                let mut scene = std::mem::take(&mut self.scene);
                let s = Arc::make_mut(&mut scene);
                let sel: Vec<ModelId> = self.selected.into_iter().collect();
                world_scene::build(&world, self.handle.gui(), &self.vis, &self.view, &sel, s);
                if self.show_estimates {
                    draw_estimates(&self.handle.estimates(), &self.view, s);
                }
                canvas::paint(ui, rect, scene.clone(), &self.view);
                self.scene = scene;
            });
        }
        self.screenshot(&ctx);
        if self.handle.quit_requested() {
            // the owner is going away (e.g. the server got SIGINT): close with it
            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
        }
        ctx.request_repaint_after(self.interval);
    }

    fn on_exit(&mut self) {
        self.handle.request_quit();
    }
}

#[cfg(test)]
mod tests {
    use super::clock_text;

    #[test]
    fn clock_text_matches_stage() {
        assert_eq!(clock_text(1_300_000), "0m 01s 300msec");
        assert_eq!(clock_text(3_725_100_000), "1h2m 05s 100msec");
    }
}
