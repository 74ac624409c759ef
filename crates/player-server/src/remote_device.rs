//! A device of another Player server, served in this one's device table so that drivers can
//! require it like any local device (upstream's `TCPRemoteDriver`, which Player creates for a
//! `requires` naming a host or port it does not serve).
//!
//! The link ([`RemoteLink`]) is opened by the first subscription and closed by the last, so a
//! cfg that names a server which is not up yet still starts: its data simply begins when that
//! server answers. A link that fails or breaks while the device is subscribed (the remote
//! server is not up yet, was killed or restarted) is logged once, naming the remote device and
//! where it is required, and opened again after a pause that grows from [`RETRY_FIRST`] to
//! [`RETRY_MAX`]; meanwhile requests are NACKed at once and commands dropped, and data resumes
//! when the remote server is back. Upstream's `TCPRemoteDriver` stays down until the last
//! subscription ends and a new one reconnects; a client re-subscribing recovers here too.
//!
//! Everything crossing the network happens on the link's task; the core only drains what
//! arrived when the link wakes it, so a slow or silent peer never stalls the server.
//! Requests are deferred until the remote reply (or the link's 5 s timeout, answered NACK).

use std::collections::{HashMap, VecDeque};
use std::net::Ipv4Addr;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use player_proto::constants::PLAYER_OPEN_MODE;
use player_proto::{Body, DeviceAddr, MapMsg, MapReq, Message};

use crate::driver::{Context, Driver, DriverError, PendingReply, Reply, RequiredDevice};
use crate::remote::{RemoteEvent, RemoteLink, RequestTicket};

/// What the link reported and the core has not handled yet.
type Inbox = Arc<Mutex<VecDeque<RemoteEvent>>>;

/// The pause before the first new attempt after a link failed or broke: short, so a restarted
/// remote server is found again at once.
pub const RETRY_FIRST: Duration = Duration::from_millis(100);

/// The longest pause between attempts (each failed attempt doubles the pause up to it): a
/// remote server that stays down costs one connection attempt, and one log line, this often.
pub const RETRY_MAX: Duration = Duration::from_secs(2);

/// The driver of one remote device.
#[derive(Debug)]
pub struct RemoteDevice {
    /// The device's address in this server's table (the remote host and port).
    addr: DeviceAddr,
    /// Where it was required first (`file:line`), for log lines.
    origin: String,
    link: Option<(RemoteLink, Inbox)>,
    waiting: HashMap<RequestTicket, PendingReply>,
    /// While subscribed without a working link: when to try again, and the pause after that.
    retry: Option<(Instant, Duration)>,
    /// The link was up before it broke (the next `Connected` is a recovery).
    was_up: bool,
}

impl RemoteDevice {
    /// The driver for the device a `requires` entry names.
    pub fn new(required: &RequiredDevice) -> RemoteDevice {
        RemoteDevice {
            addr: required.addr,
            origin: required.origin.clone(),
            link: None,
            waiting: HashMap::new(),
            retry: None,
            was_up: false,
        }
    }

    /// The host to connect to: the packed address, as upstream packs it.
    fn host(&self) -> String {
        Ipv4Addr::from(self.addr.host.to_le_bytes()).to_string()
    }

    /// Answers every request still waiting for the link with a NACK.
    fn refuse_waiting(&mut self, ctx: &mut Context<'_>) {
        for (_, pending) in self.waiting.drain() {
            ctx.answer(pending, Reply::Nack);
        }
    }

    /// Opens a link to the remote device; its events wake this driver.
    fn connect(&mut self, ctx: &mut Context<'_>) -> Result<(), DriverError> {
        let waker = ctx
            .waker()
            .ok_or_else(|| DriverError::new("a remote device needs a running server"))?;
        let handle = tokio::runtime::Handle::try_current()
            .map_err(|_| DriverError::new("a remote device needs the server's runtime"))?;
        let port = u16::try_from(self.addr.robot)
            .map_err(|_| DriverError::new(format!("{} is not a TCP port", self.addr.robot)))?;
        let inbox: Inbox = Arc::default();
        let sink = {
            let inbox = inbox.clone();
            move |event: RemoteEvent| {
                inbox
                    .lock()
                    .unwrap_or_else(|p| p.into_inner())
                    .push_back(event);
                waker.wake();
            }
        };
        let link = RemoteLink::spawn(
            &handle,
            self.host(),
            port,
            self.addr,
            PLAYER_OPEN_MODE,
            sink,
        );
        self.link = Some((link, inbox));
        Ok(())
    }

