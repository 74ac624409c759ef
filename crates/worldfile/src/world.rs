//! The resolved level: a [`WorldSpec`] built from a worldfile document the way Stage's
//! `World::Load` builds a world (stage-worldfile.md §9–§11), with every property read into typed
//! fields in SI units and radians. The simulator never needs the raw properties again.

use std::collections::btree_map::Entry;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde::Serialize;

use crate::bitmap::{self, PixelRect};
use crate::body::{self, BlockOrigin, BlockSpec, RawBlock};
use crate::color::{ColorSpec, seeded_rng};
use crate::document::{Document, EntityId, Units};
use crate::error::{Error, ErrorKind, Warning};
use crate::lexer::Dialect;
use crate::loader::{self, LoadOptions};
use crate::models::{
    ActuatorType, CommonSpec, DefaultBody, GripperSpec, Lift, ModelType, Paddles, PositionSpec,
    PowerPackSpec, SensorSpec, TypeSpec,
};
use crate::reader::{Pose, Reader};
use crate::source::SourceLoc;
use crate::table::property_table;

/// Index of a model in [`WorldSpec::models`].
pub type ModelId = usize;

property_table! {
    /// Top-level world properties (stage-worldfile.md §10).
    pub struct WorldSettings {
        /// World name (defaults to the worldfile path as given).
        name: String = String::new(), string("name");
        /// Ray-tracing / collision grid cell size, m.
        resolution: f64 = 0.02, float("resolution");
        /// Simulated time per update, ms.
        interval_sim: f64 = 100.0, float("interval_sim");
        /// Stop when simulated time reaches this many seconds; 0 never stops.
        quit_time: f64 = 0.0, float("quit_time");
        /// Worker threads (at least 1).
        threads: i64 = 1, int("threads");
        /// Print the clock.
        show_clock: bool = false, flag("show_clock");
        /// Updates between clock prints.
        show_clock_interval: i64 = 100, int("show_clock_interval");
        /// GUI: start paused.
        paused: bool = false, flag("paused");
        /// GUI: multiple of real time; <= 0 as fast as possible.
        speedup: f64 = 1.0, float("speedup");
    }
}

impl WorldSettings {
    /// `interval_sim` in whole microseconds, truncated as Stage stores it.
    pub fn interval_sim_usec(&self) -> u64 {
        (1000.0 * self.interval_sim) as u64
    }

    /// `quit_time` in whole microseconds (0: never).
    pub fn quit_time_usec(&self) -> u64 {
        (1e6 * self.quit_time) as u64
    }

    /// Grid cells per metre.
    pub fn ppm(&self) -> f64 {
        1.0 / self.resolution
    }
}

