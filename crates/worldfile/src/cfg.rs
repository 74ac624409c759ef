//! Player 3.0.2 `.cfg` files: `driver` blocks and device addresses (player-cfg.md §3–§6).

use std::collections::BTreeMap;
use std::net::{Ipv4Addr, ToSocketAddrs};
use std::path::{Path, PathBuf};

use player_proto::InterfaceCode;
use serde::{Serialize, Serializer};

use crate::document::{Document, EntityId, Property};
use crate::error::{Error, ErrorKind, Warning};
use crate::lexer::Dialect;
use crate::loader::{self, LoadOptions};
use crate::numeric::atoi;
use crate::source::SourceLoc;

/// The host part of a device address.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Host {
    /// Absent or empty: the server's default host (localhost).
    Default,
    /// All digits: a raw packed 32-bit address, as Player takes it (`atoi`).
    Packed(u32),
    /// A host name or dotted address (resolved by whoever uses it).
    Name(String),
}

impl Host {
    /// The IPv4 address, when it is known without a name lookup.
    pub fn ipv4(&self) -> Option<Ipv4Addr> {
        match self {
            Host::Default => Some(Ipv4Addr::LOCALHOST),
            // Player keeps addresses in network byte order in a host integer, so on the
            // little-endian machines it ran on, 16777343 is 127.0.0.1.
            Host::Packed(n) => Some(Ipv4Addr::from(n.to_le_bytes())),
            Host::Name(n) if n == "localhost" => Some(Ipv4Addr::LOCALHOST),
            Host::Name(n) => n.parse().ok(),
        }
    }

    /// Whether this is the local machine (`0.0.0.0` and `127.0.0.1` count as equal in Player).
    pub fn is_local(&self) -> bool {
        self.ipv4()
            .is_some_and(|ip| ip.is_loopback() || ip.is_unspecified())
    }
}

/// A device address `[key:][host:][robot:]interface:index` (player-cfg.md §5).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DeviceAddr {
    /// The string as written.
    pub text: String,
    /// Driver-specific role label (`odometry` in `odometry:::position2d:0`).
    pub key: Option<String>,
    /// Host.
    pub host: Host,
    /// The robot field, which in Player 3 is the TCP port; `None` means the server default.
    pub port: Option<u16>,
    /// Interface.
    pub interface: InterfaceCode,
    /// Index.
    pub index: u16,
    /// The interface name as written, when it is an older Player's name that is read as
    /// `interface` (see [`OLD_INTERFACE_NAMES`]).
    pub renamed_from: Option<&'static str>,
    /// Where the string is written.
    pub location: Option<SourceLoc>,
}

/// What became of an interface name of an older Player that Player 3.0.2 no longer knows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OldInterface {
    /// The same kind of device under another name: read as that interface, with a warning.
    Renamed {
        /// The Player 3.0.2 interface.
        now: InterfaceCode,
        /// When and how it changed.
        history: &'static str,
    },
    /// Gone without a drop-in replacement: still an error, saying what replaced it.
    Dropped {
        /// When it went and what to use instead.
        history: &'static str,
    },
}

/// Interface names of Player 1.x and 2.x that Player 3.0.2's address parser rejects, from
/// upstream's interface tables (`server/player.h` in 1.6.5, `libplayercore/player.h` and
/// `interface_util.c` in 2.0.x, the `interfaces/*.def` files of 2.1 and 3.0). Old cfgs still
/// use them (Stage 4.1.1's own `amcl-sonar.cfg` writes `position:0`).
pub const OLD_INTERFACE_NAMES: &[(&str, OldInterface)] = &[
    (
        "position",
        OldInterface::Renamed {
            now: InterfaceCode::POSITION2D,
            history: "Player 1.x's name for code 4, renamed in Player 2.0",
        },
    ),
    (
        "energy",
        OldInterface::Renamed {
            now: InterfaceCode::POWER,
            history: "folded into `power` in Player 2.0, removed in 2.1",
        },
    ),
    (
        "truth",
        OldInterface::Dropped {
            history: "removed in Player 2.1; use `simulation`, one device for the whole world \
                      that gives poses by model name",
        },
    ),
    (
        "mcom",
        OldInterface::Dropped {
            history: "removed in Player 3.0; `opaque` covers most of what it did",
        },
    ),
    (
        "sound",
        OldInterface::Dropped {
            history: "removed in Player 2.1",
        },
    ),
    (
        "audiodsp",
        OldInterface::Dropped {
            history: "removed in Player 2.1",
        },
    ),
    (
        "audiomixer",
        OldInterface::Dropped {
            history: "removed in Player 2.1",
        },
    ),
    (
        "waveform",
        OldInterface::Dropped {
            history: "removed in Player 2.1",
        },
    ),
    (
        "nomad",
        OldInterface::Dropped {
            history: "removed in Player 2.1",
        },
    ),
];

