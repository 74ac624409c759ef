//! The ROS 2 bridge's inbound messages: `cmd_vel` (Twist and TwistStamped), `cmd_pose` (Pose)
//! and `reset_positions` requests in both service mappings (Cyclone's and Fast DDS's), read
//! from a sample's bytes as the node's subscriptions and servers read them
//! (`ros2_bridge::inbound`'s decoders over RustDDS's CDR deserialiser), then applied to a
//! small world as the bridge applies them, the world stepped after each.
//!
//! The input is a sequence of records: a kind byte (its value mod 5: Twist, TwistStamped,
//! Pose, Cyclone request, Fast DDS request), a vehicle byte (mod the world's 3 vehicles), a
//! little-endian u16 length and that many bytes of sample (encapsulation header and CDR).
//!
//! Checks beyond "no panic":
//! - a message that decodes re-encodes (in its own representation) to the bytes it was read
//!   from, except where CDR lets writers differ: alignment padding and a string's terminator
//!   (read whatever they are, written as 0) and trailing bytes past the message; a
//!   TwistStamped whose frame is an empty string sent as length 0 (no terminator) shifts the
//!   rest and is only held to the next check; and the re-encoding is a fixed point (decoded
//!   and encoded again: the same bytes, so the same values, bit for bit);
//! - a command the bridge refuses leaves the world as it was; every model's global pose and
//!   every vehicle's odometry and velocity stay finite after every step, whatever the commands
//!   (NaN, infinities, huge speeds and poses).

#![no_main]

use libfuzzer_sys::fuzz_target;
use ros2_bridge::inbound::{
    self, RequestMapping, apply_cmd_pose, apply_cmd_vel, decode_message, decode_reset_request,
    encode_message, representation_of,
};
use ros2_bridge::msgs::{Pose, RosType, Twist, TwistStamped};
use stage_sim::{ModelId, World};

/// Three vehicles: one free, one with huge velocity bounds (so huge speeds are not clamped
/// away), one inside another model (its teleports go through the parent's frame); walls.
const WORLD: &str = "interval_sim 100\n\
    resolution 0.02\n\
    model ( name \"wall\" pose [0 4 0 0] size [8 0.2 0.5] )\n\
    position ( name \"r0\" pose [0 0 0 0] size [0.4 0.4 0.3] drive \"omni\" \
      ranger ( sensor ( range [0 8] fov 180 samples 9 ) ) )\n\
    position ( name \"r1\" pose [2 0 0 0] size [0.4 0.4 0.3] \
      velocity_bounds [-1e30 1e30 -1e30 1e30 -1 1 -1e30 1e30] )\n\
    model ( name \"base\" pose [-2 -2 0 0.5] size [1 1 0.5] \
      position ( name \"r2\" pose [0 0 0 0] size [0.3 0.3 0.2] ) )\n";

fn world() -> (World, Vec<ModelId>) {
    let spec = worldfile::WorldSpec::parse(
        std::path::Path::new("ros2_inbound.world"),
        WORLD,
        &worldfile::LoadOptions::default(),
    )
    .expect("the target's world parses");
    let mut world = World::from_owned_spec(spec, 1).expect("the target's world builds");
    let ids: Vec<ModelId> = ["r0", "r1", "r2"]
        .iter()
        .map(|n| world.model_by_name(n).expect("a vehicle"))
        .collect();
    for &m in &ids {
        world.subscribe(m).expect("a model");
    }
    (world, ids)
}

/// The re-encoding property of one decoded message (see the module's docs).
fn check_reencoding<T: RosType>(sample: &[u8], message: &T, used: usize, empty_string: bool) {
    let rep = representation_of(sample).expect("a sample that decoded has a representation");
    let again = encode_message(message, rep);
    let (second, _) = decode_message::<T>(&again)
        .unwrap_or_else(|e| panic!("a re-encoded {} does not decode: {e}", T::NAME));
    assert_eq!(
        encode_message(&second, rep),
        again,
        "{}: the re-encoding is not a fixed point",
        T::NAME
    );
    if empty_string {
        // a string sent as length 0 (no terminator) reads as "" and is written as length 1
        // and a NUL: the rest of the body shifts, so only the fixed point above is checked
        return;
    }
    // the header's representation options are ignored by readers; compare from the body on
    let read = &sample[4..4 + used];
    let written = &again[4..];
    assert_eq!(
        read.len(),
        written.len(),
        "{}: {} bytes read, {} written",
        T::NAME,
        read.len(),
        written.len()
    );
    for (i, (r, w)) in read.iter().zip(written).enumerate() {
        assert!(
            r == w || *w == 0,
            "{}: byte {i} of the body read {r:#04x} and re-encodes as {w:#04x}",
            T::NAME
        );
    }
}

fn finite(values: &[f64]) -> bool {
    values.iter().all(|v| v.is_finite())
}

fn check_world(world: &World, ids: &[ModelId], after: &str) {
    for m in world.models() {
        let g = world.global_pose(m).expect("a model");
        assert!(
            finite(&[g.x, g.y, g.z, g.a]),
            "model {m:?}'s pose {g:?} is not finite after {after}"
        );
    }
    for &v in ids {
        let s = world.position_state(v).expect("a vehicle");
        assert!(
            finite(&[
                s.pose.x,
                s.pose.y,
                s.pose.a,
                s.velocity.x,
                s.velocity.y,
                s.velocity.a
            ]),
            "vehicle {v:?}'s odometry {:?} is not finite after {after}",
            s
        );
    }
}

fuzz_target!(|data: &[u8]| {
    let (mut world, ids) = world();
    let starts: Vec<_> = ids.iter().map(|&m| (m, world.pose(m).unwrap())).collect();
    let mut rest = data;
    let mut records = 0;
    while rest.len() >= 4 && records < 32 {
        records += 1;
        let kind = rest[0] % 5;
        let vehicle = ids[usize::from(rest[1]) % ids.len()];
        let len = usize::from(u16::from_le_bytes([rest[2], rest[3]])).min(rest.len() - 4);
        let sample = &rest[4..4 + len];
        rest = &rest[4 + len..];
        let before: Vec<_> = world
            .models()
            .map(|m| world.global_pose(m).unwrap())
            .collect();
        let refused = match kind {
            0 => decode_message::<Twist>(sample).ok().map(|(m, used)| {
                check_reencoding(sample, &m, used, false);
                apply_cmd_vel(&mut world, vehicle, &m).is_err()
            }),
            1 => decode_message::<TwistStamped>(sample)
                .ok()
                .map(|(m, used)| {
                    check_reencoding(sample, &m, used, m.header.frame_id.is_empty());
                    apply_cmd_vel(&mut world, vehicle, &m.twist).is_err()
                }),
            2 => decode_message::<Pose>(sample).ok().map(|(m, used)| {
                check_reencoding(sample, &m, used, false);
                apply_cmd_pose(&mut world, vehicle, &m).is_err()
            }),
            k => {
                let mapping = if k == 3 {
                    RequestMapping::Cyclone
                } else {
                    RequestMapping::FastDds
                };
                decode_reset_request(sample, mapping).ok().map(|_| {
                    inbound::reset(&mut world, starts.iter().copied());
                    false
                })
            }
        };
        if refused == Some(true) {
            let after: Vec<_> = world
                .models()
                .map(|m| world.global_pose(m).unwrap())
                .collect();
            assert_eq!(before, after, "a refused command changed the world");
        }
        check_world(&world, &ids, "a command");
        world.step();
        check_world(&world, &ids, "a step");
    }
});
