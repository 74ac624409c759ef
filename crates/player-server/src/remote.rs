//! A client link to one device on another Player server, for drivers whose required devices live
//! elsewhere (upstream's `TCPRemoteDriver`, which the `passthrough` driver reaches through the
//! device table for `requires [":host:port:interface:index"]`).
//!
//! [`RemoteLink::spawn`] starts one task that connects, reads the 32-byte banner, switches the
//! connection to PUSH mode, subscribes with `PLAYER_PLAYER_REQ_DEV` and then forwards everything
//! the device publishes. The owner talks to it from synchronous code: [`RemoteLink::command`] and
//! [`RemoteLink::request`] only queue (bounded) and wake the task; what comes back is delivered
//! as [`RemoteEvent`]s to the [`EventSink`] given at spawn time, from the link's task.
//!
//! Upstream facts this follows (server/libplayertcp/remote_driver.cc, remote_driver.h):
//! * the DEV request is addressed to the player interface (header address all zero but the
//!   interface code), carries the full remote address in its body, and the reply must be a
//!   RESP_ACK whose granted `access` equals the mode asked for, else the setup fails;
//! * unsubscribing (`PLAYER_CLOSE_MODE`) is a courtesy: the reply is not waited for;
//! * requests are forwarded one at a time: the next message is not taken until the reply to the
//!   outstanding request (matched by interface, index and subtype) has arrived, so messages
//!   reach the remote device in the order they were issued;
//! * the remote connection is a plain PUSH-mode connection (the server default); nothing is
//!   replaced or dropped by replace rules, every DATA message is forwarded.
//!
//! Where upstream waits without bound (the TCP connect, a request's reply) this link uses
//! [`LinkTimeouts`] (5 s each by default, libplayerc's request timeout), so a silent peer ends in
//! a timed-out reply or a `Failed` event, never a hang.

use std::collections::VecDeque;
use std::fmt;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use player_proto::constants::{
    PLAYER_CLOSE_MODE, PLAYER_DATAMODE_PUSH, PLAYER_IDENT_STRLEN, PLAYER_MSGQUEUE_DEFAULT_MAXLEN,
};
use player_proto::{
    Body, DecodeLimits, DeviceAddr, DeviceDatamodeReq, DeviceReq, Error as ProtoError, Frame,
    Framer, InterfaceCode, Message, MsgType, PlayerMsg, PlayerReq, Text, banner_text,
};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;
use tokio::sync::{Notify, mpsc};
use tokio::time::{Instant, sleep_until, timeout, timeout_at};

use crate::clock::wall_seconds;

/// Commands and requests waiting to be written, at most (upstream's per-queue bound,
/// `PLAYER_MSGQUEUE_DEFAULT_MAXLEN`). Beyond it commands are dropped and requests refused, so a
/// remote server that stops reading costs bounded memory.
pub const OUTBOX_LIMIT: usize = PLAYER_MSGQUEUE_DEFAULT_MAXLEN;

/// The start of every Player banner (`PLAYER_IDENT_STRING`); anything else is not a Player
/// server.
const IDENT_PREFIX: &str = "Player v.";

/// Size of one socket read.
const READ_CHUNK: usize = 16 * 1024;

/// How long each step may take.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LinkTimeouts {
    /// Each step of the set-up (name lookup and connect, the banner, the DATAMODE and DEV
    /// replies), each write, and the wait for the server to close after unsubscribing.
    /// Upstream allows 1 s for the banner and DEV reply (`DEFAULT_SETUP_TIMEOUT`) and none for
    /// the connect; 5 s tolerates slow links.
    pub setup: Duration,
    /// The reply to one request (libplayerc's default request timeout).
    pub request: Duration,
}

impl Default for LinkTimeouts {
    fn default() -> Self {
        LinkTimeouts {
            setup: Duration::from_secs(5),
            request: Duration::from_secs(5),
        }
    }
}

/// Names one request sent through a link; its [`RemoteEvent::Reply`] carries the same ticket.
/// Unique within the link that issued it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct RequestTicket(pub u64);

impl fmt::Display for RequestTicket {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "request #{}", self.0)
    }
}

/// Why a request got no ACK.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum RemoteError {
    /// The remote device answered RESP_NACK.
    #[error("remote {link}: {request} was refused (NACK)")]
    Nack {
        /// The link (`interface:index at host:port`).
        link: String,
        /// The request's C constant.
        request: &'static str,
    },
    /// No reply within [`LinkTimeouts::request`].
    #[error("remote {link}: no reply to {request} within {after:?}")]
    Timeout {
        /// The link.
        link: String,
        /// The request's C constant.
        request: &'static str,
        /// The timeout.
        after: Duration,
    },
    /// The ACK's body could not be decoded.
    #[error("remote {link}: bad reply to {request}: {reason}")]
    BadReply {
        /// The link.
        link: String,
        /// The request's C constant.
        request: &'static str,
        /// The decoding error.
        reason: String,
    },
    /// The request was never sent: not a request for this device's interface, not encodable,
    /// the queue is full, or the link has ended.
    #[error("remote {link}: {request} not sent: {reason}")]
    NotSent {
        /// The link.
        link: String,
        /// The request's C constant.
        request: &'static str,
        /// Why.
        reason: String,
    },
    /// The link ended (closed, failed or lost) before the reply arrived.
    #[error("remote {link}: no reply to {request}: {reason}")]
    LinkEnded {
        /// The link.
        link: String,
        /// The request's C constant.
        request: &'static str,
        /// How the link ended.
        reason: String,
    },
}

