//! Draws a [`Scene`] with wgpu into any colour target: the eframe window (through an
//! `egui_wgpu` paint callback, see [`crate::canvas`]) or an offscreen texture
//! ([`crate::offscreen`]).
//!
//! Three pipelines, all batched: filled triangles from one vertex buffer, segments as one
//! instanced quad each (expanded to their pixel width in the vertex shader, so 180,000 laser
//! rays are one draw call and no CPU tessellation), and textured quads for images (and two
//! full-view quads: the layer cache and counted fans, below). Every frame
//! the scene's layers are uploaded into buffers that grow as needed and are reused; drawing is
//! then a handful of calls per layer, back to front.
//!
//! The bottom layers (floor, grid and the bodies that never move: [`CACHED_LAYERS`]) are drawn
//! into a texture of the target's size and copied in with one quad while their content, the
//! view and the background stay the same (compared by a hash of the uploaded bytes, so any
//! change — a static model moved, a colour, the zoom — redraws them). A large bitmap map is
//! tens of thousands of triangles that a software rasteriser would otherwise pay every frame.
//!
//! Fans (ranger footprints) are drawn as triangle fans, except on a software rasteriser when a
//! layer's fans cover the view [`COVERAGE_MIN_FILL`] times or more: there the fans of a layer
//! above the cached ones are counted per pixel on the CPU, colour by colour
//! ([`crate::coverage`]), each count is turned into the alpha that many blends of that colour
//! reach, and one full-view pass composites them: the colour that blending the fans one by
//! one gives (up to the 8-bit rounding of each blend) at a fraction of the cost. 1,000 lasers
//! and 12,000 sonar cones seen whole are 85,000 triangles covering the view 30 times over:
//! 160 ms a frame blended on llvmpipe with two cores, 6 ms counted. Either way a layer's fans are
//! drawn colour after colour ([`LayerData::fan_triangles`]), so both give the same picture.

use std::ops::Range;

use std::hash::{DefaultHasher, Hasher};

use crate::coverage::{self, Coverage, PixelMap};
use crate::scene::{FillVertex, LAYERS, Layer, LayerData, Rgba8, Scene, Segment};
use crate::view::View;

#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
struct Globals {
    m: [[f32; 4]; 3],
    viewport: [f32; 2],
    linear_target: u32,
    _pad: u32,
}

#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
struct ImageVertex {
    pos: [f32; 2],
    uv: [f32; 2],
}

/// A buffer that grows (to the next power of two) and is otherwise reused.
struct GrowBuffer {
    buf: wgpu::Buffer,
    cap: u64,
    usage: wgpu::BufferUsages,
    label: &'static str,
}

impl GrowBuffer {
    fn new(device: &wgpu::Device, label: &'static str, usage: wgpu::BufferUsages) -> GrowBuffer {
        let cap = 64 * 1024;
        GrowBuffer {
            buf: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: cap,
                usage: usage | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            cap,
            usage,
            label,
        }
    }

    /// Writes `bytes[from..]` at the same offset (all of it when the buffer has to grow, which
    /// loses the old contents); `from` must be a multiple of 4.
    fn upload_from(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        bytes: &[u8],
        from: usize,
    ) {
        let need = bytes.len() as u64;
        let mut from = from.min(bytes.len());
        if need > self.cap {
            from = 0;
            self.cap = need.next_power_of_two();
            self.buf = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(self.label),
                size: self.cap,
                usage: self.usage | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
        }
        if from < bytes.len() {
            queue.write_buffer(&self.buf, from as u64, &bytes[from..]);
        }
    }
}

struct GpuImage {
    bind: wgpu::BindGroup,
    verts: wgpu::Buffer,
}

/// Whether a renderer on an adapter of `kind` counts fan coverage on the CPU
/// ([`SceneRenderer::set_fan_coverage`]): on a CPU rasteriser (llvmpipe, lavapipe, WARP), where
/// blending 30 screens of fans costs over 100 ms a frame; a GPU blends them in well under one.
pub fn fan_coverage_for(kind: wgpu::DeviceType) -> bool {
    kind == wgpu::DeviceType::Cpu
}

