//! The viewer's error type.

/// What can go wrong opening or running a viewer window or an offscreen renderer.
#[derive(Debug, thiserror::Error)]
pub enum ViewerError {
    /// No display to open a window on (`DISPLAY` / `WAYLAND_DISPLAY` unset).
    #[error("no display: neither DISPLAY nor WAYLAND_DISPLAY is set")]
    NoDisplay,
    /// wgpu found no adapter (no GPU driver and no software Vulkan/GL).
    #[error("no graphics adapter found (install a GPU driver or Mesa's software Vulkan)")]
    NoAdapter,
    /// A GPU operation failed.
    #[error("graphics: {0}")]
    Gpu(String),
    /// The window system or eframe failed.
    #[error("window: {0}")]
    Window(String),
    /// Talking to the Player server failed.
    #[error("player client: {0}")]
    Client(#[from] player_client::ClientError),
    /// A file could not be written (screenshots).
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The I/O error.
        source: std::io::Error,
    },
}
