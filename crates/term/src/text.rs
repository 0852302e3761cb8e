//! Every text the controller's terminal prints that a program matches on, in one place.
//!
//! The facts come from the public captures and the manuals summarised in the project's research
//! notes on the AS terminal; each constant says how sure it is (**H**: a manual or several
//! captures agree; **M**: one capture, or what several clients rely on; **L**: inference).
//! Where the sources conflict, the constant holds the recommended choice and says so. The
//! emulator prints these texts and the deploy client matches them: correcting a fact here
//! corrects both.

/// The telnet port of the controller's terminal (E and F: **H**, D: **M**).
pub const TERMINAL_PORT: u16 = 23;

/// The line the controller sends before `login: ` (**H** for the E series; the emulator says
/// the same whatever generation it plays).
pub const BANNER: &str = "Connecting to Kawasaki E Controller";

/// The login prompt (**H**).
pub const LOGIN_PROMPT: &str = "login: ";

/// The user name that opens the monitor; no password is asked (**H**).
pub const LOGIN_USER: &str = "as";

/// The greeting after login, with the terminal's name (`AUX1`, `AUX2`, …) in the quotes (**H**).
pub fn greeting(terminal: &str) -> String {
    format!("This is AS monitor terminal \"{terminal}\"")
}

/// The prompt that ends every reply: CR LF then `>` (**H**). The controller sends no blank
/// after it.
pub const PROMPT: &[u8] = b"\r\n>";

/// The end of a line of output (**H**).
pub const EOL: &str = "\r\n";

/// Characters of one input line the controller reads; the rest is ignored (**H**).
pub const MAX_LINE_CHARS: usize = 128;

/// Terminal sessions an E controller serves at once (**H**); a further connection is refused
/// until one leaves.
pub const MAX_SESSIONS: usize = 3;

/// The yes/no question of `KILL`, `PCKILL` and `DELETE` (**H**); the answer `1` confirms. It
/// ends with a blank (clients wait for `0) `); the answer is echoed on the same line, and a
/// refusal, if any, comes only after it: `Are you sure ? (Yes:1, No:0) 1`, CR LF,
/// `(P1026)Cannot KILL program that is running.` (**H**).
pub const ARE_YOU_SURE: &str = "Are you sure ? (Yes:1, No:0) ";

/// What identifies a yes/no question in any of its wordings (`(Yes:1, No:0)`, `(Yes:1,No;0)`,
/// `Are you sure? (Enter 1 to execute)`) (**H** for the first, **M** for the others).
pub fn is_yes_no_question(line: &str) -> bool {
    let l = line.trim_end();
    let compact: String = l.chars().filter(|c| !c.is_whitespace()).collect();
    (l.contains("Are you sure") && l.ends_with(')'))
        || compact.ends_with("(Yes:1,No:0)")
        || compact.ends_with("(Yes:1,No;0)")
}

/// The first line of the syntax-error question in the middle of a `LOAD` (**H**, real
/// controllers and K-ROSET).
pub const SYNTAX_ERROR: &str = "STEP syntax error.";

/// The choices of the syntax-error question (**H**). Conflict: the E manual words it "The step
/// format is incorrect (0: Continue load 1: Delete program and exit)"; match on
/// [`DELETE_AND_ABORT_MARK`], which both wordings contain in spirit and every capture contains
/// literally.
pub const SYNTAX_ERROR_CHOICES: &str =
    "(0:Change to comment and continue, 1:Delete program and abort)";

/// What identifies the syntax-error question's choices in any wording.
pub const DELETE_AND_ABORT_MARK: &str = "Delete program";

/// The answer to the syntax-error question that deletes the program and aborts the load. The
/// deploy client always gives it: the other answer comments the line out silently.
pub const ANSWER_ABORT_LOAD: &str = "1";

/// The answer that comments the bad line out and goes on (what a careless terminal defaults to).
pub const ANSWER_COMMENT_OUT: &str = "0";

/// The question `LOAD/Q` asks per program (AS-E p.5-34, **H**); `3` (Exit) ends the load.
pub const LOAD_QUERY: &str = "Load? (1:Yes, 0:No, 2:Load all, 3:Exit)";

/// The answer to [`LOAD_QUERY`] that ends the load: the deploy client never loads by halves.
pub const ANSWER_LOAD_EXIT: &str = "3";

/// What identifies the question about a file's `.NETCONF` IP address that is not the
/// controller's (COM-F p.1-21: `9` continues, `0` stops) (**M**).
pub const FORCE_LOAD_MARK: &str = "Force load";

