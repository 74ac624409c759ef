//! The core: one task that owns the drivers, the subscriptions and the schedule.
//!
//! Connection tasks send it `(client, message)` events; it answers DEV requests (and any
//! player-interface request queued behind a device message), hands device messages to drivers,
//! steps drivers on the [`Schedule`], and pushes replies and published DATA into the
//! connections' queues, waking each touched writer once per batch.
//!
//! Drivers use each other's devices through the [`Bus`]: a driver subscribed to a device
//! receives its DATA, and its commands, requests and deferred answers are carried out by the
//! core after its callback returns, as queued [`Work`]. No driver ever runs inside another, so
//! a chain needs no locks, and a local hop costs a queue push, not a TCP round trip. Owning every driver in one
//! task keeps drivers free of locks and makes a run's order of events the order of the
//! messages, as upstream's single-threaded loop does.
//!
//! It runs on the I/O runtime rather than on a thread of its own: a woken task usually runs
//! next on the same worker, so a request goes reader → core → writer without a thread switch
//! (a separate core thread cost two cross-thread wake-ups per request, 165 µs instead of 30 µs
//! at p50 on the loaded 2-core machine). While a driver steps, the runtime's other workers
//! steal this worker's queued connection tasks; `block_in_place` around every step would hand
//! them over explicitly but costs a thread hand-off per step (fan-out fell 20-fold).

use std::any::Any;
use std::collections::{HashMap, VecDeque};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use player_proto::{Body, DecodeLimits, DeviceAddr, Frame, Message, MsgHeader, MsgType};
use tokio::sync::{mpsc, watch};

use crate::clock::{Due, Schedule, ServerClock};
use crate::connection::{ConnShared, CoreEvent, Incoming};
use crate::device::{DeviceIndex, DeviceTable, DriverId};
use crate::driver::{
    Action, ClientId, Context, Driver, DriverError, DriverWaker, PendingReply, Publication, Reply,
    RequestError, RequestTicket,
};
use crate::player_iface::{
    self, PlayerInput, Session, Subscriptions, UnsubscribeError, release_held,
};
use crate::queue::{Outgoing, PushOutcome};
use crate::worker::panic_text;

/// How long the core may step back to back (as fast as possible) before letting other tasks
/// on its worker run.
const FAST_YIELD: std::time::Duration = std::time::Duration::from_millis(2);

/// How many queued driver-to-driver deliveries one pass handles before the core looks at its
/// clients again (a chain that feeds itself must not starve them).
const WORK_PER_PASS: usize = 4096;

/// A driver as the core holds it.
pub(crate) struct DriverSlot {
    pub driver: Box<dyn Driver>,
    pub name: String,
    /// Current subscriptions to any of its devices (alwayson ones included).
    pub subscriptions: usize,
}

/// Who holds a subscription to a device.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Subscriber {
    /// A TCP client.
    Client(ClientId),
    /// Another driver (a `requires`).
    Driver(DriverId),
    /// The server itself, for alwayson drivers: never released.
    AlwaysOn,
}

/// Who waits for the answer to a deferred request.
#[derive(Clone, Copy, Debug)]
enum Requester {
    Client {
        id: ClientId,
        header: MsgHeader,
        addr: DeviceAddr,
        driver: DriverId,
    },
    Driver {
        from: DriverId,
        ticket: RequestTicket,
        header: MsgHeader,
        addr: DeviceAddr,
        driver: DriverId,
    },
}

impl Requester {
    /// The driver that owes the answer.
    fn driver(&self) -> DriverId {
        match *self {
            Requester::Client { driver, .. } | Requester::Driver { driver, .. } => driver,
        }
    }
}

/// A delivery between drivers, done by the core after the callback that caused it.
#[derive(Debug)]
enum Work {
    Data {
        to: DriverId,
        device: DeviceIndex,
        msg: Message,
    },
    Command {
        to: DriverId,
        msg: Message,
    },
    Request {
        from: DriverId,
        ticket: RequestTicket,
        to: DriverId,
        msg: Message,
    },
    Reply {
        to: DriverId,
        ticket: RequestTicket,
        result: Result<Message, RequestError>,
    },
    Wake(DriverId),
}

