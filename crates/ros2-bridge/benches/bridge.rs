//! What the bridge costs: a world of 100 diff robots, each with a 181-ray laser, stepped
//! headless as fast as possible, without the bridge and with it (every vehicle's odom,
//! ground truth, scan and transform, and /clock, published after every step). The DDS
//! participant is loopback only (`ROS_LOCALHOST_ONLY=1` semantics) in `ROS_DOMAIN_ID` or 231.
//! With no subscriber (the bridge writes only what someone reads, so this is its floor); with
//! no subscriber but every topic written anyway, as stage_ros2 does
//! ([`Bridge::publish_unmatched`]: every message built, serialised and handed to RustDDS at
//! every step); with a reader subscribed to everything (this bench run again as a child
//! process, `--reader`, taking every odom, ground_truth, base_scan, tf and /clock sample, all
//! reliable); and with a reader of everything as nav2 and rviz subscribe (`--reader-nav`:
//! scans best effort, keep last 5, as nav2's costmap and slam_toolbox take LaserScan with
//! `SensorDataQoS`; odom, ground_truth, tf and /clock reliable). The readers' runs also give
//! the latency from the end of a step to its scan (r0's) reaching the reader (wall clock, both
//! processes on this machine). On a 2-core machine the reader's own work competes
//! with the simulation, as a ROS 2 node on the same machine would; so each bridged run also
//! reports CPU time per step from the kernel's per-thread accounting (`/proc/PID/task/*/
//! schedstat`): the world's step (the `stage-sim` threads, less the stepping thread's time
//! inside `publish`, from its thread CPU clock), the bridge's own work (`publish` on the
//! stepping thread, the publisher thread, RustDDS's threads) and the reader process's.
//!
//! Each bridged run is preceded by a run of the world alone, so that its share is taken
//! against the load of the same moment. A last run reads everything at a pace the machine
//! keeps (`PACED_SPEEDUP` times real time), for the step-to-scan latency under that load
//! without the backlog of a run flat out.
//!
//! `cargo bench -p ros2-bridge --bench bridge [-- STEPS]`

