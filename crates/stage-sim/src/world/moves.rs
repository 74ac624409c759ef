//! Phase 2 of a step: position models move one at a time in creation order, each tested for
//! contact against the already-moved state (the crate docs' step semantics).
//!
//! Most of a move does not depend on the moves before it: the new pose, the new outlines of
//! the robot's tree and the contact test against static blocks (which never change while
//! robots move). That part is planned for every robot at once, in parallel; the ordered pass
//! then only installs the outlines and tests them against moving bodies. Robots whose outlines
//! do depend on earlier moves (a robot carried by another, or carrying one) take the plain
//! one-at-a-time path. Either way the outcome is bit-identical to moving them one by one.

use rayon::prelude::*;

use super::tree::{below_ground, body_of, global_of_parent, obstacle_to, tree_of};
use super::{KindState, ModelId, Sensors, World};
use crate::pose::Pose;
use crate::space::Body;

/// Below this many position models the plans are made on the calling thread.
const PARALLEL_MIN_MOVERS: usize = 16;

/// What the ordered pass does with one position model.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
enum PlanKind {
    /// Not moving this step (unsubscribed or no velocity).
    #[default]
    Still,
    /// Moves in the ordered pass from scratch ([`World::move_model`]).
    OneByOne,
    /// Moves with the plan below.
    Planned,
}

/// One position model's tentative move (buffers kept between steps).
#[derive(Debug, Default)]
pub(super) struct MovePlan {
    kind: PlanKind,
    /// The pose after the move (parent frame).
    pose: Pose,
    /// The model's tree, parents first.
    models: Vec<ModelId>,
    /// Each tree model's global pose after the move.
    globals: Vec<Pose>,
    /// Each tree model's outline after the move (swapped into the space when installed).
    bodies: Vec<Body>,
    /// Whether the model's outline is refreshed at all (bodiless models are skipped).
    refresh: Vec<bool>,
    /// The moved tree touches a static block or the ground: the move is refused.
    static_hit: bool,
    /// The move was refused (statically or by a moving body): the model stalls.
    stalled: bool,
}

