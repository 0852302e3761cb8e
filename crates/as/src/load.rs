//! Loading a file as the emulator does ([`Loaded`]) and checking it ([`check`]): the emulator
//! (`fs020n sim --as-program`, `fs020n-sim`'s `ServerProgram`) and `fs020n as check` go
//! through the same [`Loaded::from_bytes`], so they report the same errors and warnings.

use crate::ast::Module;
use crate::error::ParseError;
use crate::interp::{Config, Interpreter};
use crate::lint::{lint, lint_in_memory, Finding, Generation, Severity};
use crate::options::LoadOptions;
use crate::parser::parse_bytes;

/// A file loaded: the interpreter ready to run, and what the file holds besides programs
/// (its sections, the `.SYSDATA` switches such as AUTOSTART, the warnings).
#[derive(Debug, Clone)]
pub struct Loaded {
    /// The parsed file ([`Module::sections`], [`Module::switches`], [`Module::autostart`]).
    pub module: Module,
    /// The interpreter with the file's programs and data loaded.
    pub interpreter: Interpreter,
}

/// What `fs020n as check` reports for one file.
#[derive(Debug, Clone)]
pub struct CheckReport {
    /// Whether the file loads (no errors).
    pub loaded: bool,
    /// Why it does not load (file:line:column and what was expected).
    pub errors: Vec<ParseError>,
    /// What loaded but is worth knowing (instructions not emulated, sections kept opaque).
    pub warnings: Vec<ParseError>,
    /// The lint against the controller's limits ([`crate::lint::RULES`]).
    pub lint: Vec<Finding>,
}

impl CheckReport {
    /// Whether the file loads and nothing is linted as an error.
    pub fn passes(&self) -> bool {
        self.loaded && !self.lint.iter().any(|f| f.severity == Severity::Error)
    }
}

impl Loaded {
    /// Loads one file given as bytes (any encoding), as the emulator does.
    ///
    /// ```
    /// use fs020n_as::{Config, LoadOptions, Loaded};
    /// let text = b".PROGRAM autostart.pc()\r\n  TWAIT 1\r\n.END\r\n.SYSDATA\r\nSWITCH AUTOSTART.PC    ON\r\n.END\r\n";
    /// let loaded = Loaded::from_bytes("a.as", text, &LoadOptions::new(), Config::default())?;
    /// assert_eq!(loaded.module.autostart(), vec![(1, true)]);
    /// # Ok::<(), fs020n_as::LoadError>(())
    /// ```
    pub fn from_bytes(
        file: &str,
        bytes: &[u8],
        opts: &LoadOptions,
        config: Config,
    ) -> Result<Loaded, crate::error::LoadError> {
        let module = parse_bytes(file, bytes, opts)?;
        let interpreter = Interpreter::new(std::slice::from_ref(&module), config)?;
        Ok(Loaded {
            module,
            interpreter,
        })
    }
}

/// Loads `bytes` exactly as the emulator would ([`Loaded::from_bytes`]) and lints the file for
/// `controller` (`None`: every generation's rules that apply to all, the strictest ranges).
pub fn check(
    file: &str,
    bytes: &[u8],
    opts: &LoadOptions,
    generation: Option<Generation>,
) -> CheckReport {
    match Loaded::from_bytes(file, bytes, opts, Config::default()) {
        Ok(l) => CheckReport {
            loaded: true,
            errors: Vec::new(),
            warnings: l.interpreter.warnings().to_vec(),
            lint: lint(bytes, &l.module, generation),
        },
        Err(e) => {
            // The lint still runs when the text parses but does not compile.
            let lint = parse_bytes(file, bytes, opts)
                .map(|m| lint(bytes, &m, generation))
                .unwrap_or_default();
            CheckReport {
                loaded: false,
                errors: e.errors,
                warnings: Vec::new(),
                lint,
            }
        }
    }
}

/// Checks files as **one controller memory**, as if loaded one after another: each file must
/// load on its own (a controller loads each file alone), and the lint knows every program the
/// files define together — a `CALL` to a program none of them defines is an `undefined-program`
/// finding, and a program defined by two files is a warning (the controller's second LOAD
/// refuses it). One report per file, in order.
///
/// ```
/// use fs020n_as::{check_memory, LoadOptions};
/// let main = b".PROGRAM main()\n  CALL helper\n  CALL missing\n.END\n";
/// let lib = b".PROGRAM helper()\n.END\n";
/// let r = check_memory(&[("main.as", &main[..]), ("lib.as", &lib[..])], &LoadOptions::new(), None);
/// let undefined: Vec<&str> = r[0].lint.iter().filter(|f| f.rule == "undefined-program").map(|f| f.message.as_str()).collect();
/// assert_eq!(undefined.len(), 1);
/// assert!(undefined[0].starts_with("CALL missing"));
/// ```
pub fn check_memory(
    files: &[(&str, &[u8])],
    opts: &LoadOptions,
    generation: Option<Generation>,
) -> Vec<CheckReport> {
    let modules: Vec<Option<Module>> = files
        .iter()
        .map(|(file, bytes)| parse_bytes(file, bytes, opts).ok())
        .collect();
    let defined: Vec<&str> = modules
        .iter()
        .flatten()
        .flat_map(|m| m.programs.iter().map(|p| p.name.as_str()))
        .collect();
    files
        .iter()
        .zip(&modules)
        .enumerate()
        .map(|(k, ((file, bytes), module))| {
            let mut report = check(file, bytes, opts, generation);
            if let Some(m) = module {
                report.lint = lint_in_memory(bytes, m, generation, &defined);
                for p in &m.programs {
                    let first = modules[..k]
                        .iter()
                        .zip(files)
                        .find(|(o, _)| o.as_ref().is_some_and(|o| o.programs.iter().any(|q| q.name == p.name)));
                    if let Some((_, (other, _))) = first {
                        report.warnings.push(ParseError::new(
                            file,
                            p.span,
                            format!("program {} is also defined in {other}: loaded after it, a controller refuses this one (delete the first, or rename)", p.name),
                        ));
                    }
                }
            }
            report
        })
        .collect()
}
