//! playerv: a Player client that shows a server's devices and draws the subscribed ones around
//! the robot, with PUSH/PULL choice and position control by dragging a bull's-eye.
//!
//! The client runs on its own thread ([`worker`]); the window ([`run`]) shows its snapshots.
//! Menus: *Devices* lists every device with its driver (tick to subscribe, untick to
//! unsubscribe), *Data* chooses PUSH or PULL and the read rate, *Position* chooses how the
//! first subscribed position2d is commanded: off, velocity (the target's offset sets the
//! speed and turn rate) or position (the target becomes a goal in the odometry frame). With a
//! command mode on, left-drag places the target; otherwise left-drag pans; the wheel zooms.

pub mod scene;
pub mod state;
pub mod worker;

use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use egui::{PointerButton, Sense};
use player_client::DataMode;

use crate::canvas;
use crate::error::ViewerError;
use crate::scene::Scene;
use crate::view::View;
use state::{CommandMode, DeviceKey, PlayervState, Pose2};
use worker::{Request, Worker};

/// What `playerv` starts with.
#[derive(Clone, Debug)]
pub struct PlayervOptions {
    /// Server host.
    pub host: String,
    /// Server port.
    pub port: u16,
    /// Devices to subscribe at start (`--ranger:0` …).
    pub devices: Vec<DeviceKey>,
    /// PUSH or PULL.
    pub mode: DataMode,
    /// Reads per second.
    pub rate_hz: f64,
    /// Save a PNG of the window after `screenshot_after` and close.
    pub screenshot: Option<PathBuf>,
    /// Wall time before the screenshot.
    pub screenshot_after: Duration,
}

/// Opens the playerv window (on the calling thread) and runs until it is closed.
pub fn run(options: PlayervOptions) -> Result<(), ViewerError> {
    if !crate::world_window::display_available() {
        return Err(ViewerError::NoDisplay);
    }
    let title = format!("playerv - {}:{}", options.host, options.port);
    let result = Arc::new(Mutex::new(None));
    let res2 = result.clone();
    eframe::run_native(
        &title,
        crate::world_window::native_options(&title, [900.0, 640.0]),
        Box::new(move |cc| {
            let rs = cc
                .wgpu_render_state
                .as_ref()
                .ok_or("eframe started without wgpu")?;
            canvas::install(rs);
            let ctx = cc.egui_ctx.clone();
            let worker = Worker::spawn(
                &options.host,
                options.port,
                options.mode,
                options.rate_hz,
                options.devices.clone(),
                move || ctx.request_repaint(),
            );
            Ok(Box::new(PlayervApp::new(worker, options, res2)))
        }),
    )
    .map_err(|e| ViewerError::Window(e.to_string()))?;
    let r = result.lock().unwrap_or_else(|p| p.into_inner()).take();
    r.unwrap_or(Ok(()))
}

struct PlayervApp {
    worker: Worker,
    view: View,
    command: CommandMode,
    target: Pose2,
    dragging_target: bool,
    scene: Arc<Scene>,
    options: PlayervOptions,
    started: Instant,
    shot_requested: bool,
    result: Arc<Mutex<Option<Result<(), ViewerError>>>>,
}

impl PlayervApp {
    fn new(
        worker: Worker,
        options: PlayervOptions,
        result: Arc<Mutex<Option<Result<(), ViewerError>>>>,
    ) -> Self {
        PlayervApp {
            worker,
            view: View {
                center: [1.5, 0.0],
                scale: 60.0,
                yaw: 0.0,
                size: [600.0, 600.0],
            },
            command: CommandMode::Off,
            target: Pose2::default(),
            dragging_target: false,
            scene: Arc::new(Scene::default()),
            options,
            started: Instant::now(),
            shot_requested: false,
            result,
        }
    }

