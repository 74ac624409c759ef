//! The spatial engine: every body's outline in world space, a static BVH (parry2d) over the
//! blocks of bodies that never move, and a uniform grid over the bodies that do.
//!
//! * Static bodies (floorplans and everything not in a robot's tree) are indexed twice, both
//!   built once: a parry2d [`Bvh`](parry2d::partitioning::Bvh) (binned SAH, one leaf per
//!   block) answers contact queries and the camera's all-hits casts; for single rays their
//!   edges also sit in a uniform grid (`static_grid`) walked cell by cell with empty-space
//!   jumps: 205k instead of 413k instructions per step on simple.world (callgrind) than the
//!   flattened BVH walk, same answers.
//!   Sides that touching blocks of one model share (most of a bitmap's) are left out of that
//!   grid: a ray from open space always meets the wall's outline first (`exposed`).
//! * A ranger's fan of rays from one origin ([`Space::raycast_fan`]) works out once what its
//!   rays share: which of a few moving bodies any of them can stop at, and the static and the
//!   dynamic grid cells they start in (simple.world: 143k instructions per step, from 197k ray
//!   by ray). One-sample transducers at one origin (hospital's 12 IR sensors) are cast as one
//!   fan: hospital 18.0M → 16.2M instructions per step, a 1,000-robot swarm 10.6M → 9.3M. A
//!   fan's rays that end inside the empty cells around its start (the static grid's clearance)
//!   skip the static walk altogether.
//! * A short fan among scattered obstacles (the 10,000-robot swarm's 2 m IR fans) does not
//!   walk: the blocks within its reach are gathered once from a coarse grid of whole blocks
//!   (`block_bins`), and each ray tests their edges: the same hits, the swarm ~5% less CPU end
//!   to end (alternating runs), the other bench worlds within 2% instructions per step. Only
//!   where every block near the fan has its edges listed whole, so that the answer is the
//!   walk's.
//! * Dynamic bodies (robots and everything in their trees) live in a uniform grid; a moving model
//!   re-registers only when the set of cells its box covers changes, so moves cost O(1) and the
//!   index is never rebuilt. Each cell lists its models with their boxes and tree roots, so a
//!   ray's cheap rejections read one contiguous list. Rays walk it cell by cell (DDA) and stop
//!   at the first hit.
//! * Contact tests skip the static BVH query where the static grid shows that no static edge
//!   (shared sides included) comes near the moving body, which is most of the time.
//! * A static body that is moved later (teleported, picked up by a gripper) is switched off in
//!   the static index (its blocks are skipped) and joins the dynamic grid.
//!
//! Differences from Stage's occupancy grid (spec §6): ranges are exact distances to the first
//! edge crossed, where Stage returns the near boundary of the first grid cell that an edge was
//! rasterised into — so Stage reads up to one cell (`resolution`, 2 cm by default, more at
//! oblique angles) shorter, and Stage's contacts fire up to one cell early. Sub-cell bodies, which
//! Stage drops, are kept.
//!
//! One file per concern: `body` (outlines in world space), `static_index` (the static blocks,
//! their BVH, and the building of their edge grid: `static_grid`, `exposed`, and of their bins:
//! `block_bins`), `dyn_grid` (the moving bodies' grid), `ray` (ray queries), `contact` (contact
//! tests); [`Space`] itself, which owns all of them and registers bodies, is here.

mod block_bins;
mod body;
mod contact;
mod dyn_grid;
mod exposed;
mod lattice;
mod ray;
mod static_grid;
mod static_index;

pub use body::{Body, WorldBlock};
pub use ray::{RayHit, RayQuery};

use crate::geom::Aabb;
use crate::node::ModelId;
use dyn_grid::{DynGrid, dynamic_cell};
use static_index::StaticIndex;

