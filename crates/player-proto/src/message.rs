//! Typed messages: upstream's function table, declared once, and whole-message encode/decode.
//!
//! The table below is the (interface, type, subtype) → body struct mapping of Player 3.0.2's
//! `.def` files (`functiontable_gen.h`) plus the universal rows of `functiontable.c`. From it
//! `message_table!` generates one enum per interface and kind (`Position2dCmd`, `RangerData`,
//! `PlayerReq`, ...), a per-interface enum (`Position2dMsg`), the top-level [`Body`], the decoder
//! dispatch and the encoder. ACK and NACK use the REQ row of the same subtype; universal rows
//! match every interface code and are tried first, as upstream's lookup does.

use crate::error::{Error, MessageKey, Problem};
use crate::frame::DecodeLimits;
use crate::header::{DeviceAddr, HEADER_SIZE, MsgHeader, MsgType};
use crate::interface::InterfaceCode;
use crate::types::*;
use crate::value::Value;
use crate::xdr::{Reader, Xdr};

/// Where a body comes from: wire bytes (decoding) or a field map (building from [`Value`]s).
/// One generated dispatch serves both, so they cannot disagree about the table.
pub(crate) trait BodySource {
    fn has_body(&self) -> bool;
    fn get<S: Xdr>(&mut self) -> Result<S, Error>;
}

impl BodySource for Reader<'_> {
    fn has_body(&self) -> bool {
        !self.is_empty()
    }
    fn get<S: Xdr>(&mut self) -> Result<S, Error> {
        S::decode(self)
    }
}

struct ValueSource<'a>(Option<&'a Value>);

impl BodySource for ValueSource<'_> {
    fn has_body(&self) -> bool {
        self.0.is_some()
    }
    fn get<S: Xdr>(&mut self) -> Result<S, Error> {
        match self.0.take() {
            Some(v) => S::from_value(v),
            None => Err(Error::value("no fields given for a body")),
        }
    }
}

/// Where a body goes: wire bytes (encoding) or a field map.
pub(crate) trait BodySink {
    fn put<S: Xdr>(&mut self, body: &S) -> Result<(), Error>;
}

impl BodySink for Vec<u8> {
    fn put<S: Xdr>(&mut self, body: &S) -> Result<(), Error> {
        body.encode(self)
    }
}

/// Records only whether a body would be written.
struct PresenceSink(bool);

impl BodySink for PresenceSink {
    fn put<S: Xdr>(&mut self, _body: &S) -> Result<(), Error> {
        self.0 = true;
        Ok(())
    }
}

struct ValueSink(Option<Value>);

impl BodySink for ValueSink {
    fn put<S: Xdr>(&mut self, body: &S) -> Result<(), Error> {
        self.0 = Some(body.to_value());
        Ok(())
    }
}

/// One row of the function table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MessageRow {
    /// Interface code; 0 for the universal rows, which match every interface.
    pub interface: InterfaceCode,
    /// DATA, CMD, REQ or SYNCH (ACK/NACK use the REQ rows).
    pub msg_type: MsgType,
    /// Subtype.
    pub subtype: u8,
    /// The C constant, e.g. `PLAYER_RANGER_REQ_GET_GEOM`.
    pub constant: &'static str,
    /// The C body struct, or `None` where the `.def` says `NULL` (never a body).
    pub body: Option<&'static str>,
}

fn push_kind_rows(
    rows: &mut Vec<MessageRow>,
    interface: InterfaceCode,
    msg_type: MsgType,
    kind_rows: &[(u8, &'static str, Option<&'static str>)],
) {
    rows.extend(
        kind_rows
            .iter()
            .map(|&(subtype, constant, body)| MessageRow {
                interface,
                msg_type,
                subtype,
                constant,
                body,
            }),
    );
}

/// Upstream's `playerxdr_get_ftrow`: the row for a header's (interface, type, subtype).
/// Universal rows match any interface; ACK and NACK fall back to the REQ row.
pub fn lookup(interf: InterfaceCode, msg_type: u8, subtype: u8) -> Option<MessageRow> {
    let t = MsgType::from_u8(msg_type)?;
    let t = match t {
        MsgType::RespAck | MsgType::RespNack => MsgType::Req,
        other => other,
    };
    message_rows().into_iter().find(|row| {
        (row.interface == interf || row.interface.0 == 0)
            && row.msg_type == t
            && row.subtype == subtype
    })
}

