//! Sharing a world between its owner (the thread that steps it: the `stage` binary's simulation
//! thread, or the `player` server's stage driver) and the world window.
//!
//! Both modes hold the world as an `Arc<RwLock<World>>` and the pause flag as an
//! `Arc<AtomicBool>`; the window reads the world under a short read lock once per frame while it
//! builds its scene, so neither side stalls the other for long.
//!
//! * Owned ([`WorldHandle::new`], [`WorldHandle::from_spec`]): the owner steps through
//!   [`WorldHandle::update`] (for instance with [`spawn_simulation`]), which holds the write lock
//!   only for the step and first applies the edits the window queued ([`WorldCommand`]: drags,
//!   rotations, subscriptions for visualisation). [`WorldHandle::update`] also gives way to a
//!   window that is waiting to read, so a world stepping as fast as possible cannot starve the
//!   display.
//! * Shared ([`WorldHandle::from_shared`]): someone else (the `player` server) steps the world
//!   under its own lock and honours the pause flag; the window applies its edits itself, each
//!   under a short write lock, and pause/run toggles the owner's flag.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, RwLock, RwLockReadGuard};
use std::time::{Duration, Instant};

use stage_sim::pacing::Pacer;
use stage_sim::{ModelId, Pose, World};
use worldfile::{WindowSpec, WorldSpec};

use crate::world_scene::WorldGui;

/// An edit the window asks the world's owner to make.
#[derive(Clone, Debug, PartialEq)]
pub enum WorldCommand {
    /// Move a model (pose in its parent's frame; Stage's drag and rotate, no collision test).
    SetPose(ModelId, Pose),
    /// Add a subscription (the window shows this sensor's data).
    Subscribe(ModelId),
    /// Drop a subscription the window added.
    Unsubscribe(ModelId),
}

/// Who applies the window's edits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mode {
    /// Queued for the owner's next [`WorldHandle::update`].
    Owned,
    /// Applied at once by the window (the owner steps the world elsewhere).
    External,
}

struct Shared {
    world: Arc<RwLock<World>>,
    mode: Mode,
    gui: WorldGui,
    window: WindowSpec,
    title: String,
    commands: Mutex<Vec<WorldCommand>>,
    paused: Arc<AtomicBool>,
    quit: AtomicBool,
    readers_waiting: AtomicUsize,
    estimates: Mutex<Vec<Estimate>>,
}

/// A localiser's belief about a robot, shown by the world window beside the robot's true pose
/// (the window knows the truth; a client only sees the belief).
#[derive(Clone, Debug, PartialEq)]
pub struct Estimate {
    /// What it is (e.g. `localize:0 (amcl)`).
    pub label: String,
    /// Mean pose in the map frame, which Stage's worlds share with the world's frame: x, y
    /// (m) and heading (rad).
    pub pose: [f64; 3],
    /// Variances of x, y (m²) and heading (rad²).
    pub cov: [f64; 3],
}

/// A world shared between the thread that steps it and the world window. Cheap to clone.
#[derive(Clone)]
pub struct WorldHandle {
    shared: Arc<Shared>,
}

impl std::fmt::Debug for WorldHandle {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WorldHandle")
            .field("title", &self.shared.title)
            .field("paused", &self.paused())
            .finish()
    }
}

impl WorldHandle {
    /// Shares `world`, which the caller steps through [`WorldHandle::update`]; `gui` holds its
    /// models' GUI properties and `window` the worldfile's `window` entity (Stage's defaults
    /// when it has none). The world starts paused when its `paused` setting says so.
    pub fn new(world: World, gui: WorldGui, window: Option<WindowSpec>, title: &str) -> Self {
        let setup = WindowSetup {
            gui,
            window,
            title: title.to_string(),
        };
        WorldHandle::with_setup(world, setup)
    }

    /// Shares a world built from `spec` (its GUI properties and `window` come from the spec);
    /// the caller steps it through [`WorldHandle::update`].
    pub fn from_spec(world: World, spec: &WorldSpec) -> Self {
        WorldHandle::with_setup(world, WindowSetup::from_spec(spec))
    }

    /// [`WorldHandle::from_spec`] with what the window takes from the spec taken beforehand,
    /// so that the spec can be released before the world is built.
    pub fn with_setup(world: World, setup: WindowSetup) -> Self {
        let paused = world.config().paused;
        Self::build(
            Arc::new(RwLock::new(world)),
            Mode::Owned,
            Arc::new(AtomicBool::new(paused)),
            setup,
        )
    }

