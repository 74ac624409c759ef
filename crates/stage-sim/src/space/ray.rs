//! Ray queries: single rays, a ranger's fans from one origin, and the camera's all-hits casts.
//! Dynamic bodies are tested first (walking the dynamic grid, or scanning a short list), then
//! the static grid is walked up to the best hit so far, or, for a short fan among scattered
//! obstacles, the few blocks gathered for it from the block bins are tested directly.

use crate::node::ModelId;
use parry2d::bounding_volume::Aabb as PAabb;
use parry2d::math::Point;

use super::Space;
use super::block_bins::{BinBlock, BlockBins, MOST_NEAR};
use super::body::edges_of;
use super::dyn_grid::CellEntry;
use super::lattice::next_crossing;
use crate::geom::{Aabb, ray_polygon, ray_quad, ray_segment};

/// A ray hit: the model, which of its blocks, and the distance from the ray origin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayHit {
    /// Index of the model hit.
    pub model: ModelId,
    /// Index of the block hit within that model.
    pub block: u32,
    /// Distance from the origin (m).
    pub range: f64,
}

/// A ray: origin, heading, maximum length and (optionally) its height for the z test.
#[derive(Clone, Copy, Debug)]
pub struct RayQuery {
    /// Origin x (m).
    pub x: f64,
    /// Origin y (m).
    pub y: f64,
    /// Heading (rad).
    pub a: f64,
    /// Maximum length (m).
    pub range: f64,
    /// `Some(z)`: only blocks with `zmin ≤ z ≤ zmax` stop the ray (Stage's `ztest`).
    pub z: Option<f64>,
}

/// One ray as the casting steps hand it on: origin, unit direction and its inverse, reach,
/// the height for the z test and the tree whose models it passes through.
#[derive(Clone, Copy)]
struct Ray {
    o: [f64; 2],
    d: [f64; 2],
    inv: [f64; 2],
    range: f64,
    z: Option<f64>,
    skip_root: Option<ModelId>,
}

/// One ray's search among the dynamic bodies: the nearest accepted hit so far and the models
/// already tested (a body spanning several grid cells is listed in each; testing one again
/// cannot change the answer, as the best hit only gets nearer). The first four are kept: a
/// ray rarely tests more bodies, and eight slots cost hospital 0.8% more instructions to set
/// up per ray than they saved.
struct DynamicSearch<'s, A> {
    space: &'s Space,
    ray: Ray,
    accept: &'s A,
    best_t: f64,
    best: Option<RayHit>,
    tested: [ModelId; 4],
    count: usize,
}

impl<A: Fn(ModelId) -> bool> DynamicSearch<'_, A> {
    /// Tests every model of `list`; answers the best hit's distance so far (the walk's limit).
    #[inline(always)]
    fn consider_all(&mut self, list: &[ModelId]) -> f64 {
        let sp = self.space;
        for &m in list {
            self.consider(m, sp.roots[m.index()], &sp.aabbs[m.index()]);
        }
        self.best_t
    }

    /// [`DynamicSearch::consider_all`] for a grid cell's entries, which carry each model's box
    /// and root.
    #[inline(always)]
    fn consider_cell(&mut self, list: &[CellEntry]) -> f64 {
        for e in list {
            self.consider(e.model, e.root, &e.aabb);
        }
        self.best_t
    }

    /// Tests model `m` (of the tree rooted at `root`, within box `aabb`) after the cheap
    /// rejections, inline: the caster's own tree, a box the ray misses, a model that lets the
    /// ray through.
    #[inline(always)]
    fn consider(&mut self, m: ModelId, root: ModelId, aabb: &Aabb) {
        let Ray {
            o, inv, skip_root, ..
        } = self.ray;
        if Some(root) == skip_root || !aabb.ray_meets(o, inv, self.best_t) || !(self.accept)(m) {
            return;
        }
        self.test_body(m);
    }

    /// Tests model `m`'s blocks (its box met the ray) unless this ray has tested it already
    /// (a body listed in several cells of the walk): the check inline, the test not.
    #[inline(always)]
    fn test_body(&mut self, m: ModelId) {
        if self.tested[..self.count].contains(&m) {
            return;
        }
        if self.count < self.tested.len() {
            self.tested[self.count] = m;
            self.count += 1;
        }
        self.test_blocks(m);
    }

    /// Tests model `m`'s blocks against the ray, keeping the nearest accepted hit.
    #[inline(never)]
    fn test_blocks(&mut self, m: ModelId) {
        let Ray { o, d, inv, z, .. } = self.ray;
        let tmax = self.best_t;
        let body = &self.space.bodies[m.index()];
        // the lists looked up once (each look is a test of where they are kept)
        let (blocks, pts) = (&body.blocks[..], &body.pts[..]);
        let crossing = |pts: &[[f64; 2]], limit: f64| match <&[[f64; 2]; 4]>::try_from(pts) {
            Ok(quad) => ray_quad(o, d, quad, limit),
            Err(_) => ray_polygon(o, d, pts, limit),
        };
        let mut bt = tmax;
        let mut bb = None;
        if let [blk] = blocks {
            debug_assert_eq!((blk.start, blk.end as usize), (0, pts.len()));
            // a lone block (a robot's default body): its box is the body's, which the ray has
            // just been found to meet, and its points are all the body's
            if z_sees(z, blk.zmin, blk.zmax)
                && let Some(t) = crossing(pts, bt)
            {
                bt = t;
                bb = Some(0);
            }
        } else {
            for (bi, blk) in blocks.iter().enumerate() {
                if !z_sees(z, blk.zmin, blk.zmax) || !blk.aabb.ray_meets(o, inv, bt) {
                    continue;
                }
                if let Some(t) = crossing(blk.points(pts), bt)
                    && (bb.is_none() || t < bt)
                {
                    bt = t;
                    bb = Some(bi as u32);
                }
            }
        }
        if let Some(b) = bb {
            if bt < tmax || self.best.is_none_or(|h| m < h.model) {
                self.best_t = bt;
                self.best = Some(RayHit {
                    model: m,
                    block: b,
                    range: bt,
                });
            }
        }
    }
}

