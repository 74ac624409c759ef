//! `graphics2d` and `graphics3d`: what clients draw on a model (player-protocol.md §6.11,
//! §6.12). Stage renders each client's list in the model's frame; here the lists are kept in
//! [`Drawings`] for a world window to render, cleared by CLEAR and discarded when the client
//! unsubscribes. No data, no requests.

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};

use player_proto::{
    Body, Graphics2dCmd, Graphics2dMsg, Graphics3dCmd, Graphics3dMsg, InterfaceCode,
};
use stage_sim::{Color, ModelId};

use super::{Interface, Sender, Writing};
use crate::driver::ClientId;

/// A `graphics2d` or `graphics3d` device: bound to the named model itself, it keeps what each
/// client draws in [`Drawings`] until the client clears it or unsubscribes.
#[derive(Debug, Default)]
pub(super) struct Graphics;

impl Interface for Graphics {
    /// A figure (or CLEAR) from a client; a command that came from no client draws nothing.
    fn command(&mut self, b: &mut Writing<'_>, sender: &Sender<'_>, body: &Body) -> bool {
        match sender.client {
            Some(client) => command(sender.drawings, b.model, client, body),
            None => false,
        }
    }

    fn client_unsubscribed(&mut self, drawings: &SharedDrawings, left: DrawingKey) {
        forget(drawings, &left);
    }
}

/// Most figures one client keeps on one model: a client that draws every cycle without
/// clearing loses its oldest figures instead of growing the server without bound.
pub const MAX_FIGURES: usize = 4096;

/// One drawing command, in the bound model's frame (m, rad).
#[derive(Clone, Debug, PartialEq)]
pub enum Figure {
    /// 2D points.
    Points {
        /// Positions.
        points: Vec<[f64; 2]>,
        /// Colour.
        color: Color,
    },
    /// A 2D polyline.
    Polyline {
        /// Vertices in order.
        points: Vec<[f64; 2]>,
        /// Colour.
        color: Color,
    },
    /// A 2D polygon, outlined and optionally filled.
    Polygon {
        /// Vertices in order.
        points: Vec<[f64; 2]>,
        /// Outline colour.
        color: Color,
        /// Fill colour, when filled.
        fill: Option<Color>,
    },
    /// 3D primitives with an OpenGL mode (`PLAYER_DRAW_POINTS` 0 … `PLAYER_DRAW_POLYGON` 9).
    Draw3d {
        /// The draw mode.
        mode: u32,
        /// Vertices.
        points: Vec<[f64; 3]>,
        /// Colour.
        color: Color,
    },
    /// Translates the following 3D figures.
    Translate([f64; 3]),
    /// Rotates the following 3D figures by `angle` (rad) about `axis`.
    Rotate {
        /// Angle (rad).
        angle: f64,
        /// Axis.
        axis: [f64; 3],
    },
    /// Pushes the 3D transform.
    Push,
    /// Pops the 3D transform.
    Pop,
}

/// The figures of one client on one model through one interface.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct DrawingKey {
    /// The model drawn on.
    pub model: ModelId,
    /// `graphics2d` or `graphics3d`.
    pub interface: InterfaceCode,
    /// The client that drew.
    pub client: ClientId,
}

/// Every client's figures.
#[derive(Clone, Debug, Default)]
pub struct Drawings {
    lists: BTreeMap<DrawingKey, Vec<Figure>>,
}

impl Drawings {
    /// Every list, in (model, interface, client) order.
    pub fn iter(&self) -> impl Iterator<Item = (&DrawingKey, &[Figure])> {
        self.lists.iter().map(|(k, v)| (k, v.as_slice()))
    }

    /// The figures drawn on `model`, all clients and both interfaces.
    pub fn on_model(&self, model: ModelId) -> impl Iterator<Item = &Figure> {
        self.lists
            .iter()
            .filter(move |(k, _)| k.model == model)
            .flat_map(|(_, v)| v.iter())
    }

    /// Number of figures kept.
    pub fn len(&self) -> usize {
        self.lists.values().map(Vec::len).sum()
    }

