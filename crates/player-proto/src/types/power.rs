//! The `power` interface (2).

xdr_struct! {
    /// Battery state; `valid` says which fields are set (`PLAYER_POWER_MASK_*`).
    pub struct PowerDataState = "player_power_data_t" {
        /// Valid-field mask.
        valid: u32,
        /// Voltage (V).
        volts: f32,
        /// Charge (%).
        percent: f32,
        /// Energy stored (J).
        joules: f32,
        /// Power use (W, negative when charging).
        watts: f32,
        /// 1 charging, -1 charging others, 0 neither.
        charging: i32,
    }

    /// Charging policy.
    pub struct PowerChargepolicyConfig = "player_power_chargepolicy_config_t" {
        /// Accept charge.
        enable_input: u8,
        /// Give charge.
        enable_output: u8,
    }
}
