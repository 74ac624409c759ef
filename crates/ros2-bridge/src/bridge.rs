//! The node: one [`Vehicle`] per position model with its publishers and subscriptions, the
//! `/clock` publisher and the `reset_positions` service. [`Bridge::inbound`] applies what
//! arrived (commands, teleports, resets) to the world before a step; [`Bridge::publish`]
//! sends the world's state after it.

use std::collections::{BTreeMap, BTreeSet};
use std::time::Duration;

use ros2_client::dds::rustdds::{
    DomainParticipantStatusEvent, DomainParticipantStatusListener, GUID, StatusEvented,
};
use ros2_client::qos::{Durability, History, Reliability, WhenFull};
use ros2_client::{
    Context, MessageTypeName, Name, Node, NodeName, NodeOptions, Publisher, QosProfile, Server,
    ServiceMapping, ServiceTypeName, Subscription,
};
use stage_sim::{ModelId, ModelType, World};

mod camera;
mod writer;

pub use writer::THREAD_NAME as PUBLISHER_THREAD_NAME;
use writer::{Job, Sink, Writer};

use crate::Error;
use crate::inbound;
use crate::msgs::{
    Bool, Clock, Covariance, EmptyMessage, Header, LaserScan, Odometry, PlainEmptyRequest, Pose,
    PoseWithCovariance, Quaternion, Range, RosType, TfMessage, Time, Transform, TransformStamped,
    Twist, TwistStamped, TwistWithCovariance, Vector3,
};
use crate::names::{VehicleNames, vehicle_name};
use crate::params::{Params, RosArgs};

/// The most messages taken from one subscription per step: a flood cannot stall the world.
const MAX_TAKE_PER_STEP: usize = 64;

/// rclcpp's default for publishers and subscriptions: reliable, volatile, keep last 10
/// (stage_ros2 creates every publisher and subscription with depth 10). A full send window
/// drops the sample rather than blocking the simulation on a slow or vanished reader.
fn default_qos() -> QosProfile {
    QosProfile::publisher_default()
        .reliability(Reliability::Reliable {
            when_full: WhenFull::Fail,
        })
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 10 })
}

/// tf2's `DynamicBroadcasterQoS`: depth 100, reliable, volatile.
fn tf_qos() -> QosProfile {
    default_qos().history(History::KeepLast { depth: 100 })
}

/// tf2's `StaticBroadcasterQoS`: depth 1, reliable, transient local (a late listener gets
/// the sensor frames).
fn tf_static_qos() -> QosProfile {
    QosProfile::publisher_default()
        .reliability(Reliability::Reliable {
            when_full: WhenFull::Wait(Duration::from_millis(100)),
        })
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 1 })
}

/// Latched state (`stalled`): the last value to late subscribers.
fn latched_qos() -> QosProfile {
    default_qos()
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 1 })
}

/// ROS 2's service default: reliable, volatile, keep last 10.
fn service_qos() -> QosProfile {
    default_qos()
}

/// A node, with the name forming and remapping every topic goes through.
struct Topics {
    node: Node,
    namespace: String,
    remaps: BTreeMap<String, String>,
}

impl Topics {
    /// The absolute name of `name` in this node ([`crate::names::resolve`]).
    fn resolve(&self, name: &str) -> String {
        crate::names::resolve(&self.namespace, &self.remaps, name)
    }

    fn name(&self, name: &str) -> Result<Name, Error> {
        let full = self.resolve(name);
        Name::parse(&full).map_err(|e| Error::Name {
            name: full.clone(),
            message: format!("{e:?}"),
        })
    }

    fn publisher<T: RosType>(
        &mut self,
        name: &str,
        qos: QosProfile,
    ) -> Result<Publisher<T>, Error> {
        let n = self.name(name)?;
        let dds = |e: &dyn std::fmt::Display| Error::Dds(format!("publisher {n}: {e}"));
        let topic = self
            .node
            .create_topic(&n, MessageTypeName::new(T::PACKAGE, T::NAME), &qos)
            .map_err(|e| dds(&e))?;
        self.node
            .create_publisher(&topic, Some(qos))
            .map_err(|e| dds(&e))
    }

    fn subscription<T: RosType>(
        &mut self,
        name: &str,
        qos: QosProfile,
    ) -> Result<Subscription<T>, Error> {
        let n = self.name(name)?;
        let dds = |e: &dyn std::fmt::Display| Error::Dds(format!("subscription {n}: {e}"));
        let topic = self
            .node
            .create_topic(&n, MessageTypeName::new(T::PACKAGE, T::NAME), &qos)
            .map_err(|e| dds(&e))?;
        self.node
            .create_subscription(&topic, Some(qos))
            .map_err(|e| dds(&e))
    }
}

/// A subscription and the resolved name it is reported under.
struct Inbound<T: RosType> {
    topic: String,
    sub: Subscription<T>,
}

impl<T: RosType> Inbound<T> {
    fn new(topics: &mut Topics, name: &str) -> Result<Inbound<T>, Error> {
        Ok(Inbound {
            topic: topics.resolve(name),
            sub: topics.subscription(name, default_qos())?,
        })
    }

