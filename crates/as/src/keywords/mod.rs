//! Every AS keyword, as data: the one table the parser, the lint, `as check`, the emulated
//! terminal and docs/AS.md read.
//!
//! A row ([`Keyword`]) says what a word is — a program instruction, a monitor command (and
//! whether it may follow `MC`), an editor command, a function, a system switch, a `SYSDATA`
//! keyword or a structure word — with the argument grammar of each role, the controller
//! generations that have it, the manual's shortest abbreviation, and which roles the emulator
//! runs (its `runs` field).
//!
//! **Abbreviations.** Like the controller, a keyword may be shortened to any prefix at least as
//! long as its abbreviation in the manual's language list (`JM` = `JMOVE`, `PCEX` = `PCEXECUTE`);
//! a keyword without one must be spelled out. The manual's abbreviations are not unique across
//! the roles (`EX` is `EXECUTE` at the monitor and `EXTCALL` in a program): a word is resolved
//! among the keywords of one role ([`lookup`]), and a word that is a valid short form of two
//! keywords of that role is [`Lookup::Ambiguous`] — the controller's P0110 "Specify full
//! spelling of command.".
//!
//! **Load policy.** A program line whose instruction is in this table but not run by the
//! emulator, or whose first word is in no table at all, loads as *not emulated*: its syntax is
//! checked, it is listed as a warning, and a task that reaches it stops with E0199 (or goes on,
//! when the user stubs it). docs/AS.md explains the policy.

mod table;

use std::collections::HashMap;
use std::sync::OnceLock;

/// The grammar of a role whose arguments are not documented (a keyword known only from real
/// files or from other tools): any well-formed argument list.
pub const UNKNOWN_GRAMMAR: &str = "?";

/// What a keyword is; a keyword may have several roles (`SPEED` is an instruction and a monitor
/// command, `BITS` an instruction and a function). A small set of flags.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub struct Role(u16);

impl Role {
    /// No role.
    pub const NONE: Role = Role(0);
    /// A program instruction (a step of a `.PROGRAM`).
    pub const INSTRUCTION: Role = Role(1);
    /// A monitor command (typed at the `>` prompt).
    pub const MONITOR: Role = Role(1 << 1);
    /// A monitor command a PC program may give through `MC`.
    pub const AFTER_MC: Role = Role(1 << 2);
    /// An editor command (valid inside `EDIT` only).
    pub const EDITOR: Role = Role(1 << 3);
    /// A function, used inside expressions.
    pub const FUNCTION: Role = Role(1 << 4);
    /// A system switch (`name ON`, `SWITCH(name)`).
    pub const SWITCH: Role = Role(1 << 5);
    /// A keyword of `SYSDATA(…)`.
    pub const SYSDATA: Role = Role(1 << 6);
    /// A word inside other statements (`THEN`, `TO`, `BY`, operators, constants).
    pub const WORD: Role = Role(1 << 7);

    /// Both sets of roles.
    pub const fn or(self, other: Role) -> Role {
        Role(self.0 | other.0)
    }

    /// Whether every role of `other` is in `self` (and `other` is not empty).
    pub const fn contains(self, other: Role) -> bool {
        other.0 != 0 && self.0 & other.0 == other.0
    }

    /// Whether the two share a role.
    pub const fn intersects(self, other: Role) -> bool {
        self.0 & other.0 != 0
    }

    /// The names of the roles, for messages and docs.
    pub fn names(self) -> Vec<&'static str> {
        [
            (Role::INSTRUCTION, "instruction"),
            (Role::MONITOR, "monitor command"),
            (Role::AFTER_MC, "after MC"),
            (Role::EDITOR, "editor command"),
            (Role::FUNCTION, "function"),
            (Role::SWITCH, "system switch"),
            (Role::SYSDATA, "SYSDATA keyword"),
            (Role::WORD, "word"),
        ]
        .into_iter()
        .filter(|(r, _)| self.contains(*r))
        .map(|(_, n)| n)
        .collect()
    }
}

/// The controller generations that have a keyword (C, D, E, F series). The E manual is the
/// reference: its keywords are marked E and F (F controllers run E programs); keywords known
/// only from F-series saves and newer tools are marked F; the TCP/IP option's words D, E, F.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Generations(u8);

impl Generations {
    /// C series.
    pub const C: Generations = Generations(1);
    /// D series.
    pub const D: Generations = Generations(1 << 1);
    /// E series.
    pub const E: Generations = Generations(1 << 2);
    /// F series.
    pub const F: Generations = Generations(1 << 3);
    /// E and F.
    pub const E_F: Generations = Generations(1 << 2 | 1 << 3);
    /// D, E and F.
    pub const D_E_F: Generations = Generations(1 << 1 | 1 << 2 | 1 << 3);
    /// Every generation (the core language).
    pub const ALL: Generations = Generations(0b1111);

