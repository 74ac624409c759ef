//! `localbb` (Player 3.0.2 `server/drivers/blackboard/localbb/localbb.cpp`): a blackboard kept
//! in the server's memory. Clients set entries (a key within a group, with bytes and a type the
//! setter chooses) and subscribe to keys or to whole groups; every entry set is sent, as
//! `blackboard` DATA UPDATE, to each client listening to its key or its group.
//!
//! What each request does, as upstream:
//! * SUBSCRIBE_TO_KEY: the client listens to (group, key); the ACK carries the entry stored
//!   there (an empty one, named by the request's key and group, if none was set);
//! * UNSUBSCRIBE_FROM_KEY / UNSUBSCRIBE_FROM_GROUP: one such listening ends; empty ACK;
//! * SET_ENTRY: stores the entry, sends it as an UPDATE to each listener of its key, then to
//!   each listener of its group, then answers the setter with an empty ACK;
//! * SUBSCRIBE_TO_GROUP: the client listens to the group; each entry of the group (by key,
//!   in byte order) is sent to it as an UPDATE, then an empty ACK;
//! * GET_ENTRY: the ACK carries the stored entry, without listening.
//!
//! Upstream's quirks are kept, since clients written against it see them: subscribing twice
//! means two UPDATEs per set; a setter listening to its own key hears its set; asking for an
//! entry never set (GET_ENTRY or SUBSCRIBE_TO_KEY) stores an empty one, which a later group
//! subscription then lists; GET_ENTRY of an entry never set answers with empty key and group.
//! A client's listening ends when its subscription to the device ends (or it disconnects).
//! Requests without an entry are refused (NACK), as upstream refuses an empty body.
//!
//! Two differences: the ACK of a request reaches the client before the UPDATEs the request
//! caused (upstream queues the UPDATEs first; libplayerc handles either order), and a request
//! from another driver (not a client) is answered but cannot listen, since the server
//! addresses DATA to one client only.

use std::collections::BTreeMap;

use player_proto::{
    BlackboardData, BlackboardEntry, BlackboardMsg, BlackboardReq, Body, DeviceAddr, InterfaceCode,
    Message, Text,
};
use player_server::{ClientId, Context, Driver, DriverBlock, DriverError, Reply};

/// The name cfg files use.
pub const NAME: &str = "localbb";

/// A key or group as upstream compares them: the bytes up to the first NUL (C strings).
type Name = Vec<u8>;

fn name_of(text: &Text) -> Name {
    let bytes = text.as_bytes();
    let end = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
    bytes[..end].to_vec()
}

/// A name as the driver sends it: its bytes and a NUL (upstream's `strlen + 1`).
fn text_of(name: &[u8]) -> Text {
    let mut bytes = name.to_vec();
    bytes.push(0);
    Text::from_bytes(bytes)
}

/// One stored entry, as upstream keeps it (key and group as C strings).
#[derive(Clone, Debug, Default, PartialEq)]
struct Stored {
    key: Name,
    group: Name,
    kind: u16,
    subtype: u16,
    data: Vec<u8>,
    timestamp_sec: u32,
    timestamp_usec: u32,
}

impl Stored {
    fn from_entry(e: &BlackboardEntry) -> Stored {
        Stored {
            key: name_of(&e.key),
            group: name_of(&e.group),
            kind: e.kind,
            subtype: e.subtype,
            data: e.data.clone(),
            timestamp_sec: e.timestamp_sec,
            timestamp_usec: e.timestamp_usec,
        }
    }

    fn to_entry(&self) -> BlackboardEntry {
        BlackboardEntry {
            key: text_of(&self.key),
            group: text_of(&self.group),
            kind: self.kind,
            subtype: self.subtype,
            data: self.data.clone(),
            timestamp_sec: self.timestamp_sec,
            timestamp_usec: self.timestamp_usec,
        }
    }
}

/// The driver: one `blackboard` device and what is stored on it.
#[derive(Debug)]
pub struct LocalBb {
    addr: DeviceAddr,
    /// group -> key -> entry.
    entries: BTreeMap<Name, BTreeMap<Name, Stored>>,
    /// (group, key) -> the clients listening, once per subscription.
    key_listeners: BTreeMap<(Name, Name), Vec<ClientId>>,
    /// group -> the clients listening to the whole group, once per subscription.
    group_listeners: BTreeMap<Name, Vec<ClientId>>,
}

