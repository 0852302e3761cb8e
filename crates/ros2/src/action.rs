//! The action protocol as `rclcpp_action` serves it, as a state machine without I/O: the goals
//! an action server knows, their statuses, their results kept for late requests, and the
//! answers to result and cancel requests. The node feeds it what arrives on the action's
//! services and what its goals do, and publishes `status` whenever a method reports a change.
//!
//! | rule (rcl_action / rclcpp_action) | here |
//! |---|---|
//! | status published on every transition | every method that changes a status returns `true` or changes; [`GoalTable::status_list`] is the array to publish |
//! | results kept after a goal ends, 15 min by default | [`GoalTable::new`]'s `retention`; [`GoalTable::handle_timeout`] drops them, [`GoalTable::poll_timeout`] says when |
//! | a result request for an unknown (or rejected, or expired) goal is answered at once with STATUS_UNKNOWN | [`GoalTable::handle_result_request`] |
//! | a result request for a running goal is answered when it ends | [`GoalTable::handle_goal_end`] returns the waiting requests |
//! | cancel by id, by stamp (every goal accepted at or before it), both, or all (zero id and stamp) | [`GoalTable::handle_cancel_request`] |
//! | cancel return codes ERROR_NONE, REJECTED, UNKNOWN_GOAL_ID, GOAL_TERMINATED | [`CancelCode`] |
//!
//! Generic over the goal id `K`, the request id `Q` and the result `R`, so that it is tested
//! without DDS; time is passed in (`Instant`), so that it is tested on virtual time.

use std::collections::BTreeMap;
use std::time::Duration;

use tokio::time::Instant;

/// `action_msgs/GoalStatus` values.
pub mod status {
    /// Unknown (also: rejected, expired).
    pub const UNKNOWN: i8 = 0;
    /// Accepted, not executing yet.
    pub const ACCEPTED: i8 = 1;
    /// Executing.
    pub const EXECUTING: i8 = 2;
    /// A cancel was accepted; the goal is stopping.
    pub const CANCELING: i8 = 3;
    /// Ended: succeeded.
    pub const SUCCEEDED: i8 = 4;
    /// Ended: cancelled.
    pub const CANCELED: i8 = 5;
    /// Ended: aborted.
    pub const ABORTED: i8 = 6;

    /// A terminal status.
    pub fn is_terminal(s: i8) -> bool {
        s >= SUCCEEDED
    }
}

/// `action_msgs/CancelGoal` return codes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CancelCode {
    /// One or more goals are now CANCELING.
    ErrorNone = 0,
    /// Nothing to cancel (no goal matched, or the server refused).
    Rejected = 1,
    /// The goal id names no goal the server knows.
    UnknownGoalId = 2,
    /// The goal has already ended.
    GoalTerminated = 3,
}

/// The default time results are kept after their goal ended (rcl's default).
pub const DEFAULT_RESULT_RETENTION: Duration = Duration::from_secs(15 * 60);

#[derive(Debug, Clone)]
struct Entry<Q, R> {
    status: i8,
    accepted_ns: i64,
    result: Option<R>,
    waiting: Vec<Q>,
    expires: Option<Instant>,
}

/// A reply to a result request: the request, the goal's status, the result.
pub type ResultReply<Q, R> = (Q, i8, R);

/// The goals of one action server; see the [module documentation](self).
#[derive(Debug, Clone)]
pub struct GoalTable<K, Q, R> {
    goals: BTreeMap<K, Entry<Q, R>>,
    retention: Duration,
    unknown_result: R,
}

impl<K: Ord + Copy, Q, R: Clone> GoalTable<K, Q, R> {
    /// A table keeping results for `retention` after their goal ends; `unknown_result` is the
    /// result sent with STATUS_UNKNOWN.
    pub fn new(retention: Duration, unknown_result: R) -> GoalTable<K, Q, R> {
        GoalTable {
            goals: BTreeMap::new(),
            retention,
            unknown_result,
        }
    }

    /// A goal was accepted at `accepted_ns` (nanoseconds since the epoch) and executes at
    /// once. `false` (nothing changed) when the id is already known: reject the goal.
    pub fn handle_goal_accepted(&mut self, id: K, accepted_ns: i64) -> bool {
        if self.goals.contains_key(&id) {
            return false;
        }
        self.goals.insert(
            id,
            Entry {
                status: status::EXECUTING,
                accepted_ns,
                result: None,
                waiting: Vec::new(),
                expires: None,
            },
        );
        true
    }

    /// `true` when `id` names a goal the table knows (running or kept).
    pub fn contains(&self, id: &K) -> bool {
        self.goals.contains_key(id)
    }

    /// The goal's status ([`status::UNKNOWN`] when unknown).
    pub fn status_of(&self, id: &K) -> i8 {
        self.goals.get(id).map_or(status::UNKNOWN, |e| e.status)
    }

    /// A result request: answered now (unknown goal: STATUS_UNKNOWN; ended goal: its status
    /// and result) or kept until the goal ends (`None`).
    pub fn handle_result_request(&mut self, request: Q, id: K) -> Option<ResultReply<Q, R>> {
        match self.goals.get_mut(&id) {
            None => Some((request, status::UNKNOWN, self.unknown_result.clone())),
            Some(e) => match &e.result {
                Some(r) => Some((request, e.status, r.clone())),
                None => {
                    e.waiting.push(request);
                    None
                }
            },
        }
    }

