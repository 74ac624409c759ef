//! `snd`: Smooth Nearness-Diagram navigation, as Player 3.0.2's driver runs it.
//!
//! Provides a `position2d`; requires a `laser` and the base as two `position2d` devices
//! keyed `input` (the pose) and `output` (velocity commands; may be the same device). The
//! goal starts at the first pose received, so the robot holds still until a
//! `PLAYER_POSITION2D_CMD_POS` goal arrives; then every time both a new scan and a new pose
//! have come in, [`alg::step`] gives the next velocity, until the goal pose is reached
//! (within `goal_tol`) and the robot stops and waits for the next goal. Velocity commands pass
//! through to the output unchanged. Both position devices' data is republished as this
//! device's; requests are forwarded to the output.
//!
//! Options (Player's, with its defaults): `robot_radius` 0.25, `min_gap_width` (2 radii),
//! `obstacle_avoid_dist` (4 radii), `max_speed` 0.5, `max_turn_rate` (60° in rad/s),
//! `goal_tol [position angle]` (half a radius, 30° in rad). Upstream reads `max_turn_rate` and
//! the angle of `goal_tol` as lengths, so unlike other drivers' angles they are written in
//! radians in the cfg, as here.

pub mod alg;

use player_proto::{
    Body, DeviceAddr, InterfaceCode, LaserData, LaserMsg, Message, Pose2d, Position2dCmd,
    Position2dCmdVel, Position2dData, Position2dMsg,
};
use player_server::{Context, Driver, DriverBlock, DriverError, PendingReply};

use crate::error::Error;
use crate::forward::{Waiting, refuse_own_device};
use crate::options;

use alg::{Command, Scan, SndParams};

/// The Player name of this driver.
pub const NAME: &str = "snd";

/// Reads the options of a cfg block (absent ones keep Player's defaults).
pub fn params_from_block(block: &DriverBlock) -> Result<SndParams, Error> {
    let get = |k: &'static str, i: usize| options::tuple_length(block, k, i);
    let r = get("robot_radius", 0)?.unwrap_or(0.25);
    Ok(SndParams {
        robot_radius: r,
        min_gap_width: get("min_gap_width", 0)?.unwrap_or(2.0 * r),
        obstacle_avoid_dist: get("obstacle_avoid_dist", 0)?.unwrap_or(4.0 * r),
        max_speed: get("max_speed", 0)?.unwrap_or(0.5),
        max_turn_rate: get("max_turn_rate", 0)?.unwrap_or(60f64.to_radians()),
        goal_position_tol: get("goal_tol", 0)?.unwrap_or(r / 2.0),
        goal_angle_tol: get("goal_tol", 1)?.unwrap_or(30f64.to_radians()),
    })
}

/// The navigation state between scans: the goal and whether it is being waited for.
#[derive(Debug)]
pub struct Navigator {
    params: SndParams,
    goal: Option<(f64, f64, f64)>,
    /// A goal was set since the last arrival (upstream's `goal_changed`).
    goal_changed: bool,
    /// Arrived, waiting for a new goal.
    idle: bool,
    pose: Option<Pose2d>,
    scan: Option<Scan>,
    fresh_pose: bool,
    fresh_scan: bool,
}

impl Navigator {
    /// A navigator with no goal yet.
    pub fn new(params: SndParams) -> Navigator {
        Navigator {
            params,
            goal: None,
            goal_changed: true,
            idle: false,
            pose: None,
            scan: None,
            fresh_pose: false,
            fresh_scan: false,
        }
    }

    /// Back to the start (the driver was shut down).
    pub fn reset(&mut self) {
        *self = Navigator::new(self.params.clone());
    }

    /// A new goal; an idle robot starts at once.
    pub fn set_goal(&mut self, goal: (f64, f64, f64)) {
        self.goal = Some(goal);
        if self.idle {
            self.idle = false;
            self.goal_changed = false;
        } else {
            self.goal_changed = true;
        }
    }

    /// A pose from the input device; the first one becomes the goal.
    pub fn pose(&mut self, pose: Pose2d) -> Option<Command> {
        if self.goal.is_none() {
            self.set_goal((pose.px, pose.py, pose.pa));
        }
        self.pose = Some(pose);
        self.fresh_pose = true;
        self.run()
    }

    /// A laser scan.
    pub fn scan(&mut self, scan: Scan) -> Option<Command> {
        self.scan = Some(scan);
        self.fresh_scan = true;
        self.run()
    }

    /// One step once both a new scan and a new pose are in (upstream's `Read`).
    fn run(&mut self) -> Option<Command> {
        if !(self.fresh_pose && self.fresh_scan) || self.idle {
            return None;
        }
        let (Some(goal), Some(pose), Some(scan)) = (self.goal, self.pose, self.scan.as_ref())
        else {
            return None;
        };
        self.fresh_pose = false;
        self.fresh_scan = false;
        let cmd = alg::step(&self.params, scan, (pose.px, pose.py, pose.pa), goal)?;
        if cmd == Command::Arrived {
            if self.goal_changed {
                self.goal_changed = false;
            } else {
                self.idle = true;
            }
        }
        Some(cmd)
    }
}

/// The driver.
#[derive(Debug)]
pub struct Snd {
    addr: DeviceAddr,
    input: DeviceAddr,
    output: DeviceAddr,
    laser: DeviceAddr,
    nav: Navigator,
    waiting: Waiting<PendingReply>,
}

