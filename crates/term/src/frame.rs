//! The block-transfer frames of `LOAD` and `SAVE` over the terminal (**H**: several clients,
//! checked byte by byte against a virtual controller).
//!
//! - From the controller: `05` (ENQ) `02` (STX), a letter, the payload, `17` (ETB), mixed in
//!   with ordinary text.
//! - From the client: `02`, the letter, four blanks and an ASCII `0`, the payload, `17`. Nobody
//!   documents the `0`; every client sends it, and the emulator accepts a frame without it.
//!
//! | letter | from the controller | from the client |
//! |---|---|---|
//! | `A` | a LOAD began; the payload is the file name | accept |
//! | `B` | a SAVE began; the payload is the file name | accept |
//! | `C` | send the next block | a block of the file; `1A` (SUB) alone ends the file |
//! | `D` | a chunk of the saved file | — |
//! | `E` | the transfer is over | acknowledge |

/// Enquiry: opens a controller's frame.
pub const ENQ: u8 = 0x05;
/// Start of text.
pub const STX: u8 = 0x02;
/// End of transmission block: closes a frame.
pub const ETB: u8 = 0x17;
/// Substitute: a client's block of only this byte ends the file.
pub const SUB: u8 = 0x1A;
/// What follows the letter in a client's frame.
pub const CLIENT_HEADER: &[u8] = b"    0";
/// Longest payload kept (a file block is at most about 3 KB); a longer one is reported and
/// skipped, so a peer cannot make a scanner grow.
pub const MAX_PAYLOAD: usize = 64 * 1024;

/// The letter of a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Letter {
    /// A LOAD began / accepted.
    A,
    /// A SAVE began / accepted.
    B,
    /// Send the next block / a block.
    C,
    /// A chunk of a saved file.
    D,
    /// The transfer is over / acknowledged.
    E,
}

impl Letter {
    /// The letter's byte.
    pub fn byte(self) -> u8 {
        match self {
            Letter::A => b'A',
            Letter::B => b'B',
            Letter::C => b'C',
            Letter::D => b'D',
            Letter::E => b'E',
        }
    }

    /// The letter of a byte.
    pub fn from_byte(b: u8) -> Option<Letter> {
        Some(match b {
            b'A' => Letter::A,
            b'B' => Letter::B,
            b'C' => Letter::C,
            b'D' => Letter::D,
            b'E' => Letter::E,
            _ => return None,
        })
    }
}

/// A frame as the controller sends it.
pub fn controller_frame(letter: Letter, payload: &[u8]) -> Vec<u8> {
    let mut v = Vec::with_capacity(payload.len() + 4);
    v.extend_from_slice(&[ENQ, STX, letter.byte()]);
    v.extend_from_slice(payload);
    v.push(ETB);
    v
}

/// A frame as a client sends it.
pub fn client_frame(letter: Letter, payload: &[u8]) -> Vec<u8> {
    let mut v = Vec::with_capacity(payload.len() + 8);
    v.extend_from_slice(&[STX, letter.byte()]);
    v.extend_from_slice(CLIENT_HEADER);
    v.extend_from_slice(payload);
    v.push(ETB);
    v
}

/// What a scanner found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Piece {
    /// Ordinary bytes outside frames, as they came.
    Text(Vec<u8>),
    /// A whole frame.
    Frame {
        /// Its letter.
        letter: Letter,
        /// Its payload (for a client's frame, after the header).
        payload: Vec<u8>,
    },
    /// A frame with an unknown letter or a payload longer than [`MAX_PAYLOAD`]: skipped up
    /// to its ETB.
    Malformed {
        /// The letter byte.
        letter: u8,
        /// Bytes of payload seen.
        len: usize,
    },
}

/// Which side's frames a scanner reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sender {
    /// The controller: frames open with ENQ STX.
    Controller,
    /// A client: frames open with STX and carry the header after the letter.
    Client,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    Text,
    Enq,
    Letter,
    Payload,
}

/// Splits a byte stream, cut anywhere, into text and frames. Never panics, whatever the bytes.
#[derive(Debug, Clone)]
pub struct Scanner {
    sender: Sender,
    state: State,
    letter: u8,
    payload: Vec<u8>,
    len: usize,
}

impl Scanner {
    /// A scanner of what `sender` sends.
    pub fn new(sender: Sender) -> Scanner {
        Scanner {
            sender,
            state: State::Text,
            letter: 0,
            payload: Vec::new(),
            len: 0,
        }
    }

    /// `true` when the scanner is inside a frame (its ETB has not come yet).
    pub fn in_frame(&self) -> bool {
        matches!(self.state, State::Letter | State::Payload)
    }

    /// Scans `bytes`, appending what they complete to `out` (text in runs, frames whole).
    pub fn push(&mut self, bytes: &[u8], out: &mut Vec<Piece>) {
        let mut text = Vec::new();
        for &b in bytes {
            match self.state {
                State::Text => match (self.sender, b) {
                    (Sender::Controller, ENQ) => self.state = State::Enq,
                    (Sender::Client, STX) => self.open(&mut text, out),
                    _ => text.push(b),
                },
                State::Enq => {
                    if b == STX {
                        self.open(&mut text, out);
                    } else {
                        text.push(ENQ);
                        if b == ENQ {
                            continue;
                        }
                        text.push(b);
                        self.state = State::Text;
                    }
                }
                State::Letter => {
                    self.letter = b;
                    self.state = State::Payload;
                }
                State::Payload if b == ETB => {
                    out.push(self.close());
                    self.state = State::Text;
                }
                State::Payload => {
                    self.len += 1;
                    if self.len <= MAX_PAYLOAD {
                        self.payload.push(b);
                    }
                }
            }
        }
        if !text.is_empty() {
            out.push(Piece::Text(text));
        }
    }

