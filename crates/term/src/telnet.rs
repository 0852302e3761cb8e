//! Telnet on the terminal port: the controller's opening negotiation, and a filter that takes
//! telnet commands out of a byte stream split anywhere.
//!
//! The E controller offers a few options right after the connection opens
//! ([`CONTROLLER_OPENING`]) and works whether the client answers them or not (**M**: one real
//! client answers nothing); some controllers (a D controller's client, the vendor's terminal)
//! wait for the terminal type before `login:`. After login no party should send telnet
//! commands: on one controller a stray command became a literal character, on another it raises
//! an error. So this crate's client answers the terminal type before login and nothing after,
//! and the emulator reads only the terminal type, when it plays a terminal that asks it.

/// Interpret As Command.
pub const IAC: u8 = 0xFF;
/// Subnegotiation end.
pub const SE: u8 = 0xF0;
/// No operation.
pub const NOP: u8 = 0xF1;
/// Subnegotiation begin.
pub const SB: u8 = 0xFA;
/// Sender wants to enable an option.
pub const WILL: u8 = 0xFB;
/// Sender refuses an option.
pub const WONT: u8 = 0xFC;
/// Sender asks the peer to enable an option.
pub const DO: u8 = 0xFD;
/// Sender asks the peer to disable an option.
pub const DONT: u8 = 0xFE;

/// Option: echo.
pub const OPT_ECHO: u8 = 0x01;
/// Option: suppress go-ahead.
pub const OPT_SUPPRESS_GO_AHEAD: u8 = 0x03;
/// Option: terminal type.
pub const OPT_TERMINAL_TYPE: u8 = 0x18;

/// What a real E controller sends first, unprompted (**H**, a recorded session): DO
/// TERMINAL-TYPE, WILL ECHO, a terminal-type SEND subnegotiation (with the two `01` bytes the
/// recording shows, where the standard has one), WILL SUPPRESS-GO-AHEAD.
pub const CONTROLLER_OPENING: &[u8] = &[
    IAC,
    DO,
    OPT_TERMINAL_TYPE,
    IAC,
    WILL,
    OPT_ECHO,
    IAC,
    SB,
    OPT_TERMINAL_TYPE,
    0x01,
    0x01,
    IAC,
    SE,
    IAC,
    WILL,
    OPT_SUPPRESS_GO_AHEAD,
];

/// A telnet command seen in the stream.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum TelnetCommand {
    /// WILL, WONT, DO or DONT with its option.
    Negotiate {
        /// The verb ([`WILL`], [`WONT`], [`DO`], [`DONT`]).
        verb: u8,
        /// The option.
        option: u8,
    },
    /// A subnegotiation: the option and its bytes (IAC IAC unescaped).
    Subnegotiation {
        /// The option.
        option: u8,
        /// What followed the option, up to IAC SE.
        data: Vec<u8>,
    },
    /// Any other two-byte command (NOP, go-ahead, …).
    Other(u8),
}

/// Longest subnegotiation kept; longer ones are cut (a peer cannot make the filter grow).
pub const MAX_SUBNEGOTIATION: usize = 256;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    Data,
    Iac,
    Verb(u8),
    SubOption,
    Sub,
    SubIac,
}

/// Takes telnet commands out of a byte stream split anywhere: [`push`](TelnetFilter::push)
/// appends the data bytes to `out` and returns the commands completed by these bytes.
/// `IAC IAC` is a literal `0xFF`. Never panics, whatever the bytes.
#[derive(Debug, Clone)]
pub struct TelnetFilter {
    state: State,
    sub_option: u8,
    sub: Vec<u8>,
}

impl Default for TelnetFilter {
    fn default() -> Self {
        TelnetFilter::new()
    }
}

impl TelnetFilter {
    /// A filter at the start of a stream.
    pub fn new() -> TelnetFilter {
        TelnetFilter {
            state: State::Data,
            sub_option: 0,
            sub: Vec::new(),
        }
    }

