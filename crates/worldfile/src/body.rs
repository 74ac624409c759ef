//! Model bodies: blocks, the block group, size scaling (stage-models.md §2).
//!
//! Blocks are collected in "block units" in Stage's load order (default square, `noblocks`,
//! `bitmap`, `boundary`, then `block` sub-entities), then the whole group is stretched so its xy
//! bounding box is exactly `size` centred on the body origin, and z is scaled so the tallest block
//! reaches `size.z`.

use serde::Serialize;

use crate::color::Rgba;
use crate::source::SourceLoc;

/// Where a block came from.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum BlockOrigin {
    /// The default unit square.
    Default,
    /// A `block` sub-entity.
    Block {
        /// Its location.
        at: SourceLoc,
    },
    /// A rectangle from a bitmap.
    Bitmap,
    /// A `boundary` wall.
    Boundary,
    /// Gripper base.
    GripperBase,
    /// Gripper left paddle.
    GripperLeftPaddle,
    /// Gripper right paddle.
    GripperRightPaddle,
}

/// A block in block units, as written.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RawBlock {
    /// Vertices (counter-clockwise).
    pub points: Vec<[f64; 2]>,
    /// `[zmin zmax]`.
    pub z: [f64; 2],
    /// Own colour; `None` inherits the model's.
    pub color: Option<Rgba>,
    /// Origin.
    pub origin: BlockOrigin,
}

/// A block in the model's body frame, in metres (after size scaling).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BlockSpec {
    /// Vertices, counter-clockwise, in the body frame (the frame at `pose ⊕ origin`).
    pub points: Vec<[f64; 2]>,
    /// `[zmin zmax]` above the body base (global z = model global z + origin z + these).
    pub z: [f64; 2],
    /// Own colour; `None` inherits the model's (so recolouring the model recolours it).
    pub color: Option<Rgba>,
    /// Where it came from.
    pub origin: BlockOrigin,
    /// The same block in block units.
    pub raw_points: Vec<[f64; 2]>,
    /// `[zmin zmax]` in block units.
    pub raw_z: [f64; 2],
}

/// Bounding box of a block group in block units (blockgroup.cc `CalcSize`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct GroupBounds {
    /// Minimum corner.
    pub min: [f64; 2],
    /// Maximum corner.
    pub max: [f64; 2],
    /// Height: the largest `zmax`, at least 0.
    pub height: f64,
}

impl GroupBounds {
    /// The bounds of these blocks, `None` if there are none.
    pub fn of(blocks: &[RawBlock]) -> Option<GroupBounds> {
        let mut pts = blocks.iter().flat_map(|b| b.points.iter());
        let first = pts.next()?;
        let mut b = GroupBounds {
            min: *first,
            max: *first,
            height: 0.0,
        };
        for p in pts {
            b.min = [b.min[0].min(p[0]), b.min[1].min(p[1])];
            b.max = [b.max[0].max(p[0]), b.max[1].max(p[1])];
        }
        b.height = blocks.iter().fold(0.0f64, |h, blk| h.max(blk.z[1]));
        Some(b)
    }

    /// Extent along x and y.
    pub fn size(&self) -> [f64; 2] {
        [self.max[0] - self.min[0], self.max[1] - self.min[1]]
    }
}

/// A rectangle block `(x, y)` to `(x + dx, y + dy)`, z `[0, dz]` (model.cc `AddBlockRect`).
pub fn rect_block(x: f64, y: f64, dx: f64, dy: f64, dz: f64, origin: BlockOrigin) -> RawBlock {
    RawBlock {
        points: vec![[x, y], [x + dx, y], [x + dx, y + dy], [x, y + dy]],
        z: [0.0, dz],
        color: None,
        origin,
    }
}

/// Makes a vertex list counter-clockwise (block.cc `canonicalize_winding`).
pub fn counter_clockwise(mut points: Vec<[f64; 2]>) -> Vec<[f64; 2]> {
    let n = points.len();
    let twice_area: f64 = (0..n)
        .map(|i| {
            let a = points[i];
            let b = points[(i + 1) % n];
            a[0] * b[1] - b[0] * a[1]
        })
        .sum();
    if twice_area < 0.0 {
        points.reverse();
    }
    points
}

