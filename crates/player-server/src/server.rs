//! Building and running a server: drivers from cfg blocks, the device table, one listener per
//! port, the core task and the I/O runtime.
//!
//! The API is synchronous: [`Server::start`] returns once every port listens, with a
//! [`ServerHandle`] that reports the ports and stops everything. Connections and the core task
//! (which owns the drivers) run on a small tokio runtime owned by the handle.

use std::collections::HashMap;
use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use tokio::net::{TcpListener, TcpSocket};
use tokio::runtime::Runtime;
use tokio::sync::{mpsc, watch};

use player_proto::constants::LOCALHOST_ADDR;

use crate::clock::{DEFAULT_STEP, Pace, Schedule, ServerClock};
use crate::connection::{self, ConnContext, ConnectionLimits};
use crate::core::{Bus, Core, DriverSlot, Subscriber};
use crate::device::{Device, DeviceTable, DriverId};
use crate::driver::{
    ClientId, Driver, DriverBlock, DriverRegistry, ProvidedDevice, RequiredDevice,
};
use crate::error::ServerError;

/// Listen backlog, as upstream's `create_and_bind_socket`.
const BACKLOG: u32 = 200;

/// How a server runs.
#[derive(Clone, Debug)]
pub struct ServerConfig {
    /// Stepping pace: real time (default) or as fast as possible.
    pub pace: Pace,
    /// Address the listeners bind (all interfaces by default, as upstream).
    pub bind: IpAddr,
    /// Per-connection limits.
    pub limits: ConnectionLimits,
    /// Threads of the I/O runtime.
    pub io_threads: usize,
}

impl Default for ServerConfig {
    fn default() -> Self {
        ServerConfig {
            pace: Pace::default(),
            bind: IpAddr::V4(Ipv4Addr::UNSPECIFIED),
            limits: ConnectionLimits::default(),
            io_threads: 2,
        }
    }
}

struct PendingDriver {
    driver: Box<dyn Driver>,
    name: String,
    origin: String,
    alwayson: bool,
    requires: Vec<RequiredDevice>,
}

/// Builds the driver that reaches a device on another Player server (one per remote
/// address); the server's `requires` resolution calls it for every address it does not
/// serve itself.
pub type RemoteFactory =
    Box<dyn FnMut(&RequiredDevice) -> Result<Box<dyn Driver>, crate::driver::DriverError> + Send>;

/// The driver name remote devices are listed under (as upstream's `TCPRemoteDriver`); their
/// ports are never opened locally.
pub const REMOTE_DRIVER_NAME: &str = "remote";

/// A server being assembled: drivers and their devices, in cfg order.
pub struct Server {
    config: ServerConfig,
    table: DeviceTable,
    drivers: Vec<PendingDriver>,
    listeners: HashMap<u32, std::net::TcpListener>,
    /// The port the OS chose for devices configured on port 0, once one was.
    port_zero: Option<u32>,
    remote: Option<RemoteFactory>,
    /// Only assembled and checked, never started: binds nothing (see [`Server::for_check`]).
    check_only: bool,
}

impl std::fmt::Debug for Server {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Server")
            .field("config", &self.config)
            .field("devices", &self.table.len())
            .field("drivers", &self.drivers.len())
            .finish()
    }
}

impl Server {
    /// An empty server. Devices of other Player servers are reached over TCP
    /// ([`crate::remote_device::RemoteDevice`]).
    pub fn new(config: ServerConfig) -> Server {
        Server {
            config,
            table: DeviceTable::new(),
            drivers: Vec::new(),
            listeners: HashMap::new(),
            port_zero: None,
            remote: Some(Box::new(|required: &RequiredDevice| {
                Ok(Box::new(crate::remote_device::RemoteDevice::new(required)) as Box<dyn Driver>)
            })),
            check_only: false,
        }
    }

    /// A server that is only assembled to see what a cfg makes of it (`player --check`) and is
    /// never started: it builds drivers and resolves `requires` exactly as [`Server::new`]'s
    /// does, but devices on port 0 keep port 0 instead of having a listener bound for them.
    pub fn for_check(config: ServerConfig) -> Server {
        Server {
            check_only: true,
            ..Server::new(config)
        }
    }