message_table! {
    /// Universal requests (interface code 0 in the table: valid on every device).
    universal UniversalReq (UniversalMsg) {
        255 PLAYER_CAPABILTIES_REQ Capabilities(CapabilitiesReq),
        254 PLAYER_GET_INTPROP_REQ GetIntProp(IntPropReq),
        253 PLAYER_SET_INTPROP_REQ SetIntProp(IntPropReq),
        252 PLAYER_GET_DBLPROP_REQ GetDblProp(DblPropReq),
        251 PLAYER_SET_DBLPROP_REQ SetDblProp(DblPropReq),
        250 PLAYER_GET_STRPROP_REQ GetStrProp(StrPropReq),
        249 PLAYER_SET_STRPROP_REQ SetStrProp(StrPropReq),
        248 PLAYER_GET_BOOLPROP_REQ GetBoolProp(BoolPropReq),
        247 PLAYER_SET_BOOLPROP_REQ SetBoolProp(BoolPropReq),
    }

    /// Messages of the `player` interface (1): the server itself.
    interface Player (PlayerMsg) = PLAYER {
        req PlayerReq {
            1 DEVLIST DevList(DeviceDevlist),
            2 DRIVERINFO DriverInfo(DeviceDriverinfo),
            3 DEV Dev(DeviceReq),
            4 DATA Data,
            5 DATAMODE DataMode(DeviceDatamodeReq),
            7 AUTH Auth(DeviceAuthReq),
            8 NAMESERVICE NameService(DeviceNameserviceReq),
            10 ADD_REPLACE_RULE AddReplaceRule(AddReplaceRuleReq),
        }
        synch PlayerSynch {
            1 OK Ok,
            2 OVERFLOW Overflow(Uint32),
        }
    }

    /// Messages of the `power` interface (2).
    interface Power (PowerMsg) = POWER {
        data PowerData {
            1 STATE State(PowerDataState),
        }
        req PowerReq {
            1 SET_CHARGING_POLICY_REQ SetChargingPolicy(PowerChargepolicyConfig),
        }
    }

    /// Messages of the `gripper` interface (3).
    interface Gripper (GripperMsg) = GRIPPER {
        data GripperData {
            1 STATE State(GripperDataState),
        }
        cmd GripperCmd {
            1 OPEN Open,
            2 CLOSE Close,
            3 STOP Stop,
            4 STORE Store,
            5 RETRIEVE Retrieve,
        }
        req GripperReq {
            1 GET_GEOM GetGeom(GripperGeom),
        }
    }

    /// Messages of the `position2d` interface (4).
    interface Position2d (Position2dMsg) = POSITION2D {
        data Position2dData {
            1 STATE State(Position2dDataState),
            2 GEOM Geom(Position2dGeom),
        }
        cmd Position2dCmd {
            1 VEL Vel(Position2dCmdVel),
            2 POS Pos(Position2dCmdPos),
            3 CAR Car(Position2dCmdCar),
            4 VEL_HEAD VelHead(Position2dCmdVelHead),
        }
        req Position2dReq {
            1 GET_GEOM GetGeom(Position2dGeom),
            2 MOTOR_POWER MotorPower(Position2dPowerConfig),
            3 VELOCITY_MODE VelocityMode(Position2dVelocityModeConfig),
            4 POSITION_MODE PositionMode(Position2dPositionModeReq),
            5 SET_ODOM SetOdom(Position2dSetOdomReq),
            6 RESET_ODOM ResetOdom,
            7 SPEED_PID SpeedPid(Position2dSpeedPidReq),
            8 POSITION_PID PositionPid(Position2dPositionPidReq),
            9 SPEED_PROF SpeedProf(Position2dSpeedProfReq),
        }
    }

    /// Messages of the `sonar` interface (5).
    interface Sonar (SonarMsg) = SONAR {
        data SonarData {
            1 RANGES Ranges(SonarDataRanges),
            2 GEOM Geom(SonarGeom),
        }
        req SonarReq {
            1 GET_GEOM GetGeom(SonarGeom),
            2 POWER Power(SonarPowerConfig),
        }
    }

    /// Messages of the `laser` interface (6).
    interface Laser (LaserMsg) = LASER {
        data LaserData {
            1 SCAN Scan(LaserDataScan),
            2 SCANPOSE ScanPose(LaserDataScanpose),
            3 SCANANGLE ScanAngle(LaserDataScanangle),
        }
        req LaserReq {
            1 GET_GEOM GetGeom(LaserGeom),
            2 SET_CONFIG SetConfig(LaserConfig),
            3 GET_CONFIG GetConfig(LaserConfig),
            4 POWER Power(LaserPowerConfig),
            5 GET_ID GetId(LaserGetIdConfig),
            6 SET_FILTER SetFilter(LaserSetFilterConfig),
        }
    }

    /// Messages of the `blobfinder` interface (7).
    interface Blobfinder (BlobfinderMsg) = BLOBFINDER {
        data BlobfinderData {
            1 BLOBS Blobs(BlobfinderDataBlobs),
        }
        req BlobfinderReq {
            1 SET_COLOR SetColor(BlobfinderColorConfig),
            2 SET_IMAGER_PARAMS SetImagerParams(BlobfinderImagerConfig),
            3 GET_COLOR GetColor(BlobfinderColorConfig),
        }
    }

    /// Messages of the `ptz` interface (8).
    interface Ptz (PtzMsg) = PTZ {
        data PtzData {
            1 STATE State(PtzDataState),
            2 GEOM Geom(PtzGeom),
        }
        cmd PtzCmd {
            1 STATE State(PtzCmdState),
        }
        req PtzReq {
            1 GENERIC Generic(PtzReqGeneric),
            2 CONTROL_MODE ControlMode(PtzReqControlMode),
            4 GEOM Geom(PtzGeom),
            5 STATUS Status(PtzReqStatus),
        }
    }

    /// Messages of the `fiducial` interface (10).
    interface Fiducial (FiducialMsg) = FIDUCIAL {
        data FiducialData {
            1 SCAN Scan(FiducialDataScan),
        }
        req FiducialReq {
            1 GET_GEOM GetGeom(FiducialGeom),
            2 GET_FOV GetFov(FiducialFov),
            3 SET_FOV SetFov(FiducialFov),
            7 GET_ID GetId(FiducialId),
            8 SET_ID SetId(FiducialId),
        }
    }

    /// Messages of the `speech` interface (12).
    interface Speech (SpeechMsg) = SPEECH {
        cmd SpeechCmd {
            1 SAY Say(SpeechCmdSay),
        }
    }

    /// Messages of the `opaque` interface (51): the same struct for data, commands and
    /// requests.
    interface Opaque (OpaqueMsg) = OPAQUE {
        data OpaqueDataMsg {
            1 STATE State(OpaqueData),
        }
        cmd OpaqueCmd {
            1 DATA Data(OpaqueData),
        }
        req OpaqueReq {
            1 DATA Data(OpaqueData),
        }
    }

    /// Messages of the `blackboard` interface (64): every message carries one entry (a
    /// request names its key and group; ACKs of unsubscribe, group subscribe and set are
    /// empty).
    interface Blackboard (BlackboardMsg) = BLACKBOARD {
        data BlackboardData {
            1 UPDATE Update(BlackboardEntry),
        }
        req BlackboardReq {
            1 SUBSCRIBE_TO_KEY SubscribeToKey(BlackboardEntry),
            2 UNSUBSCRIBE_FROM_KEY UnsubscribeFromKey(BlackboardEntry),
            3 SET_ENTRY SetEntry(BlackboardEntry),
            4 SUBSCRIBE_TO_GROUP SubscribeToGroup(BlackboardEntry),
            5 UNSUBSCRIBE_FROM_GROUP UnsubscribeFromGroup(BlackboardEntry),
            6 GET_ENTRY GetEntry(BlackboardEntry),
        }
    }

    /// Messages of the `planner` interface (44): goal in, execution state out, and the plan's
    /// waypoints on request.
    interface Planner (PlannerMsg) = PLANNER {
        data PlannerDataMsg {
            1 STATE State(PlannerData),
        }
        cmd PlannerCmdMsg {
            1 GOAL Goal(PlannerCmd),
        }
        req PlannerReq {
            1 GET_WAYPOINTS GetWaypoints(PlannerWaypointsReq),
            2 ENABLE Enable(PlannerEnableReq),
        }
    }

    /// Messages of the `bumper` interface (14).
    interface Bumper (BumperMsg) = BUMPER {
        data BumperData {
            1 STATE State(BumperDataState),
            2 GEOM Geom(BumperGeom),
        }
        req BumperReq {
            1 GET_GEOM GetGeom(BumperGeom),
        }
    }

    /// Messages of the `ir` interface (22).
    interface Ir (IrMsg) = IR {
        data IrData {
            1 RANGES Ranges(IrDataRanges),
        }
        req IrReq {
            1 POSE Pose(IrPose),
            2 POWER Power(IrPowerReq),
        }
    }

    /// Messages of the `localize` interface (25).
    interface Localize (LocalizeMsg) = LOCALIZE {
        data LocalizeData {
            1 HYPOTHS Hypoths(LocalizeDataHypoths),
        }
        req LocalizeReq {
            1 SET_POSE SetPose(LocalizeSetPose),
            2 GET_PARTICLES GetParticles(LocalizeGetParticles),
        }
    }

    /// Messages of the `simulation` interface (31).
    interface Simulation (SimulationMsg) = SIMULATION {
        cmd SimulationCmd {
            1 PAUSE Pause,
            2 RESET Reset,
            3 SAVE Save,
        }
        req SimulationReq {
            1 GET_POSE2D GetPose2d(SimulationPose2dReq),
            2 SET_POSE2D SetPose2d(SimulationPose2dReq),
            3 GET_POSE3D GetPose3d(SimulationPose3dReq),
            4 SET_POSE3D SetPose3d(SimulationPose3dReq),
            5 GET_PROPERTY GetProperty(SimulationPropertyReq),
            6 SET_PROPERTY SetProperty(SimulationPropertyReq),
        }
    }

    /// Messages of the `log` interface (45): recording and replay control.
    interface Log (LogMsg) = LOG {
        req LogReq {
            1 SET_WRITE_STATE SetWriteState(LogSetWriteState),
            2 SET_READ_STATE SetReadState(LogSetReadState),
            3 GET_STATE GetState(LogGetState),
            4 SET_READ_REWIND SetReadRewind,
            5 SET_FILENAME SetFilename(LogSetFilename),
        }
    }

    /// Messages of the `blinkenlight` interface (33).
    interface Blinkenlight (BlinkenlightMsg) = BLINKENLIGHT {
        data BlinkenlightData {
            1 STATE State(BlinkenlightDataState),
        }
        cmd BlinkenlightCmd {
            1 STATE State(BlinkenlightCmdState),
            2 POWER Power(BlinkenlightCmdPower),
            3 COLOR Color(BlinkenlightCmdColor),
            4 FLASH Flash(BlinkenlightCmdFlash),
        }
    }

    /// Messages of the `camera` interface (40).
    interface Camera (CameraMsg) = CAMERA {
        data CameraData {
            1 STATE State(CameraDataState),
        }
    }

    /// Messages of the `map` interface (42).
    interface Map (MapMsg) = MAP {
        data MapData {
            1 INFO Info(MapInfo),
        }
        req MapReq {
            1 GET_INFO GetInfo(MapInfo),
            2 GET_DATA GetData(MapTile),
            3 GET_VECTOR GetVector(MapDataVector),
        }
    }

    /// Messages of the `actarray` interface (53).
    interface Actarray (ActarrayMsg) = ACTARRAY {
        data ActarrayData {
            1 STATE State(ActarrayDataState),
        }
        cmd ActarrayCmd {
            1 POS Pos(ActarrayPositionCmd),
            2 MULTI_POS MultiPos(ActarrayMultiPositionCmd),
            3 SPEED Speed(ActarraySpeedCmd),
            4 MULTI_SPEED MultiSpeed(ActarrayMultiSpeedCmd),
            5 HOME Home(ActarrayHomeCmd),
            6 CURRENT Current(ActarrayCurrentCmd),
            7 MULTI_CURRENT MultiCurrent(ActarrayMultiCurrentCmd),
        }
        req ActarrayReq {
            1 POWER Power(ActarrayPowerConfig),
            2 BRAKES Brakes(ActarrayBrakesConfig),
            3 GET_GEOM GetGeom(ActarrayGeom),
            4 SPEED Speed(ActarraySpeedConfig),
            5 ACCEL Accel(ActarrayAccelConfig),
        }
    }

    /// Messages of the `graphics2d` interface (55).
    interface Graphics2d (Graphics2dMsg) = GRAPHICS2D {
        cmd Graphics2dCmd {
            1 CLEAR Clear,
            2 POINTS Points(Graphics2dCmdPoints),
            3 POLYLINE Polyline(Graphics2dCmdPolyline),
            4 POLYGON Polygon(Graphics2dCmdPolygon),
        }
    }

    /// Messages of the `graphics3d` interface (58).
    interface Graphics3d (Graphics3dMsg) = GRAPHICS3D {
        cmd Graphics3dCmd {
            1 CLEAR Clear,
            2 DRAW Draw(Graphics3dCmdDraw),
            3 TRANSLATE Translate(Graphics3dCmdTranslate),
            4 ROTATE Rotate(Graphics3dCmdRotate),
            5 PUSH Push,
            6 POP Pop,
        }
    }

    /// Messages of the `ranger` interface (62).
    interface Ranger (RangerMsg) = RANGER {
        data RangerData {
            1 RANGE Range(RangerDataRange),
            2 RANGESTAMPED RangeStamped(RangerDataRangestamped),
            3 INTNS Intns(RangerDataIntns),
            4 INTNSSTAMPED IntnsStamped(RangerDataIntnsstamped),
            5 GEOM Geom(RangerGeom),
        }
        req RangerReq {
            1 GET_GEOM GetGeom(RangerGeom),
            2 POWER Power(RangerPowerConfig),
            3 INTNS Intns(RangerIntnsConfig),
            4 SET_CONFIG SetConfig(RangerConfig),
            5 GET_CONFIG GetConfig(RangerConfig),
        }
    }
}