    /// Shows a world someone else owns and steps (the `player` server's stage driver): `world`
    /// is the owner's lock, `spec` the worldfile it was built from, `paused` the flag the owner
    /// honours (it does not step while the flag is set). The window reads under short read
    /// locks, applies its edits (drag, rotate, subscriptions for visualisation) itself under
    /// short write locks, and toggles `paused` for pause/run. Do not call
    /// [`WorldHandle::update`] or [`spawn_simulation`] on such a handle; watch
    /// [`WorldHandle::quit_requested`] to learn that the window was closed.
    pub fn from_shared(
        world: Arc<RwLock<World>>,
        spec: &WorldSpec,
        paused: Arc<AtomicBool>,
    ) -> Self {
        Self::build(world, Mode::External, paused, WindowSetup::from_spec(spec))
    }

    fn build(
        world: Arc<RwLock<World>>,
        mode: Mode,
        paused: Arc<AtomicBool>,
        setup: WindowSetup,
    ) -> Self {
        let WindowSetup { gui, window, title } = setup;
        WorldHandle {
            shared: Arc::new(Shared {
                world,
                mode,
                gui,
                window: window.unwrap_or_default(),
                title,
                commands: Mutex::new(Vec::new()),
                paused,
                quit: AtomicBool::new(false),
                readers_waiting: AtomicUsize::new(0),
                estimates: Mutex::new(Vec::new()),
            }),
        }
    }

    /// Replaces the localisation estimates the window can show (see [`Estimate`]).
    pub fn set_estimates(&self, estimates: Vec<Estimate>) {
        *self
            .shared
            .estimates
            .lock()
            .unwrap_or_else(|p| p.into_inner()) = estimates;
    }

    /// The localisation estimates last set.
    pub fn estimates(&self) -> Vec<Estimate> {
        self.shared
            .estimates
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clone()
    }

    /// The world's lock (the same `Arc` the owner holds in shared mode).
    pub fn world(&self) -> Arc<RwLock<World>> {
        self.shared.world.clone()
    }

    /// Read access for drawing. Keep it short: the owner cannot step meanwhile.
    pub fn read(&self) -> RwLockReadGuard<'_, World> {
        self.shared.readers_waiting.fetch_add(1, Ordering::AcqRel);
        let g = self.shared.world.read().unwrap_or_else(|p| p.into_inner());
        self.shared.readers_waiting.fetch_sub(1, Ordering::AcqRel);
        g
    }

    /// The owner's access: applies the window's queued edits, then runs `f` (a step, a driver
    /// update) under the write lock.
    pub fn update<R>(&self, f: impl FnOnce(&mut World) -> R) -> R {
        // let a waiting reader in first (a bounded wait: at most a few milliseconds)
        let start = Instant::now();
        while self.shared.readers_waiting.load(Ordering::Acquire) > 0
            && start.elapsed() < Duration::from_millis(5)
        {
            std::thread::yield_now();
        }
        let mut w = self.shared.world.write().unwrap_or_else(|p| p.into_inner());
        let cmds = self.take_commands();
        for c in cmds {
            apply(&mut w, c);
        }
        f(&mut w)
    }

    /// Makes an edit: queued for the owner's next [`WorldHandle::update`] in owned mode; in
    /// shared mode for the window's next [`WorldHandle::apply_pending`] (the window sends
    /// edits while it holds a read lock, so applying them at once would deadlock).
    pub fn send(&self, cmd: WorldCommand) {
        self.shared
            .commands
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .push(cmd);
    }

    /// The queued edits, oldest first, leaving the queue empty.
    fn take_commands(&self) -> Vec<WorldCommand> {
        std::mem::take(
            &mut *self
                .shared
                .commands
                .lock()
                .unwrap_or_else(|p| p.into_inner()),
        )
    }

    /// In shared mode (the world is stepped by an owner that never calls
    /// [`WorldHandle::update`]), applies the queued edits under one short write lock; the
    /// window calls it once per frame before it reads the world. Does nothing in owned mode,
    /// where the owner applies them.
    pub fn apply_pending(&self) {
        if self.shared.mode != Mode::External {
            return;
        }
        let cmds = self.take_commands();
        if cmds.is_empty() {
            return;
        }
        let mut w = self.shared.world.write().unwrap_or_else(|p| p.into_inner());
        for c in cmds {
            apply(&mut w, c);
        }
    }

    /// The models' GUI properties.
    pub fn gui(&self) -> &WorldGui {
        &self.shared.gui
    }

    /// The worldfile's `window` settings.
    pub fn window(&self) -> &WindowSpec {
        &self.shared.window
    }

    /// The window title (the worldfile's name).
    pub fn title(&self) -> &str {
        &self.shared.title
    }

    /// Whether the world is paused (the owner should not step it).
    pub fn paused(&self) -> bool {
        self.shared.paused.load(Ordering::Acquire)
    }

    /// Pauses or resumes the world.
    pub fn set_paused(&self, paused: bool) {
        self.shared.paused.store(paused, Ordering::Release);
    }

    /// Asks everyone sharing the world to stop (the window was closed).
    pub fn request_quit(&self) {
        self.shared.quit.store(true, Ordering::Release);
    }

    /// Whether [`WorldHandle::request_quit`] was called.
    pub fn quit_requested(&self) -> bool {
        self.shared.quit.load(Ordering::Acquire)
    }
}

