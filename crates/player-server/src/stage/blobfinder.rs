//! `blobfinder` on a Stage `blobfinder` (player-protocol.md §6.3, stage-models.md §9.3): data
//! only, Stage answers no blobfinder request.

use player_proto::{BlobfinderBlob, BlobfinderData, BlobfinderDataBlobs, InterfaceCode};
use stage_sim::{ModelId, World};
use worldfile::ModelType;

use super::{Bound, Interface, Out, RangerShape, StageBinding, convert};

/// A `blobfinder` device.
#[derive(Debug, Default)]
pub(super) struct Blobfinder;

impl Interface for Blobfinder {
    fn code(&self) -> InterfaceCode {
        InterfaceCode::BLOBFINDER
    }

    fn binding(&self) -> StageBinding {
        StageBinding::Model(ModelType::Blobfinder, RangerShape::Any)
    }

    fn sample_time(&self, world: &World, model: ModelId) -> Option<u64> {
        world.blobfinder_blobs(model).map(|s| s.time_us)
    }

    /// DATA BLOBS, also when nothing is seen: per blob its colour, area, centre, box and range.
    fn publish(&mut self, b: &Bound<'_, &World>, out: &mut Out<'_, '_>) {
        let Some(data) = b.world.blobfinder_blobs(b.model) else {
            return;
        };
        // Stage fills in the image size only when there is a blob (spec §9.3).
        let (width, height) = if data.blobs.is_empty() {
            (0, 0)
        } else {
            (data.width, data.height)
        };
        let blobs = data
            .blobs
            .iter()
            .map(|blob| BlobfinderBlob {
                id: 0,
                color: blob.color.packed_rgb(),
                area: convert::blob_area(blob),
                x: convert::blob_x(blob),
                y: convert::blob_y(blob),
                left: blob.left,
                right: blob.right,
                top: blob.top,
                bottom: blob.bottom,
                range: blob.range as f32,
            })
            .collect();
        out.publish(BlobfinderData::Blobs(BlobfinderDataBlobs {
            width,
            height,
            blobs,
        }));
    }
}
