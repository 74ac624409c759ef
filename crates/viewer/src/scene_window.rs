//! A window that shows scenes drawn elsewhere: the world window for a caller that owns its
//! world and steps it itself, and only now and then hands over a picture of it (a Gymnasium
//! environment's `render()` in `"human"` mode).
//!
//! The window runs on a thread of its own, made on first use and kept for the life of the
//! process: winit allows one event loop per process, and eframe keeps it per thread, so every
//! window of the process opens and closes on that one thread ([`SceneWindow::show`],
//! [`SceneWindow::hide`]). Callers hand it frames ([`SceneWindow::present`]): a [`Scene`]
//! built for a [`View`] of the window's canvas size ([`SceneWindow::canvas_size`]) and a status
//! line; the window paints the latest one. There is one such window per process, shared by
//! whoever presents to it; a forked child gets its own.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{Sender, channel};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::Duration;

use stage_sim::fork::PerProcess;

use crate::canvas;
use crate::error::ViewerError;
use crate::scene::Scene;
use crate::view::View;
use crate::world_window::{display_available, native_options};

/// How long [`SceneWindow::show`] and [`SceneWindow::hide`] wait for the window thread.
const WAIT: Duration = Duration::from_secs(60);

/// Height of the status bar under the canvas (px).
const STATUS_BAR: f32 = 24.0;

/// Where the window is in its life.
#[derive(Clone, Debug, PartialEq)]
enum State {
    /// No window (never opened, or closed by [`SceneWindow::hide`] or its close button).
    Closed,
    /// Asked for, not yet up.
    Opening,
    /// Up and painting.
    Open,
    /// The last opening failed, for this reason.
    Failed(String),
}

/// The latest frame handed over.
struct Frame {
    scene: Arc<Scene>,
    view: View,
    status: String,
}

struct Shared {
    state: Mutex<State>,
    changed: Condvar,
    frame: Mutex<Option<Frame>>,
    /// The canvas size the window last painted at (px).
    canvas: Mutex<[f64; 2]>,
    /// The running window's context, to wake it for a new frame.
    ctx: Mutex<Option<egui::Context>>,
    /// [`SceneWindow::hide`] asked the window to close.
    close: AtomicBool,
    painted: AtomicU64,
}

/// The process's scene window (see the module documentation).
pub struct SceneWindow {
    shared: Arc<Shared>,
    /// Open requests for the window thread, made with it on first use.
    requests: Mutex<Option<Sender<OpenRequest>>>,
}

/// What the window thread is asked to open: a title and a canvas size (px).
type OpenRequest = (String, [f64; 2]);

static WINDOW: PerProcess<SceneWindow> = PerProcess::new();

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

