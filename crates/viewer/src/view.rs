//! The 2D camera: which world point is at the centre of the canvas, how many pixels a metre
//! takes and how the view is turned — the worldfile `window`'s `center`, `scale` and `rotate`
//! (stage-worldfile.md §11) — with the conversions between world and canvas pixels that
//! drawing, picking, panning and zooming share.

/// A top-down orthographic view of the world onto a canvas of `size` pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    /// World point at the canvas centre (m).
    pub center: [f64; 2],
    /// Pixels per metre.
    pub scale: f64,
    /// Rotation of the world on screen, counter-clockwise (rad): Stage's `rotate` yaw.
    pub yaw: f64,
    /// Canvas size in pixels.
    pub size: [f64; 2],
}

/// Zoom limits (pixels per metre): from a 100 km wide view to a 1 mm pixel.
pub const MIN_SCALE: f64 = 0.01;
/// See [`MIN_SCALE`].
pub const MAX_SCALE: f64 = 1000.0;

impl Default for View {
    fn default() -> Self {
        // Stage's window defaults: 400 × 300 pixels, 15 pixels per metre, centred on 0 0
        View {
            center: [0.0, 0.0],
            scale: 15.0,
            yaw: 0.0,
            size: [400.0, 300.0],
        }
    }
}

impl View {
    /// The view a worldfile `window` entity asks for. The pitch of `rotate` tilts Stage's 3D
    /// view; this viewer is top-down, so only the yaw is used.
    pub fn from_window(w: &worldfile::WindowSpec) -> View {
        let finite = |v: f64, d: f64| if v.is_finite() { v } else { d };
        View {
            center: [finite(w.center[0], 0.0), finite(w.center[1], 0.0)],
            scale: finite(w.scale, 15.0).clamp(MIN_SCALE, MAX_SCALE),
            yaw: finite(w.rotate[1], 0.0).to_radians(),
            size: [
                w.size[0].clamp(64, 8192) as f64,
                w.size[1].clamp(64, 8192) as f64,
            ],
        }
    }

    /// Canvas pixel (origin top-left, y down) of a world point.
    pub fn to_screen(&self, p: [f64; 2]) -> [f64; 2] {
        let (s, c) = self.yaw.sin_cos();
        let (dx, dy) = (p[0] - self.center[0], p[1] - self.center[1]);
        let (rx, ry) = (dx * c - dy * s, dx * s + dy * c);
        [
            self.size[0] / 2.0 + rx * self.scale,
            self.size[1] / 2.0 - ry * self.scale,
        ]
    }

    /// World point under a canvas pixel.
    pub fn to_world(&self, q: [f64; 2]) -> [f64; 2] {
        let rx = (q[0] - self.size[0] / 2.0) / self.scale;
        let ry = -(q[1] - self.size[1] / 2.0) / self.scale;
        let (s, c) = self.yaw.sin_cos();
        [
            self.center[0] + rx * c + ry * s,
            self.center[1] - rx * s + ry * c,
        ]
    }

    /// Metres per pixel.
    pub fn pixel(&self) -> f64 {
        1.0 / self.scale
    }

    /// Moves the view so the world follows the pointer by `(dx, dy)` pixels.
    pub fn pan_pixels(&mut self, dx: f64, dy: f64) {
        let a = self.to_world([self.size[0] / 2.0 - dx, self.size[1] / 2.0 - dy]);
        self.center = a;
    }

    /// Multiplies the scale by `factor` keeping the world point under canvas pixel `at` fixed
    /// (mouse-wheel zoom).
    pub fn zoom_at(&mut self, at: [f64; 2], factor: f64) {
        if !(factor.is_finite() && factor > 0.0) {
            return;
        }
        let before = self.to_world(at);
        self.scale = (self.scale * factor).clamp(MIN_SCALE, MAX_SCALE);
        let after = self.to_world(at);
        self.center[0] += before[0] - after[0];
        self.center[1] += before[1] - after[1];
    }

    /// Turns the view about the canvas centre by `da` radians.
    pub fn rotate(&mut self, da: f64) {
        if da.is_finite() {
            self.yaw = (self.yaw + da).rem_euclid(std::f64::consts::TAU);
        }
    }

    /// Fits the world box `[min, max]` in the canvas with a margin.
    pub fn fit(&mut self, min: [f64; 2], max: [f64; 2]) {
        let w = (max[0] - min[0]).max(1e-3);
        let h = (max[1] - min[1]).max(1e-3);
        self.center = [(min[0] + max[0]) / 2.0, (min[1] + max[1]) / 2.0];
        self.yaw = 0.0;
        self.scale = (0.95 * (self.size[0] / w).min(self.size[1] / h)).clamp(MIN_SCALE, MAX_SCALE);
    }

    /// The world-space axis-aligned box the canvas shows (a rotated view shows more).
    pub fn visible_world(&self) -> ([f64; 2], [f64; 2]) {
        let corners = [
            [0.0, 0.0],
            [self.size[0], 0.0],
            [self.size[0], self.size[1]],
            [0.0, self.size[1]],
        ];
        let mut min = [f64::INFINITY; 2];
        let mut max = [f64::NEG_INFINITY; 2];
        for c in corners {
            let w = self.to_world(c);
            for k in 0..2 {
                min[k] = min[k].min(w[k]);
                max[k] = max[k].max(w[k]);
            }
        }
        (min, max)
    }

