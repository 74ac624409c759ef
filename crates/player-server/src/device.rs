//! The device table: every device the server offers, who provides it, and which ports it
//! listens on (player-cfg.md §6–§7, upstream `DeviceTable`).
//!
//! Devices are added in cfg order — driver blocks in file order, each block's `provides` in
//! order — which is the order DEVLIST reports. After start-up the table never changes, so
//! connection tasks share it read-only to route messages without asking the core.

use std::collections::HashMap;

use player_proto::constants::LOCALHOST_ADDR;
use player_proto::{DeviceAddr, InterfaceCode};

use crate::error::ServerError;

/// Identifies a driver instance (one cfg `driver` block) inside a server.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct DriverId(pub usize);

/// Position of a device in its [`DeviceTable`] (cfg order).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct DeviceIndex(pub usize);

/// One device.
#[derive(Clone, Debug, PartialEq)]
pub struct Device {
    /// Its address: host, port (robot), interface, index.
    pub addr: DeviceAddr,
    /// The `key` of its `provides` entry, for drivers that give devices roles.
    pub key: Option<String>,
    /// The driver instance that serves it.
    pub driver: DriverId,
    /// The `name` of that driver's cfg block: what DEV and DRIVERINFO replies report.
    pub driver_name: String,
    /// Where the device was declared (`file:line`), for error messages.
    pub origin: String,
}

/// The devices of a server, in cfg order.
#[derive(Clone, Debug, Default)]
pub struct DeviceTable {
    devices: Vec<Device>,
    /// (robot, interface, index) → devices with that triple (normally one; hosts may differ).
    by_slot: HashMap<(u32, u16, u16), Vec<usize>>,
}

impl DeviceTable {
    /// An empty table.
    pub fn new() -> DeviceTable {
        DeviceTable::default()
    }

    /// Adds a device at the end; an address that is already present is refused
    /// (`duplicate device addr`, with hosts 0 and 127.0.0.1 treated as equal).
    pub fn add(&mut self, device: Device) -> Result<DeviceIndex, ServerError> {
        if let Some(existing) = self.find(&device.addr) {
            return Err(ServerError::DuplicateDevice {
                addr: device.addr,
                origin: device.origin,
                first: self.devices[existing.0].origin.clone(),
            });
        }
        let index = self.devices.len();
        self.by_slot
            .entry(slot(&device.addr))
            .or_default()
            .push(index);
        self.devices.push(device);
        Ok(DeviceIndex(index))
    }

    /// The device with this address (upstream's `MatchDeviceAddress`), if any.
    pub fn find(&self, addr: &DeviceAddr) -> Option<DeviceIndex> {
        self.by_slot
            .get(&slot(addr))?
            .iter()
            .copied()
            .find(|&i| self.devices[i].addr.same_device(addr))
            .map(DeviceIndex)
    }

    /// The device at `index`.
    pub fn get(&self, index: DeviceIndex) -> &Device {
        &self.devices[index.0]
    }

    /// All devices in cfg order.
    pub fn devices(&self) -> &[Device] {
        &self.devices
    }

    /// Number of devices.
    pub fn len(&self) -> usize {
        self.devices.len()
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.devices.is_empty()
    }

    /// The devices a connection on `port` sees in DEVLIST: that port, the local host.
    pub fn on_port(&self, port: u32) -> impl Iterator<Item = &Device> {
        self.devices
            .iter()
            .filter(move |d| d.addr.robot == port && d.addr.host == LOCALHOST_ADDR)
    }

    /// The ports to listen on: the distinct `robot` values, in order of first appearance,
    /// skipping devices of drivers named `remote` (they live on another server).
    pub fn ports(&self) -> Vec<u32> {
        let mut ports = Vec::new();
        for d in &self.devices {
            if d.driver_name != crate::server::REMOTE_DRIVER_NAME && !ports.contains(&d.addr.robot)
            {
                ports.push(d.addr.robot);
            }
        }
        ports
    }