use std::collections::HashMap;
use std::io::{BufRead, Read, Write};
use std::process::{Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use ros2_bridge::bridge::PUBLISHER_THREAD_NAME;
use ros2_bridge::msgs::{Clock, LaserScan, Odometry, RosType, TfMessage};
use ros2_bridge::{Bridge, Discovery, Params, RosArgs};
use ros2_client::dds::rustdds::mio1;
use ros2_client::qos::{History, Reliability};
use ros2_client::{
    Context, MessageTypeName, Name, NodeName, NodeOptions, QosProfile, Subscription,
};
use stage_sim::World;
use stage_sim::pacing::Pacer;
use worldfile::{LoadOptions, WorldSpec};

/// 100 robots on a 10 x 10 grid, 2 m apart, in a walled 24 m square.
fn world_text() -> String {
    let mut w = String::new();
    w.push_str("resolution 0.02\ninterval_sim 100\n");
    for (name, x, y, sx, sy) in [
        ("north", 0.0, 12.0, 24.0, 0.1),
        ("south", 0.0, -12.0, 24.0, 0.1),
        ("east", 12.0, 0.0, 0.1, 24.0),
        ("west", -12.0, 0.0, 0.1, 24.0),
    ] {
        w.push_str(&format!(
            "model ( name \"{name}\" pose [{x} {y} 0 0] size [{sx} {sy} 0.5] )\n"
        ));
    }
    for i in 0..10 {
        for j in 0..10 {
            let (x, y) = (-9.0 + 2.0 * i as f64, -9.0 + 2.0 * j as f64);
            w.push_str(&format!(
                "position ( name \"r{}\" pose [{x} {y} 0 {}] size [0.4 0.4 0.3] drive \"diff\" \
                 ranger ( sensor ( range [0 8] fov 180 samples 181 ) size [0.1 0.1 0.1] ) )\n",
                i * 10 + j,
                (i * 37 + j * 11) % 360
            ));
        }
    }
    w
}

fn load() -> World {
    let dir = std::env::temp_dir().join(format!("ros2-bridge-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a temporary directory");
    let path = dir.join("fleet.world");
    std::fs::write(&path, world_text()).expect("writing the world");
    let spec = WorldSpec::load(&path, &LoadOptions::default()).expect("the bench world loads");
    let _ = std::fs::remove_dir_all(&dir);
    World::from_owned_spec(spec, 1).expect("the bench world builds")
}

fn context() -> Context {
    let vars = |k: &str| match k {
        "ROS_LOCALHOST_ONLY" => Some("1".to_string()),
        "ROS_DOMAIN_ID" => Some(std::env::var(k).unwrap_or_else(|_| "231".into())),
        _ => None,
    };
    Discovery::from_vars(vars)
        .and_then(|d| d.context())
        .expect("a DDS participant")
}

/// A world with every position model and ranger subscribed (the rangers update only then),
/// as the bridge subscribes them.
fn load_subscribed() -> World {
    let mut world = load();
    let models: Vec<_> = world.models().collect();
    for m in models {
        if matches!(
            world.model_type(m),
            Ok(stage_sim::ModelType::Position | stage_sim::ModelType::Ranger)
        ) {
            world.subscribe(m).expect("a model of the world");
        }
    }
    world
}

/// A subscription the reader drains, type-erased: the number of samples taken.
trait Drain: Send {
    fn drain(&self) -> usize;
    /// Registers it for readiness events (so only subscriptions with data are read, as a
    /// ROS 2 executor's wait set does: a take costs RustDDS a system call).
    fn register(&mut self, registry: &mio1::Registry, token: mio1::Token);
}

impl<T: RosType> Drain for Subscription<T> {
    fn register(&mut self, registry: &mio1::Registry, token: mio1::Token) {
        mio1::event::Source::register(self, registry, token, mio1::Interest::READABLE)
            .expect("a subscription registers for events");
    }

    fn drain(&self) -> usize {
        let mut n = 0;
        while let Ok(Some(_)) = self.take() {
            n += 1;
        }
        n
    }
}

/// What a reader process subscribes to, and with which QoS.
#[derive(Clone, Copy, PartialEq)]
enum ReaderKind {
    /// Every topic, reliable (`--reader`).
    All,
    /// Every topic as nav2 and rviz take them: scans best effort, the rest reliable
    /// (`--reader-nav`).
    Nav,
    /// r0's scan alone, reliable (`--reader-scan`).
    Scan0,
}

impl ReaderKind {
    fn arg(self) -> &'static str {
        match self {
            ReaderKind::All => "--reader",
            ReaderKind::Nav => "--reader-nav",
            ReaderKind::Scan0 => "--reader-scan",
        }
    }

    fn from_arg(arg: &str) -> Option<ReaderKind> {
        [ReaderKind::All, ReaderKind::Nav, ReaderKind::Scan0]
            .into_iter()
            .find(|k| k.arg() == arg)
    }

    /// Whether it reads every topic (else r0's scan alone).
    fn all(self) -> bool {
        self != ReaderKind::Scan0
    }
}

/// A reliable subscription (keep last 10; 100 for tf, as tf2's listener).
fn subscribe<T: RosType>(node: &mut ros2_client::Node, name: &str) -> Subscription<T> {
    let qos = QosProfile::publisher_default().history(History::KeepLast {
        depth: if name.ends_with("tf") { 100 } else { 10 },
    });
    subscribe_with(node, name, qos)
}

/// A scan subscription with `ReaderKind`'s QoS: for `Nav`, rclcpp's `SensorDataQoS` (best
/// effort, volatile, keep last 5), as nav2's costmap layers and slam_toolbox subscribe.
fn subscribe_scan(
    node: &mut ros2_client::Node,
    name: &str,
    kind: ReaderKind,
) -> Subscription<LaserScan> {
    if kind == ReaderKind::Nav {
        let qos = QosProfile::publisher_default()
            .reliability(Reliability::BestEffort)
            .history(History::KeepLast { depth: 5 });
        subscribe_with(node, name, qos)
    } else {
        subscribe(node, name)
    }
}

/// A subscription with `qos`. RustDDS hands a new reader to its event loop through a bounded
/// channel and fails the creation when that is full (400 readers made in a row on a busy
/// machine fill it): the creation is then retried while the loop catches up, 10 s at most.
fn subscribe_with<T: RosType>(
    node: &mut ros2_client::Node,
    name: &str,
    qos: QosProfile,
) -> Subscription<T> {
    let n = Name::parse(name).expect("a topic name");
    let topic = node
        .create_topic(&n, MessageTypeName::new(T::PACKAGE, T::NAME), &qos)
        .expect("a topic");
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        match node.create_subscription(&topic, Some(qos.clone())) {
            Ok(sub) => return sub,
            Err(e) if Instant::now() < deadline => {
                eprintln!("reader: {name}: {e:?}; retrying");
                std::thread::sleep(Duration::from_millis(20));
            }
            Err(e) => panic!("a subscription to {name}: {e:?}"),
        }
    }
}

