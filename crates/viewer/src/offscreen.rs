//! Rendering without a window: a wgpu device of its own (any adapter, Mesa's software Vulkan
//! included), a colour texture of the view's size, and pixel read-back. Used by the headless
//! render tests, the screenshots and the frame benchmark.

use std::sync::mpsc;

use crate::error::ViewerError;
use crate::render::SceneRenderer;
use crate::scene::Scene;
use crate::view::View;

/// Format of offscreen targets: plain 8-bit RGBA, so read-back pixels are the scene's colours.
pub const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

/// An RGBA image read back from the GPU, rows from the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Pixels {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height * 4` bytes.
    pub rgba: Vec<u8>,
}

impl Pixels {
    /// The pixel at column `x`, row `y` (`None` outside).
    pub fn get(&self, x: i64, y: i64) -> Option<[u8; 4]> {
        if x < 0 || y < 0 || x >= self.width as i64 || y >= self.height as i64 {
            return None;
        }
        let i = ((y as usize) * self.width as usize + x as usize) * 4;
        Some([
            self.rgba[i],
            self.rgba[i + 1],
            self.rgba[i + 2],
            self.rgba[i + 3],
        ])
    }
}

/// A headless wgpu device with a scene renderer for targets of one format ([`FORMAT`] unless
/// opened with [`Offscreen::with_format`]).
pub struct Offscreen {
    format: wgpu::TextureFormat,
    device: wgpu::Device,
    queue: wgpu::Queue,
    renderer: SceneRenderer,
    info: wgpu::AdapterInfo,
    target: Option<Target>,
}

struct Target {
    size: [u32; 2],
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    readback: wgpu::Buffer,
    padded_row: u32,
}

impl Offscreen {
    /// Opens the first adapter wgpu finds (Vulkan or GL; a software one such as llvmpipe when
    /// there is no GPU). [`ViewerError::NoAdapter`] when there is none at all.
    pub fn new() -> Result<Offscreen, ViewerError> {
        Self::with_format(FORMAT)
    }

    /// [`Offscreen::new`] drawing into targets of `format`, an 8-bit RGBA one (e.g. the `Srgb`
    /// variant a window surface may have, to check that colours come out the same there).
    pub fn with_format(format: wgpu::TextureFormat) -> Result<Offscreen, ViewerError> {
        pollster::block_on(Self::open(format))
    }

