//! The ROS 2 node on DDS (`ros2-client` / RustDDS): topics, services and the
//! `FollowJointTrajectory` action around one robot session.

use std::future::Future;
use std::net::{IpAddr, Ipv4Addr};
use std::pin::Pin;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use fs020n_client::{blockers, Blocker, Robot, ServoHandle, ServoOptions};
use fs020n_kin::RobotModel;
use ros2_client::action::{ActionServerQosPolicies, GetResultResponse, SendGoalResponse};
use ros2_client::action_msgs::{
    CancelGoalRequest, CancelGoalResponse, CancelGoalResponseEnum, GoalId, GoalInfo, GoalStatus,
    GoalStatusArray, GoalStatusEnum,
};
use ros2_client::builtin_interfaces::Time as RosTime;
use ros2_client::dds::rustdds::{DomainParticipant, DomainParticipantBuilder};
use ros2_client::log::LogLevel;
use ros2_client::qos::{Durability, History, Reliability, WhenFull};
use ros2_client::service::request_id::RmwRequestId;
use ros2_client::{
    ActionTypeName, Context, MessageTypeName, Name, NodeName, NodeOptions, ParameterValue,
    QosProfile, RosoutRaw, ServiceTypeName,
};
use tokio::sync::{mpsc, watch};

use crate::action::{status, CancelCode, GoalTable};
use crate::arming::Arming;
use crate::config::NodeConfig;
use crate::diagnostics::{robot_status, NodeState};
use crate::error::Ros2Error;
use crate::execute::{execute, GoalEnd, Outcome};
use crate::forward::ForwardCommands;
use crate::goal::{plan, plan_preempting, GoalRefusal};
use crate::msg::{
    error_code, DiagnosticArray, Float64MultiArray, FollowJointTrajectoryFeedback,
    FollowJointTrajectoryGoal, FollowJointTrajectoryResult, Header, JointState, JointTrajectory,
    SetSpeedRequest, SetSpeedResponse, StringMsg, TfMessage, Time, TriggerRequest, TriggerResponse,
};
use crate::reply_gate::{Guid, Released, ReplyGate};
use crate::urdf;

/// Where the node gets its robot session. The standalone node holds one
/// `Arc<fs020n_client::Robot>`; a host that manages sessions itself (reconnects, shares the
/// session with other faces) implements this to hand out the current one.
pub trait RobotSource: Send + Sync + 'static {
    /// The session to use now; `None` while there is none (the node then publishes no joint
    /// states, reports the link in `/diagnostics` and refuses goals and services).
    fn robot(&self) -> Option<Arc<Robot>>;

    /// Asks to act on the robot before the node does: a source that shares the session (the
    /// hub) refuses while another user holds control, or when a safety fence forbids the
    /// action. `Err` carries the reason, given to the ROS 2 caller; `Ok` carries a permit the
    /// node holds until the action is over (a goal: until its end). Stops and cancels are never
    /// asked: they always go. The default allows everything.
    fn permit(&self, action: Action<'_>) -> Result<Permit, String> {
        let _ = action;
        Ok(Permit::default())
    }

    /// Checks an action without taking anything: a source with a safety fence refuses what
    /// crosses it (`Err` carries the reason). The node calls it for every sample of a servo
    /// ([`Action::StreamSample`]) while it holds the servo's permit, so it must not claim,
    /// wait or log success. The default allows everything.
    fn check(&self, action: Action<'_>) -> Result<(), String> {
        let _ = action;
        Ok(())
    }
}

/// What the node is about to do, for [`RobotSource::permit`].
#[derive(Debug, Clone, Copy)]
#[non_exhaustive]
pub enum Action<'a> {
    /// Start the motion program (command 1): the `~/start` service, or a goal with
    /// `auto_start`.
    Start,
    /// Set the monitor speed, percent (command 3): `~/set_speed` or the configured speed.
    SetSpeed(f64),
    /// Follow a trajectory (a `FollowJointTrajectory` goal): its points in the robot's joint
    /// order, degrees, from the current position.
    Trajectory(&'a [fs020n_kin::JointsDeg]),
    /// Servo the arm from `~/commands` (the client's servo, command 7 samples): asked once
    /// when the servo opens; its permit is held until the servo ends.
    Servo,
    /// One command-7 sample of the servo, exactly as it is sent (its time stamp aside): given
    /// to [`RobotSource::check`] before every push.
    StreamSample(&'a fs020n_proto::StreamSample),
}

/// Held while an action runs; dropping it tells the source the action is over (the hub then
/// releases control).
#[derive(Default)]
pub struct Permit(Option<Box<dyn Send + Sync>>);

impl Permit {
    /// A permit that keeps `guard` alive until the action is over.
    pub fn holding(guard: impl Send + Sync + 'static) -> Permit {
        Permit(Some(Box::new(guard)))
    }
}

impl std::fmt::Debug for Permit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_tuple("Permit").field(&self.0.is_some()).finish()
    }
}

impl RobotSource for Arc<Robot> {
    fn robot(&self) -> Option<Arc<Robot>> {
        Some(self.clone())
    }
}

type Server<Req, Resp> = ros2_client::Server<Req, Resp>;
type ActionServer = ros2_client::action::ActionServer<
    FollowJointTrajectoryGoal,
    FollowJointTrajectoryResult,
    FollowJointTrajectoryFeedback,
>;

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

fn dds<E: std::fmt::Display>(what: &str) -> impl FnOnce(E) -> Ros2Error + '_ {
    move |e| Ros2Error::Dds(format!("{what}: {e}"))
}

fn name(namespace: &str, base: &str) -> Result<Name, Ros2Error> {
    Name::new(namespace, base)
        .map_err(|e| Ros2Error::Config(format!("name {namespace}/{base}: {e:?}")))
}

/// Splits `/a/b/c` into (`/a/b`, `c`).
fn split_name(full: &str) -> Result<Name, Ros2Error> {
    match full.rsplit_once('/') {
        Some(("", base)) => name("/", base),
        Some((ns, base)) => name(ns, base),
        None => name("/", full),
    }
}

/// What every part of the node shares.
struct Shared {
    config: NodeConfig,
    model: RobotModel,
    source: Arc<dyn RobotSource>,
    state: Mutex<NodeState>,
    logger: ros2_client::NodeLoggingHandle,
    busy: std::sync::atomic::AtomicBool,
    /// When a goal may start the motion program (the re-arm policy).
    arming: Mutex<Arming>,
}

impl Shared {
    fn log(&self, level: LogLevel, msg: &str) {
        self.logger.rosout_raw(
            ros2_client::builtin_interfaces::Time::now(),
            level,
            &self.config.node_name,
            msg,
            file!(),
            "",
            line!(),
        );
    }

