//! `Connection`: one `player-client` session to a Player server, for Python.
//!
//! The Python proxies (`playerc.playerc_position2d`, `playercpp.Position2dProxy`,
//! `playerstage.Client`) keep their own state and call these methods; each request or command
//! is built here from the workspace's message types and sent through `player-client`, which
//! owns the socket, the PULL/PUSH rules and the reply matching. Blocking calls release the GIL,
//! so other Python threads run while one waits for the server.

use std::time::Duration;

use player_client::{
    ClientError, DataMode, FiducialProxy, Graphics2dProxy, GripperProxy, LaserProxy, LocalizeProxy,
    MapProxy, PlannerProxy, PlayerClient, Position2dProxy, RangerProxy, SimulationProxy,
    SonarProxy, SpeechProxy,
};
use player_proto::*;
use pyo3::IntoPyObjectExt;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyList};

use crate::convert;
use crate::errors::{ConnectionLost, PlayerError, client_err};

/// A connection to a Player server (`host`, `port`), in PULL mode after connecting as
/// libplayerc's. `disconnect()` closes it; any call after that raises `ConnectionLost`.
///
/// A connection belongs to the process that opened it: a child forked from that process (a
/// `multiprocessing` or `AsyncVectorEnv` worker started with `fork`) that uses an inherited one
/// gets `ConnectionLost` saying so, because parent and child would share one socket and read
/// each other's replies, and a lock the parent held at the fork would never be released.
#[pyclass(module = "playerstage._native")]
pub struct Connection {
    client: Option<PlayerClient>,
    /// The process that opened the connection.
    opened_in: u32,
    /// `host:port`, for the messages.
    peer: String,
}

/// The bodies `read()` hands back: (interface code, index, timestamp, fields or None).
type Updates = Vec<(u16, u16, f64, Vec<Body>)>;

fn pose(p: [f64; 3]) -> Pose2d {
    Pose2d {
        px: p[0],
        py: p[1],
        pa: p[2],
    }
}

fn pose3(p: [f64; 6]) -> Pose3d {
    Pose3d {
        px: p[0],
        py: p[1],
        pz: p[2],
        proll: p[3],
        ppitch: p[4],
        pyaw: p[5],
    }
}

fn color(c: (u8, u8, u8, u8)) -> Color {
    Color {
        alpha: c.0,
        red: c.1,
        green: c.2,
        blue: c.3,
    }
}

fn points(pts: Vec<(f64, f64)>) -> Vec<Point2d> {
    pts.into_iter().map(|(px, py)| Point2d { px, py }).collect()
}

/// The devices the last read updated, with the latest DATA of each of their subtypes.
fn updated(client: &PlayerClient) -> Updates {
    client
        .take_updated()
        .into_iter()
        .map(|(interf, index, t)| {
            let bodies = (0u8..=8)
                .filter_map(|s| client.latest(interf, index, s))
                .collect();
            (interf.0, index, t, bodies)
        })
        .collect()
}

