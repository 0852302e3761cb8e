//! Server-side request parsing with the controller's semantics.
//!
//! This is how the AS server program reads a request (the emulator uses it; a client never
//! needs it): only the first 255 bytes count; tokens are cut the way the program's alternating
//! `$DECODE(text, " ", 0)` / `$DECODE(text, " ", 1)` cut them ([`server_tokens`]: any run of
//! blanks *between* tokens is one separator, but a leading blank makes the first token empty);
//! every token goes through `VAL` ([`as_val`](crate::number::as_val)); the version and command number are reals; and
//! COUNT_OF_ARGS is trusted (missing arguments read 0, extra ones are ignored).
//!
//! ```
//! use fs020n_proto::ServerRequest;
//! use fs020n_proto::Command;
//! let r = ServerRequest::parse(b"1040 3 1 50abc");
//! assert!(r.version_matches());
//! assert_eq!(r.command(), Command::SetSpeed { percent: 50.0 });
//! assert!(!ServerRequest::parse(b" 1040 3 1 50").version_matches());
//! // Runs of blanks between tokens act.
//! assert_eq!(ServerRequest::parse(b"1040  3 1   50").command(), Command::SetSpeed { percent: 50.0 });
//! ```

use crate::joints::{JointsDeg, JOINT_COUNT};
use crate::number::{general_val, short_decimal_at};
use crate::request::{Command, StreamSample};
use crate::rules::{MAX_REQUEST_BYTES, PROTOCOL_VERSION};

/// Most arguments kept: no command reads more than 21, and 255 bytes cannot hold more than 128
/// tokens.
pub const MAX_ARGS: usize = 128;

/// A request as the controller understands it.
#[derive(Debug, Clone, PartialEq)]
pub struct ServerRequest {
    /// `VAL` of the first token.
    pub version: f64,
    /// `VAL` of the second token.
    pub command_number: f64,
    /// The trusted argument count (`VAL` of the third token, truncated, at least 0).
    pub count: usize,
    /// `count` arguments (at most [`MAX_ARGS`]); missing ones are 0.
    pub args: Vec<f64>,
}

impl ServerRequest {
    /// Parses the bytes of one receive call. Never fails: every input means something to the
    /// controller.
    pub fn parse(bytes: &[u8]) -> ServerRequest {
        let head = &bytes[..bytes.len().min(MAX_REQUEST_BYTES)];
        // The tokens are cut and read on the bytes, in one pass: only ASCII blanks separate and
        // only ASCII characters form numbers, so this reads what the text decoded lossily would.
        let mut tokens = TokenValues { text: head, at: 0 };
        let version = tokens.next_value();
        let command_number = tokens.next_value();
        let count_val = tokens.next_value();
        let count = if count_val >= 1.0 {
            (count_val.trunc() as usize).min(MAX_ARGS)
        } else {
            0
        };
        let mut args = Vec::with_capacity(count);
        args.extend((0..count).map(|_| tokens.next_value()));
        ServerRequest {
            version,
            command_number,
            count,
            args,
        }
    }

    /// `true` when the version is 1040: only then does the server act.
    pub fn version_matches(&self) -> bool {
        self.version == PROTOCOL_VERSION as f64
    }

    /// Argument `i` (0-based), 0 when missing.
    pub fn arg(&self, i: usize) -> f64 {
        self.args.get(i).copied().unwrap_or(0.0)
    }

    fn joints_from(&self, first: usize) -> JointsDeg {
        let mut j = [0.0; JOINT_COUNT];
        for (k, v) in j.iter_mut().enumerate() {
            *v = self.arg(first + k);
        }
        JointsDeg(j)
    }

    /// The command the server sees.
    pub fn command(&self) -> Command {
        match self.command_number {
            1.0 => Command::StartProgram,
            2.0 => Command::StopProgram,
            3.0 => Command::SetSpeed {
                percent: self.arg(0),
            },
            4.0 => Command::Reserved,
            5.0 => Command::CancelMotion,
            6.0 => Command::JointMove {
                target: self.joints_from(3),
            },
            7.0 => Command::StreamedMove(StreamSample {
                t0_s: self.arg(0),
                lookahead_passes: self.arg(1),
                position: self.joints_from(3),
                velocity: self.joints_from(9),
                acceleration: self.joints_from(15),
            }),
            255.0 => Command::EndSession,
            number => Command::Other {
                number,
                args: self.args.clone(),
            },
        }
    }
}