    fn robot(&self) -> Result<Arc<Robot>, String> {
        match self.source.robot() {
            Some(r) if r.is_connected() => Ok(r),
            Some(r) => Err(format!(
                "the robot session has ended ({}); restart the node",
                r.link_error().map_or("closed".into(), |e| e.to_string())
            )),
            None => Err("no robot session at the moment; try again when it is connected".into()),
        }
    }
}

/// A publisher on `name` (resolved under the node's namespace and remappings) of the message
/// type `(package, type)`.
fn publisher<D: serde::Serialize>(
    node: &mut ros2_client::Node,
    config: &NodeConfig,
    name: &str,
    (package, type_name): (&str, &str),
    qos: QosProfile,
) -> Result<ros2_client::Publisher<D>, Ros2Error> {
    let topic = node
        .create_topic(
            &split_name(&config.resolve(name))?,
            MessageTypeName::new(package, type_name),
            &qos,
        )
        .map_err(dds(name))?;
    node.create_publisher::<D>(&topic, Some(qos))
        .map_err(dds(name))
}

/// A subscription to `name`, as [`publisher`].
fn subscription<D: 'static>(
    node: &mut ros2_client::Node,
    config: &NodeConfig,
    name: &str,
    (package, type_name): (&str, &str),
    qos: QosProfile,
) -> Result<ros2_client::Subscription<D>, Ros2Error> {
    let topic = node
        .create_topic(
            &split_name(&config.resolve(name))?,
            MessageTypeName::new(package, type_name),
            &qos,
        )
        .map_err(dds(name))?;
    node.create_subscription::<D>(&topic, Some(qos))
        .map_err(dds(name))
}

fn joint_state_qos() -> QosProfile {
    QosProfile::publisher_default()
        .reliability(Reliability::Reliable {
            when_full: WhenFull::Fail,
        })
        .history(History::KeepLast { depth: 10 })
}

fn latched_qos() -> QosProfile {
    QosProfile::publisher_default()
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 1 })
}

fn service_qos() -> QosProfile {
    QosProfile::publisher_default().history(History::KeepLast { depth: 10 })
}