    /// The messages that arrived, oldest first (at most [`MAX_TAKE_PER_STEP`]); one that
    /// cannot be read is dropped with a warning naming the topic. A subscription no writer
    /// was ever matched with holds nothing and is not read (each read costs RustDDS a system
    /// call, 200 of them a step with 100 robots).
    fn take(&self, matches: &mut Matches) -> Vec<T> {
        let guid = self.sub.guid();
        if !matches.may_hold_data(guid) {
            return Vec::new();
        }
        let mut out = Vec::new();
        for _ in 0..MAX_TAKE_PER_STEP {
            match self.sub.take() {
                Ok(Some((m, _))) => out.push(m),
                Ok(None) => {
                    matches.drained(guid);
                    break;
                }
                Err(e) => {
                    tracing::warn!("{}: dropped a message that cannot be read: {e}", self.topic)
                }
            }
        }
        out
    }
}

/// The size of RustDDS's participant status channel (`sync_status_channel(2048)` in its
/// `DomainParticipant`): a full channel drops events, so a drain that finds this many may
/// have missed some.
const STATUS_CHANNEL_CAPACITY: usize = 2048;

/// Which of the node's writers have a matched reader, kept from the DDS participant's status
/// events (RustDDS does not implement `get_matched_subscriptions`, and ros2-client's count
/// needs a node spinner). A volatile writer with no matched reader is skipped: RustDDS would
/// serialise, store and wake its event loop for a sample nobody can ever receive (a reader
/// matched later gets a GAP for it, volatile durability), which was most of the bridge's
/// cost with 100 robots.
struct Matches {
    listener: DomainParticipantStatusListener,
    /// Local writer -> the remote readers matched with it.
    readers: BTreeMap<GUID, BTreeSet<GUID>>,
    /// Local reader -> the remote writers matched with it; a reader stays here after its
    /// writers are lost until it is read empty (a `--once` publisher's message is kept).
    writers: BTreeMap<GUID, BTreeSet<GUID>>,
    /// Set once events may have been lost (the channel was full): every writer is treated as
    /// matched from then on, as before this filter existed.
    all: bool,
    /// Every writer treated as matched, by [`Bridge::publish_unmatched`] (measurement only);
    /// unlike `all`, subscriptions are still read only once a writer matches them.
    unmatched: bool,
}

impl Matches {
    fn new(context: &Context) -> Matches {
        Matches {
            listener: context.domain_participant().status_listener(),
            readers: BTreeMap::new(),
            writers: BTreeMap::new(),
            all: false,
            unmatched: false,
        }
    }

    /// Applies the status events that arrived since the last call.
    fn poll(&mut self) {
        let mut n = 0;
        while let Some(event) = self.listener.try_recv_status() {
            n += 1;
            match event {
                DomainParticipantStatusEvent::RemoteReaderMatched {
                    local_writer,
                    remote_reader,
                } => {
                    self.readers
                        .entry(local_writer)
                        .or_default()
                        .insert(remote_reader);
                }
                DomainParticipantStatusEvent::ReaderLost { guid, .. } => {
                    for readers in self.readers.values_mut() {
                        readers.remove(&guid);
                    }
                }
                DomainParticipantStatusEvent::RemoteWriterMatched {
                    local_reader,
                    remote_writer,
                } => {
                    self.writers
                        .entry(local_reader)
                        .or_default()
                        .insert(remote_writer);
                }
                DomainParticipantStatusEvent::WriterLost { guid, .. } => {
                    for writers in self.writers.values_mut() {
                        writers.remove(&guid);
                    }
                }
                _ => {}
            }
        }
        if n >= STATUS_CHANNEL_CAPACITY && !self.all {
            tracing::warn!(
                "DDS status events may have been lost: publishing on every topic, matched or not"
            );
            self.all = true;
        }
    }

    /// Whether `writer` has a reader (or matches are unknown, or every writer is written).
    fn matched(&self, writer: GUID) -> bool {
        self.all || self.unmatched || self.readers.get(&writer).is_some_and(|r| !r.is_empty())
    }

    /// Whether `reader` may hold samples: a writer was matched with it and it has not been
    /// read empty since its last writer was lost (or matches are unknown).
    fn may_hold_data(&self, reader: GUID) -> bool {
        self.all || self.writers.contains_key(&reader)
    }

    /// `reader` was read empty: forgotten if no writer is matched with it any more.
    fn drained(&mut self, reader: GUID) {
        if self.writers.get(&reader).is_some_and(BTreeSet::is_empty) {
            self.writers.remove(&reader);
        }
    }
}

/// What a step's publishing writes through: the matches that say which writers have a reader,
/// and the step's messages, queued for the publisher thread.
struct Out<'a> {
    matches: &'a Matches,
    jobs: &'a mut Vec<Job>,
}

/// A publisher (written on the publisher thread, [`writer`]) and what the stepping thread
/// keeps of it: whether to write, and the counts.
struct Outbound<T: RosType> {
    sink: std::sync::Arc<Sink<T>>,
    guid: GUID,
    /// Transient local: written whether or not a reader is matched (late joiners get it).
    latched: bool,
    /// Samples written and skipped (no matched reader), for [`Bridge::counts`].
    written: u64,
    skipped: u64,
}

impl<T: RosType> Outbound<T> {
    fn new(topics: &mut Topics, name: &str, qos: QosProfile) -> Result<Outbound<T>, Error> {
        let latched = qos.durability != Durability::Volatile;
        let sink = Sink::new(topics.resolve(name), topics.publisher(name, qos)?);
        Ok(Outbound {
            guid: sink.guid(),
            sink,
            latched,
            written: 0,
            skipped: 0,
        })
    }

    /// Whether a message sent now would be written: the topic is latched or has a reader.
    fn wanted(&self, matches: &Matches) -> bool {
        self.latched || matches.matched(self.guid)
    }

