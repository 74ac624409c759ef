//! The `blobfinder` interface (7).

xdr_struct! {
    /// One detected blob (40 bytes on the wire).
    pub struct BlobfinderBlob = "player_blobfinder_blob_t" {
        /// Blob id.
        id: u32,
        /// Colour as packed 0x00RRGGBB.
        color: u32,
        /// Area in pixels (Stage sends a wrapped negative number).
        area: u32,
        /// Centroid x (pixels).
        x: u32,
        /// Centroid y (pixels).
        y: u32,
        /// Bounding box left.
        left: u32,
        /// Bounding box right.
        right: u32,
        /// Bounding box top.
        top: u32,
        /// Bounding box bottom.
        bottom: u32,
        /// Range (m).
        range: f32,
    }

    /// Detected blobs (DATA BLOBS).
    pub struct BlobfinderDataBlobs = "player_blobfinder_data_t" {
        /// Image width (pixels).
        width: u32,
        /// Image height (pixels).
        height: u32,
        /// The blobs.
        blobs: Vec<BlobfinderBlob>,
    }

    /// Colour tracking range.
    pub struct BlobfinderColorConfig = "player_blobfinder_color_config_t" {
        /// Channel.
        channel: u32,
        /// Red minimum.
        rmin: u32,
        /// Red maximum.
        rmax: u32,
        /// Green minimum.
        gmin: u32,
        /// Green maximum.
        gmax: u32,
        /// Blue minimum.
        bmin: u32,
        /// Blue maximum.
        bmax: u32,
    }

    /// Imager parameters; -1 leaves a value unchanged.
    pub struct BlobfinderImagerConfig = "player_blobfinder_imager_config_t" {
        /// Brightness 0-255.
        brightness: i32,
        /// Contrast 0-255.
        contrast: i32,
        /// Colour mode.
        colormode: i32,
        /// Auto gain on/off.
        autogain: i32,
    }
}
