//! The controller's program memory: the AS programs and data sections loaded through the
//! terminal (or given with `--as-program`), the switches that survive a power cycle, and the
//! interpreter built from them.
//!
//! Choices (docs/EMULATOR.md, "The controller's terminal"), kept here so that they can be
//! corrected in one place:
//! - **A program of an existing name is overwritten** by a `LOAD`, as K-ROSET and the clients
//!   that load on real robots see it ([`OVERWRITE_EXISTING`]); the E manual says the load is
//!   refused instead, which the emulator does not play.
//! - A program on a task's stack (started and not yet killed) is not replaced: its `LOAD` is
//!   refused with P1014, the file's other programs load.
//! - The interpreter is rebuilt from the whole memory when programs change; the global
//!   variables then start again from the data sections (a real controller keeps them).

use fs020n_as::keywords::SYSTEM_SWITCHES;
use fs020n_as::{Config, Interpreter, LoadError};

/// `true`: a `LOAD` overwrites a program of the same name (K-ROSET); `false` would refuse it
/// (the E manual). The emulator implements the first.
pub const OVERWRITE_EXISTING: bool = true;

/// The switches that start a PC program at power-on, with their program and PC task.
pub const AUTOSTART_SWITCHES: [(&str, &str, u8); 5] = [
    ("AUTOSTART.PC", "autostart.pc", 1),
    ("AUTOSTART2.PC", "autostart2.pc", 2),
    ("AUTOSTART3.PC", "autostart3.pc", 3),
    ("AUTOSTART4.PC", "autostart4.pc", 4),
    ("AUTOSTART5.PC", "autostart5.pc", 5),
];

/// One program as loaded: its name (lower case), the parameter text of its header and its
/// whole text from `.PROGRAM` to `.END`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct StoredProgram {
    pub(crate) name: String,
    pub(crate) params: String,
    pub(crate) text: String,
}

/// A file cut into its programs and data sections (lines outside them, such as `.*` headers,
/// are dropped, as the controller does).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub(crate) struct Sections {
    pub(crate) programs: Vec<StoredProgram>,
    pub(crate) data: Vec<String>,
}

/// The name and parameters of a `.PROGRAM name(params)` line.
fn header(line: &str) -> Option<(String, String)> {
    let t = line.trim();
    let head = t.get(..8)?;
    if !head.eq_ignore_ascii_case(".PROGRAM") {
        return None;
    }
    let rest = t[8..].trim();
    let (name, params) = match rest.find('(') {
        Some(i) => (
            &rest[..i],
            rest[i + 1..].split(')').next().unwrap_or("").trim(),
        ),
        None => (rest.split_whitespace().next().unwrap_or(""), ""),
    };
    Some((name.trim().to_ascii_lowercase(), params.to_owned()))
}

/// Cuts a file into `.PROGRAM` … `.END` blocks and other `.SECTION` … `.END` blocks.
pub(crate) fn sections(text: &str) -> Sections {
    let mut out = Sections::default();
    let mut current: Option<(Option<(String, String)>, String)> = None;
    for raw in text.split('\n') {
        let line = raw.strip_suffix('\r').unwrap_or(raw);
        let t = line.trim();
        match &mut current {
            None => {
                if let Some(h) = header(t) {
                    current = Some((Some(h), format!("{line}\n")));
                } else if t.starts_with('.') && !t.starts_with(".*") && t.len() > 1 {
                    current = Some((None, format!("{line}\n")));
                }
            }
            Some((_, body)) => {
                body.push_str(line);
                body.push('\n');
                if t.eq_ignore_ascii_case(".END") {
                    if let Some((h, body)) = current.take() {
                        match h {
                            Some((name, params)) => out.programs.push(StoredProgram {
                                name,
                                params,
                                text: body,
                            }),
                            None => out.data.push(body),
                        }
                    }
                }
            }
        }
    }
    out
}

/// The programs, data and persistent switches of the controller.
#[derive(Debug, Clone)]
pub(crate) struct ProgramStore {
    /// In load order (the order `DIRECTORY` lists them).
    programs: Vec<StoredProgram>,
    /// Data sections, in load order.
    data: Vec<String>,
    /// AUTOSTART.PC … AUTOSTART5.PC.
    autostart: [bool; 5],
    /// The interpreter's system switches (`ABS.SPEED`, `CP`, …) while no interpreter holds them.
    system: Vec<(String, bool)>,
    /// Interpreter settings.
    config: Config,
    /// Bumped at every change of the programs: the interpreter must be rebuilt.
    generation: u64,
}

