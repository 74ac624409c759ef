//! `blobfinder` on a Stage `blobfinder` (player-protocol.md §6.3, stage-models.md §9.3): data
//! only, Stage answers no blobfinder request.

use player_proto::{BlobfinderBlob, BlobfinderData, BlobfinderDataBlobs};
use stage_sim::World;

use super::{Bound, Interface, Out, convert};

/// A `blobfinder` device.
#[derive(Debug, Default)]
pub(super) struct Blobfinder;

impl Interface for Blobfinder {
    /// DATA BLOBS, also when nothing is seen: per blob its colour, area, centre, box and range.
    fn publish(&mut self, b: &Bound<'_, &World>, out: &mut Out<'_, '_>) -> Option<()> {
        let data = out.new_sample(b.answer(b.world.blobfinder_blobs(b.model)), |s| s.time_us)?;
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
        Some(())
    }
}
