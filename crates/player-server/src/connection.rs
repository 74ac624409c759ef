//! One client connection: the banner, a reader task that frames and routes incoming messages to
//! the core, and a writer task that drains the connection's [`OutQueue`] into the socket.
//!
//! The tasks only do I/O. What is shared with the core is a [`ConnShared`]: the queue behind a
//! mutex, a `Notify` that wakes the writer, and a `closing` flag both tasks watch, so the core
//! can end a connection (malformed message, client not reading) without touching the socket.

use std::net::SocketAddr;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

use player_proto::constants::LOCALHOST_ADDR;
use player_proto::{
    BANNER, Body, DecodeLimits, Error as ProtoError, Frame, Framer, InterfaceCode, Message,
    MsgHeader, PlayerMsg, PlayerReq,
};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;
use tokio::net::tcp::{OwnedReadHalf, OwnedWriteHalf};
use tokio::sync::{Notify, mpsc, watch};

use crate::clock::ServerClock;
use crate::device::{DeviceIndex, DeviceTable};
use crate::driver::{ClientId, DriverError};
use crate::player_iface::{self, PlayerInput, Session, Subscriptions, UnsubscribeError};
use crate::queue::{OutQueue, PushOutcome, QueueLimits};

/// Size of one socket read. Small, because it is paid per connection; the framer grows on its
/// own for large messages.
const READ_CHUNK: usize = 4096;

/// Most bytes the writer takes from the queue before writing them (bounds its buffer).
const WRITE_BATCH: usize = 256 * 1024;

/// Per-connection limits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ConnectionLimits {
    /// Largest message body accepted from a client. Clients of Player 3.0.2 send small
    /// messages (the largest, graphics commands, are a few KiB); anything announcing more is
    /// refused and the connection closed.
    pub max_body: usize,
    /// Bounds of the outgoing queue.
    pub queue: QueueLimits,
}

impl Default for ConnectionLimits {
    fn default() -> Self {
        ConnectionLimits {
            max_body: 1 << 20,
            queue: QueueLimits::default(),
        }
    }
}

/// What a connection shares with the core.
#[derive(Debug)]
pub(crate) struct ConnShared {
    pub id: ClientId,
    /// `ip:port` of the client, for log lines.
    pub peer: String,
    /// The port it was accepted on: the `robot` of every message it sends.
    pub port: u32,
    pub queue: Mutex<OutQueue>,
    /// Wakes the writer after the core queued something.
    pub wake: Notify,
    /// Set once to end both tasks.
    pub closing: watch::Sender<bool>,
    /// Messages sent to the core and not yet handled by it. While it is 0 the reader answers
    /// player-interface requests itself (they only touch this connection's queue and the
    /// read-only device table), saving the hop to the core task; otherwise it queues them
    /// behind the others, so replies always keep the order of the requests.
    pub in_flight: AtomicUsize,
}

impl ConnShared {
    /// Ends the connection's tasks (idempotent).
    pub fn close(&self) {
        self.closing.send_replace(true);
        self.wake.notify_one();
    }
}

/// A message from a client, classified by the reader.
#[derive(Debug)]
pub(crate) enum Incoming {
    /// To the player interface, decoded.
    Player(Message),
    /// To the player interface, no body, (type, subtype) not in the function table.
    PlayerUntyped(MsgHeader),
    /// To a device, decoded; the header carries the device's address.
    Device { device: DeviceIndex, msg: Message },
    /// To a device, no body, (type, subtype) not in the function table.
    DeviceUntyped {
        device: DeviceIndex,
        header: MsgHeader,
    },
}

/// What connections tell the core.
// Messages are nearly every event; boxing them would cost an allocation each.
#[allow(clippy::large_enum_variant)]
#[derive(Debug)]
pub(crate) enum CoreEvent {
    /// A client connected (the banner is out).
    Opened(Arc<ConnShared>),
    /// A message arrived.
    Message { id: ClientId, input: Incoming },
    /// The connection ended; the core drops its subscriptions.
    Closed { id: ClientId, reason: String },
}

/// Everything a connection needs from the server.
#[derive(Clone)]
pub(crate) struct ConnContext {
    pub table: Arc<DeviceTable>,
    pub core: mpsc::Sender<CoreEvent>,
    pub clock: ServerClock,
    pub limits: ConnectionLimits,
}