/// Wall-clock time in ns (comparable between the two processes).
fn wall_ns() -> u128 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_nanos())
        .unwrap_or(0)
}

/// The child: subscribes to every topic the bridge publishes for the fleet (or to r0's scan
/// alone), with `kind`'s QoS, says `ready`, drains them until its stdin closes, then prints
/// `samples N` and `scan STAMP_US WALL_NS` per scan of r0.
fn reader_main(kind: ReaderKind) {
    let all = kind.all();
    let ctx = context();
    let mut node = ctx
        .new_node(
            NodeName::new("/", "bench_reader").expect("a node name"),
            NodeOptions::new().enable_rosout(false),
        )
        .expect("the reader node");
    let mut subs: Vec<Box<dyn Drain>> = Vec::new();
    for i in (0..100).filter(|_| all) {
        subs.push(Box::new(subscribe::<Odometry>(
            &mut node,
            &format!("/r{i}/odom"),
        )));
        subs.push(Box::new(subscribe::<Odometry>(
            &mut node,
            &format!("/r{i}/ground_truth"),
        )));
        if i > 0 {
            subs.push(Box::new(subscribe_scan(
                &mut node,
                &format!("/r{i}/base_scan"),
                kind,
            )));
        }
        subs.push(Box::new(subscribe::<TfMessage>(
            &mut node,
            &format!("/r{i}/tf"),
        )));
    }
    if all {
        subs.push(Box::new(subscribe::<Clock>(&mut node, "/clock")));
    }
    let mut scan0 = subscribe_scan(&mut node, "/r0/base_scan", kind);
    let mut poll = mio1::Poll::new().expect("a poll");
    for (k, sub) in subs.iter_mut().enumerate() {
        sub.register(poll.registry(), mio1::Token(k + 1));
    }
    mio1::event::Source::register(
        &mut scan0,
        poll.registry(),
        mio1::Token(0),
        mio1::Interest::READABLE,
    )
    .expect("the scan subscription registers");
    let stop = Arc::new(AtomicBool::new(false));
    let s = stop.clone();
    std::thread::spawn(move || {
        let _ = std::io::stdin().read_to_end(&mut Vec::new());
        s.store(true, Ordering::Relaxed);
    });
    println!("ready");
    let _ = std::io::stdout().flush();
    let mut samples = 0;
    let mut arrivals = Vec::new();
    let mut events = mio1::Events::with_capacity(1024);
    // every subscription is read once at the start, and then when it has data
    let mut ready: Vec<usize> = (0..=subs.len()).collect();
    while !stop.load(Ordering::Relaxed) {
        for &k in &ready {
            if k == 0 {
                while let Ok(Some((scan, _))) = scan0.take() {
                    let t = scan.header.stamp;
                    let us = t.sec as u64 * 1_000_000 + u64::from(t.nanosec) / 1000;
                    arrivals.push((us, wall_ns()));
                    samples += 1;
                }
            } else if let Some(sub) = subs.get(k - 1) {
                samples += sub.drain();
            }
        }
        ready.clear();
        if poll
            .poll(&mut events, Some(Duration::from_millis(20)))
            .is_err()
        {
            continue;
        }
        ready.extend(events.iter().map(|e| e.token().0));
        ready.sort_unstable();
        ready.dedup();
    }
    let mut out = std::io::stdout().lock();
    let _ = writeln!(out, "samples {samples}");
    for (us, ns) in arrivals {
        let _ = writeln!(out, "scan {us} {ns}");
    }
}

