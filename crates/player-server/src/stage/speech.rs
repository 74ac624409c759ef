//! `speech` on any model: CMD_SAY sets the model's speech bubble text (player-protocol.md
//! §6.10). No data, no requests.

use player_proto::{Body, SpeechCmd, SpeechMsg};

use super::{Interface, Sender, Writing};

/// A `speech` device.
#[derive(Debug, Default)]
pub(super) struct Speech;

impl Interface for Speech {
    /// SAY: the text without its terminating NUL.
    fn command(&mut self, b: &mut Writing<'_>, _sender: &Sender<'_>, body: &Body) -> bool {
        let Body::Speech(SpeechMsg::Cmd(SpeechCmd::Say(say))) = body else {
            return false;
        };
        let said = b.world.say(b.model, &say.string.to_str_lossy());
        b.answer(said).is_some()
    }
}
