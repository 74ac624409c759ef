//! What the node does with the messages it receives, apart from DDS: reading a sample's bytes
//! the way RustDDS and ros2-client read them for the node's subscriptions and its
//! `reset_positions` servers, and applying a decoded command to the world.
//!
//! [`crate::Bridge`] applies every command through [`apply_cmd_vel`], [`apply_cmd_pose`] and
//! [`reset`]; the decoders let tests and the `ros2_inbound` fuzz target drive the same CDR
//! reading without a DDS participant (ros2-client keeps its own request unwrapping private, so
//! the service mappings are followed step by step here).

use ros2_client::dds::rustdds::bytes::Bytes;
use ros2_client::dds::rustdds::no_key::DeserializerAdapter;
use ros2_client::dds::rustdds::serialization::{
    deserialize_from_cdr_with_rep_id, to_writer_with_rep_id,
};
use ros2_client::dds::rustdds::{CDRDeserializerAdapter, SerializedPayload};
use serde::{Deserialize, Serialize};
use stage_sim::{ModelId, World};

/// A sample's data representation (CDR little- or big-endian, ...): the first two bytes of a
/// serialised sample.
pub use ros2_client::dds::rustdds::RepresentationIdentifier;

use crate::msgs::{EmptyMessage, PlainEmptyRequest, Pose, RosType, Twist};

/// Why a sample's bytes do not read as the expected message (the bridge drops it with a
/// warning naming the topic or service).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DecodeError {
    /// Fewer bytes than the 4-byte encapsulation header (representation and options).
    #[error("a sample of {0} bytes is shorter than its 4-byte encapsulation header")]
    Short(usize),
    /// A representation other than the CDR ones the reader takes.
    #[error("data representation {0:02x}{1:02x} is not one this reader takes (CDR)")]
    Representation(u8, u8),
    /// The CDR body does not read as the message.
    #[error("{0}")]
    Cdr(String),
}

/// A service request's mapping onto DDS: where the request identity travels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RequestMapping {
    /// Cyclone's: a 16-byte header (the client GUID's second half, the sequence number) in
    /// front of the request.
    Cyclone,
    /// Fast DDS's (ros2-client's `Enhanced`): the request alone, its identity in inline QoS.
    FastDds,
}

/// Splits a serialised sample into its representation and CDR body, as RustDDS's reader does
/// (`SerializedPayload::from_bytes`, then the representation checked against `accepted`).
fn body(
    payload: &[u8],
    accepted: &[RepresentationIdentifier],
) -> Result<(RepresentationIdentifier, Bytes), DecodeError> {
    let sample = SerializedPayload::from_bytes(&Bytes::copy_from_slice(payload))
        .map_err(|_| DecodeError::Short(payload.len()))?;
    let rep = sample.representation_identifier;
    if !accepted.contains(&rep) {
        let b = rep.to_bytes();
        return Err(DecodeError::Representation(b[0], b[1]));
    }
    Ok((rep, sample.value))
}

/// Reads a topic sample (the 4-byte encapsulation header and the CDR body) as the node's
/// subscription of `T` does: RustDDS's `CDRDeserializerAdapter` with its representations
/// (CDR big- and little-endian, PL_CDR little-endian). Returns the message and the number of
/// body bytes it took (a writer may send more).
pub fn decode_message<T: RosType>(payload: &[u8]) -> Result<(T, usize), DecodeError> {
    let (rep, value) = body(payload, CDRDeserializerAdapter::<T>::supported_encodings())?;
    // what the subscription's reader calls ...
    let message = CDRDeserializerAdapter::<T>::from_bytes(&value, rep)
        .map_err(|e| DecodeError::Cdr(e.to_string()))?;
    // ... and the same read again for its length, which the adapter does not return
    let (_, used) = deserialize_from_cdr_with_rep_id::<T>(&value, rep)
        .map_err(|e| DecodeError::Cdr(e.to_string()))?;
    Ok((message, used))
}

/// The representation a sample names in its first two bytes (`None`: fewer than two).
pub fn representation_of(sample: &[u8]) -> Option<RepresentationIdentifier> {
    RepresentationIdentifier::from_bytes(sample.get(..2)?).ok()
}