    /// Whether `g` (one generation) is among these.
    pub const fn has(self, g: Generations) -> bool {
        self.0 & g.0 != 0
    }

    /// The letters, `"EF"`.
    pub fn letters(self) -> String {
        [
            (Self::C, 'C'),
            (Self::D, 'D'),
            (Self::E, 'E'),
            (Self::F, 'F'),
        ]
        .into_iter()
        .filter(|(g, _)| self.has(*g))
        .map(|(_, c)| c)
        .collect()
    }
}

/// One AS keyword.
///
/// Argument grammars use this crate's notation: `snake_case` words are values,
/// `[…]` may be omitted (a comma that follows an omitted value stays, trailing ones may go),
/// `…` repeats, UPPER-CASE words are literal keywords (`ALWAYS`, `TILL`, `BY`), `n:` prefixes
/// are written `number :`, `/Q` is a qualifier, `name[]` an array. An empty grammar means no
/// arguments; [`UNKNOWN_GRAMMAR`] means undocumented.
#[derive(Debug, Clone, Copy)]
pub struct Keyword {
    /// The keyword in lower case, with its `$`/`#` sigil for functions (`$mid`, `#ppoint`).
    pub name: &'static str,
    /// The manual's shortest form, lower case (`jm` for `jmove`); `None`: no shorter form.
    pub abbr: Option<&'static str>,
    /// The grammar as a program instruction.
    pub instruction: Option<&'static str>,
    /// The grammar as a monitor command.
    pub monitor: Option<&'static str>,
    /// The grammar as an editor command.
    pub editor: Option<&'static str>,
    /// The grammar of the function's arguments.
    pub function: Option<&'static str>,
    /// Every role (instruction, monitor, function…).
    pub roles: Role,
    /// The generations that have it.
    pub generations: Generations,
    /// The roles the emulator runs. A role the keyword has but the emulator does not run
    /// loads as not emulated.
    pub runs: Role,
}

impl Keyword {
    const fn new(name: &'static str) -> Keyword {
        Keyword {
            name,
            abbr: None,
            instruction: None,
            monitor: None,
            editor: None,
            function: None,
            roles: Role::NONE,
            generations: Generations::E_F,
            runs: Role::NONE,
        }
    }
    const fn abbr(mut self, a: &'static str) -> Keyword {
        self.abbr = Some(a);
        self
    }
    const fn instruction(mut self, g: &'static str) -> Keyword {
        self.instruction = Some(g);
        self.roles = self.roles.or(Role::INSTRUCTION);
        self
    }
    const fn monitor(mut self, g: &'static str) -> Keyword {
        self.monitor = Some(g);
        self.roles = self.roles.or(Role::MONITOR);
        self
    }
    const fn editor(mut self, g: &'static str) -> Keyword {
        self.editor = Some(g);
        self.roles = self.roles.or(Role::EDITOR);
        self
    }
    const fn function(mut self, g: &'static str) -> Keyword {
        self.function = Some(g);
        self.roles = self.roles.or(Role::FUNCTION);
        self
    }
    const fn switch(mut self) -> Keyword {
        self.roles = self.roles.or(Role::SWITCH);
        self
    }
    const fn sysdata(mut self) -> Keyword {
        self.roles = self.roles.or(Role::SYSDATA);
        self
    }
    const fn word(mut self) -> Keyword {
        self.roles = self.roles.or(Role::WORD);
        self
    }
    const fn after_mc(mut self) -> Keyword {
        self.roles = self.roles.or(Role::AFTER_MC).or(Role::MONITOR);
        self
    }
    const fn generations(mut self, g: Generations) -> Keyword {
        self.generations = g;
        self
    }
    const fn runs(mut self, r: Role) -> Keyword {
        self.runs = r;
        self
    }

    /// The shortest prefix that names this keyword (its abbreviation, or the whole name).
    pub fn shortest(&self) -> &'static str {
        self.abbr.unwrap_or(self.name)
    }

    /// Whether `word` names this keyword: the name, or a prefix of it at least as long as
    /// the abbreviation.
    pub fn accepts(&self, word: &str) -> bool {
        word == self.name || (word.len() >= self.shortest().len() && self.name.starts_with(word))
    }

    /// The grammar of `role` (one role).
    pub fn grammar(&self, role: Role) -> Option<&'static str> {
        if role == Role::INSTRUCTION {
            self.instruction
        } else if role == Role::MONITOR || role == Role::AFTER_MC {
            self.monitor
        } else if role == Role::EDITOR {
            self.editor
        } else if role == Role::FUNCTION {
            self.function
        } else {
            None
        }
    }

    /// How many values the grammar of `role` takes: (at least, at most; `None` = no limit).
    /// `None` when the grammar is unknown.
    pub fn arity(&self, role: Role) -> Option<(usize, Option<usize>)> {
        arity(self.grammar(role)?)
    }
}