/// The answer to the `.NETCONF` question that stops the load.
pub const ANSWER_FORCE_LOAD_STOP: &str = "0";

/// The question after values offered for editing (`HERE`, `POINT`, `TIME`), on a line of
/// its own and without a prompt after it; a line end keeps the values (**M**: the wording of a
/// controller mock said to match K-ROSET for `TIME`; the E manual prints it with small
/// differences of case and blanks, AS-E p.3-13, p.5-49).
pub const CHANGE_QUESTION: &str = "Change? (If not, Hit RETURN only)";

/// A pause that waits for Enter (**M**: a client answers it in the middle of a LOAD).
pub const PRESS_ENTER: &str = "Press ENTER.";

/// The question some controllers ask after the end of a `LOAD`'s file, answered with a line
/// end (**M**: some clients always wait for it, others never see it).
pub const CONFIRM: &str = "Confirm !";

/// The last line of a `LOAD` in the E manual's example (AS-E p.5-35), without a count (**M**:
/// captures of E and F controllers show [`load_completed`] instead).
pub const LOADING_DONE: &str = "Loading done.";

/// `Loading...(name)`: a `LOAD` began (**H**).
pub fn loading(file: &str) -> String {
    format!("Loading...({file})")
}

/// `Saving...(name)`: a `SAVE` began (**M**).
pub fn saving(file: &str) -> String {
    format!("Saving...({file})")
}

/// The last line of a `LOAD` with the count of errors (**H**).
pub fn load_completed(errors: usize) -> String {
    format!("File load completed. ({errors} errors)")
}

/// What identifies the last line of a `LOAD`.
pub const LOAD_COMPLETED_MARK: &str = "File load completed.";

/// The refusal of a program whose name is already in memory, on a controller that does not
/// overwrite programs (AS-E p.5-34: "Programs are not overwritten", the LOAD is aborted). The
/// manual gives neither code nor text: both are the emulator's (**L**); a client recognises a
/// real controller's refusal by the program missing from the listing afterwards.
pub const P1039_PROGRAM_EXISTS: MonitorError = MonitorError {
    code: 1039,
    text: "Program already exists. LOAD aborted.",
};

/// The last line of a `SAVE` (**M**).
pub const SAVE_COMPLETED: &str = "File save completed.";

/// The line the controller prints for each program it loads (**H**, captures; the manual's
/// example differs).
pub fn program_loaded(name: &str, params: &str) -> String {
    format!("Program {name}({params})")
}

/// `Cleared error state.`: `ERESET` when there was an error (**M**).
pub const CLEARED_ERROR: &str = "Cleared error state.";

/// A PC program's end, printed after a prompt that was already sent (**M**).
pub fn pc_completed(task: u8) -> String {
    format!("Program completed.No = {task}")
}

/// `PC program aborted.No = n` after `PCABORT n:` (**M**: a client looks for the text and
/// the number).
pub fn pc_aborted(task: u8) -> String {
    format!("PC program aborted.No = {task}")
}

/// The line of `PCSTATUS` that says whether the task runs (**H** for the words; **M** for the
/// period after "not running": the manual's PCSTATUS example shows none, its STATUS line
/// `Stepper status:  Program is not running.` has one, and a telnet library fixed "after tests
/// on a real robot" looks for `Program is not running.` with it in PCSTATUS's answer).
pub fn pc_status_line(running: bool) -> &'static str {
    if running {
        "PC status: Program running"
    } else {
        "PC status: Program is not running."
    }
}

/// The last part of `STATUS` and `PCSTATUS` when no program runs (**H**).
pub const NO_PROGRAM_RUNNING: &str = "No program is running.";

/// The header of the program line of `STATUS`/`PCSTATUS` (**H**: a client reads the name from
/// token 0 and the step from token 2 of the line after it).
pub const PROGRAM_TABLE_HEADER: &str = "Program name   Priority   Step No.";

/// An error the monitor prints: `(Pnnnn)` and the text, no blank between (**H**).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MonitorError {
    /// The number after `P`.
    pub code: u16,
    /// The text (AS-E, appendix 4).
    pub text: &'static str,
}

impl MonitorError {
    /// The line as the controller prints it: `(P1019)PC program is running.`
    pub fn line(&self) -> String {
        format!("(P{:04}){}", self.code, self.text)
    }
}

