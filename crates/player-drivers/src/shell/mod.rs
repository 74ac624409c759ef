//! Player's `server/drivers/shell/`: drivers that move messages around rather than talk to
//! hardware.

pub mod logformat;
pub mod passthrough;
pub mod readlog;
pub mod relay;
pub mod writelog;