property_table! {
    /// The GUI `window` entity (stage-worldfile.md §11); kept for viewers.
    pub struct WindowSpec {
        /// Window size in pixels.
        size: [i64; 2] = [400, 300], ints::<2>("size");
        /// World point at the window centre, m (never unit-converted).
        center: [f64; 2] = [0.0, 0.0], floats::<2>("center", "ff");
        /// `[pitch yaw]` view rotation in degrees (never converted).
        rotate: [f64; 2] = [0.0, 0.0], floats::<2>("rotate", "ff");
        /// Pixels per metre.
        scale: f64 = 15.0, float("scale");
        /// Perspective camera position, m.
        pcam_loc: [f64; 3] = [0.0, -4.0, 3.0], floats::<3>("pcam_loc", "lll");
        /// Perspective camera `[pitch yaw]`, converted as angles.
        pcam_angle: Option<[f64; 2]> = None, floats::<2>("pcam_angle", "aa");
        /// Start in perspective view.
        pcam_on: bool = false, flag("pcam_on");
        /// Milliseconds between redraws.
        interval: i64 = 40, int("interval");
        /// Frames between screenshots.
        screenshot_skip: i64 = 1, int("screenshot_skip");
        /// Save screenshots.
        screenshots: bool = false, flag("screenshots");
        /// View toggle.
        show_data: bool = false, flag("show_data");
        /// View toggle.
        show_flags: bool = true, flag("show_flags");
        /// View toggle.
        show_blocks: bool = true, flag("show_blocks");
        /// View toggle.
        show_boundingboxes: bool = false, flag("show_boundingboxes");
        /// View toggle.
        show_trailblur: bool = false, flag("show_trailblur");
        /// View toggle.
        show_clock: bool = true, flag("show_clock");
        /// View toggle.
        show_follow: bool = false, flag("show_follow");
        /// View toggle.
        show_footprints: bool = false, flag("show_footprints");
        /// View toggle.
        show_grid: bool = true, flag("show_grid");
        /// View toggle.
        show_occupancy: bool = false, flag("show_occupancy");
        /// View toggle.
        show_trailarrows: bool = false, flag("show_trailarrows");
        /// View toggle.
        show_trailrise: bool = false, flag("show_trailrise");
        /// View toggle.
        show_trailfast: bool = false, flag("show_trailfast");
        /// Model visualisation toggle.
        show_ranger_ranges: bool = true, flag("show_ranger_ranges");
        /// Model visualisation toggle.
        show_ranger_strikes: bool = false, flag("show_ranger_strikes");
        /// Model visualisation toggle.
        show_ranger_fov: bool = false, flag("show_ranger_fov");
        /// Model visualisation toggle.
        show_ranger_beams: bool = false, flag("show_ranger_beams");
        /// Model visualisation toggle.
        show_ranger_transducers: bool = false, flag("show_ranger_transducers");
        /// Model visualisation toggle.
        show_fiducial: bool = true, flag("show_fiducial");
        /// Model visualisation toggle.
        show_fiducial_fov: bool = false, flag("show_fiducial_fov");
        /// Model visualisation toggle.
        show_gripper_data: bool = true, flag("show_gripper_data");
        /// Model visualisation toggle.
        show_blinken: bool = true, flag("show_blinken");
        /// Model visualisation toggle.
        show_camera: bool = true, flag("show_camera");
        /// Model visualisation toggle.
        ranger_vis: bool = true, flag("ranger_vis");
        /// Model visualisation toggle.
        blobfinder_vis: bool = true, flag("blobfinder_vis");
        /// Model visualisation toggle.
        raster_vis: bool = false, flag("raster_vis");
        /// Model visualisation toggle.
        show_position_waypoints: bool = true, flag("show_position_waypoints");
        /// Model visualisation toggle.
        show_position_coords: bool = false, flag("show_position_coords");
    }
}

/// One model, fully resolved.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ModelSpec {
    /// Its index in [`WorldSpec::models`] (pre-order: parents before children).
    pub id: ModelId,
    /// Enclosing model.
    pub parent: Option<ModelId>,
    /// Child models in creation order.
    pub children: Vec<ModelId>,
    /// Type.
    pub model_type: ModelType,
    /// The type word as written (differs from the type for legacy aliases such as `map`).
    pub type_word: String,
    /// The macro the model was written as (e.g. `pioneer2dx`).
    pub macro_name: Option<String>,
    /// The model's name: its `name` property, else the generated name.
    pub name: String,
    /// Stage's generated name (`position:0`, `r0.ranger:1`), also registered for lookups.
    pub generated_name: String,
    /// Where the model is written.
    pub location: Option<SourceLoc>,
    /// Its entity in the document.
    pub entity: EntityId,
    /// Pose in the parent's frame (world frame at top level): x, y, z in m, heading in rad.
    pub pose: Pose,
    /// Bounding box of the body, m.
    pub size: [f64; 3],
    /// Offset of the body and sensor frame from the pose.
    pub origin: Pose,
    /// Colour (`Random` until [`WorldSpec::resolve_random_colors`]).
    pub color: ColorSpec,
    /// Whether the GUI lets the user drag it (top-level models by default).
    pub gui_move: bool,
    /// Every other common property (stage-models.md §3).
    pub common: CommonSpec,
    /// The power pack `joules`/`kjoules` create.
    pub power_pack: Option<PowerPackSpec>,
    /// The body, in the body frame, in metres.
    pub blocks: Vec<BlockSpec>,
    /// Type-specific properties.
    pub spec: TypeSpec,
}

impl ModelSpec {
    /// The position properties, for a `position` model.
    pub fn position(&self) -> Option<&PositionSpec> {
        match &self.spec {
            TypeSpec::Position(p) => Some(p),
            _ => None,
        }
    }

    /// The sensors, for a `ranger`.
    pub fn sensors(&self) -> Option<&[SensorSpec]> {
        match &self.spec {
            TypeSpec::Ranger(r) => Some(&r.sensors),
            _ => None,
        }
    }
}

