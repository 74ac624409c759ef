//! Subscriptions and the per-model API: poses, colours, commands, sensor data, digests.

use crate::desc::Color;
use crate::error::{Error, Result};
use crate::geom::Aabb;
use crate::models::KindState;
use crate::models::actuator::{ActuatorData, ActuatorMode};
use crate::models::blinkenlight::Blinkenlight;
use crate::models::blobfinder::BlobfinderData;
use crate::models::camera::CameraImage;
use crate::models::fiducial::FiducialData;
use crate::models::gripper::{GripperCmd, GripperData};
use crate::models::lightindicator::Lightindicator;
use crate::models::position::{PositionData, PositionModel};
use crate::models::ranger::RangerData;
use crate::pose::Pose;
use crate::raster::Raster;
use crate::space::{Body, RayHit, RayQuery, Space};

use super::*;

impl World {
    // ----- subscriptions -----------------------------------------------------------------

    /// Adds a subscription. The first one starts the model: it updates every
    /// `update_interval` from now on (only subscribed models update, spec §5.4).
    pub fn subscribe(&mut self, m: ModelId) {
        let now = self.sim_time;
        let interval = self.nodes[m.index()].update_interval_us;
        let st = &mut self.states[m.index()];
        st.subs += 1;
        if st.subs == 1 {
            st.next_update = now + interval;
        }
    }

    /// Removes a subscription; the last one shuts the model down (position models stop,
    /// actuators drop their goal, sensors clear their data).
    pub fn unsubscribe(&mut self, m: ModelId) {
        let st = &mut self.states[m.index()];
        if st.subs == 0 {
            return;
        }
        st.subs -= 1;
        if st.subs == 0 {
            st.kind.shutdown();
        }
    }

    /// Current subscription count.
    pub fn subscriptions(&self, m: ModelId) -> u32 {
        self.states[m.index()].subs
    }

    /// Sim time of the model's last update, if any.
    pub fn last_update(&self, m: ModelId) -> Option<u64> {
        self.states[m.index()].updated_at
    }

    // ----- poses and colours -------------------------------------------------------------

    /// Pose in the parent frame.
    pub fn pose(&self, m: ModelId) -> Pose {
        self.poses[m.index()]
    }

    /// Sets the pose in the parent frame (the simulation interface; no collision test, as in
    /// Stage).
    pub fn set_pose(&mut self, m: ModelId, p: Pose) {
        self.poses[m.index()] = Pose::new(p.x, p.y, p.z, p.a);
        self.refresh_subtree(m);
    }

    /// Global pose of the model's pose point (with child stacking).
    pub fn global_pose(&self, m: ModelId) -> Pose {
        self.globals[m.index()]
    }

    /// The model's colour.
    pub fn color(&self, m: ModelId) -> Color {
        self.colors[m.index()]
    }

    /// Recolours the model (blocks without their own colour follow).
    pub fn set_color(&mut self, m: ModelId, c: Color) {
        self.colors[m.index()] = c;
    }

    /// Colour of block `b` of model `m`.
    pub fn block_color(&self, m: ModelId, b: usize) -> Color {
        self.nodes[m.index()].blocks[b]
            .color
            .unwrap_or(self.colors[m.index()])
    }

    /// The model's body in world coordinates (for drawing; borrowed, not copied).
    pub fn body(&self, m: ModelId) -> &Body {
        self.space.body(m)
    }

    /// The model's own blocks (not its children's), as they are now, rasterised onto square
    /// cells of `cell` metres ([`Raster`], for serving a model as a grid map). The grid spans
    /// the world-axis-aligned bounding box of the model's footprint (its `size` rectangle at
    /// its current pose), rounded up to whole cells from its lower-left corner. `None` when
    /// `cell` is not a positive length or the grid would have more than `max_cells` cells.
    pub fn rasterize(&self, m: ModelId, cell: f64, max_cells: usize) -> Option<Raster> {
        if !(cell > 0.0 && cell.is_finite()) {
            return None;
        }
        let node = &self.nodes[m.index()];
        let frame = self.globals[m.index()].compose(&node.origin);
        let [hx, hy] = [node.size[0] / 2.0, node.size[1] / 2.0];
        let mut bb = Aabb::EMPTY;
        for (x, y) in [(-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy)] {
            let (wx, wy) = frame.transform_xy(x, y);
            bb.add([wx, wy]);
        }
        // An extent of a whole number of cells (up to rounding) gets no extra sliver of a cell.
        let count = |len: f64| (len / cell - crate::raster::SLIVER).ceil().max(0.0);
        let (w, h) = (count(bb.max[0] - bb.min[0]), count(bb.max[1] - bb.min[1]));
        if w * h > max_cells as f64 {
            return None;
        }
        let mut raster = Raster::new(bb.min, cell, w as usize, h as usize);
        let body = self.space.body(m);
        for b in 0..body.blocks.len() {
            raster.fill_polygon(body.block_pts(b));
        }
        Some(raster)
    }