/// Fans covering less than this many views' worth of pixels are blended as triangles even
/// where coverage counting is on: the count's full-view composite costs a software rasteriser
/// about as much as blending two views of triangles (Stage's 1,000-robot hospital, whose sonar
/// cones cover under one view, draws in 8 ms as triangles and 11 ms counted).
pub const COVERAGE_MIN_FILL: f64 = 2.0;

/// The parameters of one coverage composite, as the shader reads them.
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
struct CoverageParams {
    colors: [[f32; 4]; coverage::MAX_GROUPS],
    size: [f32; 2],
    _pad: [f32; 2],
}

/// The per-pixel alphas of one layer's fans, a channel per colour, and what composites them.
struct CoverageTarget {
    size: [u32; 2],
    channels: usize,
    texture: wgpu::Texture,
    params: wgpu::Buffer,
    bind: wgpu::BindGroup,
}

impl CoverageTarget {
    /// A target for `size` pixels of `channels` alphas (1, 2 or 4) and its colours.
    fn new(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        size: [u32; 2],
        channels: usize,
    ) -> CoverageTarget {
        let format = match channels {
            1 => wgpu::TextureFormat::R8Unorm,
            2 => wgpu::TextureFormat::Rg8Unorm,
            _ => wgpu::TextureFormat::Rgba8Unorm,
        };
        let usage = wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST;
        let texture = texture_2d(device, "scene fan coverage", size, format, usage);
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("scene fan coverage colours"),
            size: std::mem::size_of::<CoverageParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("scene fan coverage"),
            layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&view),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: params.as_entire_binding(),
                },
            ],
        });
        CoverageTarget {
            size,
            channels,
            texture,
            params,
            bind,
        }
    }
}

/// The draw ranges of one layer.
#[derive(Clone, Default)]
struct LayerDraw {
    fills: Range<u32>,
    /// The layer's coverage composite, if its fans are counted.
    coverage: Option<usize>,
    segments: Range<u32>,
    images: Range<usize>,
}

/// Layers `0..CACHED_LAYERS` (grid and static bodies) are drawn once into a texture and reused
/// while they are unchanged.
pub const CACHED_LAYERS: usize = Layer::Static as usize + 1;

/// The drawing of the cached layers, texel for pixel.
struct LayerCache {
    /// What the drawing was made from (`None` until one is made): compared exactly, byte for
    /// byte, each frame; cheaper than hashing megabytes of floorplan vertices.
    source: Option<CacheSource>,
    size: [u32; 2],
    view: wgpu::TextureView,
    bind: wgpu::BindGroup,
}

/// Everything a drawing of the cached layers depends on.
struct CacheSource {
    globals: [u8; std::mem::size_of::<Globals>()],
    background: [u8; 4],
    fills: Vec<FillVertex>,
    segments: Vec<Segment>,
    /// Hash of the cached layers' images (rare; hashed rather than copied).
    images: u64,
}

/// Pipelines and per-frame buffers for drawing scenes into targets of one format and sample
/// count. Create one per target kind; call [`SceneRenderer::prepare`] then
/// [`SceneRenderer::paint`] each frame.
pub struct SceneRenderer {
    fill_pipeline: wgpu::RenderPipeline,
    /// The coverage composites for 1, 2 and 4 channels.
    coverage_pipelines: [wgpu::RenderPipeline; 3],
    coverage_layout: wgpu::BindGroupLayout,
    coverage_targets: Vec<CoverageTarget>,
    fan_coverage: bool,
    counter: Coverage,
    alphas: Vec<u8>,
    count_time: std::time::Duration,
    // threads to count on, found once: asking the system reads cgroup files on Linux
    count_threads: usize,
    segment_pipeline: wgpu::RenderPipeline,
    image_pipeline: wgpu::RenderPipeline,
    blit_pipeline: wgpu::RenderPipeline,
    format: wgpu::TextureFormat,
    cache: Option<LayerCache>,
    // whether the layer cache may be used (single-sample, non-sRGB targets), and whether the
    // last prepared frame paints from it
    cache_allowed: bool,
    cache_enabled: bool,
    cache_in_use: bool,
    cache_hits: u64,
    blit_sampler: wgpu::Sampler,
    globals: wgpu::Buffer,
    globals_bind: wgpu::BindGroup,
    image_layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    fills: GrowBuffer,
    segments: GrowBuffer,
    images: Vec<GpuImage>,
    draws: Vec<LayerDraw>,
    linear_target: bool,
    // staging, kept to avoid per-frame allocation
    fill_bytes: Vec<FillVertex>,
    segment_bytes: Vec<Segment>,
}