/// What became of the old interface name `name`, if it is one.
pub fn old_interface(name: &str) -> Option<OldInterface> {
    OLD_INTERFACE_NAMES
        .iter()
        .find(|(old, _)| *old == name)
        .map(|(_, what)| *what)
}

impl Serialize for DeviceAddr {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        let mut st = s.serialize_struct("DeviceAddr", 6)?;
        st.serialize_field("text", &self.text)?;
        st.serialize_field("key", &self.key)?;
        st.serialize_field("host", &self.host)?;
        st.serialize_field("port", &self.port)?;
        st.serialize_field("interface", &self.interface.to_string())?;
        st.serialize_field("index", &self.index)?;
        st.end()
    }
}

impl DeviceAddr {
    /// Parses an address string the way `ConfigFile::ReadDeviceAddr` does: split from the right
    /// on `:` into index, interface, robot, host, key; a fifth colon discards everything left of
    /// it. Where Player's `atoi` would silently read a non-number as 0 we reject it. An older
    /// Player's name for a renamed interface is read as the new one, noted in
    /// [`DeviceAddr::renamed_from`] (see [`DeviceAddr::old_name_warning`]).
    pub fn parse(text: &str) -> Result<DeviceAddr, String> {
        let mut fields: Vec<&str> = text.rsplitn(6, ':').collect();
        if fields.len() == 6 {
            fields.pop(); // Player drops whatever is left of the fifth colon from the right.
        }
        let (index, interface) = match (fields.first(), fields.get(1)) {
            (Some(i), Some(f)) => (*i, *f),
            _ => return Err("missing interface or index (expected `interface:index`)".into()),
        };
        let robot = fields.get(2).copied().filter(|s| !s.is_empty());
        let host = fields.get(3).copied().filter(|s| !s.is_empty());
        let key = fields.get(4).copied().filter(|s| !s.is_empty());
        let (interface, renamed_from) = match InterfaceCode::from_name(interface) {
            Some(code) => (code, None),
            None => match OLD_INTERFACE_NAMES
                .iter()
                .find(|(old, _)| *old == interface)
            {
                Some((old, OldInterface::Renamed { now, .. })) => (*now, Some(*old)),
                Some((_, OldInterface::Dropped { history })) => {
                    return Err(format!(
                        "unknown interface `{interface}` (an older Player's, {history})"
                    ));
                }
                None => return Err(format!("unknown interface `{interface}`")),
            },
        };
        let index = match atoi(index) {
            Some(n) if (0..=u16::MAX as i64).contains(&n.value) => n.value as u16,
            Some(_) => return Err(format!("index `{index}` is out of range")),
            None => return Err(format!("index `{index}` is not a number")),
        };
        let port = match robot {
            None => None,
            Some(r) => match atoi(r) {
                Some(n) if (0..=u16::MAX as i64).contains(&n.value) => Some(n.value as u16),
                Some(_) => return Err(format!("port `{r}` is out of range")),
                None => return Err(format!("port `{r}` is not a number")),
            },
        };
        let host = match host {
            None => Host::Default,
            Some(h) if h.bytes().all(|c| c.is_ascii_digit()) => {
                let n = atoi(h).map(|n| n.value).unwrap_or(0);
                Host::Packed(u32::try_from(n).map_err(|_| format!("host `{h}` is out of range"))?)
            }
            Some(h) => Host::Name(h.to_string()),
        };
        Ok(DeviceAddr {
            text: text.to_string(),
            key: key.map(str::to_string),
            host,
            port,
            interface,
            index,
            renamed_from,
            location: None,
        })
    }