    /// Queues the message `make` builds for the publisher thread, unless the topic is
    /// volatile and has no matched reader (then nothing is built).
    fn send(&mut self, out: &mut Out<'_>, make: impl FnOnce() -> T) {
        if !self.wanted(out.matches) {
            self.skipped += 1;
            return;
        }
        self.written += 1;
        out.jobs.push(self.sink.job(make()));
    }
}

/// `cmd_vel`, as Twist or (with `use_stamped_velocity`) TwistStamped.
enum CmdVel {
    Plain(Inbound<Twist>),
    Stamped(Inbound<TwistStamped>),
}

impl CmdVel {
    fn take(&self, matches: &mut Matches) -> Vec<Twist> {
        match self {
            CmdVel::Plain(s) => s.take(matches),
            CmdVel::Stamped(s) => s.take(matches).into_iter().map(|m| m.twist).collect(),
        }
    }
}

/// One ranger of a vehicle: `base_scan[N]`, and a Range topic per transducer of a ring.
struct Ranger {
    model: ModelId,
    frame: String,
    scan: Outbound<LaserScan>,
    /// Per transducer when there are several: its publisher and frame.
    transducers: Vec<(Outbound<Range>, String)>,
    /// The sim time of the last scan published (scans go out once, when fresh).
    last_us: u64,
}

/// A position model and its ROS interface.
struct Vehicle {
    model: ModelId,
    name: String,
    names: VehicleNames,
    /// The resolved name of its tf topic, then its index in [`Bridge::tf`].
    tf_key: String,
    tf_index: usize,
    /// The pose `reset_positions` puts it back to (parent frame, as `set_pose` takes).
    start: stage_sim::Pose,
    cmd_vel: CmdVel,
    cmd_pose: Inbound<Pose>,
    odom: Outbound<Odometry>,
    ground_truth: Option<Outbound<Odometry>>,
    stalled: Outbound<Bool>,
    last_stalled: Option<bool>,
    rangers: Vec<Ranger>,
    cameras: Vec<camera::Camera>,
    /// When the watchdog stops the vehicle (sim µs), after a command.
    watchdog_due_us: Option<u64>,
    /// The last global pose and its time, for ground truth's velocity.
    last_global: Option<(stage_sim::Pose, u64)>,
}

/// The `reset_positions` servers: Cyclone's request/reply mapping (a header in the payload)
/// and Fast DDS's (ros2-client's `Enhanced`: the related sample identity in inline QoS). Both
/// read the same topics; each drops the other's requests.
struct ResetServers {
    cyclone: Server<EmptyMessage, EmptyMessage>,
    fast_dds: Server<PlainEmptyRequest, EmptyMessage>,
}

impl ResetServers {
    fn new(topics: &mut Topics) -> Result<ResetServers, Error> {
        let service = topics.name("reset_positions")?;
        let err = |e: &dyn std::fmt::Display| Error::Dds(format!("service {service}: {e}"));
        let ty = ServiceTypeName::new("std_srvs", "Empty");
        let cyclone = topics
            .node
            .create_server(
                ServiceMapping::Cyclone,
                &service,
                &ty,
                service_qos(),
                service_qos(),
            )
            .map_err(|e| err(&e))?;
        let fast_dds = topics
            .node
            .create_server(
                ServiceMapping::Enhanced,
                &service,
                &ty,
                service_qos(),
                service_qos(),
            )
            .map_err(|e| err(&e))?;
        Ok(ResetServers { cyclone, fast_dds })
    }

    /// Answers every request that arrived; the number answered.
    fn answer(&self) -> usize {
        answer_all(&self.cyclone, "Cyclone") + answer_all(&self.fast_dds, "Fast DDS")
    }
}

/// Answers the requests waiting at `server` (at most [`MAX_TAKE_PER_STEP`]).
fn answer_all<Req: ros2_client::Message + Clone + 'static>(
    server: &Server<Req, EmptyMessage>,
    mapping: &str,
) -> usize {
    let mut n = 0;
    for _ in 0..MAX_TAKE_PER_STEP {
        match server.receive_request() {
            Ok(Some((id, _))) => {
                n += 1;
                if let Err(e) = server.send_response(id, EmptyMessage::default()) {
                    tracing::warn!("reset_positions: reply not sent ({mapping} mapping): {e:?}");
                }
            }
            Ok(None) => break,
            // the other mapping's requests do not read as this one's
            Err(e) => tracing::debug!("reset_positions ({mapping} mapping): {e}"),
        }
    }
    n
}

/// The ROS 2 side of a world: built once on it, then [`Bridge::inbound`] before each step and
/// [`Bridge::publish`] after it.
pub struct Bridge {
    params: Params,
    vehicles: Vec<Vehicle>,
    /// One publisher per tf topic (`/tf` is shared under one_tf_tree), in name order; each
    /// vehicle knows its own by index, so a step gathers transforms without name lookups.
    tf: Vec<Outbound<TfMessage>>,
    tf_static: BTreeMap<String, Outbound<TfMessage>>,
    static_sent: bool,
    /// Which writers have readers: the volatile ones without are not written.
    matches: Matches,
    clock: Outbound<Clock>,
    reset: ResetServers,
    watchdog_us: u64,
    /// The step's messages, queued by [`Bridge::publish`] and handed to `writer` at its end.
    jobs: Vec<Job>,
    /// The publisher thread; dropped before the node, after writing what is queued.
    writer: Writer,
    // last: the node outlives its entities
    topics: Topics,
}