/// Runs the node until `shutdown` resolves (or a DDS entity fails). A goal still executing
/// then is cancelled (commands 5 and 2: the robot brakes). The robot model gives the URDF and the
/// checks; use the session's own (`robot.model()`).
///
/// What it serves (`~` is the node's name, `/fs020n` by default):
///
/// * `joint_states` (`sensor_msgs/msg/JointState`, radians, with velocities) at
///   `joint_state_rate_hz`, and `/tf` with it ([`crate::tf`]); `/tf_static` once;
/// * `robot_description` (`std_msgs/msg/String`, transient local): [`urdf::generate`];
/// * `~/joint_trajectory` (`trajectory_msgs/msg/JointTrajectory`): replaces the running
///   trajectory, as a goal would;
/// * `~/commands` (`std_msgs/msg/Float64MultiArray`, radians): forward positions sent through
///   the client's servo and its watchdog ([`crate::forward`]);
/// * `/diagnostics` (`diagnostic_msgs/msg/DiagnosticArray`) at `diagnostics_rate_hz`;
/// * `<action_namespace>/follow_joint_trajectory` (`control_msgs/action/FollowJointTrajectory`,
///   the protocol of [`crate::action`], the re-arm policy of [`crate::arming`]);
/// * `~/start`, `~/stop`, `~/cancel` (`std_srvs/srv/Trigger`), `~/set_speed`
///   (`fs020n_msgs/srv/SetSpeed`).
pub async fn run(
    config: NodeConfig,
    model: RobotModel,
    source: Arc<dyn RobotSource>,
    shutdown: impl Future<Output = ()>,
) -> Result<(), Ros2Error> {
    config.validate()?;
    let mut builder = DomainParticipantBuilder::new(config.dds.domain_id);
    if config.dds.localhost_only {
        builder = builder.with_only_networks([IpAddr::V4(Ipv4Addr::LOCALHOST)]);
    }
    let participant = builder.build().map_err(dds("DDS participant"))?;
    let context = Context::from_domain_participant(participant).map_err(dds("ROS 2 context"))?;
    let fqn = config.fully_qualified_name();
    // Parameters, readable with `ros2 param`; read-only while the node runs.
    let declared: Vec<(&str, ParameterValue)> = vec![
        (
            "joint_names",
            ParameterValue::StringArray(config.joint_names.to_vec()),
        ),
        (
            "joint_state_rate_hz",
            ParameterValue::Double(config.joint_state_rate_hz),
        ),
        (
            "diagnostics_rate_hz",
            ParameterValue::Double(config.diagnostics_rate_hz),
        ),
        (
            "action_namespace",
            ParameterValue::String(config.action_namespace.clone()),
        ),
    ];
    let initial: Vec<(String, ParameterValue)> = declared
        .iter()
        .map(|(n, v)| ((*n).to_owned(), v.clone()))
        .collect();
    let mut options = NodeOptions::new()
        .enable_rosout(true)
        .start_parameter_services(true);
    for (n, v) in declared {
        options = options.declare_parameter(n, v);
    }
    let options = options.parameter_validator(Box::new(move |name, value| {
        if initial.iter().any(|(n, v)| n == name && v == value) {
            return Ok(());
        }
        Err(format!(
            "{name} is read-only while the node runs: set it in the parameter file \
             (--params-file) and restart; the speed has the ~/set_speed service"
        ))
    }));
    let node_name = NodeName::new(&config.namespace, &config.node_name)
        .map_err(|e| Ros2Error::Config(format!("node name {fqn}: {e:?}")))?;
    let mut node = context
        .new_node(node_name, options)
        .map_err(dds("ROS 2 node"))?;
    let mapping = config.dds.service_mapping.to_client();

    // Topics.
    let joint_states = publisher::<JointState>(
        &mut node,
        &config,
        "joint_states",
        ("sensor_msgs", "JointState"),
        joint_state_qos(),
    )?;
    let description = publisher::<StringMsg>(
        &mut node,
        &config,
        "robot_description",
        ("std_msgs", "String"),
        latched_qos(),
    )?;
    let diagnostics = publisher::<DiagnosticArray>(
        &mut node,
        &config,
        "/diagnostics",
        ("diagnostic_msgs", "DiagnosticArray"),
        joint_state_qos(),
    )?;

    let tf = publisher::<TfMessage>(
        &mut node,
        &config,
        "/tf",
        ("tf2_msgs", "TFMessage"),
        joint_state_qos(),
    )?;
    let tf_static = publisher::<TfMessage>(
        &mut node,
        &config,
        "/tf_static",
        ("tf2_msgs", "TFMessage"),
        latched_qos(),
    )?;

    // Streaming input: a trajectory on a topic replaces the running one (as JTC's).
    let trajectory_topic = subscription::<JointTrajectory>(
        &mut node,
        &config,
        "~/joint_trajectory",
        ("trajectory_msgs", "JointTrajectory"),
        joint_state_qos(),
    )?;

    // Streaming input: forward positions for the client's servo (MoveIt Servo, teleoperation).
    let commands_topic = subscription::<Float64MultiArray>(
        &mut node,
        &config,
        "~/commands",
        ("std_msgs", "Float64MultiArray"),
        joint_state_qos(),
    )?;

    // Services.
    let trigger = ServiceTypeName::new("std_srvs", "Trigger");
    let mut trigger_server =
        |base: &str| -> Result<Server<TriggerRequest, TriggerResponse>, Ros2Error> {
            node.create_server(
                mapping,
                &split_name(&config.resolve(&format!("~/{base}")))?,
                &trigger,
                service_qos(),
                service_qos(),
            )
            .map_err(dds("~/ service"))
        };
    let start_srv = trigger_server("start")?;
    let stop_srv = trigger_server("stop")?;
    let cancel_srv = trigger_server("cancel")?;
    let speed_srv: Server<SetSpeedRequest, SetSpeedResponse> = node
        .create_server(
            mapping,
            &split_name(&config.resolve("~/set_speed"))?,
            &ServiceTypeName::new("fs020n_msgs", "SetSpeed"),
            service_qos(),
            service_qos(),
        )
        .map_err(dds("~/set_speed"))?;

    // The action, with the QoS of ROS 2 actions: volatile services and feedback, a
    // transient-local status.
    let volatile = QosProfile::publisher_default()
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 10 });
    let action = node
        .create_action_server::<FollowJointTrajectoryGoal, FollowJointTrajectoryResult, FollowJointTrajectoryFeedback>(
            mapping,
            &split_name(&config.resolve(&config.action_name()))?,
            &ActionTypeName::new("control_msgs", "FollowJointTrajectory"),
            ActionServerQosPolicies {
                goal_service: volatile.clone(),
                result_service: volatile.clone(),
                cancel_service: volatile.clone(),
                feedback_publisher: volatile,
                status_publisher: latched_qos(),
            },
        )
        .map_err(dds("follow_joint_trajectory action"))?;
    let spinner = node.spinner().map_err(dds("ROS 2 spinner"))?;

    let shared = Shared {
        model,
        source,
        state: Mutex::new(NodeState::default()),
        logger: node.logging_handle(),
        busy: std::sync::atomic::AtomicBool::new(false),
        arming: Mutex::new(Arming::new(config.execution.auto_start)),
        config,
    };
    let shared = &shared;

    // The URDF, latched.
    let urdf_text = urdf::generate(&shared.model, &shared.config.joint_names);
    description
        .publish(StringMsg { data: urdf_text })
        .map_err(|e| Ros2Error::Dds(format!("/robot_description: {e:?}")))?;

    // The fixed frames, latched.
    let fixed = crate::tf::link_transforms(&shared.model, &shared.model.home.to_rad(), Time::now())
        .split_off(6);
    if let Err(e) = tf_static.publish(TfMessage { transforms: fixed }) {
        tracing::warn!("/tf_static not published: {e:?}");
    }

    // The speed this node runs at.
    if let (Some(percent), Ok(robot)) = (shared.config.speed_percent, shared.robot()) {
        let permitted = shared.source.permit(Action::SetSpeed(percent));
        match permitted {
            Err(reason) => shared.log(
                LogLevel::Warn,
                &format!("the speed was not set to {percent} %: {reason}"),
            ),
            Ok(_permit) => match robot.set_speed(percent).await {
                Ok(_) => lock(&shared.state).speed_percent = Some(percent),
                Err(e) => shared.log(
                    LogLevel::Warn,
                    &format!("could not set the speed to {percent} %: {e}"),
                ),
            },
        }
    }
    shared.log(
        LogLevel::Info,
        &format!(
            "{} ready: /joint_states at {} Hz, action {}",
            shared.config.fully_qualified_name(),
            shared.config.joint_state_rate_hz,
            shared.config.action_name()
        ),
    );

    let participant = context.domain_participant();
    let spin = async {
        let _ = spinner.spin().await;
        std::future::pending::<Result<(), Ros2Error>>().await
    };
    let work = async {
        tokio::try_join!(
            joint_state_loop(shared, &joint_states, &tf),
            diagnostics_loop(shared, &diagnostics),
            trigger_loop(shared, &participant, &start_srv, Trigger::Start),
            trigger_loop(shared, &participant, &stop_srv, Trigger::Stop),
            trigger_loop(shared, &participant, &cancel_srv, Trigger::Cancel),
            speed_loop(shared, &participant, &speed_srv),
            action_loop(
                shared,
                &action,
                context.domain_participant(),
                &trajectory_topic,
                &commands_topic
            ),
            spin,
        )
        .map(|_| ())
    };
    tokio::select! {
        r = work => r,
        _ = shutdown => Ok(()),
    }
}

async fn joint_state_loop(
    shared: &Shared,
    publisher: &ros2_client::Publisher<JointState>,
    tf: &ros2_client::Publisher<TfMessage>,
) -> Result<(), Ros2Error> {
    let mut previous: Option<([f64; 6], f64)> = None;
    let mut last_velocity: Vec<f64> = Vec::new();
    let period = Duration::from_secs_f64(1.0 / shared.config.joint_state_rate_hz);
    let mut ticker = tokio::time::interval(period);
    ticker.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut last_seq = None;
    loop {
        ticker.tick().await;
        let robot = match shared.robot() {
            Ok(r) => r,
            Err(why) => {
                lock(&shared.arming).handle_link_lost(&why);
                continue;
            }
        };
        let mut s = robot.status();
        // Idle, the session polls at its keep-alive rate: poll when the status is older than
        // one period, so that every message carries a fresh reply.
        if s.age() > period && robot.poll().await.is_ok() {
            s = robot.status();
        }
        // Every status passes the re-arm policy (a fault revokes it).
        lock(&shared.arming).handle_status(&s.status, s.received_at);
        // The same reply again (no newer one yet): published again while fresh, with the
        // velocities it had (two publications of one reply are no measure of motion).
        let same_reply = last_seq == Some(s.seq);
        if same_reply && s.age() > period * 2 {
            continue;
        }
        last_seq = Some(s.seq);
        let stamp = std::time::SystemTime::now()
            .checked_sub(s.age())
            .map_or_else(Time::now, Time::from_system);
        let joints_deg: [f64; 6] = std::array::from_fn(|j| s.status.joints[j]);
        let timer_s = s.status.timer.seconds();
        let velocity = if same_reply {
            last_velocity.clone()
        } else {
            let v = match timer_s {
                // Another reply of the same controller millisecond: no new measure either.
                Some(t)
                    if previous
                        .as_ref()
                        .is_some_and(|(_, t0)| (t - t0).abs() <= 1e-6) =>
                {
                    last_velocity.clone()
                }
                Some(t) => {
                    let v = crate::tf::joint_velocities(
                        previous.as_ref().map(|(q, t0)| (q, *t0)),
                        (&joints_deg, t),
                    );
                    previous = Some((joints_deg, t));
                    v
                }
                None => {
                    previous = None;
                    Vec::new()
                }
            };
            last_velocity = v.clone();
            v
        };
        let msg = JointState {
            header: Header {
                stamp,
                frame_id: String::new(),
            },
            name: shared.config.joint_names.to_vec(),
            position: s.status.joints.iter().map(|d| d.to_radians()).collect(),
            velocity,
            effort: Vec::new(),
        };
        if let Err(e) = publisher.publish(msg) {
            tracing::debug!("joint state not published: {e:?}");
        }
        let mut transforms =
            crate::tf::link_transforms(&shared.model, &s.status.joints.to_rad(), stamp);
        transforms.truncate(6);
        if let Err(e) = tf.publish(TfMessage { transforms }) {
            tracing::debug!("/tf not published: {e:?}");
        }
    }
}

