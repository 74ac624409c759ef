//! The `planner` interface (44): a 2-D path planner's goal, state and plan (Player's
//! `044_planner.def`).

use super::Pose2d;

xdr_struct! {
    /// The planner's execution state (DATA STATE): whether a plan exists, whether the robot has
    /// arrived, and where it is heading now.
    pub struct PlannerData = "player_planner_data_t" {
        /// Non-zero when the planner found a path to the goal.
        valid: u8,
        /// Non-zero when the robot has arrived at the goal.
        done: u8,
        /// Current pose (m, m, rad).
        pos: Pose2d,
        /// Goal pose (m, m, rad).
        goal: Pose2d,
        /// The waypoint being driven to (m, m, rad).
        waypoint: Pose2d,
        /// Index of that waypoint; negative when there is no plan or it is done.
        waypoint_idx: i32,
        /// Number of waypoints in the plan.
        waypoints_count: u32,
    }

    /// A new goal (CMD GOAL).
    pub struct PlannerCmd = "player_planner_cmd_t" {
        /// Goal pose (m, m, rad).
        goal: Pose2d,
    }

    /// The plan's waypoints (GET_WAYPOINTS; the request is sent empty).
    pub struct PlannerWaypointsReq = "player_planner_waypoints_req_t" {
        /// The waypoints, in driving order.
        waypoints: Vec<Pose2d>,
    }

    /// Turns robot motion on or off (ENABLE; the reply is empty).
    pub struct PlannerEnableReq = "player_planner_enable_req_t" {
        /// Non-zero to enable, zero to disable (which stops the robot).
        state: u8,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::xdr::{Reader, Xdr};

    #[test]
    fn layouts_follow_the_def() {
        // uint8_t members travel as 4-byte XDR words; the waypoint array as count + count + poses.
        let data = PlannerData {
            valid: 1,
            waypoint_idx: -1,
            waypoints_count: 3,
            ..Default::default()
        };
        let mut out = Vec::new();
        data.encode(&mut out).unwrap();
        assert_eq!(out.len(), 4 + 4 + 3 * 24 + 4 + 4);
        assert_eq!(&out[..8], &[0, 0, 0, 1, 0, 0, 0, 0]);
        assert_eq!(&out[80..84], &[0xff; 4]);
        let back = PlannerData::decode(&mut Reader::new(&out)).unwrap();
        assert_eq!(back, data);

        let req = PlannerWaypointsReq {
            waypoints: vec![Pose2d::default(); 2],
        };
        let mut out = Vec::new();
        req.encode(&mut out).unwrap();
        assert_eq!(out.len(), 8 + 2 * 24);
        assert_eq!(&out[..8], &[0, 0, 0, 2, 0, 0, 0, 2]);
    }
}
