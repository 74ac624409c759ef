//! What a controller reads: the sensor data of the step's updates, and nothing that the step's
//! moves change. Because a controller can see no more than this, the controllers of a step
//! can run while the moves are installed (`World::step`), on the other core.

use super::{ModelId, ModelState};
use crate::error::{Error, Result};
use crate::models::KindState;
use crate::models::fiducial::FiducialData;
use crate::models::ranger::RangerData;

/// Read access to the models' sensor data, as the step's updates left it (phase 1).
///
/// Poses, bodies and odometry are left out on purpose: the moves of phase 2 change them, and
/// a controller that read them could no longer run beside those moves. Every call checks its
/// id as the world's own queries do: a foreign id or a model of another type is an error.
#[derive(Clone, Copy)]
pub struct Sensors<'a> {
    states: &'a [ModelState],
}

impl<'a> Sensors<'a> {
    pub(super) fn new(states: &'a [ModelState]) -> Sensors<'a> {
        Sensors { states }
    }

    /// The type state of model `m`, or the error for an id the world does not hold.
    fn kind(&self, m: ModelId) -> Result<&'a KindState> {
        self.states
            .get(m.index())
            .map(|s| &s.kind)
            .ok_or(Error::ForeignModel {
                id: m,
                models: self.states.len(),
            })
    }

    /// The error for model `m` of the wrong type (`found`: the type it is simulated as).
    fn wrong_type(&self, m: ModelId, expected: &'static str) -> Error {
        Error::BadModel {
            id: m,
            found: self.states[m.index()].kind.model_type(),
            expected,
        }
    }

    /// A ranger's latest scans ([`World::ranger_scans`](super::World::ranger_scans)).
    pub fn ranger_scans(&self, m: ModelId) -> Result<&'a RangerData> {
        typed!(self.kind(m), "a ranger", KindState::Ranger(r) => r)
    }

    /// A fiducial finder's latest detections ([`World::fiducials`](super::World::fiducials)).
    pub fn fiducials(&self, m: ModelId) -> Result<&'a FiducialData> {
        typed!(self.kind(m), "a fiducial finder", KindState::Fiducial(f) => &f.data)
    }
}