/// Normalises an angle into (-pi, pi].
fn normalize(a: f64) -> f64 {
    a.sin().atan2(a.cos())
}

fn stamp(frame: &str, us: u64) -> Header {
    Header {
        stamp: Time::from_micros(us),
        frame_id: frame.to_string(),
    }
}

impl Bridge {
    /// Creates the node (`stage_ros2`, or as `-r __node:=`/`__ns:=` say) on `context` and
    /// the interface of every position model of `world` (subscribing the models, as
    /// stage_ros2 does, so that they update).
    pub fn new(
        context: &Context,
        world: &mut World,
        params: Params,
        ros: &RosArgs,
    ) -> Result<Bridge, Error> {
        let node_name = ros.node_name.clone().unwrap_or_else(|| "stage_ros2".into());
        let namespace = match ros.namespace.as_deref() {
            None | Some("") => "/".to_string(),
            Some(ns) if ns.starts_with('/') => ns.trim_end_matches('/').to_string(),
            Some(ns) => format!("/{}", ns.trim_end_matches('/')),
        };
        let namespace = if namespace.is_empty() {
            "/".to_string()
        } else {
            namespace
        };
        let name = NodeName::new(&namespace, &node_name).map_err(|e| Error::Name {
            name: format!("{namespace} {node_name}"),
            message: format!("{e:?}"),
        })?;
        // before any entity: its matches are in the events from now on
        let mut matches = Matches::new(context);
        let node = context
            .new_node(name, NodeOptions::new().enable_rosout(false))
            .map_err(|e| Error::Dds(format!("creating the node: {e:?}")))?;
        let mut topics = Topics {
            node,
            namespace,
            remaps: ros.remaps.clone(),
        };

        // vehicles: every position model, in creation order; rangers whose parent is one
        let positions: Vec<ModelId> = world
            .models()
            .filter(|m| world.model_type(*m).ok() == Some(ModelType::Position))
            .collect();
        if positions.is_empty() {
            tracing::warn!(
                "the world has no position model: only /clock and reset_positions are served"
            );
        }
        let prefixed = params.enforce_prefixes || positions.len() > 1;
        let mut vehicles = Vec::new();
        let mut tf = BTreeMap::new();
        let mut tf_static = BTreeMap::new();
        for (index, &m) in positions.iter().enumerate() {
            let stage_name = world.name(m).map_err(Error::Sim)?.to_string();
            let name = vehicle_name(&stage_name, index);
            tracing::info!("new vehicle \"{name}\"");
            let names = VehicleNames::new(&name, prefixed, &params);
            world.subscribe(m).map_err(Error::Sim)?;
            let rangers_of: Vec<ModelId> = world
                .children(m)
                .map_err(Error::Sim)?
                .filter(|c| world.model_type(*c).ok() == Some(ModelType::Ranger))
                .collect();
            let several = rangers_of.len() > 1;
            let mut rangers = Vec::new();
            for (k, &r) in rangers_of.iter().enumerate() {
                world.subscribe(r).map_err(Error::Sim)?;
                let (topic, frame) = names.ranger(k + 1, several);
                let count = world.ranger_scans(r).map_err(Error::Sim)?.sensors.len();
                if count == 0 {
                    tracing::warn!(
                        "{name}: ranger {} has no transducer: nothing to publish",
                        k + 1
                    );
                }
                let mut transducers = Vec::new();
                if count > 1 {
                    for t in 0..count {
                        let (ttopic, tframe) = VehicleNames::transducer(&topic, &frame, t);
                        transducers
                            .push((Outbound::new(&mut topics, &ttopic, default_qos())?, tframe));
                    }
                }
                rangers.push(Ranger {
                    model: r,
                    scan: Outbound::new(&mut topics, &topic, default_qos())?,
                    frame,
                    transducers,
                    last_us: 0,
                });
            }
            for (map, topic, qos) in [
                (&mut tf, &names.tf, tf_qos()),
                (&mut tf_static, &names.tf_static, tf_static_qos()),
            ] {
                let key = topics.resolve(topic);
                if let std::collections::btree_map::Entry::Vacant(e) = map.entry(key) {
                    e.insert(Outbound::new(&mut topics, topic, qos)?);
                }
            }
            let cmd_vel = if params.use_stamped_velocity {
                CmdVel::Stamped(Inbound::new(&mut topics, &names.cmd_vel)?)
            } else {
                CmdVel::Plain(Inbound::new(&mut topics, &names.cmd_vel)?)
            };
            // drained as entities are made, so a big fleet's own events do not fill the channel
            matches.poll();
            vehicles.push(Vehicle {
                tf_key: topics.resolve(&names.tf),
                tf_index: 0,
                model: m,
                start: world.pose(m).map_err(Error::Sim)?,
                cmd_vel,
                cmd_pose: Inbound::new(&mut topics, &names.cmd_pose)?,
                odom: Outbound::new(&mut topics, &names.odom, default_qos())?,
                ground_truth: if params.publish_ground_truth {
                    Some(Outbound::new(
                        &mut topics,
                        &names.ground_truth,
                        default_qos(),
                    )?)
                } else {
                    None
                },
                stalled: Outbound::new(&mut topics, &names.stalled, latched_qos())?,
                last_stalled: None,
                rangers,
                cameras: camera::cameras_of(world, &mut topics, m, &names)?,
                watchdog_due_us: None,
                last_global: None,
                name,
                names,
            });
        }

        let clock = Outbound::new(&mut topics, "/clock", default_qos())?;
        // both common request/reply mappings, each server dropping the other's requests
        let reset = ResetServers::new(&mut topics)?;
        let watchdog_us = (params.base_watchdog_timeout.max(0.0) * 1e6) as u64;
        for v in &mut vehicles {
            v.tf_index = tf.keys().position(|k| *k == v.tf_key).unwrap_or(0);
        }
        Ok(Bridge {
            params,
            vehicles,
            tf: tf.into_values().collect(),
            tf_static,
            static_sent: false,
            matches,
            clock,
            reset,
            watchdog_us,
            jobs: Vec::new(),
            writer: Writer::start()?,
            topics,
        })
    }

