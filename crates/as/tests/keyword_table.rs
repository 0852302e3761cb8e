//! The keyword table (`fs020n_as::keywords`): it covers every keyword of the E manual's
//! reference chapters, its abbreviations resolve as the manual says, and the keyword table in
//! docs/AS-KEYWORDS.md is generated from it (`FS020N_BLESS=1 cargo test -p fs020n-as --test
//! keyword_table` rewrites the page after a change to the table).

use fs020n_as::keywords::{self, Lookup, Role};

/// The keyword names of the E manual's chapters 5–10 (program instructions, monitor commands,
/// functions, SYSDATA keywords, system switches), as its index lists them: 366 names.
const MANUAL_INDEX: &[&str] = &[
    "jmove",
    "lmove",
    "delay",
    "stable",
    "jappro",
    "lappro",
    "jdepart",
    "ldepart",
    "home",
    "drive",
    "draw",
    "tdraw",
    "align",
    "hmove",
    "xmove",
    "c1move",
    "c2move",
    "speed",
    "accuracy",
    "accel",
    "decel",
    "break",
    "brake",
    "bspeed",
    "reffltset",
    "reffltreset",
    "ffset",
    "ffreset",
    "open",
    "openi",
    "close",
    "closei",
    "relax",
    "relaxi",
    "opens",
    "closes",
    "relaxs",
    "gunon",
    "gunoff",
    "gunontimer",
    "gunofftimer",
    "righty",
    "lefty",
    "above",
    "below",
    "uwrist",
    "dwrist",
    "goto",
    "if",
    "call",
    "return",
    "wait",
    "twait",
    "mvwait",
    "lock",
    "pause",
    "halt",
    "stop",
    "scall",
    "one",
    "returne",
    "jump",
    "sjump",
    "mon_twait",
    "then",
    "else",
    "end",
    "while",
    "do",
    "until",
    "for",
    "step",
    "case",
    "value",
    "any",
    "scase",
    "svalue",
    "reset",
    "signal",
    "pulse",
    "dlysig",
    "runmask",
    "bits",
    "bits32",
    "swait",
    "extcall",
    "on",
    "oni",
    "ignore",
    "scnt",
    "scntreset",
    "sflk",
    "sflp",
    "sout",
    "stim",
    "setpick",
    "setplace",
    "clamp",
    "hsenseset",
    "hsense",
    "print",
    "type",
    "prompt",
    "ifpwprint",
    "ifpwoverwrite",
    "ifplabel",
    "ifptitle",
    "setoutda",
    "outda",
    "here",
    "point",
    "oat",
    "ext",
    "decompose",
    "base",
    "tool",
    "set_toolshape",
    "ena_toolshape",
    "toolshape",
    "sethome",
    "set2home",
    "ulimit",
    "llimit",
    "timer",
    "utimer",
    "nchon",
    "nchoff",
    "weight",
    "mc",
    "tplight",
    "curlim",
    "settime",
    "envchkrate",
    "delete",
    "trace",
    "nload",
    "sload",
    "pcexecute",
    "pcabort",
    "pcend",
    "pcscan",
    "usb_fdir",
    "directory",
    "list",
    "usb_fdel",
    "rename",
    "usb_rename",
    "xfer",
    "copy",
    "usb_copy",
    "settrace",
    "restrace",
    "lstrace",
    "save",
    "sys",
    "rob",
    "elog",
    "oplog",
    "alllog",
    "full",
    "stg",
    "usb_save",
    "load",
    "usb_load",
    "usb_mkdir",
    "prime",
    "execute",
    "mstep",
    "abort",
    "hold",
    "continue",
    "stpnext",
    "kill",
    "status",
    "where",
    "io",
    "free",
    "time",
    "errlog",
    "switch",
    "off",
    "zsigspec",
    "hsetclamp",
    "defsig",
    "zzero",
    "ereset",
    "sysinit",
    "help",
    "id",
    "encchk_emg",
    "encchk_pon",
    "slow_repeat",
    "rec_accept",
    "env_data",
    "env2_data",
    "chsum",
    "ipeaklog",
    "ipeakclr",
    "opeinfo",
    "opeinfoclr",
    "reffltset_status",
    "ffset_status",
    "ioboard_status",
    "pcstatus",
    "pckill",
    "pccontinue",
    "pcstep",
    "sig",
    "distance",
    "dx",
    "dy",
    "dz",
    "dext",
    "asc",
    "len",
    "true",
    "false",
    "val",
    "instr",
    "maxval",
    "minval",
    "int",
    "maxindex",
    "minindex",
    "whichtask",
    "task",
    "error",
    "priority",
    "mspeed",
    "mspeed2",
    "inrange",
    "sysdata",
    "existjoint",
    "existtrans",
    "existreal",
    "existchar",
    "existinteger",
    "existpgm",
    "existlocaljoint",
    "existlocaltrans",
    "existlocalreal",
    "existlocalchar",
    "existlocalinteger",
    "strtopos",
    "strtoval",
    "round",
    "iqarm",
    "trqnm",
    "curlimm",
    "curlimp",
    "getenctemp",
    "dest",
    "#dest",
    "frame",
    "null",
    "#here",
    "trans",
    "rx",
    "ry",
    "rz",
    "#ppoint",
    "shift",
    "ave_trans",
    "tradd",
    "trsub",
    "#home",
    "ccenter",
    "cshift",
    "abs",
    "sqrt",
    "pi",
    "sin",
    "cos",
    "atan2",
    "random",
    "$chr",
    "$space",
    "$left",
    "$right",
    "$mid",
    "$decode",
    "$encode",
    "$errors",
    "$error",
    "$date",
    "$time",
    "$sysdata",
    "$errlog",
    "$errorlog",
    "$str_id",
    "$str_id2",
    "m.speed",
    "p.speed",
    "p.speed.m",
    "p.accel",
    "p.decel",
    "mtr.rpm",
    "mtr.rpm.cmd",
    "tool.vel.cmd",
    "jt.vel.cmd",
    "numrobot",
    "zrob.mgfno",
    "zrob.nowaxis",
    "sig.do",
    "sig.di",
    "sig.int",
    "language",
    "mem.free",
    "zrob.name",
    "cp",
    "check.hold",
    "cycle.stop",
    "messages",
    "ox.preout",
    "prefetch.sigins",
    "qtool",
    "rps",
    "screen",
    "rep_once",
    "stp_once",
    "autostart.pc",
    "autostart2.pc",
    "autostart5.pc",
    "errstart.pc",
    "trigger",
    "cs",
    "power",
    "rgso",
    "teach_lock",
    "repeat",
    "run",
    "pnl_cycst",
    "pnl_mpower",
    "pnl_ereset",
    "tpkey_a",
    "tpkey_s",
    "dispio_01",
    "hold.step",
    "ws_compoff",
    "flowrate",
    "ws.zero",
    "abs.speed",
    "slow_start",
    "after.wait.tmr",
    "sf_open_error",
    "stat_on_kybd",
    "waitrel_auto",
    "rep_once.rps_last",
    "dest_cirint",
    "prog.date",
    "insert_no_confirm",
    "sigmon_teach",
    "touch.ena",
    "touchst.ena",
    "tpspeed.reset",
    "oxzero",
    "ifakey",
    "disp.exestep",
    "no_sjisconv",
    "conf_variable",
    "invalid.tpkey_s",
    "divide.tpkey_s",
    "sigrstconf",
    "singular",
    "use_iso8859_5",
    "spot_op",
];