    /// True when nothing is drawn.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// The drawings shared between the stage driver and a window.
pub type SharedDrawings = Arc<Mutex<Drawings>>;

/// Player's colour (alpha 0 = opaque) as a Stage colour (opacity = 1 − alpha/255).
fn color(c: &player_proto::Color) -> Color {
    Color {
        r: f64::from(c.red) / 255.0,
        g: f64::from(c.green) / 255.0,
        b: f64::from(c.blue) / 255.0,
        a: 1.0 - f64::from(c.alpha) / 255.0,
    }
}

fn pts2(p: &[player_proto::Point2d]) -> Vec<[f64; 2]> {
    p.iter().map(|p| [p.px, p.py]).collect()
}

/// Applies one graphics command from `client` on `model`; false for commands that are not
/// graphics commands.
fn command(drawings: &SharedDrawings, model: ModelId, client: ClientId, body: &Body) -> bool {
    let (interface, figure) = match body {
        Body::Graphics2d(Graphics2dMsg::Cmd(c)) => (
            InterfaceCode::GRAPHICS2D,
            match c {
                Graphics2dCmd::Clear => None,
                Graphics2dCmd::Points(p) => Some(Figure::Points {
                    points: pts2(&p.points),
                    color: color(&p.color),
                }),
                Graphics2dCmd::Polyline(p) => Some(Figure::Polyline {
                    points: pts2(&p.points),
                    color: color(&p.color),
                }),
                Graphics2dCmd::Polygon(p) => Some(Figure::Polygon {
                    points: pts2(&p.points),
                    color: color(&p.color),
                    // libplayerc leaves fill_color uninitialised when not filled.
                    fill: (p.filled != 0).then(|| color(&p.fill_color)),
                }),
            },
        ),
        Body::Graphics3d(Graphics3dMsg::Cmd(c)) => (
            InterfaceCode::GRAPHICS3D,
            match c {
                Graphics3dCmd::Clear => None,
                Graphics3dCmd::Draw(d) => Some(Figure::Draw3d {
                    mode: d.draw_mode,
                    points: d.points.iter().map(|p| [p.px, p.py, p.pz]).collect(),
                    color: color(&d.color),
                }),
                Graphics3dCmd::Translate(t) => Some(Figure::Translate([t.x, t.y, t.z])),
                Graphics3dCmd::Rotate(r) => Some(Figure::Rotate {
                    angle: r.a,
                    axis: [r.x, r.y, r.z],
                }),
                Graphics3dCmd::Push => Some(Figure::Push),
                Graphics3dCmd::Pop => Some(Figure::Pop),
            },
        ),
        _ => return false,
    };
    let key = DrawingKey {
        model,
        interface,
        client,
    };
    let mut d = drawings.lock().unwrap_or_else(|p| p.into_inner());
    match figure {
        None => {
            d.lists.remove(&key);
        }
        Some(f) => {
            let list = d.lists.entry(key).or_default();
            if list.len() >= MAX_FIGURES {
                list.remove(0);
            }
            list.push(f);
        }
    }
    true
}

/// Discards what a client drew on a model through an interface (it unsubscribed).
fn forget(drawings: &SharedDrawings, key: &DrawingKey) {
    drawings
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .lists
        .remove(key);
}

#[cfg(test)]
mod tests {
    use super::*;
    use player_proto::{Graphics2dCmdPoints, Point2d};

    #[test]
    fn lists_are_per_client_bounded_and_cleared() {
        let d = SharedDrawings::default();
        let mut world = stage_sim::WorldDesc::default();
        world.add(
            stage_sim::ModelDesc::new("drawn on", stage_sim::KindDesc::Model),
            None,
        );
        let world = stage_sim::World::from_desc(&world, 1).unwrap();
        let m = world.model_by_name("drawn on").unwrap();
        let points = |n| {
            Body::from(Graphics2dCmd::Points(Graphics2dCmdPoints {
                points: vec![Point2d { px: n, py: 0.0 }],
                color: player_proto::Color {
                    alpha: 0,
                    red: 255,
                    green: 0,
                    blue: 0,
                },
            }))
        };
        assert!(command(&d, m, ClientId(1), &points(1.0)));
        assert!(command(&d, m, ClientId(2), &points(2.0)));
        assert_eq!(d.lock().unwrap().on_model(m).count(), 2);
        let first = d.lock().unwrap().on_model(m).next().cloned().unwrap();
        assert_eq!(
            first,
            Figure::Points {
                points: vec![[1.0, 0.0]],
                color: Color {
                    r: 1.0,
                    g: 0.0,
                    b: 0.0,
                    a: 1.0
                }
            }
        );
        for i in 0..MAX_FIGURES + 10 {
            command(&d, m, ClientId(1), &points(i as f64));
        }
        assert_eq!(d.lock().unwrap().len(), MAX_FIGURES + 1);
        assert!(command(&d, m, ClientId(1), &Graphics2dCmd::Clear.into()));
        assert_eq!(d.lock().unwrap().len(), 1);
        forget(
            &d,
            &DrawingKey {
                model: m,
                interface: InterfaceCode::GRAPHICS2D,
                client: ClientId(2),
            },
        );
        assert!(d.lock().unwrap().is_empty());
        assert!(!command(
            &d,
            m,
            ClientId(1),
            &Body::from(player_proto::SpeechCmd::Say(player_proto::SpeechCmdSay {
                string: "x".into()
            }))
        ));
    }
}
