//! `model` (spec §3): a plain body (walls, boxes, pucks, floorplans) with no behaviour of its
//! own; Stage 3's `wifi` is simulated as one.

use super::{KindDesc, ModelKind};
use crate::node::{ModelId, Node};
use crate::pose::Pose;
use crate::rng::SimRng;
use crate::view::View;
use worldfile::models as wm;

/// A plain model's state: none.
#[derive(Clone, Debug)]
pub struct Plain;

pub(crate) fn start(_: &(), _: &Pose, _: &mut SimRng) -> Plain {
    Plain
}

impl ModelKind for Plain {
    #[inline]
    fn update(&mut self, _: &View, _: ModelId, _: &Pose, _: &Node, _: &mut SimRng) {}
}

/// A Stage 3 `wifi` model, simulated as a plain model (there is no radio model), and the
/// warning that says so.
pub(crate) fn wifi_as_plain(_: &wm::WifiSpec, _: &mut SimRng) -> (KindDesc, String) {
    let why = "Stage 3 `wifi` is not simulated (no radio model); it is a plain model";
    (KindDesc::Model, why.into())
}
