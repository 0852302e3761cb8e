//! The forward position command (`~/commands`, `std_msgs/msg/Float64MultiArray`, the interface
//! of `forward_command_controller`, MoveIt Servo and teleoperation): checks each command and
//! turns it into a servo sample, without I/O.
//!
//! A command is `data` = one position per joint, radians, in the node's `joint_names` order
//! (the robot's JT1…JT6), as `forward_command_controller` reads it for its `joints`. It is
//! refused, with the reason, and never sent when:
//!
//! * it has not exactly one value per joint;
//! * a value is not finite (NaN, infinity);
//! * a joint is outside the model's range.
//!
//! An accepted command becomes a [`ServoSample`] with **zero velocity and acceleration**: a
//! position interface, as `forward_command_controller` drives one. The controller never
//! extrapolates a sample past the commanded position, so when commands stop the arm stops at
//! the last one (an estimate from arrival times would extrapolate the jitter of DDS delivery:
//! two commands arriving together read as a fast motion, and the arm would run on past the
//! last command until the watchdog). The sample a fence checks
//! ([`ForwardCommands::stream_sample`]) is the one the servo sends. The client's servo then
//! checks it again (the window the controller extrapolates over, the first sample near the
//! current joints, no jump between samples) and its watchdog stops the arm when commands stop
//! ([`fs020n_client::ServoHandle`]). A source that wants its latency compensated sends
//! `~/joint_trajectory` with velocities instead.
//!
//! | input | method |
//! |---|---|
//! | a command arrived | [`ForwardCommands::handle_command`] |
//! | the sample for a fence | [`ForwardCommands::stream_sample`] |
//! | the servo ended: what for the re-arm policy | [`servo_end`] |

use std::time::Duration;

use fs020n_client::{ClientError, ServoOutcome, ServoSample};
use fs020n_kin::{JointsDeg, RobotModel, JOINT_COUNT};
use fs020n_proto::StreamSample;

use crate::arming::GoalStop;

/// Why a command was refused. The text names the remedy.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CommandRefusal {
    /// Not one value per joint.
    #[error("{got} values for {JOINT_COUNT} joints; send one position per joint (radians, in the order of joint_names)")]
    Length {
        /// How many values came.
        got: usize,
    },
    /// A value is NaN or infinite.
    #[error("{joint} is {value}; send finite positions in radians")]
    NotFinite {
        /// The joint's name.
        joint: String,
        /// The value.
        value: f64,
    },
    /// A joint outside the model's range.
    #[error("{joint} at {value_deg:.3} deg is outside its range [{min_deg}, {max_deg}] deg; command a position inside it")]
    OutOfRange {
        /// The joint's name.
        joint: String,
        /// The commanded position, degrees.
        value_deg: f64,
        /// Lower limit, degrees.
        min_deg: f64,
        /// Upper limit, degrees.
        max_deg: f64,
    },
}

/// The checks of the forward command input.
#[derive(Debug, Clone)]
pub struct ForwardCommands {
    model: RobotModel,
    joint_names: [String; JOINT_COUNT],
}

impl ForwardCommands {
    /// For `model`, with the node's joint names (the order of `data`).
    pub fn new(model: RobotModel, joint_names: [String; JOINT_COUNT]) -> ForwardCommands {
        ForwardCommands { model, joint_names }
    }

    /// Checks a command (`data`, radians) and returns the sample to push.
    pub fn handle_command(&self, data: &[f64]) -> Result<ServoSample, CommandRefusal> {
        if data.len() != JOINT_COUNT {
            return Err(CommandRefusal::Length { got: data.len() });
        }
        let mut q = [0.0; JOINT_COUNT];
        for (i, (v, rad)) in q.iter_mut().zip(data).enumerate() {
            if !rad.is_finite() {
                return Err(CommandRefusal::NotFinite {
                    joint: self.joint_names[i].clone(),
                    value: *rad,
                });
            }
            *v = rad.to_degrees();
        }
        let position = JointsDeg(q);
        if let Err(e) = self.model.check_limits(&position) {
            return Err(CommandRefusal::OutOfRange {
                joint: self.joint_names[e.joint - 1].clone(),
                value_deg: e.value_deg,
                min_deg: e.min_deg,
                max_deg: e.max_deg,
            });
        }
        let zero = JointsDeg([0.0; JOINT_COUNT]);
        Ok(ServoSample::new(position)
            .with_velocity(zero)
            .with_acceleration(zero))
    }

    /// The command-7 sample the servo sends for `sample` (its time stamp aside), for a fence's
    /// check.
    pub fn stream_sample(sample: &ServoSample, lookahead_passes: f64) -> StreamSample {
        let zero = JointsDeg([0.0; JOINT_COUNT]);
        StreamSample {
            t0_s: 0.0,
            lookahead_passes,
            position: sample.position,
            velocity: sample.velocity.unwrap_or(zero),
            acceleration: sample.acceleration.unwrap_or(zero),
        }
    }
}

