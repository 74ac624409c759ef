//! Contacts: whether a body's outline crosses another's (static blocks through the BVH, moving
//! bodies through the dynamic grid), with overlapping z intervals.

use crate::node::ModelId;
use parry2d::bounding_volume::Aabb as PAabb;
use parry2d::math::Point;

use super::dyn_grid::CellEntry;
use super::static_index::AABB_PAD;
use super::{Body, Space};
use crate::geom::{Aabb, segments_intersect};

impl Space {
    /// Contact test for a set of models (a moving model and its descendants): returns the first
    /// other model whose outline intersects one of theirs with overlapping z intervals and that
    /// `accept` admits (unrelated, `obstacle_return`). `None`: no contact.
    pub fn first_contact(
        &self,
        movers: &[ModelId],
        cand: &mut Vec<ModelId>,
        accept: impl Fn(ModelId) -> bool,
    ) -> Option<ModelId> {
        let mut best: Option<ModelId> = None;
        for &m in movers {
            let body = &self.bodies[m.index()];
            if body.is_empty() {
                continue;
            }
            if let Some(s) = self.static_contact(body, best, &accept) {
                best = Some(s);
            }
            if let Some(d) = self.dynamic_contact(m, body, cand, best, &accept) {
                best = Some(d);
            }
        }
        best
    }

    /// Whether `body` (registered or not: a move being tried) touches a static block that
    /// `accept` admits. Static blocks do not change while robots move, so this can be asked
    /// for every robot at once, in parallel, before the moves are applied in order.
    pub fn touches_static(&self, body: &Body, accept: impl Fn(ModelId) -> bool) -> bool {
        !body.is_empty() && self.static_contact(body, None, &accept).is_some()
    }

    /// Whether any of the registered `movers` touches a moving body that `accept` admits (the
    /// order-dependent half of [`Space::first_contact`]).
    pub fn touches_dynamic(
        &self,
        movers: &[ModelId],
        cand: &mut Vec<ModelId>,
        accept: impl Fn(ModelId) -> bool,
    ) -> bool {
        movers.iter().any(|&m| {
            let body = &self.bodies[m.index()];
            !body.is_empty() && self.dynamic_contact(m, body, cand, None, &accept).is_some()
        })
    }

    /// The lowest-numbered static model below `bound` whose live blocks touch `body`.
    fn static_contact(
        &self,
        body: &Body,
        bound: Option<ModelId>,
        accept: &impl Fn(ModelId) -> bool,
    ) -> Option<ModelId> {
        if self
            .statics
            .grid
            .as_ref()
            .is_some_and(|g| g.no_edge_near(&body.aabb))
        {
            return None;
        }
        let mut best = bound;
        let mut found = None;
        let bb = body.aabb;
        let pa = PAabb::new(
            Point::new((bb.min[0] - AABB_PAD) as f32, (bb.min[1] - AABB_PAD) as f32),
            Point::new((bb.max[0] + AABB_PAD) as f32, (bb.max[1] + AABB_PAD) as f32),
        );
        for leaf in self.statics.bvh.intersect_aabb(&pa) {
            let sb = self.statics.blocks[leaf as usize];
            if !self.static_live[sb.model.index()]
                || best.is_some_and(|b| sb.model >= b)
                || !accept(sb.model)
            {
                continue;
            }
            if self
                .statics
                .edges(leaf as usize)
                .any(|(a, b)| self.edge_hits_body(body, a, b, sb.zmin, sb.zmax))
            {
                best = Some(sb.model);
                found = best;
            }
        }
        found
    }

    /// The lowest-numbered moving model below `bound`, other than `m`, whose blocks touch
    /// `body` (model `m`'s registered body).
    fn dynamic_contact(
        &self,
        m: ModelId,
        body: &Body,
        cand: &mut Vec<ModelId>,
        bound: Option<ModelId>,
        accept: &impl Fn(ModelId) -> bool,
    ) -> Option<ModelId> {
        let bb = body.aabb;
        cand.clear();
        let g = &self.grid;
        // only models whose box (carried by the cell entries) meets the mover's
        let near = |cand: &mut Vec<ModelId>, list: &[CellEntry]| {
            cand.extend(
                list.iter()
                    .filter(|e| e.model != m && e.aabb.intersects(&bb))
                    .map(|e| e.model),
            )
        };
        match g.span_of(&bb) {
            Some(span) => {
                for i in g.lat.cells_in(span) {
                    near(cand, &g.cells[i]);
                }
            }
            None => {
                // the mover is (partly) outside the grid: test every registered model
                for c in &g.cells {
                    near(cand, c);
                }
            }
        }
        cand.extend_from_slice(&g.overflow);
        cand.sort_unstable();
        cand.dedup();
        // ascending order: the first touching model is the lowest
        for &o in cand.iter() {
            if o == m {
                continue;
            }
            if bound.is_some_and(|b| o >= b) {
                break;
            }
            let ob = &self.bodies[o.index()];
            if !ob.aabb.intersects(&bb) || !accept(o) {
                continue;
            }
            for (bi, blk) in ob.blocks.iter().enumerate() {
                for (a, b) in ob.edges(bi) {
                    if self.edge_hits_body(body, a, b, blk.zmin, blk.zmax) {
                        return Some(o);
                    }
                }
            }
        }
        None
    }

    fn edge_hits_body(&self, body: &Body, a: [f64; 2], b: [f64; 2], zmin: f64, zmax: f64) -> bool {
        let mut eb = Aabb::EMPTY;
        eb.add(a);
        eb.add(b);
        if !eb.intersects(&body.aabb) {
            return false;
        }
        for (bi, blk) in body.blocks.iter().enumerate() {
            // inclusive z overlap (block.cc TestCollision); NaN bounds never overlap
            if !(zmin <= blk.zmax && zmax >= blk.zmin && eb.intersects(&blk.aabb)) {
                continue;
            }
            for (p, q) in body.edges(bi) {
                if segments_intersect(p, q, a, b) {
                    return true;
                }
            }
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Contacts with static blocks where the static grid vouches for open space (no query)
    /// and where it does not: on a wall's outline, and across the side two blocks of one wall
    /// share (which rays never need, so the ray grid leaves it out).
    #[test]
    fn static_contacts_in_open_space_on_walls_and_inside_them() {
        // a wall of two touching 10 m blocks (shared side at x = 10): 5 m grid cells, the
        // middle ones crossed by the shared side only
        let wall = Body::from_rects(&[[0.0, 0.0, 10.0, 10.0], [10.0, 0.0, 10.0, 10.0]]);
        let space = Space::new(vec![wall], &[false], vec![ModelId(0)]);
        let grid = space.statics.grid.as_ref().unwrap();
        let touches = |x: f64, y: f64| {
            let b = Body::from_rects(&[[x, y, 0.1, 0.1]]);
            (
                space.touches_static(&b, |_| true),
                grid.no_edge_near(&b.aabb),
            )
        };
        // away from every side: no contact, and the grid says so without a query
        assert_eq!(touches(6.0, 6.0), (false, true));
        // across the wall's outer side: contact
        assert_eq!(touches(-0.05, 5.0), (true, false));
        // across the shared side, which no ray needs: contact (found by the query)
        assert_eq!(touches(9.95, 5.0), (true, false));
        // leaving the grid: no vouching
        assert!(!grid.no_edge_near(&Body::from_rects(&[[-50.0, 0.0, 0.1, 0.1]]).aabb));
    }
}