/// Work run beside a step's ordered move pass: it gets the models' sensor data and which
/// models updated this step (the step's controllers).
pub(super) type Beside<'a> = &'a mut (dyn FnMut(&Sensors<'_>, &[bool]) + Send);

impl World {
    /// Moves every position model (phase 2 of [`World::step`]), and calls `beside` with the
    /// models' sensor data and which models updated this step: while the moves are installed,
    /// on another thread, when every move was planned (the ordered pass then needs no model
    /// state: the stalls it finds are recorded after it), else after the moves.
    pub(super) fn move_all(&mut self, dt: f64, beside: Option<Beside<'_>>) {
        #[cfg(test)]
        if self.moves_one_by_one {
            for k in 0..self.positions.len() {
                self.move_model(self.positions[k], dt);
            }
            if let Some(b) = beside {
                b(&Sensors::new(&self.states), &self.updated);
            }
            return;
        }
        let mut plans = std::mem::take(&mut self.move_plans);
        // each new plan's lists made now, one plan after another at their full size (the
        // robot's tree), so that the ordered pass, which reads them all in turn, finds them
        // side by side; made by whichever thread plans first they lay scattered, a cache miss
        // each in a large swarm's serial pass
        for k in plans.len()..self.positions.len() {
            let mut plan = MovePlan::default();
            tree_of(&self.nodes, self.positions[k], &mut plan.models);
            let n = plan.models.len();
            plan.globals.reserve_exact(n);
            plan.refresh.reserve_exact(n);
            plan.bodies.resize_with(n, Body::default);
            plans.push(plan);
        }
        plans.truncate(self.positions.len());
        {
            let w = &*self;
            let plan = |(k, p): (usize, &mut MovePlan)| w.plan_move(w.positions[k], dt, p);
            if plans.len() >= PARALLEL_MIN_MOVERS {
                plans
                    .par_iter_mut()
                    .enumerate()
                    .with_min_len(8)
                    .for_each(plan);
            } else {
                plans.iter_mut().enumerate().for_each(plan);
            }
        }
        // the ordered pass: planned moves touch no model state (each plan keeps its stall,
        // recorded after the pass), so with no one-by-one move among them the sensor data can
        // go to `beside` while they are installed
        let ordered = |w: &mut World, plans: &mut [MovePlan]| {
            for (k, plan) in plans.iter_mut().enumerate() {
                let m = w.positions[k];
                match plan.kind {
                    PlanKind::Still => {}
                    PlanKind::OneByOne => w.move_model(m, dt),
                    PlanKind::Planned => w.apply_move(m, plan),
                }
            }
        };
        let parallel = plans.len() >= PARALLEL_MIN_MOVERS;
        match beside {
            Some(b) if parallel && plans.iter().all(|p| p.kind != PlanKind::OneByOne) => {
                let states = std::mem::take(&mut self.states);
                let updated = std::mem::take(&mut self.updated);
                crate::pool::side_by_side(
                    || ordered(self, &mut plans),
                    || b(&Sensors::new(&states), &updated),
                );
                self.states = states;
                self.updated = updated;
                self.record_stalls(&plans);
            }
            beside => {
                if parallel {
                    crate::pool::keeping_a_helper_awake(|| ordered(self, &mut plans));
                } else {
                    ordered(self, &mut plans);
                }
                self.record_stalls(&plans);
                if let Some(b) = beside {
                    b(&Sensors::new(&self.states), &self.updated);
                }
            }
        }
        self.move_plans = plans;
    }

    /// Records in each planned robot's state whether its move was refused.
    fn record_stalls(&mut self, plans: &[MovePlan]) {
        for (k, plan) in plans.iter().enumerate() {
            if plan.kind == PlanKind::Planned
                && let KindState::Position(p) = &mut self.states[self.positions[k].index()].kind
            {
                p.set_stall(plan.stalled);
            }
        }
    }

    /// Plans model `m`'s move from the state before any move of this step.
    fn plan_move(&self, m: ModelId, dt: f64, plan: &mut MovePlan) {
        plan.kind = PlanKind::Still;
        let i = m.index();
        let Some(delta) = self.move_delta(m, dt) else {
            return;
        };
        tree_of(&self.nodes, m, &mut plan.models);
        let carries_robot = plan.models[1..]
            .iter()
            .any(|&x| matches!(self.states[x.index()].kind, KindState::Position(_)));
        if self.nodes[i].parent.is_some() || carries_robot {
            plan.kind = PlanKind::OneByOne;
            return;
        }
        plan.pose = self.poses[i].compose(&delta);
        let n = plan.models.len();
        plan.globals.clear();
        plan.refresh.clear();
        if plan.bodies.len() < n {
            plan.bodies.resize_with(n, Body::default);
        }
        for j in 0..n {
            let x = plan.models[j].index();
            let node = &self.nodes[x];
            let global = match node.parent {
                None => plan.pose,
                Some(par) => {
                    // parents come first in the list
                    let pj = plan.models[..j]
                        .iter()
                        .position(|&y| y == par)
                        .expect("tree_of lists parents before their children");
                    global_of_parent(&self.nodes[par.index()], &plan.globals[pj], &self.poses[x])
                }
            };
            plan.globals.push(global);
            let refresh = self.outline_kept_fresh(plan.models[j]);
            plan.refresh.push(refresh);
            if refresh {
                body_of(node, &global, &mut plan.bodies[j]);
            }
        }
        // the contact test's order-independent half (World::contact)
        let accept = obstacle_to(&self.space, &self.returns, self.nodes[i].root);
        let body_after = |j: usize| -> &Body {
            if plan.refresh[j] {
                &plan.bodies[j]
            } else {
                self.space.body(plan.models[j])
            }
        };
        let movers = (0..n).filter(|&j| self.returns[plan.models[j].index()].obstacle);
        let ground = movers.clone().any(|j| below_ground(body_after(j)));
        plan.static_hit = ground
            || movers
                .into_iter()
                .any(|j| self.space.touches_static(body_after(j), accept));
        plan.kind = PlanKind::Planned;
    }

    /// Installs a planned move unless it touches something; the plan records whether it stalls.
    fn apply_move(&mut self, m: ModelId, plan: &mut MovePlan) {
        let i = m.index();
        #[cfg(test)]
        {
            self.planned_moves += 1;
        }
        let hit = plan.static_hit || {
            let old = self.poses[i];
            self.poses[i] = plan.pose;
            for (j, &x) in plan.models.iter().enumerate() {
                self.globals[x.index()] = plan.globals[j];
                if plan.refresh[j] {
                    std::mem::swap(self.space.body_mut(x), &mut plan.bodies[j]);
                    self.space.commit_body(x);
                }
            }
            let root = self.nodes[i].root;
            let returns = &self.returns;
            self.subtree.clear();
            self.subtree.extend(
                plan.models
                    .iter()
                    .copied()
                    .filter(|&x| returns[x.index()].obstacle),
            );
            let hit = self.space.touches_dynamic(
                &self.subtree,
                &mut self.scratch,
                obstacle_to(&self.space, returns, root),
            );
            if hit {
                self.poses[i] = old;
                self.refresh_subtree(m);
            }
            hit
        };
        plan.stalled = hit;
    }
}

#[cfg(test)]
impl World {
    /// Moves every robot one by one with [`World::move_model`] (`true`), or as in a run.
    pub(crate) fn set_moves_one_by_one(&mut self, on: bool) {
        self.moves_one_by_one = on;
    }

    /// Moves installed from a plan so far.
    pub(crate) fn planned_moves(&self) -> u64 {
        self.planned_moves
    }

    /// The dynamic grid's contents, order within a cell left out (see
    /// [`Space::dynamic_grid_as_sets`](crate::space::Space::dynamic_grid_as_sets)).
    pub(crate) fn dynamic_grid_as_sets(&self) -> Vec<Vec<(u32, [u64; 4], u32)>> {
        self.space.dynamic_grid_as_sets()
    }
}
