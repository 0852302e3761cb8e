//! How a file is loaded: [`LoadOptions`].

/// Options of a load: which instructions the user declares no-ops.
///
/// ```
/// use fs020n_as::LoadOptions;
/// let text = b".PROGRAM p()\n  TOOL gripper\n  a = 1\n.END\n";
/// let opts = LoadOptions::new().stub("tool");
/// let m = fs020n_as::parse_bytes("p.as", text, &opts).unwrap();
/// assert!(m.warnings[0].message.contains("stubbed"));
/// ```
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct LoadOptions {
    stubs: Vec<String>,
    known_words_only: bool,
}

/// Words that shape blocks or jumps: they are never stubbed (a no-op `END` would break the
/// program's structure).
const NEVER_STUBBED: &[&str] = &[
    "if", "else", "end", "while", "do", "until", "for", "case", "scase", "value", "svalue", "any",
    "goto", "call", "return",
];

impl LoadOptions {
    /// Default options: no stubs.
    pub fn new() -> LoadOptions {
        LoadOptions::default()
    }

    /// Declares `instruction` (any case: `"JAPPRO"`, `"tool"`) a no-op: it loads, is listed
    /// as stubbed, and a task that reaches it goes on to the next step. Works for the
    /// instructions the emulator does not model and for any other instruction word the
    /// loader does not know (an application instruction); block words (`IF`, `END`, …) are
    /// never stubbed.
    pub fn stub(mut self, instruction: &str) -> LoadOptions {
        let w = instruction.trim().to_ascii_lowercase();
        if !w.is_empty() && !self.stubs.contains(&w) {
            self.stubs.push(w);
        }
        self
    }

    /// Refuses a program line whose first word is in no keyword table (a stubbed word
    /// excepted), as a controller's `LOAD` does: the controller knows its own keywords. The
    /// emulated controller loads this way; `fs020n as check` and `sim --as-program` do not
    /// (they load such a line as not emulated, and the lint names it).
    pub fn known_words_only(mut self) -> LoadOptions {
        self.known_words_only = true;
        self
    }

    /// Whether [`LoadOptions::known_words_only`] is set.
    pub fn refuses_unknown_words(&self) -> bool {
        self.known_words_only
    }

    /// The stubbed instructions, lower case, in the order given.
    pub fn stubs(&self) -> &[String] {
        &self.stubs
    }

    /// Whether `word` (lower case) is stubbed.
    pub fn is_stubbed(&self, word: &str) -> bool {
        !NEVER_STUBBED.contains(&word) && self.stubs.iter().any(|s| s == word)
    }
}