impl SceneRenderer {
    /// Builds the pipelines for targets of `format` with `samples` samples per pixel.
    pub fn new(device: &wgpu::Device, format: wgpu::TextureFormat, samples: u32) -> SceneRenderer {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("scene shaders"),
            source: wgpu::ShaderSource::Wgsl(include_str!("shaders.wgsl").into()),
        });
        let globals = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("scene globals"),
            size: std::mem::size_of::<Globals>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let globals_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("scene globals layout"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            }],
        });
        let globals_bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("scene globals"),
            layout: &globals_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: globals.as_entire_binding(),
            }],
        });
        let image_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("scene image layout"),
            entries: &[
                fragment_texture(0, true),
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                    count: None,
                },
            ],
        });
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("scene image sampler"),
            mag_filter: wgpu::FilterMode::Nearest,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let coverage_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("scene coverage layout"),
            entries: &[
                fragment_texture(0, false),
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
            ],
        });
        let coverage_pipeline_layout =
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("scene coverage pipeline layout"),
                bind_group_layouts: &[Some(&globals_layout), Some(&coverage_layout)],
                immediate_size: 0,
            });
        let color_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("scene colour layout"),
            bind_group_layouts: &[Some(&globals_layout)],
            immediate_size: 0,
        });
        let image_pipeline_layout =
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("scene image layout"),
                bind_group_layouts: &[Some(&globals_layout), Some(&image_layout)],
                immediate_size: 0,
            });
        let blended = [Some(wgpu::ColorTargetState {
            format,
            blend: Some(wgpu::BlendState::ALPHA_BLENDING),
            write_mask: wgpu::ColorWrites::ALL,
        })];
        // the cached layers are copied in as they are (colour and alpha)
        let replaced = [Some(wgpu::ColorTargetState {
            format,
            blend: None,
            write_mask: wgpu::ColorWrites::ALL,
        })];
        let pipeline = |label: &str,
                        layout: &wgpu::PipelineLayout,
                        vs: &str,
                        fs: &str,
                        buffers: &[Option<wgpu::VertexBufferLayout<'_>>],
                        targets: &[Option<wgpu::ColorTargetState>]| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some(vs),
                    compilation_options: Default::default(),
                    buffers,
                },
                primitive: wgpu::PrimitiveState {
                    topology: wgpu::PrimitiveTopology::TriangleList,
                    cull_mode: None,
                    ..Default::default()
                },
                depth_stencil: None,
                multisample: wgpu::MultisampleState {
                    count: samples.max(1),
                    mask: !0,
                    alpha_to_coverage_enabled: false,
                },
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some(fs),
                    compilation_options: Default::default(),
                    targets,
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let fill_pipeline = pipeline(
            "scene fills",
            &color_layout,
            "vs_fill",
            "fs_color",
            &[Some(wgpu::VertexBufferLayout {
                array_stride: std::mem::size_of::<FillVertex>() as u64,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &wgpu::vertex_attr_array![0 => Float32x2, 1 => Unorm8x4],
            })],
            &blended,
        );
        let segment_pipeline = pipeline(
            "scene segments",
            &color_layout,
            "vs_segment",
            "fs_color",
            &[Some(wgpu::VertexBufferLayout {
                array_stride: std::mem::size_of::<Segment>() as u64,
                step_mode: wgpu::VertexStepMode::Instance,
                attributes: &wgpu::vertex_attr_array![
                    0 => Float32x2, 1 => Float32x2, 2 => Float32, 3 => Unorm8x4
                ],
            })],
            &blended,
        );
        let image_pipeline = pipeline(
            "scene images",
            &image_pipeline_layout,
            "vs_image",
            "fs_image",
            &[Some(wgpu::VertexBufferLayout {
                array_stride: std::mem::size_of::<ImageVertex>() as u64,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &wgpu::vertex_attr_array![0 => Float32x2, 1 => Float32x2],
            })],
            &blended,
        );
        let blit_pipeline = pipeline(
            "scene layer cache",
            &image_pipeline_layout,
            "vs_blit",
            "fs_blit",
            &[],
            &replaced,
        );
        // the composite computes premultiplied colour
        let premultiplied = [Some(wgpu::ColorTargetState {
            format,
            blend: Some(wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING),
            write_mask: wgpu::ColorWrites::ALL,
        })];
        let coverage_pipelines = ["fs_coverage1", "fs_coverage2", "fs_coverage4"].map(|fs| {
            pipeline(
                "scene fan coverage",
                &coverage_pipeline_layout,
                "vs_blit",
                fs,
                &[],
                &premultiplied,
            )
        });
        let blit_sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("scene layer cache sampler"),
            mag_filter: wgpu::FilterMode::Nearest,
            min_filter: wgpu::FilterMode::Nearest,
            ..Default::default()
        });
        let cache_allowed = samples <= 1 && !format.is_srgb();
        tracing::debug!(?format, samples, cache_allowed, "scene renderer");
        SceneRenderer {
            fill_pipeline,
            coverage_pipelines,
            coverage_layout,
            coverage_targets: Vec::new(),
            fan_coverage: false,
            counter: Coverage::default(),
            alphas: Vec::new(),
            count_time: std::time::Duration::ZERO,
            count_threads: std::thread::available_parallelism().map_or(1, |n| n.get().min(8)),
            segment_pipeline,
            image_pipeline,
            blit_pipeline,
            format,
            cache: None,
            cache_allowed,
            cache_enabled: cache_allowed,
            cache_in_use: false,
            cache_hits: 0,
            blit_sampler,
            globals,
            globals_bind,
            image_layout,
            sampler,
            fills: GrowBuffer::new(device, "scene fills", wgpu::BufferUsages::VERTEX),
            segments: GrowBuffer::new(device, "scene segments", wgpu::BufferUsages::VERTEX),
            images: Vec::new(),
            draws: vec![LayerDraw::default(); LAYERS],
            linear_target: format.is_srgb(),
            fill_bytes: Vec::new(),
            segment_bytes: Vec::new(),
        }
    }

    /// Turns the layer cache on or off (on by default where the target allows it: one sample
    /// per pixel and a non-sRGB format, whose stored values are final). Off draws every layer
    /// every frame; the pictures are the same.
    pub fn set_layer_cache(&mut self, on: bool) {
        self.cache_enabled = on && self.cache_allowed;
        if !self.cache_enabled {
            self.cache = None;
        }
    }

    /// Turns CPU coverage counting of fans on or off (off by default; [`fan_coverage_for`]
    /// tells whether an adapter wants it). Off draws them as triangle fans; the pictures are
    /// the same up to blending's rounding.
    pub fn set_fan_coverage(&mut self, on: bool) {
        self.fan_coverage = on;
    }

    /// Whether the last prepared frame counted any layer's fans per pixel (rather than drawing
    /// them all as triangles).
    pub fn counted_fans(&self) -> bool {
        self.draws.iter().any(|d| d.coverage.is_some())
    }

    /// How long the last prepared frame spent counting fan coverage on the CPU.
    pub fn coverage_time(&self) -> std::time::Duration {
        self.count_time
    }

    /// How many prepared frames reused the cached layers instead of drawing them.
    pub fn layer_cache_hits(&self) -> u64 {
        self.cache_hits
    }

    /// Uploads `scene` as seen through `view` (whose `size` is the target's size in pixels),
    /// recording into `encoder` the redraw of the cached layers when they changed.
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        scene: &Scene,
        view: &View,
    ) {
        let g = Globals {
            m: view.clip_matrix(),
            viewport: [view.size[0] as f32, view.size[1] as f32],
            linear_target: u32::from(self.linear_target),
            _pad: 0,
        };
        queue.write_buffer(&self.globals, 0, bytemuck::bytes_of(&g));
        self.fill_bytes.clear();
        self.segment_bytes.clear();
        self.images.clear();
        let size = [g.viewport[0].round() as u32, g.viewport[1].round() as u32];
        let drawable = (1..=8192).contains(&size[0]) && (1..=8192).contains(&size[1]);
        let mut composites = 0;
        self.count_time = std::time::Duration::ZERO;
        for (i, layer) in scene.layers.iter().enumerate() {
            let f0 = self.fill_bytes.len() as u32;
            self.fill_bytes.extend_from_slice(&layer.triangles);
            // the colours and fill are looked at only where counting is possible at all
            let counted = (self.fan_coverage && drawable && i >= CACHED_LAYERS)
                .then(|| fan_colours(layer))
                .flatten()
                .filter(|c| !c.is_empty() && fan_fill(layer, view) >= COVERAGE_MIN_FILL);
            let mut slot = None;
            match counted {
                Some(colours) => {
                    self.count_fans(device, queue, layer, &colours, view, size, composites);
                    slot = Some(composites);
                    composites += 1;
                }
                None => layer.fan_triangles(&mut self.fill_bytes),
            }
            let s0 = self.segment_bytes.len() as u32;
            self.segment_bytes.extend_from_slice(&layer.segments);
            let i0 = self.images.len();
            for img in &layer.images {
                if let Some(gi) = self.upload_image(device, queue, img) {
                    self.images.push(gi);
                }
            }
            self.draws[i] = LayerDraw {
                fills: f0..self.fill_bytes.len() as u32,
                coverage: slot,
                segments: s0..self.segment_bytes.len() as u32,
                images: i0..self.images.len(),
            };
        }
        let cacheable = self.cache_enabled && drawable;
        let hit = cacheable && self.cache_matches(scene, &g, size);
        // on a hit the cached layers are not drawn, so their vertices need not be sent again
        let (f0, s0) = if hit {
            (
                self.draws[CACHED_LAYERS].fills.start as usize * std::mem::size_of::<FillVertex>(),
                self.draws[CACHED_LAYERS].segments.start as usize * std::mem::size_of::<Segment>(),
            )
        } else {
            (0, 0)
        };
        self.fills
            .upload_from(device, queue, bytemuck::cast_slice(&self.fill_bytes), f0);
        self.segments
            .upload_from(device, queue, bytemuck::cast_slice(&self.segment_bytes), s0);
        if hit {
            self.cache_hits += 1;
        } else if cacheable {
            self.redraw_cache(device, encoder, scene, &g, size);
        }
        self.cache_in_use = cacheable;
    }

    /// Counts how many of `layer`'s fans of each of `colours` cover each pixel, turns the
    /// counts into alphas and uploads them into coverage target `slot` (made or resized as
    /// needed) with the colours.
    #[allow(clippy::too_many_arguments)]
    fn count_fans(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        layer: &LayerData,
        colours: &[Rgba8],
        view: &View,
        size: [u32; 2],
        slot: usize,
    ) {
        let map = PixelMap::of(&View {
            size: [f64::from(size[0]), f64::from(size[1])],
            ..*view
        });
        let tables: Vec<[u8; 256]> = colours.iter().map(|c| blended_alphas(c.0[3])).collect();
        let rings = layer.fans.iter().filter_map(|f| {
            let group = colours.iter().position(|&c| c == f.color)?;
            Some((group, f.points(layer)))
        });
        let (w, h) = (size[0] as usize, size[1] as usize);
        let threads = self.count_threads;
        let started = std::time::Instant::now();
        self.counter
            .count(w, h, &map, rings, &tables, threads, &mut self.alphas);
        self.count_time += started.elapsed();
        let channels = self.alphas.len() / (w * h).max(1);
        let stale = self
            .coverage_targets
            .get(slot)
            .is_none_or(|t| t.size != size || t.channels != channels);
        if stale {
            let target = CoverageTarget::new(device, &self.coverage_layout, size, channels);
            if slot < self.coverage_targets.len() {
                self.coverage_targets[slot] = target;
            } else {
                self.coverage_targets.push(target);
            }
        }
        let t = &self.coverage_targets[slot];
        let mut params = CoverageParams {
            colors: [[0.0; 4]; coverage::MAX_GROUPS],
            size: [size[0] as f32, size[1] as f32],
            _pad: [0.0; 2],
        };
        for (k, c) in colours.iter().enumerate() {
            let [r, g, b, a] = c.0;
            let stored = |v| stored_channel(v, self.linear_target) as f32;
            params.colors[k] = [stored(r), stored(g), stored(b), f32::from(a) / 255.0];
        }
        queue.write_buffer(&t.params, 0, bytemuck::bytes_of(&params));
        queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &t.texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            &self.alphas,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(size[0] * channels as u32),
                rows_per_image: Some(size[1]),
            },
            wgpu::Extent3d {
                width: size[0],
                height: size[1],
                depth_or_array_layers: 1,
            },
        );
    }

    /// The cached layers' vertex ranges in the staging arrays.
    fn cached_ranges(&self) -> (Range<usize>, Range<usize>) {
        (
            self.draws[0].fills.start as usize..self.draws[CACHED_LAYERS - 1].fills.end as usize,
            self.draws[0].segments.start as usize
                ..self.draws[CACHED_LAYERS - 1].segments.end as usize,
        )
    }

    /// Whether the cache holds a drawing of exactly this frame's cached layers.
    fn cache_matches(&self, scene: &Scene, g: &Globals, size: [u32; 2]) -> bool {
        let Some(LayerCache {
            source: Some(src),
            size: csize,
            ..
        }) = &self.cache
        else {
            return false;
        };
        let (fills, segments) = self.cached_ranges();
        *csize == size
            && src.globals[..] == *bytemuck::bytes_of(g)
            && src.background == scene.background.0
            && bytes_eq(&src.fills, &self.fill_bytes[fills])
            && bytes_eq(&src.segments, &self.segment_bytes[segments])
            && src.images == images_hash(scene)
    }

    /// Draws the cached layers into the cache texture (made or resized as needed) and records
    /// what they were drawn from.
    fn redraw_cache(
        &mut self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        scene: &Scene,
        g: &Globals,
        size: [u32; 2],
    ) {
        if self.cache.as_ref().is_none_or(|c| c.size != size) {
            let usage =
                wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
            let texture = texture_2d(device, "scene layer cache", size, self.format, usage);
            let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
            let bind = texture_bind(
                device,
                &self.image_layout,
                &view,
                &self.blit_sampler,
                "scene layer cache",
            );
            self.cache = Some(LayerCache {
                source: None,
                size,
                view,
                bind,
            });
        }
        let cache = self.cache.as_ref().expect("cache made above");
        let bg = scene.background.0;
        {
            let mut pass = cleared_pass(
                encoder,
                &cache.view,
                bg,
                self.linear_target,
                "scene layer cache",
            );
            pass.set_bind_group(0, &self.globals_bind, &[]);
            self.draw_layers(&mut pass, 0..CACHED_LAYERS);
        }
        let (fills, segments) = self.cached_ranges();
        let mut globals = [0u8; std::mem::size_of::<Globals>()];
        globals.copy_from_slice(bytemuck::bytes_of(g));
        // reuse the old snapshot's allocations
        let old = self.cache.as_mut().and_then(|c| c.source.take());
        let (mut f, mut sg) = old.map(|o| (o.fills, o.segments)).unwrap_or_default();
        f.clear();
        f.extend_from_slice(&self.fill_bytes[fills]);
        sg.clear();
        sg.extend_from_slice(&self.segment_bytes[segments]);
        self.cache.as_mut().expect("cache made above").source = Some(CacheSource {
            globals,
            background: bg,
            fills: f,
            segments: sg,
            images: images_hash(scene),
        });
    }

    fn upload_image(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        img: &crate::scene::ImagePrim,
    ) -> Option<GpuImage> {
        let (w, h) = (img.width, img.height);
        if w == 0 || h == 0 || w > 8192 || h > 8192 || img.rgba.len() != (w * h * 4) as usize {
            return None;
        }
        let size = wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        };
        let usage = wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST;
        let tex = texture_2d(
            device,
            "scene image",
            [w, h],
            wgpu::TextureFormat::Rgba8Unorm,
            usage,
        );
        queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &tex,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            &img.rgba,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(4 * w),
                rows_per_image: Some(h),
            },
            size,
        );
        let view = tex.create_view(&wgpu::TextureViewDescriptor::default());
        let bind = texture_bind(
            device,
            &self.image_layout,
            &view,
            &self.sampler,
            "scene image",
        );
        let c = img.corners;
        let uv = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let verts: Vec<ImageVertex> = [0, 1, 2, 0, 2, 3]
            .iter()
            .map(|&k| ImageVertex {
                pos: c[k],
                uv: uv[k],
            })
            .collect();
        let vbuf = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("scene image quad"),
            size: std::mem::size_of_val(verts.as_slice()) as u64,
            usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        queue.write_buffer(&vbuf, 0, bytemuck::cast_slice(&verts));
        Some(GpuImage { bind, verts: vbuf })
    }

    /// Records the draws of the last prepared scene into `pass` (whose viewport is the canvas).
    pub fn paint(&self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_bind_group(0, &self.globals_bind, &[]);
        match (&self.cache, self.cache_in_use) {
            (Some(cache), true) => {
                pass.set_pipeline(&self.blit_pipeline);
                pass.set_bind_group(1, &cache.bind, &[]);
                pass.draw(0..6, 0..1);
                self.draw_layers(pass, CACHED_LAYERS..LAYERS);
            }
            _ => self.draw_layers(pass, 0..LAYERS),
        }
    }

    /// Records the draws of `layers` (the globals bind group must be set).
    fn draw_layers(&self, pass: &mut wgpu::RenderPass<'_>, layers: Range<usize>) {
        for d in &self.draws[layers] {
            if !d.fills.is_empty() {
                pass.set_pipeline(&self.fill_pipeline);
                pass.set_vertex_buffer(0, self.fills.buf.slice(..));
                pass.draw(d.fills.clone(), 0..1);
            }
            if let Some(t) = d.coverage.map(|k| &self.coverage_targets[k]) {
                let which = t.channels.trailing_zeros().min(2) as usize;
                pass.set_pipeline(&self.coverage_pipelines[which]);
                pass.set_bind_group(1, &t.bind, &[]);
                pass.draw(0..6, 0..1);
            }
            if !d.segments.is_empty() {
                pass.set_pipeline(&self.segment_pipeline);
                pass.set_vertex_buffer(0, self.segments.buf.slice(..));
                pass.draw(0..6, d.segments.clone());
            }
            for img in &self.images[d.images.clone()] {
                pass.set_pipeline(&self.image_pipeline);
                pass.set_bind_group(1, &img.bind, &[]);
                pass.set_vertex_buffer(0, img.verts.slice(..));
                pass.draw(0..6, 0..1);
            }
        }
    }
}