    /// A cancel request for goal `id` (`None`: the zero id) and `stamp_ns` (0: the zero
    /// stamp). Running goals it names become CANCELING; returns the code and the goals
    /// (id, accepted stamp) now canceling — the caller stops them and publishes the status.
    pub fn handle_cancel_request(
        &mut self,
        id: Option<K>,
        stamp_ns: i64,
    ) -> (CancelCode, Vec<(K, i64)>) {
        let mut canceling = Vec::new();
        for (k, e) in self.goals.iter_mut() {
            let by_id = id.as_ref() == Some(k);
            let by_stamp = stamp_ns != 0 && e.accepted_ns <= stamp_ns;
            let all = id.is_none() && stamp_ns == 0;
            if (by_id || by_stamp || all)
                && matches!(e.status, status::ACCEPTED | status::EXECUTING)
            {
                e.status = status::CANCELING;
                canceling.push((*k, e.accepted_ns));
            }
        }
        if !canceling.is_empty() {
            return (CancelCode::ErrorNone, canceling);
        }
        let code = match id.map(|k| self.goals.get(&k).map(|e| e.status)) {
            Some(None) => CancelCode::UnknownGoalId,
            Some(Some(s)) if status::is_terminal(s) => CancelCode::GoalTerminated,
            _ => CancelCode::Rejected,
        };
        (code, canceling)
    }

    /// The goal ended with `end` (a terminal status) and `result` at `now`: the result is kept
    /// until `now + retention`; returns the replies to the requests waiting for it.
    pub fn handle_goal_end(
        &mut self,
        id: K,
        end: i8,
        result: R,
        now: Instant,
    ) -> Vec<ResultReply<Q, R>> {
        let Some(e) = self.goals.get_mut(&id) else {
            return Vec::new();
        };
        e.status = end;
        e.expires = Some(now + self.retention);
        let replies = e
            .waiting
            .drain(..)
            .map(|q| (q, end, result.clone()))
            .collect();
        e.result = Some(result);
        replies
    }

    /// Drops the results kept longer than the retention. `true` when a goal was dropped (the
    /// status array changed).
    pub fn handle_timeout(&mut self, now: Instant) -> bool {
        let before = self.goals.len();
        self.goals.retain(|_, e| e.expires.is_none_or(|t| t > now));
        self.goals.len() != before
    }

    /// When the next result expires.
    pub fn poll_timeout(&self) -> Option<Instant> {
        self.goals.values().filter_map(|e| e.expires).min()
    }

    /// Every known goal: (id, accepted stamp, status), for the status topic.
    pub fn status_list(&self) -> Vec<(K, i64, i8)> {
        self.goals
            .iter()
            .map(|(k, e)| (*k, e.accepted_ns, e.status))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    type Table = GoalTable<u8, &'static str, String>;

    fn table() -> Table {
        GoalTable::new(Duration::from_secs(900), String::new())
    }

    #[test]
    fn result_requests_for_unknown_goals_are_answered_at_once_with_status_unknown() {
        let mut t = table();
        assert_eq!(
            t.handle_result_request("q1", 7),
            Some(("q1", status::UNKNOWN, String::new()))
        );
    }

    #[test]
    fn results_wait_for_the_end_and_stay_for_the_retention() {
        let t0 = Instant::now();
        let mut t = table();
        assert!(t.handle_goal_accepted(1, 100));
        assert!(!t.handle_goal_accepted(1, 200), "a duplicate id is refused");
        assert_eq!(t.handle_result_request("early", 1), None);
        let replies = t.handle_goal_end(1, status::SUCCEEDED, "done".into(), t0);
        assert_eq!(
            replies,
            vec![("early", status::SUCCEEDED, "done".to_string())]
        );
        // A late request, 14 minutes on.
        assert!(!t.handle_timeout(t0 + Duration::from_secs(14 * 60)));
        assert_eq!(
            t.handle_result_request("late", 1),
            Some(("late", status::SUCCEEDED, "done".to_string()))
        );
        assert_eq!(t.poll_timeout(), Some(t0 + Duration::from_secs(900)));
        assert!(t.handle_timeout(t0 + Duration::from_secs(900)));
        assert_eq!(
            t.handle_result_request("expired", 1).map(|r| r.1),
            Some(status::UNKNOWN)
        );
        assert!(t.status_list().is_empty());
    }

    #[test]
    fn cancel_codes_follow_rcl_action() {
        let t0 = Instant::now();
        let mut t = table();
        t.handle_goal_accepted(1, 100);
        t.handle_goal_accepted(2, 200);
        t.handle_goal_end(2, status::ABORTED, "x".into(), t0);
        assert_eq!(
            t.handle_cancel_request(Some(9), 0),
            (CancelCode::UnknownGoalId, vec![])
        );
        assert_eq!(
            t.handle_cancel_request(Some(2), 0),
            (CancelCode::GoalTerminated, vec![])
        );
        assert_eq!(
            t.handle_cancel_request(Some(1), 0),
            (CancelCode::ErrorNone, vec![(1, 100)])
        );
        assert_eq!(t.status_of(&1), status::CANCELING);
        // Already canceling: nothing more to cancel.
        assert_eq!(t.handle_cancel_request(Some(1), 0).0, CancelCode::Rejected);
    }

    #[test]
    fn cancel_all_by_zero_id_and_stamp_and_by_stamp() {
        let mut t = table();
        for (k, ns) in [(1, 100), (2, 200), (3, 300)] {
            t.handle_goal_accepted(k, ns);
        }
        assert_eq!(
            t.handle_cancel_request(None, 200),
            (CancelCode::ErrorNone, vec![(1, 100), (2, 200)])
        );
        assert_eq!(
            t.handle_cancel_request(None, 0),
            (CancelCode::ErrorNone, vec![(3, 300)])
        );
        assert_eq!(t.handle_cancel_request(None, 0).0, CancelCode::Rejected);
        let statuses: Vec<i8> = t.status_list().iter().map(|s| s.2).collect();
        assert_eq!(statuses, vec![status::CANCELING; 3]);
    }
}