async fn diagnostics_loop(
    shared: &Shared,
    publisher: &ros2_client::Publisher<DiagnosticArray>,
) -> Result<(), Ros2Error> {
    let period = Duration::from_secs_f64(1.0 / shared.config.diagnostics_rate_hz);
    let mut ticker = tokio::time::interval(period);
    ticker.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let hardware_id = shared.model.name().to_owned();
    loop {
        ticker.tick().await;
        let robot = shared.source.robot();
        let mut state = lock(&shared.state).clone();
        if let Some(r) = &robot {
            state.link_error = r.link_error().map(|e| e.to_string());
        } else {
            state.link_error = Some("no robot session".into());
        }
        let snapshot = robot.as_ref().map(|r| r.status());
        let status = robot_status(
            &format!("{}: robot", shared.config.node_name),
            &hardware_id,
            snapshot.as_ref(),
            &state,
        );
        let msg = DiagnosticArray {
            header: Header {
                stamp: Time::now(),
                frame_id: String::new(),
            },
            status: vec![status],
        };
        if let Err(e) = publisher.publish(msg) {
            tracing::debug!("diagnostics not published: {e:?}");
        }
    }
}

#[derive(Clone, Copy, Debug)]
enum Trigger {
    Start,
    Stop,
    Cancel,
}

async fn trigger_loop(
    shared: &Shared,
    participant: &DomainParticipant,
    server: &Server<TriggerRequest, TriggerResponse>,
    which: Trigger,
) -> Result<(), Ros2Error> {
    loop {
        let (id, _req) = match server.async_receive_request().await {
            Ok(r) => r,
            Err(e) => {
                tracing::warn!("{which:?} request not read: {e:?}");
                continue;
            }
        };
        let response = match shared.robot() {
            Err(message) => TriggerResponse {
                success: false,
                message,
            },
            Ok(robot) => {
                let r =
                    match which {
                        Trigger::Start => match shared.source.permit(Action::Start) {
                            Err(reason) => Ok(Err(reason)),
                            Ok(_permit) => robot.start().await.map(|()| {
                                lock(&shared.arming).handle_started();
                                Ok("the motion program is running (command 1); goals may start it \
                                again after the node's own cancels until the next fault"
                                .to_owned())
                            }),
                        },
                        Trigger::Stop => {
                            lock(&shared.arming).handle_operator_stop("~/stop");
                            robot.stop_program().await.map(|_| {
                                Ok(
                                    "the robot stopped and the motion program ended (command 2); \
                                ~/start runs it again"
                                        .to_owned(),
                                )
                            })
                        }
                        Trigger::Cancel => {
                            lock(&shared.arming).handle_operator_stop("~/cancel");
                            robot.cancel().await.map(|_| {
                            Ok("the current motion was cancelled: the robot braked to a stop and \
                                the motion program ended (commands 5 and 2); ~/start runs it again"
                                .to_owned())
                        })
                        }
                    };
                match r {
                    Ok(Ok(message)) => TriggerResponse {
                        success: true,
                        message,
                    },
                    Ok(Err(refusal)) => TriggerResponse {
                        success: false,
                        message: refusal,
                    },
                    Err(e) => TriggerResponse {
                        success: false,
                        message: e.to_string(),
                    },
                }
            }
        };
        shared.log(
            if response.success {
                LogLevel::Info
            } else {
                LogLevel::Warn
            },
            &format!("~/{which:?}: {}", response.message).to_lowercase(),
        );
        let response = when_reader_matched(shared, participant, &id, response).await;
        if let Err(e) = server.async_send_response(id, response).await {
            tracing::warn!("{which:?} response not sent: {e:?}");
        }
    }
}

async fn speed_loop(
    shared: &Shared,
    participant: &DomainParticipant,
    server: &Server<SetSpeedRequest, SetSpeedResponse>,
) -> Result<(), Ros2Error> {
    loop {
        let (id, req) = match server.async_receive_request().await {
            Ok(r) => r,
            Err(e) => {
                tracing::warn!("set_speed request not read: {e:?}");
                continue;
            }
        };
        let response = match shared.robot() {
            Err(message) => SetSpeedResponse {
                success: false,
                message,
            },
            Ok(robot) => match shared.source.permit(Action::SetSpeed(req.percent)) {
                Err(message) => SetSpeedResponse {
                    success: false,
                    message,
                },
                Ok(_permit) => match robot.set_speed(req.percent).await {
                    Ok(_) => {
                        lock(&shared.state).speed_percent = Some(req.percent);
                        SetSpeedResponse {
                            success: true,
                            message: format!("monitor speed set to {} % (command 3)", req.percent),
                        }
                    }
                    Err(e) => SetSpeedResponse {
                        success: false,
                        message: e.to_string(),
                    },
                },
            },
        };
        let response = when_reader_matched(shared, participant, &id, response).await;
        if let Err(e) = server.async_send_response(id, response).await {
            tracing::warn!("set_speed response not sent: {e:?}");
        }
    }
}