/// How many views' worth of pixels `layer`'s fans cover as `view` shows them, counting
/// overlaps: their area over the view's.
pub fn fan_fill(layer: &LayerData, view: &View) -> f64 {
    let twice: f64 = layer
        .fans
        .iter()
        .map(|f| {
            let pts = f.points(layer);
            let Some(&last) = pts.last() else { return 0.0 };
            let mut a = last;
            let mut sum = 0.0f64;
            for &b in pts {
                sum += f64::from(a[0]) * f64::from(b[1]) - f64::from(b[0]) * f64::from(a[1]);
                a = b;
            }
            sum.abs()
        })
        .sum();
    0.5 * twice * view.scale * view.scale / (view.size[0] * view.size[1]).max(1.0)
}

/// The distinct colours of `layer`'s fans in order of first appearance, `None` when there are
/// more than [`coverage::MAX_GROUPS`] (those fans are drawn as triangles: each colour is a
/// channel of the composite).
fn fan_colours(layer: &LayerData) -> Option<Vec<Rgba8>> {
    let colours = layer.fan_colours();
    (colours.len() <= coverage::MAX_GROUPS).then_some(colours)
}

/// The alpha (0-255) that `n` blends of alpha `a` (0-255) leave: `1 - (1 - a)^n`, for every
/// count `n` up to 255.
fn blended_alphas(a: u8) -> [u8; 256] {
    let keep = 1.0 - f64::from(a) / 255.0;
    let mut t = [0u8; 256];
    let mut left = 1.0f64;
    for v in t.iter_mut() {
        *v = ((1.0 - left) * 255.0).round() as u8;
        left *= keep;
    }
    t
}

