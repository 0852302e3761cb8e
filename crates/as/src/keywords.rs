//! Keywords and their abbreviations.
//!
//! Like the controller, the interpreter accepts a keyword shortened to any prefix at least as
//! long as its shortest form below (`MC EXEC` = `MC EXECUTE`, `JM` = `JMOVE`). The shortest
//! forms are chosen so that no prefix is ambiguous among the AS instructions listed here —
//! including instructions this interpreter does not support, so that `L` is not taken for
//! `LMOVE` when the controller would also know `LAPPRO`.

/// Program instructions: (keyword, shortest accepted form).
pub const STATEMENTS: &[(&str, usize)] = &[
    ("above", 5),
    ("abs.speed", 9),
    ("accel", 4),
    ("accuracy", 4),
    ("align", 5),
    ("any", 3),
    ("appro", 5),
    ("base", 4),
    ("below", 5),
    ("bits", 4),
    ("bits32", 6),
    ("brake", 3),
    ("break", 3),
    ("c1move", 6),
    ("c2move", 6),
    ("call", 3),
    ("case", 3),
    ("close", 5),
    ("closei", 6),
    ("cp", 2),
    ("decel", 5),
    ("decompose", 4),
    ("delay", 3),
    ("depart", 6),
    ("disable", 4),
    ("dlysig", 6),
    ("do", 2),
    ("draw", 4),
    ("drive", 5),
    ("dwrist", 6),
    ("else", 4),
    ("enable", 3),
    ("end", 3),
    ("execute", 3),
    ("for", 3),
    ("goto", 2),
    ("halt", 3),
    ("here", 4),
    ("hmove", 5),
    ("home", 3),
    ("if", 2),
    ("ignore", 2),
    ("jappro", 6),
    ("jdepart", 7),
    ("jmove", 2),
    ("lappro", 6),
    ("ldepart", 7),
    ("lefty", 5),
    ("lmove", 2),
    ("mc", 2),
    ("on", 2),
    ("one", 3),
    ("oni", 3),
    ("open", 4),
    ("openi", 5),
    ("pause", 3),
    ("pcabort", 4),
    ("pcexecute", 4),
    ("point", 3),
    ("print", 3),
    ("pulse", 5),
    ("relax", 5),
    ("relaxi", 6),
    ("return", 3),
    ("righty", 6),
    ("runmask", 7),
    ("scase", 3),
    ("signal", 3),
    ("speed", 2),
    ("stop", 3),
    ("svalue", 3),
    ("swait", 5),
    ("tcp_accept", 10),
    ("tcp_close", 9),
    ("tcp_connect", 11),
    ("tcp_end_listen", 14),
    ("tcp_listen", 10),
    ("tcp_recv", 8),
    ("tcp_send", 8),
    ("tcp_status", 10),
    ("tdraw", 5),
    ("timer", 3),
    ("tool", 4),
    ("twait", 2),
    ("type", 2),
    ("until", 2),
    ("udp_recvfrom", 12),
    ("udp_sendto", 10),
    ("uwrist", 6),
    ("value", 3),
    ("wait", 2),
    ("while", 3),
    ("xmove", 5),
];

/// AS instructions that exist on the controller but that the emulator does not model: a
/// program that uses them loads (each is listed as a warning), and a task that reaches one
/// stops with E0111 naming it (or goes on, when the user stubs it). They also keep
/// abbreviations honest (`L` is not taken for `LMOVE` when the controller knows `LAPPRO`).
pub const UNSUPPORTED: &[&str] = &["extcall", "intfchk", "japro", "prefetch.sigins"];

/// Families of application instructions (multi-robot `L3…` forms, `RTC_…`, `UDP_…`, the
/// interface panel's `IFPW…`), by
/// prefix: they load as not emulated like [`UNSUPPORTED`].
pub const UNSUPPORTED_PREFIXES: &[&str] = &["l3", "rtc_", "udp_", "ifpw"];

/// First words of a block-teaching step (`JOINT SPEED9 ACCU1 … #[…]`): loaded as not
/// emulated when the line is a step (its second word starts with `SPEED`, or it holds `#[`).
pub const BLOCK_TEACHING: &[&str] = &[
    "joint",
    "linear",
    "linear2",
    "circular",
    "circular2",
    "xlinear",
    "fine",
];

/// Functions the controller has but the emulator does not compute: a statement that uses
/// one loads as not emulated.
pub const UNSUPPORTED_FUNCTIONS: &[&str] = &["strtopos", "time"];

/// Whether `word` (lower case, at the start of a statement) is an instruction that loads as
/// not emulated: in [`UNSUPPORTED`] or one of the [`UNSUPPORTED_PREFIXES`] families, and not
/// an instruction the interpreter runs.
pub fn not_emulated(word: &str) -> bool {
    if statement(word).is_some() {
        return false;
    }
    UNSUPPORTED.contains(&word)
        || (UNSUPPORTED_PREFIXES
            .iter()
            .any(|p| word.starts_with(p) && word.len() > p.len()))
}

