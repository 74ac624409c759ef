//! Proxies: one subscribed device each, with typed accessors for its latest data and typed
//! requests and commands, as libplayerc++'s `ClientProxy` subclasses.
//!
//! A proxy subscribes when created and unsubscribes when dropped. Data accessors return the
//! values of the latest DATA received by [`PlayerClient::read`] (`None` before the first).

use player_proto::constants::PLAYER_GRIPPER_STATE_CLOSED;
use player_proto::*;

use crate::client::{PlayerClient, replace_action};
use crate::error::ClientError;

/// A subscribed device: the part every typed proxy shares.
#[derive(Debug)]
pub struct ClientProxy {
    client: PlayerClient,
    interf: InterfaceCode,
    index: u16,
    driver_name: String,
    /// False for a handle made by [`ClientProxy::attach`]: it did not subscribe, so dropping
    /// it must not end a subscription someone else holds.
    subscribed: bool,
}

impl ClientProxy {
    /// Subscribes to (`interf`, `index`) on the client's port.
    pub fn subscribe(
        client: &PlayerClient,
        interf: InterfaceCode,
        index: u16,
    ) -> Result<ClientProxy, ClientError> {
        let driver_name = client.subscribe(interf, index)?;
        Ok(ClientProxy {
            client: client.clone(),
            interf,
            index,
            driver_name,
            subscribed: true,
        })
    }

    /// A handle on (`interf`, `index`) for requests and commands that neither subscribes nor
    /// unsubscribes: for callers that hold the subscription themselves (the Python bindings'
    /// proxies), so that they use these typed requests instead of writing them again. Its
    /// driver name is empty.
    pub fn attach(client: &PlayerClient, interf: InterfaceCode, index: u16) -> ClientProxy {
        ClientProxy {
            client: client.clone(),
            interf,
            index,
            driver_name: String::new(),
            subscribed: false,
        }
    }

    /// The client this proxy reads through.
    pub fn client(&self) -> &PlayerClient {
        &self.client
    }

    /// The interface.
    pub fn interface(&self) -> InterfaceCode {
        self.interf
    }

    /// The index.
    pub fn index(&self) -> u16 {
        self.index
    }

    /// The driver the server reports for the device (e.g. `stage`).
    pub fn driver_name(&self) -> &str {
        &self.driver_name
    }

    /// Sends a request to this device; the ACK's body (if any).
    pub fn request(&self, body: impl Into<Body>) -> Result<Option<Body>, ClientError> {
        self.client.request(self.interf, self.index, body)
    }

    /// Sends a command to this device.
    pub fn command(&self, body: impl Into<Body>) -> Result<(), ClientError> {
        self.client.command(self.interf, self.index, body)
    }

    /// The latest DATA body of `subtype`.
    pub fn latest(&self, subtype: u8) -> Option<Body> {
        self.client.latest(self.interf, self.index, subtype)
    }

    /// Timestamp of this device's latest DATA (server time; simulated seconds under Stage).
    pub fn datatime(&self) -> f64 {
        self.with_data(|d| d.datatime).unwrap_or(0.0)
    }

    /// True when data newer than the last [`ClientProxy::not_fresh`] arrived (`IsFresh`).
    pub fn is_fresh(&self) -> bool {
        self.with_data(|d| d.fresh).unwrap_or(false)
    }

    /// Marks the current data as seen (`NotFresh`).
    pub fn not_fresh(&self) {
        let mut inner = self.client.lock();
        if let Some(d) = inner.devices.get_mut(&(self.interf, self.index)) {
            d.fresh = false;
        }
    }

    fn with_data<T>(&self, f: impl FnOnce(&crate::client::DeviceData) -> T) -> Option<T> {
        let inner = self.client.lock();
        inner.devices.get(&(self.interf, self.index)).map(f)
    }

    /// Keeps only the newest queued message of this device per (type, subtype) on the server
    /// (`replace`), or all of them (`ClientProxy::SetReplaceRule`).
    pub fn set_replace_rule(
        &self,
        replace: bool,
        msg_type: i32,
        subtype: i32,
    ) -> Result<(), ClientError> {
        self.client.add_replace_rule(
            i32::from(self.interf.0),
            i32::from(self.index),
            msg_type,
            subtype,
            replace_action(replace),
        )
    }

    /// Whether the device handles messages of (`msg_type`, `subtype`) (universal
    /// CAPABILITIES request: ACK yes, NACK no).
    pub fn has_capability(&self, msg_type: MsgType, subtype: u8) -> Result<bool, ClientError> {
        let req = CapabilitiesReq {
            msg_type: u32::from(msg_type.code()),
            subtype: u32::from(subtype),
        };
        match self.request(Body::Universal(UniversalMsg::Req(
            UniversalReq::Capabilities(Some(req)),
        ))) {
            Ok(_) => Ok(true),
            Err(ClientError::Nack { .. }) => Ok(false),
            Err(e) => Err(e),
        }
    }

    fn universal(&self, req: UniversalReq) -> Result<Option<UniversalReq>, ClientError> {
        match self.request(Body::Universal(UniversalMsg::Req(req)))? {
            Some(Body::Universal(UniversalMsg::Ack(r))) => Ok(Some(r)),
            None => Ok(None),
            Some(_) => Err(self.bad_reply("property request")),
        }
    }

    fn bad_reply(&self, what: &str) -> ClientError {
        ClientError::BadReply {
            what: format!("{what} on {}:{}", self.interf, self.index),
        }
    }

