//! The node's parameters: stage_ros2's (branch `humble`, `src/stage_node.cpp`), each with its
//! default, in one table ([`PARAMETERS`]) that both the `--ros-args` reader and the binary's
//! plain flags use, so a name or default is written once.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::Error;

/// A parameter's type, as ROS 2 declares it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// `true`/`false`.
    Bool,
    /// A float (an integer is taken too, as rclcpp's `double` parameters are not).
    Double,
    /// A string.
    String,
}

/// One parameter: name, type, default and what it does.
#[derive(Clone, Copy, Debug)]
pub struct Parameter {
    /// The ROS 2 name (`enforce_prefixes`).
    pub name: &'static str,
    /// Its type.
    pub kind: Kind,
    /// Its default, as text.
    pub default: &'static str,
    /// What it does (the `--help` text).
    pub doc: &'static str,
}

/// Every parameter stage_ros2 declares, with its default, plus `use_stamped_velocity` (of
/// later stage_ros2 versions) and `use_sim_time` (stage_ros2 forces it true).
pub const PARAMETERS: &[Parameter] = &[
    Parameter {
        name: "world_file",
        kind: Kind::String,
        default: "cave.world",
        doc: "The Stage world to load (a positional world file wins over it)",
    },
    Parameter {
        name: "enable_gui",
        kind: Kind::Bool,
        default: "true",
        doc: "Show the world window (headless without a display, or with -g)",
    },
    Parameter {
        name: "enforce_prefixes",
        kind: Kind::Bool,
        default: "false",
        doc: "Prefix topics with the vehicle's name even when there is one vehicle",
    },
    Parameter {
        name: "one_tf_tree",
        kind: Kind::Bool,
        default: "false",
        doc: "Publish every vehicle's transforms on /tf and /tf_static with prefixed frames",
    },
    Parameter {
        name: "use_static_transformations",
        kind: Kind::Bool,
        default: "true",
        doc: "Publish sensor frames once on tf_static (else on tf every step)",
    },
    Parameter {
        name: "base_watchdog_timeout",
        kind: Kind::Double,
        default: "5.0",
        doc: "Seconds (sim time) after the last cmd_vel at which a vehicle stops",
    },
    Parameter {
        name: "is_depth_canonical",
        kind: Kind::Bool,
        default: "true",
        doc: "Depth images as 32-bit float metres (else 16-bit millimetres)",
    },
    Parameter {
        name: "publish_ground_truth",
        kind: Kind::Bool,
        default: "true",
        doc: "Publish each vehicle's true pose on ground_truth",
    },
    Parameter {
        name: "frame_id_odom",
        kind: Kind::String,
        default: "odom",
        doc: "The odometry frame (prefixed under one_tf_tree)",
    },
    Parameter {
        name: "frame_id_world",
        kind: Kind::String,
        default: "world",
        doc: "The frame of ground_truth (prefixed under one_tf_tree)",
    },
    Parameter {
        name: "frame_id_base_link",
        kind: Kind::String,
        default: "base_link",
        doc: "The vehicle's body frame (prefixed under one_tf_tree)",
    },
    Parameter {
        name: "use_stamped_velocity",
        kind: Kind::Bool,
        default: "false",
        doc: "cmd_vel carries geometry_msgs/TwistStamped instead of Twist",
    },
    Parameter {
        name: "use_sim_time",
        kind: Kind::Bool,
        default: "true",
        doc: "The node's time is the simulation's (always; false is refused with a warning)",
    },
];

/// The parameters' values, typed.
#[derive(Clone, Debug, PartialEq)]
pub struct Params {
    /// `world_file`.
    pub world_file: PathBuf,
    /// `enable_gui`.
    pub enable_gui: bool,
    /// `enforce_prefixes`.
    pub enforce_prefixes: bool,
    /// `one_tf_tree`.
    pub one_tf_tree: bool,
    /// `use_static_transformations`.
    pub use_static_transformations: bool,
    /// `base_watchdog_timeout` (s).
    pub base_watchdog_timeout: f64,
    /// `is_depth_canonical`.
    pub is_depth_canonical: bool,
    /// `publish_ground_truth`.
    pub publish_ground_truth: bool,
    /// `frame_id_odom`.
    pub frame_id_odom: String,
    /// `frame_id_world`.
    pub frame_id_world: String,
    /// `frame_id_base_link`.
    pub frame_id_base_link: String,
    /// `use_stamped_velocity`.
    pub use_stamped_velocity: bool,
}

