//! `lightindicator`: an on/off light, switched through the API ([`crate::World::set_light`]).

use super::ModelKind;
use crate::digest::Digest;
use crate::node::{ModelId, Node};
use crate::pose::Pose;
use crate::rng::SimRng;
use crate::view::View;

/// A light indicator's state.
#[derive(Clone, Debug)]
pub struct Lightindicator {
    /// Lit (from the start).
    pub on: bool,
}

pub(crate) fn start(_: &(), _: &Pose, _: &mut SimRng) -> Lightindicator {
    Lightindicator { on: true }
}

impl ModelKind for Lightindicator {
    #[inline]
    fn update(&mut self, _: &View, _: ModelId, _: &Pose, _: &Node, _: &mut SimRng) {}

    fn digest(&self, d: &mut Digest) {
        d.u64(self.on as u64);
    }
}
