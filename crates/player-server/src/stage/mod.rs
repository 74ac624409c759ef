//! The `stage` driver: Player devices served from an embedded [`stage_sim::World`], as Stage
//! 4.1.1's `libstageplugin` serves them (player-cfg.md §8, player-protocol.md §6).
//!
//! Every cfg `driver( name "stage" ... )` block becomes one [`StageDriver`]; all of them share
//! one world, created by the block that provides `simulation` (which must come first) from its
//! `worldfile`. That block's driver steps the world once per `interval_sim` and supplies the
//! server clock (simulated seconds); every block publishes the data of its own devices, in
//! `provides` order, each time the bound model produced a new sample (that is, at the model's
//! `update_interval`), stamped with the sample's simulated time, and a device's current sample
//! on the first update after each subscription (a new subscriber has it in its first round,
//! as upstream's plugin publishes every device's current data). The blocks step on one grid
//! (the server's schedule), so all of them publish right after the world's step, in one pass.
//!
//! The interfaces the driver serves are listed once, in the `interfaces!` list below: each
//! line names the interface's module type, its Player interface code and its binding rule;
//! the type implements the `Interface` trait (`interface.rs`): how the interface publishes
//! data, answers requests and takes commands. Devices bind to models by
//! [`binding::bind_stage_model`]: the first unbound model of the interface's type in the named
//! model's subtree. What each device was bound to (or why not) is kept in the
//! [`StageHandle`] ([`StageHandle::devices`]), which is what `player --check` reports.
//!
//! Where we differ from Stage 4.1.1, on purpose:
//! * model subscriptions are reference counted: a model stays subscribed until the *last*
//!   client unsubscribes (Stage unsubscribes it on the first unsubscription, stopping the robot
//!   and its sensors for every other client);
//! * the legacy `laser`, `sonar` (on rangers) and `camera` interfaces are served, and `map`
//!   (the named model's blocks as a grid, `map` module), which Stage 4.1.1 ships
//!   but does not build;
//! * fields Stage leaves uninitialised are 0; GET_PROPERTY "time" answers instead of crashing;
//!   CAPABILITIES requests are answered (Stage crashes on the simulation one).
//!
//! The world is shared as a [`SharedWorld`] (`Arc<RwLock<World>>`): the [`StageHandle`]
//! returned by [`register`] hands it (and the clients' graphics) to a world window.

mod actarray;
pub mod binding;
mod blobfinder;
mod camera;
pub mod convert;
mod fiducial;
pub mod graphics;
mod gripper;
mod interface;
mod laser;
mod map;
mod position;
mod ranger;
mod simulation;
mod sonar;
mod speech;

use std::collections::HashSet;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, RwLock, RwLockWriteGuard};
use std::time::Duration;

use player_proto::{Bbox3d, DeviceAddr, InterfaceCode, Message, Pose3d};
use stage_sim::{ModelId, Pose, World};
use worldfile::{LoadOptions, ModelType, WorldSpec};

use crate::driver::{
    ClientId, Context, Driver, DriverBlock, DriverError, DriverRegistry, ProvidedDevice, Reply,
};
pub use binding::{
    BindError, BindErrorKind, BoundModel, BoundWorld, DeviceBinding, DeviceRecord, RangerShape,
    StageBinding, bind_stage_model, stage_binding,
};
pub use graphics::{Drawings, Figure, SharedDrawings};
use interface::{Bound, Interface, Out, Sender, Writing, interfaces};

/// The simulated world, shared between the server (which steps it) and viewers.
///
/// Writers (the stage driver's steps and requests) hold the lock briefly; a window should take
/// short read locks, once per frame.
pub type SharedWorld = Arc<RwLock<World>>;

/// The name the driver is registered under, as in cfg files.
pub const STAGE_DRIVER_NAME: &str = "stage";