/// The calling thread's CPU time (ns).
fn thread_cpu_ns() -> u64 {
    let mut t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes the timespec it is given and nothing else.
    let r = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut t) };
    if r != 0 {
        return 0;
    }
    t.tv_sec as u64 * 1_000_000_000 + t.tv_nsec as u64
}

/// CPU time (ns) of each thread of process `pid` (`self` for this one), by thread id, with
/// its name: the first field of `schedstat` is the time the thread ran.
fn threads_cpu(pid: &str) -> HashMap<u64, (String, u64)> {
    let mut out = HashMap::new();
    let Ok(tasks) = std::fs::read_dir(format!("/proc/{pid}/task")) else {
        return out;
    };
    for task in tasks.flatten() {
        let Some(tid) = task.file_name().to_str().and_then(|t| t.parse().ok()) else {
            continue;
        };
        let read = |f: &str| std::fs::read_to_string(task.path().join(f)).unwrap_or_default();
        let ns = read("schedstat")
            .split_whitespace()
            .next()
            .and_then(|v| v.parse().ok())
            .unwrap_or(0);
        out.insert(tid, (read("comm").trim().to_string(), ns));
    }
    out
}

/// CPU time (ns) each named group of threads took between two [`threads_cpu`] readings (a
/// thread started in between counts from 0; one that ended is lost).
fn cpu_between(
    before: &HashMap<u64, (String, u64)>,
    after: &HashMap<u64, (String, u64)>,
) -> HashMap<&'static str, u64> {
    let mut out = HashMap::new();
    for (tid, (name, ns)) in after {
        let was = before.get(tid).map_or(0, |(_, b)| *b);
        let group = if name.starts_with("stage-sim") {
            "world"
        } else if name.starts_with("RustDDS") {
            "dds"
        } else if name == PUBLISHER_THREAD_NAME {
            "publisher"
        } else {
            "other"
        };
        *out.entry(group).or_insert(0) += ns.saturating_sub(was);
    }
    out
}

/// What a bridged run measured.
struct Run {
    /// Wall time (s).
    wall: f64,
    /// When each step ended (by sim time, wall ns).
    ended: HashMap<u64, u128>,
    /// The stepping thread's CPU time inside `publish` (ns).
    publish_cpu: u64,
    /// The process's CPU time per thread group over the run (ns).
    cpu: HashMap<&'static str, u64>,
}

/// The pace of the paced run: 5 times real time, 50 steps/s on the bench world, which a
/// 2-core machine sustains with a reader of everything (100 steps/s it does not, quite).
const PACED_SPEEDUP: f64 = 5.0;

/// Steps `world` with `bridge` `steps` times, flat out or paced at `speedup` times real time.
fn bridged(world: &mut World, bridge: &mut Bridge, steps: u64, speedup: Option<f64>) -> Run {
    let mut ended = HashMap::new();
    let mut publish_cpu = 0;
    let mut pacer = speedup.map(|s| Pacer::new(world.config().interval_sim_us, s));
    let before = threads_cpu("self");
    let start = Instant::now();
    stage_sim::on_sim_threads(|| {
        for _ in 0..steps {
            bridge.inbound(world);
            world.step();
            ended.insert(world.sim_time(), wall_ns());
            let t = thread_cpu_ns();
            bridge.publish(world);
            publish_cpu += thread_cpu_ns().saturating_sub(t);
            if let Some(p) = &mut pacer {
                p.wait();
            }
        }
    });
    let wall = start.elapsed().as_secs_f64();
    let cpu = cpu_between(&before, &threads_cpu("self"));
    Run {
        wall,
        ended,
        publish_cpu,
        cpu,
    }
}