/// Checks a new goal that would preempt the running one, without acting: the robot's session
/// and the goal itself from where the arm is now. A goal that fails here is rejected and the
/// running goal goes on, as `joint_trajectory_controller` does.
async fn precheck(shared: &Shared, goal: &FollowJointTrajectoryGoal) -> Result<(), GoalRefusal> {
    let refuse = |m: String| GoalRefusal::new(error_code::INVALID_GOAL, m);
    let robot = shared.robot().map_err(refuse)?;
    let current = robot.status().status.joints;
    plan_preempting(
        goal,
        &shared.config.joint_names,
        &shared.model,
        &shared.config.execution,
        &current,
        Time::now(),
    )
    .map(|_| ())
}

/// Checks a new goal against the robot now (session, switches, program) and plans it. When the
/// program is not running and the re-arm policy allows it ([`crate::arming`]: the node ended
/// it itself and no fault came since), starts it (command 1): a goal is an explicit request
/// for motion. `preempting`: the goal replaces one the node just stopped.
async fn admit(
    shared: &Shared,
    goal: &FollowJointTrajectoryGoal,
    preempting: bool,
) -> Result<(Arc<Robot>, crate::goal::Plan, Permit), GoalRefusal> {
    let refuse = |m: String| GoalRefusal::new(error_code::INVALID_GOAL, m);
    let (robot, status) = ready_to_move(shared).await.map_err(refuse)?;
    let planner = if preempting { plan_preempting } else { plan };
    let p = planner(
        goal,
        &shared.config.joint_names,
        &shared.model,
        &shared.config.execution,
        &status.joints,
        Time::now(),
    )?;
    // The path as the robot will follow it: the points and the spline between them every
    // 10 ms (a source with a fence checks each of them, and the straight pieces between).
    let path = planned_path(&p.trajectory);
    let permit = shared
        .source
        .permit(Action::Trajectory(&path))
        .map_err(refuse)?;
    Ok((robot, p, permit))
}

/// Checks the robot now (session, switches, program) for an explicit request of motion (a
/// goal, a streamed trajectory, the first command of a servo). When the program is not
/// running and the re-arm policy allows it ([`crate::arming`]: the node ended it itself and
/// no fault came since), starts it (command 1). Returns the session and a fresh status.
async fn ready_to_move(shared: &Shared) -> Result<(Arc<Robot>, fs020n_client::Status), String> {
    let robot = shared.robot()?;
    let mut status = robot.poll().await.map_err(|e| e.to_string())?;
    lock(&shared.arming).handle_status(&status, tokio::time::Instant::now());
    // After the node's own stop the program finishes its brake before it ends: wait for that
    // end, so that the start below is not answered by a program about to end.
    let deadline = tokio::time::Instant::now() + PROGRAM_END_WAIT;
    while lock(&shared.arming).awaiting_program_end() && status.task_running {
        if tokio::time::Instant::now() >= deadline {
            return Err(format!(
                "the motion program did not end within {PROGRAM_END_WAIT:?} of the node's stop; \
                 call ~/stop, then ~/start"
            ));
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
        status = robot.poll().await.map_err(|e| e.to_string())?;
        lock(&shared.arming).handle_status(&status, tokio::time::Instant::now());
    }
    let list = blockers(&status, true);
    let may_start = lock(&shared.arming).may_start_for_goal();
    if list == [Blocker::ProgramNotRunning] && may_start.is_ok() {
        let _permit = shared
            .source
            .permit(Action::Start)
            .map_err(|r| format!("the motion program was not started: {r}"))?;
        robot
            .start()
            .await
            .map_err(|e| format!("could not start the motion program: {e}"))?;
        lock(&shared.arming).handle_started();
        status = robot.poll().await.map_err(|e| e.to_string())?;
    } else if list == [Blocker::ProgramNotRunning] {
        let reason = may_start.err().unwrap_or_default();
        return Err(format!(
            "the robot is not ready to move — {reason} ({})",
            shared.config.fully_qualified_name()
        ));
    } else if !list.is_empty() {
        let text = list
            .iter()
            .map(|b| b.to_string())
            .collect::<Vec<_>>()
            .join("; ");
        return Err(format!(
            "the robot is not ready to move — {text}; then call the {}/start service \
             (std_srvs/srv/Trigger): no goal restarts the motion program after a fault",
            shared.config.fully_qualified_name()
        ));
    }
    Ok((robot, status))
}

/// The positions of `trajectory` at its points and every 10 ms between them, in time order.
fn planned_path(trajectory: &fs020n_client::Trajectory) -> Vec<fs020n_kin::JointsDeg> {
    const STEP_S: f64 = 0.01;
    let (start, end) = (trajectory.start_s(), trajectory.end_s());
    let n = ((end - start) / STEP_S).ceil().clamp(0.0, 1e6) as usize;
    let mut path: Vec<_> = (0..=n)
        .map(|k| (start + k as f64 * STEP_S).min(end))
        .chain(trajectory.points().iter().map(|p| p.time_s))
        .map(|t| (t, trajectory.sample(t).position))
        .collect();
    path.sort_by(|a, b| a.0.total_cmp(&b.0));
    path.into_iter().map(|(_, q)| q).collect()
}

type Executing<'a> = Pin<Box<dyn Future<Output = Outcome> + Send + 'a>>;
type Goals = GoalTable<GoalId, RmwRequestId, FollowJointTrajectoryResult>;

/// How long a goal waits for the program the node stopped to end before starting it again.
const PROGRAM_END_WAIT: Duration = Duration::from_secs(3);

/// How often the action's services are read (they are polled: a few milliseconds of latency).
const ACTION_POLL: Duration = Duration::from_millis(5);

fn status_enum(s: i8) -> GoalStatusEnum {
    match s {
        status::ACCEPTED => GoalStatusEnum::Accepted,
        status::EXECUTING => GoalStatusEnum::Executing,
        status::CANCELING => GoalStatusEnum::Canceling,
        status::SUCCEEDED => GoalStatusEnum::Succeeded,
        status::CANCELED => GoalStatusEnum::Canceled,
        status::ABORTED => GoalStatusEnum::Aborted,
        _ => GoalStatusEnum::Unknown,
    }
}

/// Publishes the status of every known goal (transient local: a late subscriber gets it).
fn publish_statuses(server: &ActionServer, goals: &Goals) {
    let status_list = goals
        .status_list()
        .into_iter()
        .map(|(goal_id, ns, s)| GoalStatus {
            goal_info: GoalInfo {
                goal_id,
                stamp: RosTime::from_nanos(ns),
            },
            status: status_enum(s),
        })
        .collect();
    if let Err(e) = server.send_goal_statuses(GoalStatusArray { status_list }) {
        tracing::warn!("goal statuses not published: {e:?}");
    }
}

fn send_results(
    replies: &mut ActionReplies<'_>,
    results: Vec<(RmwRequestId, i8, FollowJointTrajectoryResult)>,
) {
    for (request, s, result) in results {
        let response = GetResultResponse {
            status: status_enum(s),
            result,
        };
        replies.send(ActionReply::Result(request, response));
    }
}

/// A reply of the action's services.
enum ActionReply {
    Goal(RmwRequestId, SendGoalResponse),
    Cancel(RmwRequestId, CancelGoalResponse),
    Result(RmwRequestId, GetResultResponse<FollowJointTrajectoryResult>),
}

impl ActionReply {
    /// The GUID the request named: its requester's reply reader under the enhanced mapping
    /// (rmw_fastrtps), else its request writer.
    fn requester(&self) -> Guid {
        let (ActionReply::Goal(id, _) | ActionReply::Cancel(id, _) | ActionReply::Result(id, _)) =
            self;
        id.writer_gid.to_bytes16()
    }

    fn send(self, server: &ActionServer) {
        let sent = match self {
            ActionReply::Goal(id, r) => server.send_goal_response(id, r),
            ActionReply::Cancel(id, r) => server.send_cancel_response(id, r),
            ActionReply::Result(id, r) => server.send_result(id, r),
        };
        if let Err(e) = sent {
            tracing::warn!("action reply not sent: {e:?}");
        }
    }
}

/// The action's replies, each sent once the requester's reply reader is matched
/// ([`crate::reply_gate`]). ros2-client keeps its servers' reply writers to itself, so the
/// readers the participant has discovered stand for the readers those writers matched.
struct ActionReplies<'a> {
    server: &'a ActionServer,
    participant: DomainParticipant,
    gate: ReplyGate<ActionReply>,
}