    /// The warning for an address written with an older Player's interface name: what it is
    /// served as, and the address to write instead.
    pub fn old_name_warning(&self) -> Option<String> {
        let old = self.renamed_from?;
        let Some(OldInterface::Renamed { history, .. }) = old_interface(old) else {
            return None;
        };
        // The address with only its interface field replaced: `odometry::position:0` ->
        // `odometry::position2d:0`.
        let (front, index) = self.text.rsplit_once(':')?;
        let prefix = front.strip_suffix(old)?;
        Some(format!(
            "interface \"{old}\" is an older Player's name ({history}); serving it as \"{now}\" \
             (write \"{prefix}{now}:{index}\")",
            now = self.interface
        ))
    }

    /// Player 1's reading of this address, when it can be one: Player 1 wrote
    /// `key:port:interface:index`, so its `odometry::position:0` is the key `odometry` on the
    /// default port, where Player 2 and 3 (which put a host before the port) read a host named
    /// `odometry`. Only the form `name::interface:index` qualifies (four fields, the port empty,
    /// the first a bare name: no dots, not `localhost`, not a number or a dotted address); with
    /// a port written (`otherhost:6665:laser:0`) it is Player 3's remote device. Whether to
    /// take this reading is up to the caller ([`CfgFile::load`]: when no host of that name
    /// resolves).
    pub fn as_player1_key(&self) -> Option<DeviceAddr> {
        let Host::Name(name) = &self.host else {
            return None;
        };
        if self.key.is_some()
            || self.port.is_some()
            || self.host.ipv4().is_some()
            || name.contains('.')
            || self.text.matches(':').count() != 3
        {
            return None;
        }
        Some(DeviceAddr {
            key: Some(name.clone()),
            host: Host::Default,
            ..self.clone()
        })
    }

    /// The warning for an address read as Player 1's `key::interface:index` (this address
    /// being the result of [`DeviceAddr::as_player1_key`]): what was read and the Player 3
    /// address to write instead, which also takes the new name of a renamed interface.
    pub fn player1_key_warning(&self) -> String {
        let key = self.key.as_deref().unwrap_or_default();
        let renamed = match self.renamed_from.and_then(old_interface) {
            Some(OldInterface::Renamed { history, .. }) => format!(
                " and \"{}\" as \"{}\" ({history})",
                self.renamed_from.unwrap_or_default(),
                self.interface
            ),
            _ => String::new(),
        };
        format!(
            "\"{text}\" is Player 1's `key::interface:index`: reading \"{key}\" as a key (no \
             host of that name resolves; Player 2 and 3 read a host there){renamed}; write \
             \"{key}:::{iface}:{index}\"",
            text = self.text,
            iface = self.interface,
            index = self.index
        )
    }

    /// The port, with the server default for an absent robot field.
    pub fn port_or(&self, default: u16) -> u16 {
        self.port.unwrap_or(default)
    }

    /// Short form for reports: `key:host:port:interface:index` with defaults filled in.
    pub fn describe(&self, default_port: u16) -> String {
        let host = match self.host.ipv4() {
            Some(ip) => ip.to_string(),
            None => match &self.host {
                Host::Name(n) => n.clone(),
                _ => String::new(),
            },
        };
        let key = self
            .key
            .as_deref()
            .map(|k| format!("{k}:"))
            .unwrap_or_default();
        format!(
            "{key}{host}:{}:{}:{}",
            self.port_or(default_port),
            self.interface,
            self.index
        )
    }
}

