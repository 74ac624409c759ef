//! From a parsed `.cfg` file ([`worldfile::CfgFile`]) to the [`DriverBlock`]s drivers are built
//! from: addresses resolved to their wire form (default host and port filled in), options kept.

use std::net::{Ipv4Addr, ToSocketAddrs};

use player_proto::DeviceAddr;
use player_proto::constants::LOCALHOST_ADDR;
use worldfile::{CfgFile, DriverSpec, Host};

use crate::driver::{DriverBlock, ProvidedDevice, RequiredDevice};
use crate::error::ServerError;

/// The driver blocks of `cfg` in file order; `default_port` is the `-p` port for addresses
/// that name none.
pub fn driver_blocks(cfg: &CfgFile, default_port: u16) -> Result<Vec<DriverBlock>, ServerError> {
    cfg.drivers
        .iter()
        .map(|spec| driver_block(cfg, spec, default_port))
        .collect()
}

/// One driver block. A malformed `provides`/`requires` entry (which Player refuses at start-up)
/// or a host name that does not resolve is an error naming its place.
pub fn driver_block(
    cfg: &CfgFile,
    spec: &DriverSpec,
    default_port: u16,
) -> Result<DriverBlock, ServerError> {
    let origin = spec
        .location
        .as_ref()
        .map(|l| l.to_string())
        .unwrap_or_else(|| cfg.path.display().to_string());
    if let Some(e) = spec.address_errors.first() {
        return Err(ServerError::Config {
            origin,
            message: e.to_string(),
        });
    }
    let resolve = |a: &worldfile::DeviceAddr| -> Result<(DeviceAddr, String), ServerError> {
        let where_ = a
            .location
            .as_ref()
            .map(|l| l.to_string())
            .unwrap_or_else(|| origin.clone());
        let host = packed_host(&a.host).ok_or_else(|| ServerError::Config {
            origin: where_.clone(),
            message: format!("cannot resolve the host of \"{}\"", a.text),
        })?;
        let addr = DeviceAddr::new(
            host,
            u32::from(a.port_or(default_port)),
            a.interface,
            a.index,
        );
        Ok((addr, where_))
    };
    let mut provides = Vec::new();
    for a in &spec.provides {
        let (addr, origin) = resolve(a)?;
        provides.push(ProvidedDevice {
            addr,
            key: a.key.clone(),
            origin,
        });
    }
    let mut requires = Vec::new();
    for a in &spec.requires {
        let (addr, origin) = resolve(a)?;
        requires.push(RequiredDevice {
            addr,
            key: a.key.clone(),
            origin,
        });
    }
    let mut options = spec.options.clone();
    for (key, value) in [
        ("plugin", &spec.plugin),
        ("model", &spec.model),
        ("worldfile", &spec.worldfile),
    ] {
        if let Some(v) = value {
            options.insert(key.to_string(), vec![v.clone()]);
        }
    }
    let option_origins = cfg
        .doc
        .properties(spec.section)
        .iter()
        .map(|p| (cfg.doc.name(p).to_string(), cfg.doc.loc(p.loc).to_string()))
        .collect();
    Ok(DriverBlock {
        name: spec.name.clone(),
        origin,
        cfg_path: Some(cfg.path.clone()),
        provides,
        requires,
        alwayson: spec.alwayson,
        options,
        units: cfg.doc.units,
        option_origins,
    })
}

/// A host as upstream packs it: the IPv4 address's bytes read as a little-endian integer, so
/// 127.0.0.1 is 16777343 ([`LOCALHOST_ADDR`]).
fn packed_host(host: &Host) -> Option<u32> {
    let ip = match host {
        Host::Default => return Some(LOCALHOST_ADDR),
        Host::Packed(n) => return Some(*n),
        Host::Name(name) => match host.ipv4() {
            Some(ip) => ip,
            None => (name.as_str(), 0)
                .to_socket_addrs()
                .ok()?
                .find_map(|a| match a.ip() {
                    std::net::IpAddr::V4(v4) => Some(v4),
                    std::net::IpAddr::V6(_) => None,
                })?,
        },
    };
    Some(pack(ip))
}

fn pack(ip: Ipv4Addr) -> u32 {
    u32::from_le_bytes(ip.octets())
}

#[cfg(test)]
mod tests {
    use super::*;
    use player_proto::InterfaceCode;
    use std::path::Path;
    use worldfile::LoadOptions;

    fn parse(text: &str) -> CfgFile {
        CfgFile::parse(Path::new("dir/t.cfg"), text, &LoadOptions::default()).unwrap()
    }