/// The gripper's three blocks for a paddle state (stage-models.md §11.2).
///
/// `paddle_size` = (length, width, height) fractions; `position` 0 open … 1 closed; `lift` 0
/// down … 1 up.
pub fn gripper_blocks(paddle_size: [f64; 3], position: f64, lift: f64) -> Vec<RawBlock> {
    let [px, py, pz] = paddle_size;
    let centre = position * (0.5 - py);
    let left_y = centre + py / 2.0;
    let right_y = 1.0 - centre - py / 2.0;
    let bottom = lift * (1.0 - pz);
    let paddle = |cy: f64, origin| {
        let mut b = rect_block(1.0 - px, cy - py / 2.0, px, py, pz, origin);
        b.z = [bottom, bottom + pz];
        b
    };
    vec![
        rect_block(0.0, 0.0, 1.0 - px, 1.0, 1.0, BlockOrigin::GripperBase),
        paddle(left_y, BlockOrigin::GripperLeftPaddle),
        paddle(right_y, BlockOrigin::GripperRightPaddle),
    ]
}

/// The four thin walls `boundary 1` adds around the current blocks (0.01 block units thick).
pub fn boundary_blocks(b: &GroupBounds) -> Vec<RawBlock> {
    let e = 0.01;
    let [sx, sy] = b.size();
    let h = b.height;
    vec![
        rect_block(b.min[0], b.min[1], e, sy, h, BlockOrigin::Boundary),
        rect_block(b.min[0], b.min[1], sx, e, h, BlockOrigin::Boundary),
        rect_block(b.min[0], b.max[1] - e, sx, e, h, BlockOrigin::Boundary),
        rect_block(b.max[0] - e, b.min[1], e, sy, h, BlockOrigin::Boundary),
    ]
}

/// What scaling had to do about degenerate groups (for warnings).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ScaleNotes {
    /// All vertices share one x or one y (Stage divides by zero there).
    pub flat_xy: bool,
    /// The group has no height (e.g. no block has `z`; Stage's z becomes NaN).
    pub flat_z: bool,
}

