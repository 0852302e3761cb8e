//! The hub's Foxglove live bridge (feature `foxglove`): a Foxglove WebSocket server (the
//! `foxglove` crate, subprotocol `foxglove.sdk.v1`) publishing what the hub sees, so that
//! Foxglove's 3D panel shows the arm:
//!
//! | topic | encoding, schema | what |
//! |---|---|---|
//! | `/joint_states` | JSON, `sensor_msgs/msg/JointState` | names `joint_1`…`joint_6`, positions in radians, 50 Hz |
//! | `/tf` | protobuf, `foxglove.FrameTransforms` | every link frame of the URDF from the joints, 50 Hz |
//! | `/robot_description` | JSON, `std_msgs/msg/String` | the URDF generated from the model; sent to each new subscriber |
//! | `/fs020n/status` | JSON | switches, error, program, controlling client, 10 Hz |
//!
//! The joint positions are the controller's encoder values of the latest status (the protocol
//! reports no velocities or torques: those arrays are empty).

use std::io;
use std::net::SocketAddr;
use std::sync::Arc;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use foxglove::messages::{FrameTransform, FrameTransforms, Quaternion, Timestamp, Vector3};
use foxglove::websocket::{ChannelView, Client, ServerListener};
use foxglove::{Channel, Context, RawChannel, Schema, WebSocketServer, WebSocketServerHandle};
use fs020n_kin::{JointsDeg, URDF_JOINT_NAMES};
use serde_json::json;
use tokio::task::JoinHandle;

use super::Hub;

/// Joint states and transforms per second.
pub const FOXGLOVE_RATE_HZ: f64 = 50.0;

/// Topic of the joint states.
pub const JOINT_STATES_TOPIC: &str = "/joint_states";
/// Topic of the URDF.
pub const ROBOT_DESCRIPTION_TOPIC: &str = "/robot_description";

const JOINT_STATE_SCHEMA: &str = r#"{
  "title": "sensor_msgs/msg/JointState",
  "type": "object",
  "properties": {
    "header": {"type": "object", "properties": {
      "stamp": {"type": "object", "properties": {"sec": {"type": "integer"}, "nanosec": {"type": "integer"}}},
      "frame_id": {"type": "string"}}},
    "name": {"type": "array", "items": {"type": "string"}},
    "position": {"type": "array", "items": {"type": "number"}},
    "velocity": {"type": "array", "items": {"type": "number"}},
    "effort": {"type": "array", "items": {"type": "number"}}
  }
}"#;

const STRING_SCHEMA: &str = r#"{"title": "std_msgs/msg/String", "type": "object", "properties": {"data": {"type": "string"}}}"#;

const STATUS_SCHEMA: &str = r#"{"title": "fs020n/Status", "type": "object"}"#;

/// Sends the URDF to each client that subscribes to `/robot_description` (a late subscriber
/// gets it too, like a latched ROS topic).
struct Latch {
    description: Arc<RawChannel>,
    urdf: Vec<u8>,
}

impl ServerListener for Latch {
    fn on_subscribe(&self, client: Client, channel: ChannelView) {
        if channel.topic() == ROBOT_DESCRIPTION_TOPIC {
            self.description.log_to_sink(&self.urdf, client.sink_id());
        }
    }
}

/// A running Foxglove bridge. Dropping it does not stop it; call [`FoxgloveBridge::stop`].
pub struct FoxgloveBridge {
    addr: SocketAddr,
    server: WebSocketServerHandle,
    task: JoinHandle<()>,
    _context: Arc<Context>,
}

impl std::fmt::Debug for FoxgloveBridge {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FoxgloveBridge")
            .field("addr", &self.addr)
            .finish_non_exhaustive()
    }
}

impl FoxgloveBridge {
    /// The bound address.
    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }

    /// Stops publishing and closes the server.
    pub async fn stop(self) {
        self.task.abort();
        self.server.stop().wait().await;
    }
}

fn io_err(e: impl std::fmt::Display) -> io::Error {
    io::Error::other(format!("Foxglove bridge: {e}"))
}

fn stamp_now() -> (u32, u32, Option<Timestamp>) {
    let d = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap_or_default();
    let sec = u32::try_from(d.as_secs()).unwrap_or(u32::MAX);
    let nsec = d.subsec_nanos();
    (sec, nsec, Timestamp::new_checked(sec, nsec))
}

fn quat_z(a: f64) -> Quaternion {
    Quaternion {
        x: 0.0,
        y: 0.0,
        z: (a / 2.0).sin(),
        w: (a / 2.0).cos(),
    }
}

fn quat_y(a: f64) -> Quaternion {
    Quaternion {
        x: 0.0,
        y: (a / 2.0).sin(),
        z: 0.0,
        w: (a / 2.0).cos(),
    }
}