    /// The vehicles' names, in position-model order (what their topics are prefixed with).
    pub fn vehicle_names(&self) -> Vec<&str> {
        self.vehicles.iter().map(|v| v.name.as_str()).collect()
    }

    /// The node's fully qualified name.
    pub fn node_name(&self) -> String {
        self.topics.node.fully_qualified_name()
    }

    /// Samples written and samples not written for want of a matched reader, over every topic
    /// since the start: what skipping unread volatile topics saves (the bench prints it).
    pub fn counts(&self) -> (u64, u64) {
        let mut c = (0, 0);
        let mut add = |w: u64, s: u64| {
            c.0 += w;
            c.1 += s;
        };
        for v in &self.vehicles {
            add(v.odom.written, v.odom.skipped);
            add(v.stalled.written, v.stalled.skipped);
            if let Some(g) = &v.ground_truth {
                add(g.written, g.skipped);
            }
            for r in &v.rangers {
                add(r.scan.written, r.scan.skipped);
                for (t, _) in &r.transducers {
                    add(t.written, t.skipped);
                }
            }
        }
        for p in self.tf.iter().chain(self.tf_static.values()) {
            add(p.written, p.skipped);
        }
        add(self.clock.written, self.clock.skipped);
        c
    }

    /// For measurement only (the bridge bench's "publishing everything" case): with `true`,
    /// every topic is built, serialised and written at every step whether or not a reader is
    /// matched, as stage_ros2 (rclcpp) does, so that the cost the matched-reader filter saves
    /// can be measured. Off by default; nothing else should turn it on.
    pub fn publish_unmatched(&mut self, on: bool) {
        self.matches.unmatched = on;
    }

    /// Applies what arrived since the last call, before the world's next step: velocity
    /// commands (arming each vehicle's watchdog), teleports, resets; then stops every vehicle
    /// whose watchdog ran out.
    pub fn inbound(&mut self, world: &mut World) {
        self.matches.poll();
        let now = world.sim_time();
        for v in &mut self.vehicles {
            if let Some(cmd) = v.cmd_vel.take(&mut self.matches).pop() {
                match inbound::apply_cmd_vel(world, v.model, &cmd) {
                    Ok(()) => v.watchdog_due_us = Some(now + self.watchdog_us),
                    Err(e) => tracing::warn!("{}: {e}", v.names.cmd_vel),
                }
            }
            if let Some(p) = v.cmd_pose.take(&mut self.matches).pop() {
                match inbound::apply_cmd_pose(world, v.model, &p) {
                    Ok(()) => v.last_global = None,
                    Err(e) => tracing::warn!("{}: {e}", v.names.cmd_pose),
                }
            }
            if let Some(due) = v.watchdog_due_us
                && now > due
            {
                v.watchdog_due_us = None;
                let moving = world.position_state(v.model).is_ok_and(|s| {
                    s.velocity.x != 0.0 || s.velocity.y != 0.0 || s.velocity.a != 0.0
                }) || world
                    .position_model(v.model)
                    .is_ok_and(|p| p.goal.x != 0.0 || p.goal.y != 0.0 || p.goal.a != 0.0);
                if moving {
                    let _ = world.position_cmd_vel(v.model, 0.0, 0.0, 0.0);
                    tracing::info!("watchdog timeout on {}", v.name);
                }
            }
        }
        let resets = self.reset.answer();
        if resets > 0 {
            tracing::info!("resetting stage");
            inbound::reset(world, self.vehicles.iter().map(|v| (v.model, v.start)));
            for v in &mut self.vehicles {
                v.last_global = None;
            }
        }
    }