/// How many values a grammar in the table's notation takes: (at least, at most; `None` = no
/// limit). `None` for [`UNKNOWN_GRAMMAR`].
pub fn arity(grammar: &str) -> Option<(usize, Option<usize>)> {
    if grammar == UNKNOWN_GRAMMAR {
        return None;
    }
    // Positions are separated by commas (at any depth of `[…]`); a position counts when it
    // holds a value, and is required when that value is outside every `[…]`.
    let (mut min, mut max, mut unbounded) = (0usize, 0usize, false);
    let mut depth = 0usize;
    let (mut has_value, mut required) = (false, false);
    let b = grammar.as_bytes();
    let mut i = 0;
    let mut end_position = |has_value: &mut bool, required: &mut bool| {
        if *has_value {
            max += 1;
            min += usize::from(*required);
        }
        *has_value = false;
        *required = false;
    };
    while i < b.len() {
        let c = b[i];
        if c == b'[' {
            // `name[]`, `name[i]`: an array marker, not an optional part.
            if i > 0 && (b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_') {
                while i < b.len() && b[i] != b']' {
                    i += 1;
                }
            } else {
                depth += 1;
            }
        } else if c == b']' {
            depth = depth.saturating_sub(1);
        } else if c == b',' {
            end_position(&mut has_value, &mut required);
        } else if b[i..].starts_with("…".as_bytes()) {
            unbounded = true;
        } else if c.is_ascii_lowercase() || c == b'$' {
            while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_' || b[i] == b'$') {
                i += 1;
            }
            has_value = true;
            required |= depth == 0;
            continue;
        }
        i += 1;
    }
    end_position(&mut has_value, &mut required);
    Some((min, (!unbounded).then_some(max)))
}

/// The literal keywords a grammar requires (`TILL` in `XMOVE`'s): upper-case words outside
/// every `[…]`, lower case.
pub fn required_words(grammar: &str) -> Vec<String> {
    let mut depth = 0usize;
    let mut out = Vec::new();
    let mut word = String::new();
    // A word next to `|` is one of alternatives (`ON|OFF`): not required as such.
    let mut after_bar = false;
    for c in grammar.chars().chain(std::iter::once(' ')) {
        if c.is_ascii_uppercase()
            || (!word.is_empty() && (c.is_ascii_alphanumeric() || c == '_' || c == '.'))
        {
            word.push(c);
            continue;
        }
        if word.len() >= 2
            && depth == 0
            && c != '|'
            && !after_bar
            && !word.chars().any(|c| c.is_ascii_lowercase())
        {
            out.push(word.to_ascii_lowercase());
        }
        if !word.is_empty() || c != ' ' {
            after_bar = c == '|';
        }
        word.clear();
        match c {
            '[' => depth += 1,
            ']' => depth = depth.saturating_sub(1),
            _ => {}
        }
    }
    out
}

/// Every keyword, sorted by name (without the sigil).
pub fn table() -> &'static [Keyword] {
    table::TABLE
}

fn index() -> &'static HashMap<&'static str, usize> {
    static INDEX: OnceLock<HashMap<&'static str, usize>> = OnceLock::new();
    INDEX.get_or_init(|| {
        table::TABLE
            .iter()
            .enumerate()
            .map(|(i, k)| (k.name, i))
            .collect()
    })
}

/// The keyword spelled exactly `name` (lower case, with its sigil).
pub fn get(name: &str) -> Option<&'static Keyword> {
    index().get(name).map(|&i| &table::TABLE[i])
}