impl ActionReplies<'_> {
    fn send(&mut self, reply: ActionReply) {
        let participant = &self.participant;
        let requester = reply.requester();
        let now = tokio::time::Instant::now();
        let known = |g: &Guid| discovered_reader(participant, g);
        if let Some(reply) = self.gate.handle_reply(requester, reply, known, now) {
            reply.send(self.server);
        }
    }

    /// Sends the held replies whose reader is matched now, or that waited long enough.
    fn poll(&mut self) {
        if self.gate.is_empty() {
            return;
        }
        let readers: Vec<Guid> = self
            .participant
            .discovered_readers()
            .iter()
            .map(|r| r.reader_proxy.remote_reader_guid.to_bytes())
            .collect();
        let now = tokio::time::Instant::now();
        for (reply, why) in self.gate.poll_released(|g| readers.contains(g), now) {
            if why == Released::WaitedOut {
                tracing::warn!(
                    "the reply reader a request named was not discovered within {:?}: replying \
                     anyway",
                    self.gate.wait()
                );
            }
            reply.send(self.server);
        }
    }
}

/// Gives `reply` back once the reply reader the request `id` named is discovered (at once
/// when its mapping names none), as [`ActionReplies`] does for the action's replies.
async fn when_reader_matched<R>(
    shared: &Shared,
    participant: &DomainParticipant,
    id: &RmwRequestId,
    reply: R,
) -> R {
    let mut gate = ReplyGate::new(shared.config.dds.service_mapping, reader_wait(shared));
    let known = |g: &Guid| discovered_reader(participant, g);
    let now = tokio::time::Instant::now();
    if let Some(reply) = gate.handle_reply(id.writer_gid.to_bytes16(), reply, known, now) {
        return reply;
    }
    loop {
        tokio::time::sleep(ACTION_POLL).await;
        let now = tokio::time::Instant::now();
        if let Some((reply, why)) = gate.poll_released(known, now).pop() {
            if why == Released::WaitedOut {
                tracing::warn!(
                    "the reply reader a request named was not discovered within {:?}: replying \
                     anyway",
                    reader_wait(shared)
                );
            }
            return reply;
        }
    }
}

/// How long a reply waits for the reply reader its request named.
fn reader_wait(shared: &Shared) -> Duration {
    Duration::from_secs_f64(shared.config.reply_reader_wait_s)
}

fn discovered_reader(participant: &DomainParticipant, guid: &Guid) -> bool {
    participant
        .discovered_readers()
        .iter()
        .any(|r| r.reader_proxy.remote_reader_guid.to_bytes() == *guid)
}

/// The goal id and stamp of a cancel request (ros2-client keeps the fields to itself: read
/// them back through its serde representation).
fn cancel_fields(request: &CancelGoalRequest) -> Option<(GoalId, RosTime)> {
    #[derive(serde::Deserialize)]
    struct Info {
        goal_id: GoalId,
        stamp: RosTime,
    }
    #[derive(serde::Deserialize)]
    struct Fields {
        goal_info: Info,
    }
    let value = serde_norway::to_value(request).ok()?;
    let f: Fields = serde_norway::from_value(value).ok()?;
    Some((f.goal_info.goal_id, f.goal_info.stamp))
}

/// Ends a goal: logs, tells the re-arm policy what became of the program, keeps the result,
/// answers the result requests waiting for it and publishes the statuses.
fn end_goal(
    shared: &Shared,
    replies: &mut ActionReplies<'_>,
    goals: &mut Goals,
    id: Option<GoalId>,
    outcome: Outcome,
) {
    shared
        .busy
        .store(false, std::sync::atomic::Ordering::SeqCst);
    lock(&shared.arming).handle_goal_ended(outcome.program.clone(), tokio::time::Instant::now());
    let end = match outcome.end {
        GoalEnd::Succeeded => status::SUCCEEDED,
        GoalEnd::Aborted => status::ABORTED,
        GoalEnd::Canceled => status::CANCELED,
    };
    let text = format!(
        "goal {:?} ({}): {}",
        outcome.end, outcome.result.error_code, outcome.result.error_string
    );
    shared.log(
        if outcome.end == GoalEnd::Succeeded {
            LogLevel::Info
        } else {
            LogLevel::Warn
        },
        &text,
    );
    lock(&shared.state).last_goal = Some(text);
    // A trajectory from the topic has no goal: nobody asks for its result.
    if let Some(id) = id {
        let results = goals.handle_goal_end(id, end, outcome.result, tokio::time::Instant::now());
        send_results(replies, results);
        publish_statuses(replies.server, goals);
    }
}

