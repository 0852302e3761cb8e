//! The one owner of the arm's motion in the node, without I/O: what runs (a trajectory from a
//! goal or from `~/joint_trajectory`, or the servo of `~/commands`), whether it is braking, and
//! the re-arm policy ([`Arming`]) — and every decision about them, as
//! `joint_trajectory_controller` keeps its active goal and trajectory apart from the
//! middleware. The node does the I/O (the robot, DDS) and tells the owner what happened; the
//! owner says what to do next. Time is passed in.
//!
//! | input | method | decision |
//! |---|---|---|
//! | a new trajectory (goal or topic) | [`MotionOwner::handle_trajectory_request`] | [`Admission`]: plan it, or check it first and replace what runs |
//! | a fresh status before moving | [`MotionOwner::handle_readiness`] | [`Readiness`]: move, start the program, poll again, or refuse with the remedy |
//! | the trajectory started / ended | [`MotionOwner::handle_trajectory_started`], [`MotionOwner::handle_trajectory_ended`] | its goal, for the result |
//! | cancel requests (the goals the action protocol cancels) | [`MotionOwner::handle_cancel_request`] | brake the running trajectory or not |
//! | feedback to send | [`MotionOwner::feedback_goal`] | the goal it belongs to, none while braking |
//! | a `~/commands` message | [`MotionOwner::handle_servo_command`] | [`ServoStep`]: open the servo, push, or refuse |
//! | the servo opened / ended | [`MotionOwner::handle_servo_opened`], [`MotionOwner::handle_servo_ended`] | |
//! | every status, a lost link | [`MotionOwner::handle_status`], [`MotionOwner::handle_link_lost`] | a fault revokes the re-arm |
//! | `~/start`, `~/stop`, `~/cancel`, the node's own start of the program | [`MotionOwner::handle_started`], [`MotionOwner::handle_operator_stop`] | |
//!
//! Faults and tolerances during a trajectory are judged by [`crate::execute`] on the robot's
//! statuses; their outcome comes back here as a [`GoalStop`].

use std::time::Duration;

use fs020n_client::{blockers, Blocker};
use fs020n_proto::Status;
use tokio::time::Instant;

use crate::arming::{Arming, GoalStop};

/// How long a move waits for the program the node stopped to end before starting it again.
pub const PROGRAM_END_WAIT: Duration = Duration::from_secs(3);

/// How often the status is read again while waiting for that end.
pub const PROGRAM_END_POLL: Duration = Duration::from_millis(20);

/// What moves the arm now.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Active<Id> {
    /// Nothing.
    Idle,
    /// A trajectory: from the goal `goal` (`None`: from `~/joint_trajectory`); `braking` once
    /// its cancel was asked.
    Trajectory {
        /// Its action goal.
        goal: Option<Id>,
        /// A cancel was asked: it brakes.
        braking: bool,
    },
    /// The servo of `~/commands`.
    Servo,
}

/// How a new trajectory is admitted.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Admission<Id> {
    /// Nothing runs: check it against the robot now and plan it.
    Plan,
    /// Something runs: check the trajectory first without acting (from where the arm is);
    /// only if it passes, end the servo (`end_servo`) or preempt the running trajectory
    /// (`preempt`: its goal, `None` for a streamed one) — the arm brakes — then plan it from
    /// where the arm stopped. One that fails the check is refused and what runs goes on.
    Replace {
        /// The servo runs: end it.
        end_servo: bool,
        /// A trajectory runs: preempt it (ABORTED "preempted by a new goal").
        preempt: Option<Option<Id>>,
    },
}

/// What to do before moving, given a fresh status.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Readiness {
    /// The arm may move.
    Ready,
    /// The program is not running and the re-arm policy allows starting it: start it (command
    /// 1), then move.
    StartProgram,
    /// The program the node stopped is still finishing its brake: read the status again after
    /// [`PROGRAM_END_POLL`].
    PollAgain,
    /// Refused, with the reason and the remedy.
    Refused(String),
}

/// What to do with a `~/commands` message.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ServoStep {
    /// No servo runs: check readiness, open one, then push.
    Open,
    /// The servo runs: push the sample.
    Push,
}

