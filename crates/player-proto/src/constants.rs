//! Numeric constants of `player.h` and the interface `.def` files, under their C names so code
//! written against libplayerc reads the same.
//!
//! Subtype constants are not here: they are associated constants of the typed message enums
//! (e.g. `PlayerSynch::OK`, `Position2dReq::GET_GEOM`), generated from the message table.

/// Bound on a decoded C message (`PLAYER_MAX_MESSAGE_SIZE`, 8 MiB).
pub const PLAYER_MAX_MESSAGE_SIZE: usize = 8_388_608;
/// Bound on an encoded message (`PLAYERXDR_MAX_MESSAGE_SIZE` = 4 × `PLAYER_MAX_MESSAGE_SIZE`).
pub const PLAYERXDR_MAX_MESSAGE_SIZE: usize = 4 * PLAYER_MAX_MESSAGE_SIZE;
/// Capacity of driver-name arrays, count including the NUL (`PLAYER_MAX_DRIVER_STRING_LEN`).
pub const PLAYER_MAX_DRIVER_STRING_LEN: usize = 64;
/// Capacity of the DEVLIST reply (`PLAYER_MAX_DEVICES`).
pub const PLAYER_MAX_DEVICES: usize = 4096;
/// Capacity of the AUTH key (`PLAYER_KEYLEN`).
pub const PLAYER_KEYLEN: usize = 32;
/// Length of the identification banner (`PLAYER_IDENT_STRLEN`).
pub const PLAYER_IDENT_STRLEN: usize = 32;
/// Outgoing queue length of a connection (`PLAYER_MSGQUEUE_DEFAULT_MAXLEN`).
pub const PLAYER_MSGQUEUE_DEFAULT_MAXLEN: usize = 1024;
/// TCP port used when a `provides` entry names none (`PLAYERTCP_DEFAULT_PORT`).
pub const PLAYERTCP_DEFAULT_PORT: u16 = 6665;
/// 127.0.0.1 as upstream stores it: `in_addr.s_addr` read as a little-endian u32 (16777343,
/// encoded `01 00 00 7f`). The host value of every server-side device address.
pub const LOCALHOST_ADDR: u32 = 16_777_343;

/// DEV access: subscribe (`PLAYER_OPEN_MODE`).
pub const PLAYER_OPEN_MODE: u8 = 1;
/// DEV access: unsubscribe (`PLAYER_CLOSE_MODE`).
pub const PLAYER_CLOSE_MODE: u8 = 2;
/// DEV access granted on failure (`PLAYER_ERROR_MODE`).
pub const PLAYER_ERROR_MODE: u8 = 3;
/// Data mode: stream every message as published (`PLAYER_DATAMODE_PUSH`, the server default).
pub const PLAYER_DATAMODE_PUSH: u8 = 1;
/// Data mode: one round per `PLAYER_PLAYER_REQ_DATA` (`PLAYER_DATAMODE_PULL`, what clients set).
pub const PLAYER_DATAMODE_PULL: u8 = 2;
/// Replace rule action: queue the message (`PLAYER_PLAYER_MSG_REPLACE_RULE_ACCEPT`).
pub const PLAYER_PLAYER_MSG_REPLACE_RULE_ACCEPT: i32 = 0;
/// Replace rule action: replace the previous matching message
/// (`PLAYER_PLAYER_MSG_REPLACE_RULE_REPLACE`).
pub const PLAYER_PLAYER_MSG_REPLACE_RULE_REPLACE: i32 = 1;
/// Replace rule action: drop (`PLAYER_PLAYER_MSG_REPLACE_RULE_IGNORE`).
pub const PLAYER_PLAYER_MSG_REPLACE_RULE_IGNORE: i32 = 2;

/// `power` valid-mask bit: volts (`PLAYER_POWER_MASK_VOLTS`).
pub const PLAYER_POWER_MASK_VOLTS: u32 = 1;
/// `power` valid-mask bit: watts.
pub const PLAYER_POWER_MASK_WATTS: u32 = 2;
/// `power` valid-mask bit: joules.
pub const PLAYER_POWER_MASK_JOULES: u32 = 4;
/// `power` valid-mask bit: percent.
pub const PLAYER_POWER_MASK_PERCENT: u32 = 8;
/// `power` valid-mask bit: charging.
pub const PLAYER_POWER_MASK_CHARGING: u32 = 16;