/// The link frames of the generated URDF for these joints (parent, child, translation,
/// rotation).
fn transforms(hub: &Hub, joints: &JointsDeg, stamp: Option<Timestamp>) -> FrameTransforms {
    let g = &hub.model().geometry;
    let q = joints.to_rad();
    let v = |x, y, z| Some(Vector3 { x, y, z });
    let frames = [
        ("base_link", "link_1", v(0.0, 0.0, 0.0), quat_z(q[0])),
        (
            "link_1",
            "link_2",
            v(g.shoulder_offset_m, 0.0, g.base_height_m),
            quat_y(q[1]),
        ),
        (
            "link_2",
            "link_3",
            v(0.0, 0.0, g.upper_arm_m),
            quat_y(-q[2]),
        ),
        ("link_3", "link_4", v(0.0, 0.0, g.forearm_m), quat_z(q[3])),
        ("link_4", "link_5", v(0.0, 0.0, 0.0), quat_y(-q[4])),
        ("link_5", "link_6", v(0.0, 0.0, 0.0), quat_z(q[5])),
        ("link_6", "flange", v(0.0, 0.0, g.flange_m), quat_z(0.0)),
        ("flange", "tool0", v(0.0, 0.0, 0.0), quat_z(0.0)),
    ];
    FrameTransforms {
        transforms: frames
            .into_iter()
            .map(|(parent, child, translation, rotation)| FrameTransform {
                timestamp: stamp,
                parent_frame_id: parent.into(),
                child_frame_id: child.into(),
                translation,
                rotation: Some(rotation),
            })
            .collect(),
    }
}

/// Serves the Foxglove bridge of `hub` on `addr` (e.g. `127.0.0.1:8765`; port 0 picks one).
/// Must run inside a tokio runtime.
pub async fn serve_foxglove(hub: Hub, addr: SocketAddr) -> io::Result<FoxgloveBridge> {
    let context = Context::new();
    let build = |topic: &str, name: &str, schema: &'static str| {
        context
            .channel_builder(topic)
            .message_encoding("json")
            .schema(Schema::new(name, "jsonschema", schema.as_bytes()))
            .build_raw()
            .map_err(io_err)
    };
    let joint_states = build(
        JOINT_STATES_TOPIC,
        "sensor_msgs/msg/JointState",
        JOINT_STATE_SCHEMA,
    )?;
    let description = build(
        ROBOT_DESCRIPTION_TOPIC,
        "std_msgs/msg/String",
        STRING_SCHEMA,
    )?;
    let status = build("/fs020n/status", "fs020n/Status", STATUS_SCHEMA)?;
    let tf: Channel<FrameTransforms> = context.channel_builder("/tf").build();
    let urdf = json!({"data": hub.model().to_urdf()})
        .to_string()
        .into_bytes();
    let server = WebSocketServer::new()
        .name(format!("fs020n hub ({})", hub.robot_addr()))
        .bind(addr.ip().to_string(), addr.port())
        .context(&context)
        .listener(Arc::new(Latch {
            description: description.clone(),
            urdf,
        }))
        .start()
        .await
        .map_err(io_err)?;
    let bound = SocketAddr::new(addr.ip(), server.port());
    if !bound.ip().is_loopback() {
        tracing::warn!(addr = %bound, "the Foxglove bridge listens off loopback (read-only, no authentication)");
    }
    tracing::info!(addr = %bound, "Foxglove bridge listening (ws://{bound})");
    let task = tokio::spawn(async move {
        let mut tick = tokio::time::interval(Duration::from_secs_f64(1.0 / FOXGLOVE_RATE_HZ));
        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
        let mut n: u64 = 0;
        loop {
            tick.tick().await;
            n += 1;
            let st = hub.state();
            let Some(s) = &st.status else { continue };
            let (sec, nanosec, stamp) = stamp_now();
            if joint_states.has_sinks() {
                let msg = json!({
                    "header": {"stamp": {"sec": sec, "nanosec": nanosec}, "frame_id": ""},
                    "name": URDF_JOINT_NAMES,
                    "position": s.joints_deg.to_rad().0,
                    "velocity": [],
                    "effort": [],
                });
                joint_states.log(msg.to_string().as_bytes());
            }
            if tf.has_sinks() && s.joints_deg.is_finite() {
                tf.log(&transforms(&hub, &s.joints_deg, stamp));
            }
            if n % 5 == 0 && status.has_sinks() {
                let msg = json!({
                    "power": s.power, "run": s.run, "repeat": s.repeat,
                    "teach_lock": s.teach_lock, "program_running": s.task_running,
                    "error": s.error_name, "error_message": s.error_message,
                    "blockers": s.blockers, "timer_s": s.timer_s,
                    "connected": st.link.connected, "controller": st.controller,
                });
                status.log(msg.to_string().as_bytes());
            }
        }
    });
    Ok(FoxgloveBridge {
        addr: bound,
        server,
        task,
        _context: context,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quaternions_are_unit_and_about_their_axes() {
        let q = quat_z(std::f64::consts::FRAC_PI_2);
        assert!((q.w * q.w + q.z * q.z - 1.0).abs() < 1e-12);
        assert!((q.z - (std::f64::consts::FRAC_PI_4).sin()).abs() < 1e-12);
        let q = quat_y(-1.0);
        assert!(q.y < 0.0 && q.x == 0.0 && q.z == 0.0);
    }
}