impl Default for Params {
    /// Every parameter at its default in [`PARAMETERS`].
    fn default() -> Params {
        let mut p = Params {
            world_file: PathBuf::new(),
            enable_gui: false,
            enforce_prefixes: false,
            one_tf_tree: false,
            use_static_transformations: false,
            base_watchdog_timeout: 0.0,
            is_depth_canonical: false,
            publish_ground_truth: false,
            frame_id_odom: String::new(),
            frame_id_world: String::new(),
            frame_id_base_link: String::new(),
            use_stamped_velocity: false,
        };
        for d in PARAMETERS {
            p.set(d.name, d.default)
                .expect("every default in PARAMETERS parses");
        }
        p
    }
}

/// Reads a boolean as ROS 2's YAML does (`true`, `True`, `false`, ...).
fn parse_bool(name: &str, value: &str) -> Result<bool, Error> {
    match value.trim().to_ascii_lowercase().as_str() {
        "true" | "1" | "yes" | "on" => Ok(true),
        "false" | "0" | "no" | "off" => Ok(false),
        _ => Err(Error::BadParameter {
            name: name.to_string(),
            message: format!("`{value}` is not a boolean (true or false)"),
        }),
    }
}

impl Params {
    /// Sets parameter `name` from its text. An unknown name or a value of the wrong type is an
    /// error naming the parameter.
    pub fn set(&mut self, name: &str, value: &str) -> Result<(), Error> {
        let value = unquote(value);
        let flag = |v: &str| parse_bool(name, v);
        match name {
            "world_file" => self.world_file = PathBuf::from(value),
            "enable_gui" => self.enable_gui = flag(value)?,
            "enforce_prefixes" => self.enforce_prefixes = flag(value)?,
            "one_tf_tree" => self.one_tf_tree = flag(value)?,
            "use_static_transformations" => self.use_static_transformations = flag(value)?,
            "base_watchdog_timeout" => {
                let t: f64 = value.trim().parse().map_err(|_| Error::BadParameter {
                    name: name.to_string(),
                    message: format!("`{value}` is not a number"),
                })?;
                if !t.is_finite() {
                    return Err(Error::BadParameter {
                        name: name.to_string(),
                        message: format!("`{value}` is not a finite number of seconds"),
                    });
                }
                self.base_watchdog_timeout = t;
            }
            "is_depth_canonical" => self.is_depth_canonical = flag(value)?,
            "publish_ground_truth" => self.publish_ground_truth = flag(value)?,
            "frame_id_odom" => self.frame_id_odom = value.to_string(),
            "frame_id_world" => self.frame_id_world = value.to_string(),
            "frame_id_base_link" => self.frame_id_base_link = value.to_string(),
            "use_stamped_velocity" => self.use_stamped_velocity = flag(value)?,
            "use_sim_time" => {
                if !flag(value)? {
                    tracing::warn!(
                        "use_sim_time:=false ignored: the simulator's node runs on its own clock"
                    );
                }
            }
            _ => return Err(Error::UnknownParameter(name.to_string())),
        }
        Ok(())
    }
}

/// Strips one pair of matching quotes (`'cave.world'`), as ROS 2's YAML values may have.
fn unquote(v: &str) -> &str {
    let v = v.trim();
    for q in ['"', '\''] {
        if let Some(inner) = v.strip_prefix(q).and_then(|s| s.strip_suffix(q)) {
            return inner;
        }
    }
    v
}

/// What `--ros-args` sections carried besides parameters: the node's name and namespace
/// (`-r __node:=NAME`, `-r __ns:=/NS`, as a launch file's `Node(name=, namespace=)` passes
/// them) and topic remappings (`-r FROM:=TO`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RosArgs {
    /// Parameters in the order given (`-p`, then each `--params-file`'s in file order).
    pub parameters: Vec<(String, String)>,
    /// `__node`, when remapped.
    pub node_name: Option<String>,
    /// `__ns`, when remapped.
    pub namespace: Option<String>,
    /// Topic remappings, `FROM` -> `TO`.
    pub remaps: BTreeMap<String, String>,
}