/// Which moving bodies a ray tests.
#[derive(Clone, Copy)]
enum Movers<'a> {
    /// These (a world of so few that walking the dynamic grid would cost more); each is still
    /// asked about its tree and `accept`.
    Few(&'a [ModelId]),
    /// Those the walk of the dynamic grid meets, from the cell holding the origin if known.
    Walk(Option<[i32; 2]>),
}

/// What the rays of one cast share: origin, reach, height for the z test and the tree they pass
/// through, plus what a fan works out once: which moving bodies to test (`movers`), `start`, the
/// static grid's cell holding `o`, if known, `open`, how far from `o` no static edge lies (0:
/// unknown).
#[derive(Clone, Copy)]
struct Shared<'a> {
    o: [f64; 2],
    range: f64,
    z: Option<f64>,
    skip_root: Option<ModelId>,
    movers: Movers<'a>,
    start: Option<[i32; 2]>,
    open: f64,
}

impl Shared<'_> {
    /// The ray along `d` from the cast's origin.
    #[inline(always)]
    fn ray(&self, d: [f64; 2]) -> Ray {
        Ray {
            o: self.o,
            d,
            inv: [1.0 / d[0], 1.0 / d[1]],
            range: self.range,
            z: self.z,
            skip_root: self.skip_root,
        }
    }
}

/// The static blocks a fan's rays can meet, gathered from the block bins when the first ray
/// needs them (most of a packed crowd's rays stop at a neighbour first and need none).
struct FanStatics<'a> {
    bins: &'a BlockBins,
    /// The bins of the fan's disc ([`BlockBins::disc_span`]).
    span: [i32; 4],
    /// The fan's directions, for the box its rays reach.
    dirs: &'a [[f64; 2]],
    /// `None`: not gathered yet; `Some(None)`: the rays walk; `Some(Some(n))`: `n` blocks.
    count: Option<Option<usize>>,
    blocks: [&'a BinBlock; MOST_NEAR],
}

impl<'a> FanStatics<'a> {
    /// The blocks that the rays of the fan `shared` describes can meet and that they do not
    /// pass (see [`BlockBins::gather`]), or `None` when the rays walk.
    #[inline(always)]
    fn near(
        &mut self,
        space: &Space,
        shared: &Shared,
        accept: &impl Fn(ModelId) -> bool,
    ) -> Option<&[&'a BinBlock]> {
        let count = match self.count {
            Some(c) => c,
            None => self.gather(space, shared, accept),
        }?;
        Some(&self.blocks[..count])
    }

    /// The first ask of [`FanStatics::near`]: gathers, once per fan, the blocks the fan's
    /// rays can meet and that stop them (height, a model moved since, the caster's own tree,
    /// `accept`).
    #[inline(never)]
    fn gather(
        &mut self,
        space: &Space,
        shared: &Shared,
        accept: &impl Fn(ModelId) -> bool,
    ) -> Option<usize> {
        let Shared {
            o,
            range,
            z,
            skip_root,
            ..
        } = *shared;
        let mut area = Aabb::EMPTY;
        area.add(o);
        for d in self.dirs {
            area.add([o[0] + d[0] * range, o[1] + d[1] * range]);
        }
        let keep =
            |b: &BinBlock| space.static_stops(b.model, [b.zmin, b.zmax], z, skip_root, accept);
        let count = self.bins.gather(self.span, &area, keep, &mut self.blocks);
        self.count = Some(count);
        count
    }
}

/// Stage's `ztest`: whether a block spanning `zmin..=zmax` can stop a ray at height `z`
/// (`None`: any height).
#[inline(always)]
fn z_sees(z: Option<f64>, zmin: f64, zmax: f64) -> bool {
    match z {
        Some(z) => !(z < zmin || z > zmax),
        None => true,
    }
}

