//! Plain drawing primitives in world coordinates: what a world (or a playerv client state) looks
//! like, independent of how it is drawn.
//!
//! A [`Scene`] is built on the CPU by pure functions ([`crate::world_scene`],
//! [`crate::playerv::scene`]) and drawn by [`crate::render`] with wgpu. Everything is batched by
//! [`Layer`] so the renderer issues a few draw calls per layer whatever the number of robots:
//! filled triangles (polygons are triangulated here), segments of a given pixel width (rays,
//! outlines, grid lines), images (camera frames) and text labels (drawn by egui, on top).

use crate::triangulate;
use crate::view::View;

/// An sRGB colour with alpha, 8 bits per channel (what the render targets store).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct Rgba8(pub [u8; 4]);

impl Rgba8 {
    /// Opaque black.
    pub const BLACK: Rgba8 = Rgba8([0, 0, 0, 255]);
    /// Opaque white.
    pub const WHITE: Rgba8 = Rgba8([255, 255, 255, 255]);

    /// From components in `0..=1` (clamped).
    pub fn from_f64(r: f64, g: f64, b: f64, a: f64) -> Rgba8 {
        let q = |v: f64| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
        Rgba8([q(r), q(g), q(b), q(a)])
    }

    /// From a simulator / worldfile colour.
    pub fn from_color(c: &stage_sim::Color) -> Rgba8 {
        Rgba8::from_f64(c.r, c.g, c.b, c.a)
    }

    /// Opaque colour from 8-bit components.
    pub const fn rgb(r: u8, g: u8, b: u8) -> Rgba8 {
        Rgba8([r, g, b, 255])
    }

    /// The same colour with another alpha.
    pub fn with_alpha(self, a: u8) -> Rgba8 {
        Rgba8([self.0[0], self.0[1], self.0[2], a])
    }

    /// The colour scaled towards black by `f` (0 black, 1 unchanged); alpha kept.
    pub fn darker(self, f: f32) -> Rgba8 {
        let s = |v: u8| (v as f32 * f).round().clamp(0.0, 255.0) as u8;
        Rgba8([s(self.0[0]), s(self.0[1]), s(self.0[2]), self.0[3]])
    }

    /// Player's packed `0x00RRGGBB` colour (blobfinder blobs), opaque.
    pub fn from_packed_rgb(c: u32) -> Rgba8 {
        Rgba8::rgb((c >> 16) as u8, (c >> 8) as u8, c as u8)
    }
}

/// A world-space vertex of a filled triangle.
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct FillVertex {
    /// Position (m).
    pub pos: [f32; 2],
    /// Colour.
    pub color: Rgba8,
}

/// A straight segment drawn `width` pixels wide whatever the zoom (one GPU instance).
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct Segment {
    /// Start (m).
    pub a: [f32; 2],
    /// End (m).
    pub b: [f32; 2],
    /// Width in pixels.
    pub width: f32,
    /// Colour.
    pub color: Rgba8,
}

/// A filled fan (a ranger footprint): the polygon through its centre and its rim points, kept
/// whole rather than as triangles so the renderer can choose how to draw it: as a triangle fan,
/// or, for many translucent fans on a software rasteriser, by counting how many cover each
/// pixel ([`crate::coverage`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FanPrim {
    /// Index of the centre in the layer's [`LayerData::fan_points`]; the rim follows it.
    pub first: u32,
    /// Number of points, the centre included (at least 3).
    pub len: u32,
    /// Colour.
    pub color: Rgba8,
}

impl FanPrim {
    /// The fan's points (centre, then rim) in `layer`.
    pub fn points<'a>(&self, layer: &'a LayerData) -> &'a [[f32; 2]] {
        let (a, n) = (self.first as usize, self.len as usize);
        layer.fan_points.get(a..a + n).unwrap_or(&[])
    }
}

