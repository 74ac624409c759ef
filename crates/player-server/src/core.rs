//! The core: one task that owns the drivers, the subscriptions and the schedule.
//!
//! Connection tasks send it `(client, message)` events; it answers DEV requests (and any
//! player-interface request queued behind a device message), hands device messages to drivers,
//! steps drivers on the [`Schedule`], and pushes replies and published DATA into the
//! connections' queues, waking each touched writer once per batch. Owning every driver in one
//! task keeps drivers free of locks and makes a run's order of events the order of the
//! messages, as upstream's single-threaded loop does.
//!
//! It runs on the I/O runtime rather than on a thread of its own: a woken task usually runs
//! next on the same worker, so a request goes reader → core → writer without a thread switch
//! (a separate core thread cost two cross-thread wake-ups per request, 165 µs instead of 30 µs
//! at p50 on the loaded 2-core machine). While a driver steps, the runtime's other workers
//! steal this worker's queued connection tasks; `block_in_place` around every step would hand
//! them over explicitly but costs a thread hand-off per step (fan-out fell 20-fold).

use std::collections::HashMap;
use std::sync::Arc;
use std::sync::atomic::Ordering;

use player_proto::{Body, Frame, Message, MsgHeader, MsgType};
use tokio::sync::{mpsc, watch};

use crate::clock::{Due, Schedule, ServerClock};
use crate::connection::{ConnShared, CoreEvent, Incoming};
use crate::device::{DeviceIndex, DeviceTable, DriverId};
use crate::driver::{ClientId, Context, Driver, DriverError, Publication, Reply};
use crate::player_iface::{self, PlayerInput, Session, Subscriptions, UnsubscribeError};
use crate::queue::{Outgoing, PushOutcome};

/// How long the core may step back to back (as fast as possible) before letting other tasks
/// on its worker run.
const FAST_YIELD: std::time::Duration = std::time::Duration::from_millis(2);

/// A driver as the core holds it.
pub(crate) struct DriverSlot {
    pub driver: Box<dyn Driver>,
    pub name: String,
    /// Current subscriptions to any of its devices (alwayson ones included).
    pub subscriptions: usize,
}

struct Conn {
    shared: Arc<ConnShared>,
    /// Devices this connection subscribed to, once per subscription.
    subs: Vec<DeviceIndex>,
    dirty: bool,
}

/// The core's state.
pub(crate) struct Core {
    pub table: Arc<DeviceTable>,
    pub drivers: Vec<DriverSlot>,
    /// Per device: subscribed clients, once per subscription (duplicates duplicate DATA).
    pub subscribers: Vec<Vec<ClientId>>,
    pub clock: ServerClock,
    pub clock_driver: Option<usize>,
    pub schedule: Schedule,
    pub events: mpsc::Receiver<CoreEvent>,
    pub stop: watch::Receiver<bool>,
    conns: HashMap<ClientId, Conn>,
    dirty: Vec<ClientId>,
    to_close: Vec<(ClientId, String)>,
    published: Vec<Publication>,
}

impl Core {
    /// A core over already started drivers (alwayson subscriptions done).
    pub fn new(
        table: Arc<DeviceTable>,
        drivers: Vec<DriverSlot>,
        clock: ServerClock,
        clock_driver: Option<usize>,
        mut schedule: Schedule,
        events: mpsc::Receiver<CoreEvent>,
        stop: watch::Receiver<bool>,
    ) -> Core {
        for (i, d) in drivers.iter().enumerate() {
            schedule.set_active(i, d.subscriptions > 0);
        }
        Core {
            subscribers: vec![Vec::new(); table.len()],
            table,
            drivers,
            clock,
            clock_driver,
            schedule,
            events,
            stop,
            conns: HashMap::new(),
            dirty: Vec::new(),
            to_close: Vec::new(),
            published: Vec::new(),
        }
    }

