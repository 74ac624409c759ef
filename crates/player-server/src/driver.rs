//! What a driver is: the [`Driver`] trait, the cfg block it is built from, and the registry of
//! factories keyed by driver name.
//!
//! Drivers are plain synchronous objects owned by the server's core task: the core hands them
//! subscriptions, requests and commands between ticks and calls [`Driver::update`] on their own
//! step. Nothing in here is async; a driver never touches a socket or a queue, it only returns
//! replies and publishes data through its [`Context`].

use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};
use std::time::Duration;

use player_proto::{Body, DeviceAddr, InterfaceCode, Message};

use crate::device::DriverId;
use crate::error::ServerError;

/// A connected client, as the server numbers them (for drivers that keep per-client state).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ClientId(pub u64);

impl fmt::Display for ClientId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "client {}", self.0)
    }
}

/// A driver's reason for refusing something (a cfg block, a subscription).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct DriverError(pub String);

impl DriverError {
    /// An error with this message.
    pub fn new(msg: impl Into<String>) -> DriverError {
        DriverError(msg.into())
    }
}

/// One device in a block's `provides`, resolved to its wire address.
#[derive(Clone, Debug, PartialEq)]
pub struct ProvidedDevice {
    /// The address: host, port (the cfg's or the server default), interface, index.
    pub addr: DeviceAddr,
    /// The optional `key` (role label) of the entry.
    pub key: Option<String>,
    /// Where the entry is written (`file:line`).
    pub origin: String,
}

/// One device in a block's `requires`, resolved to its wire address: a device this driver
/// subscribes to, commands or queries. It may be provided by any block of the cfg (earlier or
/// later) or live on another Player server (a host or port this server does not serve).
#[derive(Clone, Debug, PartialEq)]
pub struct RequiredDevice {
    /// The address: host, port (the cfg's or the server default), interface, index.
    pub addr: DeviceAddr,
    /// The optional key (role, e.g. `odometry`, `input`, `output`, `laser`) of the entry.
    pub key: Option<String>,
    /// Where the entry is written (`file:line`).
    pub origin: String,
}

/// A cfg `driver ( ... )` block, as the server hands it to a driver factory.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DriverBlock {
    /// The `name` field: which factory builds it.
    pub name: String,
    /// Where the block is written (`file:line`), for error messages.
    pub origin: String,
    /// The cfg file, when there is one: relative paths in options resolve against its folder.
    pub cfg_path: Option<PathBuf>,
    /// The devices it provides, in `provides` order.
    pub provides: Vec<ProvidedDevice>,
    /// The devices it requires, in `requires` order.
    pub requires: Vec<RequiredDevice>,
    /// The `alwayson` field, when written.
    pub alwayson: Option<bool>,
    /// Every other field, as its list of values (e.g. `model`, `worldfile`).
    pub options: BTreeMap<String, Vec<String>>,
    /// Where each option is written (`file:line:col`), when the block comes from a cfg: a
    /// message about a value (a world file that cannot be read) names the value's line.
    pub option_origins: BTreeMap<String, String>,
    /// The cfg's `unit_length` and `unit_angle`: Player's `ReadLength` and `ReadAngle` scale
    /// the values written by them (metres and degrees unless the cfg says otherwise).
    pub units: worldfile::Units,
}

impl DriverBlock {
    /// A block written in code rather than read from a cfg file (one the server adds itself,
    /// a program embedding the server, a bench or a test): the driver `name`, with `origin`
    /// standing where a cfg block's `file:line` would in error messages; no devices or options
    /// yet (add them with [`DriverBlock::providing`], [`DriverBlock::requiring`] and
    /// [`DriverBlock::with_options`]).
    pub fn new(name: impl Into<String>, origin: impl Into<String>) -> DriverBlock {
        DriverBlock {
            name: name.into(),
            origin: origin.into(),
            ..DriverBlock::default()
        }
    }

    /// The block with an unkeyed `provides` entry for each of `addrs`, each reported at
    /// `origin`.
    pub fn providing(mut self, addrs: impl IntoIterator<Item = DeviceAddr>, origin: &str) -> Self {
        self.provides
            .extend(addrs.into_iter().map(|addr| ProvidedDevice {
                addr,
                key: None,
                origin: origin.into(),
            }));
        self
    }