/// Prints the CPU time per step of the world, of the bridge (by part) and of the reader
/// process (`reader_ns`, when there is one).
fn report_cpu(run: &Run, steps: u64, reader_ns: Option<u64>) {
    let per_step = |ns: u64| ns as f64 * 1e-6 / steps as f64;
    let g = |k: &str| run.cpu.get(k).copied().unwrap_or(0);
    let world = g("world").saturating_sub(run.publish_cpu);
    let bridge = run.publish_cpu + g("publisher") + g("dds");
    println!(
        "    CPU per step: world {:.2} ms; bridge {:.2} ms (publish on the stepping thread {:.2}, \
         publisher thread {:.2}, RustDDS threads {:.2}) = {:.0}% of this process's{}",
        per_step(world),
        per_step(bridge),
        per_step(run.publish_cpu),
        per_step(g("publisher")),
        per_step(g("dds")),
        100.0 * bridge as f64 / (world + bridge).max(1) as f64,
        match reader_ns {
            Some(r) => format!("; the reader process {:.2} ms", per_step(r)),
            None => String::new(),
        }
    );
}

fn main() {
    if let Some(kind) = std::env::args().find_map(|a| ReaderKind::from_arg(&a)) {
        reader_main(kind);
        return;
    }
    let steps: u64 = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(600);

    println!(
        "100 robots x 181-ray lasers, {steps} steps ({:.0} s simulated); each bridged run after \
         a run of the world alone",
        steps as f64 * 0.1
    );
    let params = || Params {
        world_file: "fleet.world".into(),
        ..Params::default()
    };

    // no subscriber
    let alone = world_alone(steps);
    let ctx = context();
    let mut world = load_subscribed();
    let mut bridge =
        Bridge::new(&ctx, &mut world, params(), &RosArgs::default()).expect("the bridge starts");
    let run = bridged(&mut world, &mut bridge, steps, None);
    let (written, skipped) = bridge.counts();
    report("no subscriber", steps, alone, &run);
    println!("    samples written {written}, skipped (no reader) {skipped}");
    report_cpu(&run, steps, None);
    drop(bridge);
    drop(ctx);

    // no subscriber, every topic written anyway, as stage_ros2 publishes
    let alone = world_alone(steps);
    let ctx = context();
    let mut world = load_subscribed();
    let mut bridge =
        Bridge::new(&ctx, &mut world, params(), &RosArgs::default()).expect("the bridge starts");
    bridge.publish_unmatched(true);
    let run = bridged(&mut world, &mut bridge, steps, None);
    let (written, skipped) = bridge.counts();
    report(
        "everything published, as stage_ros2 does (no reader)",
        steps,
        alone,
        &run,
    );
    println!("    samples written {written}, skipped {skipped}");
    report_cpu(&run, steps, None);
    drop(bridge);
    drop(ctx);

    // a reader of everything (reliable), one as nav2/rviz subscribe (scans best effort), then
    // of r0's scan alone (the latency without the load), then of everything at a pace the
    // machine keeps
    with_reader(ReaderKind::All, steps, None);
    with_reader(ReaderKind::Nav, steps, None);
    with_reader(ReaderKind::Scan0, steps, None);
    with_reader(ReaderKind::All, steps, Some(PACED_SPEEDUP));
}

/// The world alone, flat out: the wall time of `steps` steps.
fn world_alone(steps: u64) -> f64 {
    let mut world = load_subscribed();
    let start = Instant::now();
    stage_sim::on_sim_threads(|| {
        for _ in 0..steps {
            world.step();
        }
    });
    start.elapsed().as_secs_f64()
}

/// Prints a bridged run's rate against the world alone's (`alone`, wall s) and the bridge's
/// share of the run.
fn report(label: &str, steps: u64, alone: f64, run: &Run) {
    let t = run.wall;
    println!(
        "  {label}: alone {:7.1} steps/s, bridged {:7.1} steps/s (real-time factor {:6.1}x): \
         bridge share {:3.0}% ({:.2} ms/step)",
        steps as f64 / alone,
        steps as f64 / t,
        steps as f64 * 0.1 / t,
        100.0 * (t - alone).max(0.0) / t,
        (t - alone) / steps as f64 * 1e3
    );
}