/// A whole world, ready for the simulator.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct WorldSpec {
    /// The worldfile path as given.
    pub path: String,
    /// Top-level settings.
    pub settings: WorldSettings,
    /// The first `window` entity, if any.
    pub window: Option<WindowSpec>,
    /// Units the file used.
    pub units: Units,
    /// Models in pre-order (entity order).
    pub models: Vec<ModelSpec>,
    /// Everything suspicious that did not stop loading, unused properties included.
    pub warnings: Vec<Warning>,
    #[serde(skip)]
    names: HashMap<String, ModelId>,
}

impl WorldSpec {
    /// Loads and resolves a worldfile.
    pub fn load(path: &Path, opts: &LoadOptions) -> Result<WorldSpec, Error> {
        let doc = loader::load_document(path, Dialect::World, opts)?;
        resolve(&doc, opts)
    }

    /// Parses `text` as the worldfile at `path` (includes and bitmaps resolve relative to it)
    /// and resolves it.
    pub fn parse(path: &Path, text: &str, opts: &LoadOptions) -> Result<WorldSpec, Error> {
        let doc = loader::parse_document(path, text.as_bytes().to_vec(), Dialect::World, opts)?;
        resolve(&doc, opts)
    }

    /// The model registered under `name` (explicit or generated); with duplicates, the last
    /// registered wins, as in Stage.
    pub fn find_model(&self, name: &str) -> Option<ModelId> {
        self.names.get(name).copied()
    }

    /// The model with this id.
    ///
    /// # Panics
    /// If the id is not from this world.
    pub fn model(&self, id: ModelId) -> &ModelSpec {
        &self.models[id]
    }

    /// Top-level models in order.
    pub fn top_level(&self) -> impl Iterator<Item = &ModelSpec> {
        self.models.iter().filter(|m| m.parent.is_none())
    }

    /// `id` and all its descendants, depth-first pre-order (the order the Player driver
    /// searches for a model to bind, player-cfg.md §8.3).
    pub fn subtree(&self, id: ModelId) -> Vec<ModelId> {
        let mut out = Vec::new();
        let mut stack = vec![id];
        while let Some(m) = stack.pop() {
            out.push(m);
            stack.extend(self.models[m].children.iter().rev());
        }
        out
    }

    /// The pose of `id` in the world frame (stage-models.md §1.2): parent global pose composed
    /// with the local pose, lifted by the parent's height when the parent stacks children.
    pub fn global_pose(&self, id: ModelId) -> Pose {
        let m = &self.models[id];
        match m.parent {
            None => m.pose,
            Some(p) => {
                let parent = &self.models[p];
                let mut g = compose(self.global_pose(p), m.pose);
                if parent.common.stack_children {
                    g[2] += parent.size[2];
                }
                g
            }
        }
    }

    /// Replaces every `random` colour (models and ranger sensors, in model order) by a draw
    /// from a generator seeded with `seed`, so the same seed gives the same colours.
    pub fn resolve_random_colors(&mut self, seed: u64) {
        let mut rng = seeded_rng(seed);
        for m in &mut self.models {
            if m.color == ColorSpec::Random {
                m.color = ColorSpec::Rgba(ColorSpec::Random.resolve(&mut rng));
            }
            if let TypeSpec::Ranger(r) = &mut m.spec {
                for s in &mut r.sensors {
                    if s.color == ColorSpec::Random {
                        s.color = ColorSpec::Rgba(ColorSpec::Random.resolve(&mut rng));
                    }
                }
            }
        }
    }
}

/// `p ⊕ q`: `q`, given in `p`'s frame, expressed in `p`'s parent frame (the shared
/// [`pose::Pose::compose`], on the file's `[x y z a]` arrays as they are).
pub fn compose(p: Pose, q: Pose) -> Pose {
    let frame = |p: Pose| pose::Pose {
        x: p[0],
        y: p[1],
        z: p[2],
        a: p[3],
    };
    frame(p).compose(&frame(q)).to_array()
}

/// How many models of each type a parent (or the world) has, for Stage's generated names.
#[derive(Default)]
struct TypeCounts([u32; crate::models::TYPES.len()]);

impl TypeCounts {
    /// The index the next model of type `t` gets (counting it).
    fn next(&mut self, t: ModelType) -> u32 {
        let count = &mut self.0[t as usize];
        let index = *count;
        *count += 1;
        index
    }
}

