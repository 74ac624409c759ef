//! The `playerv` binary: Player's device viewer. Connects to a Player server, lists its
//! devices, subscribes the ones named on the command line (`--ranger:0`, `--position2d:0`, …)
//! and draws them; more can be (un)subscribed from the Devices menu. As playernav, it takes
//! `HOST:PORT` arguments for a navigation stack per robot: `playerv --map:0 --planner:0
//! --localize:0 localhost:6665 localhost:6666` shows both robots on the first one's map, and
//! clicks send goals to (and set poses of) the robot chosen in the Robot menu.

use std::path::PathBuf;
use std::time::Duration;

use anyhow::{Context, bail};
use clap::Parser;
use player_client::DataMode;
use player_proto::constants::PLAYERTCP_DEFAULT_PORT;
use viewer::playerv::{self, PlayervOptions, state::DeviceKey};

/// Player 3.0.2's device viewer. Devices are named as in playerv: `--INTERFACE:INDEX`
/// (e.g. `--position2d:0 --ranger:0`; the index defaults to 0).
#[derive(Parser, Debug)]
#[command(name = "playerv", version, disable_help_flag = true)]
struct Args {
    /// Server host (playerv's `-h`; help is `--help`).
    #[arg(short = 'h', long = "host", default_value = "localhost")]
    host: String,
    /// Server port.
    #[arg(short = 'p', long = "port", default_value_t = PLAYERTCP_DEFAULT_PORT)]
    port: u16,
    /// Ask for data with requests (PULL mode) instead of having it pushed.
    #[arg(long, conflicts_with = "push")]
    pull: bool,
    /// Have the server push data as it comes (the default).
    #[arg(long)]
    push: bool,
    /// Reads per second.
    #[arg(long, value_name = "HZ", default_value_t = 5.0)]
    rate: f64,
    /// Draw localisers' particle clouds from the start (also in the Navigation menu).
    #[arg(long)]
    particles: bool,
    /// Save a PNG of the window after `--screenshot-after` seconds, then quit.
    #[arg(long, value_name = "FILE.png")]
    screenshot: Option<PathBuf>,
    /// Wall seconds before `--screenshot` is taken.
    #[arg(long, value_name = "SECONDS", default_value_t = 2.0)]
    screenshot_after: f64,
    /// Servers as playernav names them (`HOST:PORT`, one robot each); when given, they
    /// replace `-h`/`-p`.
    #[arg(value_name = "HOST:PORT", value_parser = parse_server)]
    servers: Vec<(String, u16)>,
    /// Print help.
    #[arg(long, action = clap::ArgAction::Help)]
    help: Option<bool>,
}

/// `host:port` (the port defaulting to Player's 6665 when only a host is given).
fn parse_server(s: &str) -> Result<(String, u16), String> {
    match s.rsplit_once(':') {
        Some((host, port)) if !host.is_empty() => port
            .parse()
            .map(|p| (host.to_string(), p))
            .map_err(|_| format!("\"{port}\" is not a port number")),
        Some(_) => Err(format!("\"{s}\" names no host")),
        None => Ok((s.to_string(), PLAYERTCP_DEFAULT_PORT)),
    }
}

/// Takes playerv's device flags (`--ranger:0`, `--laser`) out of the arguments: clap cannot
/// declare one flag per interface and index. Anything that names no interface is left for
/// clap, which reports it.
fn split_device_flags(args: Vec<String>) -> (Vec<String>, Vec<DeviceKey>) {
    let mut rest = Vec::new();
    let mut devices = Vec::new();
    for (i, a) in args.into_iter().enumerate() {
        let device = (i > 0)
            .then(|| a.strip_prefix("--"))
            .flatten()
            .and_then(DeviceKey::parse);
        match device {
            Some(d) if !devices.contains(&d) => devices.push(d),
            Some(_) => {}
            None => rest.push(a),
        }
    }
    (rest, devices)
}

fn main() -> std::process::ExitCode {
    cli::exit_status(run())
}

fn run() -> anyhow::Result<()> {
    let (rest, devices) = split_device_flags(std::env::args().collect());
    let args = Args::parse_from(rest);
    if !(args.rate.is_finite() && args.rate > 0.0) {
        bail!("--rate must be a positive number of reads per second");
    }
    if !(args.screenshot_after.is_finite() && args.screenshot_after >= 0.0) {
        bail!("--screenshot-after must be >= 0");
    }
    let (host, port) = args
        .servers
        .first()
        .cloned()
        .unwrap_or((args.host.clone(), args.port));
    let options = PlayervOptions {
        host: host.clone(),
        port,
        more_servers: args.servers.iter().skip(1).cloned().collect(),
        particles: args.particles,
        devices,
        mode: if args.pull {
            DataMode::Pull
        } else {
            DataMode::Push
        },
        rate_hz: args.rate,
        screenshot: args.screenshot.clone(),
        screenshot_after: Duration::from_secs_f64(args.screenshot_after),
    };
    playerv::run(options).with_context(|| format!("playerv on {host}:{port}"))?;
    if let Some(p) = &args.screenshot {
        println!("screenshot saved to {}", p.display());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn strings(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn device_flags_are_taken_out_and_the_rest_left_for_clap() {
        let (rest, devices) = split_device_flags(strings(&[
            "playerv",
            "-h",
            "robot1",
            "--ranger:1",
            "--position2d",
            "--pull",
            "--ranger:1",
            "--nonsense:0",
        ]));
        assert_eq!(
            rest,
            strings(&["playerv", "-h", "robot1", "--pull", "--nonsense:0"])
        );
        let names: Vec<String> = devices.iter().map(ToString::to_string).collect();
        assert_eq!(names, ["ranger:1", "position2d:0"]);
        let args = Args::try_parse_from(&rest[..4]).expect("parses");
        assert_eq!(args.host, "robot1");
        assert!(args.pull);
        assert!(
            Args::try_parse_from(rest).is_err(),
            "unknown flags are errors"
        );
    }

    #[test]
    fn servers_are_taken_as_playernav_takes_them() {
        let args =
            Args::try_parse_from(["playerv", "localhost:6665", "robot2:7000", "robot3"]).unwrap();
        assert_eq!(
            args.servers,
            vec![
                ("localhost".to_string(), 6665),
                ("robot2".to_string(), 7000),
                ("robot3".to_string(), 6665)
            ]
        );
        assert!(Args::try_parse_from(["playerv", "host:port"]).is_err());
        assert!(Args::try_parse_from(["playerv", ":6665"]).is_err());
    }
}