/// Serves one accepted socket until it closes.
pub(crate) async fn serve(
    mut stream: TcpStream,
    peer: SocketAddr,
    port: u32,
    id: ClientId,
    ctx: ConnContext,
) {
    if let Err(e) = stream.set_nodelay(true) {
        tracing::warn!("{peer}: cannot set TCP_NODELAY: {e}");
    }
    // The banner is the first thing on the wire, in one write.
    if let Err(e) = stream.write_all(&BANNER).await {
        tracing::info!("{peer}: gone before the banner was sent: {e}");
        return;
    }
    let (closing, closing_rx) = watch::channel(false);
    let shared = Arc::new(ConnShared {
        id,
        peer: peer.to_string(),
        port,
        queue: Mutex::new(OutQueue::new(ctx.limits.queue)),
        wake: Notify::new(),
        closing,
        in_flight: AtomicUsize::new(0),
    });
    if ctx
        .core
        .send(CoreEvent::Opened(shared.clone()))
        .await
        .is_err()
    {
        return; // the server is stopping
    }
    tracing::info!("accepted client {} from {peer} on port {port}", id.0);
    let (read, write) = stream.into_split();
    tokio::spawn(write_loop(write, shared.clone(), ctx.clone()));
    let reason = read_loop(read, &shared, &ctx, closing_rx).await;
    if let Some(reason) = reason {
        let _ = ctx.core.send(CoreEvent::Closed { id, reason }).await;
    }
}

/// Reads, frames and routes messages. Returns the reason the connection ended, or `None` when
/// the core ended it.
async fn read_loop(
    mut read: OwnedReadHalf,
    shared: &ConnShared,
    ctx: &ConnContext,
    mut closing: watch::Receiver<bool>,
) -> Option<String> {
    let limits = DecodeLimits {
        max_body: ctx.limits.max_body,
    };
    let mut framer = Framer::new(limits);
    let mut buf = vec![0u8; READ_CHUNK];
    loop {
        let n = tokio::select! {
            r = read.read(&mut buf) => r,
            _ = closing.wait_for(|c| *c) => return None,
        };
        match n {
            Ok(0) => {
                let pending = framer.buffered();
                return Some(if pending > 0 {
                    format!("disconnected in the middle of a message ({pending} bytes discarded)")
                } else {
                    "disconnected".to_string()
                });
            }
            Ok(n) => framer.push(&buf[..n]),
            Err(e) => return Some(format!("read error: {e}")),
        }
        loop {
            let frame = match framer.next_frame() {
                Ok(Some(f)) => f,
                Ok(None) => break,
                Err(e) => return Some(format!("malformed message: {e}")),
            };
            match classify(frame, shared, ctx, &limits) {
                Ok(Some(Incoming::Player(msg)))
                    if shared.in_flight.load(Ordering::Acquire) == 0 && !is_dev(&msg) =>
                {
                    answer_locally(&msg, shared, ctx);
                }
                Ok(Some(input)) => {
                    shared.in_flight.fetch_add(1, Ordering::AcqRel);
                    let event = CoreEvent::Message {
                        id: shared.id,
                        input,
                    };
                    // Waits when the core is busy: TCP back-pressure instead of memory.
                    if ctx.core.send(event).await.is_err() {
                        return None;
                    }
                }
                Ok(None) => {}
                Err(reason) => return Some(format!("malformed message: {reason}")),
            }
        }
    }
}

/// DEV requests need the drivers: they always go to the core.
fn is_dev(msg: &Message) -> bool {
    matches!(msg.body, Body::Player(PlayerMsg::Req(PlayerReq::Dev(_))))
}

/// Answers a player-interface request (other than DEV) on the connection task.
fn answer_locally(msg: &Message, shared: &ConnShared, ctx: &ConnContext) {
    let outcome = {
        let mut queue = shared.queue.lock().unwrap_or_else(|p| p.into_inner());
        let mut session = Session {
            table: &ctx.table,
            port: shared.port,
            now: ctx.clock.now(),
            queue: &mut queue,
            peer: &shared.peer,
        };
        player_iface::handle(PlayerInput::Typed(msg), &mut session, &mut NoDrivers)
    };
    if outcome == Some(PushOutcome::Overloaded) {
        // Let the core close it, with its subscriptions.
        let _ = ctx.core.try_send(CoreEvent::Closed {
            id: shared.id,
            reason: "not reading: outgoing queue exceeded its hard limit".into(),
        });
        shared.close();
    } else {
        shared.wake.notify_one();
    }
}

