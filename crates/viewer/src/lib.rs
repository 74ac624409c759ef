//! The Stage world window and the playerv client viewer: egui for menus and panels, wgpu for
//! the world drawing.
//!
//! * [`scene`] — plain primitives in world coordinates (fills, pixel-wide segments, images,
//!   labels) by layer; [`world_scene`] builds one from a `stage_sim::World`,
//!   [`playerv::scene`] from a playerv client state. Pure and unit-tested.
//! * [`render`] — draws a scene with wgpu in a few batched, instanced draw calls per layer, into
//!   the eframe window ([`canvas`]) or an offscreen texture ([`offscreen`]).
//! * [`world_window`] — the Stage window: [`world_window::run`] with a [`WorldHandle`] the
//!   simulation owner shares (the `stage` binary now, the `player` server's core later).
//! * [`scene_window`] — a window showing scenes its caller builds and hands over, for a caller
//!   that steps its world itself (a Gymnasium environment's `"human"` render mode).
//! * [`playerv`] — the playerv client: [`playerv::run`].
//!
//! Everything renders with no GPU through Mesa's software Vulkan (llvmpipe/lavapipe).
//!
//! Frame budget (a software rasteriser pays per triangle and per blended pixel, so the scene
//! carries only what shows): ranger fans are thinned to half a pixel ([`lod`]), off-screen
//! sensors and bodies are skipped, bodies under two pixels are one dot, the static models'
//! primitives are kept between frames while they and the view are unchanged, the renderer
//! draws the grid and static layers into a cached texture, and colours are converted per vertex,
//! not per pixel. `cargo bench -p viewer --bench frame` measured on llvmpipe, 2 cores (2026-11-25):
//! Stage's `hospital.world` (1,000 robots, 12,000 IR footprints shown) whole world 1280×720
//! 9.0 ms per frame (111 fps), in its worldfile window view 10.4 ms at the start and 14.7 ms once
//! the swarm has spread (68 fps); 1,000 robots with 8 m 180-ray lasers and footprints 183 ms,
//! bound by blending ~44 M overlapping translucent footprint pixels per frame, which a GPU does
//! in milliseconds.

#![warn(missing_docs)]

pub mod canvas;
pub mod coverage;
pub mod error;
pub mod handle;
pub mod lod;
pub mod offscreen;
pub mod playerv;
pub mod render;
pub mod scene;
pub mod scene_window;
mod triangulate;
pub mod view;
pub mod world_scene;
pub mod world_window;

pub use error::ViewerError;
pub use handle::{WindowSetup, WorldCommand, WorldHandle};
pub use offscreen::{Offscreen, Pixels};
pub use render::SceneRenderer;
pub use scene::{Layer, Rgba8, Scene};
pub use view::View;