/// What a world's window takes from the worldfile the world was built from: its models' GUI
/// properties, the `window` entity and the title. Apart from the spec so that a caller can
/// release the spec (tens of megabytes for a large world) before building the world.
#[derive(Clone, Debug)]
pub struct WindowSetup {
    gui: WorldGui,
    window: Option<WindowSpec>,
    title: String,
}

impl WindowSetup {
    /// The setup of a world built from `spec`; its title is the worldfile's name.
    pub fn from_spec(spec: &WorldSpec) -> WindowSetup {
        WindowSetup {
            gui: WorldGui::from_spec(spec),
            window: spec.window.clone(),
            title: std::path::Path::new(&spec.path)
                .file_name()
                .map(|f| f.to_string_lossy().into_owned())
                .unwrap_or_else(|| spec.path.clone()),
        }
    }
}

fn apply(w: &mut World, c: WorldCommand) {
    let applied = match c {
        WorldCommand::SetPose(m, p) => {
            if [p.x, p.y, p.z, p.a].iter().all(|v| v.is_finite()) {
                w.set_pose(m, p)
            } else {
                Ok(())
            }
        }
        WorldCommand::Subscribe(m) => w.subscribe(m),
        WorldCommand::Unsubscribe(m) => w.unsubscribe(m),
    };
    if let Err(e) = applied {
        tracing::debug!("ignoring a window command: {e}");
    }
}

/// How [`spawn_simulation`] paces the world.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pacing {
    /// Multiple of real time; `<= 0` runs as fast as possible.
    pub speedup: f64,
}

