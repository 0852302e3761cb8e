//! Estimate of the controller's session clock (TIMER(1)) from the replies, for stamping
//! command-7 samples.
//!
//! Every reply carries TIMER(1), read by the server between receiving the request and sending
//! the reply. The best local estimate of that instant is the midpoint of the round trip
//! (`sent + rtt/2`, the "RTT/2 correction"). Pairs (local midpoint, TIMER) of recent round
//! trips are fitted with a straight line `server = offset + rate · local` by least squares,
//! using only round trips no slower than twice the fastest recent one (a slow round trip has a
//! wide, asymmetric uncertainty). `rate − 1` is the drift between the two clocks; it is bounded
//! to ±[`MAX_DRIFT`] so that a short, noisy window cannot tilt the line. With fewer than two
//! usable pairs, or pairs spanning less than [`MIN_SPAN_S`], the rate is taken as 1.

use std::collections::VecDeque;

use tokio::time::Instant;

/// Pairs kept.
pub const CLOCK_WINDOW: usize = 64;
/// Largest drift accepted from the fit (1000 ppm).
pub const MAX_DRIFT: f64 = 1e-3;
/// Shortest span of local times (s) for which the rate is fitted.
pub const MIN_SPAN_S: f64 = 0.5;

#[derive(Debug, Clone, Copy)]
struct Pair {
    local_s: f64,
    server_s: f64,
    rtt_s: f64,
}

/// The fitted line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClockFit {
    /// Server time at the estimator's local epoch, seconds.
    pub offset_s: f64,
    /// Server seconds per local second (1 + drift).
    pub rate: f64,
    /// Pairs used.
    pub pairs: usize,
    /// Root-mean-square residual of the pairs used, seconds.
    pub residual_s: f64,
}

/// Estimator of the server clock.
#[derive(Debug, Clone)]
pub struct ServerClock {
    epoch: Instant,
    pairs: VecDeque<Pair>,
    /// The fit of the current pairs, computed when first asked for.
    fit: std::cell::Cell<Option<Option<ClockFit>>>,
}

impl ServerClock {
    /// An estimator with local times counted from `epoch`.
    pub fn new(epoch: Instant) -> ServerClock {
        ServerClock {
            epoch,
            pairs: VecDeque::with_capacity(CLOCK_WINDOW),
            fit: std::cell::Cell::new(None),
        }
    }

    fn local_s(&self, t: Instant) -> f64 {
        // Times before the epoch are negative.
        if t >= self.epoch {
            t.duration_since(self.epoch).as_secs_f64()
        } else {
            -self.epoch.duration_since(t).as_secs_f64()
        }
    }

    /// Adds a round trip: request written at `sent`, reply complete at `received`, carrying
    /// TIMER(1) = `server_s`.
    pub fn add(&mut self, sent: Instant, received: Instant, server_s: f64) {
        if !server_s.is_finite() || received < sent {
            return;
        }
        let rtt_s = received.duration_since(sent).as_secs_f64();
        let local_s = self.local_s(sent) + rtt_s / 2.0;
        if self.pairs.len() == CLOCK_WINDOW {
            self.pairs.pop_front();
        }
        self.pairs.push_back(Pair {
            local_s,
            server_s,
            rtt_s,
        });
        self.fit.set(None);
    }

    fn compute(&self) -> Option<ClockFit> {
        let min_rtt = self
            .pairs
            .iter()
            .map(|p| p.rtt_s)
            .fold(f64::INFINITY, f64::min);
        let limit = 2.0 * min_rtt + 1e-4;
        let used = || self.pairs.iter().filter(move |p| p.rtt_s <= limit);
        // Each sum adds the same terms in the same order as one pass per sum would: the fit is
        // the same to the bit, in three passes over the window instead of eight.
        let (mut n, mut sum_x, mut sum_y) = (0usize, 0.0f64, 0.0f64);
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for p in used() {
            n += 1;
            sum_x += p.local_s;
            sum_y += p.server_s;
            lo = lo.min(p.local_s);
            hi = hi.max(p.local_s);
        }
        if n == 0 {
            return None;
        }
        let nf = n as f64;
        let (mx, my) = (sum_x / nf, sum_y / nf);
        let (mut sxx, mut sxy) = (0.0f64, 0.0f64);
        for p in used() {
            sxx += (p.local_s - mx).powi(2);
            sxy += (p.local_s - mx) * (p.server_s - my);
        }
        let span = hi - lo;
        let rate = if n >= 2 && span >= MIN_SPAN_S && sxx > 0.0 {
            (sxy / sxx).clamp(1.0 - MAX_DRIFT, 1.0 + MAX_DRIFT)
        } else {
            1.0
        };
        let offset_s = my - rate * mx;
        let residual_s = (used()
            .map(|p| (p.server_s - (offset_s + rate * p.local_s)).powi(2))
            .sum::<f64>()
            / nf)
            .sqrt();
        Some(ClockFit {
            offset_s,
            rate,
            pairs: n,
            residual_s,
        })
    }

    /// The current fit, once at least one reply has been seen (computed on demand: adding a
    /// pair costs nothing until the estimate is used).
    pub fn fit(&self) -> Option<ClockFit> {
        if let Some(f) = self.fit.get() {
            return f;
        }
        let f = self.compute();
        self.fit.set(Some(f));
        f
    }

    /// Number of pairs held.
    pub fn len(&self) -> usize {
        self.pairs.len()
    }