/// What a link reports. `Failed` or `Closed` is the link's last event, except for replies to
/// requests made after it ended, which are refused at once.
// Data messages are nearly every event; boxing them would cost an allocation each.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq)]
pub enum RemoteEvent {
    /// Subscribed: the remote server granted the access asked for. Data follows.
    Connected {
        /// The remote device's driver, as its DEV reply names it.
        driver_name: String,
    },
    /// A DATA message of the device. Its header carries the remote address the link was
    /// spawned with (the owner relabels it) and the remote timestamp, subtype and seq.
    Data(Message),
    /// The outcome of [`RemoteLink::request`]: the RESP_ACK (header relabelled as for data;
    /// its body is the reply kind, e.g. `Position2dMsg::Ack(..)`), or why there is none.
    Reply {
        /// The ticket `request` returned.
        ticket: RequestTicket,
        /// The ACK, or the NACK / timeout / failure.
        result: Result<Message, RemoteError>,
    },
    /// The link could not be set up (connect, banner, data mode or subscription). The text
    /// names the device and the peer `host:port`.
    Failed(String),
    /// The link was up, or being closed on request, and has ended (peer closed, malformed
    /// stream, write stalled, or [`RemoteLink::close`]). The text names the device and peer.
    Closed(String),
}

/// Receives a link's events. Called from the link's task (and, for requests refused at once,
/// from the thread calling [`RemoteLink::request`]), so it must not block: forward into a
/// channel. Implemented for closures and for an unbounded tokio sender.
pub trait EventSink: Send + Sync + 'static {
    /// Takes one event.
    fn deliver(&self, event: RemoteEvent);
}

impl<F> EventSink for F
where
    F: Fn(RemoteEvent) + Send + Sync + 'static,
{
    fn deliver(&self, event: RemoteEvent) {
        self(event)
    }
}

impl EventSink for mpsc::UnboundedSender<RemoteEvent> {
    fn deliver(&self, event: RemoteEvent) {
        // A receiver that is gone wants nothing more.
        let _ = self.send(event);
    }
}

/// What the owner queued for the remote device, already encoded.
#[derive(Debug)]
struct Outgoing {
    bytes: Vec<u8>,
    /// `Some` for a request: what its reply must match.
    request: Option<Pending>,
}

#[derive(Clone, Copy, Debug)]
struct Pending {
    ticket: RequestTicket,
    subtype: u8,
    what: &'static str,
}

#[derive(Debug, Default)]
struct Outbox {
    queue: VecDeque<Outgoing>,
    /// `close` was called (or the link dropped).
    closing: bool,
    /// The task has ended or is ending: nothing more will be sent.
    finished: bool,
    /// Commands dropped because the queue was full, since the last warning.
    dropped: u64,
}

/// State shared by the handle and the task.
struct Shared {
    /// The remote device (host and robot = the remote server and port).
    device: DeviceAddr,
    /// `interface:index at host:port`, for every message.
    label: String,
    outbox: Mutex<Outbox>,
    /// Wakes the task after something was queued or `close` was called.
    wake: Notify,
    next_ticket: AtomicU64,
    sink: Box<dyn EventSink>,
}

impl Shared {
    fn outbox(&self) -> MutexGuard<'_, Outbox> {
        self.outbox.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn is_closing(&self) -> bool {
        self.outbox().closing
    }

    fn refuse(&self, pending: Pending, reason: impl Into<String>) {
        self.sink.deliver(RemoteEvent::Reply {
            ticket: pending.ticket,
            result: Err(RemoteError::NotSent {
                link: self.label.clone(),
                request: pending.what,
                reason: reason.into(),
            }),
        });
    }

    /// Marks the link finished and answers every request still waiting with `reason`.
    fn finish(&self, inflight: Option<Pending>, reason: &str) -> Vec<Outgoing> {
        let queued: Vec<Outgoing> = {
            let mut out = self.outbox();
            out.finished = true;
            out.queue.drain(..).collect()
        };
        let waiting = inflight
            .into_iter()
            .chain(queued.iter().filter_map(|o| o.request));
        for pending in waiting {
            self.sink.deliver(RemoteEvent::Reply {
                ticket: pending.ticket,
                result: Err(RemoteError::LinkEnded {
                    link: self.label.clone(),
                    request: pending.what,
                    reason: reason.to_string(),
                }),
            });
        }
        queued
    }
}

/// A link to one device on a remote Player server. Dropping it closes the link.
pub struct RemoteLink {
    shared: Arc<Shared>,
}

impl fmt::Debug for RemoteLink {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("RemoteLink")
            .field("link", &self.shared.label)
            .finish()
    }
}

impl RemoteLink {
    /// Starts a link to `device` on the Player server at `host:port` with default timeouts.
    ///
    /// `device` is the remote address: its `robot` is the remote port, its `host` whatever the
    /// owner uses for that server (it is written into outgoing headers and into the headers of
    /// every event's message). `access` is the DEV mode asked for (`PLAYER_OPEN_MODE`). Returns
    /// at once; the outcome arrives as [`RemoteEvent::Connected`] or [`RemoteEvent::Failed`].
    pub fn spawn(
        handle: &tokio::runtime::Handle,
        host: String,
        port: u16,
        device: DeviceAddr,
        access: u8,
        on_event: impl EventSink,
    ) -> RemoteLink {
        RemoteLink::spawn_with(
            handle,
            host,
            port,
            device,
            access,
            LinkTimeouts::default(),
            on_event,
        )
    }

    /// As [`RemoteLink::spawn`], with explicit timeouts.
    pub fn spawn_with(
        handle: &tokio::runtime::Handle,
        host: String,
        port: u16,
        device: DeviceAddr,
        access: u8,
        timeouts: LinkTimeouts,
        on_event: impl EventSink,
    ) -> RemoteLink {
        let label = format!("{}:{} at {host}:{port}", device.interf, device.index);
        let shared = Arc::new(Shared {
            device,
            label,
            outbox: Mutex::new(Outbox::default()),
            wake: Notify::new(),
            next_ticket: AtomicU64::new(1),
            sink: Box::new(on_event),
        });
        let target = Target {
            host,
            port,
            access,
            timeouts,
        };
        handle.spawn(run(shared.clone(), target));
        RemoteLink { shared }
    }