    /// Publishes the world's state after a step, stamped with its sim time: odometry, ground
    /// truth, fresh scans, transforms, stall changes and `/clock`. Nothing is published at
    /// time 0 (ROS reserves a zero clock). The messages are built here and handed to the
    /// publisher thread, which serialises and writes them, in order, while the next step is
    /// computed; this waits only when that thread is two steps behind.
    pub fn publish(&mut self, world: &World) {
        let now = world.sim_time();
        if now == 0 {
            return;
        }
        self.matches.poll();
        if !self.static_sent {
            self.send_static(world);
            self.static_sent = true;
        }
        let mut out = Out {
            matches: &self.matches,
            jobs: &mut self.jobs,
        };
        let mut dynamic: Vec<Vec<TransformStamped>> = self.tf.iter().map(|_| Vec::new()).collect();
        // transforms are gathered only for tf topics someone reads
        let tf_wanted: Vec<bool> = self.tf.iter().map(|p| p.wanted(out.matches)).collect();
        for v in &mut self.vehicles {
            let Ok(state) = world.position_state(v.model) else {
                continue;
            };
            let est = state.pose;
            let want_tf = tf_wanted.get(v.tf_index).copied().unwrap_or(false);
            let tf = &mut dynamic[v.tf_index];
            if want_tf {
                tf.push(TransformStamped {
                    header: stamp(&v.names.frame_odom, now),
                    child_frame_id: v.names.frame_base_link.clone(),
                    transform: Transform {
                        translation: Vector3 {
                            x: est.x,
                            y: est.y,
                            z: 0.0,
                        },
                        rotation: Quaternion::from_yaw(est.a),
                    },
                });
            }
            v.odom.send(&mut out, || Odometry {
                header: stamp(&v.names.frame_odom, now),
                child_frame_id: v.names.frame_base_link.clone(),
                pose: PoseWithCovariance {
                    pose: Pose {
                        position: Vector3 {
                            x: est.x,
                            y: est.y,
                            z: 0.0,
                        },
                        orientation: Quaternion::from_yaw(est.a),
                    },
                    covariance: Covariance::default(),
                },
                twist: TwistWithCovariance {
                    twist: Twist {
                        linear: Vector3 {
                            x: state.velocity.x,
                            y: state.velocity.y,
                            z: 0.0,
                        },
                        angular: Vector3 {
                            x: 0.0,
                            y: 0.0,
                            z: state.velocity.a,
                        },
                    },
                    covariance: Covariance::default(),
                },
            });

            let stalled = state.stall;
            if v.last_stalled != Some(stalled) {
                v.stalled.send(&mut out, || Bool { data: stalled });
                v.last_stalled = Some(stalled);
            }

            if let Some(gt) = &mut v.ground_truth
                && let Ok(g) = world.global_pose(v.model)
            {
                let mut vel = stage_sim::Pose::new(0.0, 0.0, 0.0, 0.0);
                if let Some((last, t)) = v.last_global
                    && now > t
                {
                    let dt = (now - t) as f64 * 1e-6;
                    vel = stage_sim::Pose::new(
                        (g.x - last.x) / dt,
                        (g.y - last.y) / dt,
                        (g.z - last.z) / dt,
                        normalize(g.a - last.a) / dt,
                    );
                }
                v.last_global = Some((g, now));
                gt.send(&mut out, || Odometry {
                    header: stamp(&v.names.frame_world, now),
                    child_frame_id: String::new(),
                    pose: PoseWithCovariance {
                        pose: Pose {
                            position: Vector3 {
                                x: g.x,
                                y: g.y,
                                z: 0.0,
                            },
                            orientation: Quaternion::from_yaw(g.a),
                        },
                        covariance: Covariance::default(),
                    },
                    twist: TwistWithCovariance {
                        twist: Twist {
                            linear: Vector3 {
                                x: vel.x,
                                y: vel.y,
                                z: vel.z,
                            },
                            angular: Vector3 {
                                x: 0.0,
                                y: 0.0,
                                z: vel.a,
                            },
                        },
                        covariance: Covariance::default(),
                    },
                });
            }

            for r in &mut v.rangers {
                if want_tf && !self.params.use_static_transformations {
                    for mut t in ranger_transforms(world, v.model, &v.names, r) {
                        t.header.stamp = Time::from_micros(now);
                        tf.push(t);
                    }
                }
                publish_scan(world, r, &mut out);
            }
            for c in &mut v.cameras {
                if want_tf
                    && !self.params.use_static_transformations
                    && let Some(mut t) = c.transform(world, v.model, &v.names)
                {
                    t.header.stamp = Time::from_micros(now);
                    tf.push(t);
                }
                c.publish(world, &self.params, &mut out);
            }
        }
        for ((p, transforms), wanted) in self.tf.iter_mut().zip(dynamic).zip(tf_wanted) {
            // an unread topic is counted as skipped, as every other
            if !transforms.is_empty() || !wanted {
                p.send(&mut out, || TfMessage { transforms });
            }
        }
        self.clock.send(&mut out, || Clock {
            clock: Time::from_micros(now),
        });
        // the next step's queue starts with room for as many
        let n = self.jobs.len();
        self.writer
            .submit(std::mem::replace(&mut self.jobs, Vec::with_capacity(n)));
    }

    /// The sensor frames, once, on each tf_static topic (transient local: tf2 listeners that
    /// join later still get them).
    fn send_static(&mut self, world: &World) {
        if !self.params.use_static_transformations {
            return;
        }
        let mut statics: BTreeMap<String, Vec<TransformStamped>> = BTreeMap::new();
        for v in &self.vehicles {
            let key = self.topics.resolve(&v.names.tf_static);
            for r in &v.rangers {
                let mut t = ranger_transforms(world, v.model, &v.names, r);
                for x in &mut t {
                    x.header.stamp = Time::from_micros(world.sim_time());
                }
                statics.entry(key.clone()).or_default().extend(t);
            }
            for c in &v.cameras {
                if let Some(mut t) = c.transform(world, v.model, &v.names) {
                    t.header.stamp = Time::from_micros(world.sim_time());
                    statics.entry(key.clone()).or_default().push(t);
                }
            }
        }
        let mut out = Out {
            matches: &self.matches,
            jobs: &mut self.jobs,
        };
        for (topic, transforms) in statics {
            if let Some(p) = self.tf_static.get_mut(&topic) {
                p.send(&mut out, || TfMessage { transforms });
            }
        }
    }
}

