//! [`PlayerClient`]: one TCP connection to a Player server, with libplayerc's session rules.
//!
//! Connecting reads the 32-byte banner and switches the connection to PULL mode, as libplayerc
//! does. [`PlayerClient::read`] then runs one data round (REQ_DATA, ACK, DATA…, SYNCH); requests
//! wait for the reply whose interface, index and subtype match, keeping any DATA that arrives
//! meanwhile for the next read. The latest DATA of every subscribed device is kept, keyed by
//! (interface, index, subtype); proxies read their typed views from it.

use std::collections::{BTreeMap, HashMap, VecDeque};
use std::io::{self, Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use player_proto::constants::{
    PLAYER_CLOSE_MODE, PLAYER_DATAMODE_PULL, PLAYER_DATAMODE_PUSH, PLAYER_OPEN_MODE,
    PLAYER_PLAYER_MSG_REPLACE_RULE_ACCEPT, PLAYER_PLAYER_MSG_REPLACE_RULE_REPLACE,
};
use player_proto::{
    AddReplaceRuleReq, BANNER, Body, DecodeLimits, DeviceAddr, DeviceDatamodeReq, DeviceDriverinfo,
    DeviceReq, Error as ProtoError, Framer, InterfaceCode, Message, MsgHeader, MsgType, PlayerMsg,
    PlayerReq, PlayerSynch, Text, banner_text,
};

use crate::error::ClientError;

/// The default Player port (`PLAYER_PORTNUM`): player-proto's, re-exported so clients need not
/// depend on the protocol crate for it.
pub const DEFAULT_PORT: u16 = player_proto::constants::PLAYERTCP_DEFAULT_PORT;

/// libplayerc's default request timeout.
pub const DEFAULT_REQUEST_TIMEOUT: Duration = Duration::from_secs(5);

/// How many received messages are kept while waiting for a reply (`PLAYERC_QUEUE_RING_SIZE`);
/// beyond it the oldest is dropped, as libplayerc does.
const FIFO_LIMIT: usize = 512;

/// How the server delivers data to this client.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DataMode {
    /// Every message as soon as it is published.
    Push,
    /// One round per [`PlayerClient::read`] (the libplayerc default).
    Pull,
}

/// A device the server offers (DEVLIST + DRIVERINFO).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DeviceInfo {
    /// Its address (host and port as the server reports them).
    pub addr: DeviceAddr,
    /// The driver serving it, e.g. `stage`.
    pub driver_name: String,
}

/// A message as received: header, and the body when the function table has one for it.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Received {
    pub header: MsgHeader,
    pub body: Option<Body>,
}

impl Received {
    fn kind(&self) -> Option<MsgType> {
        self.header.kind().ok()
    }
}

/// Latest data of one (interface, index).
#[derive(Clone, Debug, Default)]
pub(crate) struct DeviceData {
    /// Proxies currently subscribed.
    pub proxies: usize,
    /// Latest DATA body per subtype.
    pub latest: BTreeMap<u8, Body>,
    /// Timestamp of the latest DATA.
    pub datatime: f64,
    /// Set when DATA newer than the previous arrived; cleared by the proxy.
    pub fresh: bool,
}

pub(crate) struct Inner {
    stream: TcpStream,
    framer: Framer,
    host: String,
    port: u16,
    banner: String,
    mode: DataMode,
    request_timeout: Duration,
    read_timeout: Option<Duration>,
    fifo: VecDeque<Received>,
    data_requested: bool,
    data_received: bool,
    overflow: u32,
    datatime: f64,
    pub(crate) devices: HashMap<(InterfaceCode, u16), DeviceData>,
    /// Subscribed devices that received DATA since the last [`PlayerClient::take_updated`].
    updated: Vec<(InterfaceCode, u16)>,
    scratch: Vec<u8>,
}

/// A connection to a Player server. Cheap to clone: clones share the connection (proxies hold
/// one), and it may be used from several threads, one call at a time.
#[derive(Clone)]
pub struct PlayerClient {
    pub(crate) inner: Arc<Mutex<Inner>>,
}