    /// The remote device's address, as given to `spawn`.
    pub fn device(&self) -> DeviceAddr {
        self.shared.device
    }

    /// `interface:index at host:port`, as the link's messages name it.
    pub fn label(&self) -> &str {
        &self.shared.label
    }

    /// Queues a command for the remote device (never answered). Dropped with a warning if
    /// `body` is not a command of the device's interface, if [`OUTBOX_LIMIT`] messages are
    /// already waiting, or if the link has ended.
    pub fn command(&self, body: Body) {
        let shared = &self.shared;
        if body.msg_type() != MsgType::Cmd {
            tracing::warn!(
                "remote {}: dropping {}: not a command",
                shared.label,
                body.constant()
            );
            return;
        }
        let bytes = match encode(shared.device, body) {
            Ok(b) => b,
            Err((what, e)) => {
                tracing::warn!("remote {}: dropping {what}: {e}", shared.label);
                return;
            }
        };
        let mut out = shared.outbox();
        if out.closing || out.finished {
            tracing::debug!("remote {}: link ended; command dropped", shared.label);
            return;
        }
        if out.queue.len() >= OUTBOX_LIMIT {
            out.dropped += 1;
            if out.dropped.is_power_of_two() {
                tracing::warn!(
                    "remote {}: {} commands waiting; {} dropped so far",
                    shared.label,
                    out.queue.len(),
                    out.dropped
                );
            }
            return;
        }
        out.queue.push_back(Outgoing {
            bytes,
            request: None,
        });
        drop(out);
        shared.wake.notify_one();
    }

    /// Queues a request for the remote device and returns its ticket; the ACK, NACK, timeout
    /// or failure arrives as [`RemoteEvent::Reply`] with that ticket. Requests are sent one at
    /// a time, in order, each after the previous one's reply. A body that is not a request of
    /// the device's interface (or a universal one), a full queue or an ended link is answered
    /// at once with [`RemoteError::NotSent`], on the calling thread.
    pub fn request(&self, body: Body) -> RequestTicket {
        let shared = &self.shared;
        let pending = Pending {
            ticket: RequestTicket(shared.next_ticket.fetch_add(1, Ordering::Relaxed)),
            subtype: body.subtype(),
            what: body.constant(),
        };
        if body.msg_type() != MsgType::Req {
            shared.refuse(pending, "not a request");
            return pending.ticket;
        }
        let bytes = match encode(shared.device, body) {
            Ok(b) => b,
            Err((_, e)) => {
                shared.refuse(pending, e.to_string());
                return pending.ticket;
            }
        };
        let mut out = shared.outbox();
        let refused = if out.closing || out.finished {
            Some("the link has ended".to_string())
        } else if out.queue.len() >= OUTBOX_LIMIT {
            Some(format!("{OUTBOX_LIMIT} messages already waiting"))
        } else {
            out.queue.push_back(Outgoing {
                bytes,
                request: Some(pending),
            });
            None
        };
        drop(out);
        match refused {
            Some(reason) => shared.refuse(pending, reason),
            None => shared.wake.notify_one(),
        }
        pending.ticket
    }

    /// Ends the link: commands already queued are still written, waiting requests are
    /// answered with [`RemoteError::LinkEnded`], the device is unsubscribed (DEV close) and the
    /// connection shut; a [`RemoteEvent::Closed`] follows. Idempotent.
    pub fn close(&self) {
        let mut out = self.shared.outbox();
        if out.closing {
            return;
        }
        out.closing = true;
        drop(out);
        self.shared.wake.notify_one();
    }
}

impl Drop for RemoteLink {
    fn drop(&mut self) {
        self.close();
    }
}

/// A message's bytes, addressed to the remote device.
fn encode(device: DeviceAddr, body: Body) -> Result<Vec<u8>, (&'static str, ProtoError)> {
    let what = body.constant();
    Message::new(device, wall_seconds(), body)
        .encode()
        .map_err(|e| (what, e))
}

/// Where to connect and how.
struct Target {
    host: String,
    port: u16,
    access: u8,
    timeouts: LinkTimeouts,
}

/// The player-interface address the set-up messages travel under (upstream zeroes the header
/// and sets only the interface code).
fn player_addr() -> DeviceAddr {
    DeviceAddr::new(0, 0, InterfaceCode::PLAYER, 0)
}

/// The socket and what has been received but not yet framed.
struct Conn {
    stream: TcpStream,
    framer: Framer,
    buf: Vec<u8>,
}

impl Conn {
    /// Writes all of `bytes` or fails after `limit` (a peer that does not read).
    async fn write(&mut self, bytes: &[u8], limit: Duration) -> Result<(), String> {
        match timeout(limit, self.stream.write_all(bytes)).await {
            Ok(Ok(())) => Ok(()),
            Ok(Err(e)) => Err(format!("write error: {e}")),
            Err(_) => Err(format!(
                "the remote server is not reading (a write stalled for {limit:?})"
            )),
        }
    }

    /// Why the stream ended, for an end of file.
    fn eof_reason(&self) -> String {
        match self.framer.buffered() {
            0 => "the remote server closed the connection".to_string(),
            n => format!(
                "the remote server closed the connection in the middle of a message \
                 ({n} bytes discarded)"
            ),
        }
    }

    /// The next complete frame, reading as needed until `deadline`.
    async fn next_frame(&mut self, deadline: Instant, waiting_for: &str) -> Result<Frame, String> {
        loop {
            match self.framer.next_frame() {
                Ok(Some(frame)) => return Ok(frame),
                Ok(None) => {}
                Err(e) => return Err(format!("malformed message: {e}")),
            }
            match timeout_at(deadline, self.stream.read(&mut self.buf)).await {
                Ok(Ok(0)) => return Err(self.eof_reason()),
                Ok(Ok(n)) => self.framer.push(&self.buf[..n]),
                Ok(Err(e)) => return Err(format!("read error: {e}")),
                Err(_) => return Err(format!("no {waiting_for} in time")),
            }
        }
    }

