//! The world: model tree, clock and scheduler, the deterministic two-phase step, and the API
//! that servers, viewers and controllers use.

use std::collections::HashMap;

use rayon::prelude::*;

use crate::controller::{self, Command, Commands, Controller};
use crate::desc::{BlockDesc, Color, KindDesc, ModelDesc, ModelType, WorldDesc};
use crate::error::{Error, Result};
use crate::geom::Aabb;
use crate::models::actuator::{ActuatorData, ActuatorMode};
use crate::models::blobfinder::BlobfinderData;
use crate::models::camera::CameraImage;
use crate::models::fiducial::FiducialData;
use crate::models::gripper::{GripAction, GripperCmd, GripperData};
use crate::models::position::{PositionData, PositionModel};
use crate::models::ranger::RangerData;
use crate::pose::Pose;
use crate::raster::Raster;
use crate::rng::SimRng;
use crate::space::{Body, RayHit, RayQuery, Space, WorldBlock};

mod moves;

use crate::models::KindState;

pub use crate::node::{LocalBlock, ModelId, Node};
pub(crate) use crate::view::View;

/// Per-model mutable state: scheduling, RNG stream and the type's data.
#[derive(Clone, Debug)]
pub(crate) struct ModelState {
    subs: u32,
    next_update: u64,
    /// Update once without a subscription (blinkenlight, camera start themselves).
    self_start: bool,
    updated_at: Option<u64>,
    rng: SimRng,
    kind: KindState,
}

/// World-level settings in internal units.
#[derive(Clone, Debug, PartialEq)]
pub struct WorldConfig {
    /// World name.
    pub name: String,
    /// Simulated time per step (µs).
    pub interval_sim_us: u64,
    /// Quit time (µs); 0 = never.
    pub quit_time_us: u64,
    /// Stage's grid resolution (m).
    pub resolution: f64,
    /// Target multiple of real time; ≤ 0 = as fast as possible.
    pub speedup: f64,
    /// Start paused (GUI).
    pub paused: bool,
    /// `threads` from the file (informational: the step uses rayon's pool).
    pub threads: usize,
    /// Print the clock.
    pub show_clock: bool,
    /// Clock printing period (updates).
    pub show_clock_interval: u64,
}

struct ControllerSlot {
    model: u32,
    trigger: u32,
    ctrl: Box<dyn Controller>,
}

/// A running world. See the crate docs for the step semantics.
pub struct World {
    cfg: WorldConfig,
    seed: u64,
    sim_time: u64,
    updates: u64,
    nodes: Vec<Node>,
    poses: Vec<Pose>,
    globals: Vec<Pose>,
    colors: Vec<Color>,
    says: Vec<String>,
    space: Space,
    states: Vec<ModelState>,
    names: HashMap<String, u32>,
    positions: Vec<u32>,
    fiducial_targets: Vec<u32>,
    controllers: Vec<ControllerSlot>,
    warnings: Vec<String>,
    rays_cast: u64,
    // scratch
    due: Vec<bool>,
    updated: Vec<bool>,
    subtree: Vec<u32>,
    scratch: Vec<u32>,
    move_plans: Vec<moves::MovePlan>,
}

/// Stack below this many rays per step is run on the calling thread (fork/join costs more).
const PARALLEL_MIN_RAYS: usize = 1024;

fn local_blocks(m: &ModelDesc) -> Result<Vec<LocalBlock>> {
    if m.default_body {
        let [sx, sy, sz] = m.size;
        return Ok(vec![LocalBlock {
            pts: vec![
                [-sx / 2.0, -sy / 2.0],
                [sx / 2.0, -sy / 2.0],
                [sx / 2.0, sy / 2.0],
                [-sx / 2.0, sy / 2.0],
            ],
            z: [0.0, sz],
            color: None,
        }]);
    }
    m.blocks
        .iter()
        .map(|b| {
            let bad = |msg: String| Error::InvalidModel {
                model: m.name.clone(),
                source_loc: m.source.clone(),
                msg,
            };
            if b.points.len() < 2 {
                return Err(bad(format!(
                    "a block has {} point(s); at least 2 are needed",
                    b.points.len()
                )));
            }
            if b.points.iter().flatten().any(|v| !v.is_finite())
                || !b.zmin.is_finite()
                || !b.zmax.is_finite()
            {
                return Err(bad("a block coordinate is not a finite number".into()));
            }
            Ok(LocalBlock {
                pts: b.points.clone(),
                z: [b.zmin, b.zmax],
                color: b.color,
            })
        })
        .collect()
}