    /// Runs until the server stops or every connection task and acceptor is gone.
    pub async fn run(mut self) {
        let mut last_yield = std::time::Instant::now();
        loop {
            if *self.stop.borrow() {
                break;
            }
            // Answer everything already received before stepping anything.
            while let Ok(ev) = self.events.try_recv() {
                self.event(ev);
            }
            self.flush();
            match self.schedule.due() {
                Due::Now => {
                    self.tick();
                    self.flush();
                    // As fast as possible, steps follow each other at once. Yield now and then
                    // so this worker's writers run too, but not after every step: writers
                    // that find many messages queued send them in one write.
                    if last_yield.elapsed() >= FAST_YIELD {
                        tokio::task::yield_now().await;
                        last_yield = std::time::Instant::now();
                    }
                    continue;
                }
                Due::At(at) => {
                    tokio::select! {
                        biased;
                        _ = self.stop.changed() => {}
                        ev = self.events.recv() => match ev {
                            Some(ev) => self.event(ev),
                            None => break,
                        },
                        _ = tokio::time::sleep_until(at.into()) => {}
                    }
                }
                Due::Never => {
                    tokio::select! {
                        biased;
                        _ = self.stop.changed() => {}
                        ev = self.events.recv() => match ev {
                            Some(ev) => self.event(ev),
                            None => break,
                        },
                    }
                }
            }
            self.flush();
        }
        self.shutdown();
    }

    fn shutdown(&mut self) {
        let ids: Vec<ClientId> = self.conns.keys().copied().collect();
        for id in ids {
            self.close(id, "server shutting down");
        }
        for slot in &mut self.drivers {
            slot.driver.shutdown();
        }
    }

    fn event(&mut self, ev: CoreEvent) {
        match ev {
            CoreEvent::Opened(shared) => {
                self.conns.insert(
                    shared.id,
                    Conn {
                        shared,
                        subs: Vec::new(),
                        dirty: false,
                    },
                );
            }
            CoreEvent::Closed { id, reason } => self.close(id, &reason),
            CoreEvent::Message { id, input } => {
                if let Some(conn) = self.conns.get(&id) {
                    let shared = conn.shared.clone();
                    self.message(id, input);
                    shared.in_flight.fetch_sub(1, Ordering::AcqRel);
                }
            }
        }
        for (id, reason) in std::mem::take(&mut self.to_close) {
            self.close(id, &reason);
        }
    }

    /// Ends a connection: drops its subscriptions (telling the drivers) and stops its tasks.
    fn close(&mut self, id: ClientId, reason: &str) {
        let Some(conn) = self.conns.remove(&id) else {
            return;
        };
        conn.shared.close();
        if reason.starts_with("malformed") || reason.starts_with("not reading") {
            tracing::warn!("closing client {} ({}): {reason}", id.0, conn.shared.peer);
        } else {
            tracing::info!("closing client {} ({}): {reason}", id.0, conn.shared.peer);
        }
        let mut subs = SubscriptionBook {
            table: &self.table,
            drivers: &mut self.drivers,
            subscribers: &mut self.subscribers,
            schedule: &mut self.schedule,
            held: &mut Vec::new(),
            id,
        };
        for device in conn.subs.iter().rev() {
            subs.held.push(*device);
            if let Err(e) = subs.unsubscribe(*device) {
                tracing::warn!("unsubscribing closed client {}: {e}", id.0);
            }
        }
    }

    fn message(&mut self, id: ClientId, input: Incoming) {
        match input {
            Incoming::Player(msg) => self.player(id, PlayerInput::Typed(&msg)),
            Incoming::PlayerUntyped(header) => self.player(id, PlayerInput::Untyped(&header)),
            Incoming::Device { device, msg } => self.device_message(id, device, &msg),
            Incoming::DeviceUntyped { device, header } => {
                let kind = header.kind().ok();
                if kind == Some(MsgType::Req) {
                    tracing::warn!(
                        "client {}: request subtype {} is not in the {} interface; NACK",
                        id.0,
                        header.subtype,
                        header.addr.interf
                    );
                    let nack = device_reply_header(
                        &header,
                        self.table.get(device).addr,
                        MsgType::RespNack,
                        self.clock.now(),
                    );
                    self.push(id, Outgoing::header_only(nack));
                } else {
                    tracing::warn!(
                        "client {}: ignoring message type {} subtype {} to {}:{}",
                        id.0,
                        header.msg_type,
                        header.subtype,
                        header.addr.interf,
                        header.addr.index
                    );
                }
            }
        }
    }

