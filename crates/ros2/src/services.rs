//! The node's services: `~/start`, `~/stop`, `~/cancel` (`std_srvs/srv/Trigger`) and
//! `~/set_speed` (`fs020n_msgs/srv/SetSpeed`).

use ros2_client::dds::rustdds::DomainParticipant;
use ros2_client::log::LogLevel;

use crate::error::Ros2Error;
use crate::msg::{SetSpeedRequest, SetSpeedResponse, TriggerRequest, TriggerResponse};
use crate::replies::when_reader_matched;
use crate::shared::{lock, Shared};
use crate::source::Action;

/// A service server of the node.
pub(crate) type Server<Req, Resp> = ros2_client::Server<Req, Resp>;

/// A service's server and the DDS topic its replies go on (`rr/…Reply`: a reply waits for a
/// reader of it, [`crate::reply_gate`]).
pub(crate) struct Service<Req: ros2_client::Message, Resp: ros2_client::Message> {
    pub(crate) server: Server<Req, Resp>,
    pub(crate) reply_topic: String,
}

/// Which `std_srvs/srv/Trigger` service.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Trigger {
    /// `~/start`: command 1, the re-arm.
    Start,
    /// `~/stop`: command 2.
    Stop,
    /// `~/cancel`: commands 5 and 2.
    Cancel,
}

/// Answers the Trigger service `which`.
pub(crate) async fn trigger_loop(
    shared: &Shared,
    participant: &DomainParticipant,
    service: &Service<TriggerRequest, TriggerResponse>,
    which: Trigger,
) -> Result<(), Ros2Error> {
    loop {
        let (id, _req) = match service.server.async_receive_request().await {
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
                                lock(&shared.motion).handle_started();
                                Ok("the motion program is running (command 1); goals may start it \
                                again after the node's own cancels until the next fault"
                                .to_owned())
                            }),
                        },
                        Trigger::Stop => {
                            lock(&shared.motion).handle_operator_stop("~/stop");
                            robot.stop_program().await.map(|_| {
                                Ok(
                                    "the robot stopped and the motion program ended (command 2); \
                                ~/start runs it again"
                                        .to_owned(),
                                )
                            })
                        }
                        Trigger::Cancel => {
                            lock(&shared.motion).handle_operator_stop("~/cancel");
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
        let response =
            when_reader_matched(shared, participant, &id, &service.reply_topic, response).await;
        if let Err(e) = service.server.async_send_response(id, response).await {
            tracing::warn!("{which:?} response not sent: {e:?}");
        }
    }
}

/// Answers `~/set_speed`.
pub(crate) async fn speed_loop(
    shared: &Shared,
    participant: &DomainParticipant,
    service: &Service<SetSpeedRequest, SetSpeedResponse>,
) -> Result<(), Ros2Error> {
    loop {
        let (id, req) = match service.server.async_receive_request().await {
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
        let response =
            when_reader_matched(shared, participant, &id, &service.reply_topic, response).await;
        if let Err(e) = service.server.async_send_response(id, response).await {
            tracing::warn!("set_speed response not sent: {e:?}");
        }
    }
}