/// One `driver ( ... )` block.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DriverSpec {
    /// Its section in the document.
    pub section: EntityId,
    /// Where the block is written.
    pub location: Option<SourceLoc>,
    /// Driver name (`stage`, `vfh`, ...).
    pub name: String,
    /// Plugin library to load first.
    pub plugin: Option<String>,
    /// Devices this driver offers, in order (up to the first malformed one).
    pub provides: Vec<DeviceAddr>,
    /// Devices it subscribes to (up to the first malformed one).
    pub requires: Vec<DeviceAddr>,
    /// Malformed addresses, at most one per field: like Player, parsing a field stops at its
    /// first bad string, and a driver with one fails to start. The file itself still loads.
    #[serde(skip)]
    pub address_errors: Vec<Error>,
    /// Stage model to bind (stage driver).
    pub model: Option<String>,
    /// Worldfile (stage driver's simulation block), as written.
    pub worldfile: Option<String>,
    /// `alwayson`.
    pub alwayson: Option<bool>,
    /// Every other field, raw: driver-specific options.
    pub options: BTreeMap<String, Vec<String>>,
}

/// A parsed `.cfg` file.
#[derive(Clone, Debug)]
pub struct CfgFile {
    /// The document (sections and raw fields).
    pub doc: Document,
    /// The path as given.
    pub path: PathBuf,
    /// Driver blocks in file order.
    pub drivers: Vec<DriverSpec>,
    /// Problems that do not stop loading.
    pub warnings: Vec<Warning>,
}

const DRIVER_FIELDS: &[&str] = &[
    "name",
    "plugin",
    "provides",
    "requires",
    "model",
    "worldfile",
    "alwayson",
];

impl CfgFile {
    /// Loads a cfg file (and its includes). An address in Player 1's `key::interface:index`
    /// form whose would-be host does not resolve is read as Player 1 read it, with a warning
    /// ([`DeviceAddr::as_player1_key`]): Stage's own `amcl-sonar.cfg` requires
    /// `odometry::position:0`, which Player 3 refuses for want of a host `odometry`.
    pub fn load(path: &Path, opts: &LoadOptions) -> Result<CfgFile, Error> {
        let doc = loader::load_document(path, Dialect::Cfg, opts)?;
        Self::from_document(path, doc, &host_resolves)
    }

    /// Parses `text` as the cfg file at `path` (as [`CfgFile::load`] reads it).
    pub fn parse(path: &Path, text: &str, opts: &LoadOptions) -> Result<CfgFile, Error> {
        let doc = loader::parse_document(path, text.as_bytes().to_vec(), Dialect::Cfg, opts)?;
        Self::from_document(path, doc, &host_resolves)
    }

    /// `resolves` says whether a host name names a machine (Player 1 keys are the names that
    /// do not).
    fn from_document(
        path: &Path,
        doc: Document,
        resolves: &dyn Fn(&str) -> bool,
    ) -> Result<CfgFile, Error> {
        let mut warnings = doc.warnings.clone();
        let mut drivers = Vec::new();
        for section in doc.entities_of_type("driver") {
            drivers.push(read_driver(&doc, section, resolves, &mut warnings)?);
        }
        Ok(CfgFile {
            path: path.to_path_buf(),
            doc,
            drivers,
            warnings,
        })
    }

    /// The worldfile path the stage driver would load for `driver` (player-cfg.md §8.2):
    /// absolute as written, else relative to the directory of the cfg path as given.
    pub fn worldfile_path(&self, driver: &DriverSpec) -> Option<PathBuf> {
        let wf = driver.worldfile.as_deref()?;
        Some(if wf.starts_with('/') {
            PathBuf::from(wf)
        } else {
            self.path.parent().unwrap_or(Path::new("")).join(wf)
        })
    }
}

/// Whether `name` resolves to an IPv4 address, as the server will need it to (the server packs
/// IPv4 hosts only).
fn host_resolves(name: &str) -> bool {
    (name, 0)
        .to_socket_addrs()
        .is_ok_and(|mut addrs| addrs.any(|a| a.is_ipv4()))
}

/// The first value of a field [`Document::use_property`] returned, as text.
fn field_text(doc: &Document, p: &Property) -> Option<String> {
    doc.values(p).first().map(|v| v.text.to_string())
}

