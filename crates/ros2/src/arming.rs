//! When a goal may start the motion program by itself: the node's re-arm policy, as a state
//! machine without I/O (statuses and the node's own actions in, a decision out).
//!
//! A goal is an explicit request for motion, so after the node itself ended the program — a
//! cancel of a goal, a goal preempted by a newer one, a path tolerance the node enforced (each
//! brakes with commands 5 and 2, the client library's sure stop) — the next goal starts it again
//! (command 1), as a `joint_trajectory_controller` accepts the next goal after a cancel.
//!
//! A **fault** revokes that: a status with any blocker other than "program not running"
//! (controller error, E-stop, HOLD, TEACH, TEACH LOCK, motor power off), a lost link, the
//! program ended by anyone but the node (`~/stop`, `~/cancel`, another client, the controller),
//! or a goal that ended because the robot stopped it. From then on no goal starts the program:
//! `~/start` (after the cause is cleared) re-arms. `auto_start` only makes the node armed at its
//! start; faults revoke it all the same.
//!
//! | input | method |
//! |---|---|
//! | every status the node sees | [`Arming::handle_status`] |
//! | the link lost, no session | [`Arming::handle_link_lost`] |
//! | a goal starts executing / ends | [`Arming::handle_goal_started`], [`Arming::handle_goal_ended`] |
//! | `~/start` succeeded, the node started the program for a goal | [`Arming::handle_started`] |
//! | `~/stop`, `~/cancel` | [`Arming::handle_operator_stop`] |
//! | may a goal start the program? | [`Arming::may_start_for_goal`] |

use fs020n_client::{blockers, Blocker};
use fs020n_proto::Status;
use tokio::time::Instant;

/// How an executed goal ended, for the policy.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum GoalStop {
    /// The program still runs (success, a goal tolerance missed, a refusal before moving).
    ProgramRunning,
    /// The node ended the program itself: a cancel, a preemption, a path tolerance.
    ByTheNode,
    /// The robot, the link or someone else stopped it; the text says what (a fault).
    Fault(String),
}

/// The node's re-arm state; see the [module documentation](self).
#[derive(Debug, Clone)]
pub struct Arming {
    /// `None`: a goal may start the program; `Some(reason)`: `~/start` first.
    revoked: Option<String>,
    /// The program was seen running since the node last ended it (so a program that is not
    /// running any more was ended by someone else).
    running_seen: bool,
    /// Statuses received before this instant predate the node's last own stop.
    own_stop_at: Option<Instant>,
    /// The node stopped the program and it has not been seen ended yet (it finishes its brake
    /// first): statuses showing it running say nothing new.
    program_ending: bool,
    /// Faults seen so far (a goal's own stop re-arms only if none came during the goal).
    faults: u64,
    faults_at_goal_start: u64,
    goal_active: bool,
}

/// What `~/start` is, for the texts.
const START_HINT: &str =
    "call the ~/start service (std_srvs/srv/Trigger) once the cause is cleared";

impl Arming {
    /// At the node's start: armed with `auto_start`, else `~/start` is needed.
    pub fn new(auto_start: bool) -> Arming {
        Arming {
            revoked: (!auto_start).then(|| {
                "the motion program is not running: call the ~/start service \
                 (std_srvs/srv/Trigger) first, or run the node with auto_start"
                    .to_owned()
            }),
            running_seen: false,
            own_stop_at: None,
            program_ending: false,
            faults: 0,
            faults_at_goal_start: 0,
            goal_active: false,
        }
    }

    fn revoke(&mut self, reason: String) {
        self.faults += 1;
        self.revoked = Some(reason);
        self.running_seen = false;
        self.program_ending = false;
    }

    /// A status from the controller, received at `received_at`.
    pub fn handle_status(&mut self, status: &Status, received_at: Instant) {
        let faults: Vec<Blocker> = blockers(status, false);
        if !faults.is_empty() {
            let text = faults
                .iter()
                .map(|b| b.to_string())
                .collect::<Vec<_>>()
                .join("; ");
            self.revoke(format!(
                "a fault stopped the robot ({text}); no goal restarts the motion program after a \
                 fault: {START_HINT}"
            ));
            return;
        }
        if self.own_stop_at.is_some_and(|t| received_at < t) {
            // From before the node's own stop: says nothing about the program now.
            return;
        }
        if status.task_running {
            if !self.program_ending {
                self.running_seen = true;
            }
        } else if self.program_ending {
            self.program_ending = false;
        } else if self.running_seen && !self.goal_active {
            self.revoke(format!(
                "the motion program was ended by someone else (~/stop, ~/cancel, another client \
                 or the controller): {START_HINT}"
            ));
        }
    }

    /// The session is gone (or there is none).
    pub fn handle_link_lost(&mut self, why: &str) {
        if self.revoked.as_deref().is_some_and(|r| r.contains("link")) {
            return;
        }
        self.revoke(format!(
            "the link to the robot was lost ({why}): {START_HINT}"
        ));
    }

    /// A goal starts executing (the program runs).
    pub fn handle_goal_started(&mut self) {
        self.goal_active = true;
        self.running_seen = true;
        self.faults_at_goal_start = self.faults;
    }

    /// A goal ended, `at` (after its last command was answered).
    pub fn handle_goal_ended(&mut self, how: GoalStop, at: Instant) {
        self.goal_active = false;
        match how {
            GoalStop::ProgramRunning => {}
            GoalStop::ByTheNode if self.faults == self.faults_at_goal_start => {
                self.revoked = None;
                self.running_seen = false;
                self.program_ending = true;
                self.own_stop_at = Some(at);
            }
            // A fault came during the goal: it stays revoked.
            GoalStop::ByTheNode => {}
            GoalStop::Fault(what) => self.revoke(format!("{what}; {START_HINT}")),
        }
    }

