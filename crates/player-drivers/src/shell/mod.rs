//! Player's `server/drivers/shell/`: drivers that move messages around rather than talk to
//! hardware.

pub mod logformat;
pub mod passthrough;
pub mod readlog;
pub mod relay;
pub mod writelog;

use player_proto::{LogGetState, LogReq};
use player_server::Reply;

/// A log device's SET_READ_STATE / SET_WRITE_STATE, as readlog and writelog both answer it:
/// `enabled` follows the request's `state`, logged as `what` (playback, logging) starting or
/// stopping.
fn switch_state(driver: &str, enabled: &mut bool, state: u8, what: &str) {
    *enabled = state != 0;
    tracing::info!(
        "{driver}: {} {what}",
        if *enabled { "start" } else { "stop" }
    );
}

/// A log device's GET_STATE answer: its `log_type` (read or write) and whether it is enabled.
fn state_reply(log_type: u8, enabled: bool) -> Reply {
    Reply::ack(LogReq::GetState(Some(LogGetState {
        log_type,
        state: u8::from(enabled),
    })))
}