/// Whether a crossing at `t` of a static block, whose (model, block index) `key` gives, beats
/// the best hit so far: the answer is the least (distance, model, block), whatever order
/// edges are met in. `key` is asked only on a tie (reading it first cost simple.world 1% more
/// instructions per step).
#[inline(always)]
fn beats(t: f64, best: &Option<RayHit>, key: impl FnOnce() -> (ModelId, u32)) -> bool {
    match best {
        None => true,
        Some(h) => t < h.range || (t == h.range && key() < (h.model, h.block)),
    }
}

/// Dynamic sets up to this size are scanned directly instead of walking the grid.
const SMALL_DYNAMIC_SET: usize = 24;

impl Space {
    /// Casts a ray; `accept(model)` decides which models can stop it (Stage's match predicate).
    /// Returns the nearest accepted edge crossing whose block passes the z test.
    pub fn raycast(&self, q: &RayQuery, accept: impl Fn(ModelId) -> bool) -> Option<RayHit> {
        let (s, c) = q.a.sin_cos();
        self.raycast_dir([q.x, q.y], [c, s], q.range, q.z, None, accept)
    }

    /// [`Space::raycast`] with the unit direction given (saves the sine/cosine per ray when a
    /// caller sweeps a fan), skipping every model whose tree root is `skip_root` (the caster's
    /// own tree; `None` skips nothing) before `accept` is asked.
    pub fn raycast_dir(
        &self,
        o: [f64; 2],
        d: [f64; 2],
        range: f64,
        z: Option<f64>,
        skip_root: Option<ModelId>,
        accept: impl Fn(ModelId) -> bool,
    ) -> Option<RayHit> {
        // the cells holding the origin, when it lies inside the grids, found directly: cheaper
        // than finding where the ray enters them (cave's sonar rays, each cast alone: -3 to -4%
        // CPU per run, perf stat, 8 alternating runs in each order), and a ray ending in the
        // open space around it walks no static cells
        let (start, open) = self.static_start(o);
        let shared = Shared {
            o,
            range,
            z,
            skip_root,
            movers: if self.members.len() <= SMALL_DYNAMIC_SET {
                Movers::Few(&self.members)
            } else {
                Movers::Walk(self.grid.lat.cell_inside(o))
            },
            start,
            open,
        };
        self.cast(shared, d, &accept)
    }

    /// [`Space::raycast_dir`] for every direction of `dirs` from the one origin `o` (a ranger
    /// transducer's samples), handing `out` each ray's index and hit. The same hits, with what
    /// the rays share worked out once: in a world of few moving bodies, which of them any ray
    /// may stop at (usually none: they are the caster's own robot), and one loop the compiler
    /// can keep the grids' fields in registers for.
    #[allow(clippy::too_many_arguments)]
    pub fn raycast_fan(
        &self,
        o: [f64; 2],
        dirs: &[[f64; 2]],
        range: f64,
        z: Option<f64>,
        skip_root: Option<ModelId>,
        accept: impl Fn(ModelId) -> bool,
        mut out: impl FnMut(usize, Option<RayHit>),
    ) {
        let mut few = [ModelId(0); SMALL_DYNAMIC_SET];
        let mut n = 0;
        let small = self.members.len() <= SMALL_DYNAMIC_SET;
        if small {
            for &m in &self.members {
                if Some(self.roots[m.index()]) != skip_root && accept(m) {
                    few[n] = m;
                    n += 1;
                }
            }
        }
        let (start, open) = self.static_start(o);
        // moving bodies are walked ray by ray even where static blocks are gathered: in a
        // crowd a metre apart a ray's walk meets some three, and gathering a 2 m fan's ~17
        // once cost more (10,000-robot swarm, 4 alternating runs)
        let movers = if small {
            Movers::Few(&few[..n])
        } else {
            Movers::Walk(self.grid.lat.cell_inside(o))
        };
        let shared = Shared {
            o,
            range,
            z,
            skip_root,
            movers,
            start,
            open,
        };
        // a fan short enough may take its obstacles from the block bins: a loop of its own, out
        // of line, so that every other fan's loop compiles as it did without it (inline, the
        // branch cost simple.world 3-6% more instructions per step)
        let mut walk_from = 0;
        if let Some(bins) = &self.statics.bins
            && let Some(span) = bins.disc_span(o, range)
        {
            let statics = FanStatics {
                bins,
                span,
                dirs,
                count: None,
                blocks: [&BinBlock::UNUSED; MOST_NEAR],
            };
            walk_from = self.cast_near_fan(shared, statics, &accept, &mut out);
        }
        for (i, &d) in dirs.iter().enumerate().skip(walk_from) {
            out(i, self.cast(shared, d, &accept));
        }
    }

    /// The static grid's cell holding `o` (`None` outside it, or without a grid) and how far
    /// around `o` no static edge lies (0: unknown; [`super::static_grid::StaticGrid::open_reach`]).
    #[inline(always)]
    fn static_start(&self, o: [f64; 2]) -> (Option<[i32; 2]>, f64) {
        let Some(g) = &self.statics.grid else {
            return (None, 0.0);
        };
        let start = g.lat.cell_inside(o);
        (start, start.map_or(0.0, |c| g.open_reach(c)))
    }