    /// `true` before the first reply.
    pub fn is_empty(&self) -> bool {
        self.pairs.is_empty()
    }

    /// Estimated server time (seconds since the session was accepted) at local instant `t`.
    pub fn server_time(&self, t: Instant) -> Option<f64> {
        let f = self.fit()?;
        Some(f.offset_s + f.rate * self.local_s(t))
    }

    /// The local instant at which the server clock reads `server_s`.
    pub fn local_instant(&self, server_s: f64) -> Option<Instant> {
        let f = self.fit()?;
        let local = (server_s - f.offset_s) / f.rate;
        if !local.is_finite() {
            return None;
        }
        let d = std::time::Duration::from_secs_f64(local.abs().min(1e9));
        Some(if local >= 0.0 {
            self.epoch + d
        } else {
            self.epoch.checked_sub(d).unwrap_or(self.epoch)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    /// The fit as first written, one pass per sum.
    fn reference_fit(c: &ServerClock) -> Option<ClockFit> {
        let min_rtt = c
            .pairs
            .iter()
            .map(|p| p.rtt_s)
            .fold(f64::INFINITY, f64::min);
        let limit = 2.0 * min_rtt + 1e-4;
        let used = || c.pairs.iter().filter(move |p| p.rtt_s <= limit);
        let n = used().count();
        if n == 0 {
            return None;
        }
        let nf = n as f64;
        let mx = used().map(|p| p.local_s).sum::<f64>() / nf;
        let my = used().map(|p| p.server_s).sum::<f64>() / nf;
        let sxx: f64 = used().map(|p| (p.local_s - mx).powi(2)).sum();
        let sxy: f64 = used().map(|p| (p.local_s - mx) * (p.server_s - my)).sum();
        let span = used().map(|p| p.local_s).fold(f64::NEG_INFINITY, f64::max)
            - used().map(|p| p.local_s).fold(f64::INFINITY, f64::min);
        let rate = if n >= 2 && span >= MIN_SPAN_S && sxx > 0.0 {
            (sxy / sxx).clamp(1.0 - MAX_DRIFT, 1.0 + MAX_DRIFT)
        } else {
            1.0
        };
        let offset_s = my - rate * mx;
        let residual_s = (used()
            .map(|p| (p.server_s - (offset_s + rate * p.local_s)).powi(2))
            .sum::<f64>()
            / nf)
            .sqrt();
        Some(ClockFit {
            offset_s,
            rate,
            pairs: n,
            residual_s,
        })
    }

    #[tokio::test(start_paused = true)]
    async fn the_fit_is_the_reference_to_the_bit() {
        let epoch = Instant::now();
        let mut c = ServerClock::new(epoch);
        // A deterministic spread of round trips and server times (a linear congruential
        // sequence), over more than the window.
        let mut x: u64 = 12345;
        let mut next = || {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (x >> 11) as f64 / (1u64 << 53) as f64
        };
        for k in 0..200u64 {
            let sent = epoch + Duration::from_micros(k * 4000 + (next() * 900.0) as u64);
            let received = sent + Duration::from_micros(50 + (next() * 3000.0) as u64);
            c.add(
                sent,
                received,
                3.0 + k as f64 * 0.004 * 1.0002 + next() * 1e-3,
            );
            assert_eq!(c.compute(), reference_fit(&c), "after {} pairs", k + 1);
        }
    }

    #[tokio::test(start_paused = true)]
    async fn fits_offset_and_drift() {
        let epoch = Instant::now();
        let mut c = ServerClock::new(epoch);
        assert!(c.server_time(epoch).is_none());
        // Server clock: 3.0 s ahead, running 200 ppm fast; RTT 2 ms, except every 5th round
        // trip, whose reply was held up 4 ms on the way back (asymmetric: its midpoint is 2 ms
        // late). Those must be filtered out.
        let server = |local: f64| 3.0 + 1.0002 * local;
        for k in 0..64 {
            let sent = epoch + Duration::from_millis(100 * k);
            let s = sent.duration_since(epoch).as_secs_f64();
            let slow = k % 5 == 0;
            let rtt = if slow { 0.006 } else { 0.002 };
            // TIMER has 1 ms resolution; the server reads it 1 ms after the request is sent.
            let t = (server(s + 0.001) * 1e3).round() / 1e3;
            c.add(sent, sent + Duration::from_secs_f64(rtt), t);
        }
        let f = c.fit().unwrap();
        assert!((f.rate - 1.0002).abs() < 5e-5, "{f:?}");
        assert_eq!(f.pairs, 51);
        let at = epoch + Duration::from_secs(10);
        let est = c.server_time(at).unwrap();
        assert!((est - server(10.0)).abs() < 1e-3, "{est}");
        let back = c.local_instant(est).unwrap();
        assert!(
            back.duration_since(at) < Duration::from_micros(10)
                || at.duration_since(back) < Duration::from_micros(10)
        );
    }

    #[tokio::test(start_paused = true)]
    async fn single_pair_assumes_rate_one() {
        let epoch = Instant::now();
        let mut c = ServerClock::new(epoch);
        c.add(epoch, epoch + Duration::from_millis(4), 1.0);
        let f = c.fit().unwrap();
        assert_eq!(f.rate, 1.0);
        assert!((c.server_time(epoch + Duration::from_millis(2)).unwrap() - 1.0).abs() < 1e-9);
    }
}