/// Writes `message` as a sample in representation `rep` (its header and CDR body), as a
/// publisher writing in that representation does; the inverse of [`decode_message`].
pub fn encode_message<T: Serialize>(message: &T, rep: RepresentationIdentifier) -> Vec<u8> {
    let header: Bytes = SerializedPayload::new(rep, Vec::new()).into();
    let mut out = header.to_vec();
    to_writer_with_rep_id(&mut out, message, rep).expect("CDR into memory does not fail");
    out
}

/// The representations a service server's reader takes (ros2-client's service adapter: CDR
/// big- and little-endian).
const SERVICE_REPRESENTATIONS: [RepresentationIdentifier; 2] = [
    RepresentationIdentifier::CDR_BE,
    RepresentationIdentifier::CDR_LE,
];

/// Cyclone's request header (rmw_cyclonedds's `cdds_request_header_t`, as ros2-client reads it).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct CycloneRequestHeader {
    /// The last 8 bytes of the client's GUID.
    pub client_guid_low: [u8; 8],
    /// The request's sequence number, high word.
    pub sequence_high: i32,
    /// The request's sequence number, low word.
    pub sequence_low: u32,
}

/// A `reset_positions` request as the node's server in `mapping` reads it: Cyclone's header
/// then std_srvs/Empty's byte, or (Fast DDS) the byte alone, refusing a request with a header
/// in front ([`PlainEmptyRequest`]). Returns the header (Cyclone's mapping) and the request.
pub fn decode_reset_request(
    payload: &[u8],
    mapping: RequestMapping,
) -> Result<(Option<CycloneRequestHeader>, EmptyMessage), DecodeError> {
    let (rep, value) = body(payload, &SERVICE_REPRESENTATIONS)?;
    let cdr = |e: ros2_client::dds::rustdds::serialization::Error| DecodeError::Cdr(e.to_string());
    match mapping {
        RequestMapping::FastDds => {
            let (r, _) =
                deserialize_from_cdr_with_rep_id::<PlainEmptyRequest>(&value, rep).map_err(cdr)?;
            Ok((
                None,
                EmptyMessage {
                    structure_needs_at_least_one_member: r.structure_needs_at_least_one_member,
                },
            ))
        }
        RequestMapping::Cyclone => {
            let (header, used) =
                deserialize_from_cdr_with_rep_id::<CycloneRequestHeader>(&value, rep)
                    .map_err(cdr)?;
            let rest = value.get(used..).unwrap_or_default();
            let (request, _) =
                deserialize_from_cdr_with_rep_id::<EmptyMessage>(rest, rep).map_err(cdr)?;
            Ok((Some(header), request))
        }
    }
}

/// Why the bridge did not apply a command (logged as a warning naming the topic).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Refused {
    /// A velocity with a NaN or infinite component.
    #[error(
        "ignored a velocity command that is not finite (linear.x {vx}, linear.y {vy}, \
         angular.z {va}); the vehicle keeps its previous command"
    )]
    Velocity {
        /// linear.x.
        vx: f64,
        /// linear.y.
        vy: f64,
        /// angular.z.
        va: f64,
    },
    /// A pose whose position or heading is NaN or infinite.
    #[error("ignored a pose that is not finite (x {x}, y {y}, yaw {yaw}); the vehicle stays")]
    PoseNotFinite {
        /// position.x.
        x: f64,
        /// position.y.
        y: f64,
        /// The orientation's yaw.
        yaw: f64,
    },
    /// A pose farther out than [`MAX_POSE_M`].
    #[error(
        "ignored a pose at x {x}, y {y}: farther than {MAX_POSE_M} m from the origin, where \
         the simulation's geometry is not exact; the vehicle stays"
    )]
    PoseTooFar {
        /// position.x.
        x: f64,
        /// position.y.
        y: f64,
    },
    /// The world refused the call (not a position model: a bug).
    #[error("{0}")]
    Sim(String),
}

/// The farthest a `cmd_pose` may put a vehicle from the origin (m). Far past any world (a
/// floorplan of 1000 km with 2 cm cells is a trillion cells), and near enough that a pose
/// and its sums keep centimetres in an f64 (2^53 cm is 9e13 m).
pub const MAX_POSE_M: f64 = 1e9;