    /// Sets how devices on other Player servers are reached (see [`RemoteFactory`]); `None`
    /// makes a `requires` naming a device this server does not serve a start-up error.
    pub fn set_remote_factory(&mut self, factory: Option<RemoteFactory>) {
        self.remote = factory;
    }

    /// Gives devices configured on port 0 the port the OS picks (bound now, once, and served
    /// later), so drivers only ever see final addresses.
    fn resolve_port_zero(&mut self, block: &DriverBlock) -> Result<DriverBlock, ServerError> {
        let mut block = block.clone();
        if self.check_only
            || (!block.provides.iter().any(|p| p.addr.robot == 0)
                && !block.requires.iter().any(|r| r.addr.robot == 0))
        {
            return Ok(block);
        }
        let port = match self.port_zero {
            Some(p) => p,
            None => {
                let err = |source| ServerError::Listen { port: 0, source };
                let listener = std::net::TcpListener::bind(SocketAddr::new(self.config.bind, 0))
                    .map_err(err)?;
                let port = u32::from(listener.local_addr().map_err(err)?.port());
                self.listeners.insert(port, listener);
                self.port_zero = Some(port);
                port
            }
        };
        let addrs = block.provides.iter_mut().map(|p| &mut p.addr);
        for addr in addrs.chain(block.requires.iter_mut().map(|r| &mut r.addr)) {
            if addr.robot == 0 {
                addr.robot = port;
            }
        }
        Ok(block)
    }

    /// Builds the driver of a cfg block with `registry` and adds its devices. Devices on port
    /// 0 get a port chosen by the OS before the driver is built.
    pub fn add_block(
        &mut self,
        block: &DriverBlock,
        registry: &mut DriverRegistry,
    ) -> Result<DriverId, ServerError> {
        let block = self.resolve_port_zero(block)?;
        let driver = registry.create(&block)?;
        self.add_driver(&block, driver)
    }

    /// Adds an already built driver serving the devices of `block` (its `name` is the driver
    /// name clients see; its `alwayson`, when written, overrides [`Driver::always_on`]).
    /// Devices on port 0 are given the OS-chosen port here, after the driver was built: use
    /// [`Server::add_block`] for drivers that need their final addresses.
    pub fn add_driver(
        &mut self,
        block: &DriverBlock,
        driver: Box<dyn Driver>,
    ) -> Result<DriverId, ServerError> {
        let block = &self.resolve_port_zero(block)?;
        if block.provides.is_empty() {
            return Err(ServerError::NoInterfaces {
                name: block.name.clone(),
                origin: block.origin.clone(),
            });
        }
        let id = DriverId(self.drivers.len());
        // All or nothing: check every address before adding any.
        let mut trial = self.table.clone();
        for ProvidedDevice { addr, key, origin } in &block.provides {
            trial.add(Device {
                addr: *addr,
                key: key.clone(),
                driver: id,
                driver_name: block.name.clone(),
                origin: origin.clone(),
            })?;
        }
        self.table = trial;
        let alwayson = block.alwayson.unwrap_or_else(|| driver.always_on());
        self.drivers.push(PendingDriver {
            driver,
            name: block.name.clone(),
            origin: block.origin.clone(),
            alwayson,
            requires: block.requires.clone(),
        });
        Ok(id)
    }