fn body_of(node: &Node, global: &Pose, out: &mut Body) {
    out.blocks.clear();
    out.pts.clear();
    out.aabb = Aabb::EMPTY;
    if node.blocks.is_empty() {
        return;
    }
    let frame = global.compose(&node.origin);
    let (s, c) = frame.a.sin_cos();
    for b in &node.blocks {
        let start = out.pts.len() as u32;
        let mut bb = Aabb::EMPTY;
        for p in &b.pts {
            let w = [frame.x + p[0] * c - p[1] * s, frame.y + p[0] * s + p[1] * c];
            bb.add(w);
            out.pts.push(w);
        }
        out.aabb.merge(&bb);
        out.blocks.push(WorldBlock {
            zmin: frame.z + b.z[0],
            zmax: frame.z + b.z[1],
            start,
            end: out.pts.len() as u32,
            aabb: bb,
        });
    }
}

fn global_of(nodes: &[Node], globals: &[Pose], m: usize, pose: &Pose) -> Pose {
    match nodes[m].parent {
        None => *pose,
        Some(p) => global_of_parent(&nodes[p as usize], &globals[p as usize], pose),
    }
}

/// `m` and its descendants into `out`, parents before children.
fn tree_of(nodes: &[Node], m: u32, out: &mut Vec<u32>) {
    out.clear();
    out.push(m);
    let mut i = 0;
    while i < out.len() {
        let x = out[i] as usize;
        out.extend_from_slice(&nodes[x].children);
        i += 1;
    }
}

/// Whether a body reaches below the ground (z < 0): a move that puts it there is refused.
fn below_ground(body: &Body) -> bool {
    body.blocks.iter().any(|b| b.zmin < 0.0)
}

/// Which models stop a move of the tree rooted at `root`: unrelated ones with
/// `obstacle_return`.
fn obstacle_to(nodes: &[Node], root: u32) -> impl Fn(u32) -> bool + Copy + '_ {
    move |o| {
        let n = &nodes[o as usize];
        n.root != root && n.obstacle_return
    }
}

/// The global pose of a child at `pose` in `parent`'s frame (stacked on top of it if the
/// parent stacks its children).
fn global_of_parent(parent: &Node, parent_global: &Pose, pose: &Pose) -> Pose {
    let mut g = parent_global.compose(pose);
    if parent.stack_children {
        g.z += parent.size[2];
    }
    g
}

