//! playerv: a Player client that shows a server's devices and draws the subscribed ones around
//! the robot, with PUSH/PULL choice and position control by dragging a bull's-eye.
//!
//! The client runs on its own thread ([`worker`]); the window ([`run`]) shows its snapshots.
//! Menus: *Devices* lists every device with its driver (tick to subscribe, untick to
//! unsubscribe), *Data* chooses PUSH or PULL and the read rate, *Position* chooses how the
//! first subscribed position2d is commanded: off, velocity (the target's offset sets the
//! speed and turn rate) or position (the target becomes a goal in the odometry frame). With a
//! command mode on, left-drag places the target; otherwise left-drag pans; the wheel zooms.
//!
//! With a navigation stack (map, planner, localize devices) the view is the map's, and the
//! canvas takes playernav's clicks ([`nav_request`]): a left click (or drag, for the heading)
//! sends the planner a goal, a right drag tells the localiser where the robot is (SET_POSE
//! with playernav's covariance); *Navigation* has Go and Stop (the planner's ENABLE) and shows
//! the particle cloud on request. The middle button always pans.

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
use player_proto::InterfaceCode;
use state::{CommandMode, DeviceKey, PlayervState, Pose2};
use worker::{Request, Worker};

/// What a click or drag on the map does (playernav's buttons).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NavAction {
    /// Send the planner a goal.
    Goal,
    /// Tell the localiser where the robot is.
    Pose,
}

/// The covariance playernav gives a pose set by hand: 0.5 m in x and y, 30° in heading (as
/// variances).
pub const SET_POSE_COV: [f64; 3] = [
    0.25,
    0.25,
    (std::f64::consts::PI / 6.0) * (std::f64::consts::PI / 6.0),
];

/// Drags shorter than this (pixels) are clicks: no heading is read from them.
const CLICK_SLOP: f64 = 5.0;

/// The request a click or drag on the canvas makes, from where the button went down to where
/// it came up (canvas pixels), as playernav reads them: the pose is where it went down, its
/// heading the drag's direction. A click gives a goal the heading of the way from the robot to
/// it, and a pose the robot's current heading. `None` without a planner (goal) or a localiser
/// (pose), or outside the map frame.
pub fn nav_request(
    st: &PlayervState,
    view: &View,
    action: NavAction,
    press: [f64; 2],
    release: [f64; 2],
) -> Option<Request> {
    let robot = st.robot_in_map()?;
    let at = view.to_world(press);
    let to = view.to_world(release);
    let dragged = (release[0] - press[0]).hypot(release[1] - press[1]) > CLICK_SLOP;
    let heading = if dragged {
        (to[1] - at[1]).atan2(to[0] - at[0])
    } else {
        match action {
            NavAction::Goal => (at[1] - robot.y).atan2(at[0] - robot.x),
            NavAction::Pose => robot.a,
        }
    };
    let pose = Pose2 {
        x: at[0],
        y: at[1],
        a: heading,
    };
    match action {
        NavAction::Goal => {
            let (k, _) = st.first(InterfaceCode::PLANNER)?;
            Some(Request::SetGoal(k, pose))
        }
        NavAction::Pose => {
            let (k, _) = st.first(InterfaceCode::LOCALIZE)?;
            Some(Request::SetPose(k, pose, SET_POSE_COV))
        }
    }
}

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
    /// More servers shown on the same canvas (playernav's `host:port` arguments: one robot
    /// each, subscribed to the same devices).
    pub more_servers: Vec<(String, u16)>,
    /// Fetch and draw localisers' particles from the start.
    pub particles: bool,
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
            canvas::install(cc)?;
            let servers = std::iter::once((options.host.clone(), options.port))
                .chain(options.more_servers.clone());
            let workers = servers
                .map(|(host, port)| {
                    let ctx = cc.egui_ctx.clone();
                    Worker::spawn(
                        &host,
                        port,
                        options.mode,
                        options.rate_hz,
                        options.devices.clone(),
                        move || ctx.request_repaint(),
                    )
                })
                .collect();
            let workers: Vec<Worker> = workers;
            if options.particles {
                for w in &workers {
                    w.send(Request::ShowParticles(true));
                }
            }
            Ok(Box::new(PlayervApp::new(workers, options, res2)))
        }),
    )
    .map_err(|e| ViewerError::Window(e.to_string()))?;
    let r = result.lock().unwrap_or_else(|p| p.into_inner()).take();
    r.unwrap_or(Ok(()))
}

struct PlayervApp {
    /// One client per server, the first one's first.
    workers: Vec<Worker>,
    /// The server whose robot the menus, commands and clicks address.
    selected: usize,
    view: View,
    command: CommandMode,
    target: Pose2,
    dragging_target: bool,
    /// A playernav click or drag under way: what it does, and where it started and is now.
    nav_drag: Option<(NavAction, [f64; 2], [f64; 2])>,
    /// The view was placed over the map once it came.
    fitted_map: bool,
    scene: Arc<Scene>,
    options: PlayervOptions,
    started: Instant,
    shot_requested: bool,
    result: Arc<Mutex<Option<Result<(), ViewerError>>>>,
}