/// What a word names among the keywords of one role.
#[derive(Debug, Clone, Copy)]
pub enum Lookup {
    /// The keyword it names (spelled out or abbreviated).
    Found(&'static Keyword),
    /// A short form of two keywords of that role (P0110 on the controller): two of them.
    Ambiguous(&'static Keyword, &'static Keyword),
    /// No keyword of that role.
    Unknown,
}

/// Resolves `word` (lower case) among the keywords that have one of the roles in `role`.
pub fn lookup(word: &str, role: Role) -> Lookup {
    if let Some(k) = get(word) {
        if k.roles.intersects(role) {
            return Lookup::Found(k);
        }
    }
    let mut found: Option<&'static Keyword> = None;
    for k in table::TABLE {
        if k.roles.intersects(role) && k.accepts(word) {
            match found {
                None => found = Some(k),
                Some(f) => return Lookup::Ambiguous(f, k),
            }
        }
    }
    found.map_or(Lookup::Unknown, Lookup::Found)
}

/// The program instruction `word` names, when the emulator runs it as an instruction.
pub fn statement(word: &str) -> Option<&'static str> {
    match lookup(word, Role::INSTRUCTION) {
        Lookup::Found(k) if k.runs.contains(Role::INSTRUCTION) => Some(k.name),
        _ => None,
    }
}

/// The monitor command `word` names after `MC`, when the emulator runs it there.
pub fn monitor(word: &str) -> Option<&'static str> {
    match lookup(word, Role::MONITOR) {
        Lookup::Found(k) if k.runs.contains(Role::AFTER_MC) => Some(k.name),
        _ => None,
    }
}

/// Whether `word` (lower case, at the start of a statement) is a program instruction of the
/// table that the emulator does not run.
pub fn not_emulated(word: &str) -> bool {
    matches!(lookup(word, Role::INSTRUCTION), Lookup::Found(k) if !k.runs.contains(Role::INSTRUCTION))
}

/// A keyword one edit (a letter added, removed, changed, or two swapped) from `word`, among
/// the keywords of `role`: the lint's "did you mean". The first in table order.
pub fn did_you_mean(word: &str, role: Role) -> Option<&'static Keyword> {
    if word.len() < 3 {
        return None;
    }
    table::TABLE
        .iter()
        .find(|k| k.roles.intersects(role) && k.name != word && one_edit(word, k.name))
}

/// Whether `a` and `b` differ by one insertion, deletion, substitution or swap of neighbours.
fn one_edit(a: &str, b: &str) -> bool {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    if a.len().abs_diff(b.len()) > 1 {
        return false;
    }
    let p = a.iter().zip(b).take_while(|(x, y)| x == y).count();
    let (ra, rb) = (&a[p..], &b[p..]);
    match ra.len().cmp(&rb.len()) {
        std::cmp::Ordering::Equal => {
            ra.is_empty()
                || ra[1..] == rb[1..]
                || (ra.len() >= 2 && ra[0] == rb[1] && ra[1] == rb[0] && ra[2..] == rb[2..])
        }
        std::cmp::Ordering::Greater => ra[1..] == *rb,
        std::cmp::Ordering::Less => *ra == rb[1..],
    }
}

/// First words of a block-teaching step (`JOINT SPEED9 ACCU1 … #[…]`), when the line is a step
/// (its second word starts with `SPEED`, or it holds `#[`): `JOINT` and `LINEAR` steps run
/// (docs/AS.md, "Block-teaching steps"), the others load as not emulated.
pub const BLOCK_TEACHING: &[&str] = &[
    "joint",
    "linear",
    "linear2",
    "circular",
    "circular2",
    "cir1",
    "cir2",
    "xlinear",
    "fine",
    "flin",
    "flinear",
];

/// System switches that `name ON|OFF`, `ENABLE name`, `DISABLE name` and `SWITCH(name)`
/// know, with their power-on state: the switches the emulator keeps. Only `ABS.SPEED` changes
/// motion here; the others are remembered and reported.
pub const SYSTEM_SWITCHES: &[(&str, bool)] = &[
    ("abs.speed", false),
    ("after.wait.tmr", false),
    ("autostart.pc", false),
    ("autostart2.pc", false),
    ("autostart3.pc", false),
    ("autostart4.pc", false),
    ("autostart5.pc", false),
    ("auto_start", false),
    ("check.hold", false),
    ("cp", true),
    ("cyc.stop", false),
    ("disp.exestep", false),
    ("error", false),
    ("errstart.pc", false),
    ("hold.step", false),
    ("message", true),
    ("ox.preout", true),
    ("prefetch.sigins", false),
    ("prog.date", false),
    ("qtool", false),
    ("rep_once", false),
    ("repeatonce", false),
    ("rps", false),
    ("screen", true),
    ("stepone", false),
];

/// Status switches of the controller's hardware that `SWITCH(name)` reads and the emulator
/// reports from its panel (the emergency stops read OFF: none is pressed in the emulator).
pub const PANEL_SWITCHES: &[&str] = &[
    "power",
    "run",
    "repeat",
    "teach_lock",
    "cs",
    "error",
    "emergency",
    "safety_fence",
    "tp_emg",
    "op_emg",
    "ex_emg",
];