/// The owner of the motion; see the [module documentation](self).
#[derive(Debug, Clone)]
pub struct MotionOwner<Id> {
    active: Active<Id>,
    arming: Arming,
    /// The node's fully qualified name, for the remedies (`/fs020n/start`).
    node: String,
}

impl<Id: Copy + Eq> MotionOwner<Id> {
    /// Idle, armed when `auto_start`; `node` is the node's fully qualified name.
    pub fn new(auto_start: bool, node: impl Into<String>) -> MotionOwner<Id> {
        MotionOwner {
            active: Active::Idle,
            arming: Arming::new(auto_start),
            node: node.into(),
        }
    }

    /// What moves the arm now.
    pub fn active(&self) -> &Active<Id> {
        &self.active
    }

    /// A new trajectory asks to run: plan it, or replace what runs once it passes the checks
    /// that need no stop (as `joint_trajectory_controller` replaces its trajectory).
    pub fn handle_trajectory_request(&self) -> Admission<Id> {
        match &self.active {
            Active::Idle => Admission::Plan,
            Active::Servo => Admission::Replace {
                end_servo: true,
                preempt: None,
            },
            Active::Trajectory { goal, .. } => Admission::Replace {
                end_servo: false,
                preempt: Some(*goal),
            },
        }
    }

    /// A status read before moving, at `now`; `waiting_since`: when this move first asked.
    /// Every status passes the re-arm policy first.
    pub fn handle_readiness(
        &mut self,
        status: &Status,
        now: Instant,
        waiting_since: Instant,
    ) -> Readiness {
        self.arming.handle_status(status, now);
        // After the node's own stop the program finishes its brake before it ends: a start
        // sent now would be answered by a program about to end.
        if self.arming.awaiting_program_end() && status.task_running {
            if now >= waiting_since + PROGRAM_END_WAIT {
                return Readiness::Refused(format!(
                    "the motion program did not end within {PROGRAM_END_WAIT:?} of the node's \
                     stop; call ~/stop, then ~/start"
                ));
            }
            return Readiness::PollAgain;
        }
        let list = blockers(status, true);
        if list.is_empty() {
            return Readiness::Ready;
        }
        if list == [Blocker::ProgramNotRunning] {
            return match self.arming.may_start_for_goal() {
                Ok(()) => Readiness::StartProgram,
                Err(reason) => Readiness::Refused(format!(
                    "the robot is not ready to move — {reason} ({})",
                    self.node
                )),
            };
        }
        let text = list
            .iter()
            .map(|b| b.to_string())
            .collect::<Vec<_>>()
            .join("; ");
        Readiness::Refused(format!(
            "the robot is not ready to move — {text}; then call the {}/start service \
             (std_srvs/srv/Trigger): no goal restarts the motion program after a fault",
            self.node
        ))
    }

    /// A trajectory started executing (`goal`: its action goal, `None` from the topic).
    pub fn handle_trajectory_started(&mut self, goal: Option<Id>) {
        self.arming.handle_goal_started();
        self.active = Active::Trajectory {
            goal,
            braking: false,
        };
    }

    /// The action protocol cancels `canceling`: `true` when the running trajectory is one of
    /// them and must brake now (once).
    pub fn handle_cancel_request(&mut self, canceling: &[Id]) -> bool {
        match &mut self.active {
            Active::Trajectory {
                goal: Some(id),
                braking,
            } if !*braking && canceling.contains(id) => {
                *braking = true;
                true
            }
            _ => false,
        }
    }

    /// The goal feedback goes to now: the running trajectory's, unless it brakes (a goal being
    /// cancelled gets no more feedback).
    pub fn feedback_goal(&self) -> Option<Id> {
        match &self.active {
            Active::Trajectory {
                goal: Some(id),
                braking: false,
            } => Some(*id),
            _ => None,
        }
    }

    /// The running trajectory ended at `at`; `program` says what became of the motion program.
    /// Returns its goal (`None` from the topic, or when none ran).
    pub fn handle_trajectory_ended(&mut self, program: GoalStop, at: Instant) -> Option<Id> {
        let Active::Trajectory { goal, .. } = self.active else {
            return None;
        };
        self.active = Active::Idle;
        self.arming.handle_goal_ended(program, at);
        goal
    }