impl Body {
    /// The body's field-map view (`None` when the message carries no body).
    pub fn to_value(&self) -> Option<Value> {
        let mut sink = ValueSink(None);
        // Putting into a field map cannot fail.
        let _ = self.write(&mut sink);
        sink.0
    }

    /// Builds the body for (interface, type, subtype) from a field map, with exactly the
    /// dispatch the decoder uses; `None` means "no body".
    pub fn from_value(key: MessageKey, fields: Option<&Value>) -> Result<Body, Error> {
        Body::read(key, &mut ValueSource(fields))
    }

    /// The body's XDR encoding (empty when it carries none).
    pub fn encode(&self) -> Result<Vec<u8>, Error> {
        let mut out = Vec::new();
        self.write(&mut out)?;
        Ok(out)
    }

    /// Whether the message carries a body (`size` > 0 on the wire).
    pub fn has_body(&self) -> bool {
        let mut sink = PresenceSink(false);
        let _ = self.write(&mut sink);
        sink.0
    }

    /// The C struct actually carried, or `None` when there is no body (e.g. a null request).
    pub fn carried_struct(&self) -> Option<&'static str> {
        self.row_struct().filter(|_| self.has_body())
    }

    /// The key this body must travel under when addressed to a device of interface `interf`
    /// (universal bodies take the device's own interface code).
    pub fn key_for(&self, interf: InterfaceCode) -> MessageKey {
        MessageKey {
            interf: self.interface().unwrap_or(interf),
            msg_type: self.msg_type().code(),
            subtype: self.subtype(),
        }
    }
}