    /// Filters `bytes`: data to `out`, commands returned.
    pub fn push(&mut self, bytes: &[u8], out: &mut Vec<u8>) -> Vec<TelnetCommand> {
        let mut commands = Vec::new();
        for &b in bytes {
            self.state = match self.state {
                State::Data if b == IAC => State::Iac,
                State::Data => {
                    out.push(b);
                    State::Data
                }
                State::Iac => match b {
                    IAC => {
                        out.push(IAC);
                        State::Data
                    }
                    WILL | WONT | DO | DONT => State::Verb(b),
                    SB => State::SubOption,
                    other => {
                        commands.push(TelnetCommand::Other(other));
                        State::Data
                    }
                },
                State::Verb(verb) => {
                    commands.push(TelnetCommand::Negotiate { verb, option: b });
                    State::Data
                }
                State::SubOption => {
                    self.sub_option = b;
                    self.sub.clear();
                    State::Sub
                }
                State::Sub if b == IAC => State::SubIac,
                State::Sub => {
                    if self.sub.len() < MAX_SUBNEGOTIATION {
                        self.sub.push(b);
                    }
                    State::Sub
                }
                State::SubIac => match b {
                    SE => {
                        commands.push(TelnetCommand::Subnegotiation {
                            option: self.sub_option,
                            data: std::mem::take(&mut self.sub),
                        });
                        State::Data
                    }
                    IAC => {
                        if self.sub.len() < MAX_SUBNEGOTIATION {
                            self.sub.push(IAC);
                        }
                        State::Sub
                    }
                    // A command inside a subnegotiation: end it there (lenient, as telnet
                    // servers are).
                    _ => State::Data,
                },
            };
        }
        commands
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_controllers_opening_is_four_commands_and_no_data() {
        let mut f = TelnetFilter::new();
        let mut out = Vec::new();
        let cmds = f.push(CONTROLLER_OPENING, &mut out);
        assert!(out.is_empty());
        assert_eq!(
            cmds,
            vec![
                TelnetCommand::Negotiate {
                    verb: DO,
                    option: OPT_TERMINAL_TYPE
                },
                TelnetCommand::Negotiate {
                    verb: WILL,
                    option: OPT_ECHO
                },
                TelnetCommand::Subnegotiation {
                    option: OPT_TERMINAL_TYPE,
                    data: vec![1, 1]
                },
                TelnetCommand::Negotiate {
                    verb: WILL,
                    option: OPT_SUPPRESS_GO_AHEAD
                },
            ]
        );
    }

    #[test]
    fn commands_split_anywhere_are_found_and_iac_iac_is_one_literal_byte() {
        let mut stream = b"ab".to_vec();
        stream.extend_from_slice(&[IAC, DO, 1, IAC, IAC]);
        stream.extend_from_slice(b"c");
        stream.extend_from_slice(&[IAC, SB, 24, 0, b'V', IAC, IAC, IAC, SE, b'd']);
        for cut in 0..=stream.len() {
            let mut f = TelnetFilter::new();
            let mut out = Vec::new();
            let mut cmds = f.push(&stream[..cut], &mut out);
            cmds.extend(f.push(&stream[cut..], &mut out));
            assert_eq!(out, [b'a', b'b', IAC, b'c', b'd'], "cut at {cut}");
            assert_eq!(cmds.len(), 2, "cut at {cut}");
            assert_eq!(
                cmds[1],
                TelnetCommand::Subnegotiation {
                    option: 24,
                    data: vec![0, b'V', IAC]
                }
            );
        }
    }

    #[test]
    fn an_endless_subnegotiation_does_not_grow_the_filter() {
        let mut f = TelnetFilter::new();
        let mut out = Vec::new();
        f.push(&[IAC, SB, 24], &mut out);
        f.push(&vec![b'x'; 10_000], &mut out);
        let cmds = f.push(&[IAC, SE], &mut out);
        match &cmds[0] {
            TelnetCommand::Subnegotiation { data, .. } => {
                assert_eq!(data.len(), MAX_SUBNEGOTIATION)
            }
            other => panic!("{other:?}"),
        }
    }
}