/// Player's `ReadBool`: yes/true/1 and no/false/0.
fn read_bool(doc: &Document, p: &Property, warnings: &mut Vec<Warning>) -> Option<bool> {
    let text = field_text(doc, p)?;
    match text.as_str() {
        "yes" | "true" | "1" => Some(true),
        "no" | "false" | "0" => Some(false),
        _ => match atoi(&text) {
            // `alwayson` is read with ReadInt by Player: any integer counts.
            Some(n) if n.complete => Some(n.value != 0),
            _ => {
                warnings.push(Warning::at(
                    doc.loc(p.loc),
                    format!(
                        "`{}` \"{text}\" is not a boolean; ignored as in Player",
                        doc.name(p)
                    ),
                ));
                None
            }
        },
    }
}

fn read_driver(
    doc: &Document,
    section: EntityId,
    resolves: &dyn Fn(&str) -> bool,
    warnings: &mut Vec<Warning>,
) -> Result<DriverSpec, Error> {
    let entity = doc.entity(section);
    let location = entity.loc.map(|l| doc.loc(l));
    let field = |name: &str| {
        doc.use_property(section, name)
            .and_then(|p| field_text(doc, p))
    };
    let Some(name) = field("name") else {
        return Err(match entity.loc {
            Some(loc) => Error::at(ErrorKind::MissingDriverName, &doc.sources, loc, "driver"),
            None => Error::new(ErrorKind::MissingDriverName),
        });
    };
    let mut address_errors = Vec::new();
    let mut renamed = Vec::new();
    let mut addresses = |field: &str| -> Vec<DeviceAddr> {
        let mut out = Vec::new();
        let Some(p) = doc.use_property(section, field) else {
            return out;
        };
        for v in doc.values(p) {
            match DeviceAddr::parse(&v.text) {
                Ok(mut a) => {
                    a.location = Some(doc.loc(v.loc));
                    let player1 = a.as_player1_key().filter(|_| match &a.host {
                        Host::Name(name) => !resolves(name),
                        _ => false,
                    });
                    if let Some(p1) = player1 {
                        renamed.push(Warning::at(doc.loc(v.loc), p1.player1_key_warning()));
                        a = p1;
                    } else if let Some(w) = a.old_name_warning() {
                        renamed.push(Warning::at(doc.loc(v.loc), w));
                    }
                    out.push(a);
                }
                Err(reason) => {
                    address_errors.push(Error::at(
                        ErrorKind::BadDeviceAddress {
                            field: field.into(),
                            text: v.text.to_string(),
                            reason,
                        },
                        &doc.sources,
                        v.loc,
                        &format!("\"{}\"", v.text),
                    ));
                    break;
                }
            }
        }
        out
    };
    let provides = addresses("provides");
    let requires = addresses("requires");
    warnings.append(&mut renamed);
    let options = doc
        .properties(section)
        .iter()
        .filter(|p| !DRIVER_FIELDS.contains(&doc.name(p)))
        .map(|p| {
            (
                doc.name(p).to_string(),
                doc.values(p).iter().map(|v| v.text.to_string()).collect(),
            )
        })
        .collect();
    Ok(DriverSpec {
        section,
        location,
        name,
        plugin: field("plugin"),
        provides,
        requires,
        address_errors,
        model: field("model"),
        worldfile: field("worldfile"),
        alwayson: doc
            .use_property(section, "alwayson")
            .and_then(|p| read_bool(doc, p, warnings)),
        options,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn addr(s: &str) -> DeviceAddr {
        DeviceAddr::parse(s).unwrap_or_else(|e| panic!("{s}: {e}"))
    }

    #[test]
    fn address_short_forms_and_defaults() {
        // player-cfg.md §5.3, with the server default port 6665.
        let a = addr("ranger:1");
        assert_eq!(
            (a.host.clone(), a.port_or(6665), a.interface, a.index, a.key),
            (Host::Default, 6665, InterfaceCode::RANGER, 1, None)
        );
        let a = addr("6666:position2d:0");
        assert_eq!(
            (a.port, a.interface, a.index),
            (Some(6666), InterfaceCode::POSITION2D, 0)
        );
        let a = addr("6665:ranger:1");
        assert_eq!((a.port, a.index), (Some(6665), 1));
        let a = addr("127.0.0.1::ranger:2");
        assert_eq!(
            (a.host.clone(), a.port, a.index),
            (Host::Name("127.0.0.1".into()), None, 2)
        );
        assert_eq!(a.host.ipv4(), Some(Ipv4Addr::LOCALHOST));
        let a = addr("localhost:7000:fiducial:3");
        assert_eq!(
            (a.port, a.interface, a.index),
            (Some(7000), InterfaceCode::FIDUCIAL, 3)
        );
        assert!(a.host.is_local());
        let a = addr(":7002:ranger:0");
        assert_eq!((a.host.clone(), a.port), (Host::Default, Some(7002)));
        let a = addr("::ranger:1");
        assert_eq!((a.host.clone(), a.port, a.index), (Host::Default, None, 1));
        let a = addr("odometry:::position2d:4");
        assert_eq!(
            (a.key.as_deref(), a.host.clone(), a.port, a.index),
            (Some("odometry"), Host::Default, None, 4)
        );
        let a = addr("2130706433:7001:gripper:6");
        assert_eq!(
            (a.host.clone(), a.port, a.index),
            (Host::Packed(2130706433), Some(7001), 6)
        );
        assert_eq!(Host::Packed(16777343).ipv4(), Some(Ipv4Addr::LOCALHOST));
        let a = addr("x:a:b:c:7000:ranger:5");
        assert_eq!(
            (a.key.as_deref(), a.host.clone(), a.port),
            (Some("b"), Host::Name("c".into()), Some(7000))
        );
        assert_eq!(a.describe(6665), "b:c:7000:ranger:5");
        assert_eq!(addr("ranger:1").describe(6665), "127.0.0.1:6665:ranger:1");
    }

    #[test]
    fn address_errors() {
        assert!(
            DeviceAddr::parse("ranger")
                .unwrap_err()
                .contains("missing interface")
        );
        assert!(
            DeviceAddr::parse("foo:0")
                .unwrap_err()
                .contains("unknown interface `foo`")
        );
        assert!(
            DeviceAddr::parse("ranger:x")
                .unwrap_err()
                .contains("not a number")
        );
        assert!(
            DeviceAddr::parse("70000:ranger:0")
                .unwrap_err()
                .contains("out of range")
        );
        assert!(
            DeviceAddr::parse("abc:ranger:0")
                .unwrap_err()
                .contains("port `abc`")
        );
        assert!(
            DeviceAddr::parse("ranger:70000")
                .unwrap_err()
                .contains("out of range")
        );
    }

    #[test]
    fn older_players_interface_names() {
        let a = addr("position:0");
        assert_eq!(
            (a.interface, a.renamed_from),
            (InterfaceCode::POSITION2D, Some("position"))
        );
        assert_eq!(
            a.old_name_warning().unwrap(),
            "interface \"position\" is an older Player's name (Player 1.x's name for code 4, \
             renamed in Player 2.0); serving it as \"position2d\" (write \"position2d:0\")"
        );
        let a = addr("odometry::6665:position:3");
        assert_eq!(
            (a.key.as_deref(), a.port, a.index),
            (Some("odometry"), Some(6665), 3)
        );
        assert!(
            a.old_name_warning()
                .unwrap()
                .ends_with("(write \"odometry::6665:position2d:3\")"),
            "{:?}",
            a.old_name_warning()
        );
        assert_eq!(addr("energy:1").interface, InterfaceCode::POWER);
        assert_eq!(addr("position2d:0").old_name_warning(), None);
        let e = DeviceAddr::parse("truth:0").unwrap_err();
        assert!(
            e.starts_with("unknown interface `truth` (an older Player's, removed in Player 2.1; use `simulation`"),
            "{e}"
        );
        // Every old name is one Player 3.0.2 rejects; renamed ones land on 3.0.2 interfaces.
        for (old, what) in OLD_INTERFACE_NAMES {
            assert_eq!(InterfaceCode::from_name(old), None, "{old}");
            if let OldInterface::Renamed { now, .. } = what {
                assert!(now.name().is_some(), "{old}");
            }
        }
        // In a cfg: read as the new name, with a warning at the address.
        let cfg = CfgFile::parse(
            Path::new("old.cfg"),
            "driver( name \"amcl\"\n provides [\"localize:0\"]\n requires [\"7000:position:0\" \"sonar:0\"] )\n",
            &LoadOptions::default(),
        )
        .unwrap();
        let d = &cfg.drivers[0];
        assert_eq!(d.requires[0].interface, InterfaceCode::POSITION2D);
        assert!(d.address_errors.is_empty());
        assert_eq!(cfg.warnings.len(), 1, "{:?}", cfg.warnings);
        let w = cfg.warnings[0].to_string();
        assert!(
            w.starts_with(
                "old.cfg:3:12: warning: interface \"position\" is an older Player's name"
            ) && w.ends_with("(write \"7000:position2d:0\")"),
            "{w}"
        );
    }

    #[test]
    fn player1_keys_where_player3_puts_a_host() {
        // The Player 1 reading exists for four fields with a bare name first, and only then.
        let p1 = addr("odometry::position:0").as_player1_key().unwrap();
        assert_eq!(
            (
                p1.key.as_deref(),
                p1.host.clone(),
                p1.port,
                p1.interface,
                p1.index
            ),
            (
                Some("odometry"),
                Host::Default,
                None,
                InterfaceCode::POSITION2D,
                0
            )
        );
        let p1 = addr("laser::map:2").as_player1_key().unwrap();
        assert_eq!(
            (p1.key.as_deref(), p1.port, p1.index),
            (Some("laser"), None, 2)
        );
        assert_eq!(
            p1.player1_key_warning(),
            "\"laser::map:2\" is Player 1's `key::interface:index`: reading \"laser\" as a key \
             (no host of that name resolves; Player 2 and 3 read a host there); write \
             \"laser:::map:2\""
        );
        for not_player1 in [
            "otherhost:6665:laser:0",
            "localhost::ranger:0",
            "127.0.0.1::ranger:0",
            "2130706433::ranger:0",
            "robot.lab::ranger:0",
            "odometry:robot::position2d:0",
            ":odometry::position2d:0",
            "6665:ranger:0",
            "ranger:0",
        ] {
            assert_eq!(addr(not_player1).as_player1_key(), None, "{not_player1}");
        }

        // In a cfg: taken when the name does not resolve, with one warning naming the Player 3
        // address (the interface renamed too); a host that resolves stays a host.
        let text = "driver( name \"amcl\" provides [\"localize:0\"]\n requires [\"odometry::position:0\" \"sonar:0\" \"sonar::map:0\" \"robot7::map:1\"] )\n";
        let doc = |t: &str| {
            loader::parse_document(
                Path::new("p1.cfg"),
                t.as_bytes().to_vec(),
                Dialect::Cfg,
                &LoadOptions::default(),
            )
            .unwrap()
        };
        let cfg = CfgFile::from_document(Path::new("p1.cfg"), doc(text), &|name: &str| {
            name == "robot7"
        })
        .unwrap();
        let r = &cfg.drivers[0].requires;
        let read: Vec<_> = r
            .iter()
            .map(|a| (a.key.as_deref(), a.host.clone(), a.interface))
            .collect();
        assert_eq!(
            read,
            [
                (Some("odometry"), Host::Default, InterfaceCode::POSITION2D),
                (None, Host::Default, InterfaceCode::SONAR),
                (Some("sonar"), Host::Default, InterfaceCode::MAP),
                (None, Host::Name("robot7".into()), InterfaceCode::MAP),
            ]
        );
        let warnings: Vec<String> = cfg.warnings.iter().map(|w| w.to_string()).collect();
        assert_eq!(
            warnings,
            [
                "p1.cfg:2:12: warning: \"odometry::position:0\" is Player 1's \
                 `key::interface:index`: reading \"odometry\" as a key (no host of that name \
                 resolves; Player 2 and 3 read a host there) and \"position\" as \"position2d\" \
                 (Player 1.x's name for code 4, renamed in Player 2.0); write \
                 \"odometry:::position2d:0\"",
                "p1.cfg:2:45: warning: \"sonar::map:0\" is Player 1's `key::interface:index`: \
                 reading \"sonar\" as a key (no host of that name resolves; Player 2 and 3 read a \
                 host there); write \"sonar:::map:0\"",
            ]
        );
        // Loaded for real, a name no resolver knows is a key.
        let cfg = CfgFile::parse(Path::new("p1.cfg"), text, &LoadOptions::default()).unwrap();
        assert_eq!(cfg.drivers[0].requires[0].key.as_deref(), Some("odometry"));
    }

    #[test]
    fn drivers_and_options() {
        let cfg = CfgFile::parse(
            Path::new("dir/x.cfg"),
            "driver( name \"stage\" plugin \"stageplugin\" provides [\"simulation:0\"] worldfile \"w.world\" usegui false)\n\
             driver\n(\n name \"vfh\"\n provides [\"6665:position2d:1\"\n   \"key:::laser:0\"]\n requires [\"position2d:0\"]\n safety_dist 0.1\n alwayson 1\n)\n",
            &LoadOptions::default(),
        )
        .unwrap();
        assert_eq!(cfg.drivers.len(), 2);
        let d0 = &cfg.drivers[0];
        assert_eq!(d0.name, "stage");
        assert_eq!(d0.plugin.as_deref(), Some("stageplugin"));
        assert_eq!(d0.options.get("usegui"), Some(&vec!["false".to_string()]));
        assert_eq!(cfg.worldfile_path(d0), Some(PathBuf::from("dir/w.world")));
        let d1 = &cfg.drivers[1];
        assert_eq!(d1.provides.len(), 2);
        assert_eq!(d1.provides[1].key.as_deref(), Some("key"));
        assert_eq!(d1.requires[0].interface, InterfaceCode::POSITION2D);
        assert_eq!(d1.alwayson, Some(true));
        assert_eq!(
            d1.options.get("safety_dist"),
            Some(&vec!["0.1".to_string()])
        );
        assert_eq!(d1.location.as_ref().unwrap().line, 2);
    }

    #[test]
    fn driver_errors_are_located() {
        let e = CfgFile::parse(
            Path::new("x.cfg"),
            "\ndriver( provides [\"ranger:0\"] )\n",
            &LoadOptions::default(),
        )
        .unwrap_err();
        assert_eq!(e.kind, ErrorKind::MissingDriverName);
        assert_eq!(e.location.as_ref().unwrap().line, 2);
        // A bad address does not stop the file loading, but stops its field (as in Player).
        let cfg = CfgFile::parse(
            Path::new("x.cfg"),
            "driver( name \"stage\" provides [\"simulation:0\" \"foo:0\" \"ranger:0\"] )\n",
            &LoadOptions::default(),
        )
        .unwrap();
        let d = &cfg.drivers[0];
        assert_eq!(d.provides.len(), 1);
        assert_eq!(d.address_errors.len(), 1);
        let e = &d.address_errors[0];
        assert!(matches!(e.kind, ErrorKind::BadDeviceAddress { .. }));
        assert_eq!(e.location.as_ref().unwrap().col, 47);
    }

    #[test]
    fn duplicate_fields_merge_element_wise() {
        let cfg = CfgFile::parse(
            Path::new("x.cfg"),
            "driver( name \"a\" provides [\"simulation:0\" \"ranger:0\" \"ranger:1\"] provides [\"simulation:9\"] )\n",
            &LoadOptions::default(),
        )
        .unwrap();
        let texts: Vec<&str> = cfg.drivers[0]
            .provides
            .iter()
            .map(|a| a.text.as_str())
            .collect();
        assert_eq!(texts, vec!["simulation:9", "ranger:0", "ranger:1"]);
    }
}