/// Per-driver bookkeeping beside its slot.
struct DriverState {
    /// Devices this driver subscribed to, once per subscription.
    holds: Vec<DeviceIndex>,
    /// Set while its setup runs, so a subscription cycle is refused instead of recursing.
    setting_up: bool,
    waker: DriverWaker,
    woken: Arc<AtomicBool>,
    /// Set when one of its callbacks panicked: why it is out of service. Its state may be
    /// half-updated, so it is never called again (not even `shutdown`); its devices refuse
    /// subscriptions and requests with this text.
    failed: Option<String>,
}

/// The drivers, their devices' subscribers and everything that passes between them.
pub(crate) struct Bus {
    pub table: Arc<DeviceTable>,
    pub drivers: Vec<DriverSlot>,
    state: Vec<DriverState>,
    /// Per device: its subscribers, once per subscription (duplicates duplicate DATA).
    subscribers: Vec<Vec<Subscriber>>,
    pub clock: ServerClock,
    pub clock_driver: Option<usize>,
    pub schedule: Schedule,
    published: Vec<Publication>,
    work: VecDeque<Work>,
    pending: HashMap<u64, Requester>,
    next_id: u64,
    /// Messages for clients, moved into their queues by the core.
    to_clients: Vec<(ClientId, Outgoing)>,
}

impl Bus {
    /// A bus over built drivers, none subscribed yet; `wake` is where their wakers send.
    pub fn new(
        table: Arc<DeviceTable>,
        drivers: Vec<DriverSlot>,
        clock: ServerClock,
        clock_driver: Option<usize>,
        schedule: Schedule,
        wake: mpsc::UnboundedSender<DriverId>,
    ) -> Bus {
        let state = (0..drivers.len())
            .map(|i| {
                let woken = Arc::new(AtomicBool::new(false));
                DriverState {
                    holds: Vec::new(),
                    setting_up: false,
                    waker: DriverWaker::new(DriverId(i), wake.clone(), woken.clone()),
                    woken,
                    failed: None,
                }
            })
            .collect();
        Bus {
            subscribers: vec![Vec::new(); table.len()],
            table,
            drivers,
            state,
            clock,
            clock_driver,
            schedule,
            published: Vec::new(),
            work: VecDeque::new(),
            pending: HashMap::new(),
            next_id: 1,
            to_clients: Vec::new(),
        }
    }

