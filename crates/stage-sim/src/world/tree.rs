//! The model tree: global poses and world outlines, subtrees, names and reparenting.

use crate::desc::{ModelDesc, ModelType};
use crate::error::{Error, Result};
use crate::geom::Aabb;
use crate::pose::Pose;
use crate::space::{Body, WorldBlock};

use super::*;

pub(super) fn local_blocks(m: &ModelDesc) -> Result<Vec<LocalBlock>> {
    if m.default_body {
        let [sx, sy, sz] = m.size;
        return Ok(vec![LocalBlock {
            pts: vec![
                [-sx / 2.0, -sy / 2.0],
                [sx / 2.0, -sy / 2.0],
                [sx / 2.0, sy / 2.0],
                [-sx / 2.0, sy / 2.0],
            ],
            z: [0.0, sz],
            color: None,
        }]);
    }
    m.blocks
        .iter()
        .map(|b| {
            let bad = |msg: String| Error::InvalidModel {
                model: m.name.clone(),
                source_loc: m.source.clone(),
                msg,
            };
            if b.points.len() < 2 {
                return Err(bad(format!(
                    "a block has {} point(s); at least 2 are needed",
                    b.points.len()
                )));
            }
            if b.points.iter().flatten().any(|v| !v.is_finite())
                || !b.zmin.is_finite()
                || !b.zmax.is_finite()
            {
                return Err(bad("a block coordinate is not a finite number".into()));
            }
            Ok(LocalBlock {
                pts: b.points.clone(),
                z: [b.zmin, b.zmax],
                color: b.color,
            })
        })
        .collect()
}

pub(super) fn body_of(node: &Node, global: &Pose, out: &mut Body) {
    out.blocks.clear();
    out.aabb = Aabb::EMPTY;
    if node.blocks.is_empty() {
        out.pts.clear();
        return;
    }
    let frame = global.compose(&node.origin);
    let (s, c) = frame.a.sin_cos();
    // the points written into slots made at once (a pioneer's outline is dozens of points, and
    // every robot's outline is rebuilt at every move, into a body that has as many already)
    let total = node.blocks.iter().map(|b| b.pts.len()).sum();
    if out.pts.len() != total {
        out.pts.clear();
        out.pts.resize(total, [0.0; 2]);
    }
    let mut next = 0;
    for b in &node.blocks {
        let start = next as u32;
        let mut bb = Aabb::EMPTY;
        for (p, slot) in b.pts.iter().zip(&mut out.pts[next..]) {
            let w = [frame.x + p[0] * c - p[1] * s, frame.y + p[0] * s + p[1] * c];
            bb.add(w);
            *slot = w;
        }
        next += b.pts.len();
        out.aabb.merge(&bb);
        out.blocks.push(WorldBlock {
            zmin: frame.z + b.z[0],
            zmax: frame.z + b.z[1],
            start,
            end: next as u32,
            aabb: bb,
        });
    }
}

pub(super) fn global_of(nodes: &[Node], globals: &[Pose], m: usize, pose: &Pose) -> Pose {
    match nodes[m].parent {
        None => *pose,
        Some(p) => global_of_parent(&nodes[p.index()], &globals[p.index()], pose),
    }
}

/// `m` and its descendants into `out`, parents before children.
pub(super) fn tree_of(nodes: &[Node], m: ModelId, out: &mut Vec<ModelId>) {
    out.clear();
    out.push(m);
    let mut i = 0;
    while i < out.len() {
        let x = out[i].index();
        out.extend_from_slice(&nodes[x].children);
        i += 1;
    }
}

/// Whether a body reaches below the ground (z < 0): a move that puts it there is refused.
pub(super) fn below_ground(body: &Body) -> bool {
    body.blocks.iter().any(|b| b.zmin < 0.0)
}