    fn player(&mut self, id: ClientId, input: PlayerInput<'_>) {
        let now = self.clock.now();
        let Core {
            table,
            drivers,
            subscribers,
            schedule,
            conns,
            ..
        } = self;
        let Some(conn) = conns.get_mut(&id) else {
            return;
        };
        let shared = conn.shared.clone();
        let outcome = {
            let mut queue = shared.queue.lock().unwrap_or_else(|p| p.into_inner());
            let mut session = Session {
                table,
                port: shared.port,
                now,
                queue: &mut queue,
                peer: &shared.peer,
            };
            let mut book = SubscriptionBook {
                table,
                drivers,
                subscribers,
                schedule,
                held: &mut conn.subs,
                id,
            };
            player_iface::handle(input, &mut session, &mut book)
        };
        self.after_push(id, outcome);
    }

    fn device_message(&mut self, id: ClientId, device: DeviceIndex, msg: &Message) {
        let dev = self.table.get(device);
        let addr = dev.addr;
        let driver = dev.driver;
        let now = self.clock.now();
        let kind = msg.header.kind().ok();
        {
            let slot = &mut self.drivers[driver.0];
            let mut ctx = Context::new(now, Some(id), &mut self.published);
            match kind {
                Some(MsgType::Req) => {
                    let reply = slot.driver.handle_request(&mut ctx, msg);
                    let out = device_reply(&msg.header, addr, reply, now, &slot.name);
                    self.push(id, out);
                }
                Some(MsgType::Cmd) => slot.driver.handle_command(&mut ctx, msg),
                _ => tracing::warn!(
                    "client {}: ignoring {} message sent to {}:{}",
                    id.0,
                    msg.body.msg_type(),
                    addr.interf,
                    addr.index
                ),
            }
        }
        self.fan_out(driver, now);
    }

    /// Steps the drivers that are due, then delivers what they published.
    fn tick(&mut self) {
        for d in self.schedule.take_due() {
            let now = self.clock.now();
            let slot = &mut self.drivers[d];
            let mut ctx = Context::new(now, None, &mut self.published);
            slot.driver.update(&mut ctx);
            if self.clock_driver == Some(d) {
                if let Some(t) = slot.driver.clock() {
                    self.clock.set_simulated(t);
                }
            }
            self.fan_out(DriverId(d), now);
        }
    }

    /// Sends every pending publication of `driver` to the subscribers of its device: encoded
    /// once, shared by every queue.
    fn fan_out(&mut self, driver: DriverId, now: f64) {
        let pubs = std::mem::take(&mut self.published);
        for p in &pubs {
            let Some(device) = self.table.find(&p.addr) else {
                tracing::warn!(
                    "driver \"{}\" published for unknown device {}",
                    self.drivers[driver.0].name,
                    p.addr
                );
                continue;
            };
            let dev = self.table.get(device);
            if dev.driver != driver || p.body.msg_type() != MsgType::Data {
                tracing::warn!(
                    "driver \"{}\" published {} for {}, which it cannot",
                    self.drivers[driver.0].name,
                    p.body.constant(),
                    p.addr
                );
                continue;
            }
            if self.subscribers[device.0].is_empty() {
                continue;
            }
            let msg = Message::new(dev.addr, p.timestamp.unwrap_or(now), p.body.clone());
            let out = match Outgoing::from_message(&msg) {
                Ok(out) => out,
                Err(e) => {
                    tracing::error!(
                        "driver \"{}\" published an unencodable {}: {e}",
                        self.drivers[driver.0].name,
                        p.body.constant()
                    );
                    continue;
                }
            };
            for i in 0..self.subscribers[device.0].len() {
                let id = self.subscribers[device.0][i];
                self.push(id, out.clone());
            }
        }
        self.published = pubs;
        self.published.clear();
    }

    fn push(&mut self, id: ClientId, out: Outgoing) {
        let outcome = self.conns.get(&id).map(|conn| {
            conn.shared
                .queue
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .push(out)
        });
        self.after_push(id, outcome);
    }

    fn after_push(&mut self, id: ClientId, outcome: Option<PushOutcome>) {
        let Some(conn) = self.conns.get_mut(&id) else {
            return;
        };
        match outcome {
            Some(PushOutcome::Overloaded) => self.to_close.push((
                id,
                "not reading: outgoing queue exceeded its hard limit".to_string(),
            )),
            Some(_) if !conn.dirty => {
                conn.dirty = true;
                self.dirty.push(id);
            }
            _ => {}
        }
    }

    /// Wakes every writer whose queue changed.
    fn flush(&mut self) {
        for (id, reason) in std::mem::take(&mut self.to_close) {
            self.close(id, &reason);
        }
        for id in self.dirty.drain(..) {
            if let Some(conn) = self.conns.get_mut(&id) {
                conn.dirty = false;
                conn.shared.wake.notify_one();
            }
        }
    }
}