/// The tokens of a request as the AS server program cuts them: `$DECODE(text, " ", 0)` takes
/// the text before the next blank (nothing when the text starts with one), then
/// `$DECODE(text, " ", 1)` removes the whole run of blanks that follows, and so on. So runs of
/// blanks between tokens are one separator, trailing blanks end the tokens, and a leading blank
/// yields an empty first token (`VAL("")` is 0: a version mismatch). Only the blank (0x20)
/// separates; a tab is part of a token.
///
/// ```
/// use fs020n_proto::server_tokens;
/// assert_eq!(server_tokens("1040  3 1 50 ").collect::<Vec<_>>(), ["1040", "3", "1", "50"]);
/// assert_eq!(server_tokens(" 1040 3").collect::<Vec<_>>(), ["", "1040", "3"]);
/// ```
pub fn server_tokens(text: &str) -> impl Iterator<Item = &str> {
    let mut rest = Some(text);
    std::iter::from_fn(move || {
        let r = rest?;
        let cut = r.find(' ').unwrap_or(r.len());
        let (token, after) = r.split_at(cut);
        let after = after.trim_start_matches(' ');
        rest = (!after.is_empty()).then_some(after);
        // The first cut of a text that starts with a blank is an empty token; afterwards the
        // blanks are gone, so an empty token only ends the text.
        (!token.is_empty() || cut == 0 && r.len() == text.len()).then_some(token)
    })
}

/// `VAL` of each token of [`server_tokens`], read on the bytes in one pass; 0 for every token
/// after the last.
struct TokenValues<'a> {
    text: &'a [u8],
    /// Where the next token starts: after a run of blanks, except at the start (a leading
    /// blank is an empty first token, as `$DECODE` cuts it).
    at: usize,
}