    /// The block with a `requires` entry for each `(key, address)` of `entries` (`None`: an
    /// unkeyed entry), each reported at `origin`.
    pub fn requiring<'k>(
        mut self,
        entries: impl IntoIterator<Item = (Option<&'k str>, DeviceAddr)>,
        origin: &str,
    ) -> Self {
        self.requires
            .extend(entries.into_iter().map(|(key, addr)| RequiredDevice {
                addr,
                key: key.map(str::to_string),
                origin: origin.into(),
            }));
        self
    }

    /// The block with option `key` set to `values` (a cfg tuple's values in order; one value
    /// for a plain option).
    pub fn with_option<V: Into<String>>(
        mut self,
        key: &str,
        values: impl IntoIterator<Item = V>,
    ) -> Self {
        self.options.insert(
            key.to_string(),
            values.into_iter().map(Into::into).collect(),
        );
        self
    }

    /// The block with each `(key, value)` of `options` set as a one-value option.
    pub fn with_options(self, options: &[(&str, &str)]) -> Self {
        options
            .iter()
            .fold(self, |block, &(key, value)| block.with_option(key, [value]))
    }

    /// The first value of an option.
    pub fn option(&self, key: &str) -> Option<&str> {
        self.options.get(key)?.first().map(String::as_str)
    }

    /// An option read as a number, with a clear error naming the block when it is not one.
    pub fn option_parse<T: std::str::FromStr>(&self, key: &str) -> Result<Option<T>, DriverError> {
        match self.option(key) {
            None => Ok(None),
            Some(text) => text.parse().map(Some).map_err(|_| {
                DriverError::new(format!("option `{key}` has an invalid value \"{text}\""))
            }),
        }
    }

    /// The first provided device of `interface` (upstream's single-interface `Driver`
    /// constructor); an error saying the block must provide one, with an example entry, when
    /// there is none.
    pub fn provided(&self, interface: InterfaceCode) -> Result<DeviceAddr, DriverError> {
        self.provides
            .iter()
            .find(|p| p.addr.interf == interface)
            .map(|p| p.addr)
            .ok_or_else(|| {
                let name = interface.to_string();
                let article = if name.starts_with(['a', 'e', 'i', 'o', 'u']) {
                    "an"
                } else {
                    "a"
                };
                DriverError::new(format!(
                    "must provide {article} {name} device (e.g. \"{name}:0\")"
                ))
            })
    }

    /// The required device of `interface` with `key` (Player's `ReadDeviceAddr(.., "requires",
    /// code, -1, key)`): the first entry of that interface whose key matches. `None` matches
    /// any entry of that interface, keyed or not, as upstream's NULL key does (so
    /// `requires ["laser:::ranger:0"]` serves a driver that asks for no key). An entry with the
    /// key but another interface is an error saying what the driver needs there, as is a
    /// missing one.
    pub fn required(
        &self,
        interface: InterfaceCode,
        key: Option<&str>,
    ) -> Result<&RequiredDevice, DriverError> {
        self.find_required(interface, key)?.ok_or_else(|| {
            DriverError::new(match key {
                Some(k) => format!(
                    "requires a {interface} device with key \"{k}\" (e.g. \"{k}:::{interface}:0\")"
                ),
                None => format!("requires a {interface} device (e.g. \"{interface}:0\")"),
            })
        })
    }

    /// Like [`DriverBlock::required`], but an absent entry is `None` (optional inputs, such as
    /// a laser that a driver uses when given).
    pub fn optional_required(
        &self,
        interface: InterfaceCode,
        key: Option<&str>,
    ) -> Result<Option<&RequiredDevice>, DriverError> {
        self.find_required(interface, key)
    }