    /// Resolves every block's `requires`, now that every block is built (a block may require a
    /// device a later block provides): each names a device of this server, or, when its host
    /// or port is not served here, a device of another server, reached through a remote
    /// driver added once per address. A local address nothing provides, and a cycle of
    /// `requires`, are errors naming the cfg line. Idempotent; [`Server::start`] calls it.
    pub fn resolve_requires(&mut self) -> Result<(), ServerError> {
        match self.resolve_all_requires().into_iter().next() {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }

    /// [`Server::resolve_requires`], going on past every problem: all of them, in cfg order
    /// (a cycle last). What `player --check` reports.
    pub fn resolve_all_requires(&mut self) -> Vec<ServerError> {
        let mut problems = Vec::new();
        let local_ports = self.table.ports();
        let mut wanted: Vec<RequiredDevice> = Vec::new();
        for d in &self.drivers {
            for r in &d.requires {
                if self.table.find(&r.addr).is_some() {
                    continue;
                }
                let is_local_host = r.addr.host == LOCALHOST_ADDR || r.addr.host == 0;
                if is_local_host && local_ports.contains(&r.addr.robot) {
                    problems.push(ServerError::RequiresMissing {
                        origin: r.origin.clone(),
                        addr: r.addr,
                        driver: d.name.clone(),
                    });
                    continue;
                }
                if !wanted.iter().any(|w| w.addr.same_device(&r.addr)) {
                    wanted.push(r.clone());
                }
            }
        }
        for r in wanted {
            let driver = match self.remote.as_mut() {
                Some(make) => match make(&r) {
                    Ok(driver) => driver,
                    Err(source) => {
                        problems.push(ServerError::DriverFailed {
                            name: REMOTE_DRIVER_NAME.into(),
                            origin: r.origin.clone(),
                            source,
                        });
                        continue;
                    }
                },
                None => {
                    problems.push(ServerError::RequiresMissing {
                        origin: r.origin.clone(),
                        addr: r.addr,
                        driver: REMOTE_DRIVER_NAME.into(),
                    });
                    continue;
                }
            };
            let block = DriverBlock {
                alwayson: Some(false),
                ..DriverBlock::new(REMOTE_DRIVER_NAME, r.origin.clone())
                    .providing([r.addr], &r.origin)
            };
            if let Err(e) = self.add_driver(&block, driver) {
                problems.push(e);
            }
        }
        problems.extend(self.check_cycles().err());
        problems
    }

    /// Refuses a cycle of `requires` (it could never be set up), naming each block on it.
    fn check_cycles(&self) -> Result<(), ServerError> {
        // Driver -> drivers it requires, through the device table.
        let edges: Vec<Vec<usize>> = self
            .drivers
            .iter()
            .map(|d| {
                d.requires
                    .iter()
                    .filter_map(|r| self.table.find(&r.addr))
                    .map(|i| self.table.get(i).driver.0)
                    .collect()
            })
            .collect();
        // 0 = unseen, 1 = on the current path, 2 = done.
        let mut mark = vec![0u8; edges.len()];
        let mut path = Vec::new();
        fn visit(
            n: usize,
            edges: &[Vec<usize>],
            mark: &mut [u8],
            path: &mut Vec<usize>,
        ) -> Option<Vec<usize>> {
            mark[n] = 1;
            path.push(n);
            for &m in &edges[n] {
                if mark[m] == 1 {
                    let start = path.iter().position(|&p| p == m).unwrap_or(0);
                    let mut cycle = path[start..].to_vec();
                    cycle.push(m);
                    return Some(cycle);
                }
                if mark[m] == 0 {
                    if let Some(c) = visit(m, edges, mark, path) {
                        return Some(c);
                    }
                }
            }
            path.pop();
            mark[n] = 2;
            None
        }
        for n in 0..edges.len() {
            if mark[n] == 0 {
                if let Some(cycle) = visit(n, &edges, &mut mark, &mut path) {
                    let chain = cycle
                        .iter()
                        .map(|&i| {
                            format!("\"{}\" ({})", self.drivers[i].name, self.drivers[i].origin)
                        })
                        .collect::<Vec<_>>()
                        .join(" requires ");
                    return Err(ServerError::RequiresCycle {
                        origin: self.drivers[cycle[0]].origin.clone(),
                        chain,
                    });
                }
            }
        }
        Ok(())
    }

    /// Serves `port` on an already bound listener instead of binding it (tests bind port 0
    /// first to learn a free port, then configure devices on it).
    pub fn use_listener(&mut self, port: u32, listener: std::net::TcpListener) {
        self.listeners.insert(port, listener);
    }

    /// The device table so far.
    pub fn table(&self) -> &DeviceTable {
        &self.table
    }

    /// Subscribes alwayson drivers, opens one listener per port, starts the runtime with the
    /// core task and the acceptors. Port 0 is given a free port by the OS; its devices are relabelled.
    pub fn start(mut self) -> Result<ServerHandle, ServerError> {
        self.resolve_requires()?;
        let Server {
            config,
            mut table,
            drivers,
            mut listeners,
            port_zero: _,
            remote: _,
            check_only: _,
        } = self;
        if table.is_empty() {
            return Err(ServerError::NoDevices);
        }
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(config.io_threads.max(1))
            .thread_name("player-io")
            .enable_all()
            .build()
            .map_err(ServerError::Runtime)?;

        // Listeners first: port 0 relabelling changes device addresses.
        let mut bound = Vec::new();
        let guard = runtime.enter();
        for port in table.ports() {
            let listener = match listeners.remove(&port) {
                Some(l) => l
                    .set_nonblocking(true)
                    .and_then(|()| TcpListener::from_std(l))
                    .map_err(|source| ServerError::Listen { port, source })?,
                None => bind(config.bind, port)?,
            };
            let actual = listener
                .local_addr()
                .map_err(|source| ServerError::Listen { port, source })?
                .port();
            bound.push((port, u32::from(actual), listener));
        }
        drop(guard);
        for (asked, actual, _) in &bound {
            table.relabel_port(*asked, *actual);
        }

        let alwayson: Vec<bool> = drivers.iter().map(|d| d.alwayson).collect();
        let slots: Vec<DriverSlot> = drivers
            .into_iter()
            .map(|d| DriverSlot {
                driver: d.driver,
                name: d.name,
                subscriptions: 0,
            })
            .collect();
        ServerHandle::launch(config, table, slots, &alwayson, bound, runtime)
    }
}

/// Binds a listener like upstream: `SO_REUSEADDR`, backlog 200. Needs a runtime context.
fn bind(ip: IpAddr, port: u32) -> Result<TcpListener, ServerError> {
    let tcp_port = u16::try_from(port).map_err(|_| ServerError::BadPort(port))?;
    let err = |source| ServerError::Listen { port, source };
    let socket = match ip {
        IpAddr::V4(_) => TcpSocket::new_v4(),
        IpAddr::V6(_) => TcpSocket::new_v6(),
    }
    .map_err(err)?;
    socket.set_reuseaddr(true).map_err(err)?;
    socket.bind(SocketAddr::new(ip, tcp_port)).map_err(err)?;
    socket.listen(BACKLOG).map_err(err)
}

/// A running server. Dropping it stops the server.
pub struct ServerHandle {
    ports: Vec<u16>,
    table: Arc<DeviceTable>,
    clock: ServerClock,
    stop: watch::Sender<bool>,
    runtime: Option<Runtime>,
    core: Option<tokio::task::JoinHandle<()>>,
}

impl std::fmt::Debug for ServerHandle {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ServerHandle")
            .field("ports", &self.ports)
            .finish()
    }
}