impl std::fmt::Debug for PlayerClient {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let inner = self.lock();
        f.debug_struct("PlayerClient")
            .field("host", &inner.host)
            .field("port", &inner.port)
            .field("mode", &inner.mode)
            .finish()
    }
}

fn wall_seconds() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_secs_f64())
        .unwrap_or(0.0)
}

/// The rule action of libplayerc++'s `SetReplaceRule(replace, ...)`: keep only the newest
/// queued message (`replace`) or all of them.
pub(crate) fn replace_action(replace: bool) -> i32 {
    if replace {
        PLAYER_PLAYER_MSG_REPLACE_RULE_REPLACE
    } else {
        PLAYER_PLAYER_MSG_REPLACE_RULE_ACCEPT
    }
}

/// The address libplayerc writes into player-interface requests.
fn player_addr() -> DeviceAddr {
    DeviceAddr::new(0, 0, InterfaceCode::PLAYER, 0)
}

impl PlayerClient {
    /// Connects to `host:port`, reads the banner and switches to PULL mode (as
    /// `playerc_client_connect` and libplayerc++'s `PlayerClient` constructor do).
    pub fn connect(host: &str, port: u16) -> Result<PlayerClient, ClientError> {
        let addr = format!("{host}:{port}");
        let err = |source| ClientError::Connect {
            addr: addr.clone(),
            source,
        };
        let mut last = io::Error::new(io::ErrorKind::NotFound, "no address");
        let mut stream = None;
        for a in (host, port).to_socket_addrs().map_err(err)? {
            match TcpStream::connect_timeout(&a, DEFAULT_REQUEST_TIMEOUT) {
                Ok(s) => {
                    stream = Some(s);
                    break;
                }
                Err(e) => last = e,
            }
        }
        let mut stream = stream.ok_or_else(|| err(last))?;
        stream.set_nodelay(true)?;
        // The banner: 32 bytes, sent at once on accept.
        stream.set_read_timeout(Some(Duration::from_secs(2)))?;
        let mut banner = [0u8; BANNER.len()];
        stream
            .read_exact(&mut banner)
            .map_err(|_| ClientError::Banner { addr: addr.clone() })?;
        let inner = Inner {
            stream,
            framer: Framer::new(DecodeLimits::default()),
            host: host.to_string(),
            port,
            banner: banner_text(&banner),
            mode: DataMode::Push,
            request_timeout: DEFAULT_REQUEST_TIMEOUT,
            read_timeout: None,
            fifo: VecDeque::new(),
            data_requested: false,
            data_received: false,
            overflow: 0,
            datatime: 0.0,
            devices: HashMap::new(),
            updated: Vec::new(),
            scratch: vec![0; 64 * 1024],
        };
        let client = PlayerClient {
            inner: Arc::new(Mutex::new(inner)),
        };
        client.set_datamode(DataMode::Pull)?;
        Ok(client)
    }

    pub(crate) fn lock(&self) -> MutexGuard<'_, Inner> {
        self.inner.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// The banner text the server sent (`Player v.3.0.2`).
    pub fn banner(&self) -> String {
        self.lock().banner.clone()
    }

    /// The port connected to.
    pub fn port(&self) -> u16 {
        self.lock().port
    }

    /// The current data mode.
    pub fn datamode(&self) -> DataMode {
        self.lock().mode
    }

    /// How long requests wait for their reply (default 5 s).
    pub fn set_request_timeout(&self, timeout: Duration) {
        self.lock().request_timeout = timeout;
    }

    /// Bounds how long [`PlayerClient::read`] waits for data (`None`, the default, waits as
    /// long as it takes, as libplayerc does).
    pub fn set_read_timeout(&self, timeout: Option<Duration>) {
        self.lock().read_timeout = timeout;
    }

    /// Timestamp of the latest DATA received.
    pub fn datatime(&self) -> f64 {
        self.lock().datatime
    }