/// What the end of a servo means for the re-arm policy ([`crate::arming`]), and the text for
/// `/rosout` and `/diagnostics`: the watchdog and the node's own stop are the node's stops (the
/// next command starts the program again); a stop of the robot by anyone else (`Cancelled`), a
/// fault or a lost link (`Err`) require `~/start`.
pub fn servo_end(
    ended: Result<ServoOutcome, &ClientError>,
    watchdog: Duration,
) -> (GoalStop, String) {
    match ended {
        Ok(ServoOutcome::Watchdog) => (
            GoalStop::ByTheNode,
            format!(
                "~/commands stopped for {watchdog:?}: the watchdog braked the arm and ended the \
                 motion program (commands 5 and 2); the next command starts it again"
            ),
        ),
        Ok(ServoOutcome::Stopped) => (
            GoalStop::ByTheNode,
            "the servo of ~/commands was stopped for a trajectory (commands 5 and 2)".into(),
        ),
        Ok(ServoOutcome::Cancelled) => {
            let what = "the servo of ~/commands was cancelled by a stop of the robot (~/stop, \
                        ~/cancel or another client)";
            (GoalStop::Fault(what.into()), what.into())
        }
        Err(e) => {
            let what = format!("the servo of ~/commands ended: {e}");
            (GoalStop::Fault(what.clone()), what)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::arming::Arming;
    use fs020n_client::LinkError;
    use tokio::time::Instant;

    #[test]
    fn after_the_watchdog_the_next_command_may_start_the_program() {
        let mut arming = Arming::new(false);
        arming.handle_started();
        arming.handle_goal_started();
        let (how, text) = servo_end(Ok(ServoOutcome::Watchdog), Duration::from_millis(200));
        assert_eq!(how, GoalStop::ByTheNode);
        assert!(
            text.contains("200ms") && text.contains("watchdog"),
            "{text}"
        );
        arming.handle_goal_ended(how, Instant::now());
        assert_eq!(arming.may_start_for_goal(), Ok(()));
    }

    #[test]
    fn after_a_fault_or_a_stop_by_someone_else_commands_need_start() {
        let lost = ClientError::LinkLost(LinkError::SessionEnded);
        for ended in [Ok(ServoOutcome::Cancelled), Err(&lost)] {
            let mut arming = Arming::new(false);
            arming.handle_started();
            arming.handle_goal_started();
            let (how, _) = servo_end(ended, Duration::from_millis(200));
            assert!(matches!(how, GoalStop::Fault(_)), "{how:?}");
            arming.handle_goal_ended(how, Instant::now());
            let refusal = arming.may_start_for_goal().unwrap_err();
            assert!(refusal.contains("~/start"), "{refusal}");
        }
    }

    fn commands() -> ForwardCommands {
        let names = std::array::from_fn(|i| format!("joint_{}", i + 1));
        ForwardCommands::new(RobotModel::fs020n(), names)
    }

    fn home_rad() -> Vec<f64> {
        RobotModel::fs020n()
            .home
            .0
            .iter()
            .map(|d| d.to_radians())
            .collect()
    }

    #[test]
    fn a_command_becomes_a_position_sample_in_degrees_without_velocity() {
        let mut q = home_rad();
        q[0] = 0.5;
        let s = commands().handle_command(&q).unwrap();
        let home = RobotModel::fs020n().home;
        assert!((s.position[0] - 0.5f64.to_degrees()).abs() < 1e-9);
        for i in 1..JOINT_COUNT {
            assert!((s.position[i] - home[i]).abs() < 1e-9);
        }
        assert_eq!(s.velocity, Some(JointsDeg([0.0; JOINT_COUNT])));
        assert_eq!(s.acceleration, Some(JointsDeg([0.0; JOINT_COUNT])));
    }

    #[test]
    fn a_wrong_length_is_refused() {
        let c = commands();
        assert_eq!(
            c.handle_command(&[0.0; 5]),
            Err(CommandRefusal::Length { got: 5 })
        );
        assert!(c.handle_command(&[0.0; 7]).is_err());
        assert!(c.handle_command(&[]).is_err());
    }

    #[test]
    fn a_nan_or_infinity_is_refused_naming_the_joint() {
        let c = commands();
        let mut q = home_rad();
        q[3] = f64::NAN;
        let e = c.handle_command(&q).unwrap_err();
        assert!(e.to_string().starts_with("joint_4 is NaN"), "{e}");
        q[3] = f64::NEG_INFINITY;
        assert!(matches!(
            c.handle_command(&q),
            Err(CommandRefusal::NotFinite { .. })
        ));
    }

    #[test]
    fn a_joint_out_of_range_is_refused_naming_it() {
        let c = commands();
        let mut q = home_rad();
        q[0] = 3.5; // 200 deg; JT1 is ±180
        let e = c.handle_command(&q).unwrap_err();
        assert!(
            matches!(&e, CommandRefusal::OutOfRange { joint, .. } if joint == "joint_1"),
            "{e}"
        );
        assert!(e.to_string().contains("outside its range"), "{e}");
    }

    #[test]
    fn the_stream_sample_is_what_the_servo_sends() {
        let s = commands().handle_command(&home_rad()).unwrap();
        let m = ForwardCommands::stream_sample(&s, 2.0);
        assert_eq!(m.position, s.position);
        assert_eq!(m.velocity, JointsDeg([0.0; JOINT_COUNT]));
        assert_eq!(m.acceleration, JointsDeg([0.0; JOINT_COUNT]));
        assert_eq!(m.lookahead_passes, 2.0);
    }
}
