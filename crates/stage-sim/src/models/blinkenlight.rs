//! `blinkenlight` (spec §14): a light Stage starts itself that toggles at every update.

use super::ModelKind;
use crate::digest::Digest;
use crate::node::{ModelId, Node};
use crate::pose::Pose;
use crate::rng::SimRng;
use crate::view::View;
use worldfile::models as wm;

/// Blinkenlight properties (spec §14).
#[derive(Clone, Debug, PartialEq)]
pub struct BlinkenlightDesc {
    /// Period (ms, unused by Stage).
    pub period_ms: u32,
    /// Duty cycle (unused by Stage).
    pub dutycycle: f64,
}

default_from_spec!(BlinkenlightDesc);

/// A blinkenlight's state.
#[derive(Clone, Debug)]
pub struct Blinkenlight {
    /// Lit (off before the first update).
    pub on: bool,
}

pub(crate) fn desc_from_spec(b: &wm::BlinkenlightSpec, _: &mut SimRng) -> BlinkenlightDesc {
    BlinkenlightDesc {
        period_ms: b.period.clamp(0, u32::MAX as i64) as u32,
        dutycycle: b.dutycycle,
    }
}

pub(crate) fn start(_: &BlinkenlightDesc, _: &Pose, _: &mut SimRng) -> Blinkenlight {
    Blinkenlight { on: false }
}

impl ModelKind for Blinkenlight {
    fn starts_itself(&self) -> bool {
        true
    }

    #[inline]
    fn update(&mut self, _: &View, _: ModelId, _: &Pose, _: &Node, _: &mut SimRng) {
        self.on = !self.on;
    }

    fn digest(&self, d: &mut Digest) {
        d.u64(self.on as u64);
    }
}
