//! The `camera` interface on a Stage `camera` model: the simulator's ray-cast colour image as
//! raw RGB888 (player-protocol.md §6.7). Stage 4.1.1's plugin had this commented out.

use std::ops::Deref;

use player_proto::constants::{PLAYER_CAMERA_COMPRESS_RAW, PLAYER_CAMERA_FORMAT_RGB888};
use player_proto::{CameraData, CameraDataState};
use stage_sim::World;

use super::{Bound, Out};

/// DATA STATE: the latest image, alpha dropped (the sky, transparent in the simulator, is
/// black).
pub(super) fn publish<W: Deref<Target = World>>(b: &Bound<'_, W>, out: &mut Out<'_, '_>) {
    let Some(img) = b.answer(b.world.camera_image(b.model)) else {
        return;
    };
    if img.width == 0 || img.height == 0 {
        return;
    }
    let image = img
        .rgba
        .chunks_exact(4)
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect();
    out.publish(CameraData::State(CameraDataState {
        width: img.width,
        height: img.height,
        bpp: 24,
        format: PLAYER_CAMERA_FORMAT_RGB888,
        fdiv: 1,
        compression: PLAYER_CAMERA_COMPRESS_RAW,
        image,
    }));
}