    /// [`Space::raycast_fan`]'s loop for a fan that may gather its static blocks from `bins`
    /// (see [`FanStatics`]). Answers the index of the first ray left to cast: all of them, or
    /// the first that needed the static blocks when they could not be gathered (it and the
    /// rest walk the static grid, in the caller's loop: one place walks, which the compiler
    /// then inlines whole).
    #[inline(never)]
    fn cast_near_fan(
        &self,
        shared: Shared,
        mut statics: FanStatics,
        accept: &impl Fn(ModelId) -> bool,
        out: &mut impl FnMut(usize, Option<RayHit>),
    ) -> usize {
        let dirs = statics.dirs;
        for (i, &d) in dirs.iter().enumerate() {
            let ray = shared.ray(d);
            let best = self.dynamic_first(&ray, shared.movers, accept);
            // as in the walk: a ray that ends inside the open space around its start has
            // nothing to meet (bins exist only with the static grid)
            let hit = if best.map_or(ray.range, |h| h.range) < shared.open {
                best
            } else if let Some(near) = statics.near(self, &shared, accept) {
                self.near_static_hit(&ray, near, best)
            } else {
                return i;
            };
            out(i, hit);
        }
        dirs.len()
    }

    /// One ray along `d` (see [`Space::raycast_dir`]).
    #[inline(always)]
    fn cast(
        &self,
        shared: Shared,
        d: [f64; 2],
        accept: &impl Fn(ModelId) -> bool,
    ) -> Option<RayHit> {
        let ray = shared.ray(d);
        let best = self.dynamic_first(&ray, shared.movers, accept);
        self.walk_statics(&ray, (shared.start, shared.open), best, accept)
    }

    /// A ray's nearest moving body among `movers`: tested first, as in crowds its hits are
    /// near and bound the static part.
    #[inline(always)]
    fn dynamic_first(
        &self,
        ray: &Ray,
        movers: Movers,
        accept: &impl Fn(ModelId) -> bool,
    ) -> Option<RayHit> {
        match movers {
            Movers::Few([]) => None,
            movers => self.dynamic_hit(ray, accept, movers),
        }
    }

    /// The best of `best` (the ray's dynamic hit) and the static edges the ray meets, walking
    /// the static grid from `start` (its cell, if known); the answer is the least (distance,
    /// model, block). A ray that ends (at its reach or its dynamic hit) within `open` of its
    /// start has nothing to walk to.
    #[inline(always)]
    fn walk_statics(
        &self,
        ray: &Ray,
        (start, open): (Option<[i32; 2]>, f64),
        mut best: Option<RayHit>,
        accept: &impl Fn(ModelId) -> bool,
    ) -> Option<RayHit> {
        let Ray {
            o,
            d,
            inv,
            range,
            z,
            skip_root,
        } = *ray;
        let mut best_t = best.map_or(range, |h| h.range);
        let st = &self.statics;
        if let Some(grid) = &st.grid
            && best_t >= open
        {
            grid.walk(o, d, inv, best_t, start, |list| {
                for e in list {
                    let Some(t) = ray_segment(o, d, e.a, e.b, best_t) else {
                        continue;
                    };
                    let sb = &st.blocks[e.block as usize];
                    if beats(t, &best, || (sb.model, sb.block))
                        && self.static_stops(sb.model, [sb.zmin, sb.zmax], z, skip_root, accept)
                    {
                        best_t = t;
                        best = Some(RayHit {
                            model: sb.model,
                            block: sb.block,
                            range: t,
                        });
                    }
                }
                best_t
            });
        }
        best
    }

    /// Whether a block of static model `model` spanning heights `zmin..=zmax` stops a ray at
    /// height `z` cast from the tree rooted at `skip_root`: it passes the z test, its model has
    /// not moved since the index was built, it is not the caster's own, and `accept` takes it.
    #[inline(always)]
    fn static_stops(
        &self,
        model: ModelId,
        [zmin, zmax]: [f64; 2],
        z: Option<f64>,
        skip_root: Option<ModelId>,
        accept: &impl Fn(ModelId) -> bool,
    ) -> bool {
        z_sees(z, zmin, zmax)
            && self.static_live[model.index()]
            && Some(self.roots[model.index()]) != skip_root
            && accept(model)
    }

    /// The best of `best` (the ray's dynamic hit) and the crossings of the ray with the static
    /// blocks `near`, gathered and vetted for its fan: every edge of each block whose box the
    /// ray meets (the walk would meet each of those edges somewhere too). The answer is the
    /// least (distance, model, block), as the walk's.
    #[inline(never)]
    fn near_static_hit(
        &self,
        ray: &Ray,
        near: &[&BinBlock],
        mut best: Option<RayHit>,
    ) -> Option<RayHit> {
        let Ray { o, d, inv, .. } = *ray;
        let mut best_t = best.map_or(ray.range, |h| h.range);
        for b in near {
            if !b.aabb.ray_meets(o, inv, best_t) {
                continue;
            }
            for (p, q) in edges_of(&self.statics.pts[b.start as usize..b.end as usize]) {
                let Some(t) = ray_segment(o, d, p, q, best_t) else {
                    continue;
                };
                if beats(t, &best, || (b.model, b.block)) {
                    best_t = t;
                    best = Some(RayHit {
                        model: b.model,
                        block: b.block,
                        range: t,
                    });
                }
            }
        }
        best
    }