/// Byte equality (a `memcmp`; float `==` would treat NaN and ±0 specially and compare slower).
fn bytes_eq<T: bytemuck::Pod>(a: &[T], b: &[T]) -> bool {
    bytemuck::cast_slice::<T, u8>(a) == bytemuck::cast_slice::<T, u8>(b)
}

/// Hash of the cached layers' images (their placement, size and texels).
fn images_hash(scene: &Scene) -> u64 {
    let mut h = DefaultHasher::new();
    for layer in &scene.layers[..CACHED_LAYERS] {
        h.write_usize(layer.images.len());
        for img in &layer.images {
            h.write(bytemuck::cast_slice(&img.corners));
            h.write_u32(img.width);
            h.write_u32(img.height);
            h.write(&img.rgba);
        }
    }
    h.finish()
}

/// A single-sample 2D texture of `size` pixels without mipmaps.
fn texture_2d(
    device: &wgpu::Device,
    label: &str,
    size: [u32; 2],
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width: size[0],
            height: size[1],
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

/// A bind group layout entry for a 2D float texture the fragment shader reads (`filterable`:
/// through a filtering sampler; else only loaded).
fn fragment_texture(binding: u32, filterable: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Texture {
            multisampled: false,
            sample_type: wgpu::TextureSampleType::Float { filterable },
            view_dimension: wgpu::TextureViewDimension::D2,
        },
        count: None,
    }
}