    /// Sends a player-interface request and waits for its reply (ACK or NACK of the same
    /// subtype on the player interface), skipping anything else.
    async fn player_request(
        &mut self,
        label: &str,
        req: PlayerReq,
        limit: Duration,
    ) -> Result<Frame, String> {
        let what = req.constant();
        let subtype = req.subtype();
        let msg = Message::new(player_addr(), wall_seconds(), Body::from(req));
        let bytes = msg
            .encode()
            .map_err(|e| format!("cannot encode {what}: {e}"))?;
        self.write(&bytes, limit).await?;
        let deadline = Instant::now() + limit;
        loop {
            let frame = self
                .next_frame(deadline, &format!("reply to {what} within {limit:?}"))
                .await?;
            let h = &frame.header;
            let reply = matches!(h.kind(), Ok(MsgType::RespAck | MsgType::RespNack));
            if reply && h.addr.interf == InterfaceCode::PLAYER && h.subtype == subtype {
                return Ok(frame);
            }
            tracing::debug!(
                "remote {label}: skipping {} while waiting for the reply to {what}",
                h.key()
            );
        }
    }
}

/// Connects and subscribes; returns the connection and the remote driver's name.
async fn set_up(shared: &Shared, target: &Target) -> Result<(Conn, String), String> {
    let limit = target.timeouts.setup;
    let stream = connect(&target.host, target.port, limit).await?;
    if let Err(e) = stream.set_nodelay(true) {
        tracing::warn!("remote {}: cannot set TCP_NODELAY: {e}", shared.label);
    }
    let mut conn = Conn {
        stream,
        framer: Framer::new(DecodeLimits::default()),
        buf: vec![0; READ_CHUNK],
    };

    // The banner: 32 bytes, whatever pieces they come in.
    let deadline = Instant::now() + limit;
    let mut banner = [0u8; PLAYER_IDENT_STRLEN];
    let mut got = 0;
    while got < banner.len() {
        match timeout_at(deadline, conn.stream.read(&mut banner[got..])).await {
            Ok(Ok(0)) => {
                return Err(format!(
                    "the server closed the connection after {got} of the {PLAYER_IDENT_STRLEN} \
                     banner bytes"
                ));
            }
            Ok(Ok(n)) => got += n,
            Ok(Err(e)) => return Err(format!("read error while waiting for the banner: {e}")),
            Err(_) => {
                return Err(format!(
                    "no banner within {limit:?} ({got} of {PLAYER_IDENT_STRLEN} bytes)"
                ));
            }
        }
    }
    let text = banner_text(&banner);
    if !text.starts_with(IDENT_PREFIX) {
        return Err(format!("not a Player server (banner {text:?})"));
    }
    tracing::debug!("remote {}: banner {text:?}", shared.label);

    // PUSH is the default of a new connection; asking for it makes that explicit.
    let reply = conn
        .player_request(
            &shared.label,
            PlayerReq::DataMode(Some(DeviceDatamodeReq {
                mode: PLAYER_DATAMODE_PUSH,
            })),
            limit,
        )
        .await?;
    if reply.header.kind() != Ok(MsgType::RespAck) {
        return Err("the server refused PUSH data mode (NACK)".into());
    }

    let reply = conn
        .player_request(
            &shared.label,
            dev_request(shared.device, target.access),
            limit,
        )
        .await?;
    let granted = match reply.decode(&DecodeLimits::default()) {
        Ok(Message {
            body: Body::Player(PlayerMsg::Ack(PlayerReq::Dev(Some(d)))),
            ..
        }) => d,
        Ok(Message {
            body: Body::Player(PlayerMsg::Nack(_)),
            ..
        }) => return Err("no such device on the remote server (DEV NACK)".into()),
        Ok(_) => return Err("DEV reply without a body".into()),
        Err(e) => return Err(format!("malformed DEV reply: {e}")),
    };
    if granted.access != target.access {
        return Err(format!(
            "subscription refused (asked for access {}, granted {})",
            target.access, granted.access
        ));
    }
    Ok((conn, granted.driver_name.to_str_lossy().into_owned()))
}

/// The DEV request upstream sends: the full remote address in the body.
fn dev_request(device: DeviceAddr, access: u8) -> PlayerReq {
    PlayerReq::Dev(Some(DeviceReq {
        addr: device,
        access,
        driver_name: Text::empty(),
    }))
}

/// Resolves `host` and connects to the first address that accepts, within `limit`.
async fn connect(host: &str, port: u16, limit: Duration) -> Result<TcpStream, String> {
    let attempt = async {
        let addrs = tokio::net::lookup_host((host, port))
            .await
            .map_err(|e| format!("cannot resolve host {host:?}: {e}"))?;
        let mut last = format!("host {host:?} has no address");
        for addr in addrs {
            match TcpStream::connect(addr).await {
                Ok(s) => return Ok(s),
                Err(e) => last = format!("cannot connect to {addr}: {e}"),
            }
        }
        Err(last)
    };
    match timeout(limit, attempt).await {
        Ok(r) => r,
        Err(_) => Err(format!("no connection within {limit:?}")),
    }
}

/// Waits until `close` has been called.
async fn close_requested(shared: &Shared) {
    loop {
        // A `notify_one` between the check and the await leaves a permit, so none is missed.
        if shared.is_closing() {
            return;
        }
        shared.wake.notified().await;
    }
}

