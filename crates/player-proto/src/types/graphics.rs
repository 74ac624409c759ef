//! The `graphics2d` (55) and `graphics3d` (58) interfaces.

use super::{Color, Point2d, Point3d};

xdr_struct! {
    /// Points to draw.
    pub struct Graphics2dCmdPoints = "player_graphics2d_cmd_points_t" {
        /// Points (m, in the device frame).
        points: Vec<Point2d>,
        /// Colour.
        color: Color,
    }

    /// A polyline to draw.
    pub struct Graphics2dCmdPolyline = "player_graphics2d_cmd_polyline_t" {
        /// Vertices.
        points: Vec<Point2d>,
        /// Colour.
        color: Color,
    }

    /// A polygon to draw.
    pub struct Graphics2dCmdPolygon = "player_graphics2d_cmd_polygon_t" {
        /// Vertices.
        points: Vec<Point2d>,
        /// Outline colour.
        color: Color,
        /// Fill colour (uninitialised by libplayerc when not filled).
        fill_color: Color,
        /// Filled or not.
        filled: u8,
    }

    /// Primitives to draw (`PLAYER_DRAW_*` mode).
    pub struct Graphics3dCmdDraw = "player_graphics3d_cmd_draw_t" {
        /// Draw mode.
        draw_mode: u32,
        /// Vertices.
        points: Vec<Point3d>,
        /// Colour.
        color: Color,
    }

    /// Translate the drawing frame.
    pub struct Graphics3dCmdTranslate = "player_graphics3d_cmd_translate_t" {
        /// Along x (m).
        x: f64,
        /// Along y (m).
        y: f64,
        /// Along z (m).
        z: f64,
    }

    /// Rotate the drawing frame by `a` about (x, y, z).
    pub struct Graphics3dCmdRotate = "player_graphics3d_cmd_rotate_t" {
        /// Angle (rad).
        a: f64,
        /// Axis x.
        x: f64,
        /// Axis y.
        y: f64,
        /// Axis z.
        z: f64,
    }
}