#[test]
fn the_table_covers_every_keyword_of_the_manuals_index() {
    assert_eq!(MANUAL_INDEX.len(), 366);
    let missing: Vec<&&str> = MANUAL_INDEX
        .iter()
        .filter(|n| keywords::get(n).is_none())
        .collect();
    assert!(missing.is_empty(), "not in the table: {missing:?}");
    let table = keywords::table();
    assert!(
        table.len() > MANUAL_INDEX.len(),
        "the table ({}) holds the manual's {} names and those of real files",
        table.len(),
        MANUAL_INDEX.len()
    );
    let count = |r: Role| table.iter().filter(|k| k.roles.contains(r)).count();
    assert!(
        count(Role::INSTRUCTION) >= 300,
        "{}",
        count(Role::INSTRUCTION)
    );
    assert!(count(Role::MONITOR) >= 100, "{}", count(Role::MONITOR));
    assert!(count(Role::FUNCTION) >= 60, "{}", count(Role::FUNCTION));
    assert!(count(Role::SWITCH) >= 60, "{}", count(Role::SWITCH));
}

#[test]
fn the_commands_mc_runs_are_the_manuals_six_the_pc_program_commands_and_zpower() {
    let mut mc: Vec<&str> = keywords::table()
        .iter()
        .filter(|k| k.runs.contains(Role::AFTER_MC))
        .map(|k| k.name)
        .collect();
    mc.sort_unstable();
    assert_eq!(
        mc,
        [
            "abort",
            "continue",
            "ereset",
            "execute",
            "hold",
            "pcabort",
            "pcexecute",
            "speed",
            "zpower"
        ]
    );
}

