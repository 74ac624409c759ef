//! The read-only view of the world that model updates get in phase 1 of a step: the tree, the
//! poses and colours at the end of the previous step, and the spatial index.

use crate::color::Color;
use crate::node::Node;
use crate::pose::Pose;
use crate::space::Space;

/// Read-only view of the world handed to model updates (phase 1).
pub(crate) struct View<'a> {
    pub nodes: &'a [Node],
    pub globals: &'a [Pose],
    pub colors: &'a [Color],
    pub space: &'a Space,
    pub fiducial_targets: &'a [u32],
    pub sim_time: u64,
    pub dt: f64,
}

impl View<'_> {
    #[inline]
    pub fn root(&self, m: u32) -> u32 {
        self.nodes[m as usize].root
    }
    #[inline]
    pub fn body_frame(&self, m: u32) -> Pose {
        self.globals[m as usize].compose(&self.nodes[m as usize].origin)
    }
    #[inline]
    pub fn block_color(&self, m: u32, b: u32) -> Color {
        self.nodes[m as usize].blocks[b as usize]
            .color
            .unwrap_or(self.colors[m as usize])
    }
}
