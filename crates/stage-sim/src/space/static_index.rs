//! The static bodies' blocks, built once: a parry2d BVH for contacts and all-hits casts, and
//! the exposed parts of their edges in the static grid for single rays (see the module docs of
//! `space`).

use crate::node::ModelId;
use parry2d::bounding_volume::Aabb as PAabb;
use parry2d::math::Point;
use parry2d::partitioning::{Bvh, BvhBuildStrategy};

use super::block_bins::{BinBlock, BlockBins};
use super::body::{Body, edges_of};
use super::exposed::{Rect, exposed_parts};
use super::static_grid::{GridEdge, ListedEdge, StaticGrid};
use crate::geom::Aabb;

/// A static block: its model, block index, z interval and vertex range in `StaticIndex::pts`.
#[derive(Clone, Copy)]
pub(super) struct StaticBlock {
    pub(super) model: ModelId,
    pub(super) block: u32,
    pub(super) zmin: f64,
    pub(super) zmax: f64,
    start: u32,
    end: u32,
}

/// The static bodies' blocks in a parry2d BVH (one leaf per block), with their outlines in
/// one flat vertex array.
pub(super) struct StaticIndex {
    pub(super) blocks: Vec<StaticBlock>,
    pub(super) pts: Vec<[f64; 2]>,
    pub(super) bvh: Bvh,
    /// The same blocks' edges in a uniform grid, for rays.
    pub(super) grid: Option<StaticGrid>,
    /// The same blocks whole in a coarser grid, for fans (present with `grid`).
    pub(super) bins: Option<BlockBins>,
}

/// Margin (m) added around each box handed to the BVH, whose boxes are `f32`: rounding never
/// shrinks a box past its block.
pub(super) const AABB_PAD: f64 = 1e-4;

impl StaticIndex {
    pub(super) fn build(bodies: &[Body], dynamic: &[bool]) -> StaticIndex {
        let mut blocks = Vec::new();
        let mut pts = Vec::new();
        let mut leaves = Vec::new();
        let mut boxes = Vec::new();
        for (m, body) in bodies.iter().enumerate() {
            if dynamic[m] {
                continue;
            }
            for (bi, wb) in body.blocks.iter().enumerate() {
                let p = body.block_pts(bi);
                let start = pts.len() as u32;
                pts.extend_from_slice(p);
                let mut bb = Aabb::EMPTY;
                p.iter().for_each(|q| bb.add(*q));
                boxes.push(bb);
                leaves.push(PAabb::new(
                    Point::new((bb.min[0] - AABB_PAD) as f32, (bb.min[1] - AABB_PAD) as f32),
                    Point::new((bb.max[0] + AABB_PAD) as f32, (bb.max[1] + AABB_PAD) as f32),
                ));
                blocks.push(StaticBlock {
                    model: ModelId(m as u32),
                    block: bi as u32,
                    zmin: wb.zmin,
                    zmax: wb.zmax,
                    start,
                    end: pts.len() as u32,
                });
            }
        }
        let bvh = Bvh::from_leaves(BvhBuildStrategy::Binned, &leaves);
        // rays list each edge only where it is exposed (see `exposed`)
        let rects: Vec<Option<Rect>> = blocks
            .iter()
            .map(|sb| Rect::of(&pts[sb.start as usize..sb.end as usize]))
            .collect();
        let mut edges = Vec::new();
        // whether each block's edges are all listed whole (see `block_bins`)
        let mut whole = vec![true; blocks.len()];
        for (i, sb) in blocks.iter().enumerate() {
            // the rectangles of the same model and z interval that touch this one
            let near: Vec<Rect> = match &rects[i] {
                Some(_) => bvh
                    .intersect_aabb(&leaves[i])
                    .filter_map(|leaf| {
                        let (l, o) = (leaf as usize, &blocks[leaf as usize]);
                        let same =
                            l != i && o.model == sb.model && o.zmin == sb.zmin && o.zmax == sb.zmax;
                        if same { rects[l] } else { None }
                    })
                    .collect(),
                None => Vec::new(),
            };
            for (a, b) in edges_of(&pts[sb.start as usize..sb.end as usize]) {
                let parts = match &rects[i] {
                    Some(own) => exposed_parts(a, b, own, near.iter().copied()),
                    None => vec![[a, b]],
                };
                whole[i] &= parts[..] == [[a, b]];
                let edge = GridEdge {
                    a,
                    b,
                    block: i as u32,
                };
                edges.push(ListedEdge { edge, parts });
            }
        }
        let grid = StaticGrid::build(&edges);
        let bins = grid.as_ref().map(|g| {
            let listed: Vec<(BinBlock, bool)> = blocks
                .iter()
                .zip(&boxes)
                .zip(&whole)
                .map(|((sb, &aabb), &whole)| {
                    let z = [sb.zmin, sb.zmax];
                    let bb = BinBlock::new(aabb, z, sb.model, sb.block, [sb.start, sb.end]);
                    (bb, whole)
                })
                .collect();
            BlockBins::build(&g.lat, &listed)
        });
        StaticIndex {
            blocks,
            pts,
            bvh,
            grid,
            bins,
        }
    }

    /// Edges of static block `i`.
    #[inline]
    pub(super) fn edges(&self, i: usize) -> impl Iterator<Item = ([f64; 2], [f64; 2])> + '_ {
        let b = &self.blocks[i];
        edges_of(&self.pts[b.start as usize..b.end as usize])
    }
}