    /// A `~/commands` message: open the servo, push to it, or refuse while a trajectory runs.
    pub fn handle_servo_command(&self) -> Result<ServoStep, String> {
        match &self.active {
            Active::Trajectory { .. } => Err("a trajectory is executing (a goal or \
                 ~/joint_trajectory); cancel it or wait for its end before sending commands"
                .into()),
            Active::Servo => Ok(ServoStep::Push),
            Active::Idle => Ok(ServoStep::Open),
        }
    }

    /// The servo opened.
    pub fn handle_servo_opened(&mut self) {
        self.arming.handle_goal_started();
        self.active = Active::Servo;
    }

    /// The servo ended at `at` (`how`: the watchdog or the node's stop, or a fault).
    pub fn handle_servo_ended(&mut self, how: GoalStop, at: Instant) {
        if self.active == Active::Servo {
            self.active = Active::Idle;
        }
        self.arming.handle_goal_ended(how, at);
    }

    /// A status from the controller, received at `received_at`.
    pub fn handle_status(&mut self, status: &Status, received_at: Instant) {
        self.arming.handle_status(status, received_at);
    }

    /// The session is gone (or there is none).
    pub fn handle_link_lost(&mut self, why: &str) {
        self.arming.handle_link_lost(why);
    }

    /// The program was started (`~/start`, or by the node before a move): armed.
    pub fn handle_started(&mut self) {
        self.arming.handle_started();
    }