impl TokenValues<'_> {
    /// `VAL` of the next token (0 when there is none: `VAL("")` is 0 too).
    #[inline(always)]
    fn next_value(&mut self) -> f64 {
        let text = self.text;
        let start = self.at;
        // `VAL` skips leading blanks; inside a token only tabs can lead.
        let mut i = start;
        while text.get(i) == Some(&b'\t') {
            i += 1;
        }
        let (value, mut end) = match short_decimal_at(text, i) {
            Some((v, end)) => (f64::from(v as f32), end),
            None => {
                let rest = text.get(i..).unwrap_or_default();
                let len = rest.iter().position(|&c| c == b' ').unwrap_or(rest.len());
                (general_val(&rest[..len]), i + len)
            }
        };
        // The rest of the token (what follows its number), then the run of blanks after it.
        while text.get(end).is_some_and(|&c| c != b' ') {
            end += 1;
        }
        while text.get(end) == Some(&b' ') {
            end += 1;
        }
        self.at = end;
        value
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn controller_semantics() {
        let r = ServerRequest::parse(b"1040 6 9 0 0 0 1 2 3 4 5 6");
        assert_eq!(
            r.command(),
            Command::JointMove {
                target: JointsDeg::new([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
            }
        );
        // COUNT too large: missing args are 0.
        let r = ServerRequest::parse(b"1040 6 9 0 0 0 1 2");
        assert_eq!(
            r.command(),
            Command::JointMove {
                target: JointsDeg::new([1.0, 2.0, 0.0, 0.0, 0.0, 0.0])
            }
        );
        // COUNT too small: extra tokens ignored.
        let r = ServerRequest::parse(b"1040 6 4 0 0 0 1 2 3");
        assert_eq!(
            r.command(),
            Command::JointMove {
                target: JointsDeg::new([1.0, 0.0, 0.0, 0.0, 0.0, 0.0])
            }
        );
        // 6.5 matches nothing.
        assert!(
            matches!(ServerRequest::parse(b"1040 6.5 0").command(), Command::Other { number, .. } if number == 6.5)
        );
        // Empty / non-numeric tokens are 0; "12abc" is 12.
        let r = ServerRequest::parse(b"1040 3 1 12abc");
        assert_eq!(r.command(), Command::SetSpeed { percent: 12.0 });
        let r = ServerRequest::parse(b"");
        assert!(!r.version_matches());
        assert_eq!(r.command_number, 0.0);
        // A run of blanks between tokens is one separator (the program cuts the whole run).
        let r = ServerRequest::parse(b"1040  3 1 50");
        assert_eq!(r.command(), Command::SetSpeed { percent: 50.0 });
        let r = ServerRequest::parse(b"1040 6   9 0 0 0  1 2 3    4 5 6   ");
        assert_eq!(
            r.command(),
            Command::JointMove {
                target: JointsDeg::new([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
            }
        );
        // A leading blank (or several) still empties the version token.
        assert!(!ServerRequest::parse(b" 1040 3 1 50").version_matches());
        assert!(!ServerRequest::parse(b"   1040 3 1 50").version_matches());
        // Only blanks separate.
        // Only blanks separate: "1040\t3" is one token whose VAL is 1040, so "1" is the command.
        let r = ServerRequest::parse(b"1040\t3 1 50");
        assert!(r.version_matches());
        assert_eq!(r.command_number, 1.0);
        assert!(ServerRequest::parse(b"1040.0 1 0").version_matches());
    }

    /// The reading on text decoded lossily, token by token (the definition the byte parser
    /// must match).
    fn reference_parse(bytes: &[u8]) -> ServerRequest {
        let head = &bytes[..bytes.len().min(MAX_REQUEST_BYTES)];
        let text = String::from_utf8_lossy(head);
        let tokens: Vec<&str> = server_tokens(&text).collect();
        let val = |i: usize| tokens.get(i).map_or(0.0, |t| crate::number::as_val(t));
        let count_val = val(2);
        let count = if count_val >= 1.0 {
            (count_val.trunc() as usize).min(MAX_ARGS)
        } else {
            0
        };
        ServerRequest {
            version: val(0),
            command_number: val(1),
            count,
            args: (0..count).map(|i| val(3 + i)).collect(),
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(1_000))]
        /// Bytes of every kind (blanks, tabs, digits, signs, points, exponents, invalid UTF-8,
        /// a cut multi-byte character at byte 255) parse as the text reading says.
        #[test]
        fn the_byte_parser_reads_what_the_text_reading_says(
            parts in proptest::collection::vec(
                proptest::prop_oneof![
                    proptest::string::bytes_regex("[ ]{1,3}").unwrap(),
                    proptest::string::bytes_regex("[+-]?[0-9]{0,6}[.]?[0-9]{0,4}").unwrap(),
                    proptest::string::bytes_regex("[0-9]{1,3}[eE][+-]?[0-9]{1,2}").unwrap(),
                    proptest::string::bytes_regex("\t|x|é|\\xff|\\xc3").unwrap(),
                    proptest::collection::vec(proptest::prelude::any::<u8>(), 0..4),
                ],
                0..90,
            ),
        ) {
            let bytes: Vec<u8> = parts.concat();
            proptest::prop_assert_eq!(ServerRequest::parse(&bytes), reference_parse(&bytes));
            let mut request = b"1040 7 21 ".to_vec();
            request.extend_from_slice(&bytes);
            proptest::prop_assert_eq!(ServerRequest::parse(&request), reference_parse(&request));
        }
    }

    #[test]
    fn only_the_first_255_bytes_count() {
        let mut text = String::from("1040 3 1 ");
        text.push_str(&" ".repeat(MAX_REQUEST_BYTES - text.len()));
        text.push_str("50");
        let r = ServerRequest::parse(text.as_bytes());
        assert_eq!(r.command(), Command::SetSpeed { percent: 0.0 });
        let mut text = String::from("1040 3 1 ");
        text.push_str(&"7".repeat(MAX_REQUEST_BYTES - text.len() - 1));
        let cut = ServerRequest::parse(format!("{text}99").as_bytes());
        let whole = ServerRequest::parse(format!("{text}9").as_bytes());
        assert_eq!(cut.args, whole.args);
    }

    #[test]
    fn client_encoding_round_trips_through_the_server_parser() {
        let c = Command::StreamedMove(StreamSample {
            t0_s: 3.25,
            lookahead_passes: 2.0,
            position: JointsDeg::new([1.5, -2.0, -90.0, 0.0, -90.0, 10.0]),
            velocity: JointsDeg::new([1.0; 6]),
            acceleration: JointsDeg::new([-1.0; 6]),
        });
        let text = crate::Request::new(c.clone()).encode().unwrap();
        let r = ServerRequest::parse(text.as_bytes());
        assert!(r.version_matches());
        assert_eq!(r.command(), c);
    }

    /// The tokenizer on bytes as it was (an iterator over the tokens).
    fn previous_token_bytes(text: &[u8]) -> impl Iterator<Item = &[u8]> {
        let mut rest = Some(text);
        let mut first = true;
        std::iter::from_fn(move || {
            let r = rest?;
            let cut = r.iter().position(|&c| c == b' ').unwrap_or(r.len());
            let (token, after) = r.split_at(cut);
            let blanks = after.iter().take_while(|&&c| c == b' ').count();
            let after = &after[blanks..];
            rest = (!after.is_empty()).then_some(after);
            let is_first = std::mem::replace(&mut first, false);
            (!token.is_empty() || cut == 0 && is_first).then_some(token)
        })
    }

    /// The parser as it was before the one-pass reading: tokens cut first, then each read by
    /// the previous `VAL`.
    fn previous_parse(bytes: &[u8]) -> ServerRequest {
        let head = &bytes[..bytes.len().min(MAX_REQUEST_BYTES)];
        let mut tokens = previous_token_bytes(head);
        let mut val = || {
            tokens
                .next()
                .map_or(0.0, crate::number::reference::as_val_bytes)
        };
        let version = val();
        let command_number = val();
        let count_val = val();
        let count = if count_val >= 1.0 {
            (count_val.trunc() as usize).min(MAX_ARGS)
        } else {
            0
        };
        let args = (0..count).map(|_| val()).collect();
        ServerRequest {
            version,
            command_number,
            count,
            args,
        }
    }

    /// Bit for bit (signed zeros and all): `PartialEq` on f64 would call 0 and -0 equal.
    fn bits(r: &ServerRequest) -> (u64, u64, usize, Vec<u64>) {
        (
            r.version.to_bits(),
            r.command_number.to_bits(),
            r.count,
            r.args.iter().map(|a| a.to_bits()).collect(),
        )
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(5_000))]
        /// The one-pass parser reads every request bit for bit as the previous parser did:
        /// command-7 requests as clients write them, requests with odd tokens (runs of blanks,
        /// tabs, signs, points, exponents, asterisks, long digit strings, overflow), and
        /// arbitrary bytes, also beyond byte 255.
        #[test]
        fn the_one_pass_parser_reads_what_the_previous_parser_read(
            numbers in proptest::collection::vec(-1.0e6f64..1.0e6, 0..30),
            count in 0usize..40,
            parts in proptest::collection::vec(
                proptest::prop_oneof![
                    proptest::string::bytes_regex("[ ]{1,3}").unwrap(),
                    proptest::string::bytes_regex("[+-]?[0-9]{0,9}[.]?[0-9]{0,9}").unwrap(),
                    proptest::string::bytes_regex("[0-9]{1,20}[.]?[0-9]{0,20}").unwrap(),
                    proptest::string::bytes_regex("[+-]?[0-9]{0,3}[.]?[0-9]{0,3}[eE][+-]?[0-9]{0,3}").unwrap(),
                    proptest::string::bytes_regex("[-+.*eE\t]{1,3}|x|\\*{10}|1040|7|21").unwrap(),
                    proptest::collection::vec(proptest::prelude::any::<u8>(), 0..6),
                ],
                0..100,
            ),
            bytes in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..300),
        ) {
            let mut cmd7 = format!("1040 7 {count}");
            for v in &numbers {
                cmd7.push(' ');
                crate::number::push_request_number(&mut cmd7, *v, "x").unwrap_or_default();
            }
            let odd = parts.concat();
            let mut prefixed = b"1040 7 21 ".to_vec();
            prefixed.extend_from_slice(&odd);
            for input in [cmd7.as_bytes(), &odd, &prefixed, &bytes] {
                let new = ServerRequest::parse(input);
                let old = previous_parse(input);
                proptest::prop_assert_eq!(bits(&new), bits(&old), "{:?}", String::from_utf8_lossy(input));
            }
        }
    }

    #[test]
    fn one_pass_edges() {
        for input in [
            &b""[..],
            b" ",
            b"   ",
            b" 1040",
            b"1040",
            b"1040 ",
            b"1040 7 21",
            b"1040 7 21 ",
            b"1040\t7 1 5",
            b"\t1040 7 1 \t-5",
            b"1040 7 3 1e5 -2.5e-3 9999999999999999999",
            b"1040 7 3 -0 -.0 +.",
            b"1040 7 3 1.2.3 --5 +-5",
            b"1040 7 3 1e99 -1e39 3.4e38",
            b"1040 3 1.9e0 50",
            b"1040 3 1 0.0000000000000001",
            b"1040 3 1 0000000000000001.5",
            b"1040 200 200",
        ] {
            assert_eq!(
                bits(&ServerRequest::parse(input)),
                bits(&previous_parse(input)),
                "{:?}",
                String::from_utf8_lossy(input)
            );
        }
    }

    /// The fuzz targets' seed corpora (`fuzz/seeds/`): every seed reads as the previous
    /// implementation read it, whole, cut at each byte, and after a command-7 head.
    #[test]
    fn fuzz_seeds_read_as_before() {
        let seeds = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/seeds");
        let mut read = 0;
        for target in ["server_parse", "as_val"] {
            let dir = std::fs::read_dir(seeds.join(target)).expect("the fuzz seed corpus");
            for entry in dir {
                let bytes = std::fs::read(entry.expect("a seed").path()).expect("a seed");
                for cut in 0..=bytes.len() {
                    let input = &bytes[..cut];
                    assert_eq!(
                        bits(&ServerRequest::parse(input)),
                        bits(&previous_parse(input))
                    );
                    assert_eq!(
                        crate::number::as_val_bytes(input).to_bits(),
                        crate::number::reference::as_val_bytes(input).to_bits()
                    );
                }
                let mut cmd7 = b"1040 7 21 ".to_vec();
                cmd7.extend_from_slice(&bytes);
                assert_eq!(
                    bits(&ServerRequest::parse(&cmd7)),
                    bits(&previous_parse(&cmd7))
                );
                read += 1;
            }
        }
        assert!(read >= 20, "only {read} seeds");
    }
}
