//! Where the node gets its robot session and whom it asks before acting: the API a host
//! implements to run the node on a session it owns ([`RobotSource`], [`Action`], [`Permit`]).

use std::sync::Arc;

use fs020n_client::Robot;

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