    /// Runs one driver callback with a full context; returns its result, what it asked for,
    /// and whether it took the request it was handling ([`Context::defer`]). `None` when the
    /// driver is out of service, or panicked in this callback (`what`, for the log): what it
    /// asked for and published in it is dropped, and it is taken out of service
    /// ([`Bus::fail`]).
    fn call<R>(
        &mut self,
        d: DriverId,
        what: &str,
        client: Option<ClientId>,
        request: Option<PendingReply>,
        f: impl FnOnce(&mut dyn Driver, &mut Context<'_>) -> R,
    ) -> Option<(R, Vec<Action>, bool)> {
        if self.state[d.0].failed.is_some() {
            return None;
        }
        let now = self.clock.now();
        let waker = self.state[d.0].waker.clone();
        let published_before = self.published.len();
        let mut ctx =
            Context::new(now, client, &mut self.published).with_core(self.next_id, request, waker);
        let driver = self.drivers[d.0].driver.as_mut();
        // The driver is never called again after a panic, so its possibly broken state is
        // never observed: asserting unwind safety is sound here.
        let outcome = catch_unwind(AssertUnwindSafe(|| f(driver, &mut ctx)));
        let deferred = request.is_some() && ctx.defer().is_none();
        let (actions, next) = ctx.finish();
        self.next_id = next;
        match outcome {
            Ok(r) => Some((r, actions, deferred)),
            Err(payload) => {
                self.published.truncate(published_before);
                self.fail(d, what, payload.as_ref());
                None
            }
        }
    }

    /// Calls a context-free method of driver `d` (`subscribe`, `unsubscribe`, `clock`, ...),
    /// as [`Bus::call`] does: `None` when the driver is out of service or panicked.
    fn call_plain<R>(
        &mut self,
        d: DriverId,
        what: &str,
        f: impl FnOnce(&mut dyn Driver) -> R,
    ) -> Option<R> {
        if self.state[d.0].failed.is_some() {
            return None;
        }
        let driver = self.drivers[d.0].driver.as_mut();
        match catch_unwind(AssertUnwindSafe(|| f(driver))) {
            Ok(r) => Some(r),
            Err(payload) => {
                self.fail(d, what, payload.as_ref());
                None
            }
        }
    }

    /// Takes driver `d`, whose `what` callback panicked, out of service, as a crashed driver
    /// of upstream would be had it not taken the whole server with it: the panic is logged
    /// naming the driver and its devices; every subscription to its devices is dropped (their
    /// clients get no more data, a new subscription is refused, a request is NACKed); the
    /// requests it was still to answer are NACKed now; what it had subscribed to is
    /// released. Every other driver and client carries on.
    fn fail(&mut self, d: DriverId, what: &str, payload: &(dyn Any + Send)) {
        let cause = panic_text(payload);
        let devices: Vec<DeviceIndex> = (0..self.table.len())
            .map(DeviceIndex)
            .filter(|&i| self.table.get(i).driver == d)
            .collect();
        let names: Vec<String> = devices
            .iter()
            .map(|&i| {
                let a = self.table.get(i).addr;
                format!("{}:{}:{}", a.robot, a.interf, a.index)
            })
            .collect();
        let origin = devices
            .first()
            .map(|&i| self.table.get(i).origin.clone())
            .unwrap_or_default();
        let name = self.drivers[d.0].name.clone();
        tracing::error!(
            "driver \"{name}\" ({origin}) panicked in {what}: {cause}; its devices ({}) are out of \
             service: their subscriptions are dropped and their requests refused; the server \
             carries on",
            names.join(", ")
        );
        self.state[d.0].failed = Some(format!(
            "driver \"{name}\" is out of service: it panicked in {what}: {cause}"
        ));
        self.state[d.0].setting_up = false;
        self.schedule.set_active(d.0, false);
        for &device in &devices {
            self.subscribers[device.0].clear();
        }
        self.drivers[d.0].subscriptions = 0;
        let owed: Vec<u64> = self
            .pending
            .iter()
            .filter(|(_, r)| r.driver() == d)
            .map(|(&token, _)| token)
            .collect();
        for token in owed {
            if let Some(requester) = self.pending.remove(&token) {
                self.deliver_reply(requester, Reply::Nack);
            }
        }
        self.release_all(d);
    }

    /// Why driver `d` is out of service, if it is.
    fn failure(&self, d: DriverId) -> Option<&str> {
        self.state[d.0].failed.as_deref()
    }

    /// Runs a callback and carries out what it asked for, then delivers what it published.
    fn run(&mut self, d: DriverId, what: &str, f: impl FnOnce(&mut dyn Driver, &mut Context<'_>)) {
        self.run_for(d, what, None, f);
    }

    /// As [`Bus::run`], for a message from `client` (drivers keep per-client state, e.g.
    /// Stage's graphics are drawn per client).
    fn run_for(
        &mut self,
        d: DriverId,
        what: &str,
        client: Option<ClientId>,
        f: impl FnOnce(&mut dyn Driver, &mut Context<'_>),
    ) {
        if let Some(((), actions, _)) = self.call(d, what, client, None, f) {
            self.act(d, actions);
        }
        self.fan_out(d);
    }

    fn fresh_id(&mut self) -> u64 {
        let id = self.next_id;
        self.next_id += 1;
        id
    }

    /// Subscribes `sub` to `device`, setting its driver up (and, through its `requires`, the
    /// chain below it) on the first subscription.
    pub fn subscribe(&mut self, sub: Subscriber, device: DeviceIndex) -> Result<(), DriverError> {
        let dev = self.table.get(device);
        let (addr, d) = (dev.addr, dev.driver);
        if let Some(why) = self.failure(d) {
            return Err(DriverError::new(why));
        }
        if self.state[d.0].setting_up {
            return Err(DriverError::new(format!(
                "subscription cycle: driver \"{}\" is still being set up",
                self.drivers[d.0].name
            )));
        }
        match self.call_plain(d, "subscribe", |drv| drv.subscribe(addr)) {
            Some(result) => result?,
            None => return Err(self.out_of_service(d)),
        }
        if self.drivers[d.0].subscriptions == 0 {
            if let Err(e) = self.setup(d) {
                let _ = self.call_plain(d, "unsubscribe", |drv| drv.unsubscribe(addr));
                return Err(e);
            }
        }
        let slot = &mut self.drivers[d.0];
        slot.subscriptions += 1;
        if slot.subscriptions == 1 {
            self.schedule.set_active(d.0, true);
        }
        self.subscribers[device.0].push(sub);
        Ok(())
    }

    /// The driver's setup, with the subscriptions it asks for carried out at once: one that
    /// fails undoes the others and fails the setup.
    fn setup(&mut self, d: DriverId) -> Result<(), DriverError> {
        self.state[d.0].setting_up = true;
        let Some((result, actions, _)) =
            self.call(d, "setup", None, None, |drv, ctx| drv.setup(ctx))
        else {
            return Err(self.out_of_service(d));
        };
        let mut result = result;
        let mut rest = Vec::new();
        for action in actions {
            match action {
                Action::Subscribe(addr) if result.is_ok() => {
                    if let Err(e) = self.hold(d, addr) {
                        result = Err(DriverError::new(format!("cannot subscribe to {addr}: {e}")));
                    }
                }
                Action::Subscribe(_) => {}
                other => rest.push(other),
            }
        }
        self.state[d.0].setting_up = false;
        if result.is_err() {
            self.release_all(d);
            // What it queued before failing (requests to its inputs) has no one to answer.
            self.fan_out(d);
            return result;
        }
        self.act(d, rest);
        self.fan_out(d);
        Ok(())
    }

    /// Subscribes driver `d` to the device at `addr`.
    fn hold(&mut self, d: DriverId, addr: DeviceAddr) -> Result<(), DriverError> {
        let device = self
            .table
            .find(&addr)
            .ok_or_else(|| DriverError::new(format!("no device {addr}")))?;
        self.subscribe(Subscriber::Driver(d), device)?;
        self.state[d.0].holds.push(device);
        Ok(())
    }

    /// Ends every subscription driver `d` holds, last first.
    fn release_all(&mut self, d: DriverId) {
        while let Some(device) = self.state[d.0].holds.pop() {
            if let Err(e) = self.unsubscribe(Subscriber::Driver(d), device) {
                tracing::warn!(
                    "driver \"{}\" releasing {}: {e}",
                    self.drivers[d.0].name,
                    self.table.get(device).addr
                );
            }
        }
    }

    /// Ends one subscription of `sub` to `device`; the driver's last one tears it (and what it
    /// holds) down.
    pub fn unsubscribe(&mut self, sub: Subscriber, device: DeviceIndex) -> Result<(), DriverError> {
        let dev = self.table.get(device);
        let (addr, d) = (dev.addr, dev.driver);
        let list = &mut self.subscribers[device.0];
        if let Some(p) = list.iter().rposition(|&s| s == sub) {
            list.remove(p);
        }
        if self.failure(d).is_some() {
            // Its subscriptions were dropped when it failed; nothing more to undo.
            return Ok(());
        }
        if let Subscriber::Client(c) = sub {
            self.call_plain(d, "client_unsubscribed", |drv| {
                drv.client_unsubscribed(addr, c)
            });
        }
        let Some(result) = self.call_plain(d, "unsubscribe", |drv| drv.unsubscribe(addr)) else {
            return Ok(());
        };
        let slot = &mut self.drivers[d.0];
        slot.subscriptions = slot.subscriptions.saturating_sub(1);
        if slot.subscriptions == 0 {
            self.schedule.set_active(d.0, false);
            self.run(d, "teardown", |drv, ctx| drv.teardown(ctx));
            self.release_all(d);
        }
        result
    }

    /// Carries out a driver's actions: subscriptions now, deliveries queued.
    fn act(&mut self, d: DriverId, actions: Vec<Action>) {
        let now = self.clock.now();
        for action in actions {
            match action {
                Action::Subscribe(addr) => {
                    if let Err(e) = self.hold(d, addr) {
                        tracing::warn!(
                            "driver \"{}\" could not subscribe to {addr}: {e}",
                            self.drivers[d.0].name
                        );
                    }
                }
                Action::Unsubscribe(addr) => {
                    let found = self.table.find(&addr).and_then(|device| {
                        let holds = &mut self.state[d.0].holds;
                        let p = holds.iter().rposition(|&h| h == device)?;
                        holds.remove(p);
                        Some(device)
                    });
                    match found {
                        Some(device) => {
                            if let Err(e) = self.unsubscribe(Subscriber::Driver(d), device) {
                                tracing::warn!("driver \"{}\": {e}", self.drivers[d.0].name);
                            }
                        }
                        None => tracing::warn!(
                            "driver \"{}\" unsubscribed from {addr}, which it does not hold",
                            self.drivers[d.0].name
                        ),
                    }
                }
                Action::Command(addr, body) => match self.table.find(&addr) {
                    Some(device) => {
                        let dev = self.table.get(device);
                        let msg = Message::new(dev.addr, now, body);
                        self.work.push_back(Work::Command {
                            to: dev.driver,
                            msg,
                        });
                    }
                    None => tracing::warn!(
                        "driver \"{}\" commanded {addr}, which no driver provides",
                        self.drivers[d.0].name
                    ),
                },
                Action::Request(ticket, addr, body) => match self.table.find(&addr) {
                    Some(device) => {
                        let dev = self.table.get(device);
                        let msg = Message::new(dev.addr, now, body);
                        self.work.push_back(Work::Request {
                            from: d,
                            ticket,
                            to: dev.driver,
                            msg,
                        });
                    }
                    None => self.work.push_back(Work::Reply {
                        to: d,
                        ticket,
                        result: Err(RequestError::NoDevice(addr)),
                    }),
                },
                Action::Answer(pending, reply) => match self.pending.remove(&pending.0) {
                    Some(requester) => self.deliver_reply(requester, reply),
                    None => tracing::debug!(
                        "driver \"{}\" answered request {} that nobody waits for",
                        self.drivers[d.0].name,
                        pending.0
                    ),
                },
            }
        }
    }

    /// A client's request to a device of driver `d`.
    fn client_request(&mut self, id: ClientId, d: DriverId, addr: DeviceAddr, msg: &Message) {
        let token = self.fresh_id();
        let requester = Requester::Client {
            id,
            header: msg.header,
            addr,
            driver: d,
        };
        let called = self.call(
            d,
            "handle_request",
            Some(id),
            Some(PendingReply(token)),
            |drv, ctx| drv.handle_request(ctx, msg),
        );
        let Some((reply, actions, deferred)) = called else {
            tracing::debug!("client {}: {}; NACK", id.0, self.out_of_service(d));
            self.deliver_reply(requester, Reply::Nack);
            return;
        };
        self.settle(token, requester, reply, deferred);
        self.act(d, actions);
        self.fan_out(d);
    }

    /// Records a deferred request, or delivers an immediate reply.
    fn settle(&mut self, token: u64, requester: Requester, reply: Reply, deferred: bool) {
        match (reply, deferred) {
            (Reply::Deferred, true) => {
                self.pending.insert(token, requester);
            }
            (Reply::Deferred, false) => {
                let d = requester.driver();
                tracing::error!(
                    "driver \"{}\" deferred a request without taking it (Context::defer); NACK",
                    self.drivers[d.0].name
                );
                self.deliver_reply(requester, Reply::Nack);
            }
            (reply, _) => self.deliver_reply(requester, reply),
        }
    }

    fn deliver_reply(&mut self, requester: Requester, reply: Reply) {
        let now = self.clock.now();
        match requester {
            Requester::Client {
                id,
                header,
                addr,
                driver,
            } => {
                let out = device_reply(&header, addr, reply, now, &self.drivers[driver.0].name);
                self.to_clients.push((id, out));
            }
            Requester::Driver {
                from,
                ticket,
                header,
                addr,
                driver,
            } => {
                let result = reply_message(&header, addr, reply, now, &self.drivers[driver.0].name);
                self.work.push_back(Work::Reply {
                    to: from,
                    ticket,
                    result,
                });
            }
        }
    }

    /// Steps the drivers that are due.
    pub fn tick(&mut self) {
        for d in self.schedule.take_due() {
            let id = DriverId(d);
            self.run(id, "update", |drv, ctx| drv.update(ctx));
            if self.clock_driver == Some(d) {
                if let Some(Some(t)) = self.call_plain(id, "clock", |drv| drv.clock()) {
                    self.clock.set_simulated(t);
                }
            }
        }
    }

    /// Handles queued deliveries between drivers, at most [`WORK_PER_PASS`] of them.
    pub fn pump(&mut self) {
        for _ in 0..WORK_PER_PASS {
            let Some(work) = self.work.pop_front() else {
                return;
            };
            match work {
                Work::Data { to, device, msg } => {
                    // Data queued before the driver let go of the device is not its any more.
                    if self.state[to.0].holds.contains(&device) {
                        self.run(to, "handle_data", |drv, ctx| drv.handle_data(ctx, &msg));
                    }
                }
                Work::Command { to, msg } => self.run(to, "handle_command", |drv, ctx| {
                    drv.handle_command(ctx, &msg)
                }),
                Work::Reply { to, ticket, result } => self.run(to, "handle_reply", |drv, ctx| {
                    drv.handle_reply(ctx, ticket, result)
                }),
                Work::Wake(d) => {
                    self.state[d.0].woken.store(false, Ordering::Release);
                    self.run(d, "wake", |drv, ctx| drv.wake(ctx));
                }
                Work::Request {
                    from,
                    ticket,
                    to,
                    msg,
                } => {
                    let token = self.fresh_id();
                    let called = self.call(
                        to,
                        "handle_request",
                        None,
                        Some(PendingReply(token)),
                        |drv, ctx| drv.handle_request(ctx, &msg),
                    );
                    let Some((reply, actions, deferred)) = called else {
                        let why = self.out_of_service(to);
                        self.work.push_back(Work::Reply {
                            to: from,
                            ticket,
                            result: Err(RequestError::Failed(why.0)),
                        });
                        continue;
                    };
                    let requester = Requester::Driver {
                        from,
                        ticket,
                        header: msg.header,
                        addr: msg.header.addr,
                        driver: to,
                    };
                    self.settle(token, requester, reply, deferred);
                    self.act(to, actions);
                    self.fan_out(to);
                }
            }
        }
        if !self.work.is_empty() {
            tracing::debug!(
                "{} driver deliveries wait for the next pass",
                self.work.len()
            );
        }
    }

    /// Whether deliveries are waiting.
    pub fn busy(&self) -> bool {
        !self.work.is_empty()
    }

    /// Queues a wake-up of driver `d` (from its [`DriverWaker`]).
    pub fn wake(&mut self, d: DriverId) {
        if d.0 < self.drivers.len() {
            self.work.push_back(Work::Wake(d));
        }
    }

    /// Delivers every pending publication of `driver` to the subscribers of its device: encoded
    /// once for every client queue, typed for subscribed drivers.
    fn fan_out(&mut self, driver: DriverId) {
        if self.published.is_empty() {
            return;
        }
        let now = self.clock.now();
        let mut pubs = std::mem::take(&mut self.published);
        for p in pubs.drain(..) {
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
            let name = &self.drivers[driver.0].name;
            if let Some(id) = p.to {
                let msg = Message::new(dev.addr, p.timestamp.unwrap_or(now), p.body);
                if let Some(out) = encoded_for_clients(name, &msg) {
                    self.to_clients.push((id, out));
                }
                continue;
            }
            if self.subscribers[device.0].is_empty() {
                continue;
            }
            let msg = Message::new(dev.addr, p.timestamp.unwrap_or(now), p.body);
            let mut encoded: Option<Outgoing> = None;
            for i in 0..self.subscribers[device.0].len() {
                match self.subscribers[device.0][i] {
                    Subscriber::Client(id) => {
                        if encoded.is_none() {
                            encoded = encoded_for_clients(name, &msg);
                            if encoded.is_none() {
                                break;
                            }
                        }
                        if let Some(out) = &encoded {
                            self.to_clients.push((id, out.clone()));
                        }
                    }
                    Subscriber::Driver(to) => self.work.push_back(Work::Data {
                        to,
                        device,
                        msg: msg.clone(),
                    }),
                    Subscriber::AlwaysOn => {}
                }
            }
        }
        self.published = pubs;
    }

    /// The server is stopping: every driver hears it.
    fn shutdown(&mut self) {
        for d in 0..self.drivers.len() {
            self.call_plain(DriverId(d), "shutdown", |drv| drv.shutdown());
        }
    }

    /// The error of a driver that is out of service (after a panic in a call just made).
    fn out_of_service(&self, d: DriverId) -> DriverError {
        DriverError::new(self.failure(d).unwrap_or("driver is out of service"))
    }
}

/// `msg`, published by driver `driver`, encoded once for every client queue it goes to; an
/// unencodable one is logged and goes nowhere.
fn encoded_for_clients(driver: &str, msg: &Message) -> Option<Outgoing> {
    Outgoing::from_message(msg)
        .map_err(|e| {
            tracing::error!(
                "driver \"{driver}\" published an unencodable {}: {e}",
                msg.body.constant()
            )
        })
        .ok()
}

struct Conn {
    shared: Arc<ConnShared>,
    /// Devices this connection subscribed to, once per subscription.
    subs: Vec<DeviceIndex>,
    dirty: bool,
}

/// The core's state.
pub(crate) struct Core {
    bus: Bus,
    events: mpsc::Receiver<CoreEvent>,
    wakes: mpsc::UnboundedReceiver<DriverId>,
    stop: watch::Receiver<bool>,
    conns: HashMap<ClientId, Conn>,
    dirty: Vec<ClientId>,
    to_close: Vec<(ClientId, String)>,
}

impl Core {
    /// A core over a bus whose alwayson drivers are already subscribed.
    pub fn new(
        bus: Bus,
        events: mpsc::Receiver<CoreEvent>,
        wakes: mpsc::UnboundedReceiver<DriverId>,
        stop: watch::Receiver<bool>,
    ) -> Core {
        Core {
            bus,
            events,
            wakes,
            stop,
            conns: HashMap::new(),
            dirty: Vec::new(),
            to_close: Vec::new(),
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
            while let Ok(d) = self.wakes.try_recv() {
                self.bus.wake(d);
            }
            self.settle();
            let due = if self.bus.busy() {
                Due::Now
            } else {
                self.bus.schedule.due()
            };
            match due {
                Due::Now => {
                    if !self.bus.busy() {
                        self.bus.tick();
                    }
                    self.settle();
                    // As fast as possible, steps follow each other at once. Yield now and then
                    // so this worker's writers run too, but not after every step: writers
                    // that find many messages queued send them in one write.
                    if last_yield.elapsed() >= FAST_YIELD {
                        tokio::task::yield_now().await;
                        last_yield = std::time::Instant::now();
                    }
                    continue;
                }
                Due::At(_) | Due::Never => {
                    // Until the next step is due, if any: Never waits for messages only.
                    let step = async {
                        match due {
                            Due::At(at) => tokio::time::sleep_until(at.into()).await,
                            _ => std::future::pending().await,
                        }
                    };
                    tokio::select! {
                        biased;
                        _ = self.stop.changed() => {}
                        ev = self.events.recv() => match ev {
                            Some(ev) => self.event(ev),
                            None => break,
                        },
                        Some(d) = self.wakes.recv() => self.bus.wake(d),
                        _ = step => {}
                    }
                }
            }
            self.settle();
        }
        self.shutdown();
    }

    /// Runs queued driver deliveries, moves what the bus produced for clients into their
    /// queues, and wakes the writers.
    fn settle(&mut self) {
        self.bus.pump();
        self.deliver();
        self.flush();
    }

    fn shutdown(&mut self) {
        let ids: Vec<ClientId> = self.conns.keys().copied().collect();
        for id in ids {
            self.close(id, "server shutting down");
        }
        self.deliver();
        self.bus.shutdown();
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
        self.deliver();
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
        for device in conn.subs.iter().rev() {
            if let Err(e) = self.bus.unsubscribe(Subscriber::Client(id), *device) {
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
                        self.bus.table.get(device).addr,
                        MsgType::RespNack,
                        self.bus.clock.now(),
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
        let now = self.bus.clock.now();
        let table = self.bus.table.clone();
        let Some(conn) = self.conns.get_mut(&id) else {
            return;
        };
        let shared = conn.shared.clone();
        let outcome = {
            let mut queue = shared.queue.lock().unwrap_or_else(|p| p.into_inner());
            let mut session = Session {
                table: &table,
                port: shared.port,
                now,
                queue: &mut queue,
                peer: &shared.peer,
            };
            let mut book = SubscriptionBook {
                bus: &mut self.bus,
                held: &mut conn.subs,
                id,
            };
            player_iface::handle(input, &mut session, &mut book)
        };
        self.after_push(id, outcome);
    }

    fn device_message(&mut self, id: ClientId, device: DeviceIndex, msg: &Message) {
        let dev = self.bus.table.get(device);
        let (addr, driver) = (dev.addr, dev.driver);
        match msg.header.kind().ok() {
            Some(MsgType::Req) => self.bus.client_request(id, driver, addr, msg),
            Some(MsgType::Cmd) => {
                self.bus
                    .run_for(driver, "handle_command", Some(id), |drv, ctx| {
                        drv.handle_command(ctx, msg)
                    })
            }
            _ => tracing::warn!(
                "client {}: ignoring {} message sent to {}:{}",
                id.0,
                msg.body.msg_type(),
                addr.interf,
                addr.index
            ),
        }
    }

    /// Moves what the bus produced for clients into their queues.
    fn deliver(&mut self) {
        let mut out = std::mem::take(&mut self.bus.to_clients);
        for (id, msg) in out.drain(..) {
            self.push(id, msg);
        }
        if self.bus.to_clients.is_empty() {
            self.bus.to_clients = out;
        }
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
        self.deliver();
        for id in self.dirty.drain(..) {
            if let Some(conn) = self.conns.get_mut(&id) {
                conn.dirty = false;
                conn.shared.wake.notify_one();
            }
        }
    }
}

/// The subscription bookkeeping of one connection, over the core's bus.
struct SubscriptionBook<'a> {
    bus: &'a mut Bus,
    held: &'a mut Vec<DeviceIndex>,
    id: ClientId,
}

impl Subscriptions for SubscriptionBook<'_> {
    fn subscribe(&mut self, device: DeviceIndex) -> Result<(), DriverError> {
        self.bus.subscribe(Subscriber::Client(self.id), device)?;
        self.held.push(device);
        Ok(())
    }

    fn unsubscribe(&mut self, device: DeviceIndex) -> Result<(), UnsubscribeError> {
        release_held(self.held, device)?;
        self.bus
            .unsubscribe(Subscriber::Client(self.id), device)
            .map_err(UnsubscribeError::Driver)
    }
}

/// A driver's [`Reply`] as the requesting driver sees it: the ACK as a message (header
/// RESP_ACK from the device), or why there is none.
fn reply_message(
    req: &MsgHeader,
    addr: DeviceAddr,
    reply: Reply,
    now: f64,
    driver: &str,
) -> Result<Message, RequestError> {
    let header = device_reply_header(req, addr, MsgType::RespAck, now);
    match reply {
        Reply::Nack | Reply::NotHandled => Err(RequestError::Nack),
        Reply::Deferred => Err(RequestError::Failed(format!(
            "driver \"{driver}\" deferred a request twice"
        ))),
        // Through its bytes, so the requesting driver sees the ACK exactly as a TCP client (or a
        // remote server's reply) would: the same typed variant, the same checks.
        Reply::Ack(Some(body)) => match ack_body(req, addr, &body).and_then(|bytes| {
            let mut h = header;
            h.size = bytes.len() as u32;
            Message::decode(h, &bytes, &DecodeLimits::default()).map_err(|e| e.to_string())
        }) {
            Ok(msg) => Ok(msg),
            Err(e) => {
                tracing::error!("driver \"{driver}\" answered with an unusable body: {e}");
                Err(RequestError::Nack)
            }
        },
        Reply::Ack(None) => {
            let mut empty = header;
            empty.size = 0;
            match Message::decode(empty, &[], &DecodeLimits::default()) {
                Ok(msg) => Ok(msg),
                Err(e) => Err(RequestError::Failed(format!(
                    "driver \"{driver}\" sent an empty ACK where a body is due: {e}"
                ))),
            }
        }
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
        Reply::Deferred => {
            tracing::error!("driver \"{driver}\" deferred a request twice; NACK");
            nack()
        }
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
