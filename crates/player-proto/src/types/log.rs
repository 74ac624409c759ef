//! The `log` interface (45): start, stop, rewind and rename the recording of a `writelog`
//! device or the replay of a `readlog` device (Player's `045_log.def`; libplayerc's log proxy
//! and `playervcr` send these).

use crate::xdr::Text;

/// `PLAYER_LOG_TYPE_READ`: the device replays a log (`readlog`).
pub const PLAYER_LOG_TYPE_READ: u8 = 1;
/// `PLAYER_LOG_TYPE_WRITE`: the device records a log (`writelog`).
pub const PLAYER_LOG_TYPE_WRITE: u8 = 2;
/// Capacity of the file name of SET_FILENAME (255 characters and the NUL).
pub const PLAYER_LOG_FILENAME_MAX: usize = 256;

xdr_struct! {
    /// Starts (non-zero) or stops (zero) recording (REQ SET_WRITE_STATE; empty ACK).
    pub struct LogSetWriteState = "player_log_set_write_state_t" {
        /// 0 = stop, otherwise start.
        state: u8,
    }

    /// Starts (non-zero) or stops (zero) replay (REQ SET_READ_STATE; empty ACK).
    pub struct LogSetReadState = "player_log_set_read_state_t" {
        /// 0 = stop, otherwise start.
        state: u8,
    }

    /// What the device is and whether it runs (the ACK of GET_STATE; the request is empty).
    pub struct LogGetState = "player_log_get_state_t" {
        /// [`PLAYER_LOG_TYPE_READ`] or [`PLAYER_LOG_TYPE_WRITE`].
        log_type ("type"): u8,
        /// 0 = stopped, 1 = recording or replaying.
        state: u8,
    }

    /// The file a `writelog` device records to from now on (REQ SET_FILENAME; empty ACK).
    pub struct LogSetFilename = "player_log_set_filename_t" {
        /// The name; libplayerc counts the terminating NUL.
        filename: Text [max PLAYER_LOG_FILENAME_MAX],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::message::{Body, LogReq};
    use crate::xdr::Xdr;

    /// Bytes as Player 3.0.2's generated `xdr_player_log_*` functions write them: every field
    /// widened to 4 bytes big-endian, the file name's count written by the struct and again by
    /// `xdr_bytes`, its bytes padded to 4.
    #[test]
    fn bodies_match_the_generated_xdr() {
        let mut out = Vec::new();
        LogSetWriteState { state: 1 }.encode(&mut out).unwrap();
        assert_eq!(out, [0, 0, 0, 1]);
        let mut out = Vec::new();
        LogGetState {
            log_type: PLAYER_LOG_TYPE_READ,
            state: 0,
        }
        .encode(&mut out)
        .unwrap();
        assert_eq!(out, [0, 0, 0, 1, 0, 0, 0, 0]);
        let mut out = Vec::new();
        LogSetFilename {
            filename: Text::new("a.log"),
        }
        .encode(&mut out)
        .unwrap();
        assert_eq!(
            out,
            [
                0, 0, 0, 6, 0, 0, 0, 6, b'a', b'.', b'l', b'o', b'g', 0, 0, 0
            ]
        );
        let decoded = LogSetFilename::decode(&mut crate::xdr::Reader::new(&out)).unwrap();
        assert_eq!(decoded.filename.to_str_lossy(), "a.log");
    }

    #[test]
    fn the_table_knows_every_log_request() {
        let rows: Vec<_> = crate::message::message_rows()
            .into_iter()
            .filter(|r| r.interface == crate::InterfaceCode::LOG)
            .map(|r| (r.subtype, r.constant, r.body))
            .collect();
        assert_eq!(
            rows,
            vec![
                (
                    1,
                    "PLAYER_LOG_REQ_SET_WRITE_STATE",
                    Some("player_log_set_write_state_t")
                ),
                (
                    2,
                    "PLAYER_LOG_REQ_SET_READ_STATE",
                    Some("player_log_set_read_state_t")
                ),
                (
                    3,
                    "PLAYER_LOG_REQ_GET_STATE",
                    Some("player_log_get_state_t")
                ),
                (4, "PLAYER_LOG_REQ_SET_READ_REWIND", None),
                (
                    5,
                    "PLAYER_LOG_REQ_SET_FILENAME",
                    Some("player_log_set_filename_t")
                ),
            ]
        );
        let body: Body = LogReq::SetReadRewind.into();
        assert_eq!(body.subtype(), 4);
    }

    #[test]
    fn a_file_name_longer_than_upstream_allows_is_refused() {
        let long = LogSetFilename {
            filename: Text::new(&"x".repeat(PLAYER_LOG_FILENAME_MAX)),
        };
        assert!(long.encode(&mut Vec::new()).is_err());
    }
}