    /// The spatial engine (for viewers and tools that cast their own rays).
    pub fn space(&self) -> &Space {
        &self.space
    }

    /// Casts a ray from a world pose; models in `exclude`'s tree are ignored.
    pub fn raycast(&self, q: &RayQuery, exclude: Option<ModelId>) -> Option<RayHit> {
        let root = exclude.map(|m| self.nodes[m.index()].root);
        self.space
            .raycast(q, |h| Some(self.nodes[h.index()].root) != root)
    }

    /// Speech-bubble text.
    pub fn said(&self, m: ModelId) -> &str {
        &self.says[m.index()]
    }

    /// Sets the speech-bubble text (`say`).
    pub fn say(&mut self, m: ModelId, text: &str) {
        self.says[m.index()] = text.to_string();
    }

    // ----- position ----------------------------------------------------------------------

    pub(super) fn position_mut(&mut self, m: ModelId) -> Result<&mut PositionModel> {
        match self.states.get_mut(m.index()).map(|s| &mut s.kind) {
            Some(KindState::Position(p)) => Ok(p),
            _ => Err(Error::BadModel {
                id: m.0,
                msg: "not a position model".into(),
            }),
        }
    }

    /// Velocity command (Player CMD_VEL): m/s, m/s, rad/s.
    pub fn position_cmd_vel(&mut self, m: ModelId, vx: f64, vy: f64, va: f64) -> Result<()> {
        self.position_mut(m)?.command_velocity(vx, vy, va);
        Ok(())
    }

    /// Position command in the odometry frame (Player CMD_POS).
    pub fn position_cmd_pos(&mut self, m: ModelId, x: f64, y: f64, a: f64) -> Result<()> {
        self.position_mut(m)?.command_position(x, y, a);
        Ok(())
    }

    /// Car command (Player CMD_CAR): speed and steering angle (turn rate for `diff` drive).
    pub fn position_cmd_car(&mut self, m: ModelId, speed: f64, angle: f64) -> Result<()> {
        self.position_mut(m)?.command_velocity(speed, 0.0, angle);
        Ok(())
    }

    /// Acceleration command (API only).
    pub fn position_cmd_accel(&mut self, m: ModelId, ax: f64, ay: f64, aa: f64) -> Result<()> {
        self.position_mut(m)?.command_acceleration(ax, ay, aa);
        Ok(())
    }

    /// Odometry pose, velocity and stall as last updated.
    pub fn position_state(&self, m: ModelId) -> Option<&PositionData> {
        match &self.states.get(m.index())?.kind {
            KindState::Position(p) => Some(&p.data),
            _ => None,
        }
    }

    /// The whole position model (configuration, goal, odometry error).
    pub fn position_model(&self, m: ModelId) -> Option<&PositionModel> {
        match &self.states.get(m.index())?.kind {
            KindState::Position(p) => Some(p),
            _ => None,
        }
    }

    /// Player SET_ODOM.
    pub fn set_odom(&mut self, m: ModelId, p: Pose) -> Result<()> {
        self.position_mut(m)?.set_odom(p);
        Ok(())
    }

    /// Player RESET_ODOM.
    pub fn reset_odom(&mut self, m: ModelId) -> Result<()> {
        self.position_mut(m)?.set_odom(Pose::ZERO);
        Ok(())
    }

    // ----- sensors -----------------------------------------------------------------------

    /// Ranger configuration and latest scans.
    pub fn ranger_scans(&self, m: ModelId) -> Option<&RangerData> {
        match &self.states.get(m.index())?.kind {
            KindState::Ranger(r) => Some(r),
            _ => None,
        }
    }

    /// Blobfinder data.
    pub fn blobfinder_blobs(&self, m: ModelId) -> Option<&BlobfinderData> {
        match &self.states.get(m.index())?.kind {
            KindState::Blobfinder(b) => Some(&b.data),
            _ => None,
        }
    }

    /// Blobfinder configuration.
    pub fn blobfinder_config(&self, m: ModelId) -> Option<&crate::desc::BlobfinderDesc> {
        match &self.states.get(m.index())?.kind {
            KindState::Blobfinder(b) => Some(&b.cfg),
            _ => None,
        }
    }

