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

/// What the position calls need.
const POSITION: &str = "a position model";
/// What the light calls need.
const LIGHT: &str = "a blinkenlight or light indicator";

impl World {
    // ----- subscriptions -----------------------------------------------------------------

    /// Adds a subscription. The first one starts the model: it updates every
    /// `update_interval` from now on (only subscribed models update, spec §5.4).
    pub fn subscribe(&mut self, m: ModelId) -> Result<()> {
        let i = self.check(m)?;
        let now = self.sim_time;
        let interval = self.nodes[i].update_interval_us;
        let st = &mut self.states[i];
        st.subs += 1;
        if st.subs == 1 {
            st.next_update = now + interval;
        }
        Ok(())
    }

    /// Removes a subscription; the last one shuts the model down (position models stop,
    /// actuators drop their goal, sensors clear their data).
    pub fn unsubscribe(&mut self, m: ModelId) -> Result<()> {
        let i = self.check(m)?;
        let st = &mut self.states[i];
        if st.subs == 0 {
            return Ok(());
        }
        st.subs -= 1;
        if st.subs == 0 {
            st.kind.shutdown();
        }
        Ok(())
    }

    /// Current subscription count.
    pub fn subscriptions(&self, m: ModelId) -> Result<u32> {
        Ok(self.states[self.check(m)?].subs)
    }

    /// Sim time of the model's last update, if any.
    pub fn last_update(&self, m: ModelId) -> Result<Option<u64>> {
        Ok(self.states[self.check(m)?].updated_at)
    }

    // ----- poses and colours -------------------------------------------------------------

    /// Pose in the parent frame.
    pub fn pose(&self, m: ModelId) -> Result<Pose> {
        Ok(self.poses[self.check(m)?])
    }

    /// Sets the pose in the parent frame (the simulation interface; no collision test, as in
    /// Stage).
    pub fn set_pose(&mut self, m: ModelId, p: Pose) -> Result<()> {
        let i = self.check(m)?;
        self.poses[i] = Pose::new(p.x, p.y, p.z, p.a);
        self.refresh_subtree(m);
        Ok(())
    }

    /// Global pose of the model's pose point (with child stacking).
    pub fn global_pose(&self, m: ModelId) -> Result<Pose> {
        Ok(self.globals[self.check(m)?])
    }

    /// The model's colour.
    pub fn color(&self, m: ModelId) -> Result<Color> {
        Ok(self.colors[self.check(m)?])
    }

    /// Recolours the model (blocks without their own colour follow).
    pub fn set_color(&mut self, m: ModelId, c: Color) -> Result<()> {
        let i = self.check(m)?;
        self.colors[i] = c;
        Ok(())
    }

    /// Colour of block `b` of model `m`; [`Error::NoBlock`] when the model has no block `b`.
    pub fn block_color(&self, m: ModelId, b: usize) -> Result<Color> {
        let i = self.check(m)?;
        let blocks = &self.nodes[i].blocks;
        let block = blocks.get(b).ok_or(Error::NoBlock {
            id: m,
            block: b,
            blocks: blocks.len(),
        })?;
        Ok(block.color.unwrap_or(self.colors[i]))
    }

    /// The model's body in world coordinates (for drawing; borrowed, not copied).
    pub fn body(&self, m: ModelId) -> Result<&Body> {
        self.check(m)?;
        Ok(self.space.body(m))
    }

    /// Whether the model's body is still registered as static (it never moved; floorplans and
    /// everything outside robots' trees until a gripper or `set_pose` moves it).
    pub fn is_static(&self, m: ModelId) -> Result<bool> {
        self.check(m)?;
        Ok(self.space.is_static(m))
    }