impl ServerHandle {
    fn launch(
        config: ServerConfig,
        table: DeviceTable,
        slots: Vec<DriverSlot>,
        alwayson: &[bool],
        bound: Vec<(u32, u32, TcpListener)>,
        runtime: Runtime,
    ) -> Result<ServerHandle, ServerError> {
        let table = Arc::new(table);
        let clock = ServerClock::new();
        let clock_driver = slots.iter().position(|s| s.driver.clock().is_some());
        if let Some(t) = clock_driver.and_then(|d| slots[d].driver.clock()) {
            clock.set_simulated(t);
        }
        let schedule = Schedule::new(
            config.pace,
            slots
                .iter()
                .map(|s| s.driver.step().unwrap_or(DEFAULT_STEP)),
        );
        let (stop, stop_rx) = watch::channel(false);
        let (events_tx, events_rx) = mpsc::channel(4096);
        let (wake_tx, wake_rx) = mpsc::unbounded_channel();
        let mut bus = Bus::new(
            table.clone(),
            slots,
            clock.clone(),
            clock_driver,
            schedule,
            wake_tx,
        );
        // Alwayson drivers are subscribed to every device they serve, before any client; their
        // setup may start tasks, hence the runtime context.
        {
            let _guard = runtime.enter();
            for (i, dev) in table.devices().iter().enumerate() {
                if alwayson[dev.driver.0] {
                    bus.subscribe(Subscriber::AlwaysOn, crate::device::DeviceIndex(i))
                        .map_err(|source| ServerError::AlwaysOnFailed {
                            addr: dev.addr,
                            source,
                        })?;
                }
            }
        }
        let core = Core::new(bus, events_rx, wake_rx, stop_rx.clone());

        let ctx = ConnContext {
            table: table.clone(),
            core: events_tx,
            clock: clock.clone(),
            limits: config.limits,
        };
        let next_id = Arc::new(AtomicU64::new(0));
        let mut ports = Vec::new();
        for (_, actual, listener) in bound {
            ports.push(actual as u16);
            runtime.spawn(accept_loop(
                listener,
                actual,
                ctx.clone(),
                next_id.clone(),
                stop_rx.clone(),
            ));
        }
        drop(ctx);

        let stop_on_exit = stop.clone();
        let core = runtime.spawn(async move {
            // However the core ends (even by a panic of its own; a driver's panic is caught and
            // only takes that driver out of service), the whole server stops.
            struct StopOnExit(watch::Sender<bool>);
            impl Drop for StopOnExit {
                fn drop(&mut self) {
                    self.0.send_replace(true);
                }
            }
            let _stop = StopOnExit(stop_on_exit);
            core.run().await;
        });

        Ok(ServerHandle {
            ports,
            table,
            clock,
            stop,
            runtime: Some(runtime),
            core: Some(core),
        })
    }

