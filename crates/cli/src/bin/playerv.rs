//! The `playerv` binary: Player's device viewer. Connects to a Player server, lists its
//! devices, subscribes the ones named on the command line (`--ranger:0`, `--position2d:0`, …)
//! and draws them; more can be (un)subscribed from the Devices menu.

use std::path::PathBuf;
use std::time::Duration;

use anyhow::{Context, bail};
use clap::Parser;
use player_client::DataMode;
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
    #[arg(short = 'p', long = "port", default_value_t = 6665)]
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
    /// Save a PNG of the window after `--screenshot-after` seconds, then quit.
    #[arg(long, value_name = "FILE.png")]
    screenshot: Option<PathBuf>,
    /// Wall seconds before `--screenshot` is taken.
    #[arg(long, value_name = "SECONDS", default_value_t = 2.0)]
    screenshot_after: f64,
    /// Print help.
    #[arg(long, action = clap::ArgAction::Help)]
    help: Option<bool>,
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

fn main() -> anyhow::Result<()> {
    let (rest, devices) = split_device_flags(std::env::args().collect());
    let args = Args::parse_from(rest);
    if !(args.rate.is_finite() && args.rate > 0.0) {
        bail!("--rate must be a positive number of reads per second");
    }
    if !(args.screenshot_after.is_finite() && args.screenshot_after >= 0.0) {
        bail!("--screenshot-after must be >= 0");
    }
    let options = PlayervOptions {
        host: args.host.clone(),
        port: args.port,
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
    playerv::run(options).with_context(|| format!("playerv on {}:{}", args.host, args.port))?;
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
}