/// Something the host program runs in lock-step with the world, beside the Player clients
/// (e.g. the ROS 2 bridge of `player --ros2`): the driver that steps the world calls
/// [`StepHook::before_step`] right before each step and [`StepHook::after_step`] right after
/// a step that happened, both under the world's write lock, on the server's schedule. The
/// server knows nothing else of it: what it commands reaches the world as a client's command
/// would, and Player clients see the result in the same step's data.
pub trait StepHook {
    /// Applies what the hook has for the world (commands, teleports) before a step.
    fn before_step(&mut self, world: &mut World);
    /// Reads the world right after a step (publishing its state elsewhere).
    fn after_step(&mut self, world: &World);
}

/// The hook slot the [`StageHandle`] and the world-stepping driver share.
type HookSlot = Arc<Mutex<Option<Box<dyn StepHook + Send>>>>;

/// How the `stage` driver builds its world.
#[derive(Clone, Debug, Default)]
pub struct StageOptions {
    /// Seed of every random choice in the world (Stage seeds from the clock; we are
    /// repeatable).
    pub seed: u64,
    /// Overrides the cfg's `usegui` (e.g. a `--no-gui` flag, or tests).
    pub usegui: Option<bool>,
}

/// What the `stage` driver tells its host program once the cfg is built: the world and the
/// drawings for a world window, and whether the cfg asked for one (`usegui`).
#[derive(Clone, Debug, Default)]
pub struct StageHandle {
    inner: Arc<Mutex<HandleState>>,
    paused: Arc<AtomicBool>,
    hook: HookSlot,
}

#[derive(Default)]
struct HandleState {
    world: Option<SharedWorld>,
    spec: Option<Arc<WorldSpec>>,
    worldfile: Option<PathBuf>,
    usegui: bool,
    drawings: SharedDrawings,
    devices: Vec<DeviceRecord>,
}

impl std::fmt::Debug for HandleState {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("HandleState")
            .field("world", &self.world.is_some())
            .field("worldfile", &self.worldfile)
            .field("usegui", &self.usegui)
            .finish()
    }
}

impl StageHandle {
    fn state(&self) -> std::sync::MutexGuard<'_, HandleState> {
        self.inner.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// The world, once a `simulation` device created it.
    pub fn world(&self) -> Option<SharedWorld> {
        self.state().world.clone()
    }

    /// The resolved worldfile the world was built from (window settings, names, sources).
    pub fn world_spec(&self) -> Option<Arc<WorldSpec>> {
        self.state().spec.clone()
    }

    /// The worldfile path.
    pub fn worldfile(&self) -> Option<PathBuf> {
        self.state().worldfile.clone()
    }

    /// The pause flag the driver honours: while it is set the world does not step (simulated
    /// time stands still) and devices keep publishing the unchanged state. A world window
    /// shares it (its pause button); clients cannot change it.
    pub fn paused(&self) -> Arc<AtomicBool> {
        self.paused.clone()
    }

    /// Whether the simulation block asked for Stage's window (`usegui`, default 1).
    pub fn gui_requested(&self) -> bool {
        let s = self.state();
        s.world.is_some() && s.usegui
    }

    /// What clients drew through `graphics2d`/`graphics3d`, per model and client.
    pub fn drawings(&self) -> SharedDrawings {
        self.state().drawings.clone()
    }

    /// Every device the stage blocks built so far were given, in cfg order, with the model it
    /// is bound to or the reason it is not served. A refused block's devices are here too
    /// (each refusal with its own reason), so a check can report all of them at once.
    pub fn devices(&self) -> Vec<DeviceRecord> {
        self.state().devices.clone()
    }

    fn record(&self, record: DeviceRecord) {
        self.state().devices.push(record);
    }

    /// Runs `hook` around every step of the world from the next step on (replacing any hook
    /// set before). A host builds it on [`StageHandle::world`] once the cfg is built, so that
    /// a hook that cannot be made is a start-up error rather than a failure mid-run. Paused
    /// (see [`StageHandle::paused`]), the world does not step and the hook is not called.
    pub fn set_step_hook(&self, hook: Box<dyn StepHook + Send>) {
        *self.hook.lock().unwrap_or_else(|p| p.into_inner()) = Some(hook);
    }
}

impl std::fmt::Debug for dyn StepHook + Send {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("StepHook")
    }
}

/// The one world and the models already bound.
struct Shared {
    world: SharedWorld,
    spec: Arc<WorldSpec>,
    bound: HashSet<worldfile::ModelId>,
}