    fn menus(&mut self, ui: &mut egui::Ui, st: &PlayervState) {
        egui::MenuBar::new().ui(ui, |ui| {
            ui.menu_button("File", |ui| {
                if ui.button("Quit").clicked() {
                    ui.ctx().send_viewport_cmd(egui::ViewportCommand::Close);
                }
            });
            ui.menu_button("Devices", |ui| {
                if st.devices.is_empty() {
                    ui.label("(no devices)");
                }
                for (key, driver) in &st.devices {
                    let mut on = st.subscribed.contains_key(key);
                    if ui.checkbox(&mut on, format!("{key} ({driver})")).changed() {
                        self.worker.send(if on {
                            Request::Subscribe(*key)
                        } else {
                            Request::Unsubscribe(*key)
                        });
                    }
                }
            });
            ui.menu_button("Data", |ui| {
                let mut mode = st.mode;
                ui.radio_value(&mut mode, DataMode::Pull, "PULL (one round per read)");
                ui.radio_value(&mut mode, DataMode::Push, "PUSH (everything as published)");
                if mode != st.mode {
                    self.worker.send(Request::SetMode(mode));
                }
                let mut rate = st.rate_hz;
                if ui
                    .add(egui::Slider::new(&mut rate, 0.5..=30.0).text("reads/s"))
                    .changed()
                {
                    self.worker.send(Request::SetRate(rate));
                }
            });
            ui.menu_button("Position", |ui| {
                let base = st.base().map(|(k, _)| k);
                ui.label(match base {
                    Some(k) => format!("commanding {k}"),
                    None => "no position2d subscribed".into(),
                });
                ui.radio_value(&mut self.command, CommandMode::Off, "Command off");
                ui.radio_value(&mut self.command, CommandMode::Velocity, "Velocity mode");
                ui.radio_value(&mut self.command, CommandMode::Position, "Position mode");
                if let Some(k) = base {
                    if ui.button("Stop").clicked() {
                        self.target = Pose2::default();
                        self.worker.send(Request::Stop(k));
                    }
                    if ui.button("Enable motors").clicked() {
                        self.worker.send(Request::MotorPower(k, true));
                    }
                    if ui.button("Disable motors").clicked() {
                        self.worker.send(Request::MotorPower(k, false));
                    }
                }
            });
        });
    }

    fn side(&self, ui: &mut egui::Ui, st: &PlayervState) {
        ui.heading(&st.server);
        ui.label(if st.connected {
            format!("{}  time {:.3} s", st.banner, st.datatime)
        } else {
            "not connected".into()
        });
        ui.label(format!(
            "{} mode, {:.1} reads/s",
            match st.mode {
                DataMode::Pull => "PULL",
                DataMode::Push => "PUSH",
            },
            st.rate_hz
        ));
        ui.separator();
        ui.strong("Devices");
        egui::Grid::new("devices").striped(true).show(ui, |ui| {
            for (key, driver) in &st.devices {
                let sub = st.subscribed.contains_key(key);
                ui.monospace(if sub { "[x]" } else { "[ ]" });
                ui.label(key.to_string());
                ui.label(driver);
                ui.end_row();
            }
        });
        ui.separator();
        for (key, s) in &st.subscribed {
            ui.label(format!("{key}: {}", describe(&s.data)));
        }
        ui.separator();
        egui::ScrollArea::vertical().show(ui, |ui| {
            for l in st.log.iter().rev().take(12) {
                ui.small(l);
            }
        });
    }

