//! Player's `server/drivers/blackboard/`: stores of entries that clients share through the
//! `blackboard` interface.

pub mod localbb;
