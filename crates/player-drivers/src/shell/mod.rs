//! Player's `server/drivers/shell/`: drivers that move messages around rather than talk to
//! hardware.

pub mod passthrough;
pub mod relay;
