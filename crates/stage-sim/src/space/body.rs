//! Bodies in world space: a model's polygon outlines with their z ranges, as the indices and
//! queries of [`Space`](super::Space) read them.

use crate::geom::Aabb;
use smallvec::SmallVec;

/// One block of a body in world space: its z interval and its vertex range in [`Body::pts`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorldBlock {
    /// Lower z bound (m, world).
    pub zmin: f64,
    /// Upper z bound (m, world).
    pub zmax: f64,
    /// First vertex in the body's point list.
    pub start: u32,
    /// One past the last vertex.
    pub end: u32,
    /// Bounding box of the block's vertices.
    pub aabb: Aabb,
}

impl WorldBlock {
    /// The block's vertices among its body's points `pts`.
    #[inline(always)]
    pub fn points<'a>(&self, pts: &'a [[f64; 2]]) -> &'a [[f64; 2]] {
        &pts[self.start as usize..self.end as usize]
    }
}

/// A model's body in world space (polygon outlines with z ranges); empty for bodiless models.
///
/// A lone block of up to four points (every robot's default body) is kept inline: a ray
/// testing another robot then reads the body where the body table holds it, not a list of
/// blocks and then a list of points elsewhere on the heap (two cache misses per body tested in
/// a 10,000-robot swarm: end to end ~4-6% faster, 8 alternating runs; instructions per step
/// within 1% on the other bench worlds).
#[derive(Clone, Debug, Default)]
pub struct Body {
    /// Blocks in model order (the index is the block index used in hits).
    pub blocks: SmallVec<[WorldBlock; 1]>,
    /// All vertices of all blocks, block after block.
    pub pts: SmallVec<[[f64; 2]; 4]>,
    /// Bounding box of all vertices.
    pub aabb: Aabb,
}

impl Body {
    /// Whether the model has any outline to see or touch.
    pub fn is_empty(&self) -> bool {
        self.blocks.is_empty()
    }

    /// The vertices of block `b`.
    pub fn block_pts(&self, b: usize) -> &[[f64; 2]] {
        self.blocks[b].points(&self.pts)
    }

    /// Iterates the edges of block `b` (closed polygon; a 2-point block is one segment).
    #[inline]
    pub fn edges(&self, b: usize) -> impl Iterator<Item = ([f64; 2], [f64; 2])> + '_ {
        edges_of(self.block_pts(b))
    }
}

#[cfg(test)]
impl Body {
    /// A test body of one block per rectangle `[x, y, w, h]` (corners counter-clockwise from
    /// `(x, y)`), z from 0 to 1.
    pub(super) fn from_rects(rects: &[[f64; 4]]) -> Body {
        let mut body = Body::default();
        for &[x, y, w, h] in rects {
            let start = body.pts.len() as u32;
            let pts = [[x, y], [x + w, y], [x + w, y + h], [x, y + h]];
            let mut aabb = Aabb::EMPTY;
            pts.iter().for_each(|p| aabb.add(*p));
            body.pts.extend_from_slice(&pts);
            body.blocks.push(WorldBlock {
                zmin: 0.0,
                zmax: 1.0,
                start,
                end: start + 4,
                aabb,
            });
            body.aabb.merge(&aabb);
        }
        body
    }
}

/// The edges of a closed polygon (a 2-point polygon is a single segment).
#[inline]
pub(super) fn edges_of(p: &[[f64; 2]]) -> impl Iterator<Item = ([f64; 2], [f64; 2])> + '_ {
    let n = p.len();
    let closing = (n > 2).then(|| (p[n - 1], p[0]));
    p.windows(2).map(|w| (w[0], w[1])).chain(closing)
}