/// Every body in world space plus the two indices; see the module docs.
///
/// Built and kept by a [`World`](crate::World), which hands out `&Space` for ray and contact
/// queries. The calls that take a model id index their tables unchecked (they serve the step's
/// hot loops) and so are crate-private; outside the crate a model's body and static flag come
/// from the checked [`World::body`](crate::World::body) and
/// [`World::is_static`](crate::World::is_static).
pub struct Space {
    bodies: Vec<Body>,
    /// Root of each model's tree (models with equal roots are related and never see each other).
    roots: Vec<ModelId>,
    /// Each body's box, densely packed for the hot ray loop.
    aabbs: Vec<Aabb>,
    /// Every model ever registered in the dynamic grid (a short list is scanned directly).
    members: Vec<ModelId>,
    is_member: Vec<bool>,
    is_static: Vec<bool>,
    static_live: Vec<bool>,
    statics: StaticIndex,
    grid: DynGrid,
}

impl Space {
    /// Builds the indices from every model's world-space body; `dynamic[m]` says whether model
    /// `m` can move (it is in a robot's tree).
    pub(crate) fn new(bodies: Vec<Body>, dynamic: &[bool], roots: Vec<ModelId>) -> Space {
        let n = bodies.len();
        let mut bounds = Aabb::EMPTY;
        for body in &bodies {
            bounds.merge(&body.aabb);
        }
        if !bounds.is_empty() {
            bounds.min[0] -= 10.0;
            bounds.min[1] -= 10.0;
            bounds.max[0] += 10.0;
            bounds.max[1] += 10.0;
        }
        let mut grid = DynGrid::new(bounds, dynamic_cell(&bodies, dynamic, &roots), n);
        let mut members = Vec::new();
        let mut is_member = vec![false; n];
        for (m, body) in bodies.iter().enumerate() {
            if dynamic[m] && !body.is_empty() {
                grid.update(ModelId(m as u32), &body.aabb, roots[m]);
                members.push(ModelId(m as u32));
                is_member[m] = true;
            }
        }
        Space {
            roots,
            aabbs: bodies.iter().map(|b| b.aabb).collect(),
            members,
            is_member,
            is_static: dynamic.iter().map(|d| !d).collect(),
            static_live: dynamic.iter().map(|d| !d).collect(),
            statics: StaticIndex::build(&bodies, dynamic),
            bodies,
            grid,
        }
    }

    /// Records that model `m` now belongs to the tree rooted at `root` (re-parenting).
    pub(crate) fn set_root(&mut self, m: ModelId, root: ModelId) {
        self.roots[m.index()] = root;
        self.grid.set_root(m, root);
    }

    /// The world-space body of model `m`.
    pub(crate) fn body(&self, m: ModelId) -> &Body {
        &self.bodies[m.index()]
    }

    /// All bodies, indexed by model.
    pub fn bodies(&self) -> &[Body] {
        &self.bodies
    }

    /// Number of blocks in the static index.
    pub fn static_block_count(&self) -> usize {
        self.statics.blocks.len()
    }

    /// Mutable access to a body's storage for in-place refresh; call [`Space::commit_body`] after.
    pub(crate) fn body_mut(&mut self, m: ModelId) -> &mut Body {
        let i = m.index();
        self.static_live[i] = false;
        self.is_static[i] = false;
        &mut self.bodies[i]
    }

    /// Re-registers model `m` in the dynamic index after [`Space::body_mut`] changed it.
    pub(crate) fn commit_body(&mut self, m: ModelId) {
        let aabb = self.bodies[m.index()].aabb;
        self.grid.update(m, &aabb, self.roots[m.index()]);
        self.aabbs[m.index()] = aabb;
        self.note_member(m);
    }

    fn note_member(&mut self, m: ModelId) {
        if !self.is_member[m.index()] && !self.bodies[m.index()].is_empty() {
            self.is_member[m.index()] = true;
            self.members.push(m);
        }
    }

    /// The root of model `m`'s tree.
    #[inline]
    pub(crate) fn root_of(&self, m: ModelId) -> ModelId {
        self.roots[m.index()]
    }

    /// Models whose bodies are registered as static (never moved).
    pub(crate) fn is_static(&self, m: ModelId) -> bool {
        self.is_static[m.index()]
    }
}