/// Applies a `cmd_vel` to position model `model`: linear x and y, angular z (stage_ros2 reads
/// these three), clamped by the model's `velocity_bounds` as any command. A command with a
/// NaN or infinite component is refused: the vehicle keeps its previous command (and its
/// watchdog is not re-armed).
pub fn apply_cmd_vel(world: &mut World, model: ModelId, cmd: &Twist) -> Result<(), Refused> {
    let (vx, vy, va) = (cmd.linear.x, cmd.linear.y, cmd.angular.z);
    if ![vx, vy, va].iter().all(|x| x.is_finite()) {
        return Err(Refused::Velocity { vx, vy, va });
    }
    world
        .position_cmd_vel(model, vx, vy, va)
        .map_err(|e| Refused::Sim(e.to_string()))
}

/// Applies a `cmd_pose` to position model `model`: its position and yaw in the world frame
/// (its height kept; a model inside another is set in its parent's frame), and its stall
/// cleared, as a teleport out of a collision should. A NaN or infinite pose, or one farther
/// than [`MAX_POSE_M`], is refused and the vehicle stays.
pub fn apply_cmd_pose(world: &mut World, model: ModelId, pose: &Pose) -> Result<(), Refused> {
    let (x, y, yaw) = (pose.position.x, pose.position.y, pose.orientation.yaw());
    if ![x, y, yaw].iter().all(|v| v.is_finite()) {
        return Err(Refused::PoseNotFinite { x, y, yaw });
    }
    if x.abs() > MAX_POSE_M || y.abs() > MAX_POSE_M {
        return Err(Refused::PoseTooFar { x, y });
    }
    let sim = |e: stage_sim::Error| Refused::Sim(e.to_string());
    let current = world.pose(model).map_err(sim)?;
    let target = stage_sim::Pose::new(x, y, current.z, yaw);
    let local = match world.parent(model).map_err(sim)? {
        Some(parent) => {
            let mut l = world.global_pose(parent).map_err(sim)?.relative(&target);
            l.z = current.z;
            l
        }
        None => target,
    };
    world.set_pose(model, local).map_err(sim)?;
    world.set_stall(model, false).map_err(sim)
}

