//! The read-only view of the world that model updates get in phase 1 of a step: the tree, the
//! poses and colours at the end of the previous step, and the spatial index.

use crate::color::Color;
use crate::node::{ModelId, Node, Returns};
use crate::pose::Pose;
use crate::space::Space;

/// Read-only view of the world handed to model updates (phase 1).
pub(crate) struct View<'a> {
    pub nodes: &'a [Node],
    pub returns: &'a [Returns],
    pub globals: &'a [Pose],
    pub colors: &'a [Color],
    pub space: &'a Space,
    pub fiducial_targets: &'a [ModelId],
    pub sim_time: u64,
    pub dt: f64,
}

impl View<'_> {
    #[inline]
    pub fn root(&self, m: ModelId) -> ModelId {
        self.nodes[m.index()].root
    }
    #[inline]
    pub fn body_frame(&self, m: ModelId) -> Pose {
        self.globals[m.index()].compose(&self.nodes[m.index()].origin)
    }
    #[inline]
    pub fn block_color(&self, m: ModelId, b: u32) -> Color {
        self.nodes[m.index()].blocks[b as usize]
            .color
            .unwrap_or(self.colors[m.index()])
    }
}