/// Admits `goal` (an action goal or a `~/joint_trajectory` message) as the next trajectory.
/// When a trajectory or a servo runs, the new one replaces it, as joint_trajectory_controller
/// does, once it passes the checks that do not need the arm to stop; then the servo ends, the
/// running goal is preempted and the arm brakes before the new one is planned from where it is.
async fn admit_replacing(
    shared: &Shared,
    goal: &FollowJointTrajectoryGoal,
    servo: &mut Option<ServoRun>,
    replies: &mut ActionReplies<'_>,
    goals: &mut Goals,
    current: &mut Option<(Option<GoalId>, watch::Sender<bool>)>,
    executing: &mut Option<Executing<'_>>,
) -> Result<(Arc<Robot>, crate::goal::Plan, Permit), GoalRefusal> {
    if current.is_none() && servo.is_none() {
        return admit(shared, goal, false).await;
    }
    precheck(shared, goal).await?;
    end_servo(shared, servo).await;
    preempt(shared, replies, goals, current, executing).await;
    admit(shared, goal, true).await
}

/// Stops the running trajectory because a newer one replaces it: it ends ABORTED "preempted
/// by a new goal" once the robot has braked.
async fn preempt(
    shared: &Shared,
    replies: &mut ActionReplies<'_>,
    goals: &mut Goals,
    current: &mut Option<(Option<GoalId>, watch::Sender<bool>)>,
    executing: &mut Option<Executing<'_>>,
) {
    if let (Some((old, cancel)), Some(running)) = (current.take(), executing.take()) {
        shared.log(
            LogLevel::Info,
            "a new trajectory preempts the running one: braking (commands 5 and 2)",
        );
        cancel.send_replace(true);
        let outcome = running.await.preempted();
        end_goal(shared, replies, goals, old, outcome);
    }
}

/// A servo fed by `~/commands`, with the source's permit it holds until it ends.
struct ServoRun {
    handle: ServoHandle,
    permit: Permit,
}

/// Handles one `~/commands` message: checks it, opens the servo for the first one (the same
/// readiness and re-arm policy as a goal), checks the sample with the source (a fence) and
/// pushes it. `Err`: why it was refused (nothing was sent).
async fn command(
    shared: &Shared,
    forward: &ForwardCommands,
    servo: &mut Option<ServoRun>,
    trajectory_running: bool,
    data: &[f64],
) -> Result<(), String> {
    if trajectory_running {
        return Err(
            "a trajectory is executing (a goal or ~/joint_trajectory); cancel it or \
                    wait for its end before sending commands"
                .into(),
        );
    }
    if servo.as_ref().is_some_and(|s| s.handle.is_finished()) {
        end_servo(shared, servo).await;
    }
    let sample = forward.handle_command(data).map_err(|e| e.to_string())?;
    let options = ServoOptions::default();
    let checked = ForwardCommands::stream_sample(&sample, options.lookahead_passes);
    let run = match servo {
        Some(run) => run,
        None => {
            let (robot, _) = ready_to_move(shared).await?;
            shared.source.check(Action::StreamSample(&checked))?;
            let permit = shared.source.permit(Action::Servo)?;
            let handle = robot
                .servo(options)
                .await
                .map_err(|e| format!("the servo did not open: {e}"))?;
            lock(&shared.arming).handle_goal_started();
            let text = format!(
                "servoing from ~/commands (command 7): the watchdog brakes the arm and ends the \
                 motion program after {:?} without a command",
                options.watchdog
            );
            shared.log(LogLevel::Info, &text);
            lock(&shared.state).last_command = Some(text);
            servo.insert(ServoRun { handle, permit })
        }
    };
    shared.source.check(Action::StreamSample(&checked))?;
    run.handle.push(sample).map_err(|e| e.to_string())
}

/// Ends the servo (if it still runs: commands 5 then 2), tells the re-arm policy how it ended
/// and gives the permit back. The watchdog and the node's own stop are the node's stops (the
/// next command starts the program again); a fault, a lost link or a stop of the robot by
/// anyone else requires `~/start`.
async fn end_servo(shared: &Shared, servo: &mut Option<ServoRun>) {
    let Some(ServoRun { handle, permit }) = servo.take() else {
        return;
    };
    let watchdog = handle.options().watchdog;
    let ended = handle.finish().await;
    drop(permit);
    let (how, text) =
        crate::forward::servo_end(ended.as_ref().map(|report| report.outcome), watchdog);
    lock(&shared.arming).handle_goal_ended(how, tokio::time::Instant::now());
    shared.log(LogLevel::Warn, &text);
    lock(&shared.state).last_command = Some(text);
}