    fn find_required(
        &self,
        interface: InterfaceCode,
        key: Option<&str>,
    ) -> Result<Option<&RequiredDevice>, DriverError> {
        let keyed = || {
            self.requires
                .iter()
                .filter(|r| key.is_none() || r.key.as_deref() == key)
        };
        if let Some(found) = keyed().find(|r| r.addr.interf == interface) {
            return Ok(Some(found));
        }
        // Only a keyed entry can be "the wrong interface": unkeyed ones are matched by type.
        if let (Some(k), Some(other)) = (key, keyed().next()) {
            return Err(DriverError::new(format!(
                "{}: required device \"{k}\" is a {} device, but this driver needs a {interface} there",
                other.origin, other.addr.interf
            )));
        }
        Ok(None)
    }

    /// Where option `key` is written, else where the block is.
    pub fn option_origin(&self, key: &str) -> &str {
        self.option_origins
            .get(key)
            .map_or(self.origin.as_str(), String::as_str)
    }

    /// A path written in the block: absolute as written, else relative to the cfg file's
    /// folder (as Player resolves the stage driver's `worldfile`).
    pub fn resolve_path(&self, written: &str) -> PathBuf {
        let p = Path::new(written);
        if p.is_absolute() {
            return p.to_path_buf();
        }
        match self.cfg_path.as_deref().and_then(Path::parent) {
            Some(dir) => dir.join(p),
            None => p.to_path_buf(),
        }
    }
}

/// A driver's answer to a request.
// Returned by value and consumed at once; boxing the body would only add an allocation.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq)]
pub enum Reply {
    /// RESP_ACK. The body, when the reply has one, is given as the request kind of the same
    /// subtype, e.g. `Position2dReq::GetGeom(Some(geom)).into()`; the server sends it as the ACK.
    Ack(Option<Body>),
    /// RESP_NACK, no body.
    Nack,
    /// The driver does not handle this request: the client gets an empty NACK, as upstream's
    /// `Driver::ProcessMessages` sends for unhandled requests.
    NotHandled,
    /// The driver answers later with [`Context::answer`], using the token [`Context::defer`]
    /// gave it (a relay waiting on the device it forwards to, a remote device, a planner
    /// thread). The requester waits; nothing else does.
    Deferred,
}

impl Reply {
    /// An ACK carrying `body`.
    pub fn ack(body: impl Into<Body>) -> Reply {
        Reply::Ack(Some(body.into()))
    }

    /// An ACK without a body.
    pub fn empty_ack() -> Reply {
        Reply::Ack(None)
    }
}

/// A DATA message a driver published.
#[derive(Clone, Debug, PartialEq)]
pub struct Publication {
    /// The publishing device.
    pub addr: DeviceAddr,
    /// The DATA body.
    pub body: Body,
    /// Header timestamp; `None` = the server clock now.
    pub timestamp: Option<f64>,
    /// The one client it goes to, whether or not it subscribed (Player's `Publish` to one
    /// queue: the blackboard's updates go to the clients that asked for that key); `None`
    /// sends it to every subscriber of the device.
    pub to: Option<ClientId>,
}

/// Names one request a driver sent to a device; its reply comes back to
/// [`Driver::handle_reply`] with the same ticket.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct RequestTicket(pub u64);

/// A request a driver chose to answer later ([`Reply::Deferred`]): pass it to
/// [`Context::answer`] once the answer is known. Answering twice, or a token the server no
/// longer knows (its client left), is ignored.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct PendingReply(pub u64);

/// Why a driver's request to a device got no ACK.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum RequestError {
    /// The device answered RESP_NACK (or does not handle the request).
    #[error("the device refused the request (NACK)")]
    Nack,
    /// No device has that address, or the driver is not allowed to use it.
    #[error("no such device {0}")]
    NoDevice(DeviceAddr),
    /// The device (or the link to it) failed before answering.
    #[error("{0}")]
    Failed(String),
}

/// Something a driver asked the server to do with another device; carried out by the core
/// once the driver's callback returns (so drivers never run inside each other).
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    /// Subscribe this driver to a device: its DATA then reaches [`Driver::handle_data`].
    Subscribe(DeviceAddr),
    /// End one subscription of this driver to a device.
    Unsubscribe(DeviceAddr),
    /// Send a CMD to a device.
    Command(DeviceAddr, Body),
    /// Send a REQ to a device; the reply comes to [`Driver::handle_reply`].
    Request(RequestTicket, DeviceAddr, Body),
    /// Answer a request deferred earlier.
    Answer(PendingReply, Reply),
}

