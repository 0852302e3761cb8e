//! One line of a data section (`.REALS`, `.STRINGS`, `.JOINTS`, `.TRANS`).

use crate::ast::{DataItem, DataValue};
use crate::error::ParseError;
use crate::lexer::{Sigil, Tok};

use super::cursor::{Cur, PResult};

impl Cur<'_> {
    pub(super) fn data_item(&mut self, section: &str) -> PResult<DataItem> {
        let span = self.span();
        let name = match self.next().map(|t| t.tok) {
            Some(Tok::Name(n)) if !n.local => n,
            other => {
                return Err(ParseError::new(
                    self.file,
                    span,
                    format!(
                        "expected a global variable name, found {}",
                        other.map_or("the end of the line".into(), |t| t.describe())
                    ),
                ))
            }
        };
        let (want, what) = match section {
            "reals" => (Sigil::None, "a real variable such as count = 1"),
            "strings" => (Sigil::Dollar, "a string variable such as $name = \"text\""),
            "joints" => (Sigil::Hash, "a joint point such as #home 0 0 -90 0 -90 0"),
            _ => (
                Sigil::None,
                "a transformation such as pick 850 0 1153.5 0 180 0",
            ),
        };
        if name.sigil != want {
            return Err(ParseError::new(
                self.file,
                span,
                format!(
                    "the .{} section holds {what}, found {name}",
                    section.to_uppercase()
                ),
            ));
        }
        let mut indices = Vec::new();
        if self.eat(&Tok::LBracket) {
            loop {
                let v = self.signed_number("an array index")?;
                if v.fract() != 0.0 || !(0.0..=9999.0).contains(&v) {
                    return Err(self.err("an array index is an integer from 0 to 9999"));
                }
                indices.push(v as i32);
                if indices.len() > 3 {
                    return Err(self.err("an array has at most 3 dimensions"));
                }
                if self.eat(&Tok::RBracket) {
                    break;
                }
                self.expect(&Tok::Comma, "\",\" or \"]\" in the array index")?;
            }
        }
        let value = match section {
            "reals" => {
                self.expect(&Tok::Assign, "\"=\" after the variable")?;
                DataValue::Real(self.signed_number("the value")?)
            }
            "strings" => {
                self.expect(&Tok::Assign, "\"=\" after the variable")?;
                let sspan = self.span();
                match self.next().map(|t| t.tok) {
                    Some(Tok::Str(s)) => DataValue::Str(s),
                    other => {
                        return Err(ParseError::new(
                            self.file,
                            sspan,
                            format!(
                                "expected a string in quotes, found {}",
                                other.map_or("the end of the line".into(), |t| t.describe())
                            ),
                        ))
                    }
                }
            }
            _ => {
                let mut v = [0.0; 6];
                let mut n = 0;
                while !self.at_end() {
                    self.eat(&Tok::Comma);
                    if n == 6 {
                        return Err(self.err("expected at most 6 values"));
                    }
                    v[n] = self.signed_number("a value")?;
                    n += 1;
                }
                if n == 0 {
                    return Err(self.err("expected the values after the name"));
                }
                if section == "joints" {
                    DataValue::Joints(v)
                } else {
                    DataValue::Trans(v)
                }
            }
        };
        self.expect_end("the data line")?;
        Ok(DataItem {
            name,
            indices,
            value,
            span,
        })
    }
}