/// Steps the shared worlds on a thread of its own, in lock-step as Stage does with several
/// worldfiles: `interval_sim / speedup` of real time per step (the first world's
/// `interval_sim`), no steps for a paused world, and a pause (not an exit) when a world reaches
/// its `quit_time`, as in Stage's GUI. Stops when [`WorldHandle::request_quit`] is called on any
/// of them. `on_step(i, world)` runs after every step of world `i` under its write lock (clock
/// printing, drivers). Fails only when the thread cannot be created.
pub fn spawn_simulation(
    handles: Vec<WorldHandle>,
    pacing: Pacing,
    mut on_step: impl FnMut(usize, &World) + Send + 'static,
) -> std::io::Result<std::thread::JoinHandle<()>> {
    std::thread::Builder::new()
        .name("simulation".into())
        .spawn(move || {
            // the steps run on a thread of the simulation's pool: cheap splits (stage_sim::pool)
            stage_sim::on_sim_threads(move || {
                let Some(first) = handles.first() else {
                    return;
                };
                let mut pacer = Pacer::new(first.read().config().interval_sim_us, pacing.speedup);
                while !handles.iter().any(WorldHandle::quit_requested) {
                    let mut stepped_any = false;
                    for (i, h) in handles.iter().enumerate() {
                        if h.paused() {
                            // still apply the window's edits while paused
                            h.update(|_| ());
                            continue;
                        }
                        let stepped = h.update(|w| {
                            let s = w.step();
                            if s {
                                on_step(i, w);
                            }
                            s
                        });
                        if stepped {
                            stepped_any = true;
                        } else {
                            // quit_time reached: the GUI world pauses (it can be resumed)
                            h.set_paused(true);
                        }
                    }
                    if !stepped_any {
                        std::thread::sleep(Duration::from_millis(10));
                        pacer.restart();
                        continue;
                    }
                    pacer.wait();
                }
            })
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use stage_sim::{KindDesc, ModelDesc, WorldDesc};

    fn world() -> (World, WorldGui) {
        let mut d = WorldDesc::default();
        d.config.quit_time_us = 1_000_000;
        d.add(ModelDesc::new("box", KindDesc::Model), None);
        let gui = WorldGui::from_desc(&d);
        (World::from_desc(&d, 1).unwrap(), gui)
    }

    #[test]
    fn commands_apply_at_the_next_update() {
        let (w, gui) = world();
        let m = w.model_id(0).expect("the world has a box");
        // an id from a bigger world: no model of this one
        let mut big = WorldDesc::default();
        for i in 0..100 {
            big.add(ModelDesc::new(&format!("m{i}"), KindDesc::Model), None);
        }
        let foreign = World::from_desc(&big, 1).unwrap().model_id(99).unwrap();
        let h = WorldHandle::new(w, gui, None, "t");
        h.send(WorldCommand::SetPose(m, Pose::new(1.0, 2.0, 0.0, 0.5)));
        h.send(WorldCommand::Subscribe(m));
        h.send(WorldCommand::SetPose(foreign, Pose::ZERO));
        h.send(WorldCommand::SetPose(m, Pose::new(f64::NAN, 0.0, 0.0, 0.0)));
        assert_eq!(h.read().pose(m).unwrap(), Pose::ZERO);
        h.update(|_| ());
        let w = h.read();
        assert_eq!(w.pose(m).unwrap(), Pose::new(1.0, 2.0, 0.0, 0.5));
        assert_eq!(w.subscriptions(m).unwrap(), 1);
    }

    #[test]
    fn a_shared_world_takes_edits_between_frames_and_pauses_through_the_owners_flag() {
        let text = "window ( size [ 300 200 ] scale 20 )\n\
                    define bot position ( size [ 0.5 0.5 0.2 ] gui_move 1 )\n\
                    bot ( name \"r0\" pose [ 1 2 0 0 ] )\n";
        let spec = WorldSpec::parse(
            std::path::Path::new("/tmp/shared.world"),
            text,
            &worldfile::LoadOptions::default(),
        )
        .expect("world parses");
        let world = Arc::new(RwLock::new(World::from_spec(&spec, 1).expect("builds")));
        let paused = Arc::new(AtomicBool::new(false));
        let h = WorldHandle::from_shared(world.clone(), &spec, paused.clone());
        assert_eq!(h.title(), "shared.world");
        assert_eq!(h.window().size, [300, 200]);
        assert!(Arc::ptr_eq(&h.world(), &world));
        let m = world.read().unwrap().model_by_name("r0").expect("r0");
        // no update() from the owner: the window applies its own edits between frames
        let before = world.read().unwrap().pose(m).unwrap();
        {
            // the window sends edits while it reads: that must not deadlock nor apply yet
            let _reading = h.read();
            h.send(WorldCommand::SetPose(m, Pose::new(-1.0, 0.5, 0.0, 1.0)));
            h.send(WorldCommand::Subscribe(m));
        }
        assert_eq!(world.read().unwrap().pose(m).unwrap(), before);
        h.apply_pending();
        assert_eq!(
            world.read().unwrap().pose(m).unwrap(),
            Pose::new(-1.0, 0.5, 0.0, 1.0)
        );
        assert_eq!(world.read().unwrap().subscriptions(m).unwrap(), 1);
        h.send(WorldCommand::Unsubscribe(m));
        h.apply_pending();
        assert_eq!(world.read().unwrap().subscriptions(m).unwrap(), 0);
        h.set_paused(true);
        assert!(paused.load(Ordering::Acquire));
        paused.store(false, Ordering::Release);
        assert!(!h.paused());
    }

    #[test]
    fn the_simulation_thread_pauses_at_quit_time_and_stops_on_request() {
        let (w, gui) = world();
        let h = WorldHandle::new(w, gui, None, "t");
        let t = spawn_simulation(vec![h.clone()], Pacing { speedup: -1.0 }, |_, _| {}).unwrap();
        let start = Instant::now();
        while !h.paused() && start.elapsed() < Duration::from_secs(10) {
            std::thread::sleep(Duration::from_millis(5));
        }
        assert!(h.paused(), "quit_time should pause the world");
        assert_eq!(h.read().sim_time(), 1_000_000);
        h.request_quit();
        t.join().unwrap();
    }
}