    /// An integer property (`GetIntProp`).
    pub fn get_int_prop(&self, key: &str) -> Result<i32, ClientError> {
        let req = IntPropReq {
            key: Text::new(key),
            value: 0,
        };
        match self.universal(UniversalReq::GetIntProp(Some(req)))? {
            Some(UniversalReq::GetIntProp(Some(r))) => Ok(r.value),
            _ => Err(self.bad_reply("GET_INTPROP")),
        }
    }

    /// Sets an integer property (`SetIntProp`).
    pub fn set_int_prop(&self, key: &str, value: i32) -> Result<(), ClientError> {
        let req = IntPropReq {
            key: Text::new(key),
            value,
        };
        self.universal(UniversalReq::SetIntProp(Some(req)))
            .map(|_| ())
    }

    /// A double property (`GetDblProp`).
    pub fn get_dbl_prop(&self, key: &str) -> Result<f64, ClientError> {
        let req = DblPropReq {
            key: Text::new(key),
            value: 0.0,
        };
        match self.universal(UniversalReq::GetDblProp(Some(req)))? {
            Some(UniversalReq::GetDblProp(Some(r))) => Ok(r.value),
            _ => Err(self.bad_reply("GET_DBLPROP")),
        }
    }

    /// Sets a double property (`SetDblProp`).
    pub fn set_dbl_prop(&self, key: &str, value: f64) -> Result<(), ClientError> {
        let req = DblPropReq {
            key: Text::new(key),
            value,
        };
        self.universal(UniversalReq::SetDblProp(Some(req)))
            .map(|_| ())
    }

    /// A string property (`GetStrProp`).
    pub fn get_str_prop(&self, key: &str) -> Result<String, ClientError> {
        let req = StrPropReq {
            key: Text::new(key),
            value: Text::empty(),
        };
        match self.universal(UniversalReq::GetStrProp(Some(req)))? {
            Some(UniversalReq::GetStrProp(Some(r))) => Ok(r.value.to_str_lossy().into_owned()),
            _ => Err(self.bad_reply("GET_STRPROP")),
        }
    }

    /// Sets a string property (`SetStrProp`).
    pub fn set_str_prop(&self, key: &str, value: &str) -> Result<(), ClientError> {
        let req = StrPropReq {
            key: Text::new(key),
            value: Text::new(value),
        };
        self.universal(UniversalReq::SetStrProp(Some(req)))
            .map(|_| ())
    }

    /// A boolean property (`GetBoolProp`).
    pub fn get_bool_prop(&self, key: &str) -> Result<bool, ClientError> {
        let req = BoolPropReq {
            key: Text::new(key),
            value: 0,
        };
        match self.universal(UniversalReq::GetBoolProp(Some(req)))? {
            Some(UniversalReq::GetBoolProp(Some(r))) => Ok(r.value != 0),
            _ => Err(self.bad_reply("GET_BOOLPROP")),
        }
    }

    /// Sets a boolean property (`SetBoolProp`).
    pub fn set_bool_prop(&self, key: &str, value: bool) -> Result<(), ClientError> {
        let req = BoolPropReq {
            key: Text::new(key),
            value: i8::from(value),
        };
        self.universal(UniversalReq::SetBoolProp(Some(req)))
            .map(|_| ())
    }
}

impl Drop for ClientProxy {
    /// Unsubscribes (a subscribing proxy), as libplayerc++ proxy destructors do; errors (e.g. the server is gone)
    /// are only logged.
    fn drop(&mut self) {
        if !self.subscribed {
            return;
        }
        if let Err(e) = self.client.unsubscribe(self.interf, self.index) {
            tracing::debug!("unsubscribing {}:{} failed: {e}", self.interf, self.index);
        }
    }
}