/// What a model being built needs beside its [`ModelSpec`]: its blocks are kept in block units
/// until the end.
struct Building {
    raw_blocks: Vec<RawBlock>,
    has_default_block: bool,
    global_at_load: Pose,
    child_counts: TypeCounts,
}

struct Resolver<'d> {
    doc: &'d Document,
    opts: &'d LoadOptions,
    top: PathBuf,
    warnings: Vec<Warning>,
    /// The models so far, in the store the world keeps (sized from the document at the start:
    /// a large world's models are a large part of its load, and are not copied again).
    models: Vec<ModelSpec>,
    /// What each model still needs while the world is being built.
    building: Vec<Building>,
    model_of_entity: Vec<Option<ModelId>>,
    world_counts: TypeCounts,
    bitmaps: HashMap<PathBuf, Arc<Vec<PixelRect>>>,
    /// What reading a sensor gave (and warned), for the copies of it
    /// ([`crate::document::Entity::copy_of`]).
    /// (Few originals, looked up once per copy: a B-tree costs less than hashing here.)
    sensor_reads: BTreeMap<EntityId, (SensorSpec, Vec<Warning>)>,
}

/// What an entity of a worldfile is to the resolver, by its type word.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Role {
    /// The GUI window: read once, apart.
    Window,
    /// A block of its model's body.
    Block,
    /// A sensor of its ranger.
    Sensor,
    /// A model (of a known type or not).
    Model,
}

fn entity_role(doc: &Document, id: EntityId) -> Role {
    match doc.type_name(id) {
        "window" => Role::Window,
        "block" => Role::Block,
        "sensor" => Role::Sensor,
        _ => Role::Model,
    }
}

/// Records a warning about a model, at its location.
fn warn_model(warnings: &mut Vec<Warning>, model: &ModelSpec, message: &str) {
    let msg = format!("model `{}`: {message}", model.name);
    warnings.push(match &model.location {
        Some(l) => Warning::at(l.clone(), msg),
        None => Warning::general(msg),
    });
}

/// Builds the world from a parsed worldfile document.
pub fn resolve(doc: &Document, opts: &LoadOptions) -> Result<WorldSpec, Error> {
    let top = doc
        .sources
        .top_path()
        .map(Path::to_path_buf)
        .unwrap_or_default();
    let model_count = (1..doc.entities.len())
        .filter(|&id| entity_role(doc, id) == Role::Model)
        .count();
    let mut r = Resolver {
        doc,
        opts,
        top: top.clone(),
        warnings: doc.warnings.clone(),
        models: Vec::with_capacity(model_count),
        building: Vec::with_capacity(model_count),
        model_of_entity: vec![None; doc.entities.len()],
        // The hidden ground model is the first top-level `model` ("model:0").
        world_counts: {
            let mut counts = TypeCounts::default();
            counts.next(ModelType::Model);
            counts
        },
        bitmaps: HashMap::new(),
        sensor_reads: BTreeMap::new(),
    };
    let settings = r.settings()?;
    let window = r.window()?;
    for id in 1..doc.entities.len() {
        match entity_role(doc, id) {
            Role::Window => {}
            Role::Block => r.block(id)?,
            Role::Sensor => r.sensor(id)?,
            Role::Model => r.model(id)?,
        }
    }
    let mut models = std::mem::take(&mut r.models);
    let mut names = HashMap::with_capacity(2 * models.len());
    for (spec, b) in models.iter_mut().zip(std::mem::take(&mut r.building)) {
        let (blocks, notes) = body::scale(&b.raw_blocks, spec.size);
        if notes.flat_z {
            warn_model(
                &mut r.warnings,
                spec,
                "the blocks have no height (no `z`, or all `z` at 0): Stage would compute NaN heights; each block is made full height instead",
            );
        }
        if notes.flat_xy {
            warn_model(
                &mut r.warnings,
                spec,
                "the blocks have no extent along x or y (Stage divides by zero here); that axis is collapsed to the centre",
            );
        }
        spec.blocks = blocks;
        names.insert(spec.generated_name.clone(), spec.id);
        names.insert(spec.name.clone(), spec.id);
    }
    let mut warnings = r.warnings;
    warnings.extend(doc.unused_property_warnings());
    Ok(WorldSpec {
        path: top.display().to_string(),
        settings,
        window,
        units: doc.units,
        models,
        warnings,
        names,
    })
}

