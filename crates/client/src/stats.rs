//! Round-trip statistics and counters.

use std::collections::VecDeque;
use std::time::Duration;

use serde::Serialize;

/// Round trips kept for percentiles.
pub const RTT_WINDOW: usize = 4096;

/// Round-trip time figures over the session(s) of a [`Robot`](crate::Robot).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct RttStats {
    /// Round trips measured (all of them).
    pub count: u64,
    /// Fastest, over all round trips.
    pub min: Duration,
    /// Mean, over all round trips.
    pub mean: Duration,
    /// 99th percentile, over the last [`RTT_WINDOW`] round trips.
    pub p99: Duration,
    /// Slowest, over all round trips.
    pub max: Duration,
}

/// Diagnostics of a [`Robot`](crate::Robot), kept across reconnects: read with
/// [`Robot::stats`](crate::Robot::stats).
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct Stats {
    /// Requests written.
    pub requests: u64,
    /// Replies received.
    pub replies: u64,
    /// Of the requests, keep-alive polls sent by the session task.
    pub keepalive_polls: u64,
    /// Replies slower than `ClientConfig::late_reply_after`.
    pub late_replies: u64,
    /// Successful [`Robot::reconnect`](crate::Robot::reconnect) calls.
    pub reconnects: u64,
    /// Links lost (timeouts, resets, end of stream, undecodable replies).
    pub links_lost: u64,
    /// Requests refused by the client's checks before sending.
    pub refused_before_sending: u64,
    /// Stream samples sent (commands 6/7 by [`Robot::stream`](crate::Robot::stream)).
    pub stream_samples: u64,
    /// Stream cycles that started more than one period late.
    pub stream_underruns: u64,
    /// Stream replies slower than the stream period.
    pub stream_late_replies: u64,
    /// Lines that could not be written to the recording.
    pub record_errors: u64,
    /// The step of TIMER(1) in the latest reply ([`fs020n_proto::Timer::step_s`]): the
    /// accuracy of the session's clock and of command 7's time stamps. TIMER(1) is a 32-bit
    /// AS real, so the step grows with the session's age; above the wire's 1 ms
    /// ([`fs020n_proto::TIMER_WIRE_STEP_S`]) the age costs streaming accuracy, and a reconnect
    /// starts a new session. `None` before a reply or when TIMER(1) overflowed.
    pub timer_step_s: Option<f64>,
    /// Round-trip times.
    pub rtt: RttStats,
}

#[derive(Debug, Default)]
pub(crate) struct StatsInner {
    pub(crate) stats: Stats,
    sum_ns: u128,
    window: VecDeque<Duration>,
}

impl StatsInner {
    /// Notes the TIMER(1) of a reply (its step: [`Stats::timer_step_s`]); a coarse one is
    /// logged once when it first costs streaming accuracy.
    pub(crate) fn record_timer(&mut self, timer: fs020n_proto::Timer) {
        let step = timer.step_s();
        let was_fine = self
            .stats
            .timer_step_s
            .is_none_or(|s| s <= fs020n_proto::TIMER_WIRE_STEP_S);
        if let Some(s) = step.filter(|s| *s > fs020n_proto::TIMER_WIRE_STEP_S) {
            if was_fine {
                tracing::warn!(
                    step_ms = s * 1e3,
                    "the session is old: TIMER(1) and command 7's time stamps step by {:.1} ms \
                     (reconnect to start a new session)",
                    s * 1e3
                );
            }
        }
        self.stats.timer_step_s = step;
    }

    pub(crate) fn record_rtt(&mut self, rtt: Duration, late: bool) {
        let r = &mut self.stats.rtt;
        if r.count == 0 || rtt < r.min {
            r.min = rtt;
        }
        if rtt > r.max {
            r.max = rtt;
        }
        r.count += 1;
        self.sum_ns += rtt.as_nanos();
        if self.window.len() == RTT_WINDOW {
            self.window.pop_front();
        }
        self.window.push_back(rtt);
        self.stats.replies += 1;
        if late {
            self.stats.late_replies += 1;
        }
    }

    pub(crate) fn snapshot(&self) -> Stats {
        let mut s = self.stats.clone();
        if s.rtt.count > 0 {
            let mean = self.sum_ns / u128::from(s.rtt.count);
            s.rtt.mean = Duration::from_nanos(u64::try_from(mean).unwrap_or(u64::MAX));
            let mut v: Vec<Duration> = self.window.iter().copied().collect();
            v.sort_unstable();
            // Nearest-rank percentile.
            let rank = ((v.len() as f64) * 0.99).ceil() as usize;
            s.rtt.p99 = v[rank.clamp(1, v.len()) - 1];
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_and_mean() {
        let mut s = StatsInner::default();
        for ms in 1..=100u64 {
            s.record_rtt(Duration::from_millis(ms), ms > 95);
        }
        let st = s.snapshot();
        assert_eq!(st.rtt.count, 100);
        assert_eq!(st.rtt.min, Duration::from_millis(1));
        assert_eq!(st.rtt.max, Duration::from_millis(100));
        assert_eq!(st.rtt.p99, Duration::from_millis(99));
        assert_eq!(st.rtt.mean, Duration::from_micros(50_500));
        assert_eq!(st.late_replies, 5);
        assert_eq!(st.replies, 100);
        assert_eq!(StatsInner::default().snapshot().rtt, RttStats::default());
    }
}
