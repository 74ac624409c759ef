//! `gripper`: a two-paddle gripper (stage-models.md §11). Its body is built from its paddle
//! properties, so the resolver reads them before the common ones
//! ([`crate::world::WorldSpec::load`]).

use serde::Serialize;

use super::TypeDefaults;
use crate::color::Rgba;
use crate::error::Error;
use crate::reader::Reader;
use crate::table::property_table;

/// The `gripper` defaults (its row of the type table): the body is the base and two paddles.
pub const DEFAULTS: TypeDefaults = TypeDefaults {
    body: super::DefaultBody::Gripper,
    ..TypeDefaults::new([0.2, 0.3, 0.2], Rgba::rgb(0.3, 0.3, 0.3))
};

/// Gripper paddle states.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Paddles {
    /// Open (position 0).
    Open,
    /// Closed (position 1).
    Closed,
}

/// Gripper lift states.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Lift {
    /// Down (position 0).
    Down,
    /// Up (position 1).
    Up,
}

/// Initial paddle and lift state (`paddle_state [ "open" "down" ]`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct PaddleState {
    /// Paddles.
    pub paddles: Paddles,
    /// Lift.
    pub lift: Lift,
}

impl Default for PaddleState {
    fn default() -> Self {
        PaddleState {
            paddles: Paddles::Open,
            lift: Lift::Down,
        }
    }
}

property_table! {
    /// A `gripper` (stage-models.md §11.1).
    pub struct GripperSpec {
        /// Paddle length, width, height as fractions of the gripper size (converted as lengths,
        /// a Stage quirk that only matters with `unit_length` other than metres).
        paddle_size: [f64; 3] = [0.66, 0.1, 0.4], floats::<3>("paddle_size", "lll");
        /// Initial paddle and lift state.
        paddle_state: PaddleState = PaddleState::default(), paddle_state("paddle_state");
        /// The break beams drive the paddles.
        autosnatch: bool = false, flag("autosnatch");
    }
}

/// Reads a gripper's properties.
pub(crate) fn read(r: &mut Reader<'_, '_>) -> Result<GripperSpec, Error> {
    GripperSpec::read(r)
}

impl Reader<'_, '_> {
    /// Gripper `paddle_state [ "open"|"closed" "up"|"down" ]`.
    pub(crate) fn paddle_state(&mut self, name: &str) -> Result<Option<PaddleState>, Error> {
        let Some([paddles, lift]) = self.string_tuple::<2>(name)? else {
            return Ok(None);
        };
        let mut state = PaddleState::default();
        match paddles.as_str() {
            "open" => state.paddles = Paddles::Open,
            "closed" => state.paddles = Paddles::Closed,
            other => self.warn(format!(
                "gripper paddle state \"{other}\" is not \"open\" or \"closed\"; ignored as in Stage"
            )),
        }
        match lift.as_str() {
            "down" => state.lift = Lift::Down,
            "up" => state.lift = Lift::Up,
            other => self.warn(format!(
                "gripper lift state \"{other}\" is not \"up\" or \"down\"; ignored as in Stage"
            )),
        }
        Ok(Some(state))
    }
}