    fn open(&mut self, text: &mut Vec<u8>, out: &mut Vec<Piece>) {
        if !text.is_empty() {
            out.push(Piece::Text(std::mem::take(text)));
        }
        self.payload.clear();
        self.len = 0;
        self.state = State::Letter;
    }

    fn close(&mut self) -> Piece {
        let payload = std::mem::take(&mut self.payload);
        match Letter::from_byte(self.letter) {
            Some(letter) if self.len <= MAX_PAYLOAD => {
                let payload = match self.sender {
                    Sender::Controller => payload,
                    Sender::Client => strip_header(payload),
                };
                Piece::Frame { letter, payload }
            }
            _ => Piece::Malformed {
                letter: self.letter,
                len: self.len,
            },
        }
    }
}

/// A client's payload without its header: the four blanks and the `0`, or the four blanks
/// alone (one client sends its end of file so), or nothing when the frame has no header.
fn strip_header(mut payload: Vec<u8>) -> Vec<u8> {
    let cut = if payload.starts_with(CLIENT_HEADER) {
        CLIENT_HEADER.len()
    } else if payload.starts_with(b"    ") {
        4
    } else {
        0
    };
    payload.drain(..cut);
    payload
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scan_split(sender: Sender, bytes: &[u8], cut: usize) -> Vec<Piece> {
        let mut s = Scanner::new(sender);
        let mut out = Vec::new();
        s.push(&bytes[..cut], &mut out);
        s.push(&bytes[cut..], &mut out);
        // Join adjacent text runs: where a cut falls must not matter.
        let mut joined: Vec<Piece> = Vec::new();
        for p in out {
            match (joined.last_mut(), p) {
                (Some(Piece::Text(a)), Piece::Text(b)) => a.extend(b),
                (_, p) => joined.push(p),
            }
        }
        joined
    }

    #[test]
    fn a_controller_frame_inside_text_is_found_wherever_the_stream_is_cut() {
        let mut stream = b"LOAD x.as\r\n".to_vec();
        stream.extend(controller_frame(Letter::A, b"x.as"));
        stream.extend_from_slice(b"Loading...(x.as)\r\n");
        stream.extend(controller_frame(Letter::C, b""));
        for cut in 0..=stream.len() {
            assert_eq!(
                scan_split(Sender::Controller, &stream, cut),
                vec![
                    Piece::Text(b"LOAD x.as\r\n".to_vec()),
                    Piece::Frame {
                        letter: Letter::A,
                        payload: b"x.as".to_vec()
                    },
                    Piece::Text(b"Loading...(x.as)\r\n".to_vec()),
                    Piece::Frame {
                        letter: Letter::C,
                        payload: vec![]
                    },
                ],
                "cut at {cut}"
            );
        }
    }

    #[test]
    fn a_client_frame_loses_its_header_and_one_without_the_zero_is_accepted() {
        let mut stream = client_frame(Letter::C, b".END\n");
        stream.extend_from_slice(&[STX, b'C', b' ', b' ', b' ', b' ', SUB, ETB]);
        for cut in 0..=stream.len() {
            assert_eq!(
                scan_split(Sender::Client, &stream, cut),
                vec![
                    Piece::Frame {
                        letter: Letter::C,
                        payload: b".END\n".to_vec()
                    },
                    Piece::Frame {
                        letter: Letter::C,
                        payload: vec![SUB]
                    },
                ]
            );
        }
    }

    #[test]
    fn an_enq_not_followed_by_stx_is_text() {
        let out = scan_split(
            Sender::Controller,
            &[b'a', ENQ, b'b', ENQ, ENQ, STX, b'E', ETB],
            3,
        );
        assert_eq!(
            out,
            vec![
                Piece::Text(vec![b'a', ENQ, b'b', ENQ]),
                Piece::Frame {
                    letter: Letter::E,
                    payload: vec![]
                }
            ]
        );
    }

    #[test]
    fn an_unknown_letter_or_an_endless_payload_is_malformed_and_bounded() {
        let mut s = Scanner::new(Sender::Controller);
        let mut out = Vec::new();
        s.push(&[ENQ, STX, b'Z', b'x', ETB], &mut out);
        assert_eq!(
            out,
            vec![Piece::Malformed {
                letter: b'Z',
                len: 1
            }]
        );
        out.clear();
        s.push(&[ENQ, STX, b'C'], &mut out);
        s.push(&vec![b'x'; MAX_PAYLOAD + 10], &mut out);
        assert!(s.in_frame());
        s.push(&[ETB, b'!'], &mut out);
        assert_eq!(
            out,
            vec![
                Piece::Malformed {
                    letter: b'C',
                    len: MAX_PAYLOAD + 10
                },
                Piece::Text(b"!".to_vec())
            ]
        );
    }
}
