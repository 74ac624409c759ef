//! Phase 2 of a step: position models move one at a time in creation order, each tested for
//! contact against the already-moved state (the crate docs' step semantics).
//!
//! Most of a move does not depend on the moves before it: the new pose, the new outlines of
//! the robot's tree and the contact test against static blocks (which never change while
//! robots move). That part is planned for every robot at once, in parallel; the ordered pass
//! then only installs the outlines and tests them against moving bodies. Robots whose outlines
//! do depend on earlier moves (a robot carried by another, or carrying one) take the plain
//! one-at-a-time path. Either way the outcome is bit-identical to moving them one by one.
//!
//! With more than one thread, the ordered pass is also spared most of its contact tests: a
//! planned tree whose moved outlines' boxes meet no other moving body's box in either of the
//! two places that body can be while the moves are installed (where it stands, or where its
//! own plan puts it; a robot that stays or is refused stays where it stands) is found free of
//! contact in the ordered pass whatever the order, so that test is made beforehand, for every
//! robot at once, in parallel ([`World::free_moves`]). The ordered pass still installs every outline in
//! creation order, so the dynamic grid ends exactly as one-by-one moves leave it.

use rayon::prelude::*;

use super::tree::{below_ground, body_of, global_of_parent, obstacle_to, tree_of};
use super::{KindState, ModelId, World};
use crate::geom::Aabb;
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
}

/// Where the planned outlines of this step are, by model, for the free-move test (buffers
/// kept between steps).
#[derive(Debug, Default)]
pub(super) struct PlannedOutlines {
    /// Per model: the box of its planned outline, [`Aabb::EMPTY`] when it has none (it stays
    /// where it is, or its move is refused before installing).
    planned: Vec<Aabb>,
    /// How far any planned box lies from the registered one (per side, plus a margin).
    reach: f64,
    /// Per plan: whether its move is certainly free of contact with moving bodies.
    free: Vec<bool>,
}

impl World {
    /// Moves every position model (phase 2 of [`World::step`]).
    pub(super) fn move_all(&mut self, dt: f64) {
        #[cfg(test)]
        if self.moves_one_by_one {
            for k in 0..self.positions.len() {
                self.move_model(self.positions[k], dt);
            }
            return;
        }
        let mut plans = std::mem::take(&mut self.move_plans);
        plans.resize_with(self.positions.len(), MovePlan::default);
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
        let mut outlines = std::mem::take(&mut self.planned_outlines);
        let shortcut = plans.len() >= PARALLEL_MIN_MOVERS
            && rayon::current_num_threads() > 1
            && self.free_moves(&plans, &mut outlines);
        for (k, plan) in plans.iter_mut().enumerate() {
            let m = self.positions[k];
            match plan.kind {
                PlanKind::Still => {}
                PlanKind::OneByOne => self.move_model(m, dt),
                PlanKind::Planned => {
                    let free = shortcut && outlines.free[k];
                    self.apply_move(m, plan, free)
                }
            }
        }
        self.move_plans = plans;
        self.planned_outlines = outlines;
    }

    /// Finds, in parallel, the planned moves that the ordered pass would find free of contact
    /// with moving bodies whatever the order (`outlines.free`, by plan); `false` when this step
    /// cannot tell (a tree moved one at a time, whose outlines are not known beforehand, or a
    /// planned outline of a model the dynamic grid does not list), and nothing is marked.
    fn free_moves(&self, plans: &[MovePlan], outlines: &mut PlannedOutlines) -> bool {
        outlines.planned.resize(self.nodes.len(), Aabb::EMPTY);
        let reach = self.index_planned_outlines(plans, &mut outlines.planned);
        if let Some(reach) = reach {
            // a margin for the rounding of the box differences (coordinates below 1e9 m)
            let reach = reach + 1e-6;
            let planned = &outlines.planned;
            plans
                .par_iter()
                .enumerate()
                .with_min_len(8)
                .map(|(k, plan)| self.move_is_free(k, plan, planned, reach))
                .collect_into_vec(&mut outlines.free);
        }
        for plan in plans {
            for &x in &plan.models {
                outlines.planned[x.index()] = Aabb::EMPTY;
            }
        }
        reach.is_some()
    }