impl World {
    /// Builds a world from a description; `seed` drives every random choice.
    pub fn from_desc(desc: &WorldDesc, seed: u64) -> Result<World> {
        if desc.interval_sim_us == 0 {
            return Err(Error::InvalidWorld("interval_sim must be positive".into()));
        }
        let n = desc.models.len();
        if n >= u32::MAX as usize {
            return Err(Error::InvalidWorld("too many models".into()));
        }
        let mut nodes: Vec<Node> = Vec::with_capacity(n);
        for (i, m) in desc.models.iter().enumerate() {
            if let Some(p) = m.parent {
                if p >= i {
                    return Err(Error::InvalidModel {
                        model: m.name.clone(),
                        source_loc: m.source.clone(),
                        msg: format!("parent index {p} is not an earlier model"),
                    });
                }
            }
            for v in m
                .size
                .iter()
                .chain([m.pose.x, m.pose.y, m.pose.z, m.pose.a].iter())
            {
                if !v.is_finite() {
                    return Err(Error::InvalidModel {
                        model: m.name.clone(),
                        source_loc: m.source.clone(),
                        msg: "pose or size is not finite".into(),
                    });
                }
            }
            let root = match m.parent {
                Some(p) => nodes[p].root,
                None => i as u32,
            };
            if let Some(p) = m.parent {
                nodes[p].children.push(i as u32);
            }
            nodes.push(Node {
                name: m.name.clone(),
                model_type: m.kind.model_type(),
                parent: m.parent.map(|p| p as u32),
                children: Vec::new(),
                root,
                size: m.size,
                origin: m.origin,
                stack_children: m.stack_children,
                obstacle_return: m.obstacle_return,
                ranger_return: m.ranger_return,
                fiducial_return: m.fiducial_return,
                fiducial_key: m.fiducial_key,
                gripper_return: m.gripper_return,
                update_interval_us: m.update_interval_us.max(1),
                mass: m.mass,
                blocks: local_blocks(m)?,
                source: m.source.clone(),
            });
        }
        let poses: Vec<Pose> = desc.models.iter().map(|m| m.pose).collect();
        let mut globals = vec![Pose::ZERO; n];
        for i in 0..n {
            globals[i] = global_of(&nodes, &globals, i, &poses[i]);
        }
        // A tree that contains a position model can move: its bodies are dynamic.
        let mut moving_root = vec![false; n];
        for (i, m) in desc.models.iter().enumerate() {
            if matches!(m.kind, KindDesc::Position(_)) {
                moving_root[nodes[i].root as usize] = true;
            }
        }
        let dynamic: Vec<bool> = (0..n)
            .map(|i| moving_root[nodes[i].root as usize])
            .collect();
        let mut bodies = vec![Body::default(); n];
        for i in 0..n {
            body_of(&nodes[i], &globals[i], &mut bodies[i]);
        }
        let space = Space::new(bodies, &dynamic, nodes.iter().map(|n| n.root).collect());

        let mut names = HashMap::new();
        for (i, m) in desc.models.iter().enumerate() {
            for a in &m.aliases {
                names.insert(a.clone(), i as u32);
            }
            names.insert(m.name.clone(), i as u32);
        }

        let mut states = Vec::with_capacity(n);
        let mut positions = Vec::new();
        for (i, m) in desc.models.iter().enumerate() {
            let mut rng = SimRng::new(seed, i as u64);
            let kind = KindState::new(&m.kind, &globals[i], &mut rng);
            if matches!(kind, KindState::Position(_)) {
                positions.push(i as u32);
            }
            // a kind that shapes its own body (the gripper's base and paddles, spec §11.2)
            if let Some(blocks) = kind.own_blocks(m.size) {
                let tmp = ModelDesc {
                    blocks,
                    default_body: false,
                    ..m.clone()
                };
                nodes[i].blocks = local_blocks(&tmp)?;
            }
            let self_start = kind.starts_itself();
            states.push(ModelState {
                subs: 0,
                next_update: nodes[i].update_interval_us.max(1),
                self_start,
                updated_at: None,
                rng,
                kind,
            });
        }
        let fiducial_targets = (0..n as u32)
            .filter(|&i| nodes[i as usize].fiducial_return != 0)
            .collect();

        let mut world = World {
            cfg: WorldConfig {
                name: desc.name.clone(),
                interval_sim_us: desc.interval_sim_us,
                quit_time_us: desc.quit_time_us,
                resolution: desc.resolution,
                speedup: desc.speedup,
                paused: desc.paused,
                threads: desc.threads.max(1),
                show_clock: desc.show_clock,
                show_clock_interval: desc.show_clock_interval.max(1),
            },
            seed,
            sim_time: 0,
            updates: 0,
            colors: desc.models.iter().map(|m| m.color).collect(),
            says: desc.models.iter().map(|m| m.say.clone()).collect(),
            nodes,
            poses,
            globals,
            space,
            states,
            names,
            positions,
            fiducial_targets,
            controllers: Vec::new(),
            warnings: Vec::new(),
            rays_cast: 0,
            due: vec![false; n],
            updated: vec![false; n],
            subtree: Vec::new(),
            scratch: Vec::new(),
            move_plans: Vec::new(),
        };
        // gripper bodies were replaced above: refresh their world outlines
        for i in 0..n {
            if matches!(world.states[i].kind, KindState::Gripper(_)) {
                world.refresh_subtree(i as u32);
            }
        }
        for (i, m) in desc.models.iter().enumerate() {
            if m.alwayson {
                world.subscribe(ModelId(i as u32));
            }
        }
        for (i, m) in desc.models.iter().enumerate() {
            for c in &m.ctrl {
                let name = c.split_whitespace().next().unwrap_or("");
                if name.is_empty() {
                    continue;
                }
                let rng = SimRng::new(seed ^ 0x5eed_c0de, i as u64);
                match controller::builtin(name, &world, ModelId(i as u32), c, rng) {
                    Ok(Some(inst)) => world.install_controller(inst),
                    Ok(None) => {
                        let msg = format!(
                            "controller {name} is not built in; model {} runs without it",
                            m.name
                        );
                        tracing::warn!("{msg}");
                        world.warnings.push(msg);
                    }
                    Err(e) => {
                        let msg = format!("controller {name} on model {}: {e}", m.name);
                        tracing::warn!("{msg}");
                        world.warnings.push(msg);
                    }
                }
            }
        }
        Ok(world)
    }

    fn install_controller(&mut self, inst: controller::Installed) {
        for s in &inst.subscribe {
            self.subscribe(*s);
        }
        for c in inst.init {
            self.apply(c);
        }
        self.controllers.push(ControllerSlot {
            model: inst.model.0,
            trigger: inst.trigger.0,
            ctrl: inst.ctrl,
        });
    }

    /// Attaches a controller to `model`, called after each update of `trigger` (which is
    /// subscribed, as is `model`). Commands it emits are applied after the step's moves.
    pub fn add_controller(&mut self, model: ModelId, trigger: ModelId, ctrl: Box<dyn Controller>) {
        self.install_controller(controller::Installed {
            model,
            trigger,
            subscribe: vec![model, trigger],
            init: Vec::new(),
            ctrl,
        });
    }

    // ----- clock -------------------------------------------------------------------------

    /// World settings.
    pub fn config(&self) -> &WorldConfig {
        &self.cfg
    }

    /// Overrides the quit time (µs; 0 = never).
    pub fn set_quit_time_us(&mut self, t: u64) {
        self.cfg.quit_time_us = t;
    }

    /// The seed the world was built with.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// Simulated time (µs).
    pub fn sim_time(&self) -> u64 {
        self.sim_time
    }

    /// Number of steps taken.
    pub fn updates(&self) -> u64 {
        self.updates
    }

    /// Rays cast so far (for benchmarks).
    pub fn rays_cast(&self) -> u64 {
        self.rays_cast
    }

