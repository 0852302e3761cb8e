//! The sections of an AS file, as a controller saves them (`SAVE`, a backup) and as editors
//! write them: which ones this crate reads, and where each one ends.
//!
//! A section starts with a line `.NAME …` at the start of a line (blanks before it allowed).
//! [`SECTIONS`] says, for every section name known here, whether it is closed by `.END` or is
//! one line long, and what the loader does with it. The rule for where a section ends:
//!
//! - a `.PROGRAM` ends at its `.END` (lines in its body that start with `.` are local
//!   variables, not sections);
//! - a one-line section (`.NETCONF`, `.LANGUAGE ENGLISH`, …) is that line;
//! - any other section — known or not — ends at its `.END`, or, when a line that begins a
//!   *known* section comes first, just before that line (the section had no `.END`, as saves
//!   of `.SIG_COMMENT` sometimes do; the loader warns).
//!
//! Sections that are not read are kept as opaque, reported sections (name and line range in
//! [`crate::ast::Module::sections`]): they never swallow their neighbours.

/// Where a section ends.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum SectionEnd {
    /// At a line `.END`.
    EndLine,
    /// The section is its own line (a directive).
    OneLine,
}

/// What the loader does with a section.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum SectionUse {
    /// `.PROGRAM name(params)` … `.END`: parsed and compiled.
    Program,
    /// `.REALS`, `.STRINGS`, `.JOINTS`, `.TRANS`: the values are loaded into the globals.
    Data,
    /// `.SYSDATA`: the `SWITCH name ON|OFF` lines are read (the AUTOSTART switches), the rest
    /// is kept opaque.
    SysData,
    /// Kept as it is and reported (a controller setting, a log, a comment table…).
    Opaque,
}

/// A section this crate knows: name (lower case, without the dot), where it ends, its use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SectionKind {
    /// The name after the dot, lower case.
    pub name: &'static str,
    /// Where it ends.
    pub end: SectionEnd,
    /// What the loader does with it.
    pub reads: SectionUse,
}

const fn kind(name: &'static str, end: SectionEnd, reads: SectionUse) -> SectionKind {
    SectionKind { name, end, reads }
}

use SectionEnd::{EndLine, OneLine};
use SectionUse::{Data, Opaque, Program, SysData};

/// Every section name known here. Names seen in saves of C, D, E and F controllers and of
/// their editors; a name that is not here is an unknown section, kept opaque (see the rule in
/// the module documentation).
pub const SECTIONS: &[SectionKind] = &[
    kind("program", EndLine, Program),
    kind("reals", EndLine, Data),
    kind("strings", EndLine, Data),
    kind("joints", EndLine, Data),
    kind("trans", EndLine, Data),
    kind("sysdata", EndLine, SysData),
    kind("netconf", OneLine, Opaque),
    kind("netconf2", OneLine, Opaque),
    kind("savetime", OneLine, Opaque),
    kind("language", OneLine, Opaque),
    kind("auxdata", EndLine, Opaque),
    kind("robotdata1", EndLine, Opaque),
    kind("robotdata2", EndLine, Opaque),
    kind("robotdata3", EndLine, Opaque),
    kind("robotdata4", EndLine, Opaque),
    kind("inter_panel_d", EndLine, Opaque),
    kind("inter_panel_title", EndLine, Opaque),
    kind("inter_panel_color_d", EndLine, Opaque),
    kind("sig_comment", EndLine, Opaque),
    kind("klogic_data", EndLine, Opaque),
    kind("opelog", EndLine, Opaque),
    kind("errlog", EndLine, Opaque),
    kind("oplog", EndLine, Opaque),
    kind("syslog", EndLine, Opaque),
];

/// The known section called `name` (lower case, without the dot).
pub fn section(name: &str) -> Option<&'static SectionKind> {
    SECTIONS.iter().find(|k| k.name == name)
}

/// `.WORD rest` at the start of a trimmed line: the word (lower case) and the bytes after it.
/// `None` when the line does not start with a dot and a letter.
pub fn directive(trimmed: &[u8]) -> Option<(String, &[u8])> {
    let rest = trimmed.strip_prefix(b".")?;
    let end = rest
        .iter()
        .position(|c| !(c.is_ascii_alphanumeric() || *c == b'_'))
        .unwrap_or(rest.len());
    if end == 0 || !rest[0].is_ascii_alphabetic() {
        return None;
    }
    Some((
        String::from_utf8_lossy(&rest[..end]).to_ascii_lowercase(),
        &rest[end..],
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_sections_are_found_by_name() {
        assert_eq!(section("netconf").map(|k| k.end), Some(OneLine));
        assert_eq!(section("sig_comment").map(|k| k.end), Some(EndLine));
        assert_eq!(section("program").map(|k| k.reads), Some(Program));
        assert!(section("nothing_like_it").is_none());
        assert_eq!(
            directive(b".LANGUAGE ENGLISH"),
            Some(("language".to_owned(), &b" ENGLISH"[..]))
        );
        assert_eq!(directive(b".*header"), None);
        assert_eq!(directive(b".5"), None);
    }
}