/// The link's task.
async fn run(shared: Arc<Shared>, target: Target) {
    let set_up_result = tokio::select! {
        r = set_up(&shared, &target) => Some(r),
        _ = close_requested(&shared) => None,
    };
    let (mut conn, driver_name) = match set_up_result {
        Some(Ok(up)) => up,
        Some(Err(reason)) => {
            let text = format!("remote {}: {reason}", shared.label);
            tracing::warn!("{text}");
            shared.finish(None, &format!("the link failed: {reason}"));
            shared.sink.deliver(RemoteEvent::Failed(text));
            return;
        }
        None => {
            shared.finish(None, "the link was closed");
            let text = format!("remote {}: closed before the link was up", shared.label);
            shared.sink.deliver(RemoteEvent::Closed(text));
            return;
        }
    };
    tracing::info!(
        "subscribed to remote device {} (driver \"{driver_name}\")",
        shared.label
    );
    shared.sink.deliver(RemoteEvent::Connected { driver_name });

    let mut inflight = None;
    let reason = match serve(&shared, &mut conn, &target, &mut inflight).await {
        Ok(()) => {
            let queued = shared.finish(inflight, "the link was closed");
            shut_down(&shared, &mut conn, &target, queued).await;
            "link closed".to_string()
        }
        Err(reason) => {
            tracing::warn!("remote {}: {reason}", shared.label);
            shared.finish(inflight, &reason);
            reason
        }
    };
    shared.sink.deliver(RemoteEvent::Closed(format!(
        "remote {}: {reason}",
        shared.label
    )));
}

/// A request written and not yet answered.
struct InFlight {
    pending: Pending,
    deadline: Instant,
}

/// Forwards until `close` (`Ok`) or until the link breaks (`Err` with the reason).
/// `inflight` is left holding the request still waiting for its reply.
async fn serve(
    shared: &Shared,
    conn: &mut Conn,
    target: &Target,
    inflight: &mut Option<Pending>,
) -> Result<(), String> {
    let mut waiting: Option<InFlight> = None;
    let mut bad_data = 0u64;
    loop {
        // What has been received (the set-up's last read may have brought data too).
        loop {
            let frame = match conn.framer.next_frame() {
                Ok(Some(f)) => f,
                Ok(None) => break,
                Err(e) => {
                    *inflight = waiting.map(|w| w.pending);
                    return Err(format!("malformed message: {e}"));
                }
            };
            dispatch(shared, frame, &mut waiting, &mut bad_data);
        }
        // Write what may go now: everything up to and including the next request.
        loop {
            let next = {
                let mut out = shared.outbox();
                if out.closing {
                    *inflight = waiting.map(|w| w.pending);
                    return Ok(());
                }
                if waiting.is_some() {
                    None
                } else {
                    out.queue.pop_front()
                }
            };
            let Some(next) = next else { break };
            if let Err(e) = conn.write(&next.bytes, target.timeouts.setup).await {
                *inflight = next.request;
                return Err(e);
            }
            if let Some(pending) = next.request {
                waiting = Some(InFlight {
                    pending,
                    deadline: Instant::now() + target.timeouts.request,
                });
            }
        }
        let deadline = waiting
            .as_ref()
            .map(|w| w.deadline)
            .unwrap_or_else(Instant::now);
        tokio::select! {
            r = conn.stream.read(&mut conn.buf) => {
                match r {
                    Ok(0) => {
                        *inflight = waiting.map(|w| w.pending);
                        return Err(conn.eof_reason());
                    }
                    // Framed at the top of the loop.
                    Ok(n) => conn.framer.push(&conn.buf[..n]),
                    Err(e) => {
                        *inflight = waiting.map(|w| w.pending);
                        return Err(format!("read error: {e}"));
                    }
                }
            }
            _ = shared.wake.notified() => {}
            _ = sleep_until(deadline), if waiting.is_some() => {
                if let Some(w) = waiting.take() {
                    tracing::warn!(
                        "remote {}: no reply to {} within {:?}",
                        shared.label,
                        w.pending.what,
                        target.timeouts.request
                    );
                    shared.sink.deliver(RemoteEvent::Reply {
                        ticket: w.pending.ticket,
                        result: Err(RemoteError::Timeout {
                            link: shared.label.clone(),
                            request: w.pending.what,
                            after: target.timeouts.request,
                        }),
                    });
                }
            }
        }
    }
}

/// Handles one received message: the device's DATA, the reply to the waiting request, or
/// something to skip.
fn dispatch(shared: &Shared, frame: Frame, waiting: &mut Option<InFlight>, bad_data: &mut u64) {
    let h = frame.header;
    let device = shared.device;
    let ours = h.addr.interf == device.interf && h.addr.index == device.index;
    match h.kind() {
        Ok(MsgType::Data) if ours => match frame.decode(&DecodeLimits::default()) {
            Ok(mut msg) => {
                msg.header.addr = device;
                shared.sink.deliver(RemoteEvent::Data(msg));
            }
            Err(e) => {
                // The stream is intact (the header gave the size); only this message is lost.
                *bad_data += 1;
                if bad_data.is_power_of_two() {
                    tracing::warn!(
                        "remote {}: skipping undecodable data ({} so far): {e}",
                        shared.label,
                        bad_data
                    );
                }
            }
        },
        Ok(kind @ (MsgType::RespAck | MsgType::RespNack))
            if ours
                && waiting
                    .as_ref()
                    .is_some_and(|w| w.pending.subtype == h.subtype) =>
        {
            let Some(w) = waiting.take() else { return };
            let what = w.pending.what;
            let result = if kind == MsgType::RespNack {
                Err(RemoteError::Nack {
                    link: shared.label.clone(),
                    request: what,
                })
            } else {
                match frame.decode(&DecodeLimits::default()) {
                    Ok(mut msg) => {
                        msg.header.addr = device;
                        Ok(msg)
                    }
                    Err(e) => Err(RemoteError::BadReply {
                        link: shared.label.clone(),
                        request: what,
                        reason: e.to_string(),
                    }),
                }
            };
            shared.sink.deliver(RemoteEvent::Reply {
                ticket: w.pending.ticket,
                result,
            });
        }
        Ok(MsgType::RespAck | MsgType::RespNack) => {
            // A late reply to a request that already timed out, or not ours at all.
            tracing::warn!(
                "remote {}: skipping a reply nobody waits for ({})",
                shared.label,
                h.key()
            );
        }
        Ok(MsgType::Synch) => {}
        _ => tracing::debug!("remote {}: skipping {}", shared.label, h.key()),
    }
}