impl<'d> Resolver<'d> {
    fn reader(&mut self, entity: EntityId) -> Reader<'d, '_> {
        Reader::new(self.doc, entity, &mut self.warnings)
    }

    fn entity_loc(&self, entity: EntityId) -> Option<SourceLoc> {
        self.doc.entity(entity).loc.map(|l| self.doc.loc(l))
    }

    fn entity_error(&self, kind: ErrorKind, entity: EntityId) -> Error {
        let e = self.doc.entity(entity);
        match e.loc {
            Some(loc) => Error::at(kind, &self.doc.sources, loc, self.doc.type_name(entity)),
            None => Error::new(kind),
        }
    }

    fn settings(&mut self) -> Result<WorldSettings, Error> {
        let path = self.top.display().to_string();
        let mut r = self.reader(0);
        let mut s = WorldSettings::read(&mut r)?;
        if !r.exists("name") {
            s.name = path;
        }
        for (name, value) in [
            ("resolution", s.resolution),
            ("interval_sim", s.interval_sim),
        ] {
            if !(value.is_finite() && value > 0.0) {
                let p = self
                    .doc
                    .property(0, name)
                    .expect("a non-default value was read");
                let v = &self.doc.values(p)[0];
                return Err(Error::at(
                    ErrorKind::OutOfRange {
                        name: name.into(),
                        text: v.text.to_string(),
                    },
                    &self.doc.sources,
                    v.loc,
                    &v.text,
                ));
            }
        }
        if s.threads < 1 {
            self.reader(0)
                .warn("`threads` is below 1; forced to 1 as in Stage");
            s.threads = 1;
        }
        Ok(s)
    }

    fn window(&mut self) -> Result<Option<WindowSpec>, Error> {
        let mut windows = self.doc.entities_of_type("window");
        let Some(first) = windows.next() else {
            return Ok(None);
        };
        let rest: Vec<EntityId> = windows.collect();
        let mut r = self.reader(first);
        let mut w = WindowSpec::read(&mut r)?;
        if w.screenshot_skip < 1 {
            w.screenshot_skip = 1;
        }
        for id in rest {
            self.reader(id)
                .warn("only the first `window` is used (as in Stage); this one is ignored");
        }
        Ok(Some(w))
    }

    fn parent_model(&mut self, entity: EntityId) -> Option<ModelId> {
        let parent = self.doc.entity(entity).parent?;
        let m = self.model_of_entity[parent];
        if m.is_none() && parent != 0 {
            let outer = self.doc.type_name(parent).to_string();
            self.reader(entity).warn(format!(
                "this model is inside `{outer}`, which is not a model: it becomes a top-level model, as in Stage"
            ));
        }
        m
    }