/// Decodes a message body selected by its header, refusing anything upstream's table would not
/// produce: unknown (interface, type, subtype), a body where the `.def` says `NULL`, a missing
/// DATA/CMD/SYNCH body, truncation, impossible counts, a body over `limits.max_body`, or bytes
/// left over after the struct.
pub fn decode_body(header: &MsgHeader, body: &[u8], limits: &DecodeLimits) -> Result<Body, Error> {
    if body.len() > limits.max_body {
        return Err(Error::BodyTooLarge {
            size: body.len() as u64,
            max: limits.max_body,
        });
    }
    if header.size as usize != body.len() {
        return Err(Error::SizeMismatch {
            announced: header.size,
            actual: body.len(),
        });
    }
    let mut reader = Reader::new(body);
    let decoded = Body::read(header.key(), &mut reader)?;
    if !reader.is_empty() {
        return Err(Error::Malformed {
            at: crate::error::Location::of_struct(decoded.row_struct().unwrap_or("")),
            problem: Problem::Trailing(reader.remaining()),
        });
    }
    Ok(decoded)
}

/// A complete message: its header and typed body.
#[derive(Clone, Debug, PartialEq)]
pub struct Message {
    /// The header; `size` is recomputed when encoding.
    pub header: MsgHeader,
    /// The typed body.
    pub body: Body,
}

