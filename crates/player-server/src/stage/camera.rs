//! The `camera` interface on a Stage `camera` model: the simulator's ray-cast colour image as
//! raw RGB888 (player-protocol.md §6.7). Stage 4.1.1's plugin had this commented out.

use player_proto::constants::{PLAYER_CAMERA_COMPRESS_RAW, PLAYER_CAMERA_FORMAT_RGB888};
use player_proto::{CameraData, CameraDataState};
use stage_sim::World;

use super::{Bound, Interface, Out};

/// A `camera` device.
#[derive(Debug, Default)]
pub(super) struct Camera;

impl Interface for Camera {
    /// DATA STATE: the latest image, alpha dropped (the sky, transparent in the simulator, is
    /// black).
    fn publish(&mut self, b: &Bound<'_, &World>, out: &mut Out<'_, '_>) -> Option<()> {
        let img = out.new_sample(b.answer(b.world.camera_image(b.model)), |s| s.time_us)?;
        if img.width == 0 || img.height == 0 {
            return None;
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
        Some(())
    }
}
