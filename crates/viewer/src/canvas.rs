//! A [`Scene`] drawn inside an egui window: the background and labels through egui's painter,
//! everything else by our [`SceneRenderer`] in an `egui_wgpu` paint callback (so the bulk of
//! the drawing never goes through egui's CPU tessellator).

use std::sync::Arc;

use egui::{Color32, Rect};

use crate::render::SceneRenderer;
use crate::scene::{Rgba8, Scene};
use crate::view::View;

/// A screen point as canvas pixels from the canvas `rect`'s corner, as [`View`] takes them.
pub fn local(rect: Rect, p: egui::Pos2) -> [f64; 2] {
    [(p.x - rect.min.x) as f64, (p.y - rect.min.y) as f64]
}

/// Zooms `view` about the pointer by the mouse wheel or a pinch over the canvas `resp`: the
/// world window and playerv zoom alike.
pub fn zoom_on_scroll(view: &mut View, ui: &egui::Ui, resp: &egui::Response) {
    if let Some(hover) = resp.hover_pos() {
        let scroll = ui.input(|i| i.smooth_scroll_delta.y + i.zoom_delta().ln() * 200.0);
        if scroll != 0.0 {
            view.zoom_at(local(resp.rect, hover), (scroll as f64 / 200.0).exp());
        }
    }
}

/// Adds the scene renderer to a starting eframe app's wgpu state (once, at start-up); an error
/// when eframe runs without wgpu.
pub fn install(cc: &eframe::CreationContext<'_>) -> Result<(), &'static str> {
    let rs = cc
        .wgpu_render_state
        .as_ref()
        .ok_or("eframe started without wgpu")?;
    let mut renderer = SceneRenderer::new(&rs.device, rs.target_format, 1);
    renderer.set_fan_coverage(crate::render::fan_coverage_for(
        rs.adapter.get_info().device_type,
    ));
    rs.renderer.write().callback_resources.insert(renderer);
    Ok(())
}

struct SceneCallback {
    scene: Arc<Scene>,
    view: View,
}

impl egui_wgpu::CallbackTrait for SceneCallback {
    fn prepare(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        _screen: &egui_wgpu::ScreenDescriptor,
        encoder: &mut wgpu::CommandEncoder,
        resources: &mut egui_wgpu::CallbackResources,
    ) -> Vec<wgpu::CommandBuffer> {
        if let Some(r) = resources.get_mut::<SceneRenderer>() {
            r.prepare(device, queue, encoder, &self.scene, &self.view);
        }
        Vec::new()
    }

    fn paint(
        &self,
        _info: egui::PaintCallbackInfo,
        pass: &mut wgpu::RenderPass<'static>,
        resources: &egui_wgpu::CallbackResources,
    ) {
        if let Some(r) = resources.get::<SceneRenderer>() {
            r.paint(pass);
        }
    }
}

/// egui colour of a scene colour.
pub fn color32(c: Rgba8) -> Color32 {
    Color32::from_rgba_unmultiplied(c.0[0], c.0[1], c.0[2], c.0[3])
}

/// Paints `scene` into `rect` (in points) as `view` (whose `size` is `rect`'s size in points)
/// shows it.
pub fn paint(ui: &egui::Ui, rect: Rect, scene: Arc<Scene>, view: &View) {
    let painter = ui.painter_at(rect);
    painter.rect_filled(rect, 0.0, color32(scene.background));
    let ppp = ui.ctx().pixels_per_point() as f64;
    let gpu_view = View {
        scale: view.scale * ppp,
        size: [view.size[0] * ppp, view.size[1] * ppp],
        ..*view
    };
    let labels: Vec<_> = scene.labels.clone();
    painter.add(egui_wgpu::Callback::new_paint_callback(
        rect,
        SceneCallback {
            scene,
            view: gpu_view,
        },
    ));
    for l in labels {
        let s = view.to_screen([l.pos[0] as f64, l.pos[1] as f64]);
        let at = rect.min + egui::vec2(s[0] as f32, s[1] as f32);
        if !rect.contains(at) {
            continue;
        }
        let font = egui::FontId::proportional(12.0);
        let galley = painter.layout_no_wrap(l.text, font, color32(l.color));
        let text_rect = Rect::from_min_size(at, galley.size());
        if let Some(bg) = l.bubble {
            let r = text_rect.expand(4.0);
            painter.rect_filled(r, 6.0, color32(bg));
            painter.rect_stroke(
                r,
                6.0,
                egui::Stroke::new(1.0, Color32::BLACK),
                egui::StrokeKind::Outside,
            );
        }
        painter.galley(at, galley, color32(l.color));
    }
}