#[test]
fn a_terminal_abbreviation_resolves_among_monitor_commands() {
    for (typed, full) in [
        ("pcexe", "pcexecute"),
        ("ex", "execute"),
        ("sta", "status"),
        ("di", "directory"),
    ] {
        match keywords::lookup(typed, Role::MONITOR) {
            Lookup::Found(k) => assert_eq!(k.name, full, "{typed}"),
            other => panic!("{typed}: {other:?}"),
        }
    }
}

/// The page, from the table.
fn page() -> String {
    let mut out = String::from(
        "# AS keywords\n\n\
         Generated from the keyword table of `fs020n-as` (`crates/as/src/keywords/table.rs`) by\n\
         `FS020N_BLESS=1 cargo test -p fs020n-as --test keyword_table`; a test fails when the two\n\
         differ. Every keyword of the E-series reference manual's chapters 5–10, with the\n\
         manual's shortest abbreviation, and the keywords real programs and saves use beyond it.\n\n\
         - **roles**: I program instruction, M monitor command (MC: also after `MC`), E editor\n  \
         command, F function, S system switch, D `SYSDATA` keyword, W a word inside statements.\n\
         - **runs**: the roles the emulator runs. A role it does not run loads as *not\n  \
         emulated* (docs/AS.md, the load policy). At the emulated terminal a keyword with\n  \
         both I and M runs as the instruction (docs/EMULATOR.md, `DO`).\n\
         - **grammar**: the arguments as a program instruction (else as a monitor command, else\n  \
         of the function) in the table's notation: `[…]` may be omitted, `…` repeats, UPPER\n  \
         CASE is literal, `?` undocumented.\n\n\
         | keyword | abbr. | roles | runs | generations | grammar |\n\
         |---|---|---|---|---|---|\n",
    );
    let letters = |r: Role| {
        let mut s = String::new();
        for (role, l) in [
            (Role::INSTRUCTION, "I"),
            (Role::MONITOR, "M"),
            (Role::AFTER_MC, "MC"),
            (Role::EDITOR, "E"),
            (Role::FUNCTION, "F"),
            (Role::SWITCH, "S"),
            (Role::SYSDATA, "D"),
            (Role::WORD, "W"),
        ] {
            if r.contains(role) {
                if !s.is_empty() {
                    s.push(' ');
                }
                s.push_str(l);
            }
        }
        s
    };
    for k in keywords::table() {
        let grammar = k
            .instruction
            .or(k.monitor)
            .or(k.function)
            .or(k.editor)
            .unwrap_or("")
            .replace('|', "\\|");
        let grammar = if grammar.is_empty() {
            String::new()
        } else {
            format!("`{grammar}`")
        };
        out.push_str(&format!(
            "| `{}` | {} | {} | {} | {} | {} |\n",
            k.name.to_uppercase(),
            k.abbr.map(|a| a.to_uppercase()).unwrap_or_default(),
            letters(k.roles),
            letters(k.runs),
            k.generations.letters(),
            grammar
        ));
    }
    out
}

#[test]
fn docs_keyword_page_is_generated_from_the_table() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/AS-KEYWORDS.md");
    let want = page();
    if std::env::var_os("FS020N_BLESS").is_some() {
        std::fs::write(path, &want).expect("write docs/AS-KEYWORDS.md");
    }
    let have = std::fs::read_to_string(path).unwrap_or_default();
    assert!(
        have == want,
        "docs/AS-KEYWORDS.md is not the table's page: run FS020N_BLESS=1 cargo test -p fs020n-as --test keyword_table"
    );
}