/// The transforms from the vehicle's body frame to a ranger's frame (stage_ros2's: the
/// ranger's pose on the vehicle, raised by the vehicle's height), and to each transducer's
/// frame when it has several.
fn ranger_transforms(
    world: &World,
    vehicle: ModelId,
    names: &VehicleNames,
    r: &Ranger,
) -> Vec<TransformStamped> {
    let (Ok(pose), Ok(node)) = (world.pose(r.model), world.node(vehicle)) else {
        return Vec::new();
    };
    let height = node.size[2] + pose.z;
    let mut out = vec![TransformStamped {
        header: stamp(&names.frame_base_link, 0),
        child_frame_id: r.frame.clone(),
        transform: Transform {
            translation: Vector3 {
                x: pose.x,
                y: pose.y,
                z: height,
            },
            rotation: Quaternion::from_yaw(pose.a),
        },
    }];
    if let Ok(data) = world.ranger_scans(r.model) {
        for ((_, frame), s) in r.transducers.iter().zip(&data.sensors) {
            out.push(TransformStamped {
                header: stamp(&r.frame, 0),
                child_frame_id: frame.clone(),
                transform: Transform {
                    translation: Vector3 {
                        x: s.pose.x,
                        y: s.pose.y,
                        z: s.pose.z,
                    },
                    rotation: Quaternion::from_yaw(s.pose.a),
                },
            });
        }
    }
    out
}

/// Publishes a ranger's scan when it is fresh: its first transducer as a LaserScan (as
/// stage_ros2), and each transducer as a Range when there are several.
fn publish_scan(world: &World, r: &mut Ranger, out: &mut Out<'_>) {
    let Ok(data) = world.ranger_scans(r.model) else {
        return;
    };
    if data.time_us == 0 || data.time_us == r.last_us {
        return;
    }
    r.last_us = data.time_us;
    let (Some(first), Some(scan)) = (data.sensors.first(), data.scan(0)) else {
        return;
    };
    let samples = first.samples.max(1);
    let fov = first.fov;
    r.scan.send(out, || LaserScan {
        header: stamp(&r.frame, data.time_us),
        angle_min: (-fov / 2.0) as f32,
        angle_max: (fov / 2.0) as f32,
        angle_increment: if samples > 1 {
            (fov / f64::from(samples - 1)) as f32
        } else {
            0.0
        },
        time_increment: 0.0,
        scan_time: 0.0,
        range_min: first.range[0] as f32,
        range_max: first.range[1] as f32,
        ranges: scan.ranges.iter().map(|x| *x as f32).collect(),
        intensities: scan.intensities.iter().map(|x| *x as f32).collect(),
    });
    for (k, ((publisher, frame), sensor)) in r.transducers.iter_mut().zip(&data.sensors).enumerate()
    {
        let Some(s) = data.scan(k) else { continue };
        let Some(&range) = s.ranges.first() else {
            continue;
        };
        publisher.send(out, || Range {
            header: stamp(frame, data.time_us),
            radiation_type: 0,
            field_of_view: sensor.fov as f32,
            min_range: sensor.range[0] as f32,
            max_range: sensor.range[1] as f32,
            range: range as f32,
        });
    }
}

#[cfg(test)]
mod tests {
    use std::time::Instant;

    use super::*;
    use crate::Discovery;

    /// A loopback participant in a domain of this test's own.
    fn context(domain: u32) -> Context {
        let vars = move |k: &str| match k {
            "ROS_LOCALHOST_ONLY" => Some("1".to_string()),
            "ROS_DOMAIN_ID" => Some(domain.to_string()),
            _ => None,
        };
        Discovery::from_vars(vars)
            .and_then(|d| d.context())
            .expect("a DDS participant")
    }

    fn world() -> World {
        let text = "interval_sim 100\n\
                    position ( name \"r0\" pose [0 0 0 0] size [0.4 0.4 0.3] \
                    ranger ( sensor ( range [0 8] fov 180 samples 5 ) ) )\n";
        let spec = worldfile::WorldSpec::parse(
            std::path::Path::new("matches.world"),
            text,
            &worldfile::LoadOptions::default(),
        )
        .expect("the test world parses");
        World::from_owned_spec(spec, 1).expect("the test world builds")
    }

    fn step(world: &mut World, bridge: &mut Bridge) {
        bridge.inbound(world);
        world.step();
        bridge.publish(world);
    }

    /// A node `node_name` in a participant of its own in `domain` (as another ROS 2 process
    /// would be) and `topic`, of `M`'s type, on it; the node keeps its context alive.
    fn peer_topic<M: RosType>(
        domain: u32,
        node_name: &str,
        topic: &str,
        qos: &QosProfile,
    ) -> (Node, ros2_client::dds::rustdds::Topic) {
        let node = context(domain)
            .new_node(
                NodeName::new("/", node_name).unwrap(),
                NodeOptions::new().enable_rosout(false),
            )
            .unwrap();
        let topic = node
            .create_topic(
                &Name::parse(topic).unwrap(),
                MessageTypeName::new(M::PACKAGE, M::NAME),
                qos,
            )
            .unwrap();
        (node, topic)
    }