    async fn open(format: wgpu::TextureFormat) -> Result<Offscreen, ViewerError> {
        // Vulkan first (GPU drivers, or Mesa's lavapipe); GL only when there is no Vulkan
        // adapter, which spares the EGL probing noise where Vulkan works
        let from_env = std::env::var_os("WGPU_BACKEND").is_some();
        let tries: &[wgpu::Backends] = if from_env {
            &[wgpu::Backends::all()]
        } else {
            &[wgpu::Backends::VULKAN, wgpu::Backends::GL]
        };
        let mut adapter = None;
        'search: for &backends in tries {
            let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
            if !from_env {
                desc.backends = backends;
            }
            let instance = wgpu::Instance::new(desc);
            for fallback in [false, true] {
                let opts = wgpu::RequestAdapterOptions {
                    power_preference: wgpu::PowerPreference::HighPerformance,
                    force_fallback_adapter: fallback,
                    compatible_surface: None,
                    apply_limit_buckets: false,
                };
                if let Ok(a) = instance.request_adapter(&opts).await {
                    adapter = Some(a);
                    break 'search;
                }
            }
        }
        let adapter = adapter.ok_or(ViewerError::NoAdapter)?;
        let info = adapter.get_info();
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("playerstage offscreen"),
                required_features: wgpu::Features::empty(),
                required_limits: wgpu::Limits::downlevel_defaults()
                    .using_resolution(adapter.limits()),
                ..Default::default()
            })
            .await
            .map_err(|e| ViewerError::Gpu(format!("requesting a device: {e}")))?;
        let mut renderer = SceneRenderer::new(&device, format, 1);
        renderer.set_fan_coverage(crate::render::fan_coverage_for(info.device_type));
        Ok(Offscreen {
            format,
            device,
            queue,
            renderer,
            info,
            target: None,
        })
    }

    /// The scene renderer (e.g. to turn its layer cache off for a comparison).
    pub fn renderer_mut(&mut self) -> &mut SceneRenderer {
        &mut self.renderer
    }

    /// The adapter in use (name, backend, device type).
    pub fn adapter_info(&self) -> &wgpu::AdapterInfo {
        &self.info
    }

    fn target(&mut self, size: [u32; 2]) -> &Target {
        if self.target.as_ref().is_none_or(|t| t.size != size) {
            let extent = wgpu::Extent3d {
                width: size[0],
                height: size[1],
                depth_or_array_layers: 1,
            };
            let texture = self.device.create_texture(&wgpu::TextureDescriptor {
                label: Some("offscreen target"),
                size: extent,
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: self.format,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
                view_formats: &[],
            });
            let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
            let padded_row = (size[0] * 4).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT)
                * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
            let readback = self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("offscreen readback"),
                size: padded_row as u64 * size[1] as u64,
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                mapped_at_creation: false,
            });
            self.target = Some(Target {
                size,
                texture,
                view,
                readback,
                padded_row,
            });
        }
        self.target.as_ref().expect("target just created")
    }

    fn size_of(view: &View) -> Result<[u32; 2], ViewerError> {
        let (w, h) = (view.size[0].round(), view.size[1].round());
        if !(1.0..=8192.0).contains(&w) || !(1.0..=8192.0).contains(&h) {
            return Err(ViewerError::Gpu(format!(
                "offscreen size {w}x{h} is outside 1..=8192"
            )));
        }
        Ok([w as u32, h as u32])
    }

    /// Renders and submits without reading back; returns once the GPU has finished (the
    /// benchmark's "render" figure).
    pub fn render_only(&mut self, scene: &Scene, view: &View) -> Result<(), ViewerError> {
        self.encode(scene, view, false)?;
        self.wait()
    }

    /// Renders `scene` through `view` into a texture of `view.size` pixels and reads it back.
    pub fn render(&mut self, scene: &Scene, view: &View) -> Result<Pixels, ViewerError> {
        self.encode(scene, view, true)?;
        let (size, padded_row) = {
            let t = self.target.as_ref().expect("encode made the target");
            (t.size, t.padded_row)
        };
        let (tx, rx) = mpsc::channel();
        let t = self.target.as_ref().expect("encode made the target");
        t.readback
            .slice(..)
            .map_async(wgpu::MapMode::Read, move |r| {
                let _ = tx.send(r);
            });
        self.wait()?;
        rx.recv()
            .map_err(|_| ViewerError::Gpu("read-back callback dropped".into()))?
            .map_err(|e| ViewerError::Gpu(format!("mapping the read-back buffer: {e}")))?;
        let mut rgba = Vec::with_capacity((size[0] * size[1] * 4) as usize);
        {
            let data = t
                .readback
                .slice(..)
                .get_mapped_range()
                .map_err(|e| ViewerError::Gpu(format!("reading the mapped buffer: {e}")))?;
            for row in 0..size[1] as usize {
                let start = row * padded_row as usize;
                rgba.extend_from_slice(&data[start..start + size[0] as usize * 4]);
            }
        }
        t.readback.unmap();
        Ok(Pixels {
            width: size[0],
            height: size[1],
            rgba,
        })
    }

    fn encode(&mut self, scene: &Scene, view: &View, copy: bool) -> Result<(), ViewerError> {
        let size = Self::size_of(view)?;
        self.target(size);
        let mut v = *view;
        v.size = [size[0] as f64, size[1] as f64];
        let mut enc = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("offscreen frame"),
            });
        self.renderer
            .prepare(&self.device, &self.queue, &mut enc, scene, &v);
        let t = self.target.as_ref().expect("target made above");
        {
            let bg = scene.background.0;
            let linear = self.format.is_srgb();
            let mut pass =
                crate::render::cleared_pass(&mut enc, &t.view, bg, linear, "offscreen scene");
            self.renderer.paint(&mut pass);
        }
        if copy {
            enc.copy_texture_to_buffer(
                wgpu::TexelCopyTextureInfo {
                    texture: &t.texture,
                    mip_level: 0,
                    origin: wgpu::Origin3d::ZERO,
                    aspect: wgpu::TextureAspect::All,
                },
                wgpu::TexelCopyBufferInfo {
                    buffer: &t.readback,
                    layout: wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(t.padded_row),
                        rows_per_image: Some(size[1]),
                    },
                },
                wgpu::Extent3d {
                    width: size[0],
                    height: size[1],
                    depth_or_array_layers: 1,
                },
            );
        }
        self.queue.submit([enc.finish()]);
        Ok(())
    }

    fn wait(&self) -> Result<(), ViewerError> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map(|_| ())
            .map_err(|e| ViewerError::Gpu(format!("waiting for the GPU: {e}")))
    }
}

/// Opens an offscreen renderer for a test: `None` (with a printed note) when there is no
/// adapter, unless `PLAYERSTAGE_REQUIRE_GPU=1`, which makes a missing adapter a failure (CI
/// installs Mesa's software Vulkan and sets it).
pub fn for_tests() -> Option<Offscreen> {
    for_tests_with_format(FORMAT)
}

/// [`for_tests`] with targets of `format`.
pub fn for_tests_with_format(format: wgpu::TextureFormat) -> Option<Offscreen> {
    match Offscreen::with_format(format) {
        Ok(o) => Some(o),
        Err(e) => {
            if std::env::var("PLAYERSTAGE_REQUIRE_GPU").as_deref() == Ok("1") {
                panic!("PLAYERSTAGE_REQUIRE_GPU=1 but no wgpu adapter could be opened: {e}");
            }
            eprintln!(
                "skipping: no wgpu adapter ({e}); install Mesa's Vulkan driver \
                 (mesa-vulkan-drivers) to run the render tests"
            );
            None
        }
    }
}