impl Shared {
    /// What a `simulation` device is bound to: this world.
    fn binding(&self) -> DeviceBinding {
        DeviceBinding::World(BoundWorld {
            path: self.spec.path.clone(),
            models: self.spec.models.len(),
        })
    }
}

/// The state the factory keeps across cfg blocks.
#[derive(Default)]
struct FactoryState {
    /// The world, once a `simulation` device created it.
    shared: Option<Shared>,
    /// Where the `simulation` device that failed to create it is written, if one did: later
    /// blocks have nothing to bind to. The server stops at that failure; only a check goes on.
    world_failure: Option<String>,
}

/// Registers the `stage` driver in `registry`. The factory owns the shared world; the returned
/// handle exposes it once the `simulation` block has been built.
pub fn register(registry: &mut DriverRegistry, options: StageOptions) -> StageHandle {
    let handle = StageHandle::default();
    let h = handle.clone();
    let mut state = FactoryState::default();
    registry.register(STAGE_DRIVER_NAME, move |block: &DriverBlock| {
        let driver = StageDriver::build(block, &mut state, &options, &h)?;
        Ok(Box::new(driver) as Box<dyn Driver>)
    });
    handle
}

// The interfaces the driver serves, one line each: `Variant(module::Type): PLAYER_CODE,
// binding rule;`. The type implements `Interface` (its data, requests and commands); the rule
// is what a device of it binds to (player-cfg.md §8.3, §8.5), used by the driver and reported
// by `player --check`. Every dispatch goes through the `Served` enum this makes, and a Player
// interface code finds its interface only here. The legacy `laser` prefers a one-transducer
// ranger and `sonar` a ring, as Player 2 clients expect; `map` serves the named model's blocks
// as a grid, as Stage 2's `p_map` did (Stage 4.1.1 ships that source but does not build it).
interfaces! {
    Simulation(simulation::Simulation): SIMULATION, StageBinding::World;
    Position(position::Position): POSITION2D, model(ModelType::Position);
    Ranger(ranger::Ranger): RANGER, model(ModelType::Ranger);
    Laser(laser::Laser): LASER, StageBinding::Model(ModelType::Ranger, RangerShape::Single);
    Sonar(sonar::Sonar): SONAR, StageBinding::Model(ModelType::Ranger, RangerShape::Multiple);
    Blobfinder(blobfinder::Blobfinder): BLOBFINDER, model(ModelType::Blobfinder);
    Fiducial(fiducial::Fiducial): FIDUCIAL, model(ModelType::Fiducial);
    Gripper(gripper::Gripper): GRIPPER, model(ModelType::Gripper);
    Camera(camera::Camera): CAMERA, model(ModelType::Camera);
    Actarray(actarray::Actarray): ACTARRAY, model(ModelType::Actuator);
    Speech(speech::Speech): SPEECH, StageBinding::Named;
    Graphics2d(graphics::Graphics): GRAPHICS2D, StageBinding::Named;
    Graphics3d(graphics::Graphics): GRAPHICS3D, StageBinding::Named;
    Map(map::Map): MAP, StageBinding::Named;
}

/// Binds to the first unbound model of type `t` (any ranger shape).
const fn model(t: ModelType) -> StageBinding {
    StageBinding::Model(t, RangerShape::Any)
}

/// One device of a block.
#[derive(Debug)]
struct Device {
    addr: DeviceAddr,
    /// Its interface, with the interface's own state of this device.
    served: Served,
    /// The bound model (`None` for `simulation`).
    model: Option<ModelId>,
    /// Current subscriptions (duplicates included).
    subs: u32,
    /// Sim time (µs) of the last sample published.
    published_us: u64,
    /// Subscribed since its last update: the current sample goes out again.
    resend: bool,
}

/// A bound model's answer to a world call, or `None` with the error logged. Binding checked
/// the id against the world (which never loses a model) and matched the model's type to the
/// interface, so an error here is a bug in the binding rules: the device goes quiet (no data,
/// a NACK) instead of taking the server down.
pub(crate) fn bound_answer<T>(model: ModelId, answer: stage_sim::Result<T>) -> Option<T> {
    answer
        .inspect_err(|e| tracing::error!("stage: bound model {model}: {e}"))
        .ok()
}