    /// The affine map from world metres to clip space, as three columns of a 3×3 matrix
    /// (padded to `vec4`s for WGSL's uniform layout).
    pub fn clip_matrix(&self) -> [[f32; 4]; 3] {
        let (s, c) = self.yaw.sin_cos();
        let kx = 2.0 * self.scale / self.size[0];
        let ky = 2.0 * self.scale / self.size[1];
        // clip = K · R · (p − center)
        let (m00, m01, m10, m11) = (kx * c, -kx * s, ky * s, ky * c);
        let tx = -(m00 * self.center[0] + m01 * self.center[1]);
        let ty = -(m10 * self.center[0] + m11 * self.center[1]);
        [
            [m00 as f32, m10 as f32, 0.0, 0.0],
            [m01 as f32, m11 as f32, 0.0, 0.0],
            [tx as f32, ty as f32, 1.0, 0.0],
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: [f64; 2], b: [f64; 2]) -> bool {
        (a[0] - b[0]).abs() < 1e-9 && (a[1] - b[1]).abs() < 1e-9
    }

    #[test]
    fn screen_and_world_round_trip_with_rotation() {
        let v = View {
            center: [3.0, -2.0],
            scale: 20.0,
            yaw: 0.7,
            size: [640.0, 480.0],
        };
        for p in [[0.0, 0.0], [3.0, -2.0], [10.5, 4.25], [-7.0, 1.0]] {
            assert!(close(v.to_world(v.to_screen(p)), p));
        }
        assert!(close(v.to_screen([3.0, -2.0]), [320.0, 240.0]));
    }

    #[test]
    fn unrotated_axes_point_right_and_up() {
        let v = View {
            center: [0.0, 0.0],
            scale: 10.0,
            yaw: 0.0,
            size: [200.0, 100.0],
        };
        assert!(close(v.to_screen([1.0, 0.0]), [110.0, 50.0]));
        assert!(close(v.to_screen([0.0, 1.0]), [100.0, 40.0]));
        // a quarter turn counter-clockwise: +x now points up the screen
        let r = View {
            yaw: std::f64::consts::FRAC_PI_2,
            ..v
        };
        assert!(close(r.to_screen([1.0, 0.0]), [100.0, 40.0]));
    }

    #[test]
    fn clip_matrix_agrees_with_to_screen() {
        let v = View {
            center: [1.0, 2.0],
            scale: 33.0,
            yaw: -1.1,
            size: [300.0, 200.0],
        };
        let m = v.clip_matrix();
        for p in [[0.0, 0.0], [4.0, -1.0], [1.0, 2.0]] {
            let cx = m[0][0] as f64 * p[0] + m[1][0] as f64 * p[1] + m[2][0] as f64;
            let cy = m[0][1] as f64 * p[0] + m[1][1] as f64 * p[1] + m[2][1] as f64;
            let s = v.to_screen(p);
            let sx = (cx + 1.0) / 2.0 * v.size[0];
            let sy = (1.0 - cy) / 2.0 * v.size[1];
            assert!((sx - s[0]).abs() < 1e-3 && (sy - s[1]).abs() < 1e-3);
        }
    }

    #[test]
    fn zoom_keeps_the_point_under_the_pointer() {
        let mut v = View::default();
        let at = [50.0, 70.0];
        let w = v.to_world(at);
        v.zoom_at(at, 2.5);
        assert!((v.scale - 37.5).abs() < 1e-12);
        assert!(close(v.to_world(at), w));
        v.zoom_at(at, f64::NAN);
        assert!((v.scale - 37.5).abs() < 1e-12);
        v.zoom_at(at, 1e9);
        assert_eq!(v.scale, MAX_SCALE);
    }

    #[test]
    fn pan_moves_the_world_with_the_pointer() {
        let mut v = View::default();
        let p = [1.0, 1.0];
        let before = v.to_screen(p);
        v.pan_pixels(12.0, -5.0);
        let after = v.to_screen(p);
        assert!(close(
            [after[0] - before[0], after[1] - before[1]],
            [12.0, -5.0]
        ));
    }

    #[test]
    fn window_spec_maps_to_the_view() {
        let w = worldfile::WindowSpec {
            size: [635, 666],
            center: [-7.5, 3.0],
            scale: 36.995,
            rotate: [0.0, 90.0],
            ..Default::default()
        };
        let v = View::from_window(&w);
        assert_eq!(v.size, [635.0, 666.0]);
        assert_eq!(v.center, [-7.5, 3.0]);
        assert!((v.yaw - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        let d = View::from_window(&worldfile::WindowSpec::default());
        assert_eq!(d, View::default());
    }

    #[test]
    fn fit_shows_the_whole_box() {
        let mut v = View::default();
        v.fit([-8.0, -8.0], [8.0, 8.0]);
        let (min, max) = v.visible_world();
        assert!(min[0] <= -8.0 && min[1] <= -8.0 && max[0] >= 8.0 && max[1] >= 8.0);
    }
}