    /// Switches PUSH/PULL (`PLAYER_PLAYER_REQ_DATAMODE`).
    pub fn set_datamode(&self, mode: DataMode) -> Result<(), ClientError> {
        let code = match mode {
            DataMode::Push => PLAYER_DATAMODE_PUSH,
            DataMode::Pull => PLAYER_DATAMODE_PULL,
        };
        let mut inner = self.lock();
        inner.request(
            player_addr(),
            PlayerReq::DataMode(Some(DeviceDatamodeReq { mode: code })).into(),
        )?;
        inner.mode = mode;
        inner.data_requested = false;
        Ok(())
    }

    /// libplayerc++'s `SetReplaceRule(replace, type, subtype, interf)`: for messages of this
    /// type/subtype/interface (−1 = any) keep only the newest queued one (`replace`), or all.
    pub fn set_replace_rule(
        &self,
        replace: bool,
        msg_type: i32,
        subtype: i32,
        interf: i32,
    ) -> Result<(), ClientError> {
        self.add_replace_rule(interf, -1, msg_type, subtype, replace_action(replace))
    }

    /// `playerc_client_set_replace_rule`: any rule, any action (0 accept, 1 replace,
    /// 2 ignore).
    pub fn add_replace_rule(
        &self,
        interf: i32,
        index: i32,
        msg_type: i32,
        subtype: i32,
        action: i32,
    ) -> Result<(), ClientError> {
        let rule = AddReplaceRuleReq {
            interf,
            index,
            msg_type,
            subtype,
            replace: action,
        };
        self.lock()
            .request(player_addr(), PlayerReq::AddReplaceRule(Some(rule)).into())
            .map(|_| ())
    }

    /// The devices on this port, with their drivers (DEVLIST, then one DRIVERINFO each).
    pub fn device_list(&self) -> Result<Vec<DeviceInfo>, ClientError> {
        let mut inner = self.lock();
        let reply = inner.request(player_addr(), PlayerReq::DevList(None).into())?;
        let Some(Body::Player(PlayerMsg::Ack(PlayerReq::DevList(Some(list))))) = reply.body else {
            return Err(ClientError::BadReply {
                what: "DEVLIST".into(),
            });
        };
        let mut out = Vec::new();
        for addr in list.devices {
            let req = PlayerReq::DriverInfo(Some(DeviceDriverinfo {
                addr,
                driver_name: Text::empty(),
            }));
            let reply = inner.request(player_addr(), req.into())?;
            let Some(Body::Player(PlayerMsg::Ack(PlayerReq::DriverInfo(Some(info))))) = reply.body
            else {
                return Err(ClientError::BadReply {
                    what: "DRIVERINFO".into(),
                });
            };
            out.push(DeviceInfo {
                addr,
                driver_name: info.driver_name.to_str_lossy().into_owned(),
            });
        }
        Ok(out)
    }

    /// Sends a request to device (`interf`, `index`) on this port and returns the ACK's body
    /// (`None` for an empty ACK). NACK and timeout are errors.
    pub fn request(
        &self,
        interf: InterfaceCode,
        index: u16,
        body: impl Into<Body>,
    ) -> Result<Option<Body>, ClientError> {
        let mut inner = self.lock();
        let addr = DeviceAddr::new(0, u32::from(inner.port), interf, index);
        inner.request(addr, body.into()).map(|r| r.body)
    }

    /// Sends a command to device (`interf`, `index`); commands are never answered.
    pub fn command(
        &self,
        interf: InterfaceCode,
        index: u16,
        body: impl Into<Body>,
    ) -> Result<(), ClientError> {
        let mut inner = self.lock();
        let addr = DeviceAddr::new(0, u32::from(inner.port), interf, index);
        inner.send(addr, body.into())
    }

    /// Subscribes to a device (DEV, access open) and returns its driver name. A NACK (no such
    /// device) or a refused subscription is [`ClientError::Subscribe`].
    pub fn subscribe(&self, interf: InterfaceCode, index: u16) -> Result<String, ClientError> {
        let mut inner = self.lock();
        let granted = inner.dev(interf, index, PLAYER_OPEN_MODE);
        match granted {
            Ok((PLAYER_OPEN_MODE, name)) => {
                inner.devices.entry((interf, index)).or_default().proxies += 1;
                Ok(name)
            }
            Ok(_) | Err(ClientError::Nack { .. }) => Err(ClientError::Subscribe { interf, index }),
            Err(e) => Err(e),
        }
    }