    #[test]
    fn blocks_carry_resolved_addresses_and_options() {
        let cfg = parse(
            "driver( name \"stage\" provides [\"simulation:0\"] plugin \"stageplugin\" worldfile \"w.world\" usegui 0 )\n\
             driver( name \"stage\" provides [\"6666:position2d:0\" \"odometry::7000:ranger:1\" \"127.0.0.1::ranger:2\"] model \"r0\" alwayson 1 )\n",
        );
        let blocks = driver_blocks(&cfg, 6665).unwrap();
        assert_eq!(blocks.len(), 2);
        let sim = &blocks[0];
        assert_eq!(sim.name, "stage");
        assert!(sim.origin.starts_with("dir/t.cfg:1"), "{}", sim.origin);
        assert_eq!(
            sim.provides[0].addr,
            DeviceAddr::new(LOCALHOST_ADDR, 6665, InterfaceCode::SIMULATION, 0)
        );
        assert_eq!(sim.option("worldfile"), Some("w.world"));
        assert_eq!(sim.option("usegui"), Some("0"));
        assert_eq!(sim.option("plugin"), Some("stageplugin"));
        assert_eq!(sim.resolve_path("w.world"), Path::new("dir/w.world"));
        assert_eq!(sim.option_origin("worldfile"), "dir/t.cfg:1:69");
        assert_eq!(sim.option_origin("nosuch"), sim.origin);
        let bob = &blocks[1];
        assert_eq!(bob.alwayson, Some(true));
        assert_eq!(bob.option("model"), Some("r0"));
        let addrs: Vec<_> = bob
            .provides
            .iter()
            .map(|p| (p.addr.robot, p.addr.interf, p.addr.index))
            .collect();
        assert_eq!(
            addrs,
            [
                (6666, InterfaceCode::POSITION2D, 0),
                (7000, InterfaceCode::RANGER, 1),
                (6665, InterfaceCode::RANGER, 2)
            ]
        );
        assert_eq!(bob.provides[1].key.as_deref(), Some("odometry"));
        assert_eq!(bob.provides[2].addr.host, LOCALHOST_ADDR);
        // -p changes the default port.
        let blocks = driver_blocks(&cfg, 7100).unwrap();
        assert_eq!(blocks[0].provides[0].addr.robot, 7100);
    }

    #[test]
    fn player1_keys_reach_the_block_as_keys() {
        // Stage's amcl-sonar.cfg: Player 1's `key:port:interface:index`.
        let cfg = parse(
            "driver( name \"amcl\" provides [\"localize:0\"] requires [\"odometry::position:0\" \"sonar:0\" \"sonar::map:0\"] )\n",
        );
        let blocks = driver_blocks(&cfg, 6665).unwrap();
        let requires: Vec<_> = blocks[0]
            .requires
            .iter()
            .map(|r| (r.key.as_deref(), r.addr))
            .collect();
        assert_eq!(
            requires,
            [
                (
                    Some("odometry"),
                    DeviceAddr::new(LOCALHOST_ADDR, 6665, InterfaceCode::POSITION2D, 0)
                ),
                (
                    None,
                    DeviceAddr::new(LOCALHOST_ADDR, 6665, InterfaceCode::SONAR, 0)
                ),
                (
                    Some("sonar"),
                    DeviceAddr::new(LOCALHOST_ADDR, 6665, InterfaceCode::MAP, 0)
                ),
            ]
        );
    }

    #[test]
    fn blocks_carry_the_cfg_units() {
        let metric = parse("driver( name \"mapfile\" provides [\"map:0\"] resolution 0.1 )\n");
        assert_eq!(
            driver_blocks(&metric, 6665).unwrap()[0].units,
            worldfile::Units::default()
        );
        let cfg = parse(
            "unit_length \"cm\"\nunit_angle \"radians\"\n\
             driver( name \"mapfile\" provides [\"map:0\"] resolution 10 )\n",
        );
        let units = driver_blocks(&cfg, 6665).unwrap()[0].units;
        assert_eq!((units.length, units.angle), (0.01, 1.0));
    }

    #[test]
    fn malformed_addresses_are_errors_with_their_place() {
        let cfg = parse("driver( name \"stage\" provides [\"foo:0\"] )\n");
        let err = driver_blocks(&cfg, 6665).unwrap_err().to_string();
        assert!(err.contains("dir/t.cfg:1"), "{err}");
        assert!(err.contains("foo"), "{err}");
    }
}