impl LocalBb {
    /// Builds the driver from its cfg block: it provides one `blackboard` device and takes no
    /// options.
    pub fn from_block(block: &DriverBlock) -> Result<LocalBb, DriverError> {
        Ok(LocalBb {
            addr: block.provided(InterfaceCode::BLACKBOARD)?,
            entries: BTreeMap::new(),
            key_listeners: BTreeMap::new(),
            group_listeners: BTreeMap::new(),
        })
    }

    /// The stored entry at (group, key), made (empty) if there is none, as upstream's map
    /// lookup does.
    fn stored(&mut self, group: &[u8], key: &[u8]) -> &mut Stored {
        self.entries
            .entry(group.to_vec())
            .or_default()
            .entry(key.to_vec())
            .or_default()
    }

    fn subscribe_key(&mut self, client: Option<ClientId>, req: &BlackboardEntry) -> Reply {
        let (key, group) = (name_of(&req.key), name_of(&req.group));
        listen(client, self.key_listeners_of(&group, &key));
        let mut entry = self.stored(&group, &key).clone();
        if entry.key.is_empty() {
            entry.key = key;
        }
        entry.group = group;
        Reply::ack(BlackboardReq::SubscribeToKey(Some(entry.to_entry())))
    }

    fn key_listeners_of(&mut self, group: &[u8], key: &[u8]) -> &mut Vec<ClientId> {
        self.key_listeners
            .entry((group.to_vec(), key.to_vec()))
            .or_default()
    }

    fn set_entry(&mut self, ctx: &mut Context<'_>, req: &BlackboardEntry) -> Reply {
        let stored = Stored::from_entry(req);
        let (key, group) = (stored.key.clone(), stored.group.clone());
        *self.stored(&group, &key) = stored;
        let to_key = self
            .key_listeners
            .get(&(group.clone(), key))
            .into_iter()
            .flatten();
        let to_group = self.group_listeners.get(&group).into_iter().flatten();
        for &client in to_key.chain(to_group) {
            // The entry as the setter sent it, as upstream republishes the request's bytes.
            ctx.publish_to(self.addr, client, BlackboardData::Update(req.clone()));
        }
        Reply::empty_ack()
    }

    fn subscribe_group(
        &mut self,
        ctx: &mut Context<'_>,
        client: Option<ClientId>,
        req: &BlackboardEntry,
    ) -> Reply {
        let group = name_of(&req.group);
        let mut list = self.group_listeners.remove(&group).unwrap_or_default();
        listen(client, &mut list);
        self.group_listeners.insert(group.clone(), list);
        let Some(client) = client else {
            return Reply::empty_ack();
        };
        let entries = self.entries.entry(group.clone()).or_default();
        for (key, stored) in entries.iter() {
            let mut entry = stored.clone();
            if entry.key.is_empty() {
                entry.key = key.clone();
            }
            if entry.group.is_empty() {
                entry.group = group.clone();
            }
            ctx.publish_to(self.addr, client, BlackboardData::Update(entry.to_entry()));
        }
        Reply::empty_ack()
    }

    fn get_entry(&mut self, req: &BlackboardEntry) -> Reply {
        let (key, group) = (name_of(&req.key), name_of(&req.group));
        let entry = self.stored(&group, &key).to_entry();
        Reply::ack(BlackboardReq::GetEntry(Some(entry)))
    }
}

/// Adds a client's listening; a request from a driver has no client to send to.
fn listen(client: Option<ClientId>, list: &mut Vec<ClientId>) {
    match client {
        Some(c) => list.push(c),
        None => tracing::debug!("{NAME}: a driver's subscription cannot be sent updates"),
    }
}

/// Ends one listening of `client` in `list` (the first, as upstream).
fn unlisten(list: Option<&mut Vec<ClientId>>, client: Option<ClientId>) {
    if let (Some(list), Some(client)) = (list, client) {
        if let Some(i) = list.iter().position(|&c| c == client) {
            list.remove(i);
        }
    }
}

