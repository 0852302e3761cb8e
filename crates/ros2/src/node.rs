//! The ROS 2 node on DDS (`ros2-client` / RustDDS): the wiring of its topics, services and the
//! `FollowJointTrajectory` action around one robot session. The loops are in [`crate::loops`],
//! [`crate::services`] and [`crate::action_loop`]; the decisions about motion in
//! [`crate::motion_owner`].

use std::future::Future;
use std::net::{IpAddr, Ipv4Addr};
use std::sync::{Arc, Mutex};

use fs020n_kin::RobotModel;
use ros2_client::action::ActionServerQosPolicies;
use ros2_client::dds::rustdds::DomainParticipantBuilder;
use ros2_client::log::LogLevel;
use ros2_client::qos::{Durability, History, Reliability, WhenFull};
use ros2_client::{
    ActionTypeName, Context, MessageTypeName, Name, NodeName, NodeOptions, ParameterValue,
    QosProfile, ServiceTypeName,
};

use crate::action_loop::action_loop;
use crate::config::NodeConfig;
use crate::diagnostics::NodeState;
use crate::error::Ros2Error;
use crate::loops::{diagnostics_loop, joint_state_loop};
use crate::motion_owner::MotionOwner;
use crate::msg::{
    DiagnosticArray, Float64MultiArray, FollowJointTrajectoryFeedback, FollowJointTrajectoryGoal,
    FollowJointTrajectoryResult, JointState, JointTrajectory, SetSpeedRequest, SetSpeedResponse,
    StringMsg, TfMessage, Time, TriggerRequest, TriggerResponse,
};
use crate::replies::ActionReplyTopics;
use crate::services::{speed_loop, trigger_loop, Service, Trigger};
use crate::shared::{lock, Shared};
use crate::source::{Action, RobotSource};
use crate::urdf;

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
        .new_node(node_name.clone(), options)
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

    // Services, each with the DDS topic its replies go on (a reply waits for a reader of it).
    let reply_topic = |service: &Name| service.to_dds_name("rr", &node_name, "Reply");
    let trigger = ServiceTypeName::new("std_srvs", "Trigger");
    let mut trigger_server =
        |base: &str| -> Result<Service<TriggerRequest, TriggerResponse>, Ros2Error> {
            let service = split_name(&config.resolve(&format!("~/{base}")))?;
            Ok(Service {
                server: node
                    .create_server(mapping, &service, &trigger, service_qos(), service_qos())
                    .map_err(dds("~/ service"))?,
                reply_topic: reply_topic(&service),
            })
        };
    let start_srv = trigger_server("start")?;
    let stop_srv = trigger_server("stop")?;
    let cancel_srv = trigger_server("cancel")?;
    let speed_service = split_name(&config.resolve("~/set_speed"))?;
    let speed_srv: Service<SetSpeedRequest, SetSpeedResponse> = Service {
        server: node
            .create_server(
                mapping,
                &speed_service,
                &ServiceTypeName::new("fs020n_msgs", "SetSpeed"),
                service_qos(),
                service_qos(),
            )
            .map_err(dds("~/set_speed"))?,
        reply_topic: reply_topic(&speed_service),
    };

    // The action, with the QoS of ROS 2 actions: volatile services and feedback, a
    // transient-local status. Its services are `<action>/_action/<service>`.
    let action_name = config.resolve(&config.action_name());
    let action_reply = |service: &str| -> Result<String, Ros2Error> {
        Ok(reply_topic(&split_name(&format!(
            "{action_name}/_action/{service}"
        ))?))
    };
    let action_replies = ActionReplyTopics {
        send_goal: action_reply("send_goal")?,
        cancel_goal: action_reply("cancel_goal")?,
        get_result: action_reply("get_result")?,
    };
    let volatile = QosProfile::publisher_default()
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 10 });
    let action = node
        .create_action_server::<FollowJointTrajectoryGoal, FollowJointTrajectoryResult, FollowJointTrajectoryFeedback>(
            mapping,
            &split_name(&action_name)?,
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
        motion: Mutex::new(MotionOwner::new(
            config.execution.auto_start,
            config.fully_qualified_name(),
        )),
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
                action_replies,
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
