//! Input lines as the controller reads them: CR, LF and CR LF each end one line (terminals
//! send any of the three); at most [`crate::text::MAX_LINE_CHARS`] characters
//! are kept, the rest of the line is ignored; backspace and delete remove the last character.

use crate::text::MAX_LINE_CHARS;

/// Backspace.
const BS: u8 = 0x08;
/// Delete.
const DEL: u8 = 0x7F;

/// Assembles lines from a byte stream split anywhere. Never panics, whatever the bytes.
#[derive(Debug, Clone, Default)]
pub struct LineReader {
    line: Vec<u8>,
    after_cr: bool,
    cut: bool,
}

/// One line read.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Line {
    /// The bytes kept (at most [`MAX_LINE_CHARS`]), without the line end.
    pub bytes: Vec<u8>,
    /// Characters beyond the limit were ignored.
    pub cut: bool,
}

impl Line {
    /// The line as text (bytes outside ASCII shown as U+FFFD).
    pub fn text(&self) -> String {
        String::from_utf8_lossy(&self.bytes).into_owned()
    }
}

impl LineReader {
    /// An empty reader.
    pub fn new() -> LineReader {
        LineReader::default()
    }

    /// The bytes of the line begun and not ended yet.
    pub fn pending(&self) -> &[u8] {
        &self.line
    }

    /// Reads `bytes`, appending each line they end to `out`.
    pub fn push(&mut self, bytes: &[u8], out: &mut Vec<Line>) {
        for &b in bytes {
            let after_cr = std::mem::replace(&mut self.after_cr, false);
            match b {
                b'\n' if after_cr => {}
                b'\r' | b'\n' => {
                    self.after_cr = b == b'\r';
                    out.push(Line {
                        bytes: std::mem::take(&mut self.line),
                        cut: std::mem::replace(&mut self.cut, false),
                    });
                }
                BS | DEL => {
                    self.line.pop();
                }
                0 => {}
                _ if self.line.len() < MAX_LINE_CHARS => self.line.push(b),
                _ => self.cut = true,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lines(bytes: &[u8]) -> Vec<String> {
        let mut r = LineReader::new();
        let mut out = Vec::new();
        for b in bytes {
            r.push(std::slice::from_ref(b), &mut out);
        }
        out.iter().map(Line::text).collect()
    }

    #[test]
    fn cr_lf_and_cr_lf_each_end_one_line() {
        assert_eq!(lines(b"a\rb\nc\r\nd\n\re"), ["a", "b", "c", "d", ""]);
    }

    #[test]
    fn a_line_keeps_its_first_128_characters_and_says_it_was_cut() {
        let mut long = vec![b'x'; 200];
        long.push(b'\n');
        let mut r = LineReader::new();
        let mut out = Vec::new();
        r.push(&long, &mut out);
        assert_eq!(out[0].bytes.len(), MAX_LINE_CHARS);
        assert!(out[0].cut);
        r.push(b"ok\n", &mut out);
        assert!(!out[1].cut);
    }

    #[test]
    fn backspace_removes_the_last_character() {
        assert_eq!(lines(b"IDX\x08\r"), ["ID"]);
    }
}