/// The subscription bookkeeping of one connection, over the core's tables.
struct SubscriptionBook<'a> {
    table: &'a DeviceTable,
    drivers: &'a mut [DriverSlot],
    subscribers: &'a mut [Vec<ClientId>],
    schedule: &'a mut Schedule,
    held: &'a mut Vec<DeviceIndex>,
    id: ClientId,
}

impl Subscriptions for SubscriptionBook<'_> {
    fn subscribe(&mut self, device: DeviceIndex) -> Result<(), DriverError> {
        let dev = self.table.get(device);
        let slot = &mut self.drivers[dev.driver.0];
        slot.driver.subscribe(dev.addr)?;
        slot.subscriptions += 1;
        if slot.subscriptions == 1 {
            self.schedule.set_active(dev.driver.0, true);
        }
        self.held.push(device);
        self.subscribers[device.0].push(self.id);
        Ok(())
    }

    fn unsubscribe(&mut self, device: DeviceIndex) -> Result<(), UnsubscribeError> {
        let pos = self
            .held
            .iter()
            .rposition(|&d| d == device)
            .ok_or(UnsubscribeError::NotSubscribed)?;
        self.held.remove(pos);
        let list = &mut self.subscribers[device.0];
        if let Some(p) = list.iter().rposition(|&c| c == self.id) {
            list.remove(p);
        }
        let dev = self.table.get(device);
        let slot = &mut self.drivers[dev.driver.0];
        slot.subscriptions = slot.subscriptions.saturating_sub(1);
        if slot.subscriptions == 0 {
            self.schedule.set_active(dev.driver.0, false);
        }
        slot.driver.client_unsubscribed(dev.addr, self.id);
        slot.driver
            .unsubscribe(dev.addr)
            .map_err(UnsubscribeError::Driver)
    }
}

/// Header of a device's reply (§4.4): the device's address, the request's subtype, `seq` 0.
fn device_reply_header(
    req: &MsgHeader,
    addr: player_proto::DeviceAddr,
    kind: MsgType,
    now: f64,
) -> MsgHeader {
    MsgHeader::new(addr, kind, req.subtype, now)
}

/// Encodes a driver's [`Reply`]. A body that does not fit the request (another subtype or
/// interface, or one that cannot be encoded) is a driver bug: logged, and answered with NACK so
/// the client is not left waiting.
fn device_reply(
    req: &MsgHeader,
    addr: player_proto::DeviceAddr,
    reply: Reply,
    now: f64,
    driver: &str,
) -> Outgoing {
    let nack = || Outgoing::header_only(device_reply_header(req, addr, MsgType::RespNack, now));
    match reply {
        Reply::Nack => nack(),
        Reply::NotHandled => {
            tracing::debug!(
                "driver \"{driver}\" does not handle request subtype {} on {}:{}; NACK",
                req.subtype,
                addr.interf,
                addr.index
            );
            nack()
        }
        Reply::Ack(None) => {
            Outgoing::header_only(device_reply_header(req, addr, MsgType::RespAck, now))
        }
        Reply::Ack(Some(body)) => match ack_body(req, addr, &body) {
            Ok(bytes) => {
                let header = device_reply_header(req, addr, MsgType::RespAck, now);
                match Frame::new(header, bytes) {
                    Ok(frame) => Outgoing::from_frame(&frame),
                    Err(e) => {
                        tracing::error!("driver \"{driver}\": reply too large: {e}");
                        nack()
                    }
                }
            }
            Err(e) => {
                tracing::error!(
                    "driver \"{driver}\" answered {} on {}:{} with an unusable body: {e}",
                    req.subtype,
                    addr.interf,
                    addr.index
                );
                nack()
            }
        },
    }
}

fn ack_body(
    req: &MsgHeader,
    addr: player_proto::DeviceAddr,
    body: &Body,
) -> Result<Vec<u8>, String> {
    if !matches!(body.msg_type(), MsgType::Req | MsgType::RespAck) {
        return Err(format!("{} is not a request body", body.constant()));
    }
    if body.subtype() != req.subtype || body.interface().is_some_and(|i| i != addr.interf) {
        return Err(format!("{} does not answer this request", body.constant()));
    }
    body.encode().map_err(|e| e.to_string())
}
