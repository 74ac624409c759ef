//! What a Player client reads from a server: player-client's `PlayerClient` and proxies over a
//! socket whose server sends the banner, then the fuzz input as its replies, then closes.
//!
//! The client does what a libplayerc++ program does at start: connect (which switches to PULL
//! mode, waiting for the ACK), list the devices, subscribe a position2d, a ranger and a laser
//! proxy, read a few rounds and look at the proxies' data. Any reply may be garbage, missing or
//! out of order: every call must come back (the server closes, so no call may hang) with data or
//! a `ClientError`, never a panic.

#![no_main]

use std::io::{Read, Write};
use std::net::{Shutdown, TcpListener};
use std::sync::OnceLock;
use std::time::Duration;

use libfuzzer_sys::fuzz_target;
use player_client::{LaserProxy, PlayerClient, Position2dProxy, RangerProxy};
use player_proto::BANNER;

fn listener() -> &'static TcpListener {
    static L: OnceLock<TcpListener> = OnceLock::new();
    L.get_or_init(|| TcpListener::bind("127.0.0.1:0").expect("bind a local port"))
}

/// The session a client program would run; stops at the first error.
fn session(port: u16) -> Result<(), player_client::ClientError> {
    let client = PlayerClient::connect("127.0.0.1", port)?;
    client.set_request_timeout(Duration::from_secs(2));
    client.set_read_timeout(Some(Duration::from_secs(2)));
    let _ = client.banner();
    let devices = client.device_list()?;
    let _ = format!("{devices:?}");
    let position = Position2dProxy::new(&client, 0)?;
    let ranger = RangerProxy::new(&client, 0)?;
    let laser = LaserProxy::new(&client, 0)?;
    for _ in 0..3 {
        client.read()?;
        let _ = (position.pose(), position.velocity(), position.stall());
        let _ = (ranger.ranges(), ranger.intensities());
        let _ = (laser.scan(), laser.ranges(), laser.scan_pose());
        let _ = client.take_updated();
    }
    let _ = ranger.request_geom()?;
    let _ = position.request_geom()?;
    let _ = laser.request_config()?;
    Ok(())
}

fuzz_target!(|data: &[u8]| {
    let l = listener();
    let port = l.local_addr().expect("local address").port();
    let replies = data.to_vec();
    let server = std::thread::spawn(move || {
        let (mut s, _) = l.accept().expect("accept the client");
        let _ = s.write_all(&BANNER);
        let _ = s.write_all(&replies);
        let _ = s.shutdown(Shutdown::Write);
        // take what the client sends until it hangs up
        let mut sink = [0u8; 4096];
        let _ = s.set_read_timeout(Some(Duration::from_secs(5)));
        while matches!(s.read(&mut sink), Ok(n) if n > 0) {}
    });
    let _ = session(port);
    server.join().expect("fake server thread");
});