    /// The program was started (`~/start`, or by the node for a goal): armed.
    pub fn handle_started(&mut self) {
        self.revoked = None;
        self.running_seen = true;
        self.program_ending = false;
    }

    /// The node stopped the program itself and it has not been seen ended yet: wait for its
    /// end before starting it again (a start sent while it finishes its brake would be
    /// answered by a program that ends a moment later).
    pub fn awaiting_program_end(&self) -> bool {
        self.revoked.is_none() && self.program_ending
    }

    /// `~/stop` or `~/cancel` ended the program: an operator's stop stays until `~/start`.
    pub fn handle_operator_stop(&mut self, service: &str) {
        self.revoked = Some(format!(
            "the motion program was ended by {service}: call the ~/start service \
             (std_srvs/srv/Trigger) to move again"
        ));
        self.running_seen = false;
        self.program_ending = false;
    }

    /// `Ok` when a goal may start the motion program; else why not, with the remedy.
    pub fn may_start_for_goal(&self) -> Result<(), String> {
        match &self.revoked {
            None => Ok(()),
            Some(reason) => Err(reason.clone()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fs020n_proto::ErrorCode;
    use std::time::Duration;

    fn running() -> Status {
        Status {
            repeat: true,
            run: true,
            power: true,
            task_running: true,
            ..Status::default()
        }
    }

    fn ended() -> Status {
        Status {
            task_running: false,
            ..running()
        }
    }

    #[test]
    fn a_cancel_by_the_node_lets_the_next_goal_start_the_program() {
        let t0 = Instant::now();
        let mut a = Arming::new(false);
        assert!(a.may_start_for_goal().unwrap_err().contains("~/start"));
        a.handle_started();
        a.handle_status(&running(), t0);
        a.handle_goal_started();
        a.handle_goal_ended(GoalStop::ByTheNode, t0 + Duration::from_millis(10));
        // A status read before the stop but handled after it changes nothing, nor does the
        // program still finishing its brake.
        a.handle_status(&running(), t0 + Duration::from_millis(5));
        assert!(a.awaiting_program_end());
        a.handle_status(&running(), t0 + Duration::from_millis(15));
        a.handle_status(&ended(), t0 + Duration::from_millis(20));
        assert!(!a.awaiting_program_end());
        assert_eq!(a.may_start_for_goal(), Ok(()));
        a.handle_status(&ended(), t0 + Duration::from_millis(30));
        assert_eq!(a.may_start_for_goal(), Ok(()));
    }

    #[test]
    fn a_fault_during_the_goal_is_not_re_armed_by_the_nodes_own_stop() {
        let t0 = Instant::now();
        let mut a = Arming::new(true);
        a.handle_goal_started();
        let mut hold = running();
        hold.run = false;
        a.handle_status(&hold, t0);
        a.handle_goal_ended(GoalStop::ByTheNode, t0 + Duration::from_millis(10));
        assert!(a.may_start_for_goal().unwrap_err().contains("HOLD"));
        // The switch back to RUN does not re-arm; ~/start does.
        a.handle_status(&ended(), t0 + Duration::from_millis(20));
        assert!(a.may_start_for_goal().is_err());
        a.handle_started();
        assert_eq!(a.may_start_for_goal(), Ok(()));
    }

    #[test]
    fn an_estop_while_idle_after_a_cancel_revokes() {
        let t0 = Instant::now();
        let mut a = Arming::new(false);
        a.handle_started();
        a.handle_goal_started();
        a.handle_goal_ended(GoalStop::ByTheNode, t0);
        assert_eq!(a.may_start_for_goal(), Ok(()));
        let mut estop = ended();
        estop.error = ErrorCode::EMERGENCY_STOP;
        estop.power = false;
        a.handle_status(&estop, t0 + Duration::from_secs(1));
        // Cleared at the pendant: still revoked.
        a.handle_status(&ended(), t0 + Duration::from_secs(2));
        let e = a.may_start_for_goal().unwrap_err();
        assert!(e.contains("fault") && e.contains("~/start"), "{e}");
    }

    #[test]
    fn a_program_ended_by_someone_else_or_a_lost_link_revokes() {
        let t0 = Instant::now();
        let mut a = Arming::new(true);
        a.handle_status(&running(), t0);
        a.handle_status(&ended(), t0 + Duration::from_millis(10));
        assert!(a.may_start_for_goal().unwrap_err().contains("someone else"));
        a.handle_started();
        a.handle_link_lost("connection reset");
        assert!(a
            .may_start_for_goal()
            .unwrap_err()
            .contains("connection reset"));
        a.handle_started();
        a.handle_operator_stop("~/stop");
        assert!(a.may_start_for_goal().unwrap_err().contains("~/stop"));
    }

    #[test]
    fn a_goal_stopped_by_the_robot_revokes_and_a_finished_goal_changes_nothing() {
        let t0 = Instant::now();
        let mut a = Arming::new(true);
        a.handle_goal_started();
        a.handle_goal_ended(GoalStop::ProgramRunning, t0);
        assert_eq!(a.may_start_for_goal(), Ok(()));
        a.handle_goal_started();
        a.handle_goal_ended(GoalStop::Fault("the robot stopped the motion".into()), t0);
        assert!(a
            .may_start_for_goal()
            .unwrap_err()
            .contains("robot stopped"));
    }
}