/// P1000: motor power is off (**H**, AS-E appendix).
pub const P1000_POWER_OFF: MonitorError = MonitorError {
    code: 1000,
    text: "Cannot execute program because motor power is OFF.",
};
/// P1001: the controller is in TEACH mode (**L**: the code between P1000 and P1002; the text
/// is the emulator's).
pub const P1001_TEACH_MODE: MonitorError = MonitorError {
    code: 1001,
    text: "Cannot execute program in TEACH mode.",
};
/// P1002: the teach lock is on (**H**, AS-E appendix).
pub const P1002_TEACH_LOCK: MonitorError = MonitorError {
    code: 1002,
    text: "Cannot execute program because teach lock is ON.",
};
/// P1009: the robot program runs already.
pub const P1009_ALREADY_RUNNING: MonitorError = MonitorError {
    code: 1009,
    text: "Program is already running.",
};
/// P1013: an error state blocks execution.
pub const P1013_IN_ERROR: MonitorError = MonitorError {
    code: 1013,
    text: "Cannot execute because in error now. Reset error.",
};
/// P1014: the program is on a task's stack.
pub const P1014_IN_USE: MonitorError = MonitorError {
    code: 1014,
    text: "Cannot execute because program already in use.",
};
/// P1018: a program must be killed before it is deleted.
pub const P1018_KILL_FIRST: MonitorError = MonitorError {
    code: 1018,
    text: "KILL or PCKILL to delete program.",
};
/// P1019: a PC program runs in the task.
pub const P1019_PC_RUNNING: MonitorError = MonitorError {
    code: 1019,
    text: "PC program is running.",
};
/// P1026: a running program cannot be killed.
pub const P1026_CANNOT_KILL_RUNNING: MonitorError = MonitorError {
    code: 1026,
    text: "Cannot KILL program that is running.",
};
/// P1038: no program of that name.
pub const P1038_NO_PROGRAM: MonitorError = MonitorError {
    code: 1038,
    text: "Program does not exist.",
};
/// P2076: an earlier transfer never ended. The whole line was never captured: clients match
/// its tail (`ess.`) or `LOAD in progress`; the text here is the manual's.
pub const P2076_TRANSFER_IN_PROGRESS: MonitorError = MonitorError {
    code: 2076,
    text: "SAVE/LOAD in progress.",
};
/// P0108: a statement that does not parse (**H**, AS-E appendix 4).
pub const P0108_SYNTAX_ERROR: MonitorError = MonitorError {
    code: 108,
    text: "Syntax error.",
};
/// P0117: a name that is not a valid program or variable name (**M**).
pub const P0117_INVALID_NAME: MonitorError = MonitorError {
    code: 117,
    text: "Invalid variable (or program) name.",
};
/// P0110: a short form of two commands (**H**, AS-E appendix 4).
pub const P0110_FULL_SPELLING: MonitorError = MonitorError {
    code: 110,
    text: "Specify full spelling of command.",
};
/// An unknown command. The wording is not in the sources; the emulator's choice (**L**).
pub const UNKNOWN_COMMAND: MonitorError = MonitorError {
    code: 100,
    text: "Command not found.",
};

/// E4054: the controller has no Ethernet board (**H**, AS-E appendix; printed with an `E`).
pub const E4054_NO_ETHERNET: &str =
    "(E4054)TCPIP)Cannot execute because Ethernet board not installed.";

/// E4055: a socket could not be made (`TCP_LISTEN` on a port still held) (**H**, AS-E
/// appendix).
pub const E4055_NO_SOCKET: &str = "(E4055)TCP)Cannot create a socket.";

/// A refusal found in a command's output: the whole line and its code when it has one.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Refusal {
    /// The line as printed (`(P1026)Cannot KILL program that is running.`).
    pub line: String,
    /// `P` and the number when the line has a `(Pnnnn)` code; some refusals have none
    /// (`p12:Variable (or program) does not exist.`).
    pub code: Option<(char, u16)>,
}

impl std::fmt::Display for Refusal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.line)
    }
}

/// Texts of refusals that come without a code (**H**: clients check the whole output after
/// the answer for these), lower case.
const UNCODED_REFUSALS: &[&str] = &[
    "does not exist",
    "already in use",
    "already exists",
    "cannot ",
    "kill or pckill",
    "in progress",
    "pc program is running",
    "program is already running",
    "not found",
    "invalid",
];