    /// Warnings collected while building (unknown controllers, unsupported models).
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }

    /// Adds build warnings (used by loaders that translate other formats).
    pub fn add_warnings(&mut self, w: impl IntoIterator<Item = String>) {
        for m in w {
            tracing::warn!("{m}");
            self.warnings.push(m);
        }
    }

    /// Whether `quit_time` has been reached (further steps do nothing).
    pub fn done(&self) -> bool {
        self.cfg.quit_time_us > 0 && self.sim_time >= self.cfg.quit_time_us
    }

    /// Advances the world by one `interval_sim` (spec §5.2). Returns `false` (and does nothing)
    /// once `quit_time` is reached.
    ///
    /// 1. every due, subscribed model updates against the state at the end of the previous step
    ///    (in parallel when there is enough work; results do not depend on the thread count);
    /// 2. gripper grasps/releases, then position models move one at a time in creation order,
    ///    each tested for contact against the already-moved state;
    /// 3. controllers of models that updated run (in parallel) and their commands are applied
    ///    in controller order; they take effect at the next step, as Stage's callbacks do.
    pub fn step(&mut self) -> bool {
        if self.done() {
            return false;
        }
        self.sim_time += self.cfg.interval_sim_us;
        let now = self.sim_time;
        let dt = self.cfg.interval_sim_us as f64 * 1e-6;

        // ---- phase 1: updates ----
        let mut rays = 0usize;
        let mut any = false;
        for (i, st) in self.states.iter().enumerate() {
            let d = (st.subs > 0 || st.self_start) && st.next_update <= now;
            self.due[i] = d;
            self.updated[i] = d;
            if d {
                any = true;
                rays += st.kind.ray_cost();
            }
        }
        if any {
            let view = View {
                nodes: &self.nodes,
                globals: &self.globals,
                colors: &self.colors,
                space: &self.space,
                fiducial_targets: &self.fiducial_targets,
                sim_time: now,
                dt,
            };
            let poses = &self.poses;
            let due = &self.due;
            let run = |(i, st): (usize, &mut ModelState)| {
                if due[i] {
                    update_model(&view, i as u32, &poses[i], st);
                }
            };
            if rays >= PARALLEL_MIN_RAYS {
                self.states
                    .par_iter_mut()
                    .enumerate()
                    .with_min_len(16)
                    .for_each(run);
            } else {
                self.states.iter_mut().enumerate().for_each(run);
            }
            self.rays_cast += rays as u64;
        }

        // ---- phase 2: grasps, body changes, moves ----
        if any {
            for i in 0..self.states.len() {
                if !self.due[i] {
                    continue;
                }
                if let KindState::Gripper(g) = &mut self.states[i].kind {
                    let action = g.action.take();
                    let changed = std::mem::take(&mut g.body_changed);
                    let size = self.nodes[i].size;
                    let blocks = changed.then(|| g.blocks(size));
                    if let Some(blocks) = blocks {
                        self.set_blocks(i as u32, &blocks);
                    }
                    match action {
                        Some(GripAction::Grasp(obj)) => self.grasp(i as u32, obj),
                        Some(GripAction::Release(obj)) => self.release(i as u32, obj),
                        None => {}
                    }
                }
            }
        }
        self.move_all(dt);

        // ---- phase 3: controllers ----
        if any && !self.controllers.is_empty() {
            let mut slots = std::mem::take(&mut self.controllers);
            let world = &*self;
            let run = |slot: &mut ControllerSlot| {
                let mut cmds = Commands::new(ModelId(slot.model));
                if world.updated[slot.trigger as usize] {
                    slot.ctrl.update(world, &mut cmds);
                }
                cmds
            };
            let mut outs: Vec<Commands> = if slots.len() >= 512 {
                slots.par_iter_mut().with_min_len(32).map(run).collect()
            } else {
                slots.iter_mut().map(run).collect()
            };
            self.controllers = slots;
            for out in outs.iter_mut() {
                for c in out.drain() {
                    self.apply(c);
                }
            }
        }
        self.updates += 1;
        true
    }

    /// Applies one controller command.
    pub fn apply(&mut self, c: Command) {
        match c {
            Command::Velocity(m, x, y, a) => {
                let _ = self.position_cmd_vel(m, x, y, a);
            }
            Command::Subscribe(m) => self.subscribe(m),
            Command::Unsubscribe(m) => self.unsubscribe(m),
            Command::SetColor(m, col) => self.set_color(m, col),
            Command::Say(m, s) => self.say(m, &s),
            Command::RangerNoise(m, sd) => {
                if let Some(KindState::Ranger(r)) =
                    self.states.get_mut(m.index()).map(|s| &mut s.kind)
                {
                    for s in &mut r.sensors {
                        s.noise_relative = sd;
                    }
                }
            }
        }
    }

    /// Whether model `m`'s world outline is recomputed when it moves: not for models that have
    /// no blocks and no outline (their empty body stays as it is).
    fn outline_kept_fresh(&self, m: u32) -> bool {
        !(self.space.body(m).is_empty() && self.nodes[m as usize].blocks.is_empty())
    }

    /// How far position model `m` moves this step (in its own frame); `None` when it does not
    /// move (unsubscribed, or no velocity).
    fn move_delta(&self, m: u32, dt: f64) -> Option<Pose> {
        let st = &self.states[m as usize];
        match &st.kind {
            KindState::Position(p) if st.subs > 0 => p.step_delta(dt),
            _ => None,
        }
    }

    fn move_model(&mut self, m: u32, dt: f64) {
        let i = m as usize;
        let Some(delta) = self.move_delta(m, dt) else {
            return;
        };
        let old = self.poses[i];
        self.poses[i] = old.compose(&delta);
        self.refresh_subtree(m);
        let hit = self.contact(m);
        if hit {
            self.poses[i] = old;
            self.refresh_subtree(m);
        }
        if let KindState::Position(p) = &mut self.states[i].kind {
            p.set_stall(hit);
        }
    }

    /// Whether model `m`'s tree (from `m` down) touches an unrelated obstacle or the ground.
    fn contact(&mut self, m: u32) -> bool {
        self.collect_subtree(m);
        let root = self.nodes[m as usize].root;
        let mut movers = std::mem::take(&mut self.subtree);
        movers.retain(|&s| self.nodes[s as usize].obstacle_return);
        let ground = movers.iter().any(|&s| below_ground(self.space.body(s)));
        let hit = ground
            || self
                .space
                .first_contact(&movers, &mut self.scratch, obstacle_to(&self.nodes, root))
                .is_some();
        self.subtree = movers;
        hit
    }

    /// Collects `m` and its descendants into `self.subtree`, parents before children.
    fn collect_subtree(&mut self, m: u32) {
        tree_of(&self.nodes, m, &mut self.subtree);
    }

    /// Recomputes global poses and world outlines of `m` and its descendants.
    fn refresh_subtree(&mut self, m: u32) {
        self.collect_subtree(m);
        let list = std::mem::take(&mut self.subtree);
        for &x in &list {
            let xi = x as usize;
            self.globals[xi] = global_of(&self.nodes, &self.globals, xi, &self.poses[xi]);
            if !self.outline_kept_fresh(x) {
                continue;
            }
            let node = &self.nodes[xi];
            let g = self.globals[xi];
            body_of(node, &g, self.space.body_mut(x));
            self.space.commit_body(x);
        }
        self.subtree = list;
    }

    fn set_blocks(&mut self, m: u32, blocks: &[BlockDesc]) {
        let n = &self.nodes[m as usize];
        let tmp = ModelDesc {
            size: n.size,
            blocks: blocks.to_vec(),
            default_body: false,
            ..ModelDesc::new(&n.name, KindDesc::Model)
        };
        if let Ok(b) = local_blocks(&tmp) {
            self.nodes[m as usize].blocks = b;
            self.refresh_subtree(m);
        }
    }

    fn set_root(&mut self, m: u32, root: u32) {
        self.collect_subtree(m);
        let list = std::mem::take(&mut self.subtree);
        for &x in &list {
            self.nodes[x as usize].root = root;
            self.space.set_root(x, root);
        }
        self.subtree = list;
    }

    fn reparent(&mut self, m: u32, parent: Option<u32>, local: Pose) {
        let i = m as usize;
        if let Some(old) = self.nodes[i].parent {
            self.nodes[old as usize].children.retain(|&c| c != m);
        }
        self.nodes[i].parent = parent;
        let root = match parent {
            Some(p) => {
                self.nodes[p as usize].children.push(m);
                self.nodes[p as usize].root
            }
            None => m,
        };
        self.set_root(m, root);
        self.poses[i] = local;
        self.refresh_subtree(m);
    }

    fn grasp(&mut self, gripper: u32, obj: u32) {
        // an object already carried elsewhere (or an ancestor of the gripper) cannot be taken
        let mut a = Some(gripper);
        while let Some(x) = a {
            if x == obj {
                return;
            }
            a = self.nodes[x as usize].parent;
        }
        if self.nodes[obj as usize].parent.is_some() {
            if let KindState::Gripper(g) = &mut self.states[gripper as usize].kind {
                g.data.carrying = None;
                g.close_limit = 1.0;
            }
            return;
        }
        let sz = self.nodes[gripper as usize].size[2];
        self.reparent(
            obj,
            Some(gripper),
            Pose {
                x: 0.0,
                y: 0.0,
                z: -sz,
                a: 0.0,
            },
        );
    }

    fn release(&mut self, gripper: u32, obj: u32) {
        if self.nodes[obj as usize].parent != Some(gripper) {
            return;
        }
        // dropped at the gripper's global pose, height included (Stage quirk, spec §11.3)
        let g = self.globals[gripper as usize];
        self.reparent(obj, None, g);
    }

    // ----- tree and names ----------------------------------------------------------------

    /// Number of models.
    pub fn model_count(&self) -> usize {
        self.nodes.len()
    }

    /// Every model id in creation order.
    pub fn models(&self) -> impl Iterator<Item = ModelId> + '_ {
        (0..self.nodes.len() as u32).map(ModelId)
    }

    /// The model registered under `name` (the last one registered wins, as in Stage).
    pub fn model_by_name(&self, name: &str) -> Option<ModelId> {
        self.names.get(name).map(|&i| ModelId(i))
    }

    /// Tree and configuration data of a model.
    pub fn node(&self, m: ModelId) -> &Node {
        &self.nodes[m.index()]
    }

    /// The model's name.
    pub fn name(&self, m: ModelId) -> &str {
        &self.nodes[m.index()].name
    }

    /// The model's Stage type: what code compares (the compiler checks every name).
    pub fn model_type(&self, m: ModelId) -> ModelType {
        self.nodes[m.index()].model_type
    }

    /// The model's Stage type word (`position`, `ranger`, …), for messages and display.
    pub fn type_name(&self, m: ModelId) -> &'static str {
        self.model_type(m).name()
    }

    /// The parent model.
    pub fn parent(&self, m: ModelId) -> Option<ModelId> {
        self.nodes[m.index()].parent.map(ModelId)
    }

    /// Children in creation order.
    pub fn children(&self, m: ModelId) -> impl Iterator<Item = ModelId> + '_ {
        self.nodes[m.index()].children.iter().map(|&c| ModelId(c))
    }

    /// `m` and its descendants in pre-order (how the stage driver binds devices).
    pub fn subtree(&self, m: ModelId) -> Vec<ModelId> {
        let mut out = Vec::new();
        let mut stack = vec![m.0];
        while let Some(x) = stack.pop() {
            out.push(ModelId(x));
            for &c in self.nodes[x as usize].children.iter().rev() {
                stack.push(c);
            }
        }
        out
    }

    /// Top-level models in creation order.
    pub fn roots(&self) -> impl Iterator<Item = ModelId> + '_ {
        self.models()
            .filter(|m| self.nodes[m.index()].parent.is_none())
    }

    /// Whether two models are in the same tree (they never see or touch each other).
    pub fn related(&self, a: ModelId, b: ModelId) -> bool {
        self.nodes[a.index()].root == self.nodes[b.index()].root
    }

    // ----- subscriptions -----------------------------------------------------------------

    /// Adds a subscription. The first one starts the model: it updates every
    /// `update_interval` from now on (only subscribed models update, spec §5.4).
    pub fn subscribe(&mut self, m: ModelId) {
        let now = self.sim_time;
        let interval = self.nodes[m.index()].update_interval_us;
        let st = &mut self.states[m.index()];
        st.subs += 1;
        if st.subs == 1 {
            st.next_update = now + interval;
        }
    }

    /// Removes a subscription; the last one shuts the model down (position models stop,
    /// actuators drop their goal, sensors clear their data).
    pub fn unsubscribe(&mut self, m: ModelId) {
        let st = &mut self.states[m.index()];
        if st.subs == 0 {
            return;
        }
        st.subs -= 1;
        if st.subs == 0 {
            st.kind.shutdown();
        }
    }

    /// Current subscription count.
    pub fn subscriptions(&self, m: ModelId) -> u32 {
        self.states[m.index()].subs
    }

    /// Sim time of the model's last update, if any.
    pub fn last_update(&self, m: ModelId) -> Option<u64> {
        self.states[m.index()].updated_at
    }

    // ----- poses and colours -------------------------------------------------------------

    /// Pose in the parent frame.
    pub fn pose(&self, m: ModelId) -> Pose {
        self.poses[m.index()]
    }

    /// Sets the pose in the parent frame (the simulation interface; no collision test, as in
    /// Stage).
    pub fn set_pose(&mut self, m: ModelId, p: Pose) {
        self.poses[m.index()] = Pose::new(p.x, p.y, p.z, p.a);
        self.refresh_subtree(m.0);
    }

    /// Global pose of the model's pose point (with child stacking).
    pub fn global_pose(&self, m: ModelId) -> Pose {
        self.globals[m.index()]
    }

    /// The model's colour.
    pub fn color(&self, m: ModelId) -> Color {
        self.colors[m.index()]
    }

    /// Recolours the model (blocks without their own colour follow).
    pub fn set_color(&mut self, m: ModelId, c: Color) {
        self.colors[m.index()] = c;
    }

    /// Colour of block `b` of model `m`.
    pub fn block_color(&self, m: ModelId, b: usize) -> Color {
        self.nodes[m.index()].blocks[b]
            .color
            .unwrap_or(self.colors[m.index()])
    }

    /// The model's body in world coordinates (for drawing; borrowed, not copied).
    pub fn body(&self, m: ModelId) -> &Body {
        self.space.body(m.0)
    }

    /// The model's own blocks (not its children's), as they are now, rasterised onto square
    /// cells of `cell` metres ([`Raster`], for serving a model as a grid map). The grid spans
    /// the world-axis-aligned bounding box of the model's footprint (its `size` rectangle at
    /// its current pose), rounded up to whole cells from its lower-left corner. `None` when
    /// `cell` is not a positive length or the grid would have more than `max_cells` cells.
    pub fn rasterize(&self, m: ModelId, cell: f64, max_cells: usize) -> Option<Raster> {
        if !(cell > 0.0 && cell.is_finite()) {
            return None;
        }
        let node = &self.nodes[m.index()];
        let frame = self.globals[m.index()].compose(&node.origin);
        let [hx, hy] = [node.size[0] / 2.0, node.size[1] / 2.0];
        let mut bb = Aabb::EMPTY;
        for (x, y) in [(-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy)] {
            let (wx, wy) = frame.transform_xy(x, y);
            bb.add([wx, wy]);
        }
        // An extent of a whole number of cells (up to rounding) gets no extra sliver of a cell.
        let count = |len: f64| (len / cell - crate::raster::SLIVER).ceil().max(0.0);
        let (w, h) = (count(bb.max[0] - bb.min[0]), count(bb.max[1] - bb.min[1]));
        if w * h > max_cells as f64 {
            return None;
        }
        let mut raster = Raster::new(bb.min, cell, w as usize, h as usize);
        let body = self.space.body(m.0);
        for b in 0..body.blocks.len() {
            raster.fill_polygon(body.block_pts(b));
        }
        Some(raster)
    }

    /// The spatial engine (for viewers and tools that cast their own rays).
    pub fn space(&self) -> &Space {
        &self.space
    }

    /// Casts a ray from a world pose; models in `exclude`'s tree are ignored.
    pub fn raycast(&self, q: &RayQuery, exclude: Option<ModelId>) -> Option<RayHit> {
        let root = exclude.map(|m| self.nodes[m.index()].root);
        self.space
            .raycast(q, |h| Some(self.nodes[h as usize].root) != root)
    }

    /// Speech-bubble text.
    pub fn said(&self, m: ModelId) -> &str {
        &self.says[m.index()]
    }

    /// Sets the speech-bubble text (`say`).
    pub fn say(&mut self, m: ModelId, text: &str) {
        self.says[m.index()] = text.to_string();
    }

    // ----- position ----------------------------------------------------------------------

    fn position_mut(&mut self, m: ModelId) -> Result<&mut PositionModel> {
        match self.states.get_mut(m.index()).map(|s| &mut s.kind) {
            Some(KindState::Position(p)) => Ok(p),
            _ => Err(Error::BadModel {
                id: m.0,
                msg: "not a position model".into(),
            }),
        }
    }

    /// Velocity command (Player CMD_VEL): m/s, m/s, rad/s.
    pub fn position_cmd_vel(&mut self, m: ModelId, vx: f64, vy: f64, va: f64) -> Result<()> {
        self.position_mut(m)?.command_velocity(vx, vy, va);
        Ok(())
    }

    /// Position command in the odometry frame (Player CMD_POS).
    pub fn position_cmd_pos(&mut self, m: ModelId, x: f64, y: f64, a: f64) -> Result<()> {
        self.position_mut(m)?.command_position(x, y, a);
        Ok(())
    }

    /// Car command (Player CMD_CAR): speed and steering angle (turn rate for `diff` drive).
    pub fn position_cmd_car(&mut self, m: ModelId, speed: f64, angle: f64) -> Result<()> {
        self.position_mut(m)?.command_velocity(speed, 0.0, angle);
        Ok(())
    }

    /// Acceleration command (API only).
    pub fn position_cmd_accel(&mut self, m: ModelId, ax: f64, ay: f64, aa: f64) -> Result<()> {
        self.position_mut(m)?.command_acceleration(ax, ay, aa);
        Ok(())
    }

    /// Odometry pose, velocity and stall as last updated.
    pub fn position_state(&self, m: ModelId) -> Option<&PositionData> {
        match &self.states.get(m.index())?.kind {
            KindState::Position(p) => Some(&p.data),
            _ => None,
        }
    }

    /// The whole position model (configuration, goal, odometry error).
    pub fn position_model(&self, m: ModelId) -> Option<&PositionModel> {
        match &self.states.get(m.index())?.kind {
            KindState::Position(p) => Some(p),
            _ => None,
        }
    }

    /// Player SET_ODOM.
    pub fn set_odom(&mut self, m: ModelId, p: Pose) -> Result<()> {
        self.position_mut(m)?.set_odom(p);
        Ok(())
    }

    /// Player RESET_ODOM.
    pub fn reset_odom(&mut self, m: ModelId) -> Result<()> {
        self.position_mut(m)?.set_odom(Pose::ZERO);
        Ok(())
    }

    // ----- sensors -----------------------------------------------------------------------

    /// Ranger configuration and latest scans.
    pub fn ranger_scans(&self, m: ModelId) -> Option<&RangerData> {
        match &self.states.get(m.index())?.kind {
            KindState::Ranger(r) => Some(r),
            _ => None,
        }
    }

    /// Blobfinder data.
    pub fn blobfinder_blobs(&self, m: ModelId) -> Option<&BlobfinderData> {
        match &self.states.get(m.index())?.kind {
            KindState::Blobfinder(b) => Some(&b.data),
            _ => None,
        }
    }

    /// Blobfinder configuration.
    pub fn blobfinder_config(&self, m: ModelId) -> Option<&crate::desc::BlobfinderDesc> {
        match &self.states.get(m.index())?.kind {
            KindState::Blobfinder(b) => Some(&b.cfg),
            _ => None,
        }
    }

    /// Fiducial detections.
    pub fn fiducials(&self, m: ModelId) -> Option<&FiducialData> {
        match &self.states.get(m.index())?.kind {
            KindState::Fiducial(_, d) => Some(d),
            _ => None,
        }
    }

    /// Fiducial-finder configuration.
    pub fn fiducial_config(&self, m: ModelId) -> Option<&crate::desc::FiducialDesc> {
        match &self.states.get(m.index())?.kind {
            KindState::Fiducial(c, _) => Some(c),
            _ => None,
        }
    }

    /// The model's own `fiducial_return` (Player fiducial GET_ID).
    pub fn fiducial_id(&self, m: ModelId) -> i32 {
        self.nodes[m.index()].fiducial_return
    }

    /// Sets the model's own `fiducial_return` (Player fiducial SET_ID).
    pub fn set_fiducial_id(&mut self, m: ModelId, id: i32) {
        self.nodes[m.index()].fiducial_return = id;
        self.fiducial_targets = (0..self.nodes.len() as u32)
            .filter(|&i| self.nodes[i as usize].fiducial_return != 0)
            .collect();
    }

    /// Gripper state.
    pub fn gripper_state(&self, m: ModelId) -> Option<&GripperData> {
        match &self.states.get(m.index())?.kind {
            KindState::Gripper(g) => Some(&g.data),
            _ => None,
        }
    }

    /// Gripper command (persists until replaced).
    pub fn gripper_cmd(&mut self, m: ModelId, cmd: GripperCmd) -> Result<()> {
        match self.states.get_mut(m.index()).map(|s| &mut s.kind) {
            Some(KindState::Gripper(g)) => {
                g.cmd = cmd;
                Ok(())
            }
            _ => Err(Error::BadModel {
                id: m.0,
                msg: "not a gripper".into(),
            }),
        }
    }

    /// Camera image.
    pub fn camera_image(&self, m: ModelId) -> Option<&CameraImage> {
        match &self.states.get(m.index())?.kind {
            KindState::Camera(c) => Some(&c.image),
            _ => None,
        }
    }

    /// Actuator data.
    pub fn actuator(&self, m: ModelId) -> Option<&ActuatorData> {
        match &self.states.get(m.index())?.kind {
            KindState::Actuator(a) => Some(&a.data),
            _ => None,
        }
    }

    /// Actuator command: position (`position = true`) or speed goal.
    pub fn actuator_cmd(&mut self, m: ModelId, position: bool, goal: f64) -> Result<()> {
        match self.states.get_mut(m.index()).map(|s| &mut s.kind) {
            Some(KindState::Actuator(a)) => {
                a.mode = if position {
                    ActuatorMode::Position
                } else {
                    ActuatorMode::Velocity
                };
                a.goal = goal;
                Ok(())
            }
            _ => Err(Error::BadModel {
                id: m.0,
                msg: "not an actuator".into(),
            }),
        }
    }

    /// Light state of a blinkenlight or light indicator.
    pub fn light_on(&self, m: ModelId) -> Option<bool> {
        match &self.states.get(m.index())?.kind {
            KindState::Blinkenlight { on } | KindState::LightIndicator { on } => Some(*on),
            _ => None,
        }
    }

    /// Switches a light indicator.
    pub fn set_light(&mut self, m: ModelId, value: bool) {
        if let Some(KindState::LightIndicator { on } | KindState::Blinkenlight { on }) =
            self.states.get_mut(m.index()).map(|s| &mut s.kind)
        {
            *on = value;
        }
    }

    /// A 64-bit digest of every pose, velocity and sensor output: equal digests mean equal
    /// states (used by determinism tests).
    pub fn state_digest(&self) -> u64 {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        let mut eat = |v: u64| {
            h ^= v;
            h = h.wrapping_mul(0x0100_0000_01b3);
        };
        let f = |x: f64| x.to_bits();
        eat(self.sim_time);
        for i in 0..self.nodes.len() {
            let p = self.poses[i];
            for v in [p.x, p.y, p.z, p.a] {
                eat(f(v));
            }
            self.states[i].kind.digest(&mut eat);
        }
        h
    }
}

fn update_model(v: &View, m: u32, local: &Pose, st: &mut ModelState) {
    let node = &v.nodes[m as usize];
    st.kind.update(v, m, local, node, &mut st.rng);
    st.self_start = false;
    st.updated_at = Some(v.sim_time);
    st.next_update = v.sim_time + node.update_interval_us;
}