    /// The link failed or broke (`why` names the device and the peer): requests waiting are
    /// NACKed, and a new link is tried after the current pause.
    fn lost(&mut self, ctx: &mut Context<'_>, why: &str) {
        self.link = None;
        self.refuse_waiting(ctx);
        let pause = match self.retry {
            Some((_, pause)) => pause,
            None => RETRY_FIRST,
        };
        if self.retry.is_none() {
            tracing::warn!(
                "{why} (required at {}); requests to it are refused until it is back, trying \
                 again every {RETRY_MAX:?} at most",
                self.origin
            );
        } else {
            tracing::debug!(
                "{why} (required at {}); trying again in {pause:?}",
                self.origin
            );
        }
        self.retry = Some((Instant::now() + pause, (pause * 2).min(RETRY_MAX)));
    }
}

impl Driver for RemoteDevice {
    fn setup(&mut self, ctx: &mut Context<'_>) -> Result<(), DriverError> {
        tracing::info!(
            "connecting to remote device {} (required at {})",
            self.addr,
            self.origin
        );
        self.retry = None;
        self.was_up = false;
        self.connect(ctx)
    }

    fn update(&mut self, ctx: &mut Context<'_>) {
        if let Some((at, _)) = self.retry
            && self.link.is_none()
            && Instant::now() >= at
            && let Err(e) = self.connect(ctx)
        {
            tracing::error!("remote device {}: {e}", self.addr);
        }
    }

    fn teardown(&mut self, ctx: &mut Context<'_>) {
        // Dropping the link closes it; what it still reports goes to an inbox nobody reads.
        self.link = None;
        self.retry = None;
        self.refuse_waiting(ctx);
    }

    fn wake(&mut self, ctx: &mut Context<'_>) {
        let Some((_, inbox)) = &self.link else {
            return;
        };
        let events: Vec<RemoteEvent> = inbox
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .drain(..)
            .collect();
        for event in events {
            match event {
                RemoteEvent::Data(msg) => {
                    ctx.publish_at(self.addr, msg.body, msg.header.timestamp);
                }
                RemoteEvent::Reply { ticket, result } => {
                    let Some(pending) = self.waiting.remove(&ticket) else {
                        continue;
                    };
                    let reply = match result.map(unzip_map_tile) {
                        Ok(Some(ack)) => Reply::Ack(ack.body.has_body().then_some(ack.body)),
                        Ok(None) => {
                            tracing::warn!(
                                "remote device {}: a map tile whose cells do not inflate; NACK",
                                self.addr
                            );
                            Reply::Nack
                        }
                        Err(e) => {
                            tracing::warn!("{e}");
                            Reply::Nack
                        }
                    };
                    ctx.answer(pending, reply);
                }
                RemoteEvent::Connected { driver_name } => {
                    if self.retry.take().is_some() && self.was_up {
                        tracing::warn!(
                            "remote device {} is back (driver \"{driver_name}\")",
                            self.addr
                        );
                    } else {
                        tracing::info!(
                            "remote device {} is up (driver \"{driver_name}\")",
                            self.addr
                        );
                    }
                    self.was_up = true;
                }
                RemoteEvent::Failed(why) | RemoteEvent::Closed(why) => {
                    self.lost(ctx, &why);
                    // What this link still reported is of no use any more.
                    break;
                }
            }
        }
    }

    fn handle_request(&mut self, ctx: &mut Context<'_>, request: &Message) -> Reply {
        let Some((link, _)) = &self.link else {
            return Reply::Nack;
        };
        let Some(pending) = ctx.defer() else {
            return Reply::NotHandled;
        };
        let ticket = link.request(request.body.clone());
        self.waiting.insert(ticket, pending);
        Reply::Deferred
    }

    fn handle_command(&mut self, _ctx: &mut Context<'_>, command: &Message) {
        if let Some((link, _)) = &self.link {
            link.command(command.body.clone());
        }
    }
}

/// A map GET_DATA ACK read from TCP carries its cells zlib-compressed (Player's TCP layer
/// compresses them): inside this server cells are raw, so they are inflated here (and
/// compressed again on their way to a TCP client). Anything else passes unchanged; `None` is a
/// tile that does not inflate.
fn unzip_map_tile(ack: Message) -> Option<Message> {
    match &ack.body {
        Body::Map(MapMsg::Ack(MapReq::GetData(Some(tile)))) => {
            let body = Body::Map(MapMsg::Ack(MapReq::GetData(Some(tile.unzipped()?))));
            Some(Message { body, ..ack })
        }
        _ => Some(ack),
    }
}