/// Runs the bridge with a reader process (`kind`), flat out or paced, and prints the rate,
/// the CPU time, the samples and the step-to-scan latency.
fn with_reader(kind: ReaderKind, steps: u64, speedup: Option<f64>) {
    let all = kind.all();
    let params = || Params {
        world_file: "fleet.world".into(),
        ..Params::default()
    };
    let alone = world_alone(steps);
    let mut child = Command::new(std::env::current_exe().expect("this bench's path"))
        .arg(kind.arg())
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .expect("the reader process starts");
    let mut lines = std::io::BufReader::new(child.stdout.take().expect("its stdout")).lines();
    let first = lines.next().and_then(Result::ok);
    if first.as_deref() != Some("ready") {
        drop(child.stdin.take());
        let status = child.wait();
        panic!(
            "the reader process did not start: it said {first:?} and ended with {status:?} \
             (its own message, if any, is above)"
        );
    }
    let ctx = context();
    let mut world = load_subscribed();
    let mut bridge =
        Bridge::new(&ctx, &mut world, params(), &RosArgs::default()).expect("the bridge starts");
    // discovery: step until every topic read is matched (all: nothing skipped in a step;
    // else r0's scan written), 30 s at most; the first step writes the latched topics
    bridged(&mut world, &mut bridge, 1, None);
    let warm = Instant::now();
    let mut warm_steps = 1;
    loop {
        let (w, s) = bridge.counts();
        bridged(&mut world, &mut bridge, 1, None);
        warm_steps += 1;
        let (w2, s2) = bridge.counts();
        let ready = if all { s2 == s } else { w2 > w };
        if ready || warm.elapsed() > Duration::from_secs(30) {
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let (before_w, before_s) = bridge.counts();
    let reader_pid = child.id().to_string();
    let reader_before = threads_cpu(&reader_pid);
    let run = bridged(&mut world, &mut bridge, steps, speedup);
    let reader_cpu: u64 = cpu_between(&reader_before, &threads_cpu(&reader_pid))
        .values()
        .sum();
    let (written, skipped) = bridge.counts();
    // the reader drains what is in flight, then is told to stop
    std::thread::sleep(Duration::from_millis(1000));
    drop(child.stdin.take());
    let mut samples = 0;
    let mut arrival = HashMap::new();
    for line in lines.map_while(Result::ok) {
        let f: Vec<&str> = line.split_whitespace().collect();
        match f.as_slice() {
            ["samples", n] => samples = n.parse().unwrap_or(0),
            ["scan", us, ns] => {
                if let (Ok(us), Ok(ns)) = (us.parse::<u64>(), ns.parse::<u128>()) {
                    arrival.insert(us, ns);
                }
            }
            _ => {}
        }
    }
    let _ = child.wait();
    let label = match (kind, speedup) {
        (ReaderKind::All, None) => "a reader of all (reliable)".to_string(),
        (ReaderKind::Nav, None) => "a reader of all as nav2/rviz (scans best effort)".to_string(),
        (ReaderKind::Scan0, _) => "r0's scan read".to_string(),
        (ReaderKind::All, Some(x)) => format!("a reader of all, paced at {x}x real time"),
        (ReaderKind::Nav, Some(x)) => {
            format!("a reader of all as nav2/rviz, paced at {x}x real time")
        }
    };
    if speedup.is_some() {
        println!(
            "  {label}: {:.1} steps/s (real-time factor {:.1}x)",
            steps as f64 / run.wall,
            steps as f64 * 0.1 / run.wall
        );
    } else {
        report(&label, steps, alone, &run);
    }
    report_cpu(&run, steps, Some(reader_cpu));
    println!(
        "    after {warm_steps} warm-up steps: samples written {}, skipped {}; the reader took {samples} in all",
        written - before_w,
        skipped - before_s,
    );
    let mut lat: Vec<f64> = run
        .ended
        .iter()
        .filter_map(|(us, end)| {
            arrival
                .get(us)
                .map(|got| got.saturating_sub(*end) as f64 * 1e-6)
        })
        .collect();
    lat.sort_by(f64::total_cmp);
    if lat.is_empty() {
        println!("    step-to-scan latency: no scan of r0 matched a step");
    } else {
        println!(
            "    step end -> r0's scan at the reader: median {:.2} ms, p95 {:.2} ms, max {:.2} ms ({} of {steps} scans)",
            lat[lat.len() / 2],
            lat[lat.len() * 95 / 100],
            lat[lat.len() - 1],
            lat.len()
        );
    }
}