impl ProgramStore {
    /// An empty memory, every AUTOSTART switch OFF (a new controller).
    pub(crate) fn new(config: Config) -> ProgramStore {
        ProgramStore {
            programs: Vec::new(),
            data: Vec::new(),
            autostart: [false; 5],
            system: SYSTEM_SWITCHES
                .iter()
                .map(|(n, v)| ((*n).to_owned(), *v))
                .collect(),
            config,
            generation: 0,
        }
    }

    /// A memory holding the programs and data of `text`, with the AUTOSTART switch of each
    /// autostart program it holds ON (`--as-program`: they start at every power-on).
    pub(crate) fn seeded(text: &str, config: Config) -> ProgramStore {
        let mut store = ProgramStore::new(config);
        let s = sections(text);
        for p in s.programs {
            store.put(p);
        }
        for d in s.data {
            store.put_data(d);
        }
        for (n, (_, name, _)) in (1u8..).zip(AUTOSTART_SWITCHES) {
            if store.program(name).is_some() {
                store.set_autostart(n, true);
            }
        }
        store
    }

    pub(crate) fn generation(&self) -> u64 {
        self.generation
    }

    pub(crate) fn programs(&self) -> &[StoredProgram] {
        &self.programs
    }

    pub(crate) fn program(&self, name: &str) -> Option<&StoredProgram> {
        let name = name.to_ascii_lowercase();
        self.programs.iter().find(|p| p.name == name)
    }

    pub(crate) fn data(&self) -> &[String] {
        &self.data
    }

    /// Adds (or, with [`OVERWRITE_EXISTING`], replaces) a program.
    pub(crate) fn put(&mut self, program: StoredProgram) {
        match self.programs.iter_mut().find(|p| p.name == program.name) {
            Some(p) if OVERWRITE_EXISTING => *p = program,
            Some(_) => {}
            None => self.programs.push(program),
        }
        self.generation += 1;
    }

    /// Adds a data section (one already held word for word is not added again, so that
    /// loading the same file twice does not grow the memory).
    pub(crate) fn put_data(&mut self, section: String) {
        if !self.data.contains(&section) {
            self.data.push(section);
            self.generation += 1;
        }
    }

    /// Removes a program; `false` when there is none of that name.
    pub(crate) fn remove(&mut self, name: &str) -> bool {
        let name = name.to_ascii_lowercase();
        let before = self.programs.len();
        self.programs.retain(|p| p.name != name);
        let removed = self.programs.len() != before;
        if removed {
            self.generation += 1;
        }
        removed
    }

    /// The whole memory as one AS text, leaving out the programs named in `except`.
    pub(crate) fn text_without(&self, except: &[&str]) -> String {
        let mut text = String::new();
        for p in &self.programs {
            if !except.contains(&p.name.as_str()) {
                text.push_str(&p.text);
            }
        }
        for d in &self.data {
            text.push_str(d);
        }
        text
    }

    /// An interpreter over the whole memory.
    pub(crate) fn build(&self) -> Result<Interpreter, LoadError> {
        Interpreter::from_source("controller", &self.text_without(&[]), self.config.clone())
    }

    /// The interpreter settings.
    pub(crate) fn config(&self) -> &Config {
        &self.config
    }

    /// AUTOSTART*n*.PC (`n` from 1 to 5).
    pub(crate) fn autostart(&self, n: u8) -> bool {
        n.checked_sub(1)
            .and_then(|i| self.autostart.get(usize::from(i)))
            .copied()
            .unwrap_or(false)
    }

    pub(crate) fn set_autostart(&mut self, n: u8, on: bool) {
        if let Some(s) = n
            .checked_sub(1)
            .and_then(|i| self.autostart.get_mut(usize::from(i)))
        {
            *s = on;
        }
    }

    /// The system switches kept while no interpreter holds them.
    pub(crate) fn system_switches(&self) -> &[(String, bool)] {
        &self.system
    }

    pub(crate) fn set_system_switch(&mut self, name: &str, on: bool) {
        let name = name.to_ascii_lowercase();
        if let Some(s) = self.system.iter_mut().find(|(n, _)| *n == name) {
            s.1 = on;
        }
    }
}