    /// The ports listened on, in order of first appearance in the cfg (port 0 replaced by the
    /// port the OS chose).
    pub fn ports(&self) -> &[u16] {
        &self.ports
    }

    /// The device table, with final port numbers.
    pub fn table(&self) -> &DeviceTable {
        &self.table
    }

    /// The server clock.
    pub fn clock(&self) -> &ServerClock {
        &self.clock
    }

    /// Stops the server on SIGINT or SIGTERM (Unix).
    pub fn stop_on_signals(&self) {
        let Some(rt) = &self.runtime else { return };
        let stop = self.stop.clone();
        rt.spawn(async move {
            #[cfg(unix)]
            {
                use tokio::signal::unix::{SignalKind, signal};
                let (Ok(mut int), Ok(mut term)) = (
                    signal(SignalKind::interrupt()),
                    signal(SignalKind::terminate()),
                ) else {
                    tracing::error!("cannot install signal handlers");
                    return;
                };
                tokio::select! {
                    _ = int.recv() => {}
                    _ = term.recv() => {}
                }
            }
            #[cfg(not(unix))]
            {
                let _ = tokio::signal::ctrl_c().await;
            }
            stop.send_replace(true);
        });
    }

    /// Blocks until the server is asked to stop (signal, [`ServerHandle::stop`], or the core
    /// ending).
    pub fn wait(&self) {
        let mut rx = self.stop.subscribe();
        if let Some(rt) = &self.runtime {
            rt.block_on(async move {
                let _ = rx.wait_for(|s| *s).await;
            });
        }
    }

    /// Asks the server to stop (returns at once).
    pub fn stop(&self) {
        self.stop.send_replace(true);
    }

    /// Stops the server and waits for its threads: connections are closed, drivers shut down.
    pub fn shutdown(mut self) {
        self.stop_and_join();
    }

    fn stop_and_join(&mut self) {
        self.stop.send_replace(true);
        if let (Some(core), Some(rt)) = (self.core.take(), self.runtime.as_ref()) {
            if rt.block_on(core).is_err() {
                tracing::error!("the core task panicked");
            }
        }
        if let Some(rt) = self.runtime.take() {
            rt.shutdown_timeout(Duration::from_secs(1));
        }
    }
}

impl Drop for ServerHandle {
    fn drop(&mut self) {
        self.stop_and_join();
    }
}

async fn accept_loop(
    listener: TcpListener,
    port: u32,
    ctx: ConnContext,
    next_id: Arc<AtomicU64>,
    mut stop: watch::Receiver<bool>,
) {
    tracing::debug!("listening on port {port}");
    loop {
        let accepted = tokio::select! {
            a = listener.accept() => a,
            _ = stop.wait_for(|s| *s) => return,
        };
        match accepted {
            Ok((stream, peer)) => {
                let id = ClientId(next_id.fetch_add(1, Ordering::Relaxed));
                tokio::spawn(connection::serve(stream, peer, port, id, ctx.clone()));
            }
            Err(e) => {
                // E.g. out of file descriptors: back off instead of spinning.
                tracing::warn!("accept on port {port} failed: {e}");
                tokio::time::sleep(Duration::from_millis(50)).await;
            }
        }
    }
}