impl Message {
    /// A message to or from `addr`; type and subtype come from the body, `seq` is 0.
    ///
    /// For a non-universal body `addr.interf` should be the body's interface; [`Message::encode`]
    /// checks this rather than silently rewriting the address.
    pub fn new(addr: DeviceAddr, timestamp: f64, body: impl Into<Body>) -> Message {
        let body = body.into();
        Message {
            header: MsgHeader::new(addr, body.msg_type(), body.subtype(), timestamp),
            body,
        }
    }

    /// Decodes a whole message from a header and its body bytes (see [`decode_body`]).
    pub fn decode(header: MsgHeader, body: &[u8], limits: &DecodeLimits) -> Result<Message, Error> {
        Ok(Message {
            body: decode_body(&header, body, limits)?,
            header,
        })
    }

    /// Appends header + body to `out`, with the header's `size` set to the body length.
    /// Fails (leaving `out` as it was) if the header's type, subtype or interface disagree with
    /// the body, or a value exceeds a fixed C array.
    pub fn encode_into(&self, out: &mut Vec<u8>) -> Result<(), Error> {
        let want = self.body.key_for(self.header.addr.interf);
        let have = self.header.key();
        if want != have {
            return Err(Error::HeaderMismatch {
                header: have,
                body: want,
            });
        }
        let start = out.len();
        out.extend_from_slice(&[0u8; HEADER_SIZE]);
        if let Err(e) = self.body.write(out) {
            out.truncate(start);
            return Err(e);
        }
        let size = out.len() - start - HEADER_SIZE;
        let Ok(size) = u32::try_from(size) else {
            out.truncate(start);
            return Err(Error::BodyTooLarge {
                size: size as u64,
                max: u32::MAX as usize,
            });
        };
        let header = MsgHeader {
            size,
            ..self.header
        };
        out[start..start + HEADER_SIZE].copy_from_slice(&header.to_bytes());
        Ok(())
    }

