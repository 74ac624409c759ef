//! The `speech` interface (12).

use crate::xdr::Text;

xdr_struct! {
    /// Text to say (CMD SAY).
    pub struct SpeechCmdSay = "player_speech_cmd_t" {
        /// The text, NUL counted.
        string: Text,
    }
}