impl SceneWindow {
    /// The process's scene window (not opened until [`SceneWindow::show`]).
    pub fn global() -> &'static SceneWindow {
        WINDOW.get_or_make(|| SceneWindow {
            shared: Arc::new(Shared {
                state: Mutex::new(State::Closed),
                changed: Condvar::new(),
                frame: Mutex::new(None),
                canvas: Mutex::new([0.0, 0.0]),
                ctx: Mutex::new(None),
                close: AtomicBool::new(false),
                painted: AtomicU64::new(0),
            }),
            requests: Mutex::new(None),
        })
    }

    /// Opens the window (titled `title`, its canvas `size` pixels) unless it is open already,
    /// and waits until it is up. [`ViewerError::NoDisplay`] at once without a display; the
    /// window system's or the graphics' error when it cannot be opened.
    pub fn show(&self, title: &str, size: [f64; 2]) -> Result<(), ViewerError> {
        if !display_available() {
            return Err(ViewerError::NoDisplay);
        }
        let sh = &self.shared;
        let mut state = lock(&sh.state);
        if *state == State::Open {
            return Ok(());
        }
        // a window still closing finishes first: the thread opens one at a time
        while *state == State::Opening {
            state = sh.changed.wait(state).unwrap_or_else(|p| p.into_inner());
        }
        if *state == State::Open {
            return Ok(());
        }
        *state = State::Opening;
        sh.close.store(false, Ordering::SeqCst);
        *lock(&sh.canvas) = size;
        self.request(title, size)?;
        let (state, _) = sh
            .changed
            .wait_timeout_while(state, WAIT, |s| *s == State::Opening)
            .unwrap_or_else(|p| p.into_inner());
        match &*state {
            State::Open => Ok(()),
            State::Failed(why) => Err(ViewerError::Window(why.clone())),
            State::Opening => Err(ViewerError::Window(format!(
                "the window did not open within {} s",
                WAIT.as_secs()
            ))),
            State::Closed => Err(ViewerError::Window("the window closed at once".into())),
        }
    }

    /// Sends an open request to the window thread, made on first use.
    fn request(&self, title: &str, size: [f64; 2]) -> Result<(), ViewerError> {
        let mut requests = lock(&self.requests);
        if requests.is_none() {
            let (tx, rx) = channel::<OpenRequest>();
            let shared = self.shared.clone();
            std::thread::Builder::new()
                .name("scene-window".into())
                .spawn(move || {
                    for (title, size) in rx {
                        window_thread_run(&shared, &title, size);
                    }
                })
                .map_err(|e| ViewerError::Window(format!("cannot start its thread: {e}")))?;
            *requests = Some(tx);
        }
        let tx = requests.as_ref().expect("made above");
        tx.send((title.to_string(), size))
            .map_err(|_| ViewerError::Window("its thread is gone".into()))
    }

    /// Whether the window is up (false once closed, by [`SceneWindow::hide`] or its user).
    pub fn is_open(&self) -> bool {
        *lock(&self.shared.state) == State::Open
    }

    /// The canvas size (px) to build the next frame's [`View`] for: the window's, as last
    /// painted (the size asked for until then).
    pub fn canvas_size(&self) -> [f64; 2] {
        *lock(&self.shared.canvas)
    }

    /// Hands the window a frame to paint: `scene`, built for `view`, and a status line.
    pub fn present(&self, scene: Arc<Scene>, view: View, status: String) {
        *lock(&self.shared.frame) = Some(Frame {
            scene,
            view,
            status,
        });
        if let Some(ctx) = &*lock(&self.shared.ctx) {
            ctx.request_repaint();
        }
    }

    /// Frames painted since the process started (every window): a caller can tell its
    /// frames reach the screen.
    pub fn frames_painted(&self) -> u64 {
        self.shared.painted.load(Ordering::SeqCst)
    }

    /// Closes the window, if open, and waits until it is gone (the thread stays for the next
    /// [`SceneWindow::show`]).
    pub fn hide(&self) {
        let sh = &self.shared;
        sh.close.store(true, Ordering::SeqCst);
        if let Some(ctx) = &*lock(&sh.ctx) {
            ctx.request_repaint();
        }
        let state = lock(&sh.state);
        let _ = sh
            .changed
            .wait_timeout_while(state, WAIT, |s| *s == State::Open || *s == State::Opening);
        *lock(&sh.frame) = None;
    }
}

/// One window's life on the window thread: from opening to closing.
fn window_thread_run(shared: &Arc<Shared>, title: &str, size: [f64; 2]) {
    let mut options = native_options(title, [size[0] as f32, size[1] as f32 + STATUS_BAR]);
    // not the main thread: winit must be told that is fine (X11 and Wayland alike)
    options.event_loop_builder = Some(Box::new(|builder| {
        use winit::platform::{wayland::EventLoopBuilderExtWayland, x11::EventLoopBuilderExtX11};
        EventLoopBuilderExtX11::with_any_thread(builder, true);
        EventLoopBuilderExtWayland::with_any_thread(builder, true);
    }));
    let app_shared = shared.clone();
    let run = eframe::run_native(
        title,
        options,
        Box::new(move |cc| {
            canvas::install(cc)?;
            *lock(&app_shared.ctx) = Some(cc.egui_ctx.clone());
            *lock(&app_shared.state) = State::Open;
            app_shared.changed.notify_all();
            Ok(Box::new(SceneApp { shared: app_shared }))
        }),
    );
    *lock(&shared.ctx) = None;
    let mut state = lock(&shared.state);
    *state = match (run, &*state) {
        (Err(e), State::Opening) => State::Failed(e.to_string()),
        _ => State::Closed,
    };
    shared.changed.notify_all();
}

struct SceneApp {
    shared: Arc<Shared>,
}

impl eframe::App for SceneApp {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        if self.shared.close.load(Ordering::SeqCst) {
            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
            return;
        }
        let frame = lock(&self.shared.frame);
        egui::Panel::bottom("status").show(ui, |ui| {
            ui.label(
                frame
                    .as_ref()
                    .map_or("(no frame yet)", |f| f.status.as_str()),
            );
        });
        egui::CentralPanel::no_frame().show(ui, |ui| {
            let (rect, _) = ui.allocate_exact_size(ui.available_size(), egui::Sense::hover());
            *lock(&self.shared.canvas) = [rect.width() as f64, rect.height() as f64];
            if let Some(f) = frame.as_ref() {
                canvas::paint(ui, rect, f.scene.clone(), &f.view);
            }
        });
        self.shared.painted.fetch_add(1, Ordering::SeqCst);
    }
}