/// A bind group of a texture and its sampler in the image layout.
fn texture_bind(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    view: &wgpu::TextureView,
    sampler: &wgpu::Sampler,
    label: &str,
) -> wgpu::BindGroup {
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(view),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: wgpu::BindingResource::Sampler(sampler),
            },
        ],
    })
}

/// A colour channel (an sRGB-encoded byte, as scene colours are) as a target stores it: decoded
/// to linear for a `linear_target` (an sRGB format), as the shaders' `out_color` does.
fn stored_channel(v: u8, linear_target: bool) -> f64 {
    let c = f64::from(v) / 255.0;
    if !linear_target {
        c
    } else if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// A render pass into `view`, cleared to `bg` (straight RGBA bytes) and stored.
pub(crate) fn cleared_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    view: &wgpu::TextureView,
    bg: [u8; 4],
    linear_target: bool,
    label: &str,
) -> wgpu::RenderPass<'e> {
    // the clear colour is stored as given: a target that stores linear colour needs it decoded,
    // as the shaders decode the scene's colours
    let channel = |v: u8| stored_channel(v, linear_target);
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load: wgpu::LoadOp::Clear(wgpu::Color {
                    r: channel(bg[0]),
                    g: channel(bg[1]),
                    b: channel(bg[2]),
                    a: bg[3] as f64 / 255.0,
                }),
                store: wgpu::StoreOp::Store,
            },
        })],
        depth_stencil_attachment: None,
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fan_fill_is_the_fans_area_in_views() {
        let mut layer = Scene::default();
        // a 2 x 1 m rectangle as a fan from a corner (either way round), and a triangle
        let rim = [[2.0, 0.0], [2.0, 1.0], [0.0, 1.0]];
        layer.fan(Layer::Footprints, [0.0, 0.0], &rim, Rgba8::BLACK);
        let back: Vec<[f64; 2]> = rim.iter().rev().copied().collect();
        layer.fan(Layer::Footprints, [0.0, 0.0], &back, Rgba8::BLACK);
        layer.fan(
            Layer::Footprints,
            [5.0, 5.0],
            &[[6.0, 5.0], [5.0, 6.0]],
            Rgba8::WHITE,
        );
        let view = View {
            center: [0.0, 0.0],
            scale: 10.0,
            yaw: 0.4,
            size: [100.0, 50.0],
        };
        // (2 + 2 + 0.5) m2 at 100 px per m2 over 5,000 px
        let fill = fan_fill(layer.layer(Layer::Footprints), &view);
        assert!((fill - 0.09).abs() < 1e-9, "{fill}");
    }

    #[test]
    fn blended_alphas_compound_like_repeated_blending() {
        let t = blended_alphas(40);
        assert_eq!((t[0], t[1]), (0, 40));
        // blending alpha 40 over itself: 40 + 40 * (1 - 40/255) = 73.7
        assert_eq!(t[2], 74);
        assert!(t.windows(2).all(|w| w[0] <= w[1]));
        assert_eq!(t[255], 255);
        assert!(blended_alphas(0).iter().all(|&a| a == 0));
        assert!(blended_alphas(255)[1..].iter().all(|&a| a == 255));
    }
}