impl Snd {
    /// Builds the driver from its cfg block.
    pub fn from_block(block: &DriverBlock) -> Result<Snd, DriverError> {
        let addr = block.provided(InterfaceCode::POSITION2D)?;
        let laser = block.required(InterfaceCode::LASER, None)?.addr;
        let input = block
            .required(InterfaceCode::POSITION2D, Some("input"))?
            .addr;
        let output = block
            .required(InterfaceCode::POSITION2D, Some("output"))?
            .addr;
        refuse_own_device(addr, &[input, output])?;
        Ok(Snd {
            addr,
            input,
            output,
            laser,
            nav: Navigator::new(params_from_block(block)?),
            waiting: Waiting::default(),
        })
    }

    fn send(&self, ctx: &mut Context<'_>, cmd: Option<Command>) {
        let (v, w) = match cmd {
            None => return,
            Some(Command::Arrived) => (0.0, 0.0),
            Some(Command::Drive { v, w }) => (v, w),
        };
        ctx.command(
            self.output,
            Position2dCmd::Vel(Position2dCmdVel {
                vel: Pose2d {
                    px: v,
                    py: 0.0,
                    pa: w,
                },
                state: 1,
            }),
        );
    }
}

impl Driver for Snd {
    fn setup(&mut self, ctx: &mut Context<'_>) -> Result<(), DriverError> {
        self.nav.reset();
        super::subscribe_both(ctx, self.input, self.output);
        ctx.subscribe(self.laser);
        Ok(())
    }

    fn handle_data(&mut self, ctx: &mut Context<'_>, data: &Message) {
        let from = data.header.addr;
        match &data.body {
            Body::Laser(LaserMsg::Data(LaserData::Scan(s))) if from.same_device(&self.laser) => {
                let cmd = self.nav.scan(Scan {
                    ranges: s.ranges.iter().map(|&r| f64::from(r)).collect(),
                    resolution: f64::from(s.resolution),
                    max_range: f64::from(s.max_range),
                });
                self.send(ctx, cmd);
            }
            Body::Position2d(Position2dMsg::Data(Position2dData::State(state))) => {
                if from.same_device(&self.input) {
                    ctx.publish_at(
                        self.addr,
                        Position2dData::State(state.clone()),
                        data.header.timestamp,
                    );
                    let cmd = self.nav.pose(state.pos);
                    self.send(ctx, cmd);
                } else if from.same_device(&self.output) {
                    ctx.publish_at(
                        self.addr,
                        Position2dData::State(state.clone()),
                        data.header.timestamp,
                    );
                }
            }
            _ => {}
        }
    }

    fn handle_command(&mut self, ctx: &mut Context<'_>, command: &Message) {
        match &command.body {
            Body::Position2d(Position2dMsg::Cmd(Position2dCmd::Pos(cmd))) => {
                self.nav.set_goal((cmd.pos.px, cmd.pos.py, cmd.pos.pa));
            }
            Body::Position2d(Position2dMsg::Cmd(Position2dCmd::Vel(cmd))) => {
                ctx.command(self.output, Position2dCmd::Vel(cmd.clone()));
            }
            other => tracing::warn!("snd: ignoring command {}", other.constant()),
        }
    }

    crate::forward::pass_requests_to!(output);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::options::tests::block;
    use crate::testing::pose;

    fn open() -> Scan {
        Scan {
            ranges: vec![8.0; 181],
            resolution: 1f64.to_radians(),
            max_range: 8.0,
        }
    }

    #[test]
    fn options_default_from_the_radius() {
        let p = params_from_block(&block(NAME, &[])).unwrap();
        assert_eq!(
            (p.robot_radius, p.min_gap_width, p.obstacle_avoid_dist),
            (0.25, 0.5, 1.0)
        );
        assert_eq!((p.max_speed, p.goal_position_tol), (0.5, 0.125));
        assert!((p.max_turn_rate - 60f64.to_radians()).abs() < 1e-12);
        assert!((p.goal_angle_tol - 30f64.to_radians()).abs() < 1e-12);
        let p = params_from_block(&block(
            NAME,
            &[("robot_radius", "0.4"), ("goal_tol", "0.2 0.1")],
        ))
        .unwrap();
        assert_eq!((p.min_gap_width, p.obstacle_avoid_dist), (0.8, 1.6));
        assert_eq!(
            (p.goal_position_tol, p.goal_angle_tol),
            (0.2, 0.1),
            "radians as written"
        );
        assert!(params_from_block(&block(NAME, &[("max_speed", "fast")])).is_err());
    }

    #[test]
    fn the_robot_holds_its_first_pose_until_a_goal_comes() {
        let mut nav = Navigator::new(params_from_block(&block(NAME, &[])).unwrap());
        assert_eq!(nav.scan(open()), None, "no pose yet");
        // The first pose is the goal: arrived (twice, as upstream), then idle.
        assert_eq!(nav.pose(pose(1.0, 2.0, 0.0)), Some(Command::Arrived));
        assert_eq!(nav.pose(pose(1.0, 2.0, 0.0)), None, "waits for a scan");
        assert_eq!(nav.scan(open()), Some(Command::Arrived));
        nav.pose(pose(1.0, 2.0, 0.0));
        assert_eq!(nav.scan(open()), None, "idle");
        nav.set_goal((4.0, 2.0, 0.0));
        // The scan and pose that came in while idle are still new (as upstream's ready
        // flags): the next pose alone starts the drive.
        let Some(Command::Drive { v, .. }) = nav.pose(pose(1.0, 2.0, 0.0)) else {
            panic!("should drive");
        };
        assert!(v > 0.4);
    }
}