/// The power-on state of a system switch, `None` when the name is not one.
pub fn system_switch_default(name: &str) -> Option<bool> {
    SYSTEM_SWITCHES
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, v)| *v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn abbreviations_follow_the_manuals_language_list() {
        assert_eq!(monitor("exec"), Some("execute"));
        assert_eq!(monitor("ex"), Some("execute"));
        assert_eq!(monitor("e"), None);
        assert_eq!(monitor("ere"), Some("ereset"));
        assert_eq!(monitor("cont"), Some("continue"));
        assert_eq!(monitor("pcexe"), Some("pcexecute"));
        assert_eq!(statement("jm"), Some("jmove"));
        assert_eq!(statement("l"), None);
        assert_eq!(statement("brake"), Some("brake"));
        assert_eq!(statement("bre"), Some("break"));
        assert_eq!(statement("br"), None);
        assert_eq!(statement("on"), Some("on"));
        assert_eq!(statement("oni"), Some("oni"));
        assert_eq!(statement("tw"), Some("twait"));
        assert_eq!(statement("tcp_recv"), Some("tcp_recv"));
        assert_eq!(statement("jappro"), Some("jappro"));
        assert_eq!(statement("ja"), Some("jappro"));
        assert_eq!(statement("prin"), Some("print"));
        assert_eq!(statement("deco"), Some("decompose"));
        // EX is EXECUTE at the monitor and EXTCALL in a program: ambiguous there (P0110).
        assert!(matches!(
            lookup("ex", Role::INSTRUCTION),
            Lookup::Ambiguous(..)
        ));
        assert!(not_emulated("extcall"));
        assert!(not_emulated("stable"));
        assert!(!not_emulated("returne"));
        assert!(!not_emulated("drive"));
        assert!(!not_emulated("jmove"));
        assert!(!not_emulated("tcp_send"));
        assert!(!not_emulated("no_such_word"));
    }

    #[test]
    fn every_abbreviation_resolves_to_its_keyword_or_is_a_known_collision() {
        for role in [Role::INSTRUCTION, Role::MONITOR, Role::FUNCTION] {
            for k in table().iter().filter(|k| k.roles.intersects(role)) {
                match lookup(k.name, role) {
                    Lookup::Found(f) => assert_eq!(f.name, k.name),
                    other => panic!("{} does not resolve to itself: {other:?}", k.name),
                }
            }
        }
    }

    #[test]
    fn the_table_is_sorted_and_has_no_duplicate() {
        let key = |k: &Keyword| (k.name.trim_start_matches(['$', '#']), k.name);
        for w in table().windows(2) {
            assert!(
                key(&w[0]) < key(&w[1]),
                "{} before {}",
                w[0].name,
                w[1].name
            );
        }
        for k in table() {
            assert_eq!(k.name, k.name.to_ascii_lowercase(), "names are lower case");
            assert!(k.roles != Role::NONE, "{} has a role", k.name);
            assert!(
                k.runs == Role::NONE || k.roles.contains(k.runs),
                "{} runs only roles it has",
                k.name
            );
        }
    }

    #[test]
    fn arity_counts_values_of_the_grammar() {
        assert_eq!(arity("pose_variable [, clamp_number]"), Some((1, Some(2))));
        assert_eq!(arity(""), Some((0, Some(0))));
        assert_eq!(arity("signal_number [, …]"), Some((1, None)));
        assert_eq!(
            arity("ret, port, ip_address[], timeout"),
            Some((4, Some(4)))
        );
        assert_eq!(
            arity("[x_translation, y_translation, z_translation] [, x_rotation, y_rotation, z_rotation, speed]"),
            Some((0, Some(7)))
        );
        assert_eq!(arity(UNKNOWN_GRAMMAR), None);
    }

    #[test]
    fn required_words_are_the_literal_keywords_outside_brackets() {
        assert_eq!(
            required_words("[mode] pose_variable TILL signal_number"),
            ["till"]
        );
        assert!(required_words("speed [, rotational_speed] [ALWAYS]").is_empty());
        assert!(required_words("ON|OFF").is_empty());
    }

    #[test]
    fn did_you_mean_finds_a_keyword_one_edit_away() {
        assert_eq!(
            did_you_mean("japrro", Role::INSTRUCTION).map(|k| k.name),
            Some("jappro")
        );
        assert_eq!(
            did_you_mean("lmvoe", Role::INSTRUCTION).map(|k| k.name),
            Some("lmove")
        );
        assert_eq!(
            did_you_mean("zzzzzz", Role::INSTRUCTION).map(|k| k.name),
            None
        );
    }
}
