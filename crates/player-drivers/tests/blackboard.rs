//! `localbb` over TCP: one client sets entries, another listening to the key receives them,
//! and stops receiving them once it unsubscribes; a group subscriber hears its whole group.

mod common;

use std::time::{Duration, Instant};

use player_client::{BlackboardProxy, ClientError, DataMode, PlayerClient};
use player_proto::{BlackboardEntry, Text};
use player_server::Pace;

const CFG: &str = "driver( name \"localbb\" provides [\"0:blackboard:0\"] )\n";

fn entry(group: &str, key: &str, data: &[u8]) -> BlackboardEntry {
    BlackboardEntry {
        key: Text::new(key),
        group: Text::new(group),
        kind: 1,
        subtype: 1,
        data: data.to_vec(),
        timestamp_sec: 1_700_000_000,
        timestamp_usec: 5,
    }
}

/// Reads until `board` has received `wanted`; returns every update seen on the way, in order
/// (in PUSH mode a successful read is one DATA message, and the listener subscribes to the
/// blackboard alone).
fn updates_until(
    client: &PlayerClient,
    board: &BlackboardProxy,
    wanted: &BlackboardEntry,
) -> Vec<BlackboardEntry> {
    let deadline = Instant::now() + Duration::from_secs(10);
    let mut seen: Vec<BlackboardEntry> = Vec::new();
    loop {
        assert!(
            Instant::now() < deadline,
            "timed out waiting for {wanted:?}; saw {seen:?}"
        );
        match client.read() {
            Ok(()) => {
                let u = board.update().expect("the data read is an update");
                seen.push(u.clone());
                if &u == wanted {
                    return seen;
                }
            }
            Err(ClientError::Timeout { .. }) => {}
            Err(e) => panic!("reading: {e}"),
        }
    }
}

#[test]
fn entries_reach_the_clients_listening_to_their_key_or_group() {
    let dir = std::env::temp_dir();
    let handle = common::serve_cfg(&dir, "bb-test.cfg", CFG, Pace::default());
    let port = handle.ports()[0];
    let setter = PlayerClient::connect("localhost", port).unwrap();
    let listener = PlayerClient::connect("localhost", port).unwrap();
    listener.set_datamode(DataMode::Push).unwrap();
    listener.set_read_timeout(Some(Duration::from_millis(200)));
    let a = BlackboardProxy::new(&setter, 0).unwrap();
    let b = BlackboardProxy::new(&listener, 0).unwrap();
    assert_eq!(a.driver_name(), "localbb");

    // B listens to "pose" in "robot1"; nothing set yet.
    let now = b.subscribe_to_key("pose", "robot1").unwrap();
    assert_eq!(now.key.to_str_lossy(), "pose");
    assert_eq!(now.group.to_str_lossy(), "robot1");
    assert!(now.data.is_empty());

    // A sets it: B receives it as it was set; A reads it back with GET_ENTRY.
    let first = entry("robot1", "pose", &[1, 2, 3]);
    a.set_entry(first.clone()).unwrap();
    assert_eq!(
        updates_until(&listener, &b, &first),
        std::slice::from_ref(&first)
    );
    assert_eq!(a.get_entry("pose", "robot1").unwrap(), first);
    // A later subscriber is answered with the stored entry.
    assert_eq!(a.subscribe_to_key("pose", "robot1").unwrap(), first);
    a.unsubscribe_from_key("pose", "robot1").unwrap();

    // B stops listening to "pose" and listens to "goal": a set of "pose" no longer reaches
    // it, while the later set of "goal" does (the server keeps each client's order).
    b.unsubscribe_from_key("pose", "robot1").unwrap();
    b.subscribe_to_key("goal", "robot1").unwrap();
    a.set_entry(entry("robot1", "pose", &[4])).unwrap();
    let goal = entry("robot1", "goal", &[5]);
    a.set_entry(goal.clone()).unwrap();
    assert_eq!(
        updates_until(&listener, &b, &goal),
        std::slice::from_ref(&goal)
    );

    // A group subscription lists the group's entries (by key), then hears every set in it.
    b.unsubscribe_from_key("goal", "robot1").unwrap();
    b.subscribe_to_group("robot1").unwrap();
    let pose = entry("robot1", "pose", &[4]);
    assert_eq!(
        updates_until(&listener, &b, &pose),
        [goal.clone(), pose.clone()]
    );
    let other = entry("robot2", "pose", &[6]);
    a.set_entry(other).unwrap();
    let last = entry("robot1", "speed", &[7]);
    a.set_entry(last.clone()).unwrap();
    assert_eq!(updates_until(&listener, &b, &last), [last]);
    b.unsubscribe_from_group("robot1").unwrap();
    drop((a, b, setter, listener));
    handle.shutdown();
}