    fn model(&mut self, entity: EntityId) -> Result<(), Error> {
        let word = self.doc.type_name(entity).to_string();
        let Some((model_type, legacy)) = ModelType::from_word(&word) else {
            return Err(self.entity_error(ErrorKind::UnknownModelType(word), entity));
        };
        if let Some(why) = legacy {
            self.reader(entity).warn(why);
        }
        let info = model_type.info();
        let parent = self.parent_model(entity);
        let id = self.models.len();

        // Stage names the model before loading it: `type:k` or `parent.type:k`.
        let counts = match parent {
            Some(p) => &mut self.building[p].child_counts,
            None => &mut self.world_counts,
        };
        let index = counts.next(model_type);
        let generated_name = match parent {
            Some(p) => format!("{}.{}:{index}", self.models[p].name, info.name),
            None => format!("{}:{index}", info.name),
        };

        // A gripper reads its paddle properties and builds its body before the common ones.
        let gripper = if model_type == ModelType::Gripper {
            let mut r = self.reader(entity);
            Some(GripperSpec::read(&mut r)?)
        } else {
            None
        };
        let mut raw_blocks = match info.defaults.body {
            DefaultBody::UnitSquare => vec![body::rect_block(
                -0.5,
                -0.5,
                1.0,
                1.0,
                1.0,
                BlockOrigin::Default,
            )],
            DefaultBody::Empty => Vec::new(),
            DefaultBody::Gripper => {
                let g = gripper.as_ref().expect("read above for grippers");
                let position = match g.paddle_state.paddles {
                    Paddles::Open => 0.0,
                    Paddles::Closed => 1.0,
                };
                let lift = match g.paddle_state.lift {
                    Lift::Down => 0.0,
                    Lift::Up => 1.0,
                };
                body::gripper_blocks(g.paddle_size, position, lift)
            }
        };
        let mut has_default_block = true;

        let mut r = self.reader(entity);
        let explicit_name = r.string("name")?;
        let origin = r.pose("origin")?.unwrap_or([0.0; 4]);
        let size = r
            .size("size", info.defaults.size[2])?
            .unwrap_or(info.defaults.size);
        let mut pose = r.pose("pose")?.unwrap_or([0.0; 4]);
        let color = r
            .color(true)?
            .unwrap_or(ColorSpec::Rgba(info.defaults.color));
        let common = CommonSpec::read_from(&mut r, CommonSpec::for_type(model_type))?;

        if common.noblocks && has_default_block {
            raw_blocks.clear();
            has_default_block = false;
        }
        if r.exists("bitmap") {
            if has_default_block {
                raw_blocks.clear();
                has_default_block = false;
            }
            let rects = self.bitmap(entity)?;
            raw_blocks.extend(rects.iter().map(|px| {
                body::rect_block(
                    px.x as f64,
                    px.y as f64,
                    px.w as f64,
                    px.h as f64,
                    1.0,
                    BlockOrigin::Bitmap,
                )
            }));
        }
        if common.boundary {
            match body::GroupBounds::of(&raw_blocks) {
                Some(bounds) => raw_blocks.extend(body::boundary_blocks(&bounds)),
                None => self.reader(entity).warn(
                    "`boundary 1` on a model with no blocks has nothing to surround; ignored",
                ),
            }
        }

        let mut r = self.reader(entity);
        let mut spec = match gripper {
            Some(g) => TypeSpec::Gripper(g),
            None => TypeSpec::read(model_type, &mut r)?,
        };
        if let TypeSpec::Actuator(a) = &spec {
            if let Some(start) = a.start_position {
                // Stage displaces from a reference pose it never sets (zero); we displace from
                // the loaded pose, which is what the property is documented to do.
                match a.actuator_type {
                    ActuatorType::Linear => {
                        let (s, c) = pose[3].sin_cos();
                        pose[0] += (a.axis[0] * c - a.axis[1] * s) * start;
                        pose[1] += (a.axis[0] * s + a.axis[1] * c) * start;
                        pose[2] += a.axis[2] * start;
                    }
                    ActuatorType::Rotational => pose[3] = pose::angle::normalize(pose[3] + start),
                }
            }
        }
        let name = explicit_name
            .filter(|n| !n.is_empty())
            .unwrap_or_else(|| generated_name.clone());

        let global_at_load = match parent {
            None => pose,
            Some(p) => {
                let parent = &self.models[p];
                let mut g = compose(self.building[p].global_at_load, pose);
                if parent.common.stack_children {
                    g[2] += parent.size[2];
                }
                g
            }
        };
        if let TypeSpec::Ranger(ranger) = &mut spec {
            // its sensors are its `sensor` children, read after it: room for all at once
            let doc = self.doc;
            let sensors = doc.children(entity).iter();
            let count = sensors
                .filter(|&&c| entity_role(doc, c) == Role::Sensor)
                .count();
            ranger.sensors.reserve_exact(count);
        }
        if let TypeSpec::Position(pos) = &mut spec {
            let given = self.doc.property(entity, "localization_origin");
            if given.is_none_or(|p| p.is_empty()) {
                pos.localization_origin = global_at_load;
            }
        }

        let power_pack = common.power_pack();
        let gui_move = common.gui_move.unwrap_or(parent.is_none());
        let model = ModelSpec {
            id,
            parent,
            children: Vec::new(),
            model_type,
            type_word: word,
            macro_name: self.doc.macro_name(entity).map(str::to_string),
            name,
            generated_name,
            location: self.entity_loc(entity),
            entity,
            pose,
            size,
            origin,
            color,
            gui_move,
            common,
            power_pack,
            blocks: Vec::new(),
            spec,
        };
        if let Some(p) = parent {
            self.models[p].children.push(id);
        }
        self.models.push(model);
        self.building.push(Building {
            raw_blocks,
            has_default_block,
            global_at_load,
            child_counts: TypeCounts::default(),
        });
        self.model_of_entity[entity] = Some(id);
        Ok(())
    }