    /// The model's own blocks (not its children's), as they are now, rasterised onto square
    /// cells of `cell` metres ([`Raster`], for serving a model as a grid map). The grid spans
    /// the world-axis-aligned bounding box of the model's footprint (its `size` rectangle at
    /// its current pose), rounded up to whole cells from its lower-left corner. `None` when
    /// `cell` is not a positive length or the grid would have more than `max_cells` cells.
    pub fn rasterize(&self, m: ModelId, cell: f64, max_cells: usize) -> Result<Option<Raster>> {
        let i = self.check(m)?;
        if !(cell > 0.0 && cell.is_finite()) {
            return Ok(None);
        }
        let node = &self.nodes[i];
        let frame = self.globals[i].compose(&node.origin);
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
            return Ok(None);
        }
        let mut raster = Raster::new(bb.min, cell, w as usize, h as usize);
        let body = self.space.body(m);
        for b in 0..body.blocks.len() {
            raster.fill_polygon(body.block_pts(b));
        }
        Ok(Some(raster))
    }

    /// The spatial engine (for viewers and tools that cast their own rays).
    pub fn space(&self) -> &Space {
        &self.space
    }

    /// Casts a ray from a world pose; models in `exclude`'s tree are ignored.
    pub fn raycast(&self, q: &RayQuery, exclude: Option<ModelId>) -> Result<Option<RayHit>> {
        let root = match exclude {
            Some(m) => Some(self.nodes[self.check(m)?].root),
            None => None,
        };
        Ok(self
            .space
            .raycast(q, |h| Some(self.nodes[h.index()].root) != root))
    }

    /// Speech-bubble text.
    pub fn said(&self, m: ModelId) -> Result<&str> {
        Ok(&self.says[self.check(m)?])
    }

    /// Sets the speech-bubble text (`say`).
    pub fn say(&mut self, m: ModelId, text: &str) -> Result<()> {
        let i = self.check(m)?;
        self.says[i] = text.to_string();
        Ok(())
    }

    // ----- position ----------------------------------------------------------------------

    /// Velocity command (Player CMD_VEL): m/s, m/s, rad/s.
    pub fn position_cmd_vel(&mut self, m: ModelId, vx: f64, vy: f64, va: f64) -> Result<()> {
        typed!(self.kind_mut(m), POSITION, KindState::Position(p) => p.command_velocity(vx, vy, va))
    }

    /// Position command in the odometry frame (Player CMD_POS).
    pub fn position_cmd_pos(&mut self, m: ModelId, x: f64, y: f64, a: f64) -> Result<()> {
        typed!(self.kind_mut(m), POSITION, KindState::Position(p) => p.command_position(x, y, a))
    }

    /// Car command (Player CMD_CAR): speed and steering angle (turn rate for `diff` drive).
    pub fn position_cmd_car(&mut self, m: ModelId, speed: f64, angle: f64) -> Result<()> {
        typed!(self.kind_mut(m), POSITION, KindState::Position(p) => p.command_velocity(speed, 0.0, angle))
    }

    /// Acceleration command (API only).
    pub fn position_cmd_accel(&mut self, m: ModelId, ax: f64, ay: f64, aa: f64) -> Result<()> {
        typed!(self.kind_mut(m), POSITION, KindState::Position(p) => p.command_acceleration(ax, ay, aa))
    }

    /// Odometry pose, velocity and stall as last updated.
    pub fn position_state(&self, m: ModelId) -> Result<&PositionData> {
        typed!(self.kind(m), POSITION, KindState::Position(p) => &p.data)
    }

    /// The whole position model (configuration, goal, odometry error).
    pub fn position_model(&self, m: ModelId) -> Result<&PositionModel> {
        typed!(self.kind(m), POSITION, KindState::Position(p) => p)
    }

    /// Player SET_ODOM.
    pub fn set_odom(&mut self, m: ModelId, p: Pose) -> Result<()> {
        typed!(self.kind_mut(m), POSITION, KindState::Position(model) => model.set_odom(p))
    }

    /// Sets or clears the stall flag (Stage's `SetStall`): a teleport or reset out of a
    /// collision clears it, since the flag is otherwise kept while the robot stands still.
    pub fn set_stall(&mut self, m: ModelId, stall: bool) -> Result<()> {
        typed!(self.kind_mut(m), POSITION, KindState::Position(p) => p.set_stall(stall))
    }

    /// Player RESET_ODOM.
    pub fn reset_odom(&mut self, m: ModelId) -> Result<()> {
        typed!(self.kind_mut(m), POSITION, KindState::Position(p) => p.set_odom(Pose::ZERO))
    }

    // ----- sensors -----------------------------------------------------------------------

    /// Ranger configuration and latest scans.
    pub fn ranger_scans(&self, m: ModelId) -> Result<&RangerData> {
        typed!(self.kind(m), "a ranger", KindState::Ranger(r) => r)
    }

    /// Blobfinder data.
    pub fn blobfinder_blobs(&self, m: ModelId) -> Result<&BlobfinderData> {
        typed!(self.kind(m), "a blobfinder", KindState::Blobfinder(b) => &b.data)
    }

    /// Blobfinder configuration.
    pub fn blobfinder_config(&self, m: ModelId) -> Result<&crate::desc::BlobfinderDesc> {
        typed!(self.kind(m), "a blobfinder", KindState::Blobfinder(b) => &b.cfg)
    }

    /// Camera configuration (resolution, clipping range, fields of view, pan and tilt): what
    /// a host needs to describe the images, e.g. a pinhole model for ROS's CameraInfo.
    pub fn camera_config(&self, m: ModelId) -> Result<&crate::desc::CameraDesc> {
        typed!(self.kind(m), "a camera", KindState::Camera(c) => &c.cfg)
    }

    /// Fiducial detections.
    pub fn fiducials(&self, m: ModelId) -> Result<&FiducialData> {
        typed!(self.kind(m), "a fiducial finder", KindState::Fiducial(f) => &f.data)
    }

    /// Fiducial-finder configuration.
    pub fn fiducial_config(&self, m: ModelId) -> Result<&crate::desc::FiducialDesc> {
        typed!(self.kind(m), "a fiducial finder", KindState::Fiducial(f) => &f.cfg)
    }

    /// The model's own `fiducial_return` (Player fiducial GET_ID).
    pub fn fiducial_id(&self, m: ModelId) -> Result<i32> {
        Ok(self.returns[self.check(m)?].fiducial)
    }

    /// Sets the model's own `fiducial_return` (Player fiducial SET_ID).
    pub fn set_fiducial_id(&mut self, m: ModelId, id: i32) -> Result<()> {
        let i = self.check(m)?;
        self.returns[i].fiducial = id;
        self.fiducial_targets = super::tree::fiducial_targets(&self.returns);
        Ok(())
    }

    /// Gripper state.
    pub fn gripper_state(&self, m: ModelId) -> Result<&GripperData> {
        typed!(self.kind(m), "a gripper", KindState::Gripper(g) => &g.data)
    }

    /// Gripper command (persists until replaced).
    pub fn gripper_cmd(&mut self, m: ModelId, cmd: GripperCmd) -> Result<()> {
        typed!(self.kind_mut(m), "a gripper", KindState::Gripper(g) => g.cmd = cmd)
    }

    /// Camera image.
    pub fn camera_image(&self, m: ModelId) -> Result<&CameraImage> {
        typed!(self.kind(m), "a camera", KindState::Camera(c) => &c.image)
    }

    /// Actuator data.
    pub fn actuator(&self, m: ModelId) -> Result<&ActuatorData> {
        typed!(self.kind(m), "an actuator", KindState::Actuator(a) => &a.data)
    }

    /// Actuator command: position (`position = true`) or speed goal.
    pub fn actuator_cmd(&mut self, m: ModelId, position: bool, goal: f64) -> Result<()> {
        let mode = if position {
            ActuatorMode::Position
        } else {
            ActuatorMode::Velocity
        };
        typed!(self.kind_mut(m), "an actuator", KindState::Actuator(a) => {
            a.mode = mode;
            a.goal = goal;
        })
    }

    /// Light state of a blinkenlight or light indicator.
    pub fn light_on(&self, m: ModelId) -> Result<bool> {
        typed!(self.kind(m), LIGHT, KindState::Blinkenlight(Blinkenlight { on })
            | KindState::Lightindicator(Lightindicator { on }) => *on)
    }

    /// Switches a light indicator (or a blinkenlight, until its next blink).
    pub fn set_light(&mut self, m: ModelId, value: bool) -> Result<()> {
        typed!(self.kind_mut(m), LIGHT, KindState::Blinkenlight(Blinkenlight { on })
            | KindState::Lightindicator(Lightindicator { on }) => *on = value)
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