/// The first refusal in the **whole** output of an action (`KILL`, `PCKILL`, `DELETE`,
/// `PCABORT`, `PCEXECUTE`, `SWITCH … = ON`…): a refusal comes after the echo of the answer
/// to `Are you sure ?`, and some have no `(Pnnnn)` code. A `(Ennnn)` line is not one: it is a
/// program's error, printed whenever it happens (a server's `(E4024)` at the end of a
/// session may fall in any command's output). Not for listings (`STATUS` prints "running" in
/// its ordinary lines).
pub fn refusal(output: &str) -> Option<Refusal> {
    for raw in output.split(['\n', '\r']) {
        let line = raw.trim();
        if line.is_empty() {
            continue;
        }
        // A code anywhere on the line (after the question's echoed answer, say); a program's
        // error line is not the command's.
        if let Some((letter, code, start)) = find_code(line) {
            if letter == 'E' {
                continue;
            }
            return Some(Refusal {
                line: line[start..].to_owned(),
                code: Some((letter, code)),
            });
        }
        // The yes/no question with its echoed answer is not a refusal.
        let rest = match line.find("(Yes:1") {
            Some(i) => line[i..]
                .split_once(')')
                .map_or("", |(_, r)| r.trim_start_matches(['0', '1', ' '])),
            None => line,
        };
        let lower = rest.to_ascii_lowercase();
        if UNCODED_REFUSALS.iter().any(|m| lower.contains(m)) {
            return Some(Refusal {
                line: rest.trim().to_owned(),
                code: None,
            });
        }
    }
    None
}

/// `(Pnnnn)` or `(Ennnn)` in a line: the letter, the number and where the code starts.
fn find_code(line: &str) -> Option<(char, u16, usize)> {
    let b = line.as_bytes();
    (0..b.len()).find_map(|i| {
        if b[i] != b'(' || !matches!(b.get(i + 1), Some(b'P' | b'E')) {
            return None;
        }
        let digits = b[i + 2..].iter().take_while(|c| c.is_ascii_digit()).count();
        if digits == 0 || digits > 5 || b.get(i + 2 + digits) != Some(&b')') {
            return None;
        }
        let n = line.get(i + 2..i + 2 + digits)?.parse().ok()?;
        Some((char::from(b[i + 1]), n, i))
    })
}

/// Every monitor error this crate knows, for matching a line back to its code.
pub const MONITOR_ERRORS: &[MonitorError] = &[
    P1000_POWER_OFF,
    P1001_TEACH_MODE,
    P1002_TEACH_LOCK,
    P1009_ALREADY_RUNNING,
    P1013_IN_ERROR,
    P1014_IN_USE,
    P1018_KILL_FIRST,
    P1019_PC_RUNNING,
    P1026_CANNOT_KILL_RUNNING,
    P1038_NO_PROGRAM,
    P2076_TRANSFER_IN_PROGRESS,
    P0117_INVALID_NAME,
    P1039_PROGRAM_EXISTS,
    UNKNOWN_COMMAND,
];

/// The code of a `(Pnnnn)` error line, if the line is one.
pub fn monitor_error_code(line: &str) -> Option<u16> {
    let rest = line.trim_start().strip_prefix("(P")?;
    let end = rest.find(')')?;
    rest[..end].parse().ok()
}

/// The prompt of a paged listing with SCREEN ON (**H**); a space continues.
pub const PRESS_SPACE: &str = "Press SPACE key to continue.";

/// What `PCSTATUS n:` or `STATUS` says of a task.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct TaskStatus {
    /// A program is on the task and runs or waits (`Program running`, `Program WAIT`).
    pub running: bool,
    /// The program on the task, from the line under [`PROGRAM_TABLE_HEADER`] (token 0).
    pub program: Option<String>,
    /// Its step (token 2 of that line), when given.
    pub step: Option<u32>,
}

/// Reads the output of `PCSTATUS n:` or `STATUS` (**H** for the words, **M** for the table:
/// a client reads the name from token 0 and the step from token 2).
pub fn parse_task_status(output: &str) -> TaskStatus {
    let mut status = TaskStatus::default();
    let mut lines = output.lines().map(str::trim);
    while let Some(line) = lines.next() {
        let lower = line.to_ascii_lowercase();
        if !lower.contains("not running")
            && !lower.starts_with("no program")
            && (lower.contains("program running")
                || lower.contains("program wait")
                || lower.contains("program is running"))
        {
            status.running = true;
        }
        if line.starts_with("Program name") {
            if let Some(row) = lines.next() {
                let tokens: Vec<&str> = row.split_whitespace().collect();
                if let Some(name) = tokens.first() {
                    // The running program blinks a `*` after its name (AS-E p.10-3).
                    status.program = Some(listed_name(name));
                }
                status.step = tokens.get(2).and_then(|t| t.parse().ok());
            }
        }
    }
    status
}