    /// Ends one subscription to a device (DEV, access close).
    pub fn unsubscribe(&self, interf: InterfaceCode, index: u16) -> Result<(), ClientError> {
        let mut inner = self.lock();
        if let Some(d) = inner.devices.get_mut(&(interf, index)) {
            d.proxies = d.proxies.saturating_sub(1);
        }
        match inner.dev(interf, index, PLAYER_CLOSE_MODE)? {
            (PLAYER_CLOSE_MODE, _) => Ok(()),
            _ => Err(ClientError::BadReply {
                what: format!("unsubscribe {interf}:{index}"),
            }),
        }
    }

    /// One read, as `playerc_client_read`: in PULL mode one data round (using data already
    /// received first, if any), in PUSH mode one DATA message. The data goes to the devices'
    /// latest values, which proxies read.
    pub fn read(&self) -> Result<(), ClientError> {
        self.lock().read()
    }

    /// `playerc_client_requestdata`: in PULL mode, asks the server for a round of data unless
    /// one is already asked for (nothing in PUSH mode). [`PlayerClient::read`] and
    /// [`PlayerClient::peek`] do it themselves; libplayerc scripts also call it before
    /// polling with [`PlayerClient::read_nonblock`].
    pub fn request_data(&self) -> Result<(), ClientError> {
        self.lock().request_data()
    }

    /// `playerc_client_peek`: whether a message is waiting to be read, waiting at most
    /// `timeout` for one (zero: only looks; `None`: as long as it takes). In PULL mode a
    /// round of data is asked for first ([`PlayerClient::request_data`]); with `request`
    /// false it is not (`playerc_client_internal_peek`). Nothing is consumed: the next read
    /// handles the message.
    pub fn peek(&self, timeout: Option<Duration>, request: bool) -> Result<bool, ClientError> {
        self.lock().peek(timeout, request)
    }

    /// `playerc_client_read_nonblock`: handles the messages that have arrived, without
    /// waiting for more. `true` when they completed a read (a PUSH DATA message, or the
    /// SYNCH ending a PULL round), `false` when nothing that completes one is waiting.
    pub fn read_nonblock(&self) -> Result<bool, ClientError> {
        self.lock().read_nonblock()
    }

    /// The subscribed devices that received DATA since the previous call, in the order of
    /// their first message, with their latest timestamps. Bindings that keep their proxies'
    /// state themselves (the Python `playerc` module) learn from it which proxies a
    /// [`PlayerClient::read`] updated, as `playerc_client_read` reports the proxy it
    /// dispatched to. Proxies' freshness flags are not touched.
    pub fn take_updated(&self) -> Vec<(InterfaceCode, u16, f64)> {
        let mut inner = self.lock();
        let updated = std::mem::take(&mut inner.updated);
        updated
            .into_iter()
            .map(|key| {
                let t = inner.devices.get(&key).map_or(0.0, |d| d.datatime);
                (key.0, key.1, t)
            })
            .collect()
    }

    /// The latest DATA body of (`interf`, `index`, `subtype`).
    pub fn latest(&self, interf: InterfaceCode, index: u16, subtype: u8) -> Option<Body> {
        self.lock()
            .devices
            .get(&(interf, index))?
            .latest
            .get(&subtype)
            .cloned()
    }
}

impl Inner {
    /// Encodes and writes one message.
    fn send(&mut self, addr: DeviceAddr, body: Body) -> Result<(), ClientError> {
        let msg = Message::new(addr, wall_seconds(), body);
        let bytes = msg.encode()?;
        self.stream.write_all(&bytes)?;
        Ok(())
    }