/// A Stage pose as a Player 3D pose: x, y, z, yaw; roll = pitch = 0.
pub(crate) fn pose3d(p: &Pose) -> Pose3d {
    Pose3d {
        px: p.x,
        py: p.y,
        pz: p.z,
        proll: 0.0,
        ppitch: 0.0,
        pyaw: p.a,
    }
}

/// A Stage size `[x y z]` as Player's bounding box (length along x, width along y, height).
pub(crate) fn size_bbox(size: [f64; 3]) -> Bbox3d {
    Bbox3d {
        sw: size[1],
        sl: size[0],
        sh: size[2],
    }
}

/// A worldfile pose `[x y z a]` as a Player 3D pose.
pub(crate) fn spec_pose3d(p: &worldfile::Pose) -> Pose3d {
    Pose3d {
        px: p[0],
        py: p[1],
        pz: p[2],
        proll: 0.0,
        ppitch: 0.0,
        pyaw: p[3],
    }
}

/// Reads a boolean cfg option the way Player does (`1`/`0`, `yes`/`no`, `true`/`false`).
fn bool_option(block: &DriverBlock, key: &str) -> Result<Option<bool>, DriverError> {
    match block.option(key) {
        None => Ok(None),
        Some(v) => match v.to_ascii_lowercase().as_str() {
            "yes" | "true" => Ok(Some(true)),
            "no" | "false" => Ok(Some(false)),
            other => other.parse::<i64>().map(|n| Some(n != 0)).map_err(|_| {
                DriverError::new(format!("option `{key}` has an invalid value \"{v}\""))
            }),
        },
    }
}

/// The stage driver of one cfg block.
pub struct StageDriver {
    world: SharedWorld,
    spec: Arc<WorldSpec>,
    drawings: SharedDrawings,
    /// This block created the world: it steps it and supplies the clock.
    steps_world: bool,
    /// Set by a world window: the world does not step.
    paused: Arc<AtomicBool>,
    /// The host's [`StepHook`], called around each step (by the block that steps the world).
    hook: HookSlot,
    interval: Duration,
    sim_time_us: u64,
    quit_reported: bool,
    devices: Vec<Device>,
}

impl std::fmt::Debug for StageDriver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StageDriver")
            .field("steps_world", &self.steps_world)
            .field("devices", &self.devices)
            .finish()
    }
}

impl StageDriver {
    fn build(
        block: &DriverBlock,
        state: &mut FactoryState,
        options: &StageOptions,
        handle: &StageHandle,
    ) -> Result<StageDriver, DriverError> {
        let mut steps_world = false;
        let mut devices = Vec::with_capacity(block.provides.len());
        let mut refused = Vec::new();
        // Every device is tried, even after one is refused, so that all of a block's problems
        // are known (and recorded) at once.
        for p in &block.provides {
            let addr = p.addr;
            let served = Self::serve_device(block, p, state, options, handle, &mut steps_world);
            let binding = match served {
                Ok((served, model, binding)) => {
                    devices.push(Device {
                        addr,
                        served,
                        model,
                        subs: 0,
                        published_us: 0,
                        resend: false,
                    });
                    binding
                }
                Err(e) => {
                    refused.push(format!("{}: {e}", p.origin));
                    DeviceBinding::Failed(e)
                }
            };
            handle.record(DeviceRecord {
                addr,
                origin: p.origin.clone(),
                binding,
            });
        }
        if !refused.is_empty() {
            return Err(DriverError::new(refused.join("; ")));
        }
        let s = state.shared.as_ref().ok_or_else(|| {
            DriverError::new(
                "no world: the first stage block must provide `simulation:0` with a `worldfile`",
            )
        })?;
        let (interval_us, sim_time_us) = {
            let w = s.world.read().unwrap_or_else(|e| e.into_inner());
            (w.config().interval_sim_us, w.sim_time())
        };
        Ok(StageDriver {
            world: s.world.clone(),
            spec: s.spec.clone(),
            drawings: handle.drawings(),
            steps_world,
            paused: handle.paused(),
            hook: handle.hook.clone(),
            interval: Duration::from_micros(interval_us.max(1)),
            sim_time_us,
            quit_reported: false,
            devices,
        })
    }