impl Driver for LocalBb {
    fn handle_request(&mut self, ctx: &mut Context<'_>, request: &Message) -> Reply {
        let Body::Blackboard(BlackboardMsg::Req(req)) = &request.body else {
            return Reply::NotHandled;
        };
        let client = ctx.client();
        match req {
            BlackboardReq::SubscribeToKey(Some(e)) => self.subscribe_key(client, e),
            BlackboardReq::UnsubscribeFromKey(Some(e)) => {
                let at = (name_of(&e.group), name_of(&e.key));
                unlisten(self.key_listeners.get_mut(&at), client);
                Reply::empty_ack()
            }
            BlackboardReq::SetEntry(Some(e)) => self.set_entry(ctx, e),
            BlackboardReq::SubscribeToGroup(Some(e)) => self.subscribe_group(ctx, client, e),
            BlackboardReq::UnsubscribeFromGroup(Some(e)) => {
                unlisten(self.group_listeners.get_mut(&name_of(&e.group)), client);
                Reply::empty_ack()
            }
            BlackboardReq::GetEntry(Some(e)) => self.get_entry(e),
            other => {
                tracing::warn!(
                    "{NAME}: {} without an entry; NACK",
                    Body::from(other.clone()).constant()
                );
                Reply::Nack
            }
        }
    }