    /// Reads one message, waiting at most until `deadline` (`None`: forever; a past deadline:
    /// only what is already available). `Ok(None)` on timeout.
    fn receive(&mut self, deadline: Option<Instant>) -> Result<Option<Received>, ClientError> {
        loop {
            if let Some(frame) = self.framer.next_frame()? {
                let header = frame.header;
                let body = match frame.decode(&DecodeLimits::default()) {
                    Ok(m) => Some(m.body),
                    // A reply to a subtype the table lacks has only a header.
                    Err(ProtoError::UnknownMessage(_)) if header.size == 0 => None,
                    Err(e) => return Err(e.into()),
                };
                return Ok(Some(Received { header, body }));
            }
            let timeout = deadline.map(|d| d.saturating_duration_since(Instant::now()));
            let n = match timeout {
                Some(t) if t.is_zero() => {
                    self.stream.set_nonblocking(true)?;
                    let r = self.stream.read(&mut self.scratch);
                    self.stream.set_nonblocking(false)?;
                    r
                }
                t => {
                    self.stream.set_read_timeout(t)?;
                    self.stream.read(&mut self.scratch)
                }
            };
            match n {
                Ok(0) => return Err(ClientError::Closed),
                Ok(n) => {
                    let chunk = &self.scratch[..n];
                    self.framer.push(chunk);
                }
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                    ) =>
                {
                    return Ok(None);
                }
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e.into()),
            }
        }
    }

    fn keep(&mut self, m: Received) {
        if self.fifo.len() >= FIFO_LIMIT {
            tracing::warn!("client queue overflow; discarding the oldest message");
            self.fifo.pop_front();
        }
        self.fifo.push_back(m);
    }

    /// `playerc_client_request`: send, then wait for the matching ACK or NACK; DATA and SYNCH
    /// that arrive meanwhile are kept for the next read. A reply that does not match (a late
    /// reply to an earlier, timed-out request) is skipped.
    fn request(&mut self, addr: DeviceAddr, body: Body) -> Result<Received, ClientError> {
        let what = format!("{} on {}:{}", body.constant(), addr.interf, addr.index);
        let subtype = body.subtype();
        self.send(addr, body)?;
        let deadline = Instant::now() + self.request_timeout;
        loop {
            let Some(m) = self.receive(Some(deadline))? else {
                return Err(ClientError::Timeout { what });
            };
            let matches = m.header.addr.interf == addr.interf
                && m.header.addr.index == addr.index
                && m.header.subtype == subtype;
            match m.kind() {
                Some(MsgType::Data | MsgType::Synch) => self.keep(m),
                Some(MsgType::RespAck) if matches => return Ok(m),
                Some(MsgType::RespNack) if matches => return Err(ClientError::Nack { what }),
                Some(MsgType::RespAck | MsgType::RespNack) => {
                    tracing::warn!(
                        "skipping a reply that is not for {what} ({}:{} subtype {})",
                        m.header.addr.interf,
                        m.header.addr.index,
                        m.header.subtype
                    );
                }
                _ => {}
            }
        }
    }

    /// A DEV request; returns the granted access and the driver name.
    fn dev(
        &mut self,
        interf: InterfaceCode,
        index: u16,
        access: u8,
    ) -> Result<(u8, String), ClientError> {
        let req = PlayerReq::Dev(Some(DeviceReq {
            addr: DeviceAddr::new(0, 0, interf, index),
            access,
            driver_name: Text::empty(),
        }));
        let reply = self.request(player_addr(), req.into())?;
        match reply.body {
            Some(Body::Player(PlayerMsg::Ack(PlayerReq::Dev(Some(d))))) => {
                Ok((d.access, d.driver_name.to_str_lossy().into_owned()))
            }
            _ => Err(ClientError::BadReply {
                what: format!("DEV {interf}:{index}"),
            }),
        }
    }

    fn dispatch(&mut self, m: Received) {
        let ts = m.header.timestamp;
        self.datatime = ts;
        let key = (m.header.addr.interf, m.header.addr.index);
        let Some(body) = m.body else { return };
        match self.devices.get_mut(&key) {
            Some(d) => {
                if ts > d.datatime || !d.latest.contains_key(&m.header.subtype) {
                    d.fresh = true;
                }
                d.datatime = ts;
                d.latest.insert(m.header.subtype, body);
                if !self.updated.contains(&key) {
                    self.updated.push(key);
                }
            }
            None => tracing::debug!("data for {}:{} that no proxy reads", key.0, key.1),
        }
    }

    fn request_data(&mut self) -> Result<(), ClientError> {
        if self.mode == DataMode::Pull && !self.data_requested {
            self.request(player_addr(), PlayerReq::Data.into())?;
            self.data_requested = true;
            self.data_received = false;
        }
        Ok(())
    }

    fn peek(&mut self, timeout: Option<Duration>, request: bool) -> Result<bool, ClientError> {
        if !self.fifo.is_empty() {
            return Ok(true);
        }
        if request {
            self.request_data()?;
            // The request's wait may have kept what arrived meanwhile.
            if !self.fifo.is_empty() {
                return Ok(true);
            }
        }
        let deadline = timeout.map(|t| Instant::now() + t);
        match self.receive(deadline)? {
            Some(m) => {
                self.keep(m);
                Ok(true)
            }
            None => Ok(false),
        }
    }

    fn read_nonblock(&mut self) -> Result<bool, ClientError> {
        while let Some(m) = self.next_waiting()? {
            if self.handle(m)? {
                return Ok(true);
            }
        }
        Ok(false)
    }

    /// The next message that is already here: the oldest kept one, else one the socket has
    /// without waiting.
    fn next_waiting(&mut self) -> Result<Option<Received>, ClientError> {
        match self.fifo.pop_front() {
            Some(m) => Ok(Some(m)),
            None => self.receive(Some(Instant::now())),
        }
    }

    /// One message of a read, handled: `true` when it completes the read (a PUSH DATA
    /// message, or the SYNCH ending a PULL round).
    fn handle(&mut self, m: Received) -> Result<bool, ClientError> {
        match (m.kind(), self.mode) {
            (Some(MsgType::Data), DataMode::Push) => {
                self.dispatch(m);
                Ok(true)
            }
            (Some(MsgType::Data), DataMode::Pull) => {
                self.dispatch(m);
                self.data_received = true;
                Ok(false)
            }
            (Some(MsgType::RespAck), _) => {
                tracing::warn!("discarding unclaimed ACK");
                Ok(false)
            }
            (Some(MsgType::Synch), DataMode::Push) => Ok(false),
            (Some(MsgType::Synch), DataMode::Pull) => self.end_round(m).map(|()| true),
            (kind, _) => Err(unexpected(kind, &m)),
        }
    }

    /// The SYNCH that ends a PULL round: the round is over; an error when it brought no data
    /// or the server dropped messages for this client (its overflow count).
    fn end_round(&mut self, m: Received) -> Result<(), ClientError> {
        self.data_requested = false;
        if let Some(Body::Player(PlayerMsg::Synch(PlayerSynch::Overflow(n)))) = m.body {
            self.overflow = self.overflow.saturating_add(n.value);
        }
        if !self.data_received {
            return Err(ClientError::NoData);
        }
        if self.overflow > 0 {
            let dropped = std::mem::take(&mut self.overflow);
            return Err(ClientError::Overflow { dropped });
        }
        Ok(())
    }

    fn read(&mut self) -> Result<(), ClientError> {
        let deadline = self.read_timeout.map(|t| Instant::now() + t);
        if self.fifo.is_empty() {
            self.request_data()?;
        }
        loop {
            let m = match self.next_waiting()? {
                Some(m) => m,
                None if self.mode == DataMode::Pull
                    && !self.data_requested
                    && self.data_received =>
                {
                    return Ok(());
                }
                None => self
                    .receive(deadline)?
                    .ok_or_else(|| ClientError::Timeout {
                        what: "data".into(),
                    })?,
            };
            if self.handle(m)? {
                return Ok(());
            }
        }
    }
}

/// The error for a message a read cannot place (a NACK nobody waits for, a request).
fn unexpected(kind: Option<MsgType>, m: &Received) -> ClientError {
    ClientError::Unexpected(format!(
        "{:?} from {}:{} subtype {}",
        kind, m.header.addr.interf, m.header.addr.index, m.header.subtype
    ))
}
