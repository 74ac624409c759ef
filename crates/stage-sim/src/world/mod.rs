//! The world: model tree, clock and scheduler, the deterministic two-phase step, and the API
//! that servers, viewers and controllers use.
//!
//! * `build`: a world from its description (models, bodies, controllers);
//! * `step`: the step's phases, command application and moves one by one (`moves`: the moves
//!   planned for every robot at once);
//! * `tree`: the model tree — global poses, world outlines, subtrees, names, reparenting;
//! * `query`: subscriptions and the per-model API (poses, colours, commands, sensor data,
//!   the determinism digest).

/// A type-specific call: `$state` is the checked model's type state (`kind(m)` or
/// `kind_mut(m)`); a model whose state matches `$pat` gives `Ok($out)`, any other type
/// [`Error::BadModel`] naming what the call needs.
macro_rules! typed {
    ($world:ident.$state:ident($m:expr), $needs:expr, $pat:pat => $out:expr) => {
        match $world.$state($m)? {
            $pat => Ok($out),
            _ => Err($world.wrong_type($m, $needs)),
        }
    };
}

mod build;
mod moves;
mod query;
mod sensors;
mod step;
#[cfg(test)]
mod tests;
mod tree;

use std::collections::HashMap;

use crate::controller::{Commands, Controller};
use crate::desc::Color;
use crate::error::{Error, Result};
use crate::models::KindState;
use crate::pose::Pose;
use crate::rng::SimRng;
use crate::space::Space;

pub use crate::desc::WorldConfig;
use crate::node::Returns;
pub use crate::node::{LocalBlock, ModelId, Node};
pub(crate) use crate::view::View;
pub use sensors::Sensors;

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

struct ControllerSlot {
    trigger: ModelId,
    ctrl: Box<dyn Controller>,
    /// The sink for its model's commands, emptied after each step (kept, so that updates
    /// allocate nothing).
    cmds: Commands,
}

/// A running world. See the crate docs for the step semantics.
///
/// # Model ids
///
/// Every public function that takes a [`ModelId`] returns a [`Result`], with
/// one rule for all of them:
/// * an id whose index this world does not have is [`Error::ForeignModel`] (never a panic);
/// * a type-specific call (a getter such as [`World::ranger_scans`] answering `Result<&T>`, a
///   command such as [`World::position_cmd_vel`] answering `Result<()>`) asked of a model of
///   another type is [`Error::BadModel`] (cheap: a getter may serve as a type test), and a
///   block index the model does not have is [`Error::NoBlock`];
/// * an answer that may rightly be absent stays an `Option` inside the `Result`
///   ([`World::parent`], [`World::last_update`], [`World::rasterize`], [`World::raycast`]).
///
/// The check is one comparison at this public boundary; the step, ray casts, model updates
/// and moves inside the crate index their tables directly. Ids come from the world itself
/// ([`World::models`], [`World::model_by_name`], tree links, ray hits) or from a number
/// through [`World::model_id`]. What cannot be detected: an id taken from another world whose
/// index also exists here names this world's model with that index (an id carries no world
/// tag; see [`ModelId`] for why).
pub struct World {
    cfg: WorldConfig,
    seed: u64,
    sim_time: u64,
    updates: u64,
    nodes: Vec<Node>,
    /// Each model's `*_return` properties, apart from the rest of its node: the ray and contact
    /// loops read them for every candidate they meet.
    returns: Vec<Returns>,
    poses: Vec<Pose>,
    globals: Vec<Pose>,
    colors: Vec<Color>,
    says: Vec<String>,
    space: Space,
    states: Vec<ModelState>,
    names: HashMap<String, ModelId>,
    positions: Vec<ModelId>,
    /// The gripper models, in creation order (their grasps and releases come before the moves).
    grippers: Vec<ModelId>,
    fiducial_targets: Vec<ModelId>,
    controllers: Vec<ControllerSlot>,
    warnings: Vec<String>,
    rays_cast: u64,
    // scratch
    due: Vec<bool>,
    updated: Vec<bool>,
    subtree: Vec<ModelId>,
    scratch: Vec<ModelId>,
    move_plans: Vec<moves::MovePlan>,
    /// Test switch: every robot moves with [`World::move_model`], one by one (the reference
    /// the planned pass is compared with).
    #[cfg(test)]
    moves_one_by_one: bool,
    /// Test count: moves installed from a plan ([`moves`]).
    #[cfg(test)]
    planned_moves: u64,
}

impl World {
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

    /// The one check at the public boundary: `m`'s index into the per-model tables, or
    /// [`Error::ForeignModel`] when this world has no model with that index.
    pub(super) fn check(&self, m: ModelId) -> Result<usize> {
        let i = m.index();
        if i < self.nodes.len() {
            Ok(i)
        } else {
            Err(Error::ForeignModel {
                id: m,
                models: self.nodes.len(),
            })
        }
    }

    /// The checked model's type state (for the type-specific calls).
    pub(super) fn kind(&self, m: ModelId) -> Result<&KindState> {
        Ok(&self.states[self.check(m)?].kind)
    }

    /// The checked model's type state, mutable (for the type-specific commands).
    pub(super) fn kind_mut(&mut self, m: ModelId) -> Result<&mut KindState> {
        let i = self.check(m)?;
        Ok(&mut self.states[i].kind)
    }

    /// The error for a type-specific call asked of model `m` (in range) of another type.
    pub(super) fn wrong_type(&self, m: ModelId, expected: &'static str) -> Error {
        Error::BadModel {
            id: m,
            found: self.nodes[m.index()].model_type,
            expected,
        }
    }

    /// Whether `quit_time` has been reached (further steps do nothing).
    pub fn done(&self) -> bool {
        self.cfg.quit_time_us > 0 && self.sim_time >= self.cfg.quit_time_us
    }
}