/// Which models stop a move of the tree rooted at `root`: unrelated ones with
/// `obstacle_return`.
pub(super) fn obstacle_to<'a>(
    space: &'a Space,
    returns: &'a [Returns],
    root: ModelId,
) -> impl Fn(ModelId) -> bool + Copy + 'a {
    move |o| space.root_of(o) != root && returns[o.index()].obstacle
}

/// The global pose of a child at `pose` in `parent`'s frame (stacked on top of it if the
/// parent stacks its children).
pub(super) fn global_of_parent(parent: &Node, parent_global: &Pose, pose: &Pose) -> Pose {
    let mut g = parent_global.compose(pose);
    if parent.stack_children {
        g.z += parent.size[2];
    }
    g
}

impl World {
    // ----- tree and names ----------------------------------------------------------------

    /// Number of models.
    pub fn model_count(&self) -> usize {
        self.nodes.len()
    }

    /// Every model id in creation order.
    pub fn models(&self) -> impl Iterator<Item = ModelId> + '_ {
        (0..self.nodes.len() as u32).map(ModelId)
    }

    /// The id of the model with creation index `index` (a number kept by a caller, such as a
    /// per-model table's row), or [`Error::ForeignModel`] when the world has no such model.
    pub fn model_id(&self, index: usize) -> Result<ModelId> {
        let id = ModelId(u32::try_from(index).unwrap_or(u32::MAX));
        self.check(id).map(|_| id)
    }

    /// The model registered under `name` (the last one registered wins, as in Stage).
    pub fn model_by_name(&self, name: &str) -> Option<ModelId> {
        self.names.get(name).copied()
    }

    /// Tree and configuration data of a model.
    pub fn node(&self, m: ModelId) -> Result<&Node> {
        Ok(&self.nodes[self.check(m)?])
    }

    /// The model's name.
    pub fn name(&self, m: ModelId) -> Result<&str> {
        Ok(&self.nodes[self.check(m)?].name)
    }

    /// The model's Stage type: what code compares (the compiler checks every name).
    pub fn model_type(&self, m: ModelId) -> Result<ModelType> {
        Ok(self.nodes[self.check(m)?].model_type)
    }

    /// The model's Stage type word (`position`, `ranger`, …), for messages and display.
    pub fn type_name(&self, m: ModelId) -> Result<&'static str> {
        Ok(self.model_type(m)?.name())
    }

    /// The parent model.
    pub fn parent(&self, m: ModelId) -> Result<Option<ModelId>> {
        Ok(self.nodes[self.check(m)?].parent)
    }

    /// Children in creation order.
    pub fn children(&self, m: ModelId) -> Result<impl Iterator<Item = ModelId> + '_> {
        Ok(self.nodes[self.check(m)?].children.iter().copied())
    }

    /// `m` and its descendants in pre-order (how the stage driver binds devices).
    pub fn subtree(&self, m: ModelId) -> Result<Vec<ModelId>> {
        self.check(m)?;
        let mut out = Vec::new();
        let mut stack = vec![m];
        while let Some(x) = stack.pop() {
            out.push(x);
            for &c in self.nodes[x.index()].children.iter().rev() {
                stack.push(c);
            }
        }
        Ok(out)
    }

    /// Top-level models in creation order.
    pub fn roots(&self) -> impl Iterator<Item = ModelId> + '_ {
        self.models()
            .filter(|m| self.nodes[m.index()].parent.is_none())
    }

    /// Whether two models are in the same tree (they never see or touch each other).
    pub fn related(&self, a: ModelId, b: ModelId) -> Result<bool> {
        Ok(self.nodes[self.check(a)?].root == self.nodes[self.check(b)?].root)
    }
}

/// The models a fiducial finder can see: those with a non-zero `fiducial_return`, in id order.
pub(super) fn fiducial_targets(returns: &[Returns]) -> Vec<ModelId> {
    (0..returns.len() as u32)
        .filter(|&i| returns[i as usize].fiducial != 0)
        .map(ModelId)
        .collect()
}