    /// The message's bytes: 40-byte header then body.
    pub fn encode(&self) -> Result<Vec<u8>, Error> {
        let mut out = Vec::new();
        self.encode_into(&mut out)?;
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::constants::*;

    fn localhost(interf: InterfaceCode, index: u16) -> DeviceAddr {
        DeviceAddr::new(LOCALHOST_ADDR, 6665, interf, index)
    }

    #[test]
    fn table_is_consistent() {
        let rows = message_rows();
        // 9 universal rows + every row of the 25 interfaces.
        assert_eq!(rows.iter().filter(|r| r.interface.0 == 0).count(), 9);
        for (i, a) in rows.iter().enumerate() {
            assert!(a.interface.0 == 0 || a.interface.name().is_some());
            for b in &rows[i + 1..] {
                assert!(
                    (a.interface, a.msg_type, a.subtype) != (b.interface, b.msg_type, b.subtype),
                    "duplicate row {a:?}"
                );
            }
            let prefix = match a.interface.name() {
                Some(name) => format!(
                    "PLAYER_{}_{}_",
                    name.to_uppercase(),
                    a.msg_type.short_name()
                ),
                None => "PLAYER_".into(),
            };
            assert!(a.constant.starts_with(&prefix), "{a:?}");
        }
        let interfaces: std::collections::BTreeSet<u16> =
            rows.iter().map(|r| r.interface.0).collect();
        assert_eq!(interfaces.len(), 26, "{interfaces:?}");
    }

    #[test]
    fn lookup_follows_upstream_rules() {
        let ack = MsgType::RespAck.code();
        let row = lookup(InterfaceCode::POSITION2D, ack, 1).unwrap();
        assert_eq!(row.body, Some("player_position2d_geom_t"));
        assert_eq!(row.msg_type, MsgType::Req);
        let row = lookup(InterfaceCode::GPS, MsgType::Req.code(), 255).unwrap();
        assert_eq!(row.body, Some("player_capabilities_req_t"));
        assert_eq!(
            lookup(InterfaceCode::POSITION2D, MsgType::Data.code(), 255),
            None
        );
        assert_eq!(
            lookup(InterfaceCode::PLAYER, MsgType::Synch.code(), 1).map(|r| r.body),
            Some(None)
        );
    }

    #[test]
    fn in_reply_reads_the_ack_and_the_local_req_form_only() {
        let geom = SonarReq::GetGeom(Some(SonarGeom::default()));
        let ack = Body::Sonar(SonarMsg::Ack(geom.clone()));
        let req: Body = geom.clone().into();
        assert_eq!(SonarReq::in_reply(&ack), Some(&geom));
        assert_eq!(SonarReq::in_reply(&req), Some(&geom));
        assert_eq!(SonarReq::in_reply(&Body::Sonar(SonarMsg::Nack(geom))), None);
        let data = Body::Sonar(SonarMsg::Data(SonarData::Geom(SonarGeom::default())));
        assert_eq!(SonarReq::in_reply(&data), None);
        let laser: Body = LaserReq::GetGeom(None).into();
        assert_eq!(SonarReq::in_reply(&laser), None);
        assert_eq!(LaserReq::in_reply(&laser), Some(&LaserReq::GetGeom(None)));
    }

    #[test]
    fn spec_3_8_1_position2d_data_state() {
        let msg = Message {
            header: MsgHeader {
                timestamp: 12.3,
                ..MsgHeader::new(
                    localhost(InterfaceCode::POSITION2D, 0),
                    MsgType::Data,
                    1,
                    0.0,
                )
            },
            body: Position2dData::State(Position2dDataState {
                pos: Pose2d {
                    px: 1.0,
                    py: 2.0,
                    pa: 0.5,
                },
                vel: Pose2d {
                    px: 0.25,
                    py: 0.0,
                    pa: -0.125,
                },
                stall: 0,
            })
            .into(),
        };
        let bytes = msg.encode().unwrap();
        assert_eq!(bytes.len(), 92);
        assert_eq!(&bytes[36..40], &[0, 0, 0, 0x34]);
        let header = MsgHeader::from_bytes(bytes[..40].try_into().unwrap()).unwrap();
        let back = Message::decode(header, &bytes[40..], &DecodeLimits::default()).unwrap();
        assert_eq!(back.header.size, 52);
        assert_eq!(back.body, msg.body);
    }

    #[test]
    fn null_requests_and_replies() {
        let limits = DecodeLimits::default();
        let mut h = MsgHeader::new(
            localhost(InterfaceCode::POSITION2D, 0),
            MsgType::Req,
            Position2dReq::GET_GEOM,
            0.0,
        );
        assert_eq!(
            decode_body(&h, &[], &limits).unwrap(),
            Body::Position2d(Position2dMsg::Req(Position2dReq::GetGeom(None)))
        );
        // RESET_ODOM has no struct: a body is refused, no body is fine.
        h.subtype = Position2dReq::RESET_ODOM;
        assert!(decode_body(&h, &[], &limits).is_ok());
        h.size = 4;
        let err = decode_body(&h, &[0; 4], &limits).unwrap_err();
        assert!(matches!(err, Error::UnexpectedBody { .. }), "{err}");
        // A CMD whose row has a struct needs its body.
        let h = MsgHeader::new(
            localhost(InterfaceCode::POSITION2D, 0),
            MsgType::Cmd,
            Position2dCmd::VEL,
            0.0,
        );
        let err = decode_body(&h, &[], &limits).unwrap_err();
        assert!(err.to_string().contains("requires a body"), "{err}");
    }

    #[test]
    fn dispatch_errors_are_clear() {
        let limits = DecodeLimits::default();
        let h = MsgHeader::new(localhost(InterfaceCode::RANGER, 0), MsgType::Data, 9, 0.0);
        let err = decode_body(&h, &[], &limits).unwrap_err();
        assert_eq!(
            err.to_string(),
            "no Player 3.0.2 message ranger(62) data(1) subtype 9"
        );
        let mut h = MsgHeader::new(localhost(InterfaceCode::GPS, 0), MsgType::Data, 1, 0.0);
        assert!(matches!(
            decode_body(&h, &[], &limits),
            Err(Error::UnknownMessage(_))
        ));
        h.msg_type = 9;
        assert_eq!(decode_body(&h, &[], &limits), Err(Error::UnknownMsgType(9)));
        let h = MsgHeader {
            size: 8,
            ..MsgHeader::new(localhost(InterfaceCode::RANGER, 0), MsgType::Data, 1, 0.0)
        };
        let err = decode_body(&h, &[0; 8], &DecodeLimits { max_body: 4 }).unwrap_err();
        assert!(matches!(err, Error::BodyTooLarge { size: 8, max: 4 }));
        let err = decode_body(&h, &[0; 12], &limits).unwrap_err();
        assert!(matches!(
            err,
            Error::SizeMismatch {
                announced: 8,
                actual: 12
            }
        ));
        let truncated = MsgHeader {
            size: 44,
            ..MsgHeader::new(
                localhost(InterfaceCode::POSITION2D, 0),
                MsgType::Data,
                1,
                0.0,
            )
        };
        let err = decode_body(&truncated, &[0; 44], &limits).unwrap_err();
        assert_eq!(
            err.to_string(),
            "malformed player_position2d_data_t.vel.pa: truncated: needs 8 more bytes but only 4 remain"
        );
        let h = MsgHeader { size: 12, ..h };
        let err = decode_body(&h, &[0; 12], &limits).unwrap_err();
        assert_eq!(
            err.to_string(),
            "malformed player_ranger_data_range_t: 4 trailing bytes after the last member"
        );
    }

    #[test]
    fn universal_requests_apply_to_any_interface() {
        let body = Body::Universal(UniversalMsg::Req(UniversalReq::Capabilities(Some(
            CapabilitiesReq {
                msg_type: 3,
                subtype: 3,
            },
        ))));
        let msg = Message::new(localhost(InterfaceCode::SIMULATION, 0), 0.0, body.clone());
        let bytes = msg.encode().unwrap();
        assert_eq!(&bytes[8..12], &[0, 0, 0, 31]);
        assert_eq!(&bytes[20..24], &[0, 0, 0, 255]);
        let header = MsgHeader::from_bytes(bytes[..40].try_into().unwrap()).unwrap();
        assert_eq!(
            decode_body(&header, &bytes[40..], &DecodeLimits::default()).unwrap(),
            body
        );
    }

    #[test]
    fn encode_checks_header_against_body() {
        let msg = Message::new(
            localhost(InterfaceCode::LASER, 0),
            0.0,
            Position2dCmd::Vel(Position2dCmdVel::default()),
        );
        let mut out = vec![1, 2, 3];
        let err = msg.encode_into(&mut out).unwrap_err();
        assert!(matches!(err, Error::HeaderMismatch { .. }), "{err}");
        assert_eq!(out, [1, 2, 3]);
        let too_long = Message::new(
            DeviceAddr::new(LOCALHOST_ADDR, 6665, InterfaceCode::PLAYER, 0),
            0.0,
            Body::Player(PlayerMsg::Ack(PlayerReq::Dev(Some(DeviceReq {
                driver_name: crate::Text::from_bytes(vec![b'x'; 65]),
                ..Default::default()
            })))),
        );
        let err = too_long.encode_into(&mut out).unwrap_err();
        assert_eq!(
            err.to_string(),
            "cannot encode player_device_req_t.driver_name: 65 elements exceed the maximum 64"
        );
        assert_eq!(out, [1, 2, 3]);
    }

    #[test]
    fn typed_constants() {
        assert_eq!(PlayerSynch::OK, 1);
        assert_eq!(PlayerSynch::OVERFLOW, 2);
        assert_eq!(PlayerReq::DATAMODE, 5);
        assert_eq!(ActarrayReq::GET_GEOM, 3);
        assert_eq!(UniversalReq::PLAYER_CAPABILTIES_REQ, 255);
        assert_eq!(
            Body::from(Position2dCmd::Vel(Position2dCmdVel::default())).constant(),
            "PLAYER_POSITION2D_CMD_VEL"
        );
        assert_eq!(
            Body::Player(PlayerMsg::Synch(PlayerSynch::Ok)).row_struct(),
            None
        );
        let null_req = Body::from(Position2dReq::GetGeom(None));
        assert!(!null_req.has_body());
        assert_eq!(null_req.row_struct(), Some("player_position2d_geom_t"));
        assert_eq!(null_req.carried_struct(), None);
        assert!(Body::from(Position2dReq::GetGeom(Some(Position2dGeom::default()))).has_body());
    }

    mod roundtrip {
        use super::*;
        use proptest::test_runner::{Config, TestRunner};

        /// Every row of the table, every message type it can travel as: generated values encode,
        /// decode back to the same bytes, and survive the field-map view too.
        #[test]
        fn every_message_round_trips() {
            let rows = Body::arbitrary_rows();
            assert!(rows.len() > 130, "{} rows", rows.len());
            let limits = DecodeLimits::default();
            let row_count = rows.len();
            let checked = std::cell::Cell::new(0usize);
            for (name, strategy) in rows {
                let mut runner = TestRunner::new(Config {
                    cases: 48,
                    failure_persistence: None,
                    ..Config::default()
                });
                runner
                    .run(&strategy, |body| {
                        let addr = DeviceAddr::new(
                            LOCALHOST_ADDR,
                            6665,
                            body.interface().unwrap_or(InterfaceCode::SIMULATION),
                            0,
                        );
                        let msg = Message::new(addr, 1.5, body.clone());
                        let bytes = msg.encode().expect("encode");
                        let header =
                            MsgHeader::from_bytes(bytes[..HEADER_SIZE].try_into().unwrap())
                                .expect("header");
                        let back = Message::decode(header, &bytes[HEADER_SIZE..], &limits)
                            .unwrap_or_else(|e| panic!("{name}: {e}"));
                        assert_eq!(back.encode().unwrap(), bytes, "{name}");
                        let rebuilt = Body::from_value(header.key(), body.to_value().as_ref())
                            .unwrap_or_else(|e| panic!("{name}: {e}"));
                        assert_eq!(rebuilt.encode().unwrap(), bytes[HEADER_SIZE..], "{name}");
                        checked.set(checked.get() + 1);
                        Ok(())
                    })
                    .unwrap_or_else(|e| panic!("{name}: {e}"));
            }
            eprintln!(
                "round-tripped {} cases over {row_count} table rows",
                checked.get()
            );
            assert!(checked.get() >= row_count * 48);
        }
    }
}