    fn interact(&mut self, ui: &egui::Ui, resp: &egui::Response, st: &PlayervState) {
        let rect = resp.rect;
        let to_local = |p: egui::Pos2| [(p.x - rect.min.x) as f64, (p.y - rect.min.y) as f64];
        if let Some(hover) = resp.hover_pos() {
            let scroll = ui.input(|i| i.smooth_scroll_delta.y + i.zoom_delta().ln() * 200.0);
            if scroll != 0.0 {
                self.view
                    .zoom_at(to_local(hover), (scroll as f64 / 200.0).exp());
            }
        }
        let base = st.base().map(|(k, _)| k);
        if resp.drag_started_by(PointerButton::Primary) || resp.clicked() {
            self.dragging_target = self.command != CommandMode::Off && base.is_some();
        }
        if let Some(pos) = resp.interact_pointer_pos() {
            if self.dragging_target && (resp.dragged_by(PointerButton::Primary) || resp.clicked()) {
                let w = self.view.to_world(to_local(pos));
                self.target = Pose2 {
                    x: w[0],
                    y: w[1],
                    a: 0.0,
                };
                if let Some(k) = base {
                    self.worker.send(Request::Drive {
                        device: k,
                        mode: self.command,
                        target: self.target,
                    });
                }
            } else if resp.dragged() {
                let d = resp.drag_delta();
                self.view.pan_pixels(d.x as f64, d.y as f64);
            }
        }
        if resp.drag_stopped() {
            self.dragging_target = false;
        }
    }
}

/// One line about a device's data for the side panel.
fn describe(d: &state::DeviceData) -> String {
    use state::DeviceData::*;
    match d {
        Position2d { pose, stall, .. } => format!(
            "pose ({:.2}, {:.2}, {:.0}°){}",
            pose.x,
            pose.y,
            pose.a.to_degrees(),
            if *stall { " stalled" } else { "" }
        ),
        Ranges { scans } => {
            let n: usize = scans.iter().map(|s| s.ranges.len()).sum();
            let min = scans
                .iter()
                .flat_map(|s| s.ranges.iter().copied())
                .fold(f64::INFINITY, f64::min);
            if n == 0 {
                "no ranges yet".into()
            } else {
                format!("{n} ranges, nearest {min:.2} m")
            }
        }
        Blobs { size, blobs } => format!("{} blob(s) in {}×{}", blobs.len(), size[0], size[1]),
        Fiducials { items, .. } => format!("{} fiducial(s)", items.len()),
        Gripper { state, beams, .. } => {
            let s = match *state {
                1 => "open",
                2 => "closed",
                3 => "moving",
                _ => "error",
            };
            format!("{s}, beams {beams:#b}")
        }
        Camera { width, height, .. } => format!("{width}×{height} image"),
        Other => "no data drawn".into(),
    }
}

impl eframe::App for PlayervApp {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        let st = self.worker.state();
        egui::Panel::top("menu").show(ui, |ui| self.menus(ui, &st));
        egui::Panel::left("devices")
            .default_size(260.0)
            .show(ui, |ui| self.side(ui, &st));
        egui::CentralPanel::no_frame().show(ui, |ui| {
            let (rect, resp) = ui.allocate_exact_size(ui.available_size(), Sense::click_and_drag());
            self.view.size = [rect.width() as f64, rect.height() as f64];
            self.interact(ui, &resp, &st);
            let mut scene = std::mem::take(&mut self.scene);
            let target = (self.command != CommandMode::Off).then_some((self.command, self.target));
            scene::build(&st, target, &self.view, Arc::make_mut(&mut scene));
            canvas::paint(ui, rect, scene.clone(), &self.view);
            self.scene = scene;
        });
        if let Some(path) = self.options.screenshot.clone() {
            if !self.shot_requested && self.started.elapsed() >= self.options.screenshot_after {
                self.shot_requested = true;
                let result = self.result.clone();
                let ctx2 = ctx.clone();
                ctx.request_screenshot(move |img| {
                    let r = crate::world_window::save_png(
                        &path,
                        img.size[0] as u32,
                        img.size[1] as u32,
                        img.as_raw(),
                    );
                    *result.lock().unwrap_or_else(|p| p.into_inner()) = Some(r);
                    ctx2.send_viewport_cmd(egui::ViewportCommand::Close);
                    ctx2.request_repaint();
                });
            }
            ctx.request_repaint_after(Duration::from_millis(50));
        }
    }
}
