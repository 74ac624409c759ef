//! Draws a [`Scene`] with wgpu into any colour target: the eframe window (through an
//! `egui_wgpu` paint callback, see [`crate::canvas`]) or an offscreen texture
//! ([`crate::offscreen`]).
//!
//! Three pipelines, all batched: filled triangles from one vertex buffer, segments as one
//! instanced quad each (expanded to their pixel width in the vertex shader, so 180,000 laser
//! rays are one draw call and no CPU tessellation), and textured quads for images. Every frame
//! the scene's layers are uploaded into buffers that grow as needed and are reused; drawing is
//! then a handful of calls per layer, back to front.

use std::ops::Range;

use crate::scene::{FillVertex, LAYERS, Scene, Segment};
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

    fn upload(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, bytes: &[u8]) {
        let need = bytes.len() as u64;
        if need > self.cap {
            self.cap = need.next_power_of_two();
            self.buf = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(self.label),
                size: self.cap,
                usage: self.usage | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
        }
        if !bytes.is_empty() {
            queue.write_buffer(&self.buf, 0, bytes);
        }
    }
}

struct GpuImage {
    bind: wgpu::BindGroup,
    verts: wgpu::Buffer,
}

/// The draw ranges of one layer.
#[derive(Clone, Default)]
struct LayerDraw {
    fills: Range<u32>,
    segments: Range<u32>,
    images: Range<usize>,
}

/// Pipelines and per-frame buffers for drawing scenes into targets of one format and sample
/// count. Create one per target kind; call [`SceneRenderer::prepare`] then
/// [`SceneRenderer::paint`] each frame.
pub struct SceneRenderer {
    fill_pipeline: wgpu::RenderPipeline,
    segment_pipeline: wgpu::RenderPipeline,
    image_pipeline: wgpu::RenderPipeline,
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
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        multisampled: false,
                        sample_type: wgpu::TextureSampleType::Float { filterable: true },
                        view_dimension: wgpu::TextureViewDimension::D2,
                    },
                    count: None,
                },
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
        let targets = [Some(wgpu::ColorTargetState {
            format,
            blend: Some(wgpu::BlendState::ALPHA_BLENDING),
            write_mask: wgpu::ColorWrites::ALL,
        })];
        let pipeline = |label: &str,
                        layout: &wgpu::PipelineLayout,
                        vs: &str,
                        fs: &str,
                        buffers: &[Option<wgpu::VertexBufferLayout<'_>>]| {
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
                    targets: &targets,
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
        );
        SceneRenderer {
            fill_pipeline,
            segment_pipeline,
            image_pipeline,
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

    /// Uploads `scene` as seen through `view` (whose `size` is the target's size in pixels).
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
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
        for (i, layer) in scene.layers.iter().enumerate() {
            let f0 = self.fill_bytes.len() as u32;
            self.fill_bytes.extend_from_slice(&layer.triangles);
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
                segments: s0..self.segment_bytes.len() as u32,
                images: i0..self.images.len(),
            };
        }
        self.fills
            .upload(device, queue, bytemuck::cast_slice(&self.fill_bytes));
        self.segments
            .upload(device, queue, bytemuck::cast_slice(&self.segment_bytes));
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
        let tex = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("scene image"),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba8Unorm,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
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
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("scene image"),
            layout: &self.image_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&view),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::Sampler(&self.sampler),
                },
            ],
        });
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
        for d in &self.draws {
            if !d.fills.is_empty() {
                pass.set_pipeline(&self.fill_pipeline);
                pass.set_vertex_buffer(0, self.fills.buf.slice(..));
                pass.draw(d.fills.clone(), 0..1);
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
