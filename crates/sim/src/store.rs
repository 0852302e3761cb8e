//! The controller's program memory: the AS programs and data sections loaded through the
//! terminal (or given with `--as-program`), the switches that survive a power cycle, and the
//! interpreter built from them.
//!
//! Choices (docs/EMULATOR.md, "The controller's terminal"), kept here so that they can be
//! corrected in one place:
//! - **A program of an existing name is overwritten** by a `LOAD`, as K-ROSET and the clients
//!   that load on real robots see it ([`OVERWRITE_EXISTING`]); the E manual says the load is
//!   refused instead, which the emulator does not play.
//! - A program on a task's stack (started and not yet killed, or `CALL`ed by a running task)
//!   is not replaced: its `LOAD` is refused with P1014, the file's other programs load.
//! - When programs change, the interpreter takes the new programs without stopping, whether
//!   tasks run or not (`Controller::sync_runtime` in `controller/memory.rs`): variables,
//!   signals and timers keep their values, except the variables the loaded file's data
//!   sections name. A power cycle builds the interpreter from the whole memory again (its
//!   variables start from the data sections; a real controller keeps them).
//! - The memory holds the **bytes** of what was loaded, in whatever code page the file was
//!   written (Shift-JIS comments, Windows-1250 strings…): `SAVE` gives back what `LOAD` took,
//!   line ends aside. Only names and headers are read as text.
//! - The interpreter is built with the memory's load options (`--stub`), at every rebuild.

use fs020n_as::keywords::SYSTEM_SWITCHES;
use fs020n_as::{Config, Interpreter, LoadError, LoadOptions, Loaded};

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
/// whole text from `.PROGRAM` to `.END`, as bytes with LF line ends.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct StoredProgram {
    pub(crate) name: String,
    pub(crate) params: String,
    pub(crate) text: Vec<u8>,
}

/// A file cut into its programs and data sections (lines outside them, such as `.*` headers,
/// are dropped, as the controller does).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub(crate) struct Sections {
    pub(crate) programs: Vec<StoredProgram>,
    pub(crate) data: Vec<Vec<u8>>,
}

/// The name and parameters of a `.PROGRAM name(params)` line.
fn header(line: &[u8]) -> Option<(String, String)> {
    let line = String::from_utf8_lossy(line);
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

/// A block being read: the program header (`None` for a data section) and the bytes so far.
type OpenBlock = (Option<(String, String)>, Vec<u8>);

/// Cuts a file into `.PROGRAM` … `.END` blocks and other `.SECTION` … `.END` blocks (bytes
/// kept as they are; CR LF becomes LF).
pub(crate) fn sections(bytes: &[u8]) -> Sections {
    let mut out = Sections::default();
    let mut current: Option<OpenBlock> = None;
    for raw in bytes.split(|&b| b == b'\n') {
        let line = raw.strip_suffix(b"\r").unwrap_or(raw);
        let t = line.trim_ascii();
        match &mut current {
            None => {
                if let Some(h) = header(t) {
                    current = Some((Some(h), [line, b"\n"].concat()));
                } else if t.starts_with(b".") && !t.starts_with(b".*") && t.len() > 1 {
                    current = Some((None, [line, b"\n"].concat()));
                }
            }
            Some((_, body)) => {
                body.extend_from_slice(line);
                body.push(b'\n');
                if t.eq_ignore_ascii_case(b".END") {
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
    data: Vec<Vec<u8>>,
    /// Variables defined at the terminal (`HERE`), a data section each, by name: a new
    /// definition of a name replaces its earlier one. After the loaded data, so that they win.
    defined: Vec<(String, Vec<u8>)>,
    /// AUTOSTART.PC … AUTOSTART5.PC.
    autostart: [bool; 5],
    /// The interpreter's system switches (`ABS.SPEED`, `CP`, …) while no interpreter holds them.
    system: Vec<(String, bool)>,
    /// Interpreter settings.
    config: Config,
    /// How programs load (instructions declared no-ops, `--stub`).
    load: LoadOptions,
    /// Bumped at every change of the programs: the interpreter must be rebuilt.
    generation: u64,
}

impl ProgramStore {
    /// An empty memory, every AUTOSTART switch OFF (a new controller).
    pub(crate) fn new(config: Config, load: LoadOptions) -> ProgramStore {
        ProgramStore {
            programs: Vec::new(),
            data: Vec::new(),
            defined: Vec::new(),
            autostart: [false; 5],
            system: SYSTEM_SWITCHES
                .iter()
                .map(|(n, v)| ((*n).to_owned(), *v))
                .collect(),
            config,
            load,
            generation: 0,
        }
    }

    /// A memory holding the programs and data of `bytes`, with the AUTOSTART switch of each
    /// autostart program it holds ON (`--as-program`: they start at every power-on).
    pub(crate) fn seeded(bytes: &[u8], config: Config, load: LoadOptions) -> ProgramStore {
        let mut store = ProgramStore::new(config, load);
        let s = sections(bytes);
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

    /// The data sections: those loaded, in load order, then the variables defined at the
    /// terminal.
    pub(crate) fn data(&self) -> impl Iterator<Item = &[u8]> {
        (self.data.iter().map(Vec::as_slice)).chain(self.defined.iter().map(|(_, d)| d.as_slice()))
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
    pub(crate) fn put_data(&mut self, section: Vec<u8>) {
        if !self.data.contains(&section) {
            self.data.push(section);
            self.generation += 1;
        }
    }

    /// Defines variable `name` (with its sigil, `#pick`) by a data section of its own,
    /// replacing the one an earlier definition of that name at the terminal made.
    pub(crate) fn put_defined(&mut self, name: &str, section: Vec<u8>) {
        let name = name.to_ascii_lowercase();
        self.defined.retain(|(n, _)| *n != name);
        self.defined.push((name, section));
        self.generation += 1;
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

    /// Deletes every program and variable (`SYSINIT`); the switches stay.
    pub(crate) fn clear(&mut self) {
        self.programs.clear();
        self.data.clear();
        self.defined.clear();
        self.generation += 1;
    }

    /// The whole memory as one AS file, leaving out the programs named in `except`.
    pub(crate) fn text_without(&self, except: &[&str]) -> Vec<u8> {
        let mut text = Vec::new();
        for p in &self.programs {
            if !except.contains(&p.name.as_str()) {
                text.extend_from_slice(&p.text);
            }
        }
        for d in self.data() {
            text.extend_from_slice(d);
        }
        text
    }

    /// An interpreter over the whole memory, loaded as `fs020n as check` loads a file.
    pub(crate) fn build(&self) -> Result<Interpreter, LoadError> {
        let bytes = self.text_without(&[]);
        Loaded::from_bytes("controller", &bytes, &self.load, self.config.clone())
            .map(|l| l.interpreter)
    }

    /// The interpreter settings.
    pub(crate) fn config(&self) -> &Config {
        &self.config
    }

    /// How programs load (`--stub`).
    pub(crate) fn load_options(&self) -> &LoadOptions {
        &self.load
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
