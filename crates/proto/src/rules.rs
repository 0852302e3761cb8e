//! The session rules of protocol 1040 as plain data (no clocks here: these are the numbers the
//! emulator's clock and the client's deadlines are set from).

use std::time::Duration;

/// The protocol version the server acts on.
pub const PROTOCOL_VERSION: i64 = 1040;
/// The controller's TCP port (configurable in the AS source).
pub const DEFAULT_PORT: u16 = 10050;
/// Bytes of a request the server reads; the rest is silently ignored.
pub const MAX_REQUEST_BYTES: usize = 255;
/// The server accepts connections in windows of this length, with a short gap between them.
pub const ACCEPT_WINDOW: Duration = Duration::from_secs(3);
/// No request for this long ends the session (robot stops, connection closed).
pub const RECEIVE_TIMEOUT: Duration = Duration::from_secs(5);
/// A reply that cannot be delivered within this time ends the session.
pub const SEND_TIMEOUT: Duration = Duration::from_secs(2);
/// Entries of the server's command ring.
pub const COMMAND_RING_LEN: usize = 16;
/// Joint angle (JT3 or JT5, degrees) below which command 7 uses the slow joint-move branch.
pub const SINGULAR_ZONE_DEG: f64 = 5.0;
/// Speed (percent) of command 7's joint-move branch near singularities.
pub const SINGULAR_JMOVE_SPEED_PERCENT: f64 = 30.0;
/// Duration (seconds) of command 7's straight-line move.
pub const STREAM_LMOVE_TIME_S: f64 = 0.1;
/// ACCURACY of the server program's motions (mm at the tool): a planned motion blends in once
/// the tool is this close to the current target.
pub const ACCURACY_MM: f64 = 10.0;
/// Weight of the newest pass duration in the motion program's `step` average.
pub const STEP_AVERAGE_WEIGHT: f64 = 0.1;

/// AS boolean true as sent in replies.
pub const AS_TRUE: i64 = -1;
/// AS boolean false as sent in replies.
pub const AS_FALSE: i64 = 0;