/// A program's name as a listing prints it, without the marks around it: a leading `*` or
/// `~` (no data, AS-E p.5-17) and a trailing `*` (running, AS-E p.10-3); lower case, as the
/// controller's names are case-insensitive.
pub fn listed_name(token: &str) -> String {
    token
        .trim_start_matches(['*', '~'])
        .trim_end_matches('*')
        .to_ascii_lowercase()
}

/// The programs `DIRECTORY/P` lists: every name on the lines after its header (**M**: the
/// header is one line, the names are separated by blanks and may fill several lines).
pub fn parse_directory(output: &str) -> Vec<String> {
    let mut lines = output.lines().map(str::trim).filter(|l| !l.is_empty());
    let first = lines.next().unwrap_or("");
    // A header has words that are not program names; a listing without one starts with names.
    let header = first.eq_ignore_ascii_case(DIRECTORY_HEADER)
        || first.contains(':')
        || first.to_ascii_lowercase().contains("program");
    let mut names = Vec::new();
    let rest = if header { None } else { Some(first) };
    for line in rest.into_iter().chain(lines) {
        names.extend(
            line.split_whitespace()
                .map(listed_name)
                .filter(|n| !n.is_empty()),
        );
    }
    names
}

/// What `TYPE TASK (n)` printed (AS-E p.9-20): 0 not running, 1 running, 2 held, 3 waiting
/// for its motion to finish; `None` when the output holds no such number.
pub fn parse_task_number(output: &str) -> Option<u8> {
    output
        .split_whitespace()
        .rev()
        .find_map(|t| t.parse::<f64>().ok())
        .filter(|v| (0.0..=3.0).contains(v) && v.fract() == 0.0)
        .map(|v| v as u8)
}

/// The state `SWITCH name` printed: its last `ON`/`OFF` token (**M**).
pub fn parse_switch(output: &str) -> Option<bool> {
    output
        .split_whitespace()
        .rev()
        .find_map(|t| match t.to_ascii_uppercase().as_str() {
            "ON" => Some(true),
            "OFF" => Some(false),
            _ => None,
        })
}

/// The AS version in the output of `ID`: the first line after `[Software version]`, or a
/// token that starts with `AS` and holds `_` (`ASE_K80000W48`) (**M**).
pub fn parse_as_version(output: &str) -> Option<String> {
    let mut lines = output.lines().map(str::trim);
    while let Some(line) = lines.next() {
        if line.contains("Software version") {
            if let Some(next) = lines.find(|l| !l.is_empty()) {
                return Some(next.to_owned());
            }
        }
    }
    output
        .split_whitespace()
        .find(|t| t.starts_with("AS") && t.contains('_'))
        .map(str::to_owned)
}

/// The header line of `DIRECTORY/P` before the names (**L**: clients read only the line after
/// it; the wording is the emulator's).
pub const DIRECTORY_HEADER: &str = "Program list";

/// The robot name `ID` reports on the emulator (**L**: the real controller's `ID` block is
/// documented, not captured for an FS020N).
pub const EMULATOR_ROBOT_NAME: &str = "FS020N";

/// The AS version `ID` reports on the emulator: clearly not a Kawasaki build, so that no tool
/// takes the emulator for a real controller.
pub const EMULATOR_AS_VERSION: &str = "EMULATOR-FS020N-AS";

/// The emulator's answer to a `LOAD` on a controller running its native protocol-1040 server,
/// which is not an AS program the memory could hold beside others (emulator only).
pub const EMULATOR_NATIVE_NO_LOAD: &str = "(emulator) this controller runs the native server: \
     start it with --bare or --as-program to load AS programs";

/// `PCSTATUS`'s cycle lines (**H** for the wording of the manual's example). A negative
/// remaining count (a task started with `-1`, for ever) prints as `Infinite` (**L**: the
/// manual's example shows only counts; the word is the emulator's).
pub fn cycle_lines(completed: u32, remaining: i64) -> [String; 2] {
    let remaining = if remaining < 0 {
        "Infinite".to_owned()
    } else {
        remaining.to_string()
    };
    [
        format!("Completed cycles: {completed}"),
        format!("Remaining cycles: {remaining}"),
    ]
}