/// Lets code outside the core (a driver's worker thread, a network task) ask the core to call
/// the driver's [`Driver::wake`] soon. Cheap to clone; waking a driver already due is a no-op.
#[derive(Clone)]
pub struct DriverWaker {
    driver: DriverId,
    tx: tokio::sync::mpsc::UnboundedSender<DriverId>,
    flag: std::sync::Arc<std::sync::atomic::AtomicBool>,
}

impl fmt::Debug for DriverWaker {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("DriverWaker")
            .field("driver", &self.driver)
            .finish()
    }
}

impl DriverWaker {
    /// A waker for `driver` that sends on `tx`; `flag` is set while a wake is pending, so
    /// many wakes before the core runs cost one event.
    pub(crate) fn new(
        driver: DriverId,
        tx: tokio::sync::mpsc::UnboundedSender<DriverId>,
        flag: std::sync::Arc<std::sync::atomic::AtomicBool>,
    ) -> DriverWaker {
        DriverWaker { driver, tx, flag }
    }

    /// Asks the core to call [`Driver::wake`]. Callable from any thread; never blocks.
    pub fn wake(&self) {
        use std::sync::atomic::Ordering;
        if !self.flag.swap(true, Ordering::AcqRel) {
            // A closed channel means the server stopped: nothing left to wake.
            let _ = self.tx.send(self.driver);
        }
    }
}

/// What a driver can see and do while the core runs it.
pub struct Context<'a> {
    now: f64,
    client: Option<ClientId>,
    published: &'a mut Vec<Publication>,
    actions: Vec<Action>,
    next_ticket: u64,
    request: Option<PendingReply>,
    waker: Option<DriverWaker>,
}