    /// Notes in `planned` the box of each planned outline that the ordered pass may install,
    /// and answers how far any of them lies from the model's registered box; `None` when the
    /// free test cannot be made (see [`World::free_moves`]). `planned` is left for the caller
    /// to clear.
    fn index_planned_outlines(&self, plans: &[MovePlan], planned: &mut [Aabb]) -> Option<f64> {
        let mut reach = 0.0f64;
        for plan in plans {
            match plan.kind {
                PlanKind::Still => continue,
                PlanKind::OneByOne => return None,
                PlanKind::Planned if plan.static_hit => continue,
                PlanKind::Planned => {}
            }
            for (j, &x) in plan.models.iter().enumerate() {
                let new = &plan.bodies[j];
                if !plan.refresh[j] || new.is_empty() {
                    continue;
                }
                let old = &self.space.body(x).aabb;
                if !self.space.in_dynamic_grid(x) || old.is_empty() {
                    return None;
                }
                let shift = (0..2)
                    .map(|a| {
                        (new.aabb.min[a] - old.min[a])
                            .abs()
                            .max((new.aabb.max[a] - old.max[a]).abs())
                    })
                    .fold(0.0, f64::max);
                // a box at infinity would make every other box a candidate
                if !shift.is_finite() {
                    return None;
                }
                reach = reach.max(shift);
                planned[x.index()] = new.aabb;
            }
        }
        Some(reach)
    }

    /// Whether plan `k`'s moved tree meets no moving body, by boxes, where that body is now nor
    /// where its plan puts it (`planned`, `reach`: see [`PlannedOutlines`]).
    fn move_is_free(&self, k: usize, plan: &MovePlan, planned: &[Aabb], reach: f64) -> bool {
        if plan.kind != PlanKind::Planned || plan.static_hit {
            return false;
        }
        let root = self.nodes[self.positions[k].index()].root;
        let accept = obstacle_to(&self.space, &self.returns, root);
        plan.models.iter().enumerate().all(|(j, &x)| {
            if !self.returns[x.index()].obstacle {
                return true;
            }
            let body = if plan.refresh[j] {
                &plan.bodies[j]
            } else {
                self.space.body(x)
            };
            body.is_empty()
                || !self
                    .space
                    .may_meet_dynamic(x, &body.aabb, reach, accept, planned)
        })
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

    /// Installs a planned move unless it touches something, then records the stall; `free`:
    /// the move is known to touch no moving body ([`World::free_moves`]), so only static
    /// contacts are looked at.
    fn apply_move(&mut self, m: ModelId, plan: &mut MovePlan, free: bool) {
        let i = m.index();
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
            #[cfg(test)]
            if free {
                self.move_counts.0 += 1;
            } else {
                self.move_counts.1 += 1;
            }
            let hit = !free && {
                let root = self.nodes[i].root;
                let returns = &self.returns;
                self.subtree.clear();
                self.subtree.extend(
                    plan.models
                        .iter()
                        .copied()
                        .filter(|&x| returns[x.index()].obstacle),
                );
                self.space.touches_dynamic(
                    &self.subtree,
                    &mut self.scratch,
                    obstacle_to(&self.space, returns, root),
                )
            };
            if hit {
                self.poses[i] = old;
                self.refresh_subtree(m);
            }
            hit
        };
        if let KindState::Position(p) = &mut self.states[i].kind {
            p.set_stall(hit);
        }
    }
}

#[cfg(test)]
impl World {
    /// Moves every robot one by one with [`World::move_model`] (`true`), or as in a run.
    pub(crate) fn set_moves_one_by_one(&mut self, on: bool) {
        self.moves_one_by_one = on;
    }

    /// Planned moves installed so far without the ordered contact test, and with it.
    pub(crate) fn move_counts(&self) -> (u64, u64) {
        self.move_counts
    }

    /// The dynamic grid's contents, order within a cell left out (see
    /// [`Space::dynamic_grid_as_sets`]).
    pub(crate) fn dynamic_grid_as_sets(&self) -> Vec<Vec<(u32, [u64; 4], u32)>> {
        self.space.dynamic_grid_as_sets()
    }
}