    /// One provided device: the world for `simulation` (created by the first one, which sets
    /// `creates_world`), else the model it binds to.
    fn serve_device(
        block: &DriverBlock,
        p: &ProvidedDevice,
        state: &mut FactoryState,
        options: &StageOptions,
        handle: &StageHandle,
        creates_world: &mut bool,
    ) -> Result<(Served, Option<ModelId>, DeviceBinding), BindError> {
        let addr = p.addr;
        let Some(served) = Served::new(addr.interf) else {
            return Err(BindError::new(
                BindErrorKind::UnsupportedInterface,
                format!(
                    "the stage driver does not support interface `{}` ({})",
                    addr.interf, addr.interf.0
                ),
            ));
        };
        if Served::binding_of(addr.interf) == Some(StageBinding::World) {
            if let Some(s) = &state.shared {
                tracing::warn!(
                    "{}: a second simulation device; Stage keeps one world",
                    p.origin
                );
                return Ok((served, None, s.binding()));
            }
            let shared = create_world(block, options, handle).inspect_err(|_| {
                state.world_failure = Some(p.origin.clone());
            })?;
            let binding = shared.binding();
            state.shared = Some(shared);
            *creates_world = true;
            return Ok((served, None, binding));
        }
        let device = format!("{}:{}", addr.interf, addr.index);
        let Some(s) = state.shared.as_mut() else {
            return Err(match &state.world_failure {
                Some(at) => BindError::new(
                    BindErrorKind::WorldFailed,
                    format!("`{device}` not bound: the simulation device ({at}) created no world"),
                ),
                None => BindError::new(
                    BindErrorKind::NoWorldYet,
                    format!(
                        "no world yet for `{device}`: the block providing `simulation` (with the \
                         `worldfile`) must come first"
                    ),
                ),
            });
        };
        let Some(name) = block.option("model") else {
            return Err(BindError::new(
                BindErrorKind::NoModelField,
                format!("`{device}` needs a `model` field naming the Stage model to serve"),
            ));
        };
        let id = bind_stage_model(&s.spec, name, addr.interf, &mut s.bound)
            .map_err(|why| BindError::new(why.kind, format!("cannot bind `{device}`: {why}")))?;
        let spec = s.spec.model(id);
        let w = s.world.read().unwrap_or_else(|e| e.into_inner());
        let found = w.model_id(id).ok().map(|m| {
            let node = w.node(m).expect("model_id checked the index");
            (m, node)
        });
        let Some((m, node)) = found.filter(|(_, node)| node.name == spec.name) else {
            return Err(BindError::new(
                BindErrorKind::NoSuchModel,
                format!("model \"{}\" is not in the simulated world", spec.name),
            ));
        };
        tracing::debug!(
            "{}: {device} bound to model \"{}\" ({})",
            p.origin,
            node.name,
            node.model_type.name()
        );
        let binding = DeviceBinding::Model(BoundModel {
            id,
            name: spec.name.clone(),
            model_type: spec.model_type,
        });
        Ok((served, Some(m), binding))
    }

    fn write(&self) -> RwLockWriteGuard<'_, World> {
        self.world.write().unwrap_or_else(|e| e.into_inner())
    }

    /// The device `addr` of this driver, or an error saying it is not one.
    fn own_device(&mut self, addr: &DeviceAddr) -> Result<&mut Device, DriverError> {
        let i = self
            .device(addr)
            .ok_or_else(|| DriverError::new(format!("{addr} is not a device of this driver")))?;
        Ok(&mut self.devices[i])
    }

    fn device(&self, addr: &DeviceAddr) -> Option<usize> {
        self.devices.iter().position(|d| {
            d.addr.robot == addr.robot && d.addr.interf == addr.interf && d.addr.index == addr.index
        })
    }

    /// Publishes every subscribed device's new samples, in `provides` order, and the current
    /// sample of a device subscribed since the last update.
    fn publish(&mut self, ctx: &mut Context<'_>) {
        let world = self.world.read().unwrap_or_else(|e| e.into_inner());
        for d in &mut self.devices {
            let Some(model) = d.model else { continue };
            if d.subs == 0 {
                continue;
            }
            let bound = Bound {
                world: &*world,
                spec: &self.spec,
                model,
            };
            let mut out = Out {
                ctx: &mut *ctx,
                addr: d.addr,
                published_us: &mut d.published_us,
                resend: d.resend,
                stamp: None,
            };
            d.served.interface_mut().publish(&bound, &mut out);
            d.resend = false;
        }
    }
}