impl<'a> Context<'a> {
    /// A context at server time `now`, collecting publications into `published`. Tickets
    /// start at 1; there is no waker and no deferrable request (the core sets those).
    pub fn new(
        now: f64,
        client: Option<ClientId>,
        published: &'a mut Vec<Publication>,
    ) -> Context<'a> {
        Context {
            now,
            client,
            published,
            actions: Vec::new(),
            next_ticket: 1,
            request: None,
            waker: None,
        }
    }

    /// Sets what the core knows of the call: the next free ticket, the token of the request
    /// being handled (for [`Context::defer`]) and the driver's waker.
    pub(crate) fn with_core(
        mut self,
        next_ticket: u64,
        request: Option<PendingReply>,
        waker: DriverWaker,
    ) -> Context<'a> {
        self.next_ticket = next_ticket;
        self.request = request;
        self.waker = Some(waker);
        self
    }

    /// Sets what the core would: the next free ticket and the token of the request being
    /// handled. For unit tests of drivers outside this crate, which build contexts by hand and
    /// need [`Context::defer`] to work and tickets not to restart at 1 in every call.
    pub fn with_request(mut self, next_ticket: u64, request: Option<PendingReply>) -> Context<'a> {
        self.next_ticket = next_ticket;
        self.request = request;
        self
    }

    /// What the driver asked for so far in this call (subscriptions, commands, requests,
    /// answers), in order: for unit tests of drivers, which cannot run the core.
    pub fn actions(&self) -> &[Action] {
        &self.actions
    }

    /// What the driver asked for during the call, and the next free ticket.
    pub(crate) fn finish(self) -> (Vec<Action>, u64) {
        (self.actions, self.next_ticket)
    }

    /// The server clock: wall-clock seconds, or simulated seconds when a driver supplies the
    /// clock ([`Driver::clock`]).
    pub fn now(&self) -> f64 {
        self.now
    }

    /// The client whose message is being handled (`None` in `update`, and when the message
    /// comes from another driver).
    pub fn client(&self) -> Option<ClientId> {
        self.client
    }

    /// Publishes DATA from `addr` to every subscriber, stamped with the server clock.
    pub fn publish(&mut self, addr: DeviceAddr, body: impl Into<Body>) {
        self.published.push(Publication {
            addr,
            body: body.into(),
            timestamp: None,
            to: None,
        });
    }

    /// Publishes DATA from `addr` to `client` alone, stamped with the server clock: what a
    /// driver keeping per-client interest sends (the blackboard's updates of a key go to the
    /// clients that subscribed to that key, not to every subscriber of the device).
    pub fn publish_to(&mut self, addr: DeviceAddr, client: ClientId, body: impl Into<Body>) {
        self.published.push(Publication {
            addr,
            body: body.into(),
            timestamp: None,
            to: Some(client),
        });
    }

    /// Publishes DATA with an explicit timestamp (e.g. the time the sample was taken).
    pub fn publish_at(&mut self, addr: DeviceAddr, body: impl Into<Body>, timestamp: f64) {
        self.published.push(Publication {
            addr,
            body: body.into(),
            timestamp: Some(timestamp),
            to: None,
        });
    }

    /// Subscribes this driver to `device` (one of its `requires`, usually from
    /// [`Driver::setup`]). Done when the callback returns; from `setup`, a refused
    /// subscription makes the setup (and the client's subscription that caused it) fail.
    pub fn subscribe(&mut self, device: DeviceAddr) {
        self.actions.push(Action::Subscribe(device));
    }

    /// Ends one subscription of this driver to `device`. Subscriptions still held when the
    /// driver's last subscriber leaves are ended by the server after [`Driver::teardown`].
    pub fn unsubscribe(&mut self, device: DeviceAddr) {
        self.actions.push(Action::Unsubscribe(device));
    }

    /// Sends a command to `device`, as a client would.
    pub fn command(&mut self, device: DeviceAddr, body: impl Into<Body>) {
        self.actions.push(Action::Command(device, body.into()));
    }

    /// Sends a request to `device`; its ACK (or the reason there is none) comes to
    /// [`Driver::handle_reply`] with the returned ticket, after this callback returns.
    pub fn request(&mut self, device: DeviceAddr, body: impl Into<Body>) -> RequestTicket {
        let ticket = RequestTicket(self.next_ticket);
        self.next_ticket += 1;
        self.actions
            .push(Action::Request(ticket, device, body.into()));
        ticket
    }

    /// Takes the request being handled to answer it later: return [`Reply::Deferred`] and
    /// call [`Context::answer`] with the token. `None` outside [`Driver::handle_request`].
    pub fn defer(&mut self) -> Option<PendingReply> {
        self.request.take()
    }

    /// Answers a request deferred earlier (from any later callback).
    pub fn answer(&mut self, pending: PendingReply, reply: Reply) {
        self.actions.push(Action::Answer(pending, reply));
    }

    /// A handle that other threads or tasks of this driver use to have [`Driver::wake`]
    /// called (`None` in contexts built outside a server, e.g. unit tests).
    pub fn waker(&self) -> Option<DriverWaker> {
        self.waker.clone()
    }
}

/// A driver: serves the devices of one cfg `driver` block.
///
/// The core calls these methods one at a time, never concurrently (possibly from different
/// runtime threads over time, hence `Send`). Every call should return promptly: requests are
/// answered between ticks, and clients time out after 5 s. Work that takes longer (planning,
/// a remote link) runs on a thread or task of the driver's own, which reports back through
/// a [`DriverWaker`].
///
/// A panic in any of these methods is a bug of the driver, not of the server: the core catches
/// it, logs it naming the driver and its devices, and takes that driver out of service (it is
/// never called again; its subscriptions are dropped, its requests NACKed), while every other
/// driver and client carries on.
///
/// Lifecycle, as Player's `Setup`/`Shutdown`: [`Driver::setup`] runs when the first
/// subscription to any of the driver's devices arrives (a client's, another driver's, or the
/// server's for alwayson drivers), [`Driver::teardown`] when the last one ends.
pub trait Driver: Send {
    /// A client (or, for alwayson drivers, the server at start-up) subscribes to `addr`.
    /// Called once per subscription, duplicates included. An error makes the DEV reply grant
    /// access 3 (`PLAYER_ERROR_MODE`).
    fn subscribe(&mut self, addr: DeviceAddr) -> Result<(), DriverError> {
        let _ = addr;
        Ok(())
    }

