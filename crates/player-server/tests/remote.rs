//! [`RemoteLink`] against our own server with the test driver: the link a driver uses to reach a
//! device on another Player server.

mod common;

use std::sync::mpsc;
use std::time::{Duration, Instant};

use common::{block, start};
use player_proto::constants::{LOCALHOST_ADDR, PLAYER_OPEN_MODE};
use player_proto::{
    Body, DeviceAddr, InterfaceCode, Message, Pose2d, Position2dCmd, Position2dCmdVel,
    Position2dData, Position2dMsg, Position2dReq, Position2dSpeedPidReq, RangerData, RangerMsg,
    RangerReq,
};
use player_server::remote::{LinkTimeouts, RemoteError, RemoteEvent, RemoteLink};
use player_server::{Pace, ServerHandle};

const P2D: InterfaceCode = InterfaceCode::POSITION2D;
const RANGER: InterfaceCode = InterfaceCode::RANGER;

/// A server whose test driver (registered as `test`) provides position2d:0 and ranger:0,
/// stepping every 20 ms in real time, plus whatever `options` say.
fn server(options: &[(&str, &str)]) -> (ServerHandle, u16) {
    let mut opts = vec![("step_ms", "20")];
    opts.extend_from_slice(options);
    let b = block("test", 0, &[(P2D, 0), (RANGER, 0)], &opts);
    let server = start(&[b], Pace::RealTime { speedup: 1.0 }, Vec::new());
    let port = server.ports()[0];
    (server, port)
}

fn runtime() -> tokio::runtime::Runtime {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .unwrap()
}

fn remote(port: u16, interf: InterfaceCode, index: u16) -> DeviceAddr {
    DeviceAddr::new(LOCALHOST_ADDR, u32::from(port), interf, index)
}

struct Linked {
    link: RemoteLink,
    events: mpsc::Receiver<RemoteEvent>,
}

fn link(rt: &tokio::runtime::Runtime, device: DeviceAddr) -> Linked {
    let (tx, events) = mpsc::channel();
    let link = RemoteLink::spawn(
        rt.handle(),
        "127.0.0.1".into(),
        device.robot as u16,
        device,
        PLAYER_OPEN_MODE,
        move |e| {
            let _ = tx.send(e);
        },
    );
    Linked { link, events }
}

impl Linked {
    /// The next event that is not DATA (DATA seen meanwhile is returned too).
    fn next_non_data(&self) -> (RemoteEvent, Vec<Message>) {
        let end = Instant::now() + Duration::from_secs(10);
        let mut data = Vec::new();
        loop {
            let left = end.saturating_duration_since(Instant::now());
            match self.events.recv_timeout(left) {
                Ok(RemoteEvent::Data(m)) => data.push(m),
                Ok(other) => return (other, data),
                Err(e) => panic!("no event within 10 s: {e}"),
            }
        }
    }

    /// The next DATA message.
    fn next_data(&self) -> Message {
        match self.events.recv_timeout(Duration::from_secs(5)) {
            Ok(RemoteEvent::Data(m)) => m,
            other => panic!("expected data, got {other:?}"),
        }
    }

    fn connected(&self) -> String {
        match self.next_non_data().0 {
            RemoteEvent::Connected { driver_name } => driver_name,
            other => panic!("expected Connected, got {other:?}"),
        }
    }
}

fn pose_of(m: &Message) -> Pose2d {
    match &m.body {
        Body::Position2d(Position2dMsg::Data(Position2dData::State(s))) => s.pos,
        other => panic!("not a position2d state: {other:?}"),
    }
}

#[test]
fn position2d_data_requests_and_commands() {
    let (_server, port) = server(&[]);
    let rt = runtime();
    let device = remote(port, P2D, 0);
    let l = link(&rt, device);
    assert_eq!(l.connected(), "test");

    // Data flows, labelled with the remote address.
    let first = l.next_data();
    assert_eq!(first.header.addr, device);
    assert_eq!(pose_of(&first), Pose2d::default());

    // GET_GEOM is answered with the test driver's geometry.
    let ticket = l.link.request(Position2dReq::GetGeom(None).into());
    let (reply, _) = l.next_non_data();
    let RemoteEvent::Reply { ticket: t, result } = reply else {
        panic!("{reply:?}")
    };
    assert_eq!(t, ticket);
    let ack = result.unwrap();
    assert_eq!(ack.header.addr, device);
    let Body::Position2d(Position2dMsg::Ack(Position2dReq::GetGeom(Some(geom)))) = ack.body else {
        panic!("{:?}", ack.body)
    };
    assert_eq!((geom.pose.px, geom.size.sl), (0.1, 0.5));

    // A request the driver does not handle is NACKed; the link stays up.
    let ticket = l
        .link
        .request(Position2dReq::SpeedPid(Some(Position2dSpeedPidReq::default())).into());
    let (reply, _) = l.next_non_data();
    match reply {
        RemoteEvent::Reply {
            ticket: t,
            result: Err(RemoteError::Nack { request, link }),
        } => {
            assert_eq!(t, ticket);
            assert_eq!(request, "PLAYER_POSITION2D_REQ_SPEED_PID");
            assert_eq!(link, format!("position2d:0 at 127.0.0.1:{port}"));
        }
        other => panic!("{other:?}"),
    }

    // A velocity command moves the simulated base forward.
    let vel = Position2dCmdVel {
        vel: Pose2d {
            px: 1.0,
            ..Pose2d::default()
        },
        state: 1,
    };
    l.link.command(Position2dCmd::Vel(vel).into());
    let end = Instant::now() + Duration::from_secs(5);
    loop {
        let m = l.next_data();
        if pose_of(&m).px > 0.1 {
            break;
        }
        assert!(Instant::now() < end, "the command never moved the base");
    }

    // Requests queue and are answered in order.
    let tickets: Vec<_> = (0..3)
        .map(|_| l.link.request(Position2dReq::ResetOdom.into()))
        .collect();
    for ticket in tickets {
        match l.next_non_data().0 {
            RemoteEvent::Reply {
                ticket: t,
                result: Ok(m),
            } => {
                assert_eq!(t, ticket);
                assert_eq!(m.body, Position2dMsg::Ack(Position2dReq::ResetOdom).into());
            }
            other => panic!("{other:?}"),
        }
    }

    l.link.close();
    match l.next_non_data().0 {
        RemoteEvent::Closed(text) => {
            assert_eq!(
                text,
                format!("remote position2d:0 at 127.0.0.1:{port}: link closed")
            )
        }
        other => panic!("{other:?}"),
    }
    // Nothing after Closed.
    assert!(l.events.recv_timeout(Duration::from_millis(200)).is_err());
}

