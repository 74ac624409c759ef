//! The step: its three phases, command application, and moves one model at a time.

use rayon::prelude::*;

use crate::controller::Command;
use crate::desc::{BlockDesc, KindDesc, ModelDesc};
use crate::models::KindState;
use crate::models::gripper::GripAction;
use crate::pose::Pose;

use super::tree::*;
use super::*;

/// Stack below this many rays per step is run on the calling thread (fork/join costs more).
const PARALLEL_MIN_RAYS: usize = 1024;

/// Most models in one piece of a step's parallel updates (the threads take pieces in turn),
/// unless there are more than [`PIECES_PER_STEP`] such pieces.
const SMALL_PIECE: usize = 4;

/// Roughly how many pieces a step's parallel updates are cut into at the most: in a world of
/// many models the pieces grow instead (each split costs a fork).
const PIECES_PER_STEP: usize = 512;

impl World {
    /// Advances the world by one `interval_sim` (spec §5.2). Returns `false` (and does nothing)
    /// once `quit_time` is reached.
    ///
    /// 1. every due, subscribed model updates against the state at the end of the previous step
    ///    (in parallel when there is enough work; results do not depend on the thread count);
    /// 2. gripper grasps/releases, then position models move one at a time in creation order,
    ///    each tested for contact against the already-moved state;
    /// 3. controllers of models that updated run (in parallel, and beside the ordered moves of
    ///    2: they read only sensor data) and their commands are applied in controller order;
    ///    they take effect at the next step, as Stage's callbacks do.
    ///
    /// Called from outside any rayon pool, the step runs on the simulation's pool
    /// ([`crate::pool::sim_pool`], which survives `fork`) rather than letting its splits reach
    /// rayon's global pool; a loop of steps is cheaper inside [`crate::on_sim_threads`].
    pub fn step(&mut self) -> bool {
        if rayon::current_thread_index().is_none() {
            return crate::pool::on_sim_threads(|| self.step());
        }
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
                returns: &self.returns,
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
                    update_model(&view, ModelId(i as u32), &poses[i], st);
                }
            };
            // (on one thread, cutting the work into pieces would only cost the cuts)
            if rays >= PARALLEL_MIN_RAYS && rayon::current_num_threads() > 1 {
                // pieces of a few models, so that the threads finish together: left to split
                // pieces of 16 or more, one thread would end its share 20-50 µs before the
                // other each step (hospital: 26-31 ms of its 60 s run, cave 12 ms; with pieces
                // of at most 4, 2-4 ms and 1.7 ms). A large swarm's pieces grow so that a step
                // splits some 512 times, not thousands
                let piece = (self.states.len() / PIECES_PER_STEP).max(SMALL_PIECE);
                self.states
                    .par_iter_mut()
                    .enumerate()
                    .with_max_len(piece)
                    .for_each(run);
            } else {
                self.states.iter_mut().enumerate().for_each(run);
            }
            self.rays_cast += rays as u64;
        }

        // ---- phase 2: grasps, body changes, moves ----
        if any {
            for k in 0..self.grippers.len() {
                let i = self.grippers[k].index();
                if !self.due[i] {
                    continue;
                }
                if let KindState::Gripper(g) = &mut self.states[i].kind {
                    let action = g.action.take();
                    let changed = std::mem::take(&mut g.body_changed);
                    let size = self.nodes[i].size;
                    let blocks = changed.then(|| g.blocks(size));
                    if let Some(blocks) = blocks {
                        self.set_blocks(ModelId(i as u32), &blocks);
                    }
                    match action {
                        Some(GripAction::Grasp(obj)) => self.grasp(ModelId(i as u32), obj),
                        Some(GripAction::Release(obj)) => self.release(ModelId(i as u32), obj),
                        None => {}
                    }
                }
            }
        }
        // ---- phase 2 continued: moves; phase 3: controllers ----
        // Controllers read only the sensor data of phase 1 (`Sensors`), which the moves leave
        // alone, so they run beside the ordered move pass, on the other core; their commands
        // are applied after both, in controller order.
        if !any || self.controllers.is_empty() {
            self.move_all(dt, None);
        } else {
            let mut slots = std::mem::take(&mut self.controllers);
            let mut run_all = |sensors: &Sensors<'_>, updated: &[bool]| {
                let run = |slot: &mut ControllerSlot| {
                    if updated[slot.trigger.index()] {
                        slot.ctrl.update(sensors, &mut slot.cmds);
                    }
                };
                // on the pool's own threads (`on_sim_threads`) a split costs about a
                // microsecond: cave's 100 controllers gain ~3% steps/s from it (5 alternating
                // runs, 2 cores)
                if slots.len() >= 64 {
                    slots.par_iter_mut().with_min_len(16).for_each(run);
                } else {
                    slots.iter_mut().for_each(run);
                }
            };
            self.move_all(dt, Some(&mut run_all));
            for slot in slots.iter_mut() {
                for c in slot.cmds.drain() {
                    self.apply_logged(c);
                }
            }
            self.controllers = slots;
        }
        self.updates += 1;
        true
    }

    /// Applies one controller command: the error of the call it stands for (a foreign id, a
    /// velocity for a model that is not a position model, noise for one that is not a ranger).
    pub fn apply(&mut self, c: Command) -> Result<()> {
        match c {
            Command::Velocity(m, x, y, a) => self.position_cmd_vel(m, x, y, a),
            Command::Subscribe(m) => self.subscribe(m),
            Command::Unsubscribe(m) => self.unsubscribe(m),
            Command::SetColor(m, col) => self.set_color(m, col),
            Command::Say(m, s) => self.say(m, &s),
            Command::RangerNoise(m, sd) => typed!(self.kind_mut(m), "a ranger",
            KindState::Ranger(r) => {
                for s in &mut r.sensors {
                    s.noise_relative = sd;
                }
            }),
        }
    }

    /// Applies a command queued by a controller, which has no caller to hand an error to: a
    /// refused one is logged and dropped (the controller's bug must not stop the world).
    pub(super) fn apply_logged(&mut self, c: Command) {
        if let Err(e) = self.apply(c) {
            tracing::warn!("controller command refused: {e}");
        }
    }

    /// Whether model `m`'s world outline is recomputed when it moves: not for models that have
    /// no blocks and no outline (their empty body stays as it is).
    pub(super) fn outline_kept_fresh(&self, m: ModelId) -> bool {
        !(self.space.body(m).is_empty() && self.nodes[m.index()].blocks.is_empty())
    }

    /// How far position model `m` moves this step (in its own frame); `None` when it does not
    /// move (unsubscribed, or no velocity).
    pub(super) fn move_delta(&self, m: ModelId, dt: f64) -> Option<Pose> {
        let st = &self.states[m.index()];
        match &st.kind {
            KindState::Position(p) if st.subs > 0 => p.step_delta(dt),
            _ => None,
        }
    }

    pub(super) fn move_model(&mut self, m: ModelId, dt: f64) {
        let i = m.index();
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
    pub(super) fn contact(&mut self, m: ModelId) -> bool {
        self.collect_subtree(m);
        let root = self.nodes[m.index()].root;
        let mut movers = std::mem::take(&mut self.subtree);
        movers.retain(|&s| self.returns[s.index()].obstacle);
        let ground = movers.iter().any(|&s| below_ground(self.space.body(s)));
        let hit = ground
            || self
                .space
                .first_contact(
                    &movers,
                    &mut self.scratch,
                    obstacle_to(&self.space, &self.returns, root),
                )
                .is_some();
        self.subtree = movers;
        hit
    }

    /// Collects `m` and its descendants into `self.subtree`, parents before children.
    pub(super) fn collect_subtree(&mut self, m: ModelId) {
        tree_of(&self.nodes, m, &mut self.subtree);
    }

    /// Recomputes global poses and world outlines of `m` and its descendants.
    pub(super) fn refresh_subtree(&mut self, m: ModelId) {
        self.collect_subtree(m);
        let list = std::mem::take(&mut self.subtree);
        for &x in &list {
            let xi = x.index();
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

    pub(super) fn set_blocks(&mut self, m: ModelId, blocks: &[BlockDesc]) {
        let n = &self.nodes[m.index()];
        let tmp = ModelDesc {
            size: n.size,
            blocks: blocks.to_vec(),
            default_body: false,
            ..ModelDesc::new(&n.name, KindDesc::Model)
        };
        if let Ok(b) = local_blocks(&tmp) {
            self.nodes[m.index()].blocks = b;
            self.refresh_subtree(m);
        }
    }

    pub(super) fn set_root(&mut self, m: ModelId, root: ModelId) {
        self.collect_subtree(m);
        let list = std::mem::take(&mut self.subtree);
        for &x in &list {
            self.nodes[x.index()].root = root;
            self.space.set_root(x, root);
        }
        self.subtree = list;
    }

    pub(super) fn reparent(&mut self, m: ModelId, parent: Option<ModelId>, local: Pose) {
        let i = m.index();
        if let Some(old) = self.nodes[i].parent {
            self.nodes[old.index()].children.retain(|&c| c != m);
        }
        self.nodes[i].parent = parent;
        let root = match parent {
            Some(p) => {
                self.nodes[p.index()].children.push(m);
                self.nodes[p.index()].root
            }
            None => m,
        };
        self.set_root(m, root);
        self.poses[i] = local;
        self.refresh_subtree(m);
    }

    pub(super) fn grasp(&mut self, gripper: ModelId, obj: ModelId) {
        // an object already carried elsewhere (or an ancestor of the gripper) cannot be taken
        let mut a = Some(gripper);
        while let Some(x) = a {
            if x == obj {
                return;
            }
            a = self.nodes[x.index()].parent;
        }
        if self.nodes[obj.index()].parent.is_some() {
            if let KindState::Gripper(g) = &mut self.states[gripper.index()].kind {
                g.data.carrying = None;
                g.close_limit = 1.0;
            }
            return;
        }
        let sz = self.nodes[gripper.index()].size[2];
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

    pub(super) fn release(&mut self, gripper: ModelId, obj: ModelId) {
        if self.nodes[obj.index()].parent != Some(gripper) {
            return;
        }
        // dropped at the gripper's global pose, height included (Stage quirk, spec §11.3)
        let g = self.globals[gripper.index()];
        self.reparent(obj, None, g);
    }
}

pub(super) fn update_model(v: &View, m: ModelId, local: &Pose, st: &mut ModelState) {
    let node = &v.nodes[m.index()];
    st.kind.update(v, m, local, node, &mut st.rng);
    st.self_start = false;
    st.updated_at = Some(v.sim_time);
    st.next_update = v.sim_time + node.update_interval_us;
}