/// Loads the world named by the simulation block.
fn create_world(
    block: &DriverBlock,
    options: &StageOptions,
    handle: &StageHandle,
) -> Result<Shared, BindError> {
    let Some(written) = block.option("worldfile") else {
        return Err(BindError::new(
            BindErrorKind::NoWorldfileField,
            "the simulation device needs a `worldfile` field naming the Stage world",
        ));
    };
    let opts = LoadOptions::from_env();
    let path = find_worldfile(block, written, &opts.stage_path)?;
    let usegui = match options.usegui {
        Some(v) => v,
        None => bool_option(block, "usegui")
            .map_err(|e| BindError::new(BindErrorKind::BadOption, e.to_string()))?
            .unwrap_or(true),
    };
    let (world, spec) = World::load_with(&path, &opts, options.seed).map_err(|e| {
        BindError::new(
            BindErrorKind::WorldDoesNotLoad,
            format!("the worldfile {} does not load: {e}", path.display()),
        )
    })?;
    tracing::info!(
        "stage: world \"{}\" loaded from {} ({} models)",
        world.config().name,
        path.display(),
        world.model_count()
    );
    let world = Arc::new(RwLock::new(world));
    let spec = Arc::new(spec);
    {
        let mut h = handle.state();
        h.world = Some(world.clone());
        h.spec = Some(spec.clone());
        h.worldfile = Some(path);
        h.usegui = usegui;
    }
    Ok(Shared {
        world,
        spec,
        bound: HashSet::new(),
    })
}

/// The world file a simulation block names, found as Stage 4.1.1 finds it: the name as written
/// when absolute, else beside the cfg file; failing that, in each `STAGEPATH` directory (by its
/// base name, as Stage's `Worldfile::FileOpen`, and by the name as written, as our includes).
/// Not found anywhere: an error naming the file and where the cfg names it.
fn find_worldfile(
    block: &DriverBlock,
    written: &str,
    stage_path: &[PathBuf],
) -> Result<PathBuf, BindError> {
    let first = block.resolve_path(written);
    let mut tried = vec![first.clone()];
    tried.extend(worldfile::loader::on_stage_path(written, stage_path));
    tried.dedup();
    if let Some(found) = tried.iter().find(|p| p.is_file()) {
        return Ok(found.clone());
    }
    let reason = match std::fs::metadata(&first) {
        Ok(m) if m.is_dir() => "it is a directory".to_string(),
        Ok(_) => "not a regular file".to_string(),
        Err(e) => e.to_string(),
    };
    let searched = if stage_path.is_empty() {
        "STAGEPATH is not set".to_string()
    } else {
        let dirs: Vec<String> = stage_path.iter().map(|d| d.display().to_string()).collect();
        format!("nor on STAGEPATH {}", dirs.join(":"))
    };
    Err(BindError::new(
        BindErrorKind::WorldDoesNotLoad,
        format!(
            "cannot read world file \"{written}\" named at {}: {reason} (looked for {}; \
             {searched})",
            block.option_origin("worldfile"),
            first.display(),
        ),
    ))
}

impl Driver for StageDriver {
    fn subscribe(&mut self, addr: DeviceAddr) -> Result<(), DriverError> {
        let d = self.own_device(&addr)?;
        d.subs += 1;
        d.resend = true;
        // The first subscription starts the model updating.
        if let (1, Some(m)) = (d.subs, d.model) {
            self.write()
                .subscribe(m)
                .map_err(|e| DriverError::new(format!("{addr}: {e}")))?;
        }
        Ok(())
    }