/// `reset_positions`: every vehicle back to its pose at start (in its parent's frame), its
/// stall cleared.
pub fn reset(world: &mut World, starts: impl IntoIterator<Item = (ModelId, stage_sim::Pose)>) {
    for (model, start) in starts {
        let _ = world.set_pose(model, start);
        let _ = world.set_stall(model, false);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msgs::{Header, Quaternion, Time, TwistStamped, Vector3};

    fn world() -> (World, Vec<ModelId>) {
        let text = "interval_sim 100\n\
                    position ( name \"r0\" pose [0 0 0 0] size [0.4 0.4 0.3] drive \"omni\" )\n\
                    model ( name \"box\" pose [3 3 0 0] size [1 1 1] \
                    position ( name \"r1\" pose [0 0 0 0] size [0.2 0.2 0.2] ) )\n";
        let spec = worldfile::WorldSpec::parse(
            std::path::Path::new("inbound.world"),
            text,
            &worldfile::LoadOptions::default(),
        )
        .expect("the test world parses");
        let mut world = World::from_owned_spec(spec, 1).expect("the test world builds");
        let ids: Vec<ModelId> = ["r0", "r1"]
            .iter()
            .map(|n| world.model_by_name(n).expect("named model"))
            .collect();
        // as the bridge does: subscribed position models update
        for &m in &ids {
            world.subscribe(m).unwrap();
        }
        (world, ids)
    }

    fn twist(vx: f64, vy: f64, va: f64) -> Twist {
        Twist {
            linear: Vector3 {
                x: vx,
                y: vy,
                z: 0.0,
            },
            angular: Vector3 {
                x: 0.0,
                y: 0.0,
                z: va,
            },
        }
    }

    fn pose(x: f64, y: f64, yaw: f64) -> Pose {
        Pose {
            position: Vector3 { x, y, z: 0.0 },
            orientation: Quaternion::from_yaw(yaw),
        }
    }

    fn all_finite(world: &World) -> bool {
        world.models().all(|m| {
            let g = world.global_pose(m).unwrap();
            [g.x, g.y, g.z, g.a].iter().all(|v| v.is_finite())
        })
    }

    /// A sample ros2-client's publisher writes (little-endian CDR) reads back as the same
    /// message, and a big-endian one as well.
    #[test]
    fn a_published_twist_reads_back() {
        let cmd = twist(0.5, -0.25, 1.5);
        for rep in [
            RepresentationIdentifier::CDR_LE,
            RepresentationIdentifier::CDR_BE,
        ] {
            let bytes = encode_message(&cmd, rep);
            assert_eq!(bytes.len(), 4 + 48);
            let (back, used) = decode_message::<Twist>(&bytes).unwrap();
            assert_eq!((back, used), (cmd, 48));
        }
        let stamped = TwistStamped {
            header: Header {
                stamp: Time { sec: 3, nanosec: 7 },
                frame_id: "base_link".into(),
            },
            twist: cmd,
        };
        let bytes = encode_message(&stamped, RepresentationIdentifier::CDR_LE);
        assert_eq!(decode_message::<TwistStamped>(&bytes).unwrap().0, stamped);
    }

    #[test]
    fn a_short_or_foreign_sample_is_an_error() {
        assert_eq!(decode_message::<Twist>(&[0, 1]), Err(DecodeError::Short(2)));
        let mut xcdr2 = encode_message(&twist(1.0, 0.0, 0.0), RepresentationIdentifier::CDR_LE);
        xcdr2[1] = 0x07;
        assert_eq!(
            decode_message::<Twist>(&xcdr2),
            Err(DecodeError::Representation(0, 7))
        );
        let cut = encode_message(&twist(1.0, 0.0, 0.0), RepresentationIdentifier::CDR_LE);
        assert!(matches!(
            decode_message::<Twist>(&cut[..20]),
            Err(DecodeError::Cdr(_))
        ));
    }

    /// What the fuzz target's first runs met (its re-encoding check was too strict, the
    /// reader is right): a writer may send a frame id as an empty string of length 0 (no
    /// terminator; CDR writers put a NUL, RustDDS reads both), and a terminator that is not 0.
    /// Both read; written again, the string is the canonical length 1 and NUL.
    #[test]
    fn lenient_strings_read_and_are_written_canonically() {
        let mut body = vec![0, 1, 0, 0];
        body.extend_from_slice(&[1, 0, 0, 0, 2, 0, 0, 0]); // stamp
        body.extend_from_slice(&[0, 0, 0, 0]); // frame_id: length 0
        body.extend(std::iter::repeat_n(0, 4)); // padding to 8
        body.extend((0..6).flat_map(|k| f64::from(k).to_le_bytes()));
        let (m, used) = decode_message::<TwistStamped>(&body).unwrap();
        assert_eq!((m.header.frame_id.as_str(), m.twist.angular.z), ("", 5.0));
        assert_eq!(used, body.len() - 4);
        let canonical = encode_message(&m, RepresentationIdentifier::CDR_LE);
        // after the header (4) and the stamp (8): length 1, then the NUL
        assert_eq!(&canonical[12..17], &[1, 0, 0, 0, 0]);
        assert_eq!(decode_message::<TwistStamped>(&canonical).unwrap().0, m);

        let mut odd_end = encode_message(
            &TwistStamped {
                header: Header {
                    stamp: Time::default(),
                    frame_id: "ab".into(),
                },
                twist: twist(1.0, 0.0, 0.0),
            },
            RepresentationIdentifier::CDR_LE,
        );
        odd_end[4 + 8 + 4 + 2] = b'!'; // the terminator
        let (m, _) = decode_message::<TwistStamped>(&odd_end).unwrap();
        assert_eq!(m.header.frame_id, "ab");
    }

    /// Each server reads its own mapping's request and refuses the other's.
    #[test]
    fn reset_requests_in_both_mappings() {
        let header = CycloneRequestHeader {
            client_guid_low: [1, 2, 3, 4, 5, 6, 7, 8],
            sequence_high: 0,
            sequence_low: 9,
        };
        let mut cyclone = encode_message(&header, RepresentationIdentifier::CDR_LE);
        cyclone.push(0);
        let fast = encode_message(&EmptyMessage::default(), RepresentationIdentifier::CDR_LE);
        assert_eq!(
            decode_reset_request(&cyclone, RequestMapping::Cyclone).unwrap(),
            (Some(header), EmptyMessage::default())
        );
        assert_eq!(
            decode_reset_request(&fast, RequestMapping::FastDds).unwrap(),
            (None, EmptyMessage::default())
        );
        assert!(decode_reset_request(&cyclone, RequestMapping::FastDds).is_err());
        assert!(decode_reset_request(&fast, RequestMapping::Cyclone).is_err());
    }

    /// A NaN or infinite command is refused with a message naming its values, the previous
    /// command stays, and after steps every pose is finite.
    #[test]
    fn a_command_that_is_not_finite_is_refused_and_poses_stay_finite() {
        let (mut world, ids) = world();
        let r0 = ids[0];
        apply_cmd_vel(&mut world, r0, &twist(0.3, 0.0, 0.0)).unwrap();
        for bad in [
            twist(f64::NAN, 0.0, 0.0),
            twist(0.0, f64::INFINITY, 0.0),
            twist(0.0, 0.0, f64::NEG_INFINITY),
        ] {
            let e = apply_cmd_vel(&mut world, r0, &bad).unwrap_err();
            assert!(matches!(e, Refused::Velocity { .. }), "{e}");
            assert!(
                e.to_string()
                    .starts_with("ignored a velocity command that is not finite")
            );
        }
        assert_eq!(world.position_model(r0).unwrap().goal.x, 0.3);
        for _ in 0..20 {
            world.step();
        }
        assert!(all_finite(&world));
        assert!(
            world.pose(r0).unwrap().x > 0.0,
            "the previous command drives on"
        );
    }

    /// A huge but finite speed is clamped by the model's velocity bounds (Stage's default:
    /// 1 m/s), and the vehicle stays where the world can follow it.
    #[test]
    fn a_huge_speed_is_clamped_by_the_velocity_bounds() {
        let (mut world, ids) = world();
        apply_cmd_vel(&mut world, ids[0], &twist(1e300, -f64::MAX, 1e308)).unwrap();
        for _ in 0..10 {
            world.step();
        }
        assert!(all_finite(&world));
        let v = world.position_state(ids[0]).unwrap().velocity;
        assert_eq!((v.x, v.y), (1.0, -1.0), "clamped to the bounds");
        // 1 s at no more than sqrt(2) m/s (omni drive: both axes at 1 m/s)
        let p = world.pose(ids[0]).unwrap();
        assert!(p.x.hypot(p.y) <= 2f64.sqrt() + 1e-9, "{p:?}");
    }

    #[test]
    fn a_pose_that_is_not_finite_or_too_far_is_refused() {
        let (mut world, ids) = world();
        let before = world.pose(ids[0]).unwrap();
        let mut nan_q = pose(1.0, 1.0, 0.0);
        nan_q.orientation.w = f64::NAN;
        for bad in [
            pose(f64::NAN, 0.0, 0.0),
            pose(0.0, f64::INFINITY, 0.0),
            nan_q,
        ] {
            let e = apply_cmd_pose(&mut world, ids[0], &bad).unwrap_err();
            assert!(matches!(e, Refused::PoseNotFinite { .. }), "{e}");
        }
        let e = apply_cmd_pose(&mut world, ids[0], &pose(2e9, 0.0, 0.0)).unwrap_err();
        assert!(matches!(e, Refused::PoseTooFar { .. }), "{e}");
        assert_eq!(world.pose(ids[0]).unwrap(), before);
        world.step();
        assert!(all_finite(&world));
    }

    /// A teleport is in the world frame, also for a vehicle inside another model; a reset puts
    /// it back.
    #[test]
    fn teleport_and_reset() {
        let (mut world, ids) = world();
        let start = world.pose(ids[1]).unwrap();
        apply_cmd_pose(&mut world, ids[1], &pose(-2.0, 1.0, 0.5)).unwrap();
        world.step();
        let g = world.global_pose(ids[1]).unwrap();
        assert!(
            (g.x + 2.0).abs() < 1e-9 && (g.y - 1.0).abs() < 1e-9,
            "{g:?}"
        );
        assert!((g.a - 0.5).abs() < 1e-9);
        apply_cmd_pose(&mut world, ids[0], &pose(MAX_POSE_M, -MAX_POSE_M, 0.0)).unwrap();
        world.step();
        assert!(all_finite(&world));
        reset(&mut world, [(ids[1], start)]);
        assert_eq!(world.pose(ids[1]).unwrap(), start);
    }
}