impl PlayervApp {
    fn new(
        workers: Vec<Worker>,
        options: PlayervOptions,
        result: Arc<Mutex<Option<Result<(), ViewerError>>>>,
    ) -> Self {
        PlayervApp {
            workers,
            selected: 0,
            view: View {
                center: [1.5, 0.0],
                scale: 60.0,
                yaw: 0.0,
                size: [600.0, 600.0],
            },
            command: CommandMode::Off,
            target: Pose2::default(),
            dragging_target: false,
            nav_drag: None,
            fitted_map: false,
            scene: Arc::new(Scene::default()),
            options,
            started: Instant::now(),
            shot_requested: false,
            result,
        }
    }

    /// The client of the selected server.
    fn worker(&self) -> &Worker {
        &self.workers[self.selected.min(self.workers.len() - 1)]
    }

    /// Sends `r` to every server's client (data mode, rate, particles).
    fn to_all(&self, r: Request) {
        for w in &self.workers {
            w.send(r.clone());
        }
    }

    fn menus(&mut self, ui: &mut egui::Ui, st: &PlayervState, servers: &[String]) {
        egui::MenuBar::new().ui(ui, |ui| {
            ui.menu_button("File", |ui| {
                if ui.button("Quit").clicked() {
                    ui.ctx().send_viewport_cmd(egui::ViewportCommand::Close);
                }
            });
            if servers.len() > 1 {
                ui.menu_button("Robot", |ui| {
                    for (i, name) in servers.iter().enumerate() {
                        ui.radio_value(&mut self.selected, i, name);
                    }
                });
            }
            ui.menu_button("Devices", |ui| {
                if st.devices.is_empty() {
                    ui.label("(no devices)");
                }
                for (key, driver) in &st.devices {
                    let mut on = st.subscribed.contains_key(key);
                    if ui.checkbox(&mut on, format!("{key} ({driver})")).changed() {
                        self.worker().send(if on {
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
                    self.to_all(Request::SetMode(mode));
                }
                let mut rate = st.rate_hz;
                if ui
                    .add(egui::Slider::new(&mut rate, 0.5..=30.0).text("reads/s"))
                    .changed()
                {
                    self.to_all(Request::SetRate(rate));
                }
            });
            ui.menu_button("Navigation", |ui| {
                let planner = st.first(InterfaceCode::PLANNER).map(|(k, _)| k);
                let localize = st.first(InterfaceCode::LOCALIZE).map(|(k, _)| k);
                ui.label(match planner {
                    Some(k) => format!("left click/drag: goal for {k}"),
                    None => "no planner subscribed".into(),
                });
                ui.label(match localize {
                    Some(k) => format!("right drag: pose for {k}"),
                    None => "no localize subscribed".into(),
                });
                if let Some(k) = planner {
                    if ui.button("Go").clicked() {
                        self.worker().send(Request::PlannerEnable(k, true));
                    }
                    if ui.button("Stop").clicked() {
                        self.worker().send(Request::PlannerEnable(k, false));
                    }
                }
                let mut particles = st.particles;
                if ui.checkbox(&mut particles, "Show particles").changed() {
                    self.to_all(Request::ShowParticles(particles));
                }
                if ui.button("Fit map").clicked() {
                    self.fitted_map = false;
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
                        self.worker().send(Request::Stop(k));
                    }
                    if ui.button("Enable motors").clicked() {
                        self.worker().send(Request::MotorPower(k, true));
                    }
                    if ui.button("Disable motors").clicked() {
                        self.worker().send(Request::MotorPower(k, false));
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
            // playervcr's buttons for a log device
            if let state::DeviceData::Log { reading, active } = s.data {
                ui.horizontal(|ui| {
                    let (start, stop) = if reading {
                        ("Play", "Pause")
                    } else {
                        ("Record", "Stop")
                    };
                    if ui.add_enabled(!active, egui::Button::new(start)).clicked() {
                        self.worker().send(Request::LogActive(*key, true));
                    }
                    if ui.add_enabled(active, egui::Button::new(stop)).clicked() {
                        self.worker().send(Request::LogActive(*key, false));
                    }
                    if reading && ui.button("Rewind").clicked() {
                        self.worker().send(Request::LogRewind(*key));
                    }
                });
            }
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
        let to_local = |p: egui::Pos2| canvas::local(rect, p);
        canvas::zoom_on_scroll(&mut self.view, ui, resp);
        // playernav's clicks, on the map frame and when no command mode takes the left button.
        if st.map_frame() {
            let left = self.command == CommandMode::Off;
            let action = |b: PointerButton| match b {
                PointerButton::Primary if left => Some(NavAction::Goal),
                PointerButton::Secondary => Some(NavAction::Pose),
                _ => None,
            };
            for b in [PointerButton::Primary, PointerButton::Secondary] {
                if let (Some(a), Some(pos)) = (action(b), resp.interact_pointer_pos()) {
                    if resp.drag_started_by(b) {
                        self.nav_drag = Some((a, to_local(pos), to_local(pos)));
                    } else if resp.clicked_by(b) {
                        if let Some(r) =
                            nav_request(st, &self.view, a, to_local(pos), to_local(pos))
                        {
                            self.worker().send(r);
                        }
                    }
                }
            }
            if let (Some(d), Some(pos)) = (&mut self.nav_drag, resp.interact_pointer_pos()) {
                d.2 = to_local(pos);
            }
            if resp.drag_stopped() {
                if let Some((a, press, release)) = self.nav_drag.take() {
                    if let Some(r) = nav_request(st, &self.view, a, press, release) {
                        self.worker().send(r);
                    }
                }
            }
            if self.nav_drag.is_some() || resp.dragged_by(PointerButton::Secondary) {
                return;
            }
            if resp.dragged_by(PointerButton::Middle) {
                let d = resp.drag_delta();
                self.view.pan_pixels(d.x as f64, d.y as f64);
                return;
            }
        }
        let base = st.base().map(|(k, _)| k);
        if resp.drag_started_by(PointerButton::Primary) || resp.clicked() {
            self.dragging_target = self.command != CommandMode::Off && base.is_some();
        }
        if let Some(pos) = resp.interact_pointer_pos() {
            if self.dragging_target && (resp.dragged_by(PointerButton::Primary) || resp.clicked()) {
                let w = self.view.to_world(to_local(pos));
                // The target is kept in the robot's frame, whatever frame the view is in.
                let frame = st.robot_in_map().unwrap_or_default();
                let t = scene::relative(
                    frame,
                    Pose2 {
                        x: w[0],
                        y: w[1],
                        a: frame.a,
                    },
                );
                self.target = Pose2 { a: 0.0, ..t };
                if let Some(k) = base {
                    self.worker().send(Request::Drive {
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
        Map(m) => format!("{}×{} cells of {:.3} m", m.width, m.height, m.scale),
        Planner(p) => format!(
            "{}, goal ({:.2}, {:.2}), {} waypoint(s)",
            if p.done {
                "done"
            } else if p.valid {
                "driving"
            } else {
                "no path"
            },
            p.goal.x,
            p.goal.y,
            p.waypoints.len()
        ),
        Localize {
            hypotheses,
            particles,
        } => match hypotheses.first() {
            Some(h) => format!(
                "{} hypothes{}, best ({:.2}, {:.2}, {:.0}°){}",
                hypotheses.len(),
                if hypotheses.len() == 1 { "is" } else { "es" },
                h.mean.x,
                h.mean.y,
                h.mean.a.to_degrees(),
                if particles.is_empty() {
                    String::new()
                } else {
                    format!(", {} particles", particles.len())
                }
            ),
            None => "no hypotheses yet".into(),
        },
        Log { reading, active } => match (reading, active) {
            (true, true) => "replaying".into(),
            (true, false) => "replay paused".into(),
            (false, true) => "recording".into(),
            (false, false) => "not recording".into(),
        },
        Other => "no data drawn".into(),
    }
}

impl eframe::App for PlayervApp {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        let states: Vec<PlayervState> = self.workers.iter().map(Worker::state).collect();
        let servers: Vec<String> = states.iter().map(|s| s.server.clone()).collect();
        let st = states[self.selected.min(states.len() - 1)].clone();
        egui::Panel::top("menu").show(ui, |ui| self.menus(ui, &st, &servers));
        egui::Panel::left("devices")
            .default_size(260.0)
            .show(ui, |ui| self.side(ui, &st));
        egui::CentralPanel::no_frame().show(ui, |ui| {
            let (rect, resp) = ui.allocate_exact_size(ui.available_size(), Sense::click_and_drag());
            self.view.size = [rect.width() as f64, rect.height() as f64];
            self.interact(ui, &resp, &st);
            // The server with the map draws it; every other robot goes on top.
            let has_map = |s: &PlayervState| {
                s.subscribed.values().find_map(|d| match &d.data {
                    state::DeviceData::Map(m) => Some(m.clone()),
                    _ => None,
                })
            };
            let first = states
                .iter()
                .position(|s| has_map(s).is_some())
                .unwrap_or(self.selected);
            if !self.fitted_map {
                if let Some(m) = states.get(first).and_then(has_map) {
                    self.view.fit(m.origin, m.far_corner());
                    self.fitted_map = true;
                }
            }
            let mut scene = std::mem::take(&mut self.scene);
            let target = (self.command != CommandMode::Off).then_some((self.command, self.target));
            let mine = |i: usize| if i == self.selected { target } else { None };
            let sc = Arc::make_mut(&mut scene);
            let mut inset = scene::build(&states[first], mine(first), &self.view, sc);
            for (i, other) in states.iter().enumerate() {
                if i != first {
                    inset = scene::add_robot(other, mine(i), &self.view, sc, inset);
                }
            }
            if let Some((action, press, now)) = self.nav_drag {
                let c = match action {
                    NavAction::Goal => scene::GOAL,
                    NavAction::Pose => scene::HYPOTHESIS,
                };
                Arc::make_mut(&mut scene).line(
                    crate::scene::Layer::Overlay,
                    self.view.to_world(press),
                    self.view.to_world(now),
                    2.0,
                    c,
                );
            }
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