/// Splits a command line into the arguments that are ours (returned first, program name
/// included) and what its `--ros-args ... [--]` sections say, as rclcpp reads them. Unknown
/// ROS arguments (`--log-level`, `--enclave`, ...) are skipped with their value and a warning.
pub fn split_ros_args(
    argv: impl IntoIterator<Item = String>,
) -> Result<(Vec<String>, RosArgs), Error> {
    let mut ours = Vec::new();
    let mut ros = RosArgs::default();
    let mut it = argv.into_iter();
    let mut in_ros = false;
    while let Some(a) = it.next() {
        if !in_ros {
            if a == "--ros-args" {
                in_ros = true;
            } else {
                ours.push(a);
            }
            continue;
        }
        let mut value = |what: &str| {
            it.next()
                .ok_or_else(|| Error::BadRosArgs(format!("{what} needs a value")))
        };
        match a.as_str() {
            "--" => in_ros = false,
            "--ros-args" => {}
            "-p" | "--param" => {
                let v = value(&a)?;
                let (name, val) = v
                    .split_once(":=")
                    .ok_or_else(|| Error::BadRosArgs(format!("`-p {v}`: expected NAME:=VALUE")))?;
                // a node-qualified name (`stage_ros2:world_file`) is ours too
                let name = name.rsplit(':').next().unwrap_or(name);
                ros.parameters.push((name.to_string(), val.to_string()));
            }
            "--params-file" => {
                let path = value(&a)?;
                ros.parameters.extend(read_params_file(Path::new(&path))?);
            }
            "-r" | "--remap" => {
                let v = value(&a)?;
                let (from, to) = v
                    .split_once(":=")
                    .ok_or_else(|| Error::BadRosArgs(format!("`-r {v}`: expected FROM:=TO")))?;
                // a node-qualified rule (`stage_ros2:cmd_vel:=x`) applies to us
                let from = from.rsplit(':').next().unwrap_or(from);
                match from {
                    "__node" | "__name" => ros.node_name = Some(to.to_string()),
                    "__ns" => ros.namespace = Some(to.to_string()),
                    _ => {
                        ros.remaps.insert(from.to_string(), to.to_string());
                    }
                }
            }
            "--log-level" | "--enclave" | "-e" | "--log-config-file" => {
                value(&a)?;
                tracing::warn!("--ros-args {a}: not supported, ignored");
            }
            other => tracing::warn!("--ros-args {other}: not supported, ignored"),
        }
    }
    Ok((ours, ros))
}

/// The parameters of a ROS 2 parameter file, as `ros2 launch` writes them for a `Node`'s
/// `parameters=[{...}]`: sections per node (`/**:`, `stage_ros2:`, `/ns/stage_ros2:`), each with
/// `ros__parameters:` and one `name: value` per line. Scalars only; a nested mapping or a list
/// is an error naming the line.
pub fn read_params_file(path: &Path) -> Result<Vec<(String, String)>, Error> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::ParamsFile {
        path: path.to_path_buf(),
        line: 0,
        message: e.to_string(),
    })?;
    parse_params_yaml(&text).map_err(|(line, message)| Error::ParamsFile {
        path: path.to_path_buf(),
        line,
        message,
    })
}