    /// The nearest dynamic body the ray meets within its range (see [`Space::cast`]); inline
    /// in each of the two fan loops.
    #[inline(always)]
    fn dynamic_hit(
        &self,
        ray: &Ray,
        accept: &impl Fn(ModelId) -> bool,
        movers: Movers,
    ) -> Option<RayHit> {
        let mut search = DynamicSearch {
            space: self,
            ray: *ray,
            accept,
            best_t: ray.range,
            best: None,
            tested: [ModelId(0); 4],
            count: 0,
        };
        match movers {
            Movers::Few(few) => {
                search.consider_all(few);
            }
            Movers::Walk(start) => {
                search.consider_all(&self.grid.overflow);
                self.walk_grid(ray.o, ray.d, ray.inv, start, ray.range, |list| {
                    search.consider_cell(list)
                });
            }
        }
        search.best
    }

    /// Visits the grid cells along the ray (DDA) in order, until the cell entry distance passes
    /// `limit`; `visit` gets each cell's models and answers the limit from then on (the best
    /// hit so far). `start` is the cell holding `o` when the caller knows it
    /// (`Lattice::cell_inside`).
    #[inline(always)]
    fn walk_grid(
        &self,
        o: [f64; 2],
        d: [f64; 2],
        inv: [f64; 2],
        start: Option<[i32; 2]>,
        limit: f64,
        mut visit: impl FnMut(&[CellEntry]) -> f64,
    ) {
        let g = &self.grid;
        let mut limit = limit;
        let Some([mut cx, mut cy]) = g.lat.walk_start(o, d, inv, limit, start) else {
            return;
        };
        let step_x = if d[0] >= 0.0 { 1 } else { -1 };
        let step_y = if d[1] >= 0.0 { 1 } else { -1 };
        let next_boundary = |c: i32, k: usize, step: i32| -> f64 {
            let edge = g.lat.origin[k] + (c + if step > 0 { 1 } else { 0 }) as f64 * g.lat.cell;
            (edge - o[k]) * inv[k]
        };
        let mut t_next = [
            if d[0] == 0.0 {
                f64::INFINITY
            } else {
                next_boundary(cx, 0, step_x)
            },
            if d[1] == 0.0 {
                f64::INFINITY
            } else {
                next_boundary(cy, 1, step_y)
            },
        ];
        // what a step across a y (index 0) or an x (index 1) boundary adds to the cells and to
        // the next crossings (+0.0 to the other axis's, which leaves it as it is), looked up by
        // the step's axis instead of chosen by a branch
        let cell_steps = [[0, step_y], [step_x, 0]];
        let t_steps = [
            [0.0, (g.lat.cell * inv[1]).abs()],
            [(g.lat.cell * inv[0]).abs(), 0.0],
        ];
        loop {
            if let Some(list) = g.entries((cy * g.lat.nx + cx) as usize) {
                limit = visit(list);
            }
            let (axis, t_cell) = next_crossing(t_next);
            t_next = [t_next[0] + t_steps[axis][0], t_next[1] + t_steps[axis][1]];
            cx += cell_steps[axis][0];
            cy += cell_steps[axis][1];
            // one unsigned compare per axis: a negative index wraps to a huge one
            if cx as u32 >= g.lat.nx as u32 || cy as u32 >= g.lat.ny as u32 || t_cell > limit {
                return;
            }
        }
    }

