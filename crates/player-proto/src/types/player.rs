//! The `player` interface (1): the server itself.

use crate::constants::{PLAYER_KEYLEN, PLAYER_MAX_DEVICES, PLAYER_MAX_DRIVER_STRING_LEN};
use crate::header::DeviceAddr;
use crate::xdr::Text;

xdr_struct! {
    /// The devices on the connection's port (DEVLIST reply).
    pub struct DeviceDevlist = "player_device_devlist_t" {
        /// At most `PLAYER_MAX_DEVICES` addresses.
        devices: Vec<DeviceAddr> [max PLAYER_MAX_DEVICES],
    }

    /// The driver behind a device (DRIVERINFO request and reply).
    pub struct DeviceDriverinfo = "player_device_driverinfo_t" {
        /// The device asked about.
        addr: DeviceAddr,
        /// Driver name, NUL counted, at most 64 bytes (empty in requests).
        driver_name: Text [max PLAYER_MAX_DRIVER_STRING_LEN],
    }

    /// Subscribe/unsubscribe (DEV request and reply).
    pub struct DeviceReq = "player_device_req_t" {
        /// The device.
        addr: DeviceAddr,
        /// Requested or granted access (`PLAYER_OPEN_MODE`, ...).
        access: u8,
        /// Driver name in replies, NUL counted; empty in requests.
        driver_name: Text [max PLAYER_MAX_DRIVER_STRING_LEN],
    }

    /// PUSH/PULL data mode (DATAMODE request).
    #[derive(Copy, Eq)]
    pub struct DeviceDatamodeReq = "player_device_datamode_req_t" {
        /// `PLAYER_DATAMODE_PUSH` or `PLAYER_DATAMODE_PULL`.
        mode: u8,
    }

    /// Authentication key (AUTH request; never implemented upstream).
    pub struct DeviceAuthReq = "player_device_auth_req_t" {
        /// Key bytes, at most `PLAYER_KEYLEN`.
        auth_key: Vec<u8> [max PLAYER_KEYLEN],
    }

    /// Name service lookup (NAMESERVICE request; never implemented upstream).
    pub struct DeviceNameserviceReq = "player_device_nameservice_req_t" {
        /// Robot name bytes, at most 64.
        name: Vec<u8> [max PLAYER_MAX_DRIVER_STRING_LEN],
        /// Port.
        port: u16,
    }

    /// Adds a replace rule to the connection's queue; -1 is a wildcard.
    #[derive(Copy, Eq)]
    pub struct AddReplaceRuleReq = "player_add_replace_rule_req_t" {
        /// Interface code or -1.
        interf: i32,
        /// Index or -1.
        index: i32,
        /// Message type or -1.
        msg_type ("type"): i32,
        /// Subtype or -1.
        subtype: i32,
        /// Action: `PLAYER_PLAYER_MSG_REPLACE_RULE_*`.
        replace: i32,
    }
}