/// The emulator's answer to `PCEXECUTE n: prog, cycles` whose count is not a whole number
/// (emulator only: the controller evaluates an expression there).
pub const EMULATOR_CYCLES_NOT_A_NUMBER: &str =
    "(emulator) give the cycle count as a whole number (-1: until PCABORT)";

/// The emulator's answer to `ERESET` while the emergency stop is pressed (emulator only).
pub const EMULATOR_ESTOP_PRESSED: &str =
    "(emulator) the emergency stop is pressed: release it, then ERESET";

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_task_status_names_the_running_program_and_its_step() {
        let out = format!(
            "{}\nCompleted cycles: 0\nRemaining cycles: 1\n{}\nautostart.pc      0     12   TCP_RECV",
            pc_status_line(true),
            PROGRAM_TABLE_HEADER
        );
        let s = parse_task_status(&out);
        assert!(s.running);
        assert_eq!(s.program.as_deref(), Some("autostart.pc"));
        assert_eq!(s.step, Some(12));
        let idle = parse_task_status(&format!("{}\n{NO_PROGRAM_RUNNING}", pc_status_line(false)));
        assert_eq!(idle, TaskStatus::default());
    }

    #[test]
    fn a_refusal_after_the_answer_is_found_in_the_whole_output() {
        let out = format!("{ARE_YOU_SURE}1\n{}", P1026_CANNOT_KILL_RUNNING.line());
        let r = refusal(&out).expect("the refusal after the answer");
        assert_eq!(r.code, Some(('P', 1026)));
        assert_eq!(r.line, P1026_CANNOT_KILL_RUNNING.line());
        let uncoded = format!("{ARE_YOU_SURE}1\r\np12:Variable (or program) does not exist.");
        let r = refusal(&uncoded).expect("a refusal without a code");
        assert_eq!(r.code, None);
        assert!(r.line.contains("does not exist"));
        assert_eq!(refusal(&format!("{ARE_YOU_SURE}1")), None);
        assert_eq!(refusal("PC program aborted.No = 1"), None);
        // A program's error, printed whenever it happens, is not the command's refusal.
        assert_eq!(refusal("(E4024)TCP)Communication timeout."), None);
        assert_eq!(
            refusal("(E4024)x\n(P1038)Program does not exist.")
                .unwrap()
                .code,
            Some(('P', 1038))
        );
    }

    #[test]
    fn yes_no_questions_are_known_in_each_wording() {
        assert!(is_yes_no_question(ARE_YOU_SURE));
        assert!(is_yes_no_question("Really ? (Yes:1,No;0)"));
        assert!(is_yes_no_question("Are you sure? (Enter 1 to execute)"));
        assert!(!is_yes_no_question(LOAD_QUERY));
    }

    #[test]
    fn a_directory_listing_gives_names_without_their_marks() {
        assert_eq!(
            parse_directory("Program list\nautostart.pc* ros_move ~old\n*empty"),
            ["autostart.pc", "ros_move", "old", "empty"]
        );
        assert_eq!(parse_directory("a b"), ["a", "b"]);
        assert!(parse_directory("Program list\n").is_empty());
        assert_eq!(parse_task_number("TYPE TASK (1001)\n 1"), Some(1));
        assert_eq!(parse_task_number(" 0"), Some(0));
        assert_eq!(parse_task_number("(E0102) Variable not defined"), None);
    }

    #[test]
    fn a_switch_reads_its_last_on_or_off() {
        assert_eq!(parse_switch("AUTOSTART.PC        ON"), Some(true));
        assert_eq!(parse_switch("AUTOSTART.PC OFF"), Some(false));
        assert_eq!(
            parse_switch("(P0117)Invalid variable (or program) name."),
            None
        );
    }

    #[test]
    fn the_as_version_is_read_after_its_heading_or_as_a_token() {
        assert_eq!(
            parse_as_version("Robot name: FS020N\n[Software version]\nASE_FS020N_EMU 1.0\n")
                .as_deref(),
            Some("ASE_FS020N_EMU 1.0")
        );
        assert_eq!(
            parse_as_version("AS version ASE_K80000W48").as_deref(),
            Some("ASE_K80000W48")
        );
        assert_eq!(
            monitor_error_code("(P2076)SAVE/LOAD in progress."),
            Some(2076)
        );
    }
}
