//! Reply plumbing: the action's statuses, results and replies, and the services' replies, each
//! sent once the requester's reply reader is known ([`crate::reply_gate`]).

use std::time::Duration;

use ros2_client::action::GetResultResponse;
use ros2_client::action::SendGoalResponse;
use ros2_client::action_msgs::{
    CancelGoalRequest, CancelGoalResponse, GoalId, GoalInfo, GoalStatus, GoalStatusArray,
    GoalStatusEnum,
};
use ros2_client::builtin_interfaces::Time as RosTime;
use ros2_client::dds::rustdds::DomainParticipant;
use ros2_client::service::request_id::RmwRequestId;

use crate::action::{status, GoalTable};
use crate::config::ServiceMapping;
use crate::msg::{
    FollowJointTrajectoryFeedback, FollowJointTrajectoryGoal, FollowJointTrajectoryResult,
};
use crate::reply_gate::{Awaited, KnownReader, Released, ReplyGate};
use crate::shared::Shared;

/// The `FollowJointTrajectory` action server.
pub(crate) type ActionServer = ros2_client::action::ActionServer<
    FollowJointTrajectoryGoal,
    FollowJointTrajectoryResult,
    FollowJointTrajectoryFeedback,
>;

/// The action's goals: their statuses, results and the result requests waiting for them.
pub(crate) type Goals = GoalTable<GoalId, RmwRequestId, FollowJointTrajectoryResult>;

/// How often the action's services are read, and a held service reply looks for its reader
/// (they are polled: a few milliseconds of latency).
pub(crate) const ACTION_POLL: Duration = Duration::from_millis(5);

pub(crate) fn status_enum(s: i8) -> GoalStatusEnum {
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
pub(crate) fn publish_statuses(server: &ActionServer, goals: &Goals) {
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

pub(crate) fn send_results(
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
pub(crate) enum ActionReply {
    /// To a `send_goal` request.
    Goal(RmwRequestId, SendGoalResponse),
    /// To a `cancel_goal` request.
    Cancel(RmwRequestId, CancelGoalResponse),
    /// To a `get_result` request.
    Result(RmwRequestId, GetResultResponse<FollowJointTrajectoryResult>),
}

impl ActionReply {
    /// The reader this reply waits for: its request's identity under the node's mapping, on
    /// the reply topic of the service it answers.
    fn awaited(&self, mapping: ServiceMapping, topics: &ActionReplyTopics) -> Awaited {
        let (id, topic) = match self {
            ActionReply::Goal(id, _) => (id, &topics.send_goal),
            ActionReply::Cancel(id, _) => (id, &topics.cancel_goal),
            ActionReply::Result(id, _) => (id, &topics.get_result),
        };
        Awaited::for_request(mapping, &id.writer_gid.to_bytes16(), topic)
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

/// The DDS reply topics of the action's three services (`rr/<action>/_action/send_goalReply`…).
#[derive(Debug, Clone)]
pub(crate) struct ActionReplyTopics {
    pub(crate) send_goal: String,
    pub(crate) cancel_goal: String,
    pub(crate) get_result: String,
}

/// The action's replies, each sent once the requester's reply reader is known
/// ([`crate::reply_gate`]). ros2-client keeps its servers' reply writers to itself, so the
/// readers the participant has discovered stand for the readers those writers matched.
pub(crate) struct ActionReplies<'a> {
    server: &'a ActionServer,
    participant: DomainParticipant,
    mapping: ServiceMapping,
    topics: ActionReplyTopics,
    gate: ReplyGate<ActionReply>,
}

impl<'a> ActionReplies<'a> {
    /// The replies of `server`, whose requests come under the node's service mapping and whose
    /// replies go on `topics`.
    pub(crate) fn new(
        shared: &Shared,
        server: &'a ActionServer,
        participant: DomainParticipant,
        topics: ActionReplyTopics,
    ) -> ActionReplies<'a> {
        ActionReplies {
            server,
            participant,
            mapping: shared.config.dds.service_mapping,
            topics,
            gate: ReplyGate::new(reader_wait(shared)),
        }
    }

    /// The action server.
    pub(crate) fn server(&self) -> &'a ActionServer {
        self.server
    }

    /// Sends `reply` now, or holds it until its reader is known.
    pub(crate) fn send(&mut self, reply: ActionReply) {
        let awaited = reply.awaited(self.mapping, &self.topics);
        let known = known_readers(&self.participant);
        let now = tokio::time::Instant::now();
        if let Some(reply) = self.gate.handle_reply(awaited, reply, &known, now) {
            reply.send(self.server);
        }
    }

    /// Sends the held replies whose reader is known now, or that waited long enough.
    pub(crate) fn poll(&mut self) {
        if self.gate.is_empty() {
            return;
        }
        let known = known_readers(&self.participant);
        let now = tokio::time::Instant::now();
        for (reply, why) in self.gate.poll_released(&known, now) {
            if why == Released::WaitedOut {
                warn_waited_out(self.gate.wait());
            }
            reply.send(self.server);
        }
    }
}

/// Gives `reply` back once the reader the request `id` waits for is discovered: the reply
/// reader it names, or a reader of `reply_topic` in its participant ([`Awaited::for_request`]),
/// as [`ActionReplies`] does for the action's replies.
pub(crate) async fn when_reader_matched<R>(
    shared: &Shared,
    participant: &DomainParticipant,
    id: &RmwRequestId,
    reply_topic: &str,
    reply: R,
) -> R {
    let mut gate = ReplyGate::new(reader_wait(shared));
    let mapping = shared.config.dds.service_mapping;
    let awaited = Awaited::for_request(mapping, &id.writer_gid.to_bytes16(), reply_topic);
    let now = tokio::time::Instant::now();
    if let Some(reply) = gate.handle_reply(awaited, reply, &known_readers(participant), now) {
        return reply;
    }
    loop {
        tokio::time::sleep(ACTION_POLL).await;
        let now = tokio::time::Instant::now();
        if let Some((reply, why)) = gate.poll_released(&known_readers(participant), now).pop() {
            if why == Released::WaitedOut {
                warn_waited_out(gate.wait());
            }
            return reply;
        }
    }
}

fn warn_waited_out(wait: Duration) {
    tracing::warn!(
        "the reply reader a request waits for was not discovered within {wait:?}: replying anyway"
    );
}

/// How long a reply waits for the reply reader its request named.
fn reader_wait(shared: &Shared) -> Duration {
    Duration::from_secs_f64(shared.config.reply_reader_wait_s)
}

/// The readers `participant` has discovered, with their topics.
fn known_readers(participant: &DomainParticipant) -> Vec<KnownReader> {
    participant
        .discovered_readers()
        .iter()
        .map(|r| KnownReader {
            guid: r.reader_proxy.remote_reader_guid.to_bytes(),
            topic: r.subscription_topic_data.topic_name().clone(),
        })
        .collect()
}

/// The goal id and stamp of a cancel request (ros2-client keeps the fields to itself: read
/// them back through its serde representation).
pub(crate) fn cancel_fields(request: &CancelGoalRequest) -> Option<(GoalId, RosTime)> {
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