#[test]
fn ranger_data_and_geometry() {
    let (_server, port) = server(&[("samples", "6")]);
    let rt = runtime();
    let device = remote(port, RANGER, 0);
    let l = link(&rt, device);
    assert_eq!(l.connected(), "test");
    let mut saw_range = false;
    let mut saw_intns = false;
    while !(saw_range && saw_intns) {
        let m = l.next_data();
        assert_eq!(m.header.addr, device);
        match m.body {
            Body::Ranger(RangerMsg::Data(RangerData::Range(r))) => {
                assert_eq!(r.ranges.len(), 6);
                saw_range = true;
            }
            Body::Ranger(RangerMsg::Data(RangerData::Intns(i))) => {
                assert_eq!(i.intensities.len(), 6);
                saw_intns = true;
            }
            other => panic!("{other:?}"),
        }
    }
    let ticket = l.link.request(RangerReq::GetGeom(None).into());
    match l.next_non_data().0 {
        RemoteEvent::Reply {
            ticket: t,
            result: Ok(m),
        } => {
            assert_eq!(t, ticket);
            let Body::Ranger(RangerMsg::Ack(RangerReq::GetGeom(Some(g)))) = m.body else {
                panic!("{:?}", m.body)
            };
            assert_eq!(g.element_poses.len(), 6);
        }
        other => panic!("{other:?}"),
    }
    // Dropping the link closes it.
    let events = {
        let Linked { link, events } = l;
        drop(link);
        events
    };
    let end = Instant::now() + Duration::from_secs(10);
    loop {
        match events.recv_timeout(end.saturating_duration_since(Instant::now())) {
            Ok(RemoteEvent::Data(_)) => {}
            Ok(RemoteEvent::Closed(text)) => {
                assert!(text.ends_with("link closed"), "{text}");
                break;
            }
            other => panic!("{other:?}"),
        }
    }
}

#[test]
fn missing_device_fails() {
    let (_server, port) = server(&[]);
    let rt = runtime();
    let l = link(&rt, remote(port, RANGER, 5));
    match l.next_non_data().0 {
        RemoteEvent::Failed(text) => {
            assert_eq!(
                text,
                format!(
                    "remote ranger:5 at 127.0.0.1:{port}: no such device on the remote server \
                     (DEV NACK)"
                )
            );
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn refused_subscription_fails() {
    let (_server, port) = server(&[("fail_subscribe", "1")]);
    let rt = runtime();
    let l = link(&rt, remote(port, P2D, 0));
    match l.next_non_data().0 {
        RemoteEvent::Failed(text) => {
            assert!(text.contains("asked for access 1, granted 3"), "{text}")
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn server_going_away_closes_the_link() {
    let (server, port) = server(&[]);
    let rt = runtime();
    let l = link(&rt, remote(port, P2D, 0));
    l.connected();
    l.next_data();
    server.shutdown();
    match l.next_non_data().0 {
        RemoteEvent::Closed(text) => {
            assert!(text.contains(&format!("127.0.0.1:{port}")), "{text}");
            assert!(text.contains("closed the connection"), "{text}");
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn requests_before_connected_wait_for_the_subscription() {
    let (_server, port) = server(&[]);
    let rt = runtime();
    let l = link(&rt, remote(port, P2D, 0));
    // Issued at once, before the set-up can have finished.
    let ticket = l.link.request(Position2dReq::GetGeom(None).into());
    assert_eq!(l.connected(), "test");
    match l.next_non_data().0 {
        RemoteEvent::Reply {
            ticket: t,
            result: Ok(_),
        } => assert_eq!(t, ticket),
        other => panic!("{other:?}"),
    }
}

#[test]
fn silent_device_by_host_name() {
    // Name resolution, explicit timeouts, and a device that publishes nothing: no data, but
    // requests are answered.
    let (_server, port) = server(&[("silent", "1")]);
    let rt = runtime();
    let device = remote(port, P2D, 0);
    let (tx, events) = mpsc::channel();
    let link = RemoteLink::spawn_with(
        rt.handle(),
        "localhost".into(),
        port,
        device,
        PLAYER_OPEN_MODE,
        LinkTimeouts {
            setup: Duration::from_secs(5),
            request: Duration::from_millis(300),
        },
        move |e| {
            let _ = tx.send(e);
        },
    );
    let next = || events.recv_timeout(Duration::from_secs(5)).unwrap();
    assert!(matches!(next(), RemoteEvent::Connected { .. }));
    let t = link.request(Position2dReq::GetGeom(None).into());
    assert!(matches!(next(), RemoteEvent::Reply { ticket, result: Ok(_) } if ticket == t));
    // No data at all arrives from a silent device.
    assert!(events.recv_timeout(Duration::from_millis(300)).is_err());
}