/// The orderly end after `close`: queued commands, DEV close, then the write side shut and the
/// server's own close awaited (reading on, so nothing unread makes our close a reset).
async fn shut_down(shared: &Shared, conn: &mut Conn, target: &Target, queued: Vec<Outgoing>) {
    let limit = target.timeouts.setup;
    let commands = queued.into_iter().filter(|o| o.request.is_none());
    let mut bytes: Vec<u8> = commands.flat_map(|o| o.bytes).collect();
    // Unsubscribing is a courtesy; its reply is not awaited (upstream `SubscribeRemote`).
    match Message::new(
        player_addr(),
        wall_seconds(),
        Body::from(dev_request(shared.device, PLAYER_CLOSE_MODE)),
    )
    .encode()
    {
        Ok(b) => bytes.extend_from_slice(&b),
        Err(e) => tracing::warn!("remote {}: cannot encode DEV close: {e}", shared.label),
    }
    if let Err(e) = conn.write(&bytes, limit).await {
        tracing::debug!("remote {}: while closing: {e}", shared.label);
        return;
    }
    if conn.stream.shutdown().await.is_err() {
        return;
    }
    let deadline = Instant::now() + limit;
    loop {
        match timeout_at(deadline, conn.stream.read(&mut conn.buf)).await {
            Ok(Ok(0)) | Ok(Err(_)) => return,
            Ok(Ok(_)) => {}
            Err(_) => {
                tracing::debug!(
                    "remote {}: the server did not close within {limit:?} after DEV close",
                    shared.label
                );
                return;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use player_proto::constants::{LOCALHOST_ADDR, PLAYER_OPEN_MODE};
    use player_proto::{BANNER, HEADER_SIZE, MsgHeader, Pose2d, Position2dCmd, Position2dCmdVel};
    use std::sync::mpsc as std_mpsc;
    use tokio::net::TcpListener;

    const SHORT: LinkTimeouts = LinkTimeouts {
        setup: Duration::from_millis(500),
        request: Duration::from_millis(500),
    };

    fn runtime() -> tokio::runtime::Runtime {
        tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .enable_all()
            .build()
            .unwrap()
    }

    fn p2d(port: u16) -> DeviceAddr {
        DeviceAddr::new(
            LOCALHOST_ADDR,
            u32::from(port),
            InterfaceCode::POSITION2D,
            0,
        )
    }

    /// A link whose events arrive on a std channel.
    fn link(
        rt: &tokio::runtime::Runtime,
        port: u16,
        timeouts: LinkTimeouts,
    ) -> (RemoteLink, std_mpsc::Receiver<RemoteEvent>) {
        let (tx, rx) = std_mpsc::channel();
        let link = RemoteLink::spawn_with(
            rt.handle(),
            "127.0.0.1".into(),
            port,
            p2d(port),
            PLAYER_OPEN_MODE,
            timeouts,
            move |e| {
                let _ = tx.send(e);
            },
        );
        (link, rx)
    }

    fn next(rx: &std_mpsc::Receiver<RemoteEvent>) -> RemoteEvent {
        rx.recv_timeout(Duration::from_secs(5))
            .expect("no event within 5 s")
    }

    /// A fake peer: binds, then runs `script` on the first accepted socket.
    fn fake_peer<F, Fut>(rt: &tokio::runtime::Runtime, script: F) -> u16
    where
        F: FnOnce(TcpStream) -> Fut + Send + 'static,
        Fut: std::future::Future<Output = ()> + Send + 'static,
    {
        let listener = rt.block_on(TcpListener::bind("127.0.0.1:0")).unwrap();
        let port = listener.local_addr().unwrap().port();
        rt.spawn(async move {
            if let Ok((s, _)) = listener.accept().await {
                script(s).await;
            }
        });
        port
    }

    /// Reads one whole message from the link (the fake server side).
    async fn read_msg(s: &mut TcpStream) -> Option<Message> {
        let mut head = [0u8; HEADER_SIZE];
        s.read_exact(&mut head).await.ok()?;
        let header = MsgHeader::from_bytes(&head).ok()?;
        let mut body = vec![0; header.size as usize];
        s.read_exact(&mut body).await.ok()?;
        Message::decode(header, &body, &DecodeLimits::default()).ok()
    }

    async fn send(s: &mut TcpStream, msg: Message) {
        let _ = s.write_all(&msg.encode().unwrap()).await;
    }

    fn ack(req: &Message, body: Body) -> Message {
        let mut m = Message::new(req.header.addr, 0.0, body);
        m.header.msg_type = MsgType::RespAck.code();
        m
    }

    /// Plays a Player server up to the DEV ACK granting `granted`.
    async fn handshake(s: &mut TcpStream, granted: u8) -> bool {
        s.write_all(&BANNER).await.unwrap();
        let Some(dm) = read_msg(s).await else {
            return false;
        };
        assert_eq!(
            dm.body,
            Body::from(PlayerReq::DataMode(Some(DeviceDatamodeReq {
                mode: PLAYER_DATAMODE_PUSH
            })))
        );
        send(
            s,
            ack(&dm, PlayerMsg::Ack(PlayerReq::DataMode(None)).into()),
        )
        .await;
        let Some(dev) = read_msg(s).await else {
            return false;
        };
        let Body::Player(PlayerMsg::Req(PlayerReq::Dev(Some(mut d)))) = dev.body.clone() else {
            panic!("expected DEV, got {:?}", dev.body)
        };
        assert_eq!(dev.header.addr, player_addr());
        assert_eq!(d.access, PLAYER_OPEN_MODE);
        d.access = granted;
        d.driver_name = Text::new("fake");
        send(s, ack(&dev, PlayerMsg::Ack(PlayerReq::Dev(Some(d))).into())).await;
        true
    }

    #[test]
    fn refused_connection_fails_naming_the_peer() {
        let rt = runtime();
        // A port nobody listens on: bind, note it, close.
        let port = {
            let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
            l.local_addr().unwrap().port()
        };
        let (_link, rx) = link(&rt, port, SHORT);
        match next(&rx) {
            RemoteEvent::Failed(text) => {
                assert!(text.contains(&format!("127.0.0.1:{port}")), "{text}");
                assert!(text.contains("position2d:0"), "{text}");
                assert!(text.contains("cannot connect"), "{text}");
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn bad_banner_fails() {
        let rt = runtime();
        let port = fake_peer(&rt, |mut s| async move {
            let text = *b"HTTP/1.1 400 Bad Request\r\n\r\n....";
            s.write_all(&text).await.unwrap();
            tokio::time::sleep(Duration::from_secs(2)).await;
        });
        let (_link, rx) = link(&rt, port, SHORT);
        match next(&rx) {
            RemoteEvent::Failed(text) => {
                assert!(text.contains("not a Player server"), "{text}");
                assert!(text.contains(&format!("127.0.0.1:{port}")), "{text}");
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn short_banner_then_close_fails() {
        let rt = runtime();
        let port = fake_peer(&rt, |mut s| async move {
            s.write_all(&BANNER[..10]).await.unwrap();
        });
        let (_link, rx) = link(&rt, port, SHORT);
        match next(&rx) {
            RemoteEvent::Failed(text) => {
                assert!(text.contains("after 10 of the 32 banner bytes"), "{text}")
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn silent_peer_fails_within_the_timeout() {
        let rt = runtime();
        let port = fake_peer(&rt, |s| async move {
            tokio::time::sleep(Duration::from_secs(5)).await;
            drop(s);
        });
        let start = std::time::Instant::now();
        let (_link, rx) = link(&rt, port, SHORT);
        match next(&rx) {
            RemoteEvent::Failed(text) => assert!(text.contains("no banner within"), "{text}"),
            other => panic!("{other:?}"),
        }
        assert!(start.elapsed() < Duration::from_secs(3));
    }

    #[test]
    fn unanswered_dev_fails() {
        let rt = runtime();
        let port = fake_peer(&rt, |mut s| async move {
            s.write_all(&BANNER).await.unwrap();
            let dm = read_msg(&mut s).await.unwrap();
            send(
                &mut s,
                ack(&dm, PlayerMsg::Ack(PlayerReq::DataMode(None)).into()),
            )
            .await;
            // Read the DEV request and never answer.
            let _ = read_msg(&mut s).await;
            tokio::time::sleep(Duration::from_secs(5)).await;
        });
        let (_link, rx) = link(&rt, port, SHORT);
        match next(&rx) {
            RemoteEvent::Failed(text) => {
                assert!(text.contains("no reply to PLAYER_PLAYER_REQ_DEV"), "{text}")
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn refused_access_fails() {
        let rt = runtime();
        let port = fake_peer(&rt, |mut s| async move {
            handshake(&mut s, player_proto::constants::PLAYER_ERROR_MODE).await;
            tokio::time::sleep(Duration::from_secs(2)).await;
        });
        let (_link, rx) = link(&rt, port, SHORT);
        match next(&rx) {
            RemoteEvent::Failed(text) => {
                assert!(text.contains("asked for access 1, granted 3"), "{text}")
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn absurd_size_closes_and_fails_waiting_requests() {
        let rt = runtime();
        let port = fake_peer(&rt, |mut s| async move {
            assert!(handshake(&mut s, PLAYER_OPEN_MODE).await);
            // Take the request, then answer with a header announcing 4 GiB.
            let _ = read_msg(&mut s).await;
            let mut h = MsgHeader::new(p2d(0), MsgType::Data, 1, 0.0).to_bytes();
            h[36..].copy_from_slice(&u32::MAX.to_be_bytes());
            s.write_all(&h).await.unwrap();
            tokio::time::sleep(Duration::from_secs(2)).await;
        });
        let (link, rx) = link(&rt, port, LinkTimeouts::default());
        assert_eq!(
            next(&rx),
            RemoteEvent::Connected {
                driver_name: "fake".into()
            }
        );
        let ticket = link.request(player_proto::Position2dReq::GetGeom(None).into());
        match next(&rx) {
            RemoteEvent::Reply {
                ticket: t,
                result: Err(RemoteError::LinkEnded { reason, .. }),
            } => {
                assert_eq!(t, ticket);
                assert!(reason.contains("exceeds the limit"), "{reason}");
            }
            other => panic!("{other:?}"),
        }
        match next(&rx) {
            RemoteEvent::Closed(text) => {
                assert!(text.contains("malformed message"), "{text}");
                assert!(text.contains(&format!("127.0.0.1:{port}")), "{text}");
            }
            other => panic!("{other:?}"),
        }
        // After the end, requests are refused at once.
        let late = link.request(player_proto::Position2dReq::GetGeom(None).into());
        match next(&rx) {
            RemoteEvent::Reply {
                ticket,
                result: Err(RemoteError::NotSent { .. }),
            } => assert_eq!(ticket, late),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn close_mid_message_is_reported() {
        let rt = runtime();
        let port = fake_peer(&rt, |mut s| async move {
            assert!(handshake(&mut s, PLAYER_OPEN_MODE).await);
            let msg = Message::new(
                p2d(0),
                1.0,
                player_proto::Position2dData::State(Default::default()),
            );
            let bytes = msg.encode().unwrap();
            s.write_all(&bytes).await.unwrap();
            s.write_all(&bytes[..50]).await.unwrap();
        });
        let (_link, rx) = link(&rt, port, SHORT);
        assert!(matches!(next(&rx), RemoteEvent::Connected { .. }));
        match next(&rx) {
            RemoteEvent::Data(m) => {
                assert_eq!(m.header.addr, p2d(port), "relabelled to the link's address");
                assert_eq!(m.header.timestamp, 1.0);
            }
            other => panic!("{other:?}"),
        }
        match next(&rx) {
            RemoteEvent::Closed(text) => {
                assert!(text.contains("in the middle of a message"), "{text}");
                assert!(text.contains("(50 bytes discarded)"), "{text}");
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn unanswered_request_times_out_and_the_link_stays_up() {
        let rt = runtime();
        let (seen_tx, seen_rx) = std_mpsc::channel();
        let port = fake_peer(&rt, move |mut s| async move {
            assert!(handshake(&mut s, PLAYER_OPEN_MODE).await);
            // Never answer; report everything the link sends, in order.
            while let Some(m) = read_msg(&mut s).await {
                let _ = seen_tx.send(m);
            }
        });
        let (link, rx) = link(&rt, port, SHORT);
        assert!(matches!(next(&rx), RemoteEvent::Connected { .. }));
        let first = link.request(player_proto::Position2dReq::GetGeom(None).into());
        let vel = Position2dCmd::Vel(Position2dCmdVel {
            vel: Pose2d {
                px: 0.5,
                ..Pose2d::default()
            },
            state: 1,
        });
        link.command(vel.clone().into());
        let second = link.request(player_proto::Position2dReq::ResetOdom.into());
        for ticket in [first, second] {
            match next(&rx) {
                RemoteEvent::Reply {
                    ticket: t,
                    result: Err(RemoteError::Timeout { request, .. }),
                } => {
                    assert_eq!(t, ticket);
                    assert!(request.starts_with("PLAYER_POSITION2D_REQ_"));
                }
                other => panic!("{other:?}"),
            }
        }
        // Strict order on the wire: the command waited behind the first request.
        let got: Vec<Body> = (0..3)
            .map(|_| seen_rx.recv_timeout(Duration::from_secs(2)).unwrap().body)
            .collect();
        assert_eq!(
            got,
            vec![
                player_proto::Position2dReq::GetGeom(None).into(),
                vel.into(),
                player_proto::Position2dReq::ResetOdom.into()
            ]
        );
        link.close();
        // DEV close, then the socket shut.
        let close = seen_rx.recv_timeout(Duration::from_secs(2)).unwrap();
        let Body::Player(PlayerMsg::Req(PlayerReq::Dev(Some(d)))) = close.body else {
            panic!("{close:?}")
        };
        assert_eq!((d.access, d.addr), (PLAYER_CLOSE_MODE, p2d(port)));
        match next(&rx) {
            RemoteEvent::Closed(text) => assert!(text.ends_with("link closed"), "{text}"),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn wrong_bodies_are_refused_at_once() {
        let rt = runtime();
        let port = fake_peer(&rt, |mut s| async move {
            handshake(&mut s, PLAYER_OPEN_MODE).await;
            tokio::time::sleep(Duration::from_secs(2)).await;
        });
        let (link, rx) = link(&rt, port, SHORT);
        // A ranger request on a position2d link, and a command given as a request.
        let t1 = link.request(player_proto::RangerReq::GetGeom(None).into());
        let t2 = link.request(Position2dCmd::Vel(Position2dCmdVel::default()).into());
        let mut refused = Vec::new();
        while refused.len() < 2 {
            match next(&rx) {
                RemoteEvent::Reply {
                    ticket,
                    result: Err(RemoteError::NotSent { reason, .. }),
                } => refused.push((ticket, reason)),
                RemoteEvent::Connected { .. } => {}
                other => panic!("{other:?}"),
            }
        }
        assert_eq!(refused[0].0, t1);
        assert!(refused[0].1.contains("header says"), "{}", refused[0].1);
        assert_eq!(refused[1], (t2, "not a request".to_string()));
    }

    #[test]
    fn close_before_connected_is_closed() {
        let rt = runtime();
        let port = fake_peer(&rt, |s| async move {
            tokio::time::sleep(Duration::from_secs(5)).await;
            drop(s);
        });
        let (link, rx) = link(&rt, port, LinkTimeouts::default());
        let t = link.request(player_proto::Position2dReq::GetGeom(None).into());
        drop(link);
        match next(&rx) {
            RemoteEvent::Reply {
                ticket,
                result: Err(RemoteError::LinkEnded { .. }),
            } => assert_eq!(ticket, t),
            other => panic!("{other:?}"),
        }
        match next(&rx) {
            RemoteEvent::Closed(text) => assert!(text.contains("before the link was up")),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn outbox_is_bounded() {
        let rt = runtime();
        // Never connects: everything stays queued.
        let port = fake_peer(&rt, |s| async move {
            tokio::time::sleep(Duration::from_secs(5)).await;
            drop(s);
        });
        let (link, rx) = link(&rt, port, LinkTimeouts::default());
        for _ in 0..OUTBOX_LIMIT + 10 {
            link.command(Position2dCmd::Vel(Position2dCmdVel::default()).into());
        }
        assert_eq!(link.shared.outbox().queue.len(), OUTBOX_LIMIT);
        assert_eq!(link.shared.outbox().dropped, 10);
        let t = link.request(player_proto::Position2dReq::GetGeom(None).into());
        match next(&rx) {
            RemoteEvent::Reply {
                ticket,
                result: Err(RemoteError::NotSent { reason, .. }),
            } => {
                assert_eq!(ticket, t);
                assert!(reason.contains("already waiting"), "{reason}");
            }
            other => panic!("{other:?}"),
        }
    }
}