    fn unsubscribe(&mut self, addr: DeviceAddr) -> Result<(), DriverError> {
        let d = self.own_device(&addr)?;
        if d.subs == 0 {
            return Err(DriverError::new(format!("{addr} was not subscribed")));
        }
        d.subs -= 1;
        if let (0, Some(m)) = (d.subs, d.model) {
            self.write()
                .unsubscribe(m)
                .map_err(|e| DriverError::new(format!("{addr}: {e}")))?;
        }
        Ok(())
    }

    fn client_unsubscribed(&mut self, addr: DeviceAddr, client: ClientId) {
        if let Some(i) = self.device(&addr) {
            let d = &mut self.devices[i];
            if let Some(m) = d.model {
                let left = graphics::DrawingKey {
                    model: m,
                    interface: addr.interf,
                    client,
                };
                d.served
                    .interface_mut()
                    .client_unsubscribed(&self.drawings, left);
            }
        }
    }

    fn handle_request(&mut self, _ctx: &mut Context<'_>, request: &Message) -> Reply {
        let Some(i) = self.device(&request.header.addr) else {
            return Reply::NotHandled;
        };
        // the world field alone is borrowed: the device's own state stays writable
        let mut world = self.world.write().unwrap_or_else(|e| e.into_inner());
        let d = &mut self.devices[i];
        let Some(model) = d.model else {
            return d
                .served
                .interface_mut()
                .world_request(&mut world, &request.body);
        };
        let mut b = Bound {
            world,
            spec: &self.spec,
            model,
        };
        d.served.interface_mut().request(&mut b, &request.body)
    }

    fn handle_command(&mut self, ctx: &mut Context<'_>, command: &Message) {
        let Some(i) = self.device(&command.header.addr) else {
            return;
        };
        let d = &mut self.devices[i];
        let (model, addr) = (d.model, d.addr);
        let body = &command.body;
        let handled = match model {
            // the simulation device takes no commands
            None => false,
            Some(model) => {
                let world = self.world.write().unwrap_or_else(|e| e.into_inner());
                let mut b = Bound {
                    world,
                    spec: &self.spec,
                    model,
                };
                let sender = Sender {
                    client: ctx.client(),
                    drawings: &self.drawings,
                };
                d.served.interface_mut().command(&mut b, &sender, body)
            }
        };
        if !handled {
            tracing::warn!(
                "stage: ignoring command {} to {}:{}",
                body.constant(),
                addr.interf,
                addr.index
            );
        }
    }

    fn update(&mut self, ctx: &mut Context<'_>) {
        if self.steps_world && !self.paused.load(Ordering::Relaxed) {
            let mut hook = self.hook.lock().unwrap_or_else(|e| e.into_inner());
            let mut w = self.world.write().unwrap_or_else(|e| e.into_inner());
            if let Some(h) = hook.as_mut() {
                h.before_step(&mut w);
            }
            let stepped = w.step();
            if let (true, Some(h)) = (stepped, hook.as_mut()) {
                h.after_step(&w);
            }
            if !stepped && !self.quit_reported {
                self.quit_reported = true;
                tracing::info!(
                    "stage: quit_time reached at {:.3} s: simulated time stops",
                    w.sim_time() as f64 * 1e-6
                );
            }
            self.sim_time_us = w.sim_time();
        }
        self.publish(ctx);
    }

    fn step(&self) -> Option<Duration> {
        Some(self.interval)
    }

    fn clock(&self) -> Option<f64> {
        self.steps_world.then_some(self.sim_time_us as f64 * 1e-6)
    }

    fn always_on(&self) -> bool {
        // The world runs without clients (Stage makes the simulation driver alwayson).
        self.steps_world
    }

    fn shutdown(&mut self) {
        let mut w = self.world.write().unwrap_or_else(|e| e.into_inner());
        for d in &mut self.devices {
            if let (Some(m), true) = (d.model, d.subs > 0) {
                // Shutting down: nobody to hand the error to.
                bound_answer(m, w.unsubscribe(m));
                d.subs = 0;
            }
        }
    }
}

#[cfg(test)]
mod tests;