/// Gripper state: open.
pub const PLAYER_GRIPPER_STATE_OPEN: u8 = 1;
/// Gripper state: closed.
pub const PLAYER_GRIPPER_STATE_CLOSED: u8 = 2;
/// Gripper state: moving.
pub const PLAYER_GRIPPER_STATE_MOVING: u8 = 3;
/// Gripper state: error.
pub const PLAYER_GRIPPER_STATE_ERROR: u8 = 4;

/// Capacity of laser filter parameters (`PLAYER_LASER_MAX_FILTER_PARAMS`).
pub const PLAYER_LASER_MAX_FILTER_PARAMS: usize = 8;
/// Laser filter: median.
pub const PLAYER_LASER_FILTER_MEDIAN: u8 = 1;
/// Laser filter: edge.
pub const PLAYER_LASER_FILTER_EDGE: u8 = 2;
/// Laser filter: range.
pub const PLAYER_LASER_FILTER_RANGE: u8 = 3;
/// Laser filter: mean.
pub const PLAYER_LASER_FILTER_MEAN: u8 = 4;

/// PTZ control mode: velocity.
pub const PLAYER_PTZ_VELOCITY_CONTROL: u32 = 0;
/// PTZ control mode: position.
pub const PLAYER_PTZ_POSITION_CONTROL: u32 = 1;

/// Camera format: 8-bit mono.
pub const PLAYER_CAMERA_FORMAT_MONO8: u32 = 1;
/// Camera format: 16-bit mono.
pub const PLAYER_CAMERA_FORMAT_MONO16: u32 = 2;
/// Camera format: RGB565.
pub const PLAYER_CAMERA_FORMAT_RGB565: u32 = 4;
/// Camera format: 24-bit RGB.
pub const PLAYER_CAMERA_FORMAT_RGB888: u32 = 5;
/// Camera compression: none.
pub const PLAYER_CAMERA_COMPRESS_RAW: u32 = 0;
/// Camera compression: JPEG.
pub const PLAYER_CAMERA_COMPRESS_JPEG: u32 = 1;

/// Actuator state bit: idle.
pub const PLAYER_ACTARRAY_ACTSTATE_IDLE: u8 = 1;
/// Actuator state bit: moving.
pub const PLAYER_ACTARRAY_ACTSTATE_MOVING: u8 = 2;
/// Actuator state bit: braked.
pub const PLAYER_ACTARRAY_ACTSTATE_BRAKED: u8 = 4;
/// Actuator state bit: stalled.
pub const PLAYER_ACTARRAY_ACTSTATE_STALLED: u8 = 8;
/// Actuator type: linear.
pub const PLAYER_ACTARRAY_TYPE_LINEAR: u8 = 1;
/// Actuator type: rotary.
pub const PLAYER_ACTARRAY_TYPE_ROTARY: u8 = 2;

/// graphics3d draw modes (`player_graphics3d_draw_mode_t`, sent as a u32).
pub const PLAYER_DRAW_POINTS: u32 = 0;
/// graphics3d draw mode: lines.
pub const PLAYER_DRAW_LINES: u32 = 1;
/// graphics3d draw mode: line strip.
pub const PLAYER_DRAW_LINE_STRIP: u32 = 2;
/// graphics3d draw mode: line loop.
pub const PLAYER_DRAW_LINE_LOOP: u32 = 3;
/// graphics3d draw mode: triangles.
pub const PLAYER_DRAW_TRIANGLES: u32 = 4;
/// graphics3d draw mode: triangle strip.
pub const PLAYER_DRAW_TRIANGLE_STRIP: u32 = 5;
/// graphics3d draw mode: triangle fan.
pub const PLAYER_DRAW_TRIANGLE_FAN: u32 = 6;
/// graphics3d draw mode: quads.
pub const PLAYER_DRAW_QUADS: u32 = 7;
/// graphics3d draw mode: quad strip.
pub const PLAYER_DRAW_QUAD_STRIP: u32 = 8;
/// graphics3d draw mode: polygon.
pub const PLAYER_DRAW_POLYGON: u32 = 9;
