//! The `camera` interface (40).

xdr_struct! {
    /// One image (DATA STATE).
    pub struct CameraDataState = "player_camera_data_t" {
        /// Width (pixels).
        width: u32,
        /// Height (pixels).
        height: u32,
        /// Bits per pixel.
        bpp: u32,
        /// `PLAYER_CAMERA_FORMAT_*`.
        format: u32,
        /// Frame divisor.
        fdiv: u32,
        /// `PLAYER_CAMERA_COMPRESS_*`.
        compression: u32,
        /// Pixels (raw: width × height × bpp / 8 bytes), byte-packed.
        image: Vec<u8>,
    }
}