    fn client_unsubscribed(&mut self, _addr: DeviceAddr, client: ClientId) {
        // Upstream's Unsubscribe drops every listening of the client's queue.
        for list in self
            .key_listeners
            .values_mut()
            .chain(self.group_listeners.values_mut())
        {
            list.retain(|&c| c != client);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{addr, block};
    use player_server::Publication;

    fn entry(group: &str, key: &str, data: &[u8]) -> BlackboardEntry {
        BlackboardEntry {
            key: Text::new(key),
            group: Text::new(group),
            kind: 1,
            subtype: 2,
            data: data.to_vec(),
            timestamp_sec: 3,
            timestamp_usec: 4,
        }
    }

    /// A board and the requests of numbered clients to it.
    struct Board(LocalBb);

    impl Board {
        fn new() -> Board {
            let b = block(NAME, &[addr(InterfaceCode::BLACKBOARD, 0)], &[], &[]);
            Board(LocalBb::from_block(&b).unwrap())
        }

        /// `client`'s request: the reply and what was published, to whom.
        fn ask(
            &mut self,
            client: Option<u64>,
            req: BlackboardReq,
        ) -> (Reply, Vec<(Option<u64>, BlackboardEntry)>) {
            let mut published: Vec<Publication> = Vec::new();
            let msg = Message::new(self.0.addr, 0.0, req);
            let reply = {
                let mut ctx = Context::new(0.0, client.map(ClientId), &mut published);
                self.0.handle_request(&mut ctx, &msg)
            };
            let sent = published
                .into_iter()
                .map(|p| match p.body {
                    Body::Blackboard(BlackboardMsg::Data(BlackboardData::Update(e))) => {
                        (p.to.map(|c| c.0), e)
                    }
                    other => panic!("published {other:?}"),
                })
                .collect();
            (reply, sent)
        }
    }

    fn empty(group: &str, key: &str) -> BlackboardEntry {
        BlackboardEntry {
            key: Text::new(key),
            group: Text::new(group),
            ..BlackboardEntry::default()
        }
    }

    #[test]
    fn keys_subscribed_hear_every_set_and_unsubscribing_stops_it() {
        let mut bb = Board::new();
        // Nothing set yet: the ACK names the key and group, with no data.
        let (reply, sent) = bb.ask(
            Some(1),
            BlackboardReq::SubscribeToKey(Some(empty("g", "k"))),
        );
        assert_eq!(
            reply,
            Reply::ack(BlackboardReq::SubscribeToKey(Some(empty("g", "k"))))
        );
        assert!(sent.is_empty());
        // Client 2 sets it: client 1 hears it, client 2 gets its ACK only.
        let e = entry("g", "k", &[9, 8, 7]);
        let (reply, sent) = bb.ask(Some(2), BlackboardReq::SetEntry(Some(e.clone())));
        assert_eq!(reply, Reply::empty_ack());
        assert_eq!(sent, [(Some(1), e.clone())]);
        // Another key, or the same key in another group, is not client 1's business.
        let (_, sent) = bb.ask(
            Some(2),
            BlackboardReq::SetEntry(Some(entry("g", "x", &[1]))),
        );
        assert!(sent.is_empty());
        let (_, sent) = bb.ask(
            Some(2),
            BlackboardReq::SetEntry(Some(entry("h", "k", &[1]))),
        );
        assert!(sent.is_empty());
        // A later subscriber gets the stored entry in its ACK.
        let (reply, _) = bb.ask(
            Some(3),
            BlackboardReq::SubscribeToKey(Some(empty("g", "k"))),
        );
        assert_eq!(
            reply,
            Reply::ack(BlackboardReq::SubscribeToKey(Some(e.clone())))
        );
        let (reply, _) = bb.ask(Some(3), BlackboardReq::GetEntry(Some(empty("g", "k"))));
        assert_eq!(reply, Reply::ack(BlackboardReq::GetEntry(Some(e.clone()))));
        // Unsubscribed: client 1 hears nothing more; client 3 still does.
        let (reply, _) = bb.ask(
            Some(1),
            BlackboardReq::UnsubscribeFromKey(Some(empty("g", "k"))),
        );
        assert_eq!(reply, Reply::empty_ack());
        let (_, sent) = bb.ask(Some(2), BlackboardReq::SetEntry(Some(e.clone())));
        assert_eq!(sent, [(Some(3), e.clone())]);
        // Ending its device subscription ends all of a client's listening.
        bb.0.client_unsubscribed(bb.0.addr, ClientId(3));
        let (_, sent) = bb.ask(Some(2), BlackboardReq::SetEntry(Some(e)));
        assert!(sent.is_empty());
    }

    #[test]
    fn groups_list_their_entries_then_hear_every_set() {
        let mut bb = Board::new();
        let (a, b) = (entry("g", "b", &[2]), entry("g", "a", &[1]));
        bb.ask(Some(1), BlackboardReq::SetEntry(Some(a.clone())));
        bb.ask(Some(1), BlackboardReq::SetEntry(Some(b.clone())));
        bb.ask(
            Some(1),
            BlackboardReq::SetEntry(Some(entry("other", "a", &[3]))),
        );
        // Asking for an entry never set stores an empty one (upstream's map lookup), which the
        // group lists by its key; GET_ENTRY answers it with empty names.
        let (reply, _) = bb.ask(Some(1), BlackboardReq::GetEntry(Some(empty("g", "c"))));
        assert_eq!(
            reply,
            Reply::ack(BlackboardReq::GetEntry(Some(empty("", ""))))
        );
        let (reply, sent) = bb.ask(
            Some(2),
            BlackboardReq::SubscribeToGroup(Some(empty("g", ""))),
        );
        assert_eq!(reply, Reply::empty_ack());
        assert_eq!(
            sent,
            [(Some(2), b), (Some(2), a), (Some(2), empty("g", "c"))],
            "by key, in byte order"
        );
        // A key listener and a group listener both hear a set; twice subscribed, twice heard.
        bb.ask(
            Some(3),
            BlackboardReq::SubscribeToKey(Some(empty("g", "z"))),
        );
        bb.ask(
            Some(3),
            BlackboardReq::SubscribeToKey(Some(empty("g", "z"))),
        );
        let z = entry("g", "z", &[]);
        let (_, sent) = bb.ask(Some(1), BlackboardReq::SetEntry(Some(z.clone())));
        assert_eq!(
            sent,
            [
                (Some(3), z.clone()),
                (Some(3), z.clone()),
                (Some(2), z.clone())
            ]
        );
        bb.ask(
            Some(2),
            BlackboardReq::UnsubscribeFromGroup(Some(empty("g", ""))),
        );
        bb.ask(
            Some(3),
            BlackboardReq::UnsubscribeFromKey(Some(empty("g", "z"))),
        );
        let (_, sent) = bb.ask(Some(1), BlackboardReq::SetEntry(Some(z.clone())));
        assert_eq!(sent, [(Some(3), z)]);
    }

    #[test]
    fn requests_without_an_entry_are_refused_and_drivers_cannot_listen() {
        let mut bb = Board::new();
        let (reply, _) = bb.ask(Some(1), BlackboardReq::SetEntry(None));
        assert_eq!(reply, Reply::Nack);
        let (reply, _) = bb.ask(None, BlackboardReq::SubscribeToKey(Some(empty("g", "k"))));
        assert!(matches!(reply, Reply::Ack(Some(_))));
        let (_, sent) = bb.ask(
            Some(1),
            BlackboardReq::SetEntry(Some(entry("g", "k", &[1]))),
        );
        assert!(sent.is_empty());
        let b = block(NAME, &[addr(InterfaceCode::OPAQUE, 0)], &[], &[]);
        assert!(LocalBb::from_block(&b).is_err());
    }
}