    /// The rectangles of a model's `bitmap`, found like Stage finds it (relative to the
    /// top-level worldfile), then along `STAGEPATH`.
    fn bitmap(&mut self, entity: EntityId) -> Result<Arc<Vec<PixelRect>>, Error> {
        let p = self
            .doc
            .use_property(entity, "bitmap")
            .expect("caller checked it exists");
        let Some(v) = self.doc.values(p).first() else {
            return Err(Error::at(
                ErrorKind::Io {
                    what: "bitmap",
                    path: String::new(),
                    reason: "empty file name".into(),
                },
                &self.doc.sources,
                p.loc,
                self.doc.name(p),
            ));
        };
        let name = v.text.to_string();
        let io_error = |path: String, reason: String| {
            Error::at(
                ErrorKind::Io {
                    what: "bitmap",
                    path,
                    reason,
                },
                &self.doc.sources,
                v.loc,
                &format!("\"{name}\""),
            )
        };
        if name.is_empty() {
            return Err(io_error(String::new(), "empty file name".into()));
        }
        let tried = if name.starts_with('/') {
            vec![PathBuf::from(&name)]
        } else {
            loader::candidates(&self.top, &name, &self.opts.stage_path)
        };
        let Some(path) = tried.iter().find(|p| p.is_file()).cloned() else {
            let mut reason = "no such file".to_string();
            if tried.len() > 1 {
                reason.push_str(&format!(
                    " (also searched {} STAGEPATH location(s))",
                    tried.len() - 1
                ));
            }
            return Err(io_error(tried[0].display().to_string(), reason));
        };
        if let Some(rects) = self.bitmaps.get(&path) {
            return Ok(rects.clone());
        }
        let grid = bitmap::load_occupancy(&path, self.opts.limits.max_bitmap_pixels).map_err(
            |reason| {
                Error::at(
                    ErrorKind::BadBitmap {
                        path: path.display().to_string(),
                        reason,
                    },
                    &self.doc.sources,
                    v.loc,
                    &format!("\"{name}\""),
                )
            },
        )?;
        let rects = Arc::new(bitmap::rectangles(grid, self.opts.bitmap_rows));
        self.bitmaps.insert(path, rects.clone());
        Ok(rects)
    }

    /// A `block` sub-entity (block.cc `Block::Load`), appended to its model's body.
    fn block(&mut self, entity: EntityId) -> Result<(), Error> {
        let parent = self.doc.entity(entity).parent.unwrap_or(0);
        let Some(model) = self.model_of_entity[parent] else {
            return Err(self.entity_error(ErrorKind::BlockOutsideModel, entity));
        };
        let mut r = self.reader(entity);
        let count = r.int("points")?.unwrap_or(0);
        const MAX_POINTS: i64 = 100_000;
        if !(0..=MAX_POINTS).contains(&count) {
            let p = self.doc.property(entity, "points").expect("read above");
            let v = &self.doc.values(p)[0];
            return Err(Error::at(
                ErrorKind::OutOfRange {
                    name: "points".into(),
                    text: v.text.to_string(),
                },
                &self.doc.sources,
                v.loc,
                &v.text,
            ));
        }
        let mut points = Vec::with_capacity(count as usize);
        let mut missing = Vec::new();
        for i in 0..count {
            let key = format!("point[{i}]");
            match r.floats::<2>(&key, "ll")? {
                Some(p) => points.push(p),
                None => {
                    missing.push(key);
                    points.push([0.0, 0.0]);
                }
            }
        }
        if !missing.is_empty() {
            r.warn(format!(
                "block has no {}: (0, 0) is used, as in Stage",
                missing.join(", ")
            ));
        }
        let z = r.floats::<2>("z", "ll")?.unwrap_or([0.0, 0.0]);
        let color = match r.prop("color") {
            Some(p) if !r.values(p)[0].text.is_empty() => {
                let name = r.values(p)[0].text.to_string();
                Some(r.named_color(p, &name))
            }
            _ => None,
        };
        r.int("wheel")?;
        if points.len() < 2 {
            return Err(self.entity_error(ErrorKind::TooFewPoints(points.len()), entity));
        }
        let loc = self.entity_loc(entity);
        let b = &mut self.building[model];
        if b.has_default_block {
            b.raw_blocks.clear();
            b.has_default_block = false;
        }
        b.raw_blocks.push(RawBlock {
            points: body::counter_clockwise(points),
            z,
            color,
            origin: match loc {
                Some(at) => BlockOrigin::Block { at },
                None => BlockOrigin::Default,
            },
        });
        Ok(())
    }