    /// Relabels every device on port `from` to port `to` (after the OS picked a port for a
    /// configured port 0).
    pub fn relabel_port(&mut self, from: u32, to: u32) {
        if from == to {
            return;
        }
        for d in &mut self.devices {
            if d.addr.robot == from {
                d.addr.robot = to;
            }
        }
        let mut by_slot: HashMap<(u32, u16, u16), Vec<usize>> = HashMap::new();
        for (i, d) in self.devices.iter().enumerate() {
            by_slot.entry(slot(&d.addr)).or_default().push(i);
        }
        self.by_slot = by_slot;
    }
}

fn slot(addr: &DeviceAddr) -> (u32, u16, u16) {
    (addr.robot, addr.interf.0, addr.index)
}

/// A local device address (host 127.0.0.1 packed as upstream does) on `port`.
pub fn local_addr(port: u32, interf: InterfaceCode, index: u16) -> DeviceAddr {
    DeviceAddr::new(LOCALHOST_ADDR, port, interf, index)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn device(port: u32, interf: InterfaceCode, index: u16, driver: usize) -> Device {
        Device {
            addr: local_addr(port, interf, index),
            key: None,
            driver: DriverId(driver),
            driver_name: "stage".into(),
            origin: format!("t.cfg:{}", driver + 1),
        }
    }

    #[test]
    fn cfg_order_ports_and_lookup() {
        let mut t = DeviceTable::new();
        t.add(device(6665, InterfaceCode::SIMULATION, 0, 0))
            .unwrap();
        t.add(device(6665, InterfaceCode::POSITION2D, 0, 1))
            .unwrap();
        t.add(device(6666, InterfaceCode::POSITION2D, 0, 2))
            .unwrap();
        t.add(device(6665, InterfaceCode::RANGER, 1, 1)).unwrap();
        assert_eq!(t.ports(), [6665, 6666]);
        let on_6665: Vec<_> = t.on_port(6665).map(|d| d.addr.interf).collect();
        assert_eq!(
            on_6665,
            [
                InterfaceCode::SIMULATION,
                InterfaceCode::POSITION2D,
                InterfaceCode::RANGER
            ]
        );
        // Host 0 (as clients write it) finds the local device.
        let mut a = local_addr(6666, InterfaceCode::POSITION2D, 0);
        a.host = 0;
        assert_eq!(t.find(&a), Some(DeviceIndex(2)));
        a.robot = 6667;
        assert_eq!(t.find(&a), None);
        // Interface 0 never matches.
        assert_eq!(t.find(&local_addr(6665, InterfaceCode(0), 0)), None);
    }

    #[test]
    fn duplicates_are_refused_with_both_places() {
        let mut t = DeviceTable::new();
        t.add(device(6665, InterfaceCode::RANGER, 0, 0)).unwrap();
        let mut dup = device(6665, InterfaceCode::RANGER, 0, 3);
        dup.addr.host = 0;
        let err = t.add(dup).unwrap_err().to_string();
        assert_eq!(
            err,
            "t.cfg:4: duplicate device addr 0:6665:ranger:0 (already provided at t.cfg:1)"
        );
        assert_eq!(t.len(), 1);
    }

    #[test]
    fn relabelling_port_zero() {
        let mut t = DeviceTable::new();
        t.add(device(0, InterfaceCode::RANGER, 0, 0)).unwrap();
        t.add(device(6665, InterfaceCode::RANGER, 0, 0)).unwrap();
        t.relabel_port(0, 40000);
        assert_eq!(t.ports(), [40000, 6665]);
        assert_eq!(
            t.find(&local_addr(40000, InterfaceCode::RANGER, 0)),
            Some(DeviceIndex(0))
        );
        assert_eq!(t.find(&local_addr(0, InterfaceCode::RANGER, 0)), None);
    }

    #[test]
    fn remote_devices_open_no_port() {
        let mut t = DeviceTable::new();
        let mut d = device(7000, InterfaceCode::MAP, 0, 0);
        d.driver_name = crate::server::REMOTE_DRIVER_NAME.into();
        t.add(d).unwrap();
        t.add(device(6665, InterfaceCode::RANGER, 0, 1)).unwrap();
        assert_eq!(t.ports(), [6665]);
    }
}