    /// Fiducial detections.
    pub fn fiducials(&self, m: ModelId) -> Option<&FiducialData> {
        match &self.states.get(m.index())?.kind {
            KindState::Fiducial(f) => Some(&f.data),
            _ => None,
        }
    }

    /// Fiducial-finder configuration.
    pub fn fiducial_config(&self, m: ModelId) -> Option<&crate::desc::FiducialDesc> {
        match &self.states.get(m.index())?.kind {
            KindState::Fiducial(f) => Some(&f.cfg),
            _ => None,
        }
    }

    /// The model's own `fiducial_return` (Player fiducial GET_ID).
    pub fn fiducial_id(&self, m: ModelId) -> i32 {
        self.nodes[m.index()].returns.fiducial
    }

    /// Sets the model's own `fiducial_return` (Player fiducial SET_ID).
    pub fn set_fiducial_id(&mut self, m: ModelId, id: i32) {
        self.nodes[m.index()].returns.fiducial = id;
        self.fiducial_targets = (0..self.nodes.len() as u32)
            .filter(|&i| self.nodes[i as usize].returns.fiducial != 0)
            .map(ModelId)
            .collect();
    }

    /// Gripper state.
    pub fn gripper_state(&self, m: ModelId) -> Option<&GripperData> {
        match &self.states.get(m.index())?.kind {
            KindState::Gripper(g) => Some(&g.data),
            _ => None,
        }
    }

    /// Gripper command (persists until replaced).
    pub fn gripper_cmd(&mut self, m: ModelId, cmd: GripperCmd) -> Result<()> {
        match self.states.get_mut(m.index()).map(|s| &mut s.kind) {
            Some(KindState::Gripper(g)) => {
                g.cmd = cmd;
                Ok(())
            }
            _ => Err(Error::BadModel {
                id: m.0,
                msg: "not a gripper".into(),
            }),
        }
    }

    /// Camera image.
    pub fn camera_image(&self, m: ModelId) -> Option<&CameraImage> {
        match &self.states.get(m.index())?.kind {
            KindState::Camera(c) => Some(&c.image),
            _ => None,
        }
    }

    /// Actuator data.
    pub fn actuator(&self, m: ModelId) -> Option<&ActuatorData> {
        match &self.states.get(m.index())?.kind {
            KindState::Actuator(a) => Some(&a.data),
            _ => None,
        }
    }

    /// Actuator command: position (`position = true`) or speed goal.
    pub fn actuator_cmd(&mut self, m: ModelId, position: bool, goal: f64) -> Result<()> {
        match self.states.get_mut(m.index()).map(|s| &mut s.kind) {
            Some(KindState::Actuator(a)) => {
                a.mode = if position {
                    ActuatorMode::Position
                } else {
                    ActuatorMode::Velocity
                };
                a.goal = goal;
                Ok(())
            }
            _ => Err(Error::BadModel {
                id: m.0,
                msg: "not an actuator".into(),
            }),
        }
    }

    /// Light state of a blinkenlight or light indicator.
    pub fn light_on(&self, m: ModelId) -> Option<bool> {
        match &self.states.get(m.index())?.kind {
            KindState::Blinkenlight(Blinkenlight { on })
            | KindState::Lightindicator(Lightindicator { on }) => Some(*on),
            _ => None,
        }
    }

    /// Switches a light indicator.
    pub fn set_light(&mut self, m: ModelId, value: bool) {
        if let Some(
            KindState::Lightindicator(Lightindicator { on })
            | KindState::Blinkenlight(Blinkenlight { on }),
        ) = self.states.get_mut(m.index()).map(|s| &mut s.kind)
        {
            *on = value;
        }
    }

    /// A 64-bit digest of the whole simulated state: the clock, and per model its pose,
    /// colour, speech, subscription schedule and its type's state (sensor data, commands, goals,
    /// lights). Equal digests mean equal states (the determinism tests and benches compare them).
    pub fn state_digest(&self) -> u64 {
        let mut d = crate::digest::Digest::new();
        d.u64(self.sim_time);
        for (i, st) in self.states.iter().enumerate() {
            d.pose(&self.poses[i]);
            d.color(&self.colors[i]);
            d.bytes(self.says[i].as_bytes());
            d.u64(st.next_update);
            d.u64(st.updated_at.unwrap_or(u64::MAX));
            st.kind.digest(&mut d);
        }
        d.finish()
    }
}