    /// A `sensor` sub-entity, appended to its ranger.
    fn sensor(&mut self, entity: EntityId) -> Result<(), Error> {
        let parent = self.doc.entity(entity).parent.unwrap_or(0);
        let ranger = self.model_of_entity[parent]
            .filter(|m| matches!(self.models[*m].spec, TypeSpec::Ranger(_)));
        let Some(model) = ranger else {
            return Err(self.entity_error(ErrorKind::SensorOutsideRanger, entity));
        };
        let sensor = match self.doc.entity(entity).copy_of {
            // A copy of an earlier sensor reads as that one did: the same spec, the same
            // warnings, the same properties used.
            Some(original) => {
                let (sensor, warnings) = match self.sensor_reads.entry(original) {
                    Entry::Occupied(read) => read.into_mut(),
                    Entry::Vacant(slot) => {
                        let mut warnings = Vec::new();
                        let sensor =
                            read_sensor(&mut Reader::new(self.doc, original, &mut warnings))?;
                        slot.insert((sensor, warnings))
                    }
                };
                self.doc.mark_used_as(entity, original);
                self.warnings.extend(warnings.iter().cloned());
                sensor.clone()
            }
            None => read_sensor(&mut self.reader(entity))?,
        };
        if let TypeSpec::Ranger(ranger) = &mut self.models[model].spec {
            ranger.sensors.push(sensor);
        }
        Ok(())
    }
}

/// A `sensor` entity's properties, with a warning when it produces no data.
fn read_sensor(r: &mut Reader<'_, '_>) -> Result<SensorSpec, Error> {
    let sensor = SensorSpec::read(r)?;
    if sensor.samples < 1 {
        r.warn("sensor `samples` is below 1: it produces no data");
    }
    Ok(sensor)
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::loader::lex_document;
    use crate::parser::parse_reusing;

    /// Sensors copied from a macro body read as the sensor they copy: the same specs, the same
    /// warnings in the same places, the same properties reported unused, as reading each.
    #[test]
    fn copied_sensors_read_like_the_sensor_they_copy() {
        let src = "define ir sensor ( range [0 1.2.3] fov 30 samples 0 shade 3 )\n\
                   define bot position ( ranger ( ir ( pose [0 0 0 0] ) ir ( pose [0 0 0 90] size [1 2] ) ) )\n\
                   bot ( name \"a\" )\nbot ( name \"b\" )\nbot ( name \"c\" )\n";
        let opts = LoadOptions::default();
        let parse = |reuse| {
            let (toks, sources) =
                lex_document(Path::new("t.world"), src.into(), Dialect::World, &opts).unwrap();
            parse_reusing(toks, sources, Dialect::World, &opts.limits, reuse).unwrap()
        };
        let doc = parse(true);
        let copies = doc.entities.iter().filter(|e| e.copy_of.is_some()).count();
        // the ranger and both sensors of the 2nd and 3rd robots (in the 1st, each `ir` instance
        // adds its own pose to the sensor the body makes: not a copy)
        assert_eq!(copies, 6);
        // the same text parsed afresh at every instance: no copies, each sensor read
        let each_read = parse(false);
        assert!(each_read.entities.iter().all(|e| e.copy_of.is_none()));
        let copied = resolve(&doc, &opts).unwrap();
        let read = resolve(&each_read, &opts).unwrap();
        assert_eq!(copied, read);
        let sensors: usize = copied
            .models
            .iter()
            .filter_map(|m| m.sensors())
            .map(<[_]>::len)
            .sum();
        assert_eq!(sensors, 6);
        let count = |what: &str| {
            copied
                .warnings
                .iter()
                .filter(|w| w.message.contains(what))
                .count()
        };
        assert_eq!(count("`range` value `1.2.3` is read as 1.2"), 6);
        assert_eq!(count("produces no data"), 6);
        assert_eq!(count("property `shade`"), 6);
        assert_eq!(count("Stage 3 form [x y]"), 3);
    }
}
