//! Player's `server/drivers/laser/` drivers that are not hardware: `laserposeinterpolator`.

pub mod laserposeinterpolator;
