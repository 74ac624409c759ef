//! The Player/Stage manual's rubbish collector on `player-client`: Bigbob wanders, keeps off
//! things with its sonars, turns towards the biggest blob, and when its tooth laser says
//! something is between its teeth it "collects" it, moving the nearest orange or carton to the
//! bin with the simulation interface. The same controller as `examples/bigbob/bigbob.cc`.
//!
//! `cargo run --example bigbob -- [--host H] [--port P] [--iterations N] [--robot NAME]`
//! against `player worlds/bigbob.cfg` (or `cargo run --release --bin player`).

use std::process::ExitCode;

use player_client::{
    BlobfinderProxy, ClientError, PlayerClient, Position2dProxy, RangerProxy, SimulationProxy,
};

/// Closer than this on a front sonar (m): turn away.
const AVOID_RANGE: f64 = 0.6;
/// Cruising speed (m/s) and turn rate (rad/s).
const CRUISE: f64 = 0.3;
const TURN: f64 = 0.6;
/// A tooth-laser range below this means something sits between the teeth (max is 0.25 m).
const CAUGHT_RANGE: f64 = 0.2;
/// What Bigbob collects.
const THINGS: [&str; 10] = [
    "orange1", "orange2", "orange3", "orange4", "orange5", "orange6", "carton1", "carton2",
    "carton3", "carton4",
];

struct Options {
    host: String,
    port: u16,
    iterations: Option<u64>,
    robot: String,
}

fn options() -> Result<Options, String> {
    let mut o = Options {
        host: "localhost".into(),
        port: player_client::DEFAULT_PORT,
        iterations: None,
        robot: "bob1".into(),
    };
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut value = || args.next().ok_or(format!("{a} needs a value"));
        match a.as_str() {
            "--host" => o.host = value()?,
            "--port" => o.port = value()?.parse().map_err(|e| format!("--port: {e}"))?,
            "--iterations" => {
                o.iterations = Some(value()?.parse().map_err(|e| format!("--iterations: {e}"))?)
            }
            "--robot" => o.robot = value()?,
            other => return Err(format!("unknown argument {other}")),
        }
    }
    Ok(o)
}

/// Speed and turn rate from the sonars (front-left, front-right, left, right corner) and the
/// blobs; the flag says whether Bigbob is avoiding something.
fn steer(sonar: &[f64], eyes: &BlobfinderProxy) -> (f64, f64, bool) {
    if let [fl, fr, l, r, ..] = *sonar {
        let (left, right) = (fl.min(l), fr.min(r));
        if left < AVOID_RANGE || right < AVOID_RANGE {
            let turn = if left < right { -TURN } else { TURN };
            return (0.0, turn, true);
        }
    }
    let data = eyes.data();
    let biggest = eyes
        .blobs()
        .into_iter()
        .max_by_key(|b| b.right.saturating_sub(b.left));
    match (biggest, data) {
        (Some(b), Some(d)) if d.width > 0 => {
            let centre = f64::from(d.width) / 2.0;
            (CRUISE * 0.5, 0.01 * (centre - f64::from(b.x)), false)
        }
        _ => (CRUISE, 0.2, false),
    }
}

/// Moves the thing nearest to the point 1 m ahead of the robot into the bin.
fn collect(
    sim: &SimulationProxy,
    robot: &str,
    collected: u32,
) -> Result<Option<&'static str>, ClientError> {
    let r = sim.get_pose2d(robot)?;
    let (tx, ty) = (r.px + r.pa.cos(), r.py + r.pa.sin());
    let mut nearest = None;
    let mut best = 1.0;
    for name in THINGS {
        let p = sim.get_pose2d(name)?;
        let d = (p.px - tx).hypot(p.py - ty);
        if d < best {
            best = d;
            nearest = Some(name);
        }
    }
    if let Some(name) = nearest {
        sim.set_pose2d(name, -7.0 + 0.4 * f64::from(collected), -7.4, 0.0)?;
    }
    Ok(nearest)
}

fn run(o: &Options) -> Result<(), ClientError> {
    let client = PlayerClient::connect(&o.host, o.port)?;
    let base = Position2dProxy::new(&client, 0)?;
    let sonar = RangerProxy::new(&client, 0)?;
    let eyes = BlobfinderProxy::new(&client, 0)?;
    let laser = RangerProxy::new(&client, 1)?;
    let sim = SimulationProxy::new(&client, 0)?;
    base.set_motor_enable(true)?;
    let geom = sonar.request_geom()?;
    println!(
        "bigbob: connected to {}:{}, {} sonars",
        o.host,
        o.port,
        geom.element_poses.len()
    );
    let (mut collected, mut avoided, mut saw_blobs) = (0u32, 0u64, 0u64);
    let mut i = 0u64;
    while o.iterations.is_none_or(|n| i < n) {
        i += 1;
        match client.read() {
            // A slow loop may find old data dropped by the server: the newest is still there.
            Ok(()) | Err(ClientError::Overflow { .. }) => {}
            Err(e) => return Err(e),
        }
        let (speed, turn, avoiding) = steer(&sonar.ranges(), &eyes);
        avoided += u64::from(avoiding);
        saw_blobs += u64::from(!eyes.blobs().is_empty());
        if laser.ranges().iter().any(|&r| r < CAUGHT_RANGE) {
            if let Some(name) = collect(&sim, &o.robot, collected)? {
                collected += 1;
                println!("bigbob: collected {name}");
            }
        }
        base.set_speed(speed, 0.0, turn)?;
    }
    base.set_speed(0.0, 0.0, 0.0)?;
    let p = base.pose();
    println!(
        "bigbob: pose {:.2} {:.2} {:.2}, {saw_blobs} reads with blobs, {avoided} avoiding, {collected} collected",
        p.px, p.py, p.pa
    );
    Ok(())
}

fn main() -> ExitCode {
    let o = match options() {
        Ok(o) => o,
        Err(e) => {
            eprintln!("bigbob: {e}");
            return ExitCode::from(2);
        }
    };
    match run(&o) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("bigbob: {e}");
            ExitCode::FAILURE
        }
    }
}
