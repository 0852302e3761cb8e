//! Expressions, by the manual's precedence (AS-E p.3-22), and what they are built of:
//! variables with their indices, function calls with their arguments (omitted values, a
//! `SYSDATA` keyword, format codes in `$ENCODE`), `#[…]` joint constants, signed numbers.

use crate::ast::{Arg, BinOp, Expr, ExprKind, LValue, UnOp};
use crate::error::ParseError;
use crate::keywords;
use crate::lexer::{Name, Sigil, Tok};

use super::cursor::{Cur, PResult, RobotNumber, MAX_NESTING};

impl Cur<'_> {
    pub(super) fn lvalue(&mut self) -> PResult<LValue> {
        let span = self.span();
        let name = match self.next().map(|t| t.tok) {
            Some(Tok::Name(n)) => n,
            other => {
                return Err(ParseError::new(
                    self.file,
                    span,
                    format!(
                        "expected a variable, found {}",
                        other.map_or("the end of the line".into(), |t| t.describe())
                    ),
                ))
            }
        };
        let indices = self.indices()?;
        Ok(LValue {
            name,
            indices,
            span,
        })
    }

    pub(super) fn indices(&mut self) -> PResult<Vec<Expr>> {
        let mut v = Vec::new();
        if self.eat(&Tok::LBracket) {
            if self.peek() == Some(&Tok::RBracket) {
                return Err(self.err("expected an array index between [ and ]"));
            }
            loop {
                if v.len() == 3 {
                    return Err(self.err("an array has at most 3 dimensions"));
                }
                v.push(self.expr()?);
                if self.eat(&Tok::RBracket) {
                    break;
                }
                self.expect(&Tok::Comma, "\",\" or \"]\" in the array index")?;
            }
        }
        Ok(v)
    }

    pub(super) fn expr(&mut self) -> PResult<Expr> {
        self.depth += 1;
        if self.depth > MAX_NESTING {
            return Err(self.err(format!(
                "expression nested deeper than {MAX_NESTING} levels"
            )));
        }
        let r = self.xor_expr();
        self.depth -= 1;
        r
    }

    pub(super) fn binary_level(
        &mut self,
        ops: &[(&str, BinOp)],
        sym: &[(Tok, BinOp)],
        next: fn(&mut Self) -> PResult<Expr>,
    ) -> PResult<Expr> {
        let mut left = next(self)?;
        loop {
            let span = self.span();
            let op = if let Some(w) = self.word() {
                ops.iter().find(|(k, _)| *k == w).map(|(_, o)| *o)
            } else {
                self.peek()
                    .and_then(|t| sym.iter().find(|(k, _)| k == t).map(|(_, o)| *o))
            };
            let Some(op) = op else { break };
            self.pos += 1;
            let right = next(self)?;
            left = Expr {
                kind: ExprKind::Binary(op, Box::new(left), Box::new(right)),
                span,
            };
        }
        Ok(left)
    }

    pub(super) fn xor_expr(&mut self) -> PResult<Expr> {
        self.binary_level(&[("xor", BinOp::Xor)], &[], Self::or_expr)
    }

    pub(super) fn or_expr(&mut self) -> PResult<Expr> {
        self.binary_level(
            &[("or", BinOp::Or)],
            &[(Tok::Bar, BinOp::Or)],
            Self::and_expr,
        )
    }

    pub(super) fn and_expr(&mut self) -> PResult<Expr> {
        self.binary_level(&[("and", BinOp::And)], &[], Self::bxor_expr)
    }

    pub(super) fn bxor_expr(&mut self) -> PResult<Expr> {
        self.binary_level(&[("bxor", BinOp::Bxor)], &[], Self::bor_expr)
    }

    pub(super) fn bor_expr(&mut self) -> PResult<Expr> {
        self.binary_level(&[("bor", BinOp::Bor)], &[], Self::band_expr)
    }

    pub(super) fn band_expr(&mut self) -> PResult<Expr> {
        self.binary_level(&[("band", BinOp::Band)], &[], Self::rel_expr)
    }

    pub(super) fn rel_expr(&mut self) -> PResult<Expr> {
        let e = self.binary_level(
            &[],
            &[
                (Tok::Eq, BinOp::Eq),
                (Tok::Ne, BinOp::Ne),
                (Tok::Lt, BinOp::Lt),
                (Tok::Gt, BinOp::Gt),
                (Tok::Le, BinOp::Le),
                (Tok::Ge, BinOp::Ge),
            ],
            Self::add_expr,
        )?;
        Ok(e)
    }

    pub(super) fn add_expr(&mut self) -> PResult<Expr> {
        self.binary_level(
            &[],
            &[(Tok::Plus, BinOp::Add), (Tok::Minus, BinOp::Sub)],
            Self::mod_expr,
        )
    }

    pub(super) fn mod_expr(&mut self) -> PResult<Expr> {
        self.binary_level(&[("mod", BinOp::Mod)], &[], Self::mul_expr)
    }

    pub(super) fn mul_expr(&mut self) -> PResult<Expr> {
        self.binary_level(
            &[],
            &[(Tok::Star, BinOp::Mul), (Tok::Slash, BinOp::Div)],
            Self::unary_expr,
        )
    }

    pub(super) fn unary_expr(&mut self) -> PResult<Expr> {
        let span = self.span();
        let op = if self.eat(&Tok::Minus) {
            Some(UnOp::Neg)
        } else if self.eat(&Tok::Plus) {
            return self.unary_expr_nested();
        } else if self.eat_word("com") {
            Some(UnOp::Com)
        } else if self.eat_word("not") {
            Some(UnOp::Not)
        } else {
            None
        };
        match op {
            Some(op) => {
                let e = self.unary_expr_nested()?;
                Ok(Expr {
                    kind: ExprKind::Unary(op, Box::new(e)),
                    span,
                })
            }
            None => self.pow_expr(),
        }
    }

    pub(super) fn unary_expr_nested(&mut self) -> PResult<Expr> {
        self.depth += 1;
        if self.depth > MAX_NESTING {
            return Err(self.err(format!(
                "expression nested deeper than {MAX_NESTING} levels"
            )));
        }
        let r = self.unary_expr();
        self.depth -= 1;
        r
    }

    pub(super) fn pow_expr(&mut self) -> PResult<Expr> {
        let base = self.primary()?;
        let span = self.span();
        if self.eat(&Tok::Caret) {
            // Right-associative; the exponent may carry a sign.
            let exp = self.unary_expr_nested()?;
            return Ok(Expr {
                kind: ExprKind::Binary(BinOp::Pow, Box::new(base), Box::new(exp)),
                span,
            });
        }
        Ok(base)
    }

    pub(super) fn primary(&mut self) -> PResult<Expr> {
        let span = self.span();
        let Some(tok) = self.next() else {
            return Err(ParseError::new(
                self.file,
                span,
                "expected a value, found the end of the line",
            ));
        };
        let kind = match tok.tok {
            Tok::Num(v) => ExprKind::Num(v),
            Tok::Str(s) => ExprKind::Str(s),
            // `#[j1, j2, …]`: a joint-value constant, the same as `#PPOINT(j1, j2, …)`
            // (omitted values are 0).
            Tok::HashBracket => {
                let name = Name {
                    local: false,
                    sigil: Sigil::Hash,
                    text: "ppoint".into(),
                };
                let mut args = Vec::new();
                if !self.eat(&Tok::RBracket) {
                    loop {
                        args.push(self.arg_or_omitted(&[Tok::Comma, Tok::RBracket])?);
                        if self.eat(&Tok::RBracket) {
                            break;
                        }
                        self.expect(&Tok::Comma, "\",\" or \"]\" in the joint values #[…]")?;
                    }
                }
                ExprKind::Call { name, args }
            }
            Tok::LParen => {
                let e = self.expr()?;
                self.expect(&Tok::RParen, "\")\" to close the parenthesis")?;
                return Ok(e);
            }
            Tok::Name(mut name) => {
                let name_span = span;
                // `INRANGE:2(…)`, `#S_HERE:2`: a function of robot n. Robot 1 is this robot;
                // another's is a function the emulator does not compute (not emulated).
                let robot_after_colon = self.robot_number_at(1);
                if let (false, Some(Tok::Colon), Some(robot)) =
                    (name.local, self.peek(), robot_after_colon)
                {
                    let at = self.pos;
                    let robot_one = robot == RobotNumber::This;
                    self.pos += 1;
                    // The robot number: a number or a variable (`CVPOS2:arm[.i](…)`).
                    let robot = match self.next().map(|t| t.tok) {
                        Some(Tok::Name(_)) => self.indices().map(|_| ()),
                        _ => Ok(()),
                    };
                    // A function without arguments may take its robot too (`SACHK:.rno`).
                    let function = keywords::get(&name.to_string())
                        .is_some_and(|k| k.roles.contains(keywords::Role::FUNCTION));
                    if robot.is_ok() && self.peek() == Some(&Tok::LParen) {
                        if !robot_one {
                            name.text.push_str(":n");
                        }
                    } else if robot.is_ok() && function {
                        if !robot_one {
                            name.text.push_str(":n");
                        }
                        let span = name_span;
                        return Ok(Expr {
                            kind: ExprKind::Call {
                                name,
                                args: Vec::new(),
                            },
                            span,
                        });
                    } else {
                        self.pos = at;
                    }
                }
                if !name.local && self.peek() == Some(&Tok::LParen) {
                    self.pos += 1;
                    let args = self.func_args(&name)?;
                    ExprKind::Call { name, args }
                } else {
                    if !name.local && name.sigil == Sigil::None && is_operator_word(&name.text) {
                        return Err(ParseError::new(
                            self.file,
                            span,
                            format!(
                                "expected a value, found the operator {}",
                                name.text.to_uppercase()
                            ),
                        ));
                    }
                    let indices = self.indices()?;
                    ExprKind::Var(LValue {
                        name,
                        indices,
                        span,
                    })
                }
            }
            Tok::Assign => {
                return Err(ParseError::new(
                    self.file,
                    span,
                    "expected a value, found \"=\" (a comparison is written ==)",
                ));
            }
            other => {
                return Err(ParseError::new(
                    self.file,
                    span,
                    format!("expected a value, found {}", other.describe()),
                ));
            }
        };
        Ok(Expr { kind, span })
    }

    pub(super) fn func_args(&mut self, name: &Name) -> PResult<Vec<Arg>> {
        let mut args = Vec::new();
        if self.eat(&Tok::RParen) {
            return Ok(args);
        }
        let formats = name.sigil == Sigil::Dollar && name.text == "encode";
        // `SHIFT(location BY dx, dy, dz)`: BY separates the location from the offsets.
        let shift = name.sigil == Sigil::None && name.text == "shift";
        // `SYSDATA(STEP)`, `$SYSDATA(ZROB.NAME, 1)`: the first argument is a keyword.
        let sysdata = name.text == "sysdata" && !name.local;
        loop {
            if formats && self.peek() == Some(&Tok::Slash) {
                let span = self.span();
                self.pos += 1;
                // A format code this loader does not know (`/I` without a width): kept as a
                // word; the statement loads as not emulated.
                let at = self.pos;
                match self.format_code(span) {
                    Ok(f) => args.push(Arg::Format(f, span)),
                    Err(e) => match self.toks.get(at).map(|t| &t.tok) {
                        Some(Tok::Name(n)) if !n.local && n.sigil == Sigil::None => {
                            args.push(Arg::Keyword(format!("/{}", n.text), span))
                        }
                        _ => return Err(e),
                    },
                }
            } else if sysdata && args.is_empty() {
                let span = self.span();
                match self.next().map(|t| t.tok) {
                    Some(Tok::Name(n)) if !n.local && n.sigil == Sigil::None => {
                        args.push(Arg::Keyword(n.text, span))
                    }
                    other => {
                        return Err(ParseError::new(
                            self.file,
                            span,
                            format!(
                                "expected a SYSDATA keyword such as STEP or M.SPEED, found {}",
                                other.map_or("the end of the line".into(), |t| t.describe())
                            ),
                        ))
                    }
                }
            } else {
                args.push(self.arg_or_omitted(&[Tok::Comma, Tok::RParen])?);
            }
            if self.eat(&Tok::RParen) {
                break;
            }
            if shift && args.len() == 1 && self.eat_word("by") {
                continue;
            }
            self.expect(
                &Tok::Comma,
                &format!("\",\" or \")\" in the arguments of {name}"),
            )?;
        }
        Ok(args)
    }

    /// A function argument, or an omitted one (`TRANS(, -100)`, `SHIFT(p BY , , 50)`): the
    /// next token is one of `enders`.
    pub(super) fn arg_or_omitted(&mut self, enders: &[Tok]) -> PResult<Arg> {
        match self.peek() {
            Some(t) if enders.contains(t) => Ok(Arg::Omitted(self.span())),
            _ => Ok(Arg::Expr(self.expr()?)),
        }
    }

    pub(super) fn signed_number(&mut self, what: &str) -> PResult<f64> {
        let neg = if self.eat(&Tok::Minus) {
            true
        } else {
            self.eat(&Tok::Plus);
            false
        };
        let span = self.span();
        match self.next().map(|t| t.tok) {
            Some(Tok::Num(v)) => Ok(if neg { -v } else { v }),
            other => Err(ParseError::new(
                self.file,
                span,
                format!(
                    "expected {what} (a number), found {}",
                    other.map_or("the end of the line".into(), |t| t.describe())
                ),
            )),
        }
    }
}

fn is_operator_word(w: &str) -> bool {
    matches!(
        w,
        "and"
            | "or"
            | "xor"
            | "mod"
            | "band"
            | "bor"
            | "bxor"
            | "then"
            | "do"
            | "to"
            | "step"
            | "of"
            | "goto"
    )
}