    /// Collects every accepted crossing along a ray (any z), nearest first, up to `max_hits`:
    /// used by the camera, which resolves heights per pixel.
    pub fn raycast_all(
        &self,
        q: &RayQuery,
        accept: impl Fn(ModelId) -> bool,
        out: &mut Vec<RayHit>,
    ) {
        out.clear();
        let (s, c) = q.a.sin_cos();
        let d = [c, s];
        let o = [q.x, q.y];
        let inv = [1.0 / d[0], 1.0 / d[1]];
        let mut probe = Aabb::EMPTY;
        probe.add(o);
        probe.add([o[0] + d[0] * q.range, o[1] + d[1] * q.range]);
        let pa = PAabb::new(
            Point::new(probe.min[0] as f32 - 1e-3, probe.min[1] as f32 - 1e-3),
            Point::new(probe.max[0] as f32 + 1e-3, probe.max[1] as f32 + 1e-3),
        );
        for leaf in self.statics.bvh.intersect_aabb(&pa) {
            let sb = self.statics.blocks[leaf as usize];
            if !self.static_live[sb.model.index()] || !accept(sb.model) {
                continue;
            }
            for (a, b) in self.statics.edges(leaf as usize) {
                if let Some(t) = ray_segment(o, d, a, b, q.range) {
                    out.push(RayHit {
                        model: sb.model,
                        block: sb.block,
                        range: t,
                    });
                }
            }
        }
        let mut seen: Vec<ModelId> = Vec::new();
        let mut visit = |m: ModelId| {
            if seen.contains(&m) || !accept(m) {
                return;
            }
            seen.push(m);
            let body = &self.bodies[m.index()];
            if body.aabb.ray_entry(o, inv, q.range).is_none() {
                return;
            }
            for bi in 0..body.blocks.len() {
                for (a, b) in body.edges(bi) {
                    if let Some(t) = ray_segment(o, d, a, b, q.range) {
                        out.push(RayHit {
                            model: m,
                            block: bi as u32,
                            range: t,
                        });
                    }
                }
            }
        };
        for &m in &self.grid.overflow {
            visit(m);
        }
        self.walk_grid(o, d, inv, None, q.range, |list| {
            for e in list {
                visit(e.model);
            }
            q.range
        });
        out.sort_by(|a, b| {
            a.range
                .total_cmp(&b.range)
                .then(a.model.cmp(&b.model))
                .then(a.block.cmp(&b.block))
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SimRng;
    use crate::space::Body;
    use std::f64::consts::PI;

    fn rect_body(x: f64, y: f64, w: f64, h: f64) -> Body {
        Body::from_rects(&[[x, y, w, h]])
    }

    /// The BVH walk and the grid walk together find exactly what a brute-force scan of every
    /// edge finds.
    #[test]
    fn static_ray_casts_match_brute_force() {
        let mut rng = SimRng::new(5, 5);
        for count in [1usize, 2, 3, 7, 100, 2000] {
            let bodies: Vec<Body> = (0..count)
                .map(|_| {
                    rect_body(
                        rng.uniform(-20.0, 20.0),
                        rng.uniform(-20.0, 20.0),
                        rng.uniform(0.0, 2.0),
                        rng.uniform(0.0, 2.0),
                    )
                })
                .collect();
            let n = bodies.len();
            // every third body is dynamic (grid), the rest static (BVH)
            let dynamic: Vec<bool> = (0..n).map(|i| i % 3 == 1).collect();
            let space = Space::new(
                bodies.clone(),
                &dynamic,
                (0..n as u32).map(ModelId).collect(),
            );
            for k in 0..600 {
                // half short rays (they start below the BVH root), half long ones
                let range = if k % 2 == 0 {
                    rng.uniform(0.1, 6.0)
                } else {
                    rng.uniform(0.5, 30.0)
                };
                // some rays run along an axis: exactly (a = 0: no y component) or to within
                // rounding (a = π)
                let a = match k % 10 {
                    0 => 0.0,
                    1 => PI,
                    _ => rng.uniform(-4.0, 4.0),
                };
                let q = RayQuery {
                    x: rng.uniform(-30.0, 30.0),
                    y: rng.uniform(-30.0, 30.0),
                    a,
                    range,
                    z: Some(0.5),
                };
                let got = space.raycast(&q, |_| true);
                let (s, c) = q.a.sin_cos();
                let mut want: Option<(f64, u32)> = None;
                for (m, b) in bodies.iter().enumerate() {
                    for (p, r) in b.edges(0) {
                        if let Some(t) = ray_segment([q.x, q.y], [c, s], p, r, q.range) {
                            if want.is_none_or(|(bt, bm)| t < bt || (t == bt && (m as u32) < bm)) {
                                want = Some((t, m as u32));
                            }
                        }
                    }
                }
                assert_eq!(
                    got.map(|h| (h.range, h.model.0)),
                    want,
                    "{count} bodies, {q:?}"
                );
            }
        }
    }

    /// A fan whose rays end just beyond a lone wall finds it from every distance: the open
    /// space around the fan's start cell (where a walk is skipped) never reaches the wall.
    #[test]
    fn fans_reach_a_wall_across_open_space() {
        let wall = rect_body(10.0, -0.5, 1.0, 1.0);
        // a far corner post, so that the static grid spans the open space the rays start in
        let post = rect_body(-12.0, -12.0, 1.0, 1.0);
        let mover = rect_body(-30.0, -30.0, 0.1, 0.1);
        let space = Space::new(
            vec![wall.clone(), post, mover],
            &[false, false, true],
            vec![ModelId(0), ModelId(1), ModelId(2)],
        );
        let grid = space.statics.grid.as_ref().unwrap();
        assert!(grid.open_reach(grid.lat.cell_inside([-5.0, 0.0]).unwrap()) > 2.0);
        let dirs: Vec<[f64; 2]> = (-2..=2)
            .map(|i| {
                let (s, c) = (i as f64 * 0.01).sin_cos();
                [c, s]
            })
            .collect();
        for step in 0..200 {
            let x0 = -9.95 + step as f64 * 0.0993;
            let o = [x0, 0.013];
            let range = 10.0 - x0 + 0.02;
            let mut got = vec![None; dirs.len()];
            space.raycast_fan(
                o,
                &dirs,
                range,
                Some(0.5),
                None,
                |_| true,
                |i, h| got[i] = h,
            );
            for (i, &d) in dirs.iter().enumerate() {
                let want = wall
                    .edges(0)
                    .filter_map(|(p, q)| ray_segment(o, d, p, q, range))
                    .min_by(f64::total_cmp);
                assert_eq!(got[i].map(|h| h.range), want, "from x = {x0}, ray {i}");
                assert!(want.is_some(), "from x = {x0}, ray {i} reaches the wall");
            }
        }
    }

    /// A floorplan-like model: a random 24×24 occupancy grid (cells `size` wide, corner at
    /// `at`), each row's runs of occupied cells one rectangle block, as bitmaps are loaded; so
    /// most block sides are shared, wholly or in part, with the rows above and below.
    fn bitmap_body(rng: &mut SimRng, at: [f64; 2], size: f64) -> (Body, Vec<bool>) {
        let occupied: Vec<bool> = (0..24 * 24).map(|_| rng.uniform(0.0, 1.0) < 0.5).collect();
        let mut rects = Vec::new();
        for y in 0..24 {
            let mut x = 0;
            while x < 24 {
                if !occupied[y * 24 + x] {
                    x += 1;
                    continue;
                }
                let x0 = x;
                while x < 24 && occupied[y * 24 + x] {
                    x += 1;
                }
                rects.push([
                    at[0] + x0 as f64 * size,
                    at[1] + y as f64 * size,
                    (x - x0) as f64 * size,
                    size,
                ]);
            }
        }
        (Body::from_rects(&rects), occupied)
    }

    /// Fans find what single rays find, and both what a brute-force scan of every edge of
    /// every block finds, around a floorplan whose shared block sides are left out of the
    /// static grid, among moving bodies (some the caster's own, some not accepted): few of
    /// them (scanned directly) or many (the dynamic grid walked from the fan's start cell).
    #[test]
    fn fans_match_single_rays_and_brute_force() {
        for movers in [6, 60] {
            fans_match_among(movers);
        }
    }

    fn fans_match_among(movers: usize) {
        let mut rng = SimRng::new(11, 3);
        let (size, at) = (0.5, [-6.0, -6.0]);
        let (plan, occupied) = bitmap_body(&mut rng, at, size);
        let mut bodies = vec![plan];
        for _ in 0..movers {
            bodies.push(rect_body(
                rng.uniform(-8.0, 8.0),
                rng.uniform(-8.0, 8.0),
                rng.uniform(0.1, 1.0),
                rng.uniform(0.1, 1.0),
            ));
        }
        let n = bodies.len();
        let dynamic: Vec<bool> = (0..n).map(|m| m > 0).collect();
        // models 1 and 2 are the caster's robot (root 1); model 3 never stops rays
        let roots: Vec<u32> = (0..n as u32).map(|m| if m == 2 { 1 } else { m }).collect();
        let accept = |m: ModelId| m.0 != 3;
        let space = Space::new(
            bodies.clone(),
            &dynamic,
            roots.iter().map(|&r| ModelId(r)).collect(),
        );
        assert_eq!(
            space.members.len() <= SMALL_DYNAMIC_SET,
            movers <= SMALL_DYNAMIC_SET
        );
        let mut fans = 0;
        while fans < 60 {
            let o = [rng.uniform(-9.0, 9.0), rng.uniform(-9.0, 9.0)];
            // from open space only: inside a wall a ray may pass the sides its block shares,
            // where the brute force stops at the first side of its own block
            let cell = [(o[0] - at[0]) / size, (o[1] - at[1]) / size];
            let in_plan = (0..2).all(|k| cell[k] >= 0.0 && cell[k] < 24.0);
            if in_plan && occupied[cell[1] as usize * 24 + cell[0] as usize] {
                continue;
            }
            fans += 1;
            let range = rng.uniform(1.0, 20.0);
            let a0 = rng.uniform(-PI, PI);
            let dirs: Vec<[f64; 2]> = (0..90)
                .map(|i| {
                    let (s, c) = (a0 + i as f64 * 0.07).sin_cos();
                    [c, s]
                })
                .collect();
            let mut got = vec![None; dirs.len()];
            space.raycast_fan(
                o,
                &dirs,
                range,
                Some(0.5),
                Some(ModelId(1)),
                accept,
                |i, h| got[i] = h,
            );
            for (i, &d) in dirs.iter().enumerate() {
                let single = space.raycast_dir(o, d, range, Some(0.5), Some(ModelId(1)), accept);
                assert_eq!(got[i], single, "fan from {o:?}, ray {i}");
                let mut want: Option<(f64, u32)> = None;
                for (m, b) in bodies.iter().enumerate() {
                    if roots[m] == 1 || !accept(ModelId(m as u32)) {
                        continue;
                    }
                    for bi in 0..b.blocks.len() {
                        for (p, q) in b.edges(bi) {
                            if let Some(t) = ray_segment(o, d, p, q, range) {
                                if want
                                    .is_none_or(|(bt, bm)| t < bt || (t == bt && (m as u32) < bm))
                                {
                                    want = Some((t, m as u32));
                                }
                            }
                        }
                    }
                }
                assert_eq!(
                    got[i].map(|h| (h.range, h.model.0)),
                    want,
                    "fan from {o:?}, ray {i}"
                );
            }
        }
        // the floorplan's wholly shared sides were left out of the grid (here 550 of 664 edges
        // are listed)
        let grid = space.statics.grid.as_ref().unwrap();
        let listed = grid.listed_edges();
        let all: usize = bodies[0].blocks.len() * 4;
        assert!(listed < all * 9 / 10, "{listed} of {all} edges listed");
    }

    /// A square of side `2·half` centred on `c`, turned by `a`: one four-point block.
    fn turned_square(c: [f64; 2], half: f64, a: f64) -> Body {
        let (s, co) = a.sin_cos();
        let mut body = Body::from_rects(&[[0.0, 0.0, 1.0, 1.0]]);
        let mut aabb = Aabb::EMPTY;
        for (p, [u, v]) in
            body.pts
                .iter_mut()
                .zip([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
        {
            *p = [
                c[0] + half * (u * co - v * s),
                c[1] + half * (u * s + v * co),
            ];
            aabb.add(*p);
        }
        body.blocks[0].aabb = aabb;
        body.aabb = aabb;
        body
    }

    /// Among scattered obstacles (the swarm's layout: turned squares, a few of them touching,
    /// whose bins then send fans to the walk), fans that take their obstacles from the block
    /// bins find exactly what single rays walking the static grid find, ties included (rays
    /// through the corners where obstacles touch), with and without moving bodies hit first.
    #[test]
    fn fans_over_block_bins_match_walking_rays() {
        let mut rng = SimRng::new(21, 4);
        let mut bodies = Vec::new();
        for i in 0..400 {
            let c = [rng.uniform(-20.0, 20.0), rng.uniform(-20.0, 20.0)];
            bodies.push(turned_square(c, 0.15, rng.uniform(-PI, PI)));
            if i % 40 == 0 {
                // an axis-aligned pair of the same model sharing a side: not listed whole
                bodies.push(Body::from_rects(&[
                    [c[0] + 1.0, c[1], 0.3, 0.3],
                    [c[0] + 1.3, c[1], 0.3, 0.3],
                ]));
            }
        }
        let statics = bodies.len();
        for _ in 0..300 {
            let c = [rng.uniform(-20.0, 20.0), rng.uniform(-20.0, 20.0)];
            bodies.push(turned_square(c, 0.05, rng.uniform(-PI, PI)));
        }
        let n = bodies.len();
        let dynamic: Vec<bool> = (0..n).map(|m| m >= statics).collect();
        let roots: Vec<ModelId> = (0..n as u32).map(ModelId).collect();
        // every seventh model lets rays through
        let accept = |m: ModelId| m.0 % 7 != 3;
        let space = Space::new(bodies, &dynamic, roots);
        let bins = space.statics.bins.as_ref().unwrap();
        let (mut gathered, mut walked) = (0, 0);
        for fan in 0..2000 {
            let caster = ModelId((statics + fan % (n - statics)) as u32);
            let o = space.bodies[caster.index()].aabb.min;
            let range = if fan % 2 == 0 { 2.0 } else { 0.7 };
            let a0 = rng.uniform(-PI, PI);
            let dirs: Vec<[f64; 2]> = (0..12)
                .map(|i| {
                    let (s, c) = (a0 + i as f64 * PI / 6.0).sin_cos();
                    [c, s]
                })
                .collect();
            match bins.disc_span(o, range) {
                Some(_) => gathered += 1,
                None => walked += 1,
            }
            let mut got = vec![None; dirs.len()];
            space.raycast_fan(o, &dirs, range, None, Some(caster), accept, |i, h| {
                got[i] = h
            });
            for (i, &d) in dirs.iter().enumerate() {
                let single = space.raycast_dir(o, d, range, None, Some(caster), accept);
                assert_eq!(got[i], single, "fan {fan} from {o:?}, ray {i}");
            }
        }
        // both ways are exercised (here 1,544 fans may gather, 456 walk)
        assert!(
            gathered > 1200 && walked > 100,
            "{gathered} gathered, {walked} walked"
        );
        // rays that start exactly at a static corner and run along its sides
        let corner = space.bodies[0].pts[0];
        let dirs = [[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]];
        let mut got = [None; 4];
        space.raycast_fan(corner, &dirs, 2.0, None, None, accept, |i, h| got[i] = h);
        for (i, &d) in dirs.iter().enumerate() {
            assert_eq!(
                got[i],
                space.raycast_dir(corner, d, 2.0, None, None, accept)
            );
        }
    }
}