    /// The first sample a reader of `topic` (a participant of its own in `domain`) takes while
    /// the world is stepped and published; fails after 30 s (matching takes its time).
    fn first_sample<M: RosType>(
        domain: u32,
        topic: &str,
        qos: QosProfile,
        world: &mut World,
        bridge: &mut Bridge,
    ) -> M {
        let (mut node, ros_topic) = peer_topic::<M>(domain, "reader", topic, &qos);
        let sub: Subscription<M> = node.create_subscription(&ros_topic, Some(qos)).unwrap();
        let deadline = Instant::now() + Duration::from_secs(30);
        while Instant::now() < deadline {
            step(world, bridge);
            if let Ok(Some((m, _))) = sub.take() {
                return m;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        panic!("nothing on {topic} within 30 s of a reader matching")
    }

    /// Volatile topics nobody reads are not written (only the latched tf_static and stalled
    /// are); once a reader of /clock matches, /clock is written and its samples arrive.
    #[test]
    fn unread_topics_are_skipped_and_a_reader_gets_its_topic() {
        let domain = 200 + std::process::id() % 30;
        let ctx = context(domain);
        let mut world = world();
        let mut bridge =
            Bridge::new(&ctx, &mut world, Params::default(), &RosArgs::default()).unwrap();
        for _ in 0..5 {
            step(&mut world, &mut bridge);
        }
        let (written, skipped) = bridge.counts();
        // stalled (latched) and tf_static once; odom, ground_truth, base_scan, tf, /clock
        // skipped at every step
        assert_eq!(written, 2, "only the latched topics are written");
        assert!(skipped >= 5 * 4, "{skipped} samples skipped");

        let clock: Clock = first_sample(domain, "/clock", default_qos(), &mut world, &mut bridge);
        assert!(clock.clock.sec > 0 || clock.clock.nanosec > 0);
        let (written_after, _) = bridge.counts();
        assert!(written_after > written, "/clock is written once read");
    }

    /// The measurement switch: with it, topics nobody reads are written anyway (nothing
    /// skipped), as stage_ros2 does; turned off again, they are skipped as before.
    #[test]
    fn publish_unmatched_writes_unread_topics() {
        let domain = 200 + (std::process::id() + 23) % 30;
        let ctx = context(domain);
        let mut world = world();
        let mut bridge =
            Bridge::new(&ctx, &mut world, Params::default(), &RosArgs::default()).unwrap();
        bridge.publish_unmatched(true);
        for _ in 0..5 {
            step(&mut world, &mut bridge);
        }
        let (written, skipped) = bridge.counts();
        assert_eq!(skipped, 0, "nothing is skipped");
        // the latched topics once, odom, ground_truth, tf and /clock at every step, and scans
        assert!(written >= 2 + 5 * 4, "{written} samples written");
        bridge.publish_unmatched(false);
        step(&mut world, &mut bridge);
        let (written_after, skipped_after) = bridge.counts();
        assert_eq!(written_after, written, "unread topics are skipped again");
        assert!(skipped_after >= 4, "{skipped_after} samples skipped");
    }

    /// With `use_static_transformations:=false` the sensor frames go on tf at every step with
    /// odom -> base_link, in one message per step; an unread tf topic gathers nothing and is
    /// counted as skipped.
    #[test]
    fn dynamic_sensor_frames_reach_a_tf_reader() {
        let domain = 200 + (std::process::id() + 13) % 30;
        let ctx = context(domain);
        let mut world = world();
        let params = Params {
            use_static_transformations: false,
            ..Params::default()
        };
        let mut bridge = Bridge::new(&ctx, &mut world, params, &RosArgs::default()).unwrap();
        step(&mut world, &mut bridge);
        let skipped = bridge.tf[0].skipped;
        step(&mut world, &mut bridge);
        assert_eq!(bridge.tf[0].skipped, skipped + 1, "unread tf is skipped");

        let tf: TfMessage = first_sample(domain, "/tf", tf_qos(), &mut world, &mut bridge);
        let frames: Vec<(&str, &str)> = tf
            .transforms
            .iter()
            .map(|t| (t.header.frame_id.as_str(), t.child_frame_id.as_str()))
            .collect();
        assert_eq!(frames, [("odom", "base_link"), ("base_link", "laser")]);
        let stamp = tf.transforms[0].header.stamp;
        assert!(tf.transforms.iter().all(|t| t.header.stamp == stamp));
        assert!(stamp.sec > 0 || stamp.nanosec > 0);
    }

    /// A command reaches the vehicle once a writer matches (its subscription is read only
    /// then), and the subscription is not read before.
    #[test]
    fn commands_are_read_once_a_writer_matches() {
        let domain = 200 + (std::process::id() + 7) % 30;
        let ctx = context(domain);
        let mut world = world();
        let mut bridge =
            Bridge::new(&ctx, &mut world, Params::default(), &RosArgs::default()).unwrap();
        let model = bridge.vehicles[0].model;
        let sub = match &bridge.vehicles[0].cmd_vel {
            CmdVel::Plain(s) => s.sub.guid(),
            CmdVel::Stamped(s) => s.sub.guid(),
        };
        step(&mut world, &mut bridge);
        assert!(!bridge.matches.may_hold_data(sub), "no writer yet");

        let qos = default_qos();
        let (mut node, topic) = peer_topic::<Twist>(domain, "writer", "/cmd_vel", &qos);
        let publisher: Publisher<Twist> = node.create_publisher(&topic, Some(qos)).unwrap();
        let deadline = Instant::now() + Duration::from_secs(30);
        let mut goal = 0.0;
        while goal == 0.0 && Instant::now() < deadline {
            let mut cmd = Twist::default();
            cmd.linear.x = 0.25;
            publisher.publish(cmd).unwrap();
            std::thread::sleep(Duration::from_millis(10));
            step(&mut world, &mut bridge);
            goal = world.position_model(model).unwrap().goal.x;
        }
        assert_eq!(goal, 0.25, "the command reached the vehicle");
        assert!(bridge.matches.may_hold_data(sub));
    }
}