async fn action_loop(
    shared: &Shared,
    server: &ActionServer,
    participant: DomainParticipant,
    trajectories: &ros2_client::Subscription<JointTrajectory>,
    commands: &ros2_client::Subscription<Float64MultiArray>,
) -> Result<(), Ros2Error> {
    let (feedback_tx, mut feedback_rx) = mpsc::channel::<FollowJointTrajectoryFeedback>(4);
    let feedback_tx = &feedback_tx;
    let mut goals: Goals = GoalTable::new(
        Duration::from_secs_f64(shared.config.result_retention_s),
        FollowJointTrajectoryResult::default(),
    );
    // The executing trajectory: its goal id (`None`: from the `~/joint_trajectory` topic) and
    // its cancel switch.
    let mut current: Option<(Option<GoalId>, watch::Sender<bool>)> = None;
    let mut executing: Option<Executing<'_>> = None;
    // The servo of `~/commands`, while one runs.
    let mut servo: Option<ServoRun> = None;
    let forward = ForwardCommands::new(shared.model.clone(), shared.config.joint_names.clone());
    let feedback_period = Duration::from_secs_f64(1.0 / shared.config.feedback_rate_hz);
    let mut poll = tokio::time::interval(ACTION_POLL);
    poll.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut replies = ActionReplies {
        server,
        participant,
        gate: ReplyGate::new(shared.config.dds.service_mapping, reader_wait(shared)),
    };
    publish_statuses(server, &goals);
    loop {
        tokio::select! {
            _ = poll.tick() => {
                // Goals.
                loop {
                    let (request_id, request) = match server.receive_goal() {
                        Ok(Some(r)) => r,
                        Ok(None) => break,
                        Err(e) => {
                            tracing::warn!("goal request not read: {e:?}");
                            break;
                        }
                    };
                    let id = request.goal_id;
                    let goal = request.goal;
                    let admitted = if goals.contains(&id) {
                        Err(GoalRefusal::new(error_code::INVALID_GOAL, "a goal with this id exists already; give every goal a new id"))
                    } else {
                        admit_replacing(shared, &goal, &mut servo, &mut replies, &mut goals, &mut current, &mut executing).await
                    };
                    match admitted {
                        Err(refusal) => {
                            let text = format!("goal rejected ({}): {}", refusal.code, refusal.message);
                            shared.log(LogLevel::Warn, &text);
                            lock(&shared.state).last_goal = Some(text);
                            let response = SendGoalResponse { accepted: false, stamp: RosTime::ZERO };
                            replies.send(ActionReply::Goal(request_id, response));
                        }
                        Ok((robot, p, permit)) => {
                            let stamp = RosTime::now();
                            goals.handle_goal_accepted(id, stamp.to_nanos());
                            let response = SendGoalResponse { accepted: true, stamp };
                            replies.send(ActionReply::Goal(request_id, response));
                            publish_statuses(server, &goals);
                            let text = format!(
                                "executing a trajectory of {} points over {:.3} s",
                                goal.trajectory.points.len(),
                                p.duration_s()
                            );
                            shared.log(LogLevel::Info, &text);
                            lock(&shared.state).last_goal = Some(text);
                            shared.busy.store(true, std::sync::atomic::Ordering::SeqCst);
                            lock(&shared.arming).handle_goal_started();
                            let (cancel_tx, cancel_rx) = watch::channel(false);
                            current = Some((Some(id), cancel_tx));
                            let exec = &shared.config.execution;
                            let names = &shared.config.joint_names;
                            executing = Some(Box::pin(async move {
                                let outcome = execute(&robot, &p, exec, names, feedback_period, cancel_rx, feedback_tx).await;
                                // Control is given back when the goal is over.
                                drop(permit);
                                outcome
                            }));
                        }
                    }
                }
                // Cancels.
                loop {
                    let (request_id, request) = match server.receive_cancel_request() {
                        Ok(Some(r)) => r,
                        Ok(None) => break,
                        Err(e) => {
                            tracing::warn!("cancel request not read: {e:?}");
                            break;
                        }
                    };
                    let (code, canceling) = match cancel_fields(&request) {
                        Some((id, stamp)) => goals.handle_cancel_request(
                            (id != GoalId::ZERO).then_some(id),
                            stamp.to_nanos(),
                        ),
                        None => (CancelCode::Rejected, Vec::new()),
                    };
                    if let Some((Some(id), tx)) = &current {
                        if canceling.iter().any(|(k, _)| k == id) {
                            tx.send_replace(true);
                            shared.log(LogLevel::Info, "goal cancel requested: braking (commands 5 and 2); the arm holds where it stops");
                        }
                    }
                    let response = CancelGoalResponse {
                        return_code: match code {
                            CancelCode::ErrorNone => CancelGoalResponseEnum::None,
                            CancelCode::Rejected => CancelGoalResponseEnum::Rejected,
                            CancelCode::UnknownGoalId => CancelGoalResponseEnum::UnknownGoal,
                            CancelCode::GoalTerminated => CancelGoalResponseEnum::GoalTerminated,
                        },
                        goals_canceling: canceling
                            .iter()
                            .map(|(goal_id, ns)| GoalInfo { goal_id: *goal_id, stamp: RosTime::from_nanos(*ns) })
                            .collect(),
                    };
                    replies.send(ActionReply::Cancel(request_id, response));
                    if !canceling.is_empty() {
                        publish_statuses(server, &goals);
                    }
                }
                // Result requests.
                loop {
                    let (request_id, request) = match server.receive_result_request() {
                        Ok(Some(r)) => r,
                        Ok(None) => break,
                        Err(e) => {
                            tracing::warn!("result request not read: {e:?}");
                            break;
                        }
                    };
                    if let Some(reply) = goals.handle_result_request(request_id, request.goal_id) {
                        send_results(&mut replies, vec![reply]);
                    }
                }
                if goals.handle_timeout(tokio::time::Instant::now()) {
                    publish_statuses(server, &goals);
                }
                // Replies whose requester's reply reader is matched now.
                replies.poll();
                // A servo that ended by itself (the watchdog, a fault).
                if servo.as_ref().is_some_and(|s| s.handle.is_finished()) {
                    end_servo(shared, &mut servo).await;
                }
            }
            message = commands.async_take() => {
                let data = match message {
                    Ok((m, _)) => m.data,
                    Err(e) => {
                        tracing::warn!("~/commands message not read: {e:?}");
                        continue;
                    }
                };
                if let Err(reason) = command(shared, &forward, &mut servo, current.is_some(), &data).await {
                    let text = format!("~/commands refused (nothing sent): {reason}");
                    shared.log(LogLevel::Warn, &text);
                    lock(&shared.state).last_command_refused = Some(text);
                }
            }
            Some(fb) = feedback_rx.recv() => {
                if let Some((Some(id), _)) = &current {
                    // After a cancel request the goal is "canceling": no more feedback.
                    if goals.status_of(id) == status::EXECUTING {
                        let _ = server.send_feedback(*id, fb);
                    }
                }
            }
            outcome = maybe(&mut executing), if executing.is_some() => {
                executing = None;
                let Some((id, _)) = current.take() else { continue };
                end_goal(shared, &mut replies, &mut goals, id, outcome);
            }
            message = trajectories.async_take() => {
                let trajectory = match message {
                    Ok((t, _)) => t,
                    Err(e) => {
                        tracing::warn!("~/joint_trajectory message not read: {e:?}");
                        continue;
                    }
                };
                // Checked like a goal with the node's default tolerances; it replaces the
                // running trajectory (goal or topic) once it passes the checks.
                let goal = FollowJointTrajectoryGoal { trajectory, ..Default::default() };
                let admitted = admit_replacing(shared, &goal, &mut servo, &mut replies, &mut goals, &mut current, &mut executing).await;
                match admitted {
                    Err(refusal) => {
                        let text = format!("~/joint_trajectory refused ({}): {}", refusal.code, refusal.message);
                        shared.log(LogLevel::Warn, &text);
                        lock(&shared.state).last_goal = Some(text);
                    }
                    Ok((robot, p, permit)) => {
                        let text = format!(
                            "following a ~/joint_trajectory of {} points over {:.3} s",
                            goal.trajectory.points.len(),
                            p.duration_s()
                        );
                        shared.log(LogLevel::Info, &text);
                        lock(&shared.state).last_goal = Some(text);
                        shared.busy.store(true, std::sync::atomic::Ordering::SeqCst);
                        lock(&shared.arming).handle_goal_started();
                        let (cancel_tx, cancel_rx) = watch::channel(false);
                        current = Some((None, cancel_tx));
                        let exec = &shared.config.execution;
                        let names = &shared.config.joint_names;
                        executing = Some(Box::pin(async move {
                            let outcome = execute(&robot, &p, exec, names, feedback_period, cancel_rx, feedback_tx).await;
                            drop(permit);
                            outcome
                        }));
                    }
                }
            }
        }
    }
}

/// Awaits the future in `slot`, or never when there is none.
async fn maybe<F: Future + Unpin>(slot: &mut Option<F>) -> F::Output {
    match slot {
        Some(f) => f.await,
        None => std::future::pending().await,
    }
}