    /// `~/stop` or `~/cancel` ended the program: no move starts it until `~/start`.
    pub fn handle_operator_stop(&mut self, service: &str) {
        self.arming.handle_operator_stop(service);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fs020n_proto::ErrorCode;

    type Owner = MotionOwner<u32>;

    fn running() -> Status {
        Status {
            repeat: true,
            run: true,
            power: true,
            task_running: true,
            ..Status::default()
        }
    }

    fn not_running() -> Status {
        Status {
            task_running: false,
            ..running()
        }
    }

    fn estop() -> Status {
        Status {
            error: ErrorCode::EMERGENCY_STOP,
            power: false,
            ..not_running()
        }
    }

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    /// An owner that ran `~/start` and is idle with the program running.
    fn started(t0: Instant) -> Owner {
        let mut o = Owner::new(false, "/fs020n");
        o.handle_started();
        assert_eq!(o.handle_readiness(&running(), t0, t0), Readiness::Ready);
        o
    }

    #[test]
    fn admit_a_trajectory_is_planned_when_nothing_runs() {
        let o = Owner::new(false, "/fs020n");
        assert_eq!(o.handle_trajectory_request(), Admission::Plan);
        assert_eq!(o.active(), &Active::Idle);
    }

    #[test]
    fn admit_before_start_is_refused_with_the_start_service_named() {
        let t0 = Instant::now();
        let mut o = Owner::new(false, "/arm/fs020n");
        let Readiness::Refused(why) = o.handle_readiness(&not_running(), t0, t0) else {
            panic!("refused expected");
        };
        assert!(
            why.contains("~/start") && why.contains("/arm/fs020n"),
            "{why}"
        );
        // auto_start: the first move starts the program.
        let mut o = Owner::new(true, "/fs020n");
        assert_eq!(
            o.handle_readiness(&not_running(), t0, t0),
            Readiness::StartProgram
        );
    }

    #[test]
    fn admit_a_switch_or_an_error_is_refused_and_never_starts_the_program() {
        let t0 = Instant::now();
        let mut o = Owner::new(true, "/fs020n");
        let mut hold = running();
        hold.run = false;
        let Readiness::Refused(why) = o.handle_readiness(&hold, t0, t0) else {
            panic!("refused expected");
        };
        assert!(
            why.contains("HOLD") && why.contains("/fs020n/start"),
            "{why}"
        );
        let Readiness::Refused(why) = o.handle_readiness(&estop(), t0, t0) else {
            panic!("refused expected");
        };
        assert!(why.contains("no goal restarts"), "{why}");
    }

    #[test]
    fn preempt_a_running_trajectory_is_replaced_after_the_check() {
        let t0 = Instant::now();
        let mut o = started(t0);
        o.handle_trajectory_started(Some(7));
        assert_eq!(
            o.handle_trajectory_request(),
            Admission::Replace {
                end_servo: false,
                preempt: Some(Some(7))
            }
        );
        o.handle_trajectory_ended(GoalStop::ProgramRunning, t0);
        o.handle_trajectory_started(None);
        assert_eq!(
            o.handle_trajectory_request(),
            Admission::Replace {
                end_servo: false,
                preempt: Some(None)
            }
        );
    }

    #[test]
    fn preempt_the_servo_is_ended_for_a_trajectory() {
        let t0 = Instant::now();
        let mut o = started(t0);
        assert_eq!(o.handle_servo_command(), Ok(ServoStep::Open));
        o.handle_servo_opened();
        assert_eq!(o.handle_servo_command(), Ok(ServoStep::Push));
        assert_eq!(
            o.handle_trajectory_request(),
            Admission::Replace {
                end_servo: true,
                preempt: None
            }
        );
    }

    #[test]
    fn preempted_by_the_node_the_next_trajectory_starts_the_program_once_it_ended() {
        let t0 = Instant::now();
        let mut o = started(t0);
        o.handle_trajectory_started(Some(1));
        // Preempted: the node braked (commands 5 and 2).
        assert_eq!(
            o.handle_trajectory_ended(GoalStop::ByTheNode, t0 + ms(100)),
            Some(1)
        );
        // The program still finishes its brake: poll again, then start it.
        let since = t0 + ms(110);
        assert_eq!(
            o.handle_readiness(&running(), since, since),
            Readiness::PollAgain
        );
        assert_eq!(
            o.handle_readiness(&not_running(), since + ms(40), since),
            Readiness::StartProgram
        );
    }

    #[test]
    fn preempted_a_program_that_never_ends_is_refused_after_the_wait() {
        let t0 = Instant::now();
        let mut o = started(t0);
        o.handle_trajectory_started(Some(1));
        o.handle_trajectory_ended(GoalStop::ByTheNode, t0);
        let since = t0 + ms(1);
        assert_eq!(
            o.handle_readiness(&running(), since + PROGRAM_END_WAIT - ms(1), since),
            Readiness::PollAgain
        );
        let Readiness::Refused(why) =
            o.handle_readiness(&running(), since + PROGRAM_END_WAIT, since)
        else {
            panic!("refused expected");
        };
        assert!(
            why.contains("did not end") && why.contains("~/start"),
            "{why}"
        );
    }

    #[test]
    fn cancel_brakes_the_running_goal_once_and_ends_its_feedback() {
        let t0 = Instant::now();
        let mut o = started(t0);
        o.handle_trajectory_started(Some(3));
        assert_eq!(o.feedback_goal(), Some(3));
        // Another goal's cancel: not this one.
        assert!(!o.handle_cancel_request(&[2]));
        assert_eq!(o.feedback_goal(), Some(3));
        assert!(o.handle_cancel_request(&[2, 3]));
        assert_eq!(o.feedback_goal(), None);
        // Asked again (cancel-all): it brakes already.
        assert!(!o.handle_cancel_request(&[3]));
        assert_eq!(o.handle_trajectory_ended(GoalStop::ByTheNode, t0), Some(3));
        assert_eq!(o.active(), &Active::Idle);
    }

    #[test]
    fn cancel_never_touches_a_streamed_trajectory_or_the_servo() {
        let t0 = Instant::now();
        let mut o = started(t0);
        o.handle_trajectory_started(None);
        assert!(!o.handle_cancel_request(&[0]));
        assert_eq!(o.feedback_goal(), None);
        assert_eq!(
            o.handle_trajectory_ended(GoalStop::ProgramRunning, t0),
            None
        );
        o.handle_servo_opened();
        assert!(!o.handle_cancel_request(&[0]));
        assert_eq!(
            o.handle_trajectory_ended(GoalStop::ProgramRunning, t0),
            None
        );
        assert_eq!(o.active(), &Active::Servo);
    }

    #[test]
    fn cancel_by_the_node_re_arms_the_next_goal() {
        let t0 = Instant::now();
        let mut o = started(t0);
        o.handle_trajectory_started(Some(1));
        assert!(o.handle_cancel_request(&[1]));
        o.handle_trajectory_ended(GoalStop::ByTheNode, t0 + ms(10));
        let since = t0 + ms(20);
        assert_eq!(
            o.handle_readiness(&not_running(), since, since),
            Readiness::StartProgram
        );
    }

    #[test]
    fn fault_during_a_goal_is_never_re_armed_by_a_goal() {
        let t0 = Instant::now();
        let mut o = started(t0);
        o.handle_trajectory_started(Some(1));
        o.handle_status(&estop(), t0 + ms(5));
        assert_eq!(
            o.handle_trajectory_ended(
                GoalStop::Fault("the robot stopped while moving".into()),
                t0 + ms(10)
            ),
            Some(1)
        );
        // Released, reset, power on: still no start by a goal.
        let since = t0 + ms(1000);
        let Readiness::Refused(why) = o.handle_readiness(&not_running(), since, since) else {
            panic!("refused expected");
        };
        assert!(why.contains("~/start"), "{why}");
        assert_eq!(o.handle_servo_command(), Ok(ServoStep::Open));
    }

    #[test]
    fn fault_while_idle_or_a_lost_link_revokes() {
        let t0 = Instant::now();
        let mut o = started(t0);
        o.handle_status(&estop(), t0 + ms(5));
        let since = t0 + ms(10);
        assert!(matches!(
            o.handle_readiness(&not_running(), since, since),
            Readiness::Refused(_)
        ));
        let mut o = started(t0);
        o.handle_link_lost("connection reset");
        let Readiness::Refused(why) = o.handle_readiness(&not_running(), since, since) else {
            panic!("refused expected");
        };
        assert!(why.contains("connection reset"), "{why}");
    }

    #[test]
    fn fault_of_the_servo_revokes_and_its_watchdog_re_arms() {
        let t0 = Instant::now();
        let mut o = started(t0);
        o.handle_servo_opened();
        o.handle_servo_ended(GoalStop::ByTheNode, t0 + ms(10));
        assert_eq!(o.active(), &Active::Idle);
        let since = t0 + ms(20);
        assert_eq!(
            o.handle_readiness(&not_running(), since, since),
            Readiness::StartProgram
        );
        o.handle_started();
        o.handle_servo_opened();
        o.handle_servo_ended(GoalStop::Fault("E-stop".into()), t0 + ms(30));
        assert!(matches!(
            o.handle_readiness(&not_running(), t0 + ms(40), t0 + ms(40)),
            Readiness::Refused(_)
        ));
    }

    #[test]
    fn tolerance_a_path_tolerance_the_node_enforced_re_arms_a_missed_goal_tolerance_keeps_running()
    {
        let t0 = Instant::now();
        // A path tolerance: the node braked (ByTheNode), the next goal restarts the program.
        let mut o = started(t0);
        o.handle_trajectory_started(Some(1));
        o.handle_trajectory_ended(GoalStop::ByTheNode, t0 + ms(10));
        let since = t0 + ms(20);
        assert_eq!(
            o.handle_readiness(&not_running(), since, since),
            Readiness::StartProgram
        );
        // A goal tolerance missed: the program still runs, the next goal just moves.
        let mut o = started(t0);
        o.handle_trajectory_started(Some(2));
        o.handle_trajectory_ended(GoalStop::ProgramRunning, t0 + ms(10));
        assert_eq!(
            o.handle_readiness(&running(), since, since),
            Readiness::Ready
        );
    }

    #[test]
    fn re_arm_after_an_operator_stop_only_by_start() {
        let t0 = Instant::now();
        let mut o = started(t0);
        o.handle_operator_stop("~/stop");
        let since = t0 + ms(10);
        let Readiness::Refused(why) = o.handle_readiness(&not_running(), since, since) else {
            panic!("refused expected");
        };
        assert!(why.contains("~/stop"), "{why}");
        o.handle_started();
        assert_eq!(
            o.handle_readiness(&running(), since, since),
            Readiness::Ready
        );
    }

    #[test]
    fn servo_commands_are_refused_while_a_trajectory_runs() {
        let t0 = Instant::now();
        let mut o = started(t0);
        o.handle_trajectory_started(Some(1));
        assert!(o
            .handle_servo_command()
            .unwrap_err()
            .contains("trajectory is executing"));
        o.handle_trajectory_ended(GoalStop::ProgramRunning, t0);
        assert_eq!(o.handle_servo_command(), Ok(ServoStep::Open));
    }
}