    /// One subscription to `addr` ends (DEV close, or the client disconnected).
    fn unsubscribe(&mut self, addr: DeviceAddr) -> Result<(), DriverError> {
        let _ = addr;
        Ok(())
    }

    /// `client`'s subscription to `addr` ended (called just before [`Driver::unsubscribe`]),
    /// for drivers that keep per-client state (Stage's graphics are drawn per client and
    /// discarded when that client unsubscribes).
    fn client_unsubscribed(&mut self, addr: DeviceAddr, client: ClientId) {
        let _ = (addr, client);
    }

    /// The first subscription to any of this driver's devices: subscribe to the devices it
    /// requires ([`Context::subscribe`]), ask for their geometry, start workers. An error, or
    /// a required device refusing the subscription, refuses the subscription that caused it.
    fn setup(&mut self, ctx: &mut Context<'_>) -> Result<(), DriverError> {
        let _ = ctx;
        Ok(())
    }

    /// The last subscription ended: stop. The server then ends this driver's own
    /// subscriptions to other devices.
    fn teardown(&mut self, ctx: &mut Context<'_>) {
        let _ = ctx;
    }

    /// A REQ to one of this driver's devices (universal capability/property requests
    /// included). `request.header.addr` is the device's address; the body is typed.
    /// The server turns the [`Reply`] into exactly one ACK or NACK to the requester.
    fn handle_request(&mut self, ctx: &mut Context<'_>, request: &Message) -> Reply {
        let _ = (ctx, request);
        Reply::NotHandled
    }

    /// A CMD to one of this driver's devices. Commands are never answered.
    fn handle_command(&mut self, ctx: &mut Context<'_>, command: &Message) {
        let _ = ctx;
        tracing::warn!(
            "ignoring unhandled command {} to {}",
            command.body.constant(),
            command.header.addr
        );
    }

    /// DATA from a device this driver subscribed to (`data.header.addr` is that device).
    fn handle_data(&mut self, ctx: &mut Context<'_>, data: &Message) {
        let _ = ctx;
        tracing::debug!(
            "ignoring {} from {}",
            data.body.constant(),
            data.header.addr
        );
    }

    /// The answer to a request this driver sent with [`Context::request`]: the ACK message,
    /// or why there is none.
    fn handle_reply(
        &mut self,
        ctx: &mut Context<'_>,
        ticket: RequestTicket,
        reply: Result<Message, RequestError>,
    ) {
        let _ = (ctx, ticket, reply);
    }

    /// Something woke the driver through its [`DriverWaker`]: collect what its workers
    /// produced, publish, answer deferred requests.
    fn wake(&mut self, ctx: &mut Context<'_>) {
        let _ = ctx;
    }

    /// Steps the driver (and, for a simulator, the world) to `ctx.now()` and publishes data.
    /// Called every [`Driver::step`] while the driver has a subscriber or is alwayson.
    fn update(&mut self, ctx: &mut Context<'_>) {
        let _ = ctx;
    }

    /// How often [`Driver::update`] runs, in server time (e.g. Stage's `interval_sim`).
    /// `None` uses [`crate::clock::DEFAULT_STEP`].
    fn step(&self) -> Option<Duration> {
        None
    }

    /// The server clock this driver supplies, in seconds (Stage: simulated time), or `None`.
    /// The first driver (in cfg order) that returns `Some` at start-up becomes the server's
    /// clock: every timestamp the server writes then comes from it, read after each update.
    fn clock(&self) -> Option<f64> {
        None
    }

    /// Whether the driver runs without subscribers by default (a cfg `alwayson` field
    /// overrides this). The server subscribes every device of an alwayson driver at start-up.
    fn always_on(&self) -> bool {
        false
    }

    /// The server is shutting down.
    fn shutdown(&mut self) {}
}

/// Builds a driver from its cfg block. Factories may keep state across blocks (e.g. one
/// simulated world shared by every `stage` block).
pub type DriverFactory =
    Box<dyn FnMut(&DriverBlock) -> Result<Box<dyn Driver>, DriverError> + Send>;