/// An RGBA image drawn on a world-space quad (camera frames).
#[derive(Clone, Debug, PartialEq)]
pub struct ImagePrim {
    /// Corners in world space: top-left, top-right, bottom-right, bottom-left of the image.
    pub corners: [[f32; 2]; 4],
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height` RGBA pixels, row by row from the top.
    pub rgba: Vec<u8>,
}

/// A text label anchored at a world point (drawn by egui over the scene; offscreen renders
/// leave text out).
#[derive(Clone, Debug, PartialEq)]
pub struct Label {
    /// Anchor (m).
    pub pos: [f32; 2],
    /// Text.
    pub text: String,
    /// Text colour.
    pub color: Rgba8,
    /// Draw a filled bubble (background colour) behind the text, as Stage's speech bubbles.
    pub bubble: Option<Rgba8>,
}

/// Drawing order, back to front. Within a layer triangles are drawn first, then fans, segments
/// and images.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Layer {
    /// Floor grid and map images.
    Grid = 0,
    /// Bodies of models that never move (floorplans, walls, furniture). Kept apart from the
    /// moving ones because this layer and the grid change only with the view: the renderer
    /// draws both once into a texture and reuses it while they stay the same
    /// ([`crate::render`]), which is most of the triangles of a large map.
    Static = 1,
    /// Translucent sensor footprints (ranger scans), under the moving bodies as in Stage.
    Footprints = 2,
    /// Bodies of models that move (or may be moved).
    Bodies = 3,
    /// Sensor data: rays, links, beams, blob images.
    Data = 4,
    /// Selection, noses, bubbles, the playerv target: always on top.
    Overlay = 5,
}

/// Number of [`Layer`]s.
pub const LAYERS: usize = 6;

/// The primitives of one layer.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LayerData {
    /// Filled triangles, three vertices each.
    pub triangles: Vec<FillVertex>,
    /// Filled fans.
    pub fans: Vec<FanPrim>,
    /// The fans' points (m).
    pub fan_points: Vec<[f32; 2]>,
    /// Segments.
    pub segments: Vec<Segment>,
    /// Images.
    pub images: Vec<ImagePrim>,
}

impl LayerData {
    /// Number of triangles, a fan counting as the triangles it spans.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len() / 3 + self.fans.iter().map(|f| f.len as usize - 2).sum::<usize>()
    }

    /// Appends the layer's fans to `out` as triangles (centre, rim point, next rim point), in
    /// drawing order: colour by colour, each colour's fans in the order they were added, the
    /// colours in the order each first appeared.
    ///
    /// Why by colour: a software rasteriser draws dense fans fastest by counting, per pixel,
    /// how many of each colour cover it ([`crate::coverage`]), which composites colour after
    /// colour; drawing them in that order everywhere gives every renderer the same picture.
    /// One robot's footprints (a laser's, then its sonars') keep Stage's order; only where
    /// different robots' footprints of different colours overlap does the tint differ from
    /// drawing robot after robot.
    pub fn fan_triangles(&self, out: &mut Vec<FillVertex>) {
        for k in self.fan_order() {
            let f = &self.fans[k];
            let pts = f.points(self);
            let Some((&c, rim)) = pts.split_first() else {
                continue;
            };
            let v = |pos| FillVertex {
                pos,
                color: f.color,
            };
            for w in rim.windows(2) {
                out.extend([v(c), v(w[0]), v(w[1])]);
            }
        }
    }

    /// The distinct colours of the layer's fans, in the order each first appears.
    pub fn fan_colours(&self) -> Vec<Rgba8> {
        let mut colours = Vec::new();
        // a linear search over the few colours a layer has; a set once there are many
        let mut many: Option<std::collections::HashSet<Rgba8>> = None;
        for f in &self.fans {
            let new = match &mut many {
                Some(set) => set.insert(f.color),
                None => !colours.contains(&f.color),
            };
            if new {
                colours.push(f.color);
                if many.is_none() && colours.len() > 16 {
                    many = Some(colours.iter().copied().collect());
                }
            }
        }
        colours
    }

    /// The fans' indices in drawing order (see [`LayerData::fan_triangles`]).
    fn fan_order(&self) -> Vec<usize> {
        let colours = self.fan_colours();
        if colours.len() <= 1 {
            return (0..self.fans.len()).collect();
        }
        let index: std::collections::HashMap<Rgba8, usize> =
            colours.iter().enumerate().map(|(i, &c)| (c, i)).collect();
        let rank: Vec<usize> = self.fans.iter().map(|f| index[&f.color]).collect();
        // a counting sort, stable: each colour's fans keep the order they were added in
        let mut start = vec![0usize; colours.len() + 1];
        for &r in &rank {
            start[r + 1] += 1;
        }
        for k in 0..colours.len() {
            start[k + 1] += start[k];
        }
        let mut order = vec![0usize; self.fans.len()];
        for (i, &r) in rank.iter().enumerate() {
            order[start[r]] = i;
            start[r] += 1;
        }
        order
    }
}

/// Everything to draw, in world coordinates.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// Clear colour.
    pub background: Rgba8,
    /// Layers, back to front (indexed by [`Layer`]).
    pub layers: [LayerData; LAYERS],
    /// Text labels (drawn last, by egui).
    pub labels: Vec<Label>,
    /// What built the [`Layer::Static`] primitives, when the builder can tell (`None`: unknown):
    /// lets a builder keep that layer instead of rebuilding it (a floorplan is tens of
    /// thousands of triangles).
    pub static_key: Option<u64>,
}

impl Default for Scene {
    fn default() -> Self {
        Scene::new(Rgba8::WHITE)
    }
}

impl Scene {
    /// An empty scene on `background`.
    pub fn new(background: Rgba8) -> Scene {
        Scene {
            background,
            layers: Default::default(),
            labels: Vec::new(),
            static_key: None,
        }
    }

    /// Empties the scene, keeping its allocations (scenes are rebuilt every frame).
    pub fn clear(&mut self) {
        self.clear_keeping_static(false);
    }

    /// Empties the scene but for the [`Layer::Static`] primitives and their
    /// [`Scene::static_key`] when `keep_static` is set.
    pub fn clear_keeping_static(&mut self, keep_static: bool) {
        for (i, l) in self.layers.iter_mut().enumerate() {
            if keep_static && i == Layer::Static as usize {
                continue;
            }
            l.triangles.clear();
            l.fans.clear();
            l.fan_points.clear();
            l.segments.clear();
            l.images.clear();
        }
        if !keep_static {
            self.static_key = None;
        }
        self.labels.clear();
    }

    /// The primitives of `layer`.
    pub fn layer(&self, layer: Layer) -> &LayerData {
        &self.layers[layer as usize]
    }

    /// The primitives of `layer`, to add to.
    pub fn layer_mut(&mut self, layer: Layer) -> &mut LayerData {
        &mut self.layers[layer as usize]
    }

    /// Number of segments over all layers.
    pub fn segment_count(&self) -> usize {
        self.layers.iter().map(|l| l.segments.len()).sum()
    }

    /// Number of triangles over all layers, a fan counting as the triangles it spans.
    pub fn triangle_count(&self) -> usize {
        self.layers.iter().map(LayerData::triangle_count).sum()
    }

    /// A segment.
    pub fn line(&mut self, layer: Layer, a: [f64; 2], b: [f64; 2], width: f32, color: Rgba8) {
        self.layer_mut(layer).segments.push(Segment {
            a: f32x2(a),
            b: f32x2(b),
            width,
            color,
        });
    }

    /// An open polyline.
    pub fn polyline(&mut self, layer: Layer, pts: &[[f64; 2]], width: f32, color: Rgba8) {
        for w in pts.windows(2) {
            self.line(layer, w[0], w[1], width, color);
        }
    }

    /// A closed polygon outline.
    pub fn outline(&mut self, layer: Layer, pts: &[[f64; 2]], width: f32, color: Rgba8) {
        self.polyline(layer, pts, width, color);
        if pts.len() > 2 {
            self.line(layer, pts[pts.len() - 1], pts[0], width, color);
        }
    }

    /// A blobfinder image as an inset fixed on screen, as Stage's world window and playerv both
    /// draw it: `w` × `h` image pixels from canvas pixel `top_left` at `k` canvas pixels per
    /// image pixel, on `background`, with each blob's box (`[left, top, right, bottom]` image
    /// pixels, inclusive) filled in its colour. Returns the world point of the inset's
    /// bottom-left corner.
    #[allow(clippy::too_many_arguments)]
    pub fn blob_inset(
        &mut self,
        layer: Layer,
        view: &View,
        top_left: [f64; 2],
        k: f64,
        [w, h]: [f64; 2],
        background: Rgba8,
        blobs: impl IntoIterator<Item = (Rgba8, [f64; 4])>,
    ) -> [f64; 2] {
        let corner = |x: f64, y: f64| view.to_world([top_left[0] + x * k, top_left[1] + y * k]);
        let frame = [
            corner(0.0, 0.0),
            corner(w, 0.0),
            corner(w, h),
            corner(0.0, h),
        ];
        self.fill(layer, &frame, background);
        self.outline(layer, &frame, 1.0, Rgba8::BLACK);
        for (color, [l, t, r, b]) in blobs {
            let (r, b) = ((r + 1.0).min(w), (b + 1.0).min(h));
            let q = [corner(l, t), corner(r, t), corner(r, b), corner(l, b)];
            self.fill(layer, &q, color);
        }
        frame[3]
    }

    /// A filled simple polygon (convex or not; self-intersecting ones are filled as well as the
    /// ear clipper manages). Fewer than three points draw nothing.
    pub fn fill(&mut self, layer: Layer, pts: &[[f64; 2]], color: Rgba8) {
        let tris = &mut self.layers[layer as usize].triangles;
        triangulate::fill_polygon(pts, |p| {
            tris.push(FillVertex {
                pos: f32x2(p),
                color,
            })
        });
    }

    /// A filled fan around `center` through `rim` (a ranger footprint); `rim` need not be
    /// convex, as seen from `center` it never folds back. Fewer than two rim points draw nothing.
    pub fn fan(&mut self, layer: Layer, center: [f64; 2], rim: &[[f64; 2]], color: Rgba8) {
        if rim.len() < 2 {
            return;
        }
        let l = &mut self.layers[layer as usize];
        let first = l.fan_points.len() as u32;
        l.fan_points.push(f32x2(center));
        l.fan_points.extend(rim.iter().map(|&p| f32x2(p)));
        l.fans.push(FanPrim {
            first,
            len: rim.len() as u32 + 1,
            color,
        });
    }

    /// A segment `width` metres wide drawn as two triangles, so it stays in the fill order of
    /// its layer (model outlines must not show through the models stacked on them).
    pub fn stroke(&mut self, layer: Layer, a: [f64; 2], b: [f64; 2], width: f64, color: Rgba8) {
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let len = dx.hypot(dy);
        if len == 0.0 || !len.is_finite() {
            return;
        }
        let (nx, ny) = (-dy / len * width / 2.0, dx / len * width / 2.0);
        let q = [
            [a[0] + nx, a[1] + ny],
            [b[0] + nx, b[1] + ny],
            [b[0] - nx, b[1] - ny],
            [a[0] - nx, a[1] - ny],
        ];
        let tris = &mut self.layers[layer as usize].triangles;
        for i in [0, 1, 2, 0, 2, 3] {
            tris.push(FillVertex {
                pos: f32x2(q[i]),
                color,
            });
        }
    }

    /// A filled polygon with an outline `width` metres wide centred on its edges, drawn over it
    /// (a model block as Stage draws it). An opaque convex polygon with an opaque outline is
    /// drawn as two polygons, the outline's outer edge in its colour and the fill inset by half
    /// the width over it: the same picture as the fill and one [`Scene::stroke`] per edge
    /// (with full rather than notched corners) in `2n - 4` triangles instead of `3n - 2`, which
    /// a software rasteriser drawing 1,000 robots pays per triangle. Anything else is drawn as
    /// the fill and the strokes.
    pub fn outlined_fill(
        &mut self,
        layer: Layer,
        pts: &[[f64; 2]],
        color: Rgba8,
        width: f64,
        outline: Rgba8,
    ) {
        let opaque = color.0[3] == 255 && outline.0[3] == 255;
        let rings = if opaque {
            mitred_offsets(pts, width / 2.0)
        } else {
            None
        };
        let Some((outer, inner)) = rings else {
            if pts.len() >= 3 {
                self.fill(layer, pts, color);
            }
            self.stroke_outline(layer, pts, width, outline);
            return;
        };
        let tris = &mut self.layers[layer as usize].triangles;
        for (ring, c) in [(&outer, outline), (&inner, color)] {
            for i in 1..ring.len() - 1 {
                for p in [ring[0], ring[i], ring[i + 1]] {
                    tris.push(FillVertex {
                        pos: f32x2(p),
                        color: c,
                    });
                }
            }
        }
    }

    /// A closed polygon outline of [`Scene::stroke`]s.
    pub fn stroke_outline(&mut self, layer: Layer, pts: &[[f64; 2]], width: f64, color: Rgba8) {
        let n = pts.len();
        if n < 2 {
            return;
        }
        let edges = if n == 2 { 1 } else { n };
        for i in 0..edges {
            self.stroke(layer, pts[i], pts[(i + 1) % n], width, color);
        }
    }

    /// An axis-aligned filled rectangle `[x0, x1] × [y0, y1]`.
    pub fn fill_rect(&mut self, layer: Layer, min: [f64; 2], max: [f64; 2], color: Rgba8) {
        self.fill(
            layer,
            &[min, [max[0], min[1]], max, [min[0], max[1]]],
            color,
        );
    }

    /// A filled circle of `radius` metres (as a 24-gon).
    pub fn fill_circle(&mut self, layer: Layer, c: [f64; 2], radius: f64, color: Rgba8) {
        let pts = circle_points(c, radius, 24);
        self.fill(layer, &pts, color);
    }

    /// A circle outline of `radius` metres.
    pub fn circle(&mut self, layer: Layer, c: [f64; 2], radius: f64, width: f32, color: Rgba8) {
        let pts = circle_points(c, radius, 48);
        self.outline(layer, &pts, width, color);
    }

    /// An image on a world quad.
    pub fn image(&mut self, layer: Layer, img: ImagePrim) {
        self.layer_mut(layer).images.push(img);
    }

    /// A text label.
    pub fn label(&mut self, pos: [f64; 2], text: impl Into<String>, color: Rgba8) {
        self.labels.push(Label {
            pos: f32x2(pos),
            text: text.into(),
            color,
            bubble: None,
        });
    }

    /// World-space bounds of every primitive (`None` for an empty scene).
    pub fn bounds(&self) -> Option<([f64; 2], [f64; 2])> {
        let mut min = [f64::INFINITY; 2];
        let mut max = [f64::NEG_INFINITY; 2];
        let mut add = |p: [f32; 2]| {
            for k in 0..2 {
                min[k] = min[k].min(p[k] as f64);
                max[k] = max[k].max(p[k] as f64);
            }
        };
        for l in &self.layers {
            l.triangles.iter().for_each(|v| add(v.pos));
            for s in &l.segments {
                add(s.a);
                add(s.b);
            }
            for i in &l.images {
                i.corners.iter().for_each(|&c| add(c));
            }
            for f in &l.fans {
                f.points(l).iter().for_each(|&p| add(p));
            }
        }
        (min[0] <= max[0]).then_some((min, max))
    }
}

/// A polygon's corners (m).
type Polygon = Vec<[f64; 2]>;

/// The strictly convex polygon `pts` with every edge moved `d` metres outwards and, second,
/// inwards, corners mitred: `None` when `pts` is not strictly convex (or has repeated points),
/// when a corner is too sharp to mitre within four times `d`, or when moving inwards would turn
/// an edge over (a polygon thinner than `2 d`).
fn mitred_offsets(pts: &[[f64; 2]], d: f64) -> Option<(Polygon, Polygon)> {
    let n = pts.len();
    if n < 3 || !d.is_finite() {
        return None;
    }
    let edge = |i: usize| {
        let (a, b) = (pts[i], pts[(i + 1) % n]);
        [b[0] - a[0], b[1] - a[1]]
    };
    let cross = |u: [f64; 2], v: [f64; 2]| u[0] * v[1] - u[1] * v[0];
    // every turn the same way, none straight
    let turn = cross(edge(n - 1), edge(0));
    let sign = turn.signum();
    if turn == 0.0 || !turn.is_finite() {
        return None;
    }
    if (0..n - 1).any(|i| cross(edge(i), edge(i + 1)) * sign <= 0.0) {
        return None;
    }
    // unit normals pointing out of the polygon
    let normals: Vec<[f64; 2]> = (0..n)
        .map(|i| {
            let e = edge(i);
            let len = e[0].hypot(e[1]);
            [e[1] / len * sign, -e[0] / len * sign]
        })
        .collect();
    // how far each corner moves, per unit of `d`, along the sum of its edges' normals
    let mitres: Vec<([f64; 2], f64)> = (0..n)
        .map(|i| {
            let (a, b) = (normals[(i + n - 1) % n], normals[i]);
            // 1 / cos(half the turn) as far as the edges: the corner moves d * sqrt(2 / k)
            let k = 1.0 + a[0] * b[0] + a[1] * b[1];
            (k >= 0.125).then_some(([a[0] + b[0], a[1] + b[1]], 1.0 / k))
        })
        .collect::<Option<_>>()?;
    let moved = |d: f64| -> Polygon {
        (0..n)
            .map(|i| {
                let (dir, m) = mitres[i];
                [pts[i][0] + d * m * dir[0], pts[i][1] + d * m * dir[1]]
            })
            .collect()
    };
    let (outer, inner) = (moved(d), moved(-d));
    // an inset edge must still run the way its edge did
    let turned_over = (0..n).any(|i| {
        let (a, b) = (inner[i], inner[(i + 1) % n]);
        let e = edge(i);
        (b[0] - a[0]) * e[0] + (b[1] - a[1]) * e[1] <= 0.0
    });
    (!turned_over).then_some((outer, inner))
}

/// `n` points on a circle, counter-clockwise from angle 0.
pub fn circle_points(c: [f64; 2], r: f64, n: usize) -> Vec<[f64; 2]> {
    (0..n)
        .map(|i| {
            let a = i as f64 * std::f64::consts::TAU / n as f64;
            [c[0] + r * a.cos(), c[1] + r * a.sin()]
        })
        .collect()
}

#[inline]
fn f32x2(p: [f64; 2]) -> [f32; 2] {
    [p[0] as f32, p[1] as f32]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colors_convert_and_clamp() {
        assert_eq!(
            Rgba8::from_f64(1.0, 0.5, -1.0, 2.0),
            Rgba8([255, 128, 0, 255])
        );
        assert_eq!(Rgba8::from_packed_rgb(0x00ff_a500), Rgba8::rgb(255, 165, 0));
        assert_eq!(Rgba8::rgb(200, 100, 0).darker(0.5), Rgba8::rgb(100, 50, 0));
        let c = stage_sim::Color::rgb(0.0, 0.0, 1.0);
        assert_eq!(Rgba8::from_color(&c), Rgba8::rgb(0, 0, 255));
    }

    /// The colour the last of `tris` covering `p` gives it (opaque colours), if any.
    fn top_colour(tris: &[FillVertex], p: [f64; 2]) -> Option<Rgba8> {
        let mut c = None;
        for t in tris.chunks(3) {
            let v = |k: usize| [f64::from(t[k].pos[0]), f64::from(t[k].pos[1])];
            let side = |a: [f64; 2], b: [f64; 2]| {
                (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
            };
            let s = [side(v(0), v(1)), side(v(1), v(2)), side(v(2), v(0))];
            if s.iter().all(|&x| x >= 0.0) || s.iter().all(|&x| x <= 0.0) {
                c = Some(t[0].color);
            }
        }
        c
    }

    #[test]
    fn outlined_convex_blocks_look_like_fill_and_strokes_in_fewer_triangles() {
        let (body, line) = (Rgba8::rgb(200, 0, 0), Rgba8::rgb(100, 0, 0));
        let shapes: [&[[f64; 2]]; 3] = [
            &[[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]],
            // clockwise, and a pentagon
            &[[0.0, 0.0], [0.0, 1.0], [1.5, 1.2], [2.0, 0.5], [1.0, -0.4]],
            &[[0.0, 0.0], [1.0, 0.2], [0.3, 1.0]],
        ];
        for pts in shapes {
            let mut fast = Scene::default();
            fast.outlined_fill(Layer::Bodies, pts, body, 0.1, line);
            let mut slow = Scene::default();
            slow.fill(Layer::Bodies, pts, body);
            slow.stroke_outline(Layer::Bodies, pts, 0.1, line);
            let (f, s) = (
                &fast.layer(Layer::Bodies).triangles,
                &slow.layer(Layer::Bodies).triangles,
            );
            assert_eq!(f.len() / 3, 2 * pts.len() - 4);
            assert!(f.len() < s.len());
            // the same colour everywhere but at the strokes' notched corners
            let mut checked = 0;
            for i in 0..60 {
                for j in 0..60 {
                    let p = [-0.3 + 2.6 * i as f64 / 59.0, -0.7 + 2.2 * j as f64 / 59.0];
                    let near_corner = pts.iter().any(|c| (p[0] - c[0]).hypot(p[1] - c[1]) < 0.2);
                    if !near_corner {
                        assert_eq!(top_colour(f, p), top_colour(s, p), "at {p:?} of {pts:?}");
                        checked += 1;
                    }
                }
            }
            assert!(checked > 3000);
        }
        // translucent, concave or too thin: fill and strokes as before
        let thin = [[0.0, 0.0], [2.0, 0.0], [2.0, 0.05], [0.0, 0.05]];
        let concave = [[0.0, 0.0], [2.0, 0.0], [1.0, 0.5], [2.0, 1.0], [0.0, 1.0]];
        for (pts, c) in [
            (&thin[..], body),
            (&concave[..], body),
            (&thin[..2], body),
            (shapes[0], body.with_alpha(100)),
        ] {
            let mut a = Scene::default();
            a.outlined_fill(Layer::Bodies, pts, c, 0.1, line);
            let mut b = Scene::default();
            if pts.len() >= 3 {
                b.fill(Layer::Bodies, pts, c);
            }
            b.stroke_outline(Layer::Bodies, pts, 0.1, line);
            assert_eq!(a, b);
        }
    }

    #[test]
    fn fans_are_drawn_colour_by_colour_in_order_of_first_appearance() {
        let mut s = Scene::new(Rgba8::WHITE);
        let (a, b) = (Rgba8::rgb(1, 0, 0), Rgba8::rgb(0, 2, 0));
        for (k, c) in [a, b, a, b, a].into_iter().enumerate() {
            let x = k as f64;
            s.fan(Layer::Footprints, [x, 0.0], &[[x + 1.0, 0.0], [x, 1.0]], c);
        }
        let fp = s.layer(Layer::Footprints);
        assert_eq!(fp.fan_colours(), [a, b]);
        let mut tris = Vec::new();
        fp.fan_triangles(&mut tris);
        let centres: Vec<(f32, Rgba8)> =
            tris.chunks(3).map(|t| (t[0].pos[0], t[0].color)).collect();
        assert_eq!(centres, [(0.0, a), (2.0, a), (4.0, a), (1.0, b), (3.0, b)]);
        // many colours: still each in turn
        let mut many = Scene::new(Rgba8::WHITE);
        for k in 0..40u8 {
            let c = Rgba8::rgb(k % 20, 0, 0);
            many.fan(Layer::Footprints, [0.0, 0.0], &[[1.0, 0.0], [0.0, 1.0]], c);
        }
        let fp = many.layer(Layer::Footprints);
        assert_eq!(fp.fan_colours().len(), 20);
        tris.clear();
        fp.fan_triangles(&mut tris);
        let reds: Vec<u8> = tris.chunks(3).map(|t| t[0].color.0[0]).collect();
        let want: Vec<u8> = (0..20).flat_map(|r| [r, r]).collect();
        assert_eq!(reds, want);
    }

    #[test]
    fn primitives_land_in_their_layers() {
        let mut s = Scene::new(Rgba8::WHITE);
        s.fill_rect(Layer::Bodies, [0.0, 0.0], [1.0, 2.0], Rgba8::BLACK);
        s.outline(
            Layer::Overlay,
            &[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]],
            1.0,
            Rgba8::BLACK,
        );
        s.fan(
            Layer::Footprints,
            [0.0, 0.0],
            &[[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]],
            Rgba8::BLACK,
        );
        assert_eq!(s.layer(Layer::Bodies).triangles.len(), 6);
        assert_eq!(s.layer(Layer::Overlay).segments.len(), 3);
        let fp = s.layer(Layer::Footprints);
        assert_eq!((fp.fans.len(), fp.fan_points.len()), (1, 4));
        let mut tris = Vec::new();
        fp.fan_triangles(&mut tris);
        let pos: Vec<[f32; 2]> = tris.iter().map(|v| v.pos).collect();
        assert_eq!(
            pos,
            [
                [0.0, 0.0],
                [1.0, 0.0],
                [0.0, 1.0],
                [0.0, 0.0],
                [0.0, 1.0],
                [-1.0, 0.0]
            ]
        );
        assert_eq!(s.triangle_count(), 4);
        assert_eq!(s.segment_count(), 3);
        let (min, max) = s.bounds().unwrap();
        assert_eq!((min, max), ([-1.0, 0.0], [1.0, 2.0]));
        s.clear();
        assert!(s.bounds().is_none());
    }
}