/// [`read_params_file`]'s reader, on text: errors are `(line, message)`.
fn parse_params_yaml(text: &str) -> Result<Vec<(String, String)>, (usize, String)> {
    let mut out = Vec::new();
    // indentation of `ros__parameters:` when inside one
    let mut params_indent: Option<usize> = None;
    for (n, raw) in text.lines().enumerate() {
        let line_no = n + 1;
        let line = match raw.find(" #") {
            Some(i) => &raw[..i],
            None if raw.trim_start().starts_with('#') => "",
            None => raw,
        };
        if line.trim().is_empty() || line.trim() == "---" {
            continue;
        }
        let indent = line.len() - line.trim_start().len();
        let (key, value) = line.trim().split_once(':').ok_or_else(|| {
            (
                line_no,
                format!("expected `key: value`, found `{}`", line.trim()),
            )
        })?;
        let value = value.trim();
        match params_indent {
            Some(pi) if indent > pi => {
                if value.is_empty() || value.starts_with('[') || value.starts_with('{') {
                    return Err((
                        line_no,
                        format!("parameter `{key}`: only single values are supported"),
                    ));
                }
                out.push((key.trim().to_string(), value.to_string()));
            }
            _ => {
                params_indent = (key.trim() == "ros__parameters").then_some(indent);
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(s: &str) -> Vec<String> {
        s.split_whitespace().map(str::to_string).collect()
    }

    #[test]
    fn defaults_are_stage_ros2s() {
        let p = Params::default();
        assert_eq!(p.world_file, PathBuf::from("cave.world"));
        assert!(p.enable_gui && p.use_static_transformations && p.is_depth_canonical);
        assert!(p.publish_ground_truth);
        assert!(!p.enforce_prefixes && !p.one_tf_tree && !p.use_stamped_velocity);
        assert_eq!(p.base_watchdog_timeout, 5.0);
        assert_eq!(
            (
                p.frame_id_odom.as_str(),
                p.frame_id_world.as_str(),
                p.frame_id_base_link.as_str()
            ),
            ("odom", "world", "base_link")
        );
    }

    #[test]
    fn ros_args_sections_are_taken_out_of_the_command_line() {
        let (ours, ros) = split_ros_args(args(
            "stage_ros2 -g w.world --ros-args -p enforce_prefixes:=true -p stage_ros2:one_tf_tree:=True \
             -r __node:=sim -r __ns:=/team -r cmd_vel:=teleop -- --fast",
        ))
        .unwrap();
        assert_eq!(ours, args("stage_ros2 -g w.world --fast"));
        assert_eq!(
            ros.parameters,
            vec![
                ("enforce_prefixes".into(), "true".into()),
                ("one_tf_tree".into(), "True".into())
            ]
        );
        assert_eq!(ros.node_name.as_deref(), Some("sim"));
        assert_eq!(ros.namespace.as_deref(), Some("/team"));
        assert_eq!(
            ros.remaps.get("cmd_vel").map(String::as_str),
            Some("teleop")
        );
        let mut p = Params::default();
        for (n, v) in &ros.parameters {
            p.set(n, v).unwrap();
        }
        assert!(p.enforce_prefixes && p.one_tf_tree);
    }

    #[test]
    fn bad_parameters_name_themselves() {
        let mut p = Params::default();
        let e = p
            .set("base_watchdog_timeout", "soon")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("base_watchdog_timeout") && e.contains("soon"),
            "{e}"
        );
        let e = p.set("enable_gui", "maybe").unwrap_err().to_string();
        assert!(e.contains("enable_gui"), "{e}");
        let e = p.set("no_such_thing", "1").unwrap_err().to_string();
        assert!(e.contains("no_such_thing"), "{e}");
        assert!(split_ros_args(args("x --ros-args -p world_file")).is_err());
        assert!(split_ros_args(args("x --ros-args -p")).is_err());
        p.set("base_watchdog_timeout", "2").unwrap();
        assert_eq!(p.base_watchdog_timeout, 2.0);
        p.set("world_file", "'my world.world'").unwrap();
        assert_eq!(p.world_file, PathBuf::from("my world.world"));
    }

    #[test]
    fn a_launch_params_file_is_read() {
        let text = "/**:\n  ros__parameters:\n    world_file: /tmp/cave.world  # the map\n    \
                    enable_gui: false\n    base_watchdog_timeout: 0.5\n# done\n";
        assert_eq!(
            parse_params_yaml(text).unwrap(),
            vec![
                ("world_file".into(), "/tmp/cave.world".into()),
                ("enable_gui".into(), "false".into()),
                ("base_watchdog_timeout".into(), "0.5".into()),
            ]
        );
        let nested = "stage_ros2:\n  ros__parameters:\n    frames:\n      odom: o\n";
        let (line, msg) = parse_params_yaml(nested).unwrap_err();
        assert_eq!(line, 3, "{msg}");
        assert!(msg.contains("frames"));
        assert_eq!(parse_params_yaml("other:\n  x: 1\n").unwrap(), vec![]);
    }
}