/// The drivers a server can build, by cfg `name`.
#[derive(Default)]
pub struct DriverRegistry {
    factories: BTreeMap<String, DriverFactory>,
}

impl fmt::Debug for DriverRegistry {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("DriverRegistry")
            .field("names", &self.factories.keys().collect::<Vec<_>>())
            .finish()
    }
}

impl DriverRegistry {
    /// An empty registry.
    pub fn new() -> DriverRegistry {
        DriverRegistry::default()
    }

    /// Registers (or replaces) the factory for driver `name`.
    pub fn register(
        &mut self,
        name: impl Into<String>,
        factory: impl FnMut(&DriverBlock) -> Result<Box<dyn Driver>, DriverError> + Send + 'static,
    ) {
        self.factories.insert(name.into(), Box::new(factory));
    }

    /// Registers driver `name` built by `from_block`, the usual constructor of a driver that
    /// keeps no state across blocks: each driver module then registers itself in one line.
    pub fn register_driver<D: Driver + 'static>(
        &mut self,
        name: impl Into<String>,
        from_block: fn(&DriverBlock) -> Result<D, DriverError>,
    ) {
        self.register(name, move |block: &DriverBlock| {
            Ok(Box::new(from_block(block)?) as Box<dyn Driver>)
        });
    }

    /// The registered names, sorted.
    pub fn names(&self) -> Vec<&str> {
        self.factories.keys().map(String::as_str).collect()
    }

    /// Builds the driver for `block`; an unknown name or a refusing factory is an error naming
    /// the block's place in the cfg.
    pub fn create(&mut self, block: &DriverBlock) -> Result<Box<dyn Driver>, ServerError> {
        let known = self.names().join(", ");
        let factory =
            self.factories
                .get_mut(&block.name)
                .ok_or_else(|| ServerError::UnknownDriver {
                    name: block.name.clone(),
                    origin: block.origin.clone(),
                    known,
                })?;
        factory(block).map_err(|source| ServerError::DriverFailed {
            name: block.name.clone(),
            origin: block.origin.clone(),
            source,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Nothing;
    impl Driver for Nothing {}

    #[test]
    fn registry_errors_name_the_block() {
        let mut reg = DriverRegistry::new();
        reg.register("b", |_| Ok(Box::new(Nothing) as Box<dyn Driver>));
        reg.register("a", |block: &DriverBlock| {
            Err(DriverError::new(format!(
                "no model \"{}\"",
                block.option("model").unwrap_or("")
            )))
        });
        let mut block = DriverBlock {
            name: "stage".into(),
            origin: "w.cfg:3".into(),
            ..Default::default()
        };
        assert_eq!(
            reg.create(&block).err().unwrap().to_string(),
            "w.cfg:3: couldn't find driver \"stage\" (known drivers: a, b)"
        );
        block.name = "a".into();
        block.options.insert("model".into(), vec!["r0".into()]);
        assert_eq!(
            reg.create(&block).err().unwrap().to_string(),
            "w.cfg:3: driver \"a\" failed to start: no model \"r0\""
        );
        block.name = "b".into();
        assert!(reg.create(&block).is_ok());
    }

    #[test]
    fn hand_made_contexts_defer_and_show_actions() {
        let mut out = Vec::new();
        let addr = DeviceAddr::new(0, 6665, InterfaceCode::RANGER, 0);
        let mut ctx = Context::new(2.0, None, &mut out).with_request(7, Some(PendingReply(3)));
        let ticket = ctx.request(addr, player_proto::RangerReq::GetGeom(None));
        assert_eq!(ticket, RequestTicket(7));
        assert_eq!(ctx.defer(), Some(PendingReply(3)));
        assert_eq!(ctx.defer(), None);
        ctx.answer(PendingReply(3), Reply::Nack);
        assert!(matches!(
            ctx.actions(),
            [
                Action::Request(RequestTicket(7), a, _),
                Action::Answer(PendingReply(3), Reply::Nack)
            ] if *a == addr
        ));
    }

    #[test]
    fn required_devices_by_interface_and_key() {
        let entry = |interf, key: Option<&str>| RequiredDevice {
            addr: DeviceAddr::new(0, 6665, interf, 0),
            key: key.map(str::to_string),
            origin: "x.cfg:2".into(),
        };
        let block = DriverBlock {
            requires: vec![
                entry(InterfaceCode::POSITION2D, Some("odometry")),
                entry(InterfaceCode::LASER, Some("scanner")),
                entry(InterfaceCode::RANGER, None),
            ],
            ..Default::default()
        };
        // No key: the first entry of the interface, keyed or not (upstream's NULL key).
        let laser = block.required(InterfaceCode::LASER, None).unwrap();
        assert_eq!(laser.key.as_deref(), Some("scanner"));
        assert!(block.required(InterfaceCode::RANGER, None).is_ok());
        // A key must match.
        assert!(
            block
                .required(InterfaceCode::POSITION2D, Some("odometry"))
                .is_ok()
        );
        assert!(
            block
                .optional_required(InterfaceCode::POSITION2D, Some("other"))
                .unwrap()
                .is_none()
        );
        let wrong = block
            .required(InterfaceCode::RANGER, Some("scanner"))
            .unwrap_err()
            .to_string();
        assert!(wrong.contains("is a laser device"), "{wrong}");
        let missing = block
            .required(InterfaceCode::SONAR, None)
            .unwrap_err()
            .to_string();
        assert!(missing.contains("requires a sonar device"), "{missing}");
    }

    #[test]
    fn block_options_and_paths() {
        let mut block = DriverBlock {
            cfg_path: Some(PathBuf::from("worlds/x.cfg")),
            ..Default::default()
        };
        block.options.insert("step".into(), vec!["50".into()]);
        block.options.insert("bad".into(), vec!["5x".into()]);
        assert_eq!(block.option_parse::<u64>("step"), Ok(Some(50)));
        assert_eq!(block.option_parse::<u64>("none"), Ok(None));
        assert_eq!(
            block.option_parse::<u64>("bad").unwrap_err().to_string(),
            "option `bad` has an invalid value \"5x\""
        );
        assert_eq!(block.resolve_path("a.world"), Path::new("worlds/a.world"));
        assert_eq!(
            block.resolve_path("/abs/a.world"),
            Path::new("/abs/a.world")
        );
    }

    #[test]
    fn blocks_written_in_code() {
        let at = |interf, index| DeviceAddr::new(0, 6665, interf, index);
        let block = DriverBlock::new("vfh", "here:1")
            .providing([at(InterfaceCode::POSITION2D, 1)], "here:2")
            .requiring(
                [
                    (Some("odometry"), at(InterfaceCode::POSITION2D, 0)),
                    (None, at(InterfaceCode::LASER, 0)),
                ],
                "here:3",
            )
            .with_option("safety_dist", ["0.1", "0.2"])
            .with_options(&[("step", "50"), ("step", "60"), ("name", "a b")]);
        assert_eq!(
            (block.name.as_str(), block.origin.as_str()),
            ("vfh", "here:1")
        );
        assert_eq!(
            block.provides,
            [ProvidedDevice {
                addr: at(InterfaceCode::POSITION2D, 1),
                key: None,
                origin: "here:2".into(),
            }]
        );
        let odometry = block.required(InterfaceCode::POSITION2D, Some("odometry"));
        assert_eq!(odometry.unwrap().origin, "here:3");
        assert_eq!(block.requires[1].key, None);
        assert_eq!(block.options["safety_dist"], ["0.1", "0.2"]);
        // A later value of the same option replaces the earlier; values are not split.
        assert_eq!(block.options["step"], ["60"]);
        assert_eq!(block.options["name"], ["a b"]);
        assert_eq!((block.cfg_path, block.alwayson), (None, None));
    }

    #[test]
    fn a_missing_provided_device_is_named_with_an_example() {
        let block = DriverBlock::new("relay", "here:1");
        let missing = |interface| block.provided(interface).unwrap_err().to_string();
        assert_eq!(
            missing(InterfaceCode::OPAQUE),
            "must provide an opaque device (e.g. \"opaque:0\")"
        );
        assert_eq!(
            missing(InterfaceCode::LOG),
            "must provide a log device (e.g. \"log:0\")"
        );
    }
}
