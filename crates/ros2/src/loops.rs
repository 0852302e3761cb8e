//! The node's periodic loops: `/joint_states` with `/tf`, and `/diagnostics`.

use std::time::Duration;

use crate::diagnostics::robot_status;
use crate::error::Ros2Error;
use crate::msg::{DiagnosticArray, Header, JointState, TfMessage, Time};
use crate::shared::{lock, Shared};

/// Publishes `/joint_states` and `/tf` at `joint_state_rate_hz`, each with a fresh reply of
/// the controller (polled when idle); every status passes the re-arm policy.
pub(crate) async fn joint_state_loop(
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
                lock(&shared.motion).handle_link_lost(&why);
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
        lock(&shared.motion).handle_status(&s.status, s.received_at);
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

/// Publishes `/diagnostics` at `diagnostics_rate_hz`.
pub(crate) async fn diagnostics_loop(
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
