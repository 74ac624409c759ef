//! The `blinkenlight` interface (33).

use super::Color;

xdr_struct! {
    /// Light state (DATA STATE).
    pub struct BlinkenlightDataState = "player_blinkenlight_data_t" {
        /// On/off.
        enable: u8,
        /// Flash period (s).
        period: f32,
        /// Duty cycle 0..1.
        dutycycle: f32,
        /// Colour.
        color: Color,
    }

    /// Full command (CMD STATE).
    pub struct BlinkenlightCmdState = "player_blinkenlight_cmd_t" {
        /// Light id.
        id: u16,
        /// On/off.
        enable: u8,
        /// Flash period (s).
        period: f32,
        /// Duty cycle 0..1.
        dutycycle: f32,
        /// Colour.
        color: Color,
    }

    /// Power command (CMD POWER).
    pub struct BlinkenlightCmdPower = "player_blinkenlight_cmd_power_t" {
        /// Light id.
        id: u16,
        /// On/off.
        enable: u8,
    }

    /// Colour command (CMD COLOR).
    pub struct BlinkenlightCmdColor = "player_blinkenlight_cmd_color_t" {
        /// Light id.
        id: u16,
        /// Colour.
        color: Color,
    }

    /// Flash command (CMD FLASH).
    pub struct BlinkenlightCmdFlash = "player_blinkenlight_cmd_flash_t" {
        /// Light id.
        id: u16,
        /// Flash period (s).
        period: f32,
        /// Duty cycle 0..1.
        dutycycle: f32,
    }
}