/// Subscriptions are never made on a connection task (DEV goes to the core).
struct NoDrivers;

impl Subscriptions for NoDrivers {
    fn subscribe(&mut self, _device: DeviceIndex) -> Result<(), DriverError> {
        Err(DriverError::new("subscriptions are handled by the core"))
    }
    fn unsubscribe(&mut self, _device: DeviceIndex) -> Result<(), UnsubscribeError> {
        Err(UnsubscribeError::NotSubscribed)
    }
}

/// Routes one frame: rewrites host and port (the connection's, whatever the client wrote),
/// drops messages to unknown devices with a warning as upstream does, and decodes the body.
/// `Err` means the bytes are malformed and the connection must close.
fn classify(
    mut frame: Frame,
    shared: &ConnShared,
    ctx: &ConnContext,
    limits: &DecodeLimits,
) -> Result<Option<Incoming>, String> {
    let h = &mut frame.header;
    h.addr.host = LOCALHOST_ADDR;
    h.addr.robot = shared.port;
    let kind = h.kind().map_err(|e| e.to_string())?;
    let device = if h.addr.interf == InterfaceCode::PLAYER {
        None
    } else {
        match ctx.table.find(&h.addr) {
            Some(d) => {
                h.addr = ctx.table.get(d).addr;
                Some(d)
            }
            None => {
                tracing::warn!(
                    "{}: skipping message of type {kind}:{} to unknown device {}:{}",
                    shared.peer,
                    h.subtype,
                    h.addr.interf,
                    h.addr.index
                );
                return Ok(None);
            }
        }
    };
    match frame.decode(limits) {
        Ok(msg) => Ok(Some(match device {
            None => Incoming::Player(msg),
            Some(device) => Incoming::Device { device, msg },
        })),
        Err(
            e @ (ProtoError::UnknownMessage(_)
            | ProtoError::UnexpectedBody { .. }
            | ProtoError::MissingBody { .. }),
        ) => {
            let header = frame.header;
            if header.size > 0 {
                tracing::warn!(
                    "{}: skipping message to {}:{}: {e}",
                    shared.peer,
                    header.addr.interf,
                    header.addr.index
                );
                return Ok(None);
            }
            Ok(Some(match device {
                None => Incoming::PlayerUntyped(header),
                Some(device) => Incoming::DeviceUntyped { device, header },
            }))
        }
        Err(e) => Err(e.to_string()),
    }
}

/// Drains the queue into the socket whenever the core wakes it.
async fn write_loop(mut write: OwnedWriteHalf, shared: Arc<ConnShared>, ctx: ConnContext) {
    let mut closing = shared.closing.subscribe();
    let mut buf: Vec<u8> = Vec::new();
    loop {
        tokio::select! {
            _ = shared.wake.notified() => {}
            _ = closing.wait_for(|c| *c) => return,
        }
        loop {
            if *closing.borrow() {
                return;
            }
            buf.clear();
            {
                let mut q = shared.queue.lock().unwrap_or_else(|p| p.into_inner());
                let now = ctx.clock.now();
                while buf.len() < WRITE_BATCH {
                    match q.pop(now) {
                        Some(m) => buf.extend_from_slice(&m.bytes),
                        None => break,
                    }
                }
            }
            if buf.is_empty() {
                break;
            }
            let result = tokio::select! {
                r = write.write_all(&buf) => r,
                _ = closing.wait_for(|c| *c) => return,
            };
            if let Err(e) = result {
                let _ = ctx
                    .core
                    .send(CoreEvent::Closed {
                        id: shared.id,
                        reason: format!("write error: {e}"),
                    })
                    .await;
                return;
            }
        }
        // Keep memory per idle connection small after a burst.
        if buf.capacity() > 64 * 1024 {
            buf = Vec::new();
        }
    }
}