/// Declares a typed proxy over [`ClientProxy`] for one interface.
macro_rules! proxy {
    ($(#[$attr:meta])* $name:ident, $code:ident) => {
        $(#[$attr])*
        #[derive(Debug)]
        pub struct $name {
            proxy: ClientProxy,
        }

        impl $name {
            /// Subscribes to device `index` of this interface on the client's port.
            pub fn new(client: &PlayerClient, index: u16) -> Result<$name, ClientError> {
                Ok($name {
                    proxy: ClientProxy::subscribe(client, InterfaceCode::$code, index)?,
                })
            }

            /// A handle on device `index` without subscribing ([`ClientProxy::attach`]).
            pub fn attach(client: &PlayerClient, index: u16) -> $name {
                $name {
                    proxy: ClientProxy::attach(client, InterfaceCode::$code, index),
                }
            }
        }

        impl std::ops::Deref for $name {
            type Target = ClientProxy;
            fn deref(&self) -> &ClientProxy {
                &self.proxy
            }
        }
    };
}

/// Sends a request and pulls the typed ACK body out of the reply (`$pat => $out`), or a
/// `BadReply` error naming `$what`.
macro_rules! request_ack {
    ($proxy:expr, $req:expr, $pat:pat => $out:expr, $what:literal) => {
        match $proxy.request($req)? {
            Some($pat) => Ok($out),
            _ => Err($proxy.bad_reply($what)),
        }
    };
}

/// The latest DATA of subtype `$sub` as `$out` (`None` before the first or when the body is
/// not `$pat`).
macro_rules! latest_data {
    ($proxy:expr, $sub:expr, $pat:pat => $out:expr) => {
        match $proxy.latest($sub) {
            Some($pat) => Some($out),
            _ => None,
        }
    };
}

proxy!(
    /// A mobile base (`position2d`).
    Position2dProxy,
    POSITION2D
);

impl Position2dProxy {
    /// The latest odometry state.
    pub fn state(&self) -> Option<Position2dDataState> {
        latest_data!(self, Position2dData::STATE,
            Body::Position2d(Position2dMsg::Data(Position2dData::State(s))) => s)
    }

    /// Pose (m, m, rad); zero before the first data.
    pub fn pose(&self) -> Pose2d {
        self.state().map(|s| s.pos).unwrap_or_default()
    }

    /// Velocity (m/s, m/s, rad/s).
    pub fn velocity(&self) -> Pose2d {
        self.state().map(|s| s.vel).unwrap_or_default()
    }

    /// True when the base is stalled.
    pub fn stall(&self) -> bool {
        self.state().is_some_and(|s| s.stall != 0)
    }

    /// Velocity command (`SetSpeed`): forward, sideways (m/s), turn rate (rad/s).
    pub fn set_speed(&self, xspeed: f64, yspeed: f64, yawspeed: f64) -> Result<(), ClientError> {
        self.command(Position2dCmd::Vel(Position2dCmdVel {
            vel: Pose2d {
                px: xspeed,
                py: yspeed,
                pa: yawspeed,
            },
            state: 1,
        }))
    }

    /// Car-like command (`SetCarlike`): speed (m/s) and turning angle (rad).
    pub fn set_car(&self, velocity: f64, angle: f64) -> Result<(), ClientError> {
        self.command(Position2dCmd::Car(Position2dCmdCar { velocity, angle }))
    }

    /// Position command (`GoTo`).
    pub fn go_to(&self, x: f64, y: f64, yaw: f64) -> Result<(), ClientError> {
        self.command(Position2dCmd::Pos(Position2dCmdPos {
            pos: Pose2d {
                px: x,
                py: y,
                pa: yaw,
            },
            vel: Pose2d::default(),
            state: 1,
        }))
    }

    /// Motor power on/off (`SetMotorEnable`).
    pub fn set_motor_enable(&self, enable: bool) -> Result<(), ClientError> {
        self.request(Position2dReq::MotorPower(Some(Position2dPowerConfig {
            state: u8::from(enable),
        })))
        .map(|_| ())
    }

    /// Resets odometry to zero (`ResetOdometry`).
    pub fn reset_odometry(&self) -> Result<(), ClientError> {
        self.request(Position2dReq::ResetOdom).map(|_| ())
    }

    /// Sets the odometric pose (`SetOdometry`).
    pub fn set_odometry(&self, x: f64, y: f64, yaw: f64) -> Result<(), ClientError> {
        self.request(Position2dReq::SetOdom(Some(Position2dSetOdomReq {
            pose: Pose2d {
                px: x,
                py: y,
                pa: yaw,
            },
        })))
        .map(|_| ())
    }

    /// The base's geometry (`RequestGeom`).
    pub fn request_geom(&self) -> Result<Position2dGeom, ClientError> {
        request_ack!(self, Position2dReq::GetGeom(None),
            Body::Position2d(Position2dMsg::Ack(Position2dReq::GetGeom(Some(g)))) => g,
            "position2d GET_GEOM")
    }
}

proxy!(
    /// A path planner (`planner`), e.g. `wavefront`: give it a goal and it drives the robot
    /// there; its state says whether a path exists and whether the robot has arrived.
    PlannerProxy,
    PLANNER
);

impl PlannerProxy {
    /// The latest planner state.
    pub fn data(&self) -> Option<PlannerData> {
        latest_data!(self, PlannerDataMsg::STATE,
            Body::Planner(PlannerMsg::Data(PlannerDataMsg::State(d))) => d)
    }

    /// Where the robot is (m, m, rad; libplayerc's `px, py, pa`).
    pub fn pos(&self) -> Pose2d {
        self.data().map(|d| d.pos).unwrap_or_default()
    }

    /// The goal (libplayerc's `gx, gy, ga`).
    pub fn goal(&self) -> Pose2d {
        self.data().map(|d| d.goal).unwrap_or_default()
    }

    /// The waypoint being driven to (libplayerc's `wx, wy, wa`).
    pub fn waypoint(&self) -> Pose2d {
        self.data().map(|d| d.waypoint).unwrap_or_default()
    }

    /// Index of that waypoint; negative when there is no plan or it is done (libplayerc's
    /// `curr_waypoint`).
    pub fn waypoint_idx(&self) -> i32 {
        self.data().map_or(-1, |d| d.waypoint_idx)
    }

    /// Number of waypoints in the plan (libplayerc's `waypoint_count`).
    pub fn waypoints_count(&self) -> u32 {
        self.data().map_or(0, |d| d.waypoints_count)
    }

    /// Whether the planner found a path (libplayerc's `path_valid`).
    pub fn path_valid(&self) -> bool {
        self.data().is_some_and(|d| d.valid != 0)
    }

    /// Whether the robot has arrived at the goal (libplayerc's `path_done`).
    pub fn path_done(&self) -> bool {
        self.data().is_some_and(|d| d.done != 0)
    }

    /// Sends a new goal (`playerc_planner_set_cmd_pose`, libplayerc++'s `SetGoalPose`).
    pub fn set_goal(&self, gx: f64, gy: f64, ga: f64) -> Result<(), ClientError> {
        self.command(PlannerCmdMsg::Goal(PlannerCmd {
            goal: Pose2d {
                px: gx,
                py: gy,
                pa: ga,
            },
        }))
    }

    /// The plan's waypoints (`playerc_planner_get_waypoints`).
    pub fn request_waypoints(&self) -> Result<Vec<Pose2d>, ClientError> {
        request_ack!(self, PlannerReq::GetWaypoints(None),
            Body::Planner(PlannerMsg::Ack(PlannerReq::GetWaypoints(Some(w)))) => w.waypoints,
            "planner GET_WAYPOINTS")
    }

    /// Allows or stops robot motion (`playerc_planner_enable`); disabled, the planner stops
    /// the robot.
    pub fn enable(&self, state: bool) -> Result<(), ClientError> {
        self.request(PlannerReq::Enable(Some(PlannerEnableReq {
            state: u8::from(state),
        })))
        .map(|_| ())
    }
}

proxy!(
    /// A localisation filter (`localize`), e.g. `amcl`: its pose hypotheses with their
    /// covariances, the particle set, and a way to tell it where the robot is.
    LocalizeProxy,
    LOCALIZE
);

impl LocalizeProxy {
    /// The latest hypotheses (libplayerc's `hypoths`, `pending_count`, `pending_time`).
    pub fn data(&self) -> Option<LocalizeDataHypoths> {
        latest_data!(self, LocalizeData::HYPOTHS,
            Body::Localize(LocalizeMsg::Data(LocalizeData::Hypoths(h))) => h)
    }

    /// The hypotheses of the latest data, as libplayerc's `hypoths` array (empty before the
    /// first).
    pub fn hypotheses(&self) -> Vec<LocalizeHypoth> {
        self.data().map(|d| d.hypoths).unwrap_or_default()
    }

    /// The most likely hypothesis: the one with the largest weight (libplayerc++'s
    /// `GetHypoth(0)` after amcl's sorting; here chosen explicitly, whatever the order).
    pub fn best(&self) -> Option<LocalizeHypoth> {
        self.hypotheses()
            .into_iter()
            .max_by(|a, b| a.alpha.total_cmp(&b.alpha))
    }

    /// Tells the filter where the robot is: a mean pose and the variances of x, y and the
    /// heading (`playerc_localize_set_pose`).
    pub fn set_pose(&self, mean: Pose2d, cov: [f64; 3]) -> Result<(), ClientError> {
        self.request(LocalizeReq::SetPose(Some(LocalizeSetPose { mean, cov })))
            .map(|_| ())
    }

    /// The filter's particles, their mean and variance (`playerc_localize_get_particles`).
    pub fn request_particles(&self) -> Result<LocalizeGetParticles, ClientError> {
        request_ack!(self, LocalizeReq::GetParticles(None),
            Body::Localize(LocalizeMsg::Ack(LocalizeReq::GetParticles(Some(p)))) => p,
            "localize GET_PARTICLES")
    }
}

proxy!(
    /// A range sensor array (`ranger`): sonar rings, lasers.
    RangerProxy,
    RANGER
);

impl RangerProxy {
    /// The latest ranges (m).
    pub fn ranges(&self) -> Vec<f64> {
        latest_data!(self, RangerData::RANGE,
            Body::Ranger(RangerMsg::Data(RangerData::Range(r))) => r.ranges)
        .unwrap_or_default()
    }

    /// The latest intensities.
    pub fn intensities(&self) -> Vec<f64> {
        latest_data!(self, RangerData::INTNS,
            Body::Ranger(RangerMsg::Data(RangerData::Intns(r))) => r.intensities)
        .unwrap_or_default()
    }

    /// The sensor geometry (`RequestGeom`).
    pub fn request_geom(&self) -> Result<RangerGeom, ClientError> {
        request_ack!(self, RangerReq::GetGeom(None),
            Body::Ranger(RangerMsg::Ack(RangerReq::GetGeom(Some(g)))) => g,
            "ranger GET_GEOM")
    }

    /// The scan configuration (`RequestConfigure`).
    pub fn request_config(&self) -> Result<RangerConfig, ClientError> {
        request_ack!(self, RangerReq::GetConfig(None),
            Body::Ranger(RangerMsg::Ack(RangerReq::GetConfig(Some(c)))) => c,
            "ranger GET_CONFIG")
    }

    /// Changes the configuration (`Configure`); returns what the device applied.
    pub fn configure(&self, config: RangerConfig) -> Result<RangerConfig, ClientError> {
        request_ack!(self, RangerReq::SetConfig(Some(config)),
            Body::Ranger(RangerMsg::Ack(RangerReq::SetConfig(Some(c)))) => c,
            "ranger SET_CONFIG")
    }
}

proxy!(
    /// A laser scanner (`laser`).
    LaserProxy,
    LASER
);

impl LaserProxy {
    /// The latest scan.
    pub fn scan(&self) -> Option<LaserDataScan> {
        latest_data!(self, LaserData::SCAN,
            Body::Laser(LaserMsg::Data(LaserData::Scan(s))) => s)
    }

    /// The latest ranges (m).
    pub fn ranges(&self) -> Vec<f32> {
        self.scan().map(|s| s.ranges).unwrap_or_default()
    }

    /// The latest pose-stamped scan (SCANPOSE, e.g. from `laserposeinterpolator`): libplayerc
    /// keeps its pose as the laser's `robot_pose`.
    pub fn scan_pose(&self) -> Option<LaserDataScanpose> {
        latest_data!(self, LaserData::SCANPOSE,
            Body::Laser(LaserMsg::Data(LaserData::ScanPose(s))) => s)
    }

    /// The scanner geometry (`RequestGeom`).
    pub fn request_geom(&self) -> Result<LaserGeom, ClientError> {
        request_ack!(self, LaserReq::GetGeom(None),
            Body::Laser(LaserMsg::Ack(LaserReq::GetGeom(Some(g)))) => g,
            "laser GET_GEOM")
    }

    /// The scan configuration (`RequestConfigure`).
    pub fn request_config(&self) -> Result<LaserConfig, ClientError> {
        request_ack!(self, LaserReq::GetConfig(None),
            Body::Laser(LaserMsg::Ack(LaserReq::GetConfig(Some(c)))) => c,
            "laser GET_CONFIG")
    }

    /// Changes the scan configuration (`Configure`): scan angles and resolution (rad), range
    /// resolution (m), intensities on/off. Returns the configuration the device applied (a
    /// SICK LMS200 echoes the request; a ranger served as a laser reports the rays it
    /// chose); a device that cannot do it refuses ([`ClientError::Nack`]).
    pub fn configure(&self, config: LaserConfig) -> Result<LaserConfig, ClientError> {
        request_ack!(self, LaserReq::SetConfig(Some(config)),
            Body::Laser(LaserMsg::Ack(LaserReq::SetConfig(Some(c)))) => c,
            "laser SET_CONFIG")
    }
}

proxy!(
    /// A sonar array (`sonar`).
    SonarProxy,
    SONAR
);

impl SonarProxy {
    /// The latest ranges (m).
    pub fn ranges(&self) -> Vec<f32> {
        latest_data!(self, SonarData::RANGES,
            Body::Sonar(SonarMsg::Data(SonarData::Ranges(r))) => r.ranges)
        .unwrap_or_default()
    }

    /// The transducer poses (`RequestGeom`).
    pub fn request_geom(&self) -> Result<SonarGeom, ClientError> {
        request_ack!(self, SonarReq::GetGeom(None),
            Body::Sonar(SonarMsg::Ack(SonarReq::GetGeom(Some(g)))) => g,
            "sonar GET_GEOM")
    }
}

proxy!(
    /// A colour blob detector (`blobfinder`).
    BlobfinderProxy,
    BLOBFINDER
);

impl BlobfinderProxy {
    /// The latest detection frame.
    pub fn data(&self) -> Option<BlobfinderDataBlobs> {
        latest_data!(self, BlobfinderData::BLOBS,
            Body::Blobfinder(BlobfinderMsg::Data(BlobfinderData::Blobs(b))) => b)
    }

    /// The latest blobs.
    pub fn blobs(&self) -> Vec<BlobfinderBlob> {
        self.data().map(|d| d.blobs).unwrap_or_default()
    }
}

proxy!(
    /// A fiducial (marker) detector (`fiducial`).
    FiducialProxy,
    FIDUCIAL
);

impl FiducialProxy {
    /// The latest detections.
    pub fn fiducials(&self) -> Vec<FiducialItem> {
        latest_data!(self, FiducialData::SCAN,
            Body::Fiducial(FiducialMsg::Data(FiducialData::Scan(s))) => s.fiducials)
        .unwrap_or_default()
    }

    /// The detector geometry (`RequestGeometry`).
    pub fn request_geometry(&self) -> Result<FiducialGeom, ClientError> {
        request_ack!(self, FiducialReq::GetGeom(None),
            Body::Fiducial(FiducialMsg::Ack(FiducialReq::GetGeom(Some(g)))) => g,
            "fiducial GET_GEOM")
    }
}

proxy!(
    /// A gripper (`gripper`).
    GripperProxy,
    GRIPPER
);

impl GripperProxy {
    /// The latest state.
    pub fn data(&self) -> Option<GripperDataState> {
        latest_data!(self, GripperData::STATE,
            Body::Gripper(GripperMsg::Data(GripperData::State(s))) => s)
    }

    /// `PLAYER_GRIPPER_STATE_*` of the latest data (0 before any).
    pub fn state(&self) -> u8 {
        self.data().map(|d| d.state).unwrap_or(0)
    }

    /// True when closed.
    pub fn is_closed(&self) -> bool {
        self.state() == PLAYER_GRIPPER_STATE_CLOSED
    }

    /// Break-beam bits.
    pub fn beams(&self) -> u32 {
        self.data().map(|d| d.beams).unwrap_or(0)
    }

    /// Opens the gripper.
    pub fn open(&self) -> Result<(), ClientError> {
        self.command(GripperCmd::Open)
    }

    /// Closes the gripper.
    pub fn close(&self) -> Result<(), ClientError> {
        self.command(GripperCmd::Close)
    }

    /// Stops the gripper.
    pub fn stop(&self) -> Result<(), ClientError> {
        self.command(GripperCmd::Stop)
    }

    /// The gripper geometry (`RequestGeometry`).
    pub fn request_geometry(&self) -> Result<GripperGeom, ClientError> {
        request_ack!(self, GripperReq::GetGeom(None),
            Body::Gripper(GripperMsg::Ack(GripperReq::GetGeom(Some(g)))) => g,
            "gripper GET_GEOM")
    }
}

proxy!(
    /// The simulation itself (`simulation`): model poses and properties by name.
    SimulationProxy,
    SIMULATION
);

impl SimulationProxy {
    /// A model's pose in its parent's frame (`GetPose2d`).
    pub fn get_pose2d(&self, name: &str) -> Result<Pose2d, ClientError> {
        let req = SimulationReq::GetPose2d(Some(SimulationPose2dReq {
            name: Text::new(name),
            pose: Pose2d::default(),
        }));
        request_ack!(self, req,
            Body::Simulation(SimulationMsg::Ack(SimulationReq::GetPose2d(Some(r)))) => r.pose,
            "simulation GET_POSE2D")
    }

    /// Moves a model (`SetPose2d`).
    pub fn set_pose2d(&self, name: &str, x: f64, y: f64, a: f64) -> Result<(), ClientError> {
        self.request(SimulationReq::SetPose2d(Some(SimulationPose2dReq {
            name: Text::new(name),
            pose: Pose2d {
                px: x,
                py: y,
                pa: a,
            },
        })))
        .map(|_| ())
    }

    /// A model's 3D pose and the simulation time in µs (`GetPose3d`).
    pub fn get_pose3d(&self, name: &str) -> Result<(Pose3d, f64), ClientError> {
        let req = SimulationReq::GetPose3d(Some(SimulationPose3dReq {
            name: Text::new(name),
            ..SimulationPose3dReq::default()
        }));
        request_ack!(self, req,
            Body::Simulation(SimulationMsg::Ack(SimulationReq::GetPose3d(Some(r)))) => (r.pose, r.simtime),
            "simulation GET_POSE3D")
    }

    /// Moves a model in 3D (`SetPose3d`).
    pub fn set_pose3d(&self, name: &str, pose: Pose3d) -> Result<(), ClientError> {
        self.request(SimulationReq::SetPose3d(Some(SimulationPose3dReq {
            name: Text::new(name),
            pose,
            simtime: 0.0,
        })))
        .map(|_| ())
    }

    /// A model property's raw value bytes (`GetProperty`); `size` is the value's byte length.
    pub fn get_property(
        &self,
        name: &str,
        prop: &str,
        size: usize,
    ) -> Result<Vec<u8>, ClientError> {
        let req = SimulationReq::GetProperty(Some(SimulationPropertyReq {
            name: Text::new(name),
            prop: Text::new(prop),
            index: 0,
            value: vec![0; size],
        }));
        request_ack!(self, req,
            Body::Simulation(SimulationMsg::Ack(SimulationReq::GetProperty(Some(r)))) => r.value,
            "simulation GET_PROPERTY")
    }

    /// Sets a model property from raw value bytes (`SetProperty`).
    pub fn set_property(&self, name: &str, prop: &str, value: Vec<u8>) -> Result<(), ClientError> {
        self.request(SimulationReq::SetProperty(Some(SimulationPropertyReq {
            name: Text::new(name),
            prop: Text::new(prop),
            index: 0,
            value,
        })))
        .map(|_| ())
    }

    /// A model's colour (r, g, b, a in 0..1): the `"color"` property, four floats in the
    /// little-endian layout x86 libplayerc clients send.
    pub fn get_color(&self, name: &str) -> Result<[f32; 4], ClientError> {
        let bytes = self.get_property(name, "color", 16)?;
        if bytes.len() != 16 {
            return Err(self.bad_reply("simulation GET_PROPERTY color"));
        }
        let mut rgba = [0f32; 4];
        for (v, chunk) in rgba.iter_mut().zip(bytes.chunks_exact(4)) {
            *v = f32::from_le_bytes([chunk[0], chunk[1], chunk[2], chunk[3]]);
        }
        Ok(rgba)
    }

    /// Sets a model's colour (r, g, b, a in 0..1).
    pub fn set_color(&self, name: &str, rgba: [f32; 4]) -> Result<(), ClientError> {
        let bytes = rgba.iter().flat_map(|v| v.to_le_bytes()).collect();
        self.set_property(name, "color", bytes)
    }
}

proxy!(
    /// Text to speech (`speech`): under Stage, a speech bubble.
    SpeechProxy,
    SPEECH
);

impl SpeechProxy {
    /// Says `text` (`Say`).
    pub fn say(&self, text: &str) -> Result<(), ClientError> {
        self.command(SpeechCmd::Say(SpeechCmdSay {
            string: Text::new(text),
        }))
    }
}

proxy!(
    /// 2D drawing on a model (`graphics2d`).
    Graphics2dProxy,
    GRAPHICS2D
);

impl Graphics2dProxy {
    /// Clears the drawing.
    pub fn clear(&self) -> Result<(), ClientError> {
        self.command(Graphics2dCmd::Clear)
    }

    /// Draws points.
    pub fn draw_points(&self, points: Vec<Point2d>, color: Color) -> Result<(), ClientError> {
        self.command(Graphics2dCmd::Points(Graphics2dCmdPoints { points, color }))
    }

    /// Draws an open polyline.
    pub fn draw_polyline(&self, points: Vec<Point2d>, color: Color) -> Result<(), ClientError> {
        self.command(Graphics2dCmd::Polyline(Graphics2dCmdPolyline {
            points,
            color,
        }))
    }

    /// Draws a polygon, filled or not.
    pub fn draw_polygon(
        &self,
        points: Vec<Point2d>,
        color: Color,
        fill_color: Option<Color>,
    ) -> Result<(), ClientError> {
        self.command(Graphics2dCmd::Polygon(Graphics2dCmdPolygon {
            points,
            color,
            fill_color: fill_color.unwrap_or_default(),
            filled: u8::from(fill_color.is_some()),
        }))
    }
}

proxy!(
    /// An actuator array (`actarray`).
    ActArrayProxy,
    ACTARRAY
);

impl ActArrayProxy {
    /// The latest actuator states.
    pub fn data(&self) -> Option<ActarrayDataState> {
        latest_data!(self, ActarrayData::STATE,
            Body::Actarray(ActarrayMsg::Data(ActarrayData::State(s))) => s)
    }

    /// Moves one joint to a position (`MoveTo`).
    pub fn move_to(&self, joint: i32, position: f32) -> Result<(), ClientError> {
        self.command(ActarrayCmd::Pos(ActarrayPositionCmd { joint, position }))
    }

    /// Moves one joint at a speed (`MoveAtSpeed`).
    pub fn move_at_speed(&self, joint: i32, speed: f32) -> Result<(), ClientError> {
        self.command(ActarrayCmd::Speed(ActarraySpeedCmd { joint, speed }))
    }

    /// Sends a joint home (`MoveHome`).
    pub fn move_home(&self, joint: i32) -> Result<(), ClientError> {
        self.command(ActarrayCmd::Home(ActarrayHomeCmd { joint }))
    }

    /// The array geometry (`RequestGeometry`).
    pub fn request_geometry(&self) -> Result<ActarrayGeom, ClientError> {
        request_ack!(self, ActarrayReq::GetGeom(None),
            Body::Actarray(ActarrayMsg::Ack(ActarrayReq::GetGeom(Some(g)))) => g,
            "actarray GET_GEOM")
    }
}

proxy!(
    /// A camera (`camera`).
    CameraProxy,
    CAMERA
);

impl CameraProxy {
    /// The latest image.
    pub fn image(&self) -> Option<CameraDataState> {
        latest_data!(self, CameraData::STATE,
            Body::Camera(CameraMsg::Data(CameraData::State(s))) => s)
    }
}

proxy!(
    /// A map (`map`): an occupancy grid fetched by request, tile by tile (libplayerc++'s
    /// `MapProxy`, libplayerc's `playerc_map_t`).
    MapProxy,
    MAP
);

/// A whole grid map as [`MapProxy::get_map`] assembles it.
#[derive(Clone, Debug, PartialEq)]
pub struct OccupancyMap {
    /// Scale (m/cell), size (cells) and the pose of cell (0, 0).
    pub info: MapInfo,
    /// `width × height` cells, row by row from row 0 (the lowest): -1 free, 0 unknown,
    /// +1 occupied.
    pub cells: Vec<i8>,
}

impl OccupancyMap {
    /// Index of cell (`x`, `y`) in [`OccupancyMap::cells`] (`PLAYERC_MAP_INDEX`), `None` off
    /// the map.
    pub fn index(&self, x: u32, y: u32) -> Option<usize> {
        (x < self.info.width && y < self.info.height)
            .then(|| y as usize * self.info.width as usize + x as usize)
    }

    /// Cell (`x`, `y`) (`GetCell`), `None` off the map.
    pub fn cell(&self, x: u32, y: u32) -> Option<i8> {
        self.index(x, y).map(|k| self.cells[k])
    }
}

impl MapProxy {
    /// The map's metadata (GET_INFO).
    pub fn request_info(&self) -> Result<MapInfo, ClientError> {
        request_ack!(self, MapReq::GetInfo(None),
            Body::Map(MapMsg::Ack(MapReq::GetInfo(Some(i)))) => i,
            "map GET_INFO")
    }

    /// The cells of one tile (GET_DATA), row by row, inflated as libplayerc does: upstream
    /// servers send them zlib-compressed. Exactly `width × height` cells or an error.
    pub fn request_tile(
        &self,
        col: u32,
        row: u32,
        width: u32,
        height: u32,
    ) -> Result<Vec<i8>, ClientError> {
        let want = MapTile::request(col, row, width, height);
        let zipped = request_ack!(self, MapReq::GetData(Some(want)),
            Body::Map(MapMsg::Ack(MapReq::GetData(Some(t)))) => t,
            "map GET_DATA")?;
        let cells = width as usize * height as usize;
        let zipped = MapTile {
            width,
            height,
            ..zipped
        };
        zipped.unzipped().map(|t| t.data).ok_or_else(|| {
            self.bad_reply(&format!(
                "map GET_DATA ({col},{row}) {width} x {height}: cells that do not inflate to \
                 {cells} bytes"
            ))
        })
    }

    /// The whole map (`RequestMap`, `playerc_map_get_map`): GET_INFO, then every tile in
    /// libplayerc's order ([`MapInfo::tile_requests`]).
    pub fn get_map(&self) -> Result<OccupancyMap, ClientError> {
        let info = self.request_info()?;
        let (w, h) = (info.width as usize, info.height as usize);
        let mut cells = vec![0i8; w * h];
        for t in info.tile_requests() {
            let tile = self.request_tile(t.col, t.row, t.width, t.height)?;
            let tw = t.width as usize;
            for (j, band) in tile.chunks_exact(tw).enumerate() {
                let start = (t.row as usize + j) * w + t.col as usize;
                cells[start..start + tw].copy_from_slice(band);
            }
        }
        Ok(OccupancyMap { info, cells })
    }

    /// The vector map (GET_VECTOR, `playerc_map_get_vector`); grid map drivers NACK it.
    pub fn get_vector(&self) -> Result<MapDataVector, ClientError> {
        request_ack!(self, MapReq::GetVector(None),
            Body::Map(MapMsg::Ack(MapReq::GetVector(Some(v)))) => v,
            "map GET_VECTOR")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn map_cells_are_indexed_row_by_row() {
        let m = OccupancyMap {
            info: MapInfo {
                scale: 1.0,
                width: 3,
                height: 2,
                origin: Pose2d::default(),
            },
            cells: vec![-1, 0, 1, 1, 1, -1],
        };
        assert_eq!(m.index(2, 1), Some(5));
        assert_eq!(m.cell(2, 0), Some(1));
        assert_eq!(m.cell(0, 1), Some(1));
        assert_eq!(m.cell(3, 0), None);
        assert_eq!(m.cell(0, 2), None);
    }
}

proxy!(
    /// A log device (`log`) of `writelog` (recording) or `readlog` (replay), as libplayerc's
    /// `playerc_log_t` and `playervcr` drive it: start and stop, rewind a replay, and name the
    /// file a recording goes to.
    LogProxy,
    LOG
);

/// What a log device is and does, from [`LogProxy::get_state`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LogState {
    /// `PLAYER_LOG_TYPE_READ` (1, readlog) or `PLAYER_LOG_TYPE_WRITE` (2, writelog).
    pub log_type: u8,
    /// Whether it is recording or replaying.
    pub state: bool,
}

impl LogProxy {
    /// Starts (`true`) or stops recording (`playerc_log_set_write_state`).
    pub fn set_write_state(&self, state: bool) -> Result<(), ClientError> {
        self.request(LogReq::SetWriteState(Some(LogSetWriteState {
            state: u8::from(state),
        })))?;
        Ok(())
    }

    /// Starts (`true`) or pauses replay (`playerc_log_set_read_state`).
    pub fn set_read_state(&self, state: bool) -> Result<(), ClientError> {
        self.request(LogReq::SetReadState(Some(LogSetReadState {
            state: u8::from(state),
        })))?;
        Ok(())
    }

    /// The device's kind and whether it runs (`playerc_log_get_state`).
    pub fn get_state(&self) -> Result<LogState, ClientError> {
        request_ack!(self, LogReq::GetState(None),
            Body::Log(LogMsg::Ack(LogReq::GetState(Some(s)))) => LogState {
                log_type: s.log_type,
                state: s.state != 0,
            },
            "log GET_STATE")
    }

    /// Rewinds a replay to the start of its file (`playerc_log_set_read_rewind`); whether it
    /// plays is unchanged.
    pub fn rewind(&self) -> Result<(), ClientError> {
        self.request(LogReq::SetReadRewind)?;
        Ok(())
    }

    /// Records to `filename` from now on (`playerc_log_set_filename`); the device refuses
    /// while recording. The name is counted without a NUL, as libplayerc sends it.
    pub fn set_filename(&self, filename: &str) -> Result<(), ClientError> {
        if filename.len() >= PLAYER_LOG_FILENAME_MAX {
            return Err(self.bad_reply("log SET_FILENAME: file name longer than 255 bytes"));
        }
        self.request(LogReq::SetFilename(Some(LogSetFilename {
            filename: Text::from_bytes(filename.as_bytes().to_vec()),
        })))?;
        Ok(())
    }
}

proxy!(
    /// A blackboard (`blackboard`, served by `localbb`): entries shared between clients, as
    /// libplayerc's `playerc_blackboard`. Updates of the keys and groups listened to arrive as
    /// DATA; [`BlackboardProxy::update`] is the latest.
    BlackboardProxy,
    BLACKBOARD
);

impl BlackboardProxy {
    /// A request naming `key` in `group` (libplayerc sends the names NUL counted).
    fn named(key: &str, group: &str) -> BlackboardEntry {
        BlackboardEntry {
            key: Text::new(key),
            group: Text::new(group),
            ..BlackboardEntry::default()
        }
    }

    /// Listens to `key` in `group`: every later set of it arrives as an update. Returns the
    /// entry stored now (empty data if none was set).
    pub fn subscribe_to_key(&self, key: &str, group: &str) -> Result<BlackboardEntry, ClientError> {
        request_ack!(self, BlackboardReq::SubscribeToKey(Some(Self::named(key, group))),
            Body::Blackboard(BlackboardMsg::Ack(BlackboardReq::SubscribeToKey(Some(e)))) => e,
            "blackboard SUBSCRIBE_TO_KEY")
    }

    /// Stops listening to `key` in `group` (one subscription of it).
    pub fn unsubscribe_from_key(&self, key: &str, group: &str) -> Result<(), ClientError> {
        self.request(BlackboardReq::UnsubscribeFromKey(Some(Self::named(
            key, group,
        ))))
        .map(drop)
    }

    /// Listens to every key of `group`; its current entries arrive as updates.
    pub fn subscribe_to_group(&self, group: &str) -> Result<(), ClientError> {
        self.request(BlackboardReq::SubscribeToGroup(Some(Self::named(
            "", group,
        ))))
        .map(drop)
    }

    /// Stops listening to `group` (one subscription of it).
    pub fn unsubscribe_from_group(&self, group: &str) -> Result<(), ClientError> {
        self.request(BlackboardReq::UnsubscribeFromGroup(Some(Self::named(
            "", group,
        ))))
        .map(drop)
    }

    /// Stores `entry` (its key and group say where); the listeners get it as an update.
    pub fn set_entry(&self, entry: BlackboardEntry) -> Result<(), ClientError> {
        self.request(BlackboardReq::SetEntry(Some(entry))).map(drop)
    }

    /// The entry stored at `key` in `group`, without listening to it.
    pub fn get_entry(&self, key: &str, group: &str) -> Result<BlackboardEntry, ClientError> {
        request_ack!(self, BlackboardReq::GetEntry(Some(Self::named(key, group))),
            Body::Blackboard(BlackboardMsg::Ack(BlackboardReq::GetEntry(Some(e)))) => e,
            "blackboard GET_ENTRY")
    }

    /// The latest update received.
    pub fn update(&self) -> Option<BlackboardEntry> {
        latest_data!(self, BlackboardData::UPDATE,
            Body::Blackboard(BlackboardMsg::Data(BlackboardData::Update(e))) => e)
    }
}