/// Monitor commands accepted after `MC`: (keyword, shortest accepted form).
pub const MONITOR: &[(&str, usize)] = &[
    ("abort", 2),
    ("continue", 4),
    ("ereset", 3),
    ("execute", 2),
    ("hold", 2),
    ("pcabort", 4),
    ("pcexecute", 4),
    ("speed", 2),
];

/// Monitor commands the controller knows but `MC` here does not run.
pub const MONITOR_UNSUPPORTED: &[&str] = &[
    "delete",
    "directory",
    "edit",
    "erase",
    "kill",
    "list",
    "load",
    "save",
    "status",
    "step",
    "zpower",
    "pcstatus",
    "pcend",
    "pckill",
    "pcstep",
    "pccontinue",
];

/// System switches that `name ON|OFF`, `ENABLE name`, `DISABLE name` and `SWITCH(name)`
/// know, with their power-on state. Only `ABS.SPEED` changes motion here; the others are
/// remembered and reported.
pub const SYSTEM_SWITCHES: &[(&str, bool)] = &[
    ("abs.speed", false),
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
    ("prefetch.sigins", false),
    ("prog.date", false),
    ("qtool", false),
    ("rep_once", false),
    ("repeatonce", false),
    ("rps", false),
    ("screen", true),
    ("stepone", false),
];

/// Switches the controller has but the emulator does not keep: `SWITCH(name)` of one loads
/// as not emulated.
pub const UNSUPPORTED_SWITCHES: &[&str] =
    &["emergency", "safety_fence", "tp_emg", "op_emg", "ex_emg"];

/// Panel switches read by `SWITCH(name)`.
pub const PANEL_SWITCHES: &[&str] = &["power", "run", "repeat", "teach_lock", "cs", "error"];

/// Resolves `word` (lower case) against `table`: an exact keyword, or a prefix at least as long
/// as the keyword's shortest form that matches exactly one keyword of `table` and none of
/// `others`.
pub fn resolve(
    word: &str,
    table: &[(&'static str, usize)],
    others: &[&str],
) -> Option<&'static str> {
    if let Some((k, _)) = table.iter().find(|(k, _)| *k == word) {
        return Some(k);
    }
    let mut found = None;
    for (k, min) in table {
        if word.len() >= *min && k.starts_with(word) {
            if found.is_some() {
                return None;
            }
            found = Some(*k);
        }
    }
    if found.is_some() && others.iter().any(|o| o.starts_with(word)) {
        return None;
    }
    found
}

/// Resolves a statement keyword.
pub fn statement(word: &str) -> Option<&'static str> {
    resolve(word, STATEMENTS, UNSUPPORTED)
}

/// Resolves a monitor command after `MC`.
pub fn monitor(word: &str) -> Option<&'static str> {
    resolve(word, MONITOR, MONITOR_UNSUPPORTED)
}

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
    fn abbreviations() {
        assert_eq!(monitor("exec"), Some("execute"));
        assert_eq!(monitor("ex"), Some("execute"));
        assert_eq!(monitor("e"), None);
        assert_eq!(monitor("ere"), Some("ereset"));
        assert_eq!(monitor("cont"), Some("continue"));
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
        assert_eq!(statement("jappr"), None);
        assert!(not_emulated("extcall"));
        assert!(!not_emulated("drive"));
        assert!(!not_emulated("hmove"));
        assert!(!not_emulated("c1move"));
        assert!(!not_emulated("jappro"));
        assert!(not_emulated("l3jmove"));
        assert!(!not_emulated("jmove"));
        assert!(!not_emulated("tcp_send"));
        assert_eq!(statement("sca"), Some("scase"));
        assert_eq!(statement("pr"), None);
        assert_eq!(statement("pri"), Some("print"));
        assert_eq!(statement("en"), None);
        assert_eq!(statement("dec"), None);
        assert_eq!(statement("deco"), Some("decompose"));
        // Every shortest form resolves to its keyword.
        for (k, min) in STATEMENTS {
            assert_eq!(statement(&k[..*min]), Some(*k), "{k}");
        }
        for (k, min) in MONITOR {
            assert_eq!(monitor(&k[..*min]), Some(*k), "{k}");
        }
        // No shortest form shadows another keyword.
        for (k, min) in STATEMENTS {
            for (o, _) in STATEMENTS {
                if k != o {
                    assert!(
                        &k[..*min] == *k || !o.starts_with(&k[..*min]),
                        "{k} shortest form {} is a prefix of {o}",
                        &k[..*min]
                    );
                }
            }
        }
    }
}