/// Scales a block group to `size` (stage-models.md §2.3).
///
/// Degenerate groups, where Stage produces inf/NaN: a flat axis maps to 0 (every vertex is at
/// the centre on that axis), and a group with no height makes every block full height
/// `[0, size.z]` so it still collides and blocks rays.
pub fn scale(blocks: &[RawBlock], size: [f64; 3]) -> (Vec<BlockSpec>, ScaleNotes) {
    let mut notes = ScaleNotes::default();
    let Some(bounds) = GroupBounds::of(blocks) else {
        return (Vec::new(), notes);
    };
    let [bx, by] = bounds.size();
    let offset = [bounds.min[0] + bx / 2.0, bounds.min[1] + by / 2.0];
    let factor = |extent: f64, target: f64, flat: &mut bool| {
        if extent > 0.0 {
            target / extent
        } else {
            *flat = true;
            0.0
        }
    };
    let sx = factor(bx, size[0], &mut notes.flat_xy);
    let sy = factor(by, size[1], &mut notes.flat_xy);
    let sz = if bounds.height > 0.0 {
        Some(size[2] / bounds.height)
    } else {
        notes.flat_z = true;
        None
    };
    let out = blocks
        .iter()
        .map(|b| BlockSpec {
            points: b
                .points
                .iter()
                .map(|p| [(p[0] - offset[0]) * sx, (p[1] - offset[1]) * sy])
                .collect(),
            z: match sz {
                Some(s) => [b.z[0] * s, b.z[1] * s],
                None => [0.0, size[2]],
            },
            color: b.color,
            origin: b.origin.clone(),
            raw_points: b.points.clone(),
            raw_z: b.z,
        })
        .collect();
    (out, notes)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn block(points: &[[f64; 2]], z: [f64; 2]) -> RawBlock {
        RawBlock {
            points: points.to_vec(),
            z,
            color: None,
            origin: BlockOrigin::Default,
        }
    }

    #[test]
    fn union_is_stretched_to_size_and_centred() {
        // stage-models.md §2.3: a triangle plus a square in a 2 x 1 model.
        let blocks = [
            block(&[[0.0, 0.0], [10.0, 0.0], [10.0, 5.0]], [0.0, 1.0]),
            block(
                &[[2.0, 1.0], [3.0, 1.0], [3.0, 2.0], [2.0, 2.0]],
                [0.0, 1.0],
            ),
        ];
        let (out, notes) = scale(&blocks, [2.0, 1.0, 1.0]);
        assert_eq!(notes, ScaleNotes::default());
        assert_eq!(out[0].points, vec![[-1.0, -0.5], [1.0, -0.5], [1.0, 0.5]]);
        let p = out[1].points[0];
        assert!(
            (p[0] + 0.6).abs() < 1e-12 && (p[1] + 0.3).abs() < 1e-12,
            "{p:?}"
        );
    }

    #[test]
    fn z_scales_from_zero_to_the_tallest_block() {
        // stage-models.md §2.3 example: size.z 0.5, blocks z [2 4] and [0 1] -> s = 0.125.
        let sq = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let (out, _) = scale(
            &[block(&sq, [2.0, 4.0]), block(&sq, [0.0, 1.0])],
            [1.0, 1.0, 0.5],
        );
        assert_eq!(out[0].z, [0.25, 0.5]);
        assert_eq!(out[1].z, [0.0, 0.125]);
    }

    #[test]
    fn flat_groups_do_not_produce_nan() {
        let (out, notes) = scale(
            &[block(&[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]], [0.0, 0.0])],
            [2.0, 2.0, 0.3],
        );
        assert!(notes.flat_z);
        assert_eq!(out[0].z, [0.0, 0.3]);
        let (out, notes) = scale(
            &[block(&[[0.0, 1.0], [4.0, 1.0]], [0.0, 1.0])],
            [2.0, 2.0, 1.0],
        );
        assert!(notes.flat_xy);
        assert_eq!(out[0].points, vec![[-1.0, 0.0], [1.0, 0.0]]);
    }

    #[test]
    fn winding_is_made_counter_clockwise() {
        let cw = vec![[0.0, 0.0], [0.0, 1.0], [1.0, 1.0], [1.0, 0.0]];
        assert_eq!(
            counter_clockwise(cw),
            vec![[1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.0, 0.0]]
        );
    }

    #[test]
    fn gripper_body_fills_its_box() {
        let blocks = gripper_blocks([0.66, 0.1, 0.4], 0.0, 0.0);
        let b = GroupBounds::of(&blocks).unwrap();
        assert_eq!((b.min, b.max, b.height), ([0.0, 0.0], [1.0, 1.0], 1.0));
        // Open paddles sit at the sides, 0.1 wide, 0.4 tall at the bottom.
        assert_eq!(blocks[1].points[0], [1.0 - 0.66, 0.0]);
        assert!((blocks[2].points[2][1] - 1.0).abs() < 1e-12);
        assert_eq!(blocks[1].z, [0.0, 0.4]);
        // Closed and lifted: paddles meet in the middle and rise to the top.
        let closed = gripper_blocks([0.66, 0.1, 0.4], 1.0, 1.0);
        assert!((closed[1].points[2][1] - 0.5).abs() < 1e-12);
        assert!((closed[2].points[0][1] - 0.5).abs() < 1e-12);
        assert!((closed[1].z[1] - 1.0).abs() < 1e-12);
    }

    #[test]
    fn boundary_hugs_the_blocks() {
        let b = GroupBounds {
            min: [0.0, 0.0],
            max: [10.0, 5.0],
            height: 1.0,
        };
        let walls = boundary_blocks(&b);
        assert_eq!(walls.len(), 4);
        let all = GroupBounds::of(&walls).unwrap();
        assert_eq!((all.min, all.max), ([0.0, 0.0], [10.0, 5.0]));
    }
}