/// `read()`'s answer: `(interface code, index, timestamp, fields)` per updated device, the
/// fields of all its bodies merged into one dict of libplayerc names.
fn updates_to_py(py: Python<'_>, updates: Updates) -> PyResult<Bound<'_, PyList>> {
    let out = PyList::empty(py);
    for (interf, index, t, bodies) in updates {
        let fields = PyDict::new(py);
        for b in &bodies {
            if let Some(d) = convert::data(py, b)? {
                fields.update(d.as_mapping())?;
            }
        }
        out.append((interf, index, t, fields))?;
    }
    Ok(out)
}

fn bad_reply(what: &str) -> PyErr {
    PlayerError::new_err(format!("unexpected reply to {what}"))
}

impl Connection {
    fn client(&self) -> PyResult<PlayerClient> {
        let here = std::process::id();
        if here != self.opened_in {
            return Err(ConnectionLost::new_err(format!(
                "the connection to {} was opened in process {}, and this is process {here}, a \
                 forked child: a child cannot share its parent's connection; open a new one in \
                 the child, or start workers with the 'spawn' or 'forkserver' method",
                self.peer, self.opened_in
            )));
        }
        self.client
            .clone()
            .ok_or_else(|| ConnectionLost::new_err("not connected (disconnect() was called)"))
    }

    /// Sends a request with the GIL released; the ACK's body.
    fn request(
        &self,
        py: Python<'_>,
        interf: InterfaceCode,
        index: u16,
        body: impl Into<Body> + Send,
    ) -> PyResult<Option<Body>> {
        let client = self.client()?;
        py.allow_threads(move || client.request(interf, index, body))
            .map_err(client_err)
    }

    /// Runs `f` on the client with the GIL released. The typed requests are player-client's
    /// proxies' own, on handles `attach`ed without subscribing (the Python proxies hold the
    /// subscriptions), so each request and its ACK's unpacking is written once.
    fn call<T: Send>(
        &self,
        py: Python<'_>,
        f: impl FnOnce(&PlayerClient) -> Result<T, ClientError> + Send,
    ) -> PyResult<T> {
        let client = self.client()?;
        py.allow_threads(move || f(&client)).map_err(client_err)
    }

    /// Runs `f` on the client without releasing the GIL: for commands through player-client's
    /// proxies (never answered, so nothing to wait for).
    fn send<T>(&self, f: impl FnOnce(&PlayerClient) -> Result<T, ClientError>) -> PyResult<T> {
        f(&self.client()?).map_err(client_err)
    }

    /// Sends a command (never answered).
    fn command(&self, interf: InterfaceCode, index: u16, body: impl Into<Body>) -> PyResult<()> {
        self.client()?
            .command(interf, index, body)
            .map_err(client_err)
    }
}

#[pymethods]
impl Connection {
    /// Connects to `host:port` (reads the banner, switches to PULL mode).
    #[new]
    fn new(py: Python<'_>, host: String, port: u16) -> PyResult<Self> {
        let peer = format!("{host}:{port}");
        let client = py
            .allow_threads(move || PlayerClient::connect(&host, port))
            .map_err(client_err)?;
        Ok(Connection {
            client: Some(client),
            opened_in: std::process::id(),
            peer,
        })
    }

    /// Closes the connection (the server ends this client's subscriptions).
    fn disconnect(&mut self) {
        self.client = None;
    }

    /// True until `disconnect()`.
    #[getter]
    fn connected(&self) -> bool {
        self.client.is_some()
    }

    /// The server's banner (`Player v.3.0.2`).
    #[getter]
    fn banner(&self) -> PyResult<String> {
        Ok(self.client()?.banner())
    }

    /// Timestamp of the latest DATA received (server time).
    #[getter]
    fn datatime(&self) -> PyResult<f64> {
        Ok(self.client()?.datatime())
    }

    /// True in PULL mode, False in PUSH mode.
    #[getter]
    fn pull(&self) -> PyResult<bool> {
        Ok(self.client()?.datamode() == DataMode::Pull)
    }

    /// Switches PULL (True) / PUSH (False) (`PLAYER_PLAYER_REQ_DATAMODE`).
    fn set_pull(&self, py: Python<'_>, pull: bool) -> PyResult<()> {
        let client = self.client()?;
        let mode = if pull { DataMode::Pull } else { DataMode::Push };
        py.allow_threads(move || client.set_datamode(mode))
            .map_err(client_err)
    }

    /// How long requests wait for their reply, in seconds (default 5).
    fn set_request_timeout(&self, seconds: f64) -> PyResult<()> {
        let t = Duration::try_from_secs_f64(seconds)
            .map_err(|e| PlayerError::new_err(format!("request timeout {seconds}: {e}")))?;
        self.client()?.set_request_timeout(t);
        Ok(())
    }

    /// How long `read()` waits for data, in seconds (`None`: as long as it takes).
    #[pyo3(signature = (seconds=None))]
    fn set_read_timeout(&self, seconds: Option<f64>) -> PyResult<()> {
        let t = seconds
            .map(Duration::try_from_secs_f64)
            .transpose()
            .map_err(|e| PlayerError::new_err(format!("read timeout {seconds:?}: {e}")))?;
        self.client()?.set_read_timeout(t);
        Ok(())
    }

    /// `playerc_client_set_replace_rule`: -1 matches any interface/index/type/subtype;
    /// `action` 0 accept, 1 replace, 2 ignore.
    fn set_replace_rule(
        &self,
        py: Python<'_>,
        interf: i32,
        index: i32,
        msg_type: i32,
        subtype: i32,
        action: i32,
    ) -> PyResult<()> {
        let client = self.client()?;
        py.allow_threads(move || client.add_replace_rule(interf, index, msg_type, subtype, action))
            .map_err(client_err)
    }

    /// The server's devices: `(interface code, index, driver name)` each.
    fn device_list(&self, py: Python<'_>) -> PyResult<Vec<(u16, u16, String)>> {
        let client = self.client()?;
        let list = py
            .allow_threads(move || client.device_list())
            .map_err(client_err)?;
        Ok(list
            .into_iter()
            .map(|d| (d.addr.interf.0, d.addr.index, d.driver_name))
            .collect())
    }

    /// Subscribes to (`interf`, `index`); returns the driver name. A missing device raises
    /// `RequestRefused`.
    fn subscribe(&self, py: Python<'_>, interf: u16, index: u16) -> PyResult<String> {
        let client = self.client()?;
        py.allow_threads(move || client.subscribe(InterfaceCode(interf), index))
            .map_err(client_err)
    }

    /// Ends one subscription.
    fn unsubscribe(&self, py: Python<'_>, interf: u16, index: u16) -> PyResult<()> {
        let client = self.client()?;
        py.allow_threads(move || client.unsubscribe(InterfaceCode(interf), index))
            .map_err(client_err)
    }

    /// One `playerc_client_read`: a PULL round, or one PUSH message. Returns the devices that
    /// received data as `(interface code, index, timestamp, fields)`, where `fields` is one
    /// dict merging the latest DATA of every subtype (libplayerc's field names). The server's
    /// overflow reports (messages it dropped for a slow client) are not errors, as in
    /// libplayerc.
    fn read<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let client = self.client()?;
        let updates: Updates = py
            .allow_threads(move || -> Result<Updates, ClientError> {
                match client.read() {
                    // libplayerc counts the server's overflow reports and goes on: the round
                    // still holds the newest data of every device.
                    Ok(()) | Err(ClientError::Overflow { .. }) => {}
                    Err(e) => return Err(e),
                }
                Ok(updated(&client))
            })
            .map_err(client_err)?;
        updates_to_py(py, updates)
    }

    /// `playerc_client_requestdata`: in PULL mode, asks for a round of data unless one is
    /// asked for already.
    fn request_data(&self, py: Python<'_>) -> PyResult<()> {
        self.call(py, |c| c.request_data())
    }

    /// `playerc_client_peek` (`request` true) / `internal_peek` (false): whether a message
    /// is waiting, waiting at most `seconds` (`None`: as long as it takes).
    #[pyo3(signature = (seconds, request=true))]
    fn peek(&self, py: Python<'_>, seconds: Option<f64>, request: bool) -> PyResult<bool> {
        let timeout = seconds
            .map(|s| Duration::try_from_secs_f64(s.max(0.0)))
            .transpose()
            .map_err(|e| PlayerError::new_err(format!("peek timeout {seconds:?}: {e}")))?;
        self.call(py, move |c| c.peek(timeout, request))
    }

    /// `playerc_client_read_nonblock`: handles what has arrived without waiting. `None` when
    /// that completed no read, else the updates as `read()` returns them.
    fn read_nonblock<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyList>>> {
        let client = self.client()?;
        let updates = py
            .allow_threads(move || -> Result<Option<Updates>, ClientError> {
                match client.read_nonblock() {
                    Ok(true) | Err(ClientError::Overflow { .. }) => Ok(Some(updated(&client))),
                    Ok(false) => Ok(None),
                    Err(e) => Err(e),
                }
            })
            .map_err(client_err)?;
        updates.map(|u| updates_to_py(py, u)).transpose()
    }

    // --- position2d -------------------------------------------------------------------

    /// `playerc_position2d_set_cmd_vel`.
    fn position2d_set_cmd_vel(
        &self,
        index: u16,
        vx: f64,
        vy: f64,
        va: f64,
        state: u8,
    ) -> PyResult<()> {
        self.command(
            InterfaceCode::POSITION2D,
            index,
            Position2dCmd::Vel(Position2dCmdVel {
                vel: pose([vx, vy, va]),
                state,
            }),
        )
    }

    /// `playerc_position2d_set_cmd_pose_with_vel`.
    fn position2d_set_cmd_pose_with_vel(
        &self,
        index: u16,
        pos: [f64; 3],
        vel: [f64; 3],
        state: u8,
    ) -> PyResult<()> {
        self.command(
            InterfaceCode::POSITION2D,
            index,
            Position2dCmd::Pos(Position2dCmdPos {
                pos: pose(pos),
                vel: pose(vel),
                state,
            }),
        )
    }

    /// `playerc_position2d_set_cmd_vel_head`: forward speed and absolute heading.
    fn position2d_set_cmd_vel_head(&self, index: u16, vx: f64, pa: f64) -> PyResult<()> {
        self.command(
            InterfaceCode::POSITION2D,
            index,
            Position2dCmd::VelHead(Position2dCmdVelHead {
                velocity: vx,
                angle: pa,
            }),
        )
    }

    /// `playerc_position2d_set_cmd_car`.
    fn position2d_set_cmd_car(&self, index: u16, vx: f64, a: f64) -> PyResult<()> {
        self.command(
            InterfaceCode::POSITION2D,
            index,
            Position2dCmd::Car(Position2dCmdCar {
                velocity: vx,
                angle: a,
            }),
        )
    }

    /// `playerc_position2d_enable` (motor power).
    fn position2d_enable(&self, py: Python<'_>, index: u16, enable: bool) -> PyResult<()> {
        self.call(py, move |c| {
            Position2dProxy::attach(c, index).set_motor_enable(enable)
        })
    }

    /// `playerc_position2d_set_odom`.
    fn position2d_set_odom(&self, py: Python<'_>, index: u16, p: [f64; 3]) -> PyResult<()> {
        self.call(py, move |c| {
            Position2dProxy::attach(c, index).set_odometry(p[0], p[1], p[2])
        })
    }

    /// RESET_ODOM.
    fn position2d_reset_odom(&self, py: Python<'_>, index: u16) -> PyResult<()> {
        self.call(py, move |c| {
            Position2dProxy::attach(c, index).reset_odometry()
        })
    }

    /// `playerc_position2d_get_geom`: `{pose: [6], size: [3]}`.
    fn position2d_get_geom<'py>(
        &self,
        py: Python<'py>,
        index: u16,
    ) -> PyResult<Bound<'py, PyDict>> {
        let g = self.call(py, move |c| {
            Position2dProxy::attach(c, index).request_geom()
        })?;
        convert::pose_size(py, &g.pose, &g.size)
    }

    // --- ranger -----------------------------------------------------------------------

    /// `playerc_ranger_get_geom`.
    fn ranger_get_geom<'py>(&self, py: Python<'py>, index: u16) -> PyResult<Bound<'py, PyDict>> {
        let g = self.call(py, move |c| RangerProxy::attach(c, index).request_geom())?;
        convert::ranger_geom(py, &g)
    }

    /// `playerc_ranger_get_config`.
    fn ranger_get_config<'py>(&self, py: Python<'py>, index: u16) -> PyResult<Bound<'py, PyDict>> {
        let c = self.call(py, move |c| RangerProxy::attach(c, index).request_config())?;
        convert::ranger_config(py, &c)
    }

    /// `playerc_ranger_set_config`: the seven values in libplayerc's order; returns the
    /// configuration the device applied.
    #[allow(clippy::too_many_arguments)]
    fn ranger_set_config<'py>(
        &self,
        py: Python<'py>,
        index: u16,
        min_angle: f64,
        max_angle: f64,
        angular_res: f64,
        min_range: f64,
        max_range: f64,
        range_res: f64,
        frequency: f64,
    ) -> PyResult<Bound<'py, PyDict>> {
        let cfg = RangerConfig {
            min_angle,
            max_angle,
            angular_res,
            min_range,
            max_range,
            range_res,
            frequency,
        };
        match self.request(
            py,
            InterfaceCode::RANGER,
            index,
            RangerReq::SetConfig(Some(cfg.clone())),
        )? {
            Some(Body::Ranger(RangerMsg::Ack(RangerReq::SetConfig(Some(c))))) => {
                convert::ranger_config(py, &c)
            }
            None => convert::ranger_config(py, &cfg),
            _ => Err(bad_reply("ranger SET_CONFIG")),
        }
    }

    /// `playerc_ranger_power_config`.
    fn ranger_power_config(&self, py: Python<'_>, index: u16, state: u8) -> PyResult<()> {
        let req = RangerReq::Power(Some(RangerPowerConfig { state }));
        self.request(py, InterfaceCode::RANGER, index, req)
            .map(|_| ())
    }

    /// `playerc_ranger_intns_config`.
    fn ranger_intns_config(&self, py: Python<'_>, index: u16, state: u8) -> PyResult<()> {
        let req = RangerReq::Intns(Some(RangerIntnsConfig { state }));
        self.request(py, InterfaceCode::RANGER, index, req)
            .map(|_| ())
    }

    // --- laser, sonar -----------------------------------------------------------------

    /// `playerc_laser_get_geom`: `{pose: [6], size: [3]}`.
    fn laser_get_geom<'py>(&self, py: Python<'py>, index: u16) -> PyResult<Bound<'py, PyDict>> {
        let g = self.call(py, move |c| LaserProxy::attach(c, index).request_geom())?;
        convert::pose_size(py, &g.pose, &g.size)
    }

    /// `playerc_laser_get_config`.
    fn laser_get_config<'py>(&self, py: Python<'py>, index: u16) -> PyResult<Bound<'py, PyDict>> {
        let c = self.call(py, move |c| LaserProxy::attach(c, index).request_config())?;
        convert::laser_config(py, &c)
    }

    /// `playerc_laser_set_config`; returns the configuration the device applied.
    #[allow(clippy::too_many_arguments)]
    fn laser_set_config<'py>(
        &self,
        py: Python<'py>,
        index: u16,
        min_angle: f32,
        max_angle: f32,
        resolution: f32,
        range_res: f32,
        intensity: u8,
        scanning_frequency: f32,
    ) -> PyResult<Bound<'py, PyDict>> {
        let cfg = LaserConfig {
            min_angle,
            max_angle,
            resolution,
            max_range: 0.0,
            range_res,
            intensity,
            scanning_frequency,
        };
        let c = self.call(py, move |c| LaserProxy::attach(c, index).configure(cfg))?;
        convert::laser_config(py, &c)
    }

    /// `playerc_sonar_get_geom`: `{pose_count, poses}`.
    fn sonar_get_geom<'py>(&self, py: Python<'py>, index: u16) -> PyResult<Bound<'py, PyDict>> {
        let g = self.call(py, move |c| SonarProxy::attach(c, index).request_geom())?;
        let d = PyDict::new(py);
        convert::sonar_geom(&d, &g)?;
        Ok(d)
    }

    // --- fiducial, gripper ------------------------------------------------------------

    /// `playerc_fiducial_get_geom`: `{pose: [6], size: [3], fiducial_size: [2]}`.
    fn fiducial_get_geom<'py>(&self, py: Python<'py>, index: u16) -> PyResult<Bound<'py, PyDict>> {
        let g = self.call(py, move |c| {
            FiducialProxy::attach(c, index).request_geometry()
        })?;
        let d = convert::pose_size(py, &g.pose, &g.size)?;
        d.set_item("fiducial_size", [g.fiducial_size.sw, g.fiducial_size.sl])?;
        Ok(d)
    }

    /// A gripper command: `open`, `close`, `stop`, `store` or `retrieve`.
    fn gripper_cmd(&self, index: u16, what: &str) -> PyResult<()> {
        let cmd = match what {
            "open" => GripperCmd::Open,
            "close" => GripperCmd::Close,
            "stop" => GripperCmd::Stop,
            "store" => GripperCmd::Store,
            "retrieve" => GripperCmd::Retrieve,
            other => {
                return Err(PlayerError::new_err(format!(
                    "unknown gripper command `{other}`"
                )));
            }
        };
        self.command(InterfaceCode::GRIPPER, index, cmd)
    }

    /// `playerc_gripper_get_geom`.
    fn gripper_get_geom<'py>(&self, py: Python<'py>, index: u16) -> PyResult<Bound<'py, PyDict>> {
        let g = self.call(py, move |c| {
            GripperProxy::attach(c, index).request_geometry()
        })?;
        let d = PyDict::new(py);
        d.set_item("pose", convert::pose3d(&g.pose))?;
        d.set_item("outer_size", convert::bbox3d(&g.outer_size))?;
        d.set_item("inner_size", convert::bbox3d(&g.inner_size))?;
        d.set_item("num_beams", g.num_beams)?;
        d.set_item("capacity", g.capacity)?;
        Ok(d)
    }

    // --- simulation -------------------------------------------------------------------

    /// `playerc_simulation_get_pose2d`: `(x, y, a)`.
    fn simulation_get_pose2d(&self, py: Python<'_>, index: u16, name: &str) -> PyResult<[f64; 3]> {
        let p = self.call(py, move |c| {
            SimulationProxy::attach(c, index).get_pose2d(name)
        })?;
        Ok(convert::pose2d(&p))
    }

    /// `playerc_simulation_set_pose2d`.
    fn simulation_set_pose2d(
        &self,
        py: Python<'_>,
        index: u16,
        name: &str,
        p: [f64; 3],
    ) -> PyResult<()> {
        self.call(py, move |c| {
            SimulationProxy::attach(c, index).set_pose2d(name, p[0], p[1], p[2])
        })
    }

    /// `playerc_simulation_get_pose3d`: `([x, y, z, roll, pitch, yaw], simtime)`.
    fn simulation_get_pose3d(
        &self,
        py: Python<'_>,
        index: u16,
        name: &str,
    ) -> PyResult<([f64; 6], f64)> {
        let (p, simtime) = self.call(py, move |c| {
            SimulationProxy::attach(c, index).get_pose3d(name)
        })?;
        Ok((convert::pose3d(&p), simtime))
    }

    /// `playerc_simulation_set_pose3d`.
    fn simulation_set_pose3d(
        &self,
        py: Python<'_>,
        index: u16,
        name: &str,
        p: [f64; 6],
    ) -> PyResult<()> {
        self.call(py, move |c| {
            SimulationProxy::attach(c, index).set_pose3d(name, pose3(p))
        })
    }

    /// `playerc_simulation_get_property`: the value's raw bytes (`size` of them asked for).
    fn simulation_get_property<'py>(
        &self,
        py: Python<'py>,
        index: u16,
        name: &str,
        prop: &str,
        size: usize,
    ) -> PyResult<Bound<'py, PyBytes>> {
        let value = self.call(py, move |c| {
            SimulationProxy::attach(c, index).get_property(name, prop, size)
        })?;
        Ok(PyBytes::new(py, &value))
    }

    /// `playerc_simulation_set_property` from raw value bytes.
    fn simulation_set_property(
        &self,
        py: Python<'_>,
        index: u16,
        name: &str,
        prop: &str,
        value: Vec<u8>,
    ) -> PyResult<()> {
        self.call(py, move |c| {
            SimulationProxy::attach(c, index).set_property(name, prop, value)
        })
    }

    /// `playerc_simulation_pause` / `reset` / `save`: the command by name.
    fn simulation_cmd(&self, index: u16, what: &str) -> PyResult<()> {
        let cmd = match what {
            "pause" => SimulationCmd::Pause,
            "reset" => SimulationCmd::Reset,
            "save" => SimulationCmd::Save,
            other => {
                return Err(PlayerError::new_err(format!(
                    "unknown simulation command `{other}`"
                )));
            }
        };
        self.command(InterfaceCode::SIMULATION, index, cmd)
    }

    // --- speech, graphics2d -----------------------------------------------------------

    /// `playerc_speech_say`.
    fn speech_say(&self, index: u16, text: &str) -> PyResult<()> {
        self.send(|c| SpeechProxy::attach(c, index).say(text))
    }

    /// `playerc_graphics2d_clear`.
    fn graphics2d_clear(&self, index: u16) -> PyResult<()> {
        self.send(|c| Graphics2dProxy::attach(c, index).clear())
    }

    /// `playerc_graphics2d_draw_points`; `color` is `(alpha, red, green, blue)`.
    fn graphics2d_points(
        &self,
        index: u16,
        pts: Vec<(f64, f64)>,
        rgba: (u8, u8, u8, u8),
    ) -> PyResult<()> {
        self.send(|c| Graphics2dProxy::attach(c, index).draw_points(points(pts), color(rgba)))
    }

    /// `playerc_graphics2d_draw_polyline`.
    fn graphics2d_polyline(
        &self,
        index: u16,
        pts: Vec<(f64, f64)>,
        rgba: (u8, u8, u8, u8),
    ) -> PyResult<()> {
        self.send(|c| Graphics2dProxy::attach(c, index).draw_polyline(points(pts), color(rgba)))
    }

    /// `playerc_graphics2d_draw_polygon`.
    fn graphics2d_polygon(
        &self,
        index: u16,
        pts: Vec<(f64, f64)>,
        rgba: (u8, u8, u8, u8),
        filled: bool,
        fill: (u8, u8, u8, u8),
    ) -> PyResult<()> {
        let cmd = Graphics2dCmd::Polygon(Graphics2dCmdPolygon {
            points: points(pts),
            color: color(rgba),
            fill_color: color(fill),
            filled: u8::from(filled),
        });
        self.command(InterfaceCode::GRAPHICS2D, index, cmd)
    }

    // --- map, planner, localize -------------------------------------------------------

    /// `playerc_map_get_map`: `(info dict, cells bytes)`, cells row by row from the lowest
    /// row, -1 free / 0 unknown / +1 occupied as signed bytes. Fetched tile by tile as
    /// libplayerc does (through `player-client`'s map proxy, a subscription of its own).
    fn map_get_map<'py>(
        &self,
        py: Python<'py>,
        index: u16,
    ) -> PyResult<(Bound<'py, PyDict>, Bound<'py, PyBytes>)> {
        let client = self.client()?;
        let map = py
            .allow_threads(move || MapProxy::new(&client, index)?.get_map())
            .map_err(client_err)?;
        let d = PyDict::new(py);
        convert::map_info(&d, &map.info)?;
        let cells: Vec<u8> = map.cells.iter().map(|&c| c as u8).collect();
        Ok((d, PyBytes::new(py, &cells)))
    }

    /// `playerc_map_get_vector`: `{minx, maxx, miny, maxy, segments: [(x0, y0, x1, y1)]}`.
    fn map_get_vector<'py>(&self, py: Python<'py>, index: u16) -> PyResult<Bound<'py, PyDict>> {
        let v = self.call(py, move |c| MapProxy::attach(c, index).get_vector())?;
        let d = PyDict::new(py);
        d.set_item("vminx", v.minx)?;
        d.set_item("vmaxx", v.maxx)?;
        d.set_item("vminy", v.miny)?;
        d.set_item("vmaxy", v.maxy)?;
        let segs: Vec<[f64; 4]> = v
            .segments
            .iter()
            .map(|s| [s.x0, s.y0, s.x1, s.y1])
            .collect();
        d.set_item("num_segments", segs.len())?;
        d.set_item("segments", segs)?;
        Ok(d)
    }

    /// `playerc_planner_set_cmd_pose`.
    fn planner_set_cmd_pose(&self, index: u16, g: [f64; 3]) -> PyResult<()> {
        self.command(
            InterfaceCode::PLANNER,
            index,
            PlannerCmdMsg::Goal(PlannerCmd { goal: pose(g) }),
        )
    }

    /// `playerc_planner_get_waypoints`: `[[x, y, a], ...]`.
    fn planner_get_waypoints(&self, py: Python<'_>, index: u16) -> PyResult<Vec<[f64; 3]>> {
        let w = self.call(py, move |c| {
            PlannerProxy::attach(c, index).request_waypoints()
        })?;
        Ok(w.iter().map(convert::pose2d).collect())
    }

    /// `playerc_planner_enable`.
    fn planner_enable(&self, py: Python<'_>, index: u16, state: bool) -> PyResult<()> {
        self.call(py, move |c| PlannerProxy::attach(c, index).enable(state))
    }

    /// `playerc_localize_set_pose`: mean `[x, y, a]`, covariance `[xx, yy, aa]`.
    fn localize_set_pose(
        &self,
        py: Python<'_>,
        index: u16,
        mean: [f64; 3],
        cov: [f64; 3],
    ) -> PyResult<()> {
        self.call(py, move |c| {
            LocalizeProxy::attach(c, index).set_pose(pose(mean), cov)
        })
    }

    /// `playerc_localize_get_particles`: `{mean: [3], variance, particles: [([3], alpha)]}`.
    fn localize_get_particles<'py>(
        &self,
        py: Python<'py>,
        index: u16,
    ) -> PyResult<Bound<'py, PyDict>> {
        let p = self.call(py, move |c| {
            LocalizeProxy::attach(c, index).request_particles()
        })?;
        let d = PyDict::new(py);
        d.set_item("mean", convert::pose2d(&p.mean))?;
        d.set_item("variance", p.variance)?;
        let parts: Vec<([f64; 3], f64)> = p
            .particles
            .iter()
            .map(|q| (convert::pose2d(&q.pose), q.alpha))
            .collect();
        d.set_item("num_particles", parts.len())?;
        d.set_item("particles", parts)?;
        Ok(d)
    }

    /// `playerc_laser_get_id`: the laser's serial number.
    fn laser_get_id(&self, py: Python<'_>, index: u16) -> PyResult<u32> {
        match self.request(py, InterfaceCode::LASER, index, LaserReq::GetId(None))? {
            Some(Body::Laser(LaserMsg::Ack(LaserReq::GetId(Some(id))))) => Ok(id.serial_number),
            _ => Err(bad_reply("laser GET_ID")),
        }
    }

    // --- graphics3d ------------------------------------------------------------------

    /// `playerc_graphics3d_draw`: `mode` a `PLAYER_DRAW_*` value, points `(x, y, z)`,
    /// `rgba` `(alpha, red, green, blue)`.
    fn graphics3d_draw(
        &self,
        index: u16,
        mode: u32,
        pts: Vec<(f64, f64, f64)>,
        rgba: (u8, u8, u8, u8),
    ) -> PyResult<()> {
        let cmd = Graphics3dCmd::Draw(Graphics3dCmdDraw {
            draw_mode: mode,
            points: pts
                .into_iter()
                .map(|(px, py, pz)| Point3d { px, py, pz })
                .collect(),
            color: color(rgba),
        });
        self.command(InterfaceCode::GRAPHICS3D, index, cmd)
    }

    /// `playerc_graphics3d_clear`.
    fn graphics3d_clear(&self, index: u16) -> PyResult<()> {
        self.command(InterfaceCode::GRAPHICS3D, index, Graphics3dCmd::Clear)
    }

    /// `playerc_graphics3d_translate`: moves the drawing frame.
    fn graphics3d_translate(&self, index: u16, x: f64, y: f64, z: f64) -> PyResult<()> {
        let cmd = Graphics3dCmd::Translate(Graphics3dCmdTranslate { x, y, z });
        self.command(InterfaceCode::GRAPHICS3D, index, cmd)
    }

    /// `playerc_graphics3d_rotate`: turns the drawing frame by `a` radians about (x, y, z).
    fn graphics3d_rotate(&self, index: u16, a: f64, x: f64, y: f64, z: f64) -> PyResult<()> {
        let cmd = Graphics3dCmd::Rotate(Graphics3dCmdRotate { a, x, y, z });
        self.command(InterfaceCode::GRAPHICS3D, index, cmd)
    }

    // --- actarray --------------------------------------------------------------------

    /// `playerc_actarray_get_geom`: `{actuators_geom: [{type, length, orientation, axis,
    /// min, centre, max, home, config_speed, hasbrakes}], base_pos, base_orientation}`.
    fn actarray_get_geom<'py>(&self, py: Python<'py>, index: u16) -> PyResult<Bound<'py, PyDict>> {
        let g = self.call(py, move |c| {
            player_client::ActArrayProxy::attach(c, index).request_geometry()
        })?;
        let point = |p: &Point3d| [p.px, p.py, p.pz];
        let turn = |o: &Orientation3d| [o.proll, o.ppitch, o.pyaw];
        let items = PyList::empty(py);
        for a in &g.actuators {
            let e = PyDict::new(py);
            e.set_item("type", a.kind)?;
            e.set_item("length", a.length)?;
            e.set_item("orientation", turn(&a.orientation))?;
            e.set_item("axis", point(&a.axis))?;
            e.set_item("min", a.min)?;
            e.set_item("centre", a.centre)?;
            e.set_item("max", a.max)?;
            e.set_item("home", a.home)?;
            e.set_item("config_speed", a.config_speed)?;
            e.set_item("hasbrakes", a.hasbrakes)?;
            items.append(e)?;
        }
        let d = PyDict::new(py);
        d.set_item("actuators_geom", items)?;
        d.set_item("base_pos", point(&g.base_pos))?;
        d.set_item("base_orientation", turn(&g.base_orientation))?;
        Ok(d)
    }

    /// An actarray command for one joint (-1: all, for `home`): `what` is `position`
    /// (`value` the goal), `speed`, `current` or `home` (`value` unused).
    fn actarray_cmd(&self, index: u16, what: &str, joint: i32, value: f32) -> PyResult<()> {
        let cmd = match what {
            "position" => ActarrayCmd::Pos(ActarrayPositionCmd {
                joint,
                position: value,
            }),
            "speed" => ActarrayCmd::Speed(ActarraySpeedCmd {
                joint,
                speed: value,
            }),
            "current" => ActarrayCmd::Current(ActarrayCurrentCmd {
                joint,
                current: value,
            }),
            "home" => ActarrayCmd::Home(ActarrayHomeCmd { joint }),
            other => {
                return Err(PlayerError::new_err(format!(
                    "unknown actarray command `{other}`"
                )));
            }
        };
        self.command(InterfaceCode::ACTARRAY, index, cmd)
    }

    /// An actarray command for every joint at once: `what` is `position`, `speed` or
    /// `current`, `values` one per joint.
    fn actarray_multi_cmd(&self, index: u16, what: &str, values: Vec<f32>) -> PyResult<()> {
        let cmd = match what {
            "position" => ActarrayCmd::MultiPos(ActarrayMultiPositionCmd { positions: values }),
            "speed" => ActarrayCmd::MultiSpeed(ActarrayMultiSpeedCmd { speeds: values }),
            "current" => ActarrayCmd::MultiCurrent(ActarrayMultiCurrentCmd { currents: values }),
            other => {
                return Err(PlayerError::new_err(format!(
                    "unknown actarray command `{other}`"
                )));
            }
        };
        self.command(InterfaceCode::ACTARRAY, index, cmd)
    }

    /// An actarray configuration request: `what` is `power` or `brakes` (`value` 0 / 1,
    /// `joint` unused), `speed` or `accel` (for `joint`, -1: all).
    fn actarray_config(
        &self,
        py: Python<'_>,
        index: u16,
        what: &str,
        joint: i32,
        value: f32,
    ) -> PyResult<()> {
        let on = u8::from(value != 0.0);
        let req = match what {
            "power" => ActarrayReq::Power(Some(ActarrayPowerConfig { value: on })),
            "brakes" => ActarrayReq::Brakes(Some(ActarrayBrakesConfig { value: on })),
            "speed" => ActarrayReq::Speed(Some(ActarraySpeedConfig {
                joint,
                speed: value,
            })),
            "accel" => ActarrayReq::Accel(Some(ActarrayAccelConfig {
                joint,
                accel: value,
            })),
            other => {
                return Err(PlayerError::new_err(format!(
                    "unknown actarray request `{other}`"
                )));
            }
        };
        self.request(py, InterfaceCode::ACTARRAY, index, req)
            .map(|_| ())
    }

    // --- log -------------------------------------------------------------------------

    /// `playerc_log_get_state`: `(type, state)`, `type` 1 (`PLAYER_LOG_TYPE_READ`) or 2
    /// (`PLAYER_LOG_TYPE_WRITE`), `state` 1 while replaying or recording.
    fn log_get_state(&self, py: Python<'_>, index: u16) -> PyResult<(u8, u8)> {
        let s = self.call(py, move |c| {
            player_client::LogProxy::attach(c, index).get_state()
        })?;
        Ok((s.log_type, u8::from(s.state)))
    }

    /// `playerc_log_set_write_state` / `set_read_state` (`what` "write" or "read") and
    /// `set_read_rewind` ("rewind", `state` unused).
    fn log_set_state(&self, py: Python<'_>, index: u16, what: &str, state: bool) -> PyResult<()> {
        #[derive(Clone, Copy)]
        enum Op {
            Write,
            Read,
            Rewind,
        }
        let op = match what {
            "write" => Op::Write,
            "read" => Op::Read,
            "rewind" => Op::Rewind,
            other => {
                return Err(PlayerError::new_err(format!(
                    "unknown log request `{other}` (write, read or rewind)"
                )));
            }
        };
        self.call(py, move |c| {
            let log = player_client::LogProxy::attach(c, index);
            match op {
                Op::Write => log.set_write_state(state),
                Op::Read => log.set_read_state(state),
                Op::Rewind => log.rewind(),
            }
        })
    }

    /// `playerc_log_set_filename`: where a writelog records from now on.
    fn log_set_filename(&self, py: Python<'_>, index: u16, filename: &str) -> PyResult<()> {
        let filename = filename.to_owned();
        self.call(py, move |c| {
            player_client::LogProxy::attach(c, index).set_filename(&filename)
        })
    }

    // --- any device: capabilities and properties --------------------------------------

    /// `playerc_device_hascapability`: whether device (`interf`, `index`) handles messages of
    /// (`msg_type`, `subtype`). A type or subtype no Player message has is never handled (not
    /// asked: the wire has no room for it).
    fn device_has_capability(
        &self,
        py: Python<'_>,
        interf: u16,
        index: u16,
        msg_type: u32,
        subtype: u32,
    ) -> PyResult<bool> {
        let t = u8::try_from(msg_type).ok().and_then(MsgType::from_u8);
        let (Some(t), Ok(s)) = (t, u8::try_from(subtype)) else {
            return Ok(false);
        };
        self.call(py, move |c| {
            player_client::ClientProxy::attach(c, InterfaceCode(interf), index).has_capability(t, s)
        })
    }

    /// `playerc_device_get_{bool,int,dbl,str}prop` (`kind` "bool", "int", "dbl" or "str"):
    /// property `key` of device (`interf`, `index`). A device without it NACKs:
    /// `RequestRefused`.
    fn device_get_prop<'py>(
        &self,
        py: Python<'py>,
        interf: u16,
        index: u16,
        kind: &str,
        key: &str,
    ) -> PyResult<Bound<'py, PyAny>> {
        let kind = PropKind::parse(kind)?;
        let key = key.to_owned();
        let value = self.call(py, move |c| {
            let dev = player_client::ClientProxy::attach(c, InterfaceCode(interf), index);
            Ok(match kind {
                PropKind::Bool => PropValue::Bool(dev.get_bool_prop(&key)?),
                PropKind::Int => PropValue::Int(dev.get_int_prop(&key)?),
                PropKind::Dbl => PropValue::Dbl(dev.get_dbl_prop(&key)?),
                PropKind::Str => PropValue::Str(dev.get_str_prop(&key)?),
            })
        })?;
        match value {
            PropValue::Bool(v) => v.into_bound_py_any(py),
            PropValue::Int(v) => v.into_bound_py_any(py),
            PropValue::Dbl(v) => v.into_bound_py_any(py),
            PropValue::Str(v) => v.into_bound_py_any(py),
        }
    }

    /// `playerc_device_set_{bool,int,dbl,str}prop`: sets property `key` of device (`interf`,
    /// `index`) to `value` (a bool, an int that fits 32 bits, a float or a str, by `kind`).
    fn device_set_prop(
        &self,
        py: Python<'_>,
        interf: u16,
        index: u16,
        kind: &str,
        key: &str,
        value: &Bound<'_, PyAny>,
    ) -> PyResult<()> {
        let value = match PropKind::parse(kind)? {
            PropKind::Bool => PropValue::Bool(value.extract()?),
            PropKind::Int => PropValue::Int(value.extract()?),
            PropKind::Dbl => PropValue::Dbl(value.extract()?),
            PropKind::Str => PropValue::Str(value.extract()?),
        };
        let key = key.to_owned();
        self.call(py, move |c| {
            let dev = player_client::ClientProxy::attach(c, InterfaceCode(interf), index);
            match value {
                PropValue::Bool(v) => dev.set_bool_prop(&key, v),
                PropValue::Int(v) => dev.set_int_prop(&key, v),
                PropValue::Dbl(v) => dev.set_dbl_prop(&key, v),
                PropValue::Str(v) => dev.set_str_prop(&key, &v),
            }
        })
    }
}

/// The four kinds of Player device property (`player_{bool,int,dbl,str}prop_req_t`).
#[derive(Clone, Copy)]
enum PropKind {
    Bool,
    Int,
    Dbl,
    Str,
}

impl PropKind {
    /// The kind named as in libplayerc's function names (`get_dblprop`: "dbl").
    fn parse(kind: &str) -> PyResult<PropKind> {
        match kind {
            "bool" => Ok(PropKind::Bool),
            "int" => Ok(PropKind::Int),
            "dbl" => Ok(PropKind::Dbl),
            "str" => Ok(PropKind::Str),
            other => Err(PlayerError::new_err(format!(
                "unknown property kind `{other}` (bool, int, dbl or str)"
            ))),
        }
    }
}

/// A property's value, of one of the four kinds.
enum PropValue {
    Bool(bool),
    Int(i32),
    Dbl(f64),
    Str(String),
}
