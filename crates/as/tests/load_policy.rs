//! The load policy as a property: a program line `WORD args…` whose word the emulator does not
//! run — a keyword of the table it does not model, or a word in no table — loads as not
//! emulated whenever its argument list is well formed (strings closed, brackets balanced), and
//! is refused, naming line and column, when it is not.

use fs020n_as::ast::StmtKind;
use fs020n_as::keywords::{self, Lookup, Role};
use proptest::prelude::*;

fn cases(default: u32) -> u32 {
    std::env::var("FS020N_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// A word the emulator does not run as an instruction (and that is no structure word, no
/// system switch it keeps, no block-teaching word).
fn word() -> impl Strategy<Value = String> {
    let unknown = "[a-z][a-z0-9_]{2,11}";
    let from_table: Vec<&'static str> = keywords::table()
        .iter()
        .filter(|k| {
            k.roles.contains(Role::INSTRUCTION)
                && !k.runs.contains(Role::INSTRUCTION)
                && k.name
                    .bytes()
                    .all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'.')
        })
        .map(|k| k.name)
        .collect();
    prop_oneof![
        unknown.prop_map(|s| s.to_string()),
        proptest::sample::select(from_table).prop_map(str::to_owned),
    ]
    .prop_filter("a word the emulator does not run", |w| {
        !matches!(keywords::lookup(w, Role::INSTRUCTION), Lookup::Found(k) if k.runs.contains(Role::INSTRUCTION))
            && !matches!(keywords::lookup(w, Role::INSTRUCTION), Lookup::Ambiguous(..))
            && keywords::system_switch_default(w).is_none()
            && !keywords::BLOCK_TEACHING.contains(&w.as_str())
    })
}

/// One well-formed argument: a number, a name, a string, a joint constant, a call, an array
/// element, a qualifier, or an omitted value.
fn arg() -> impl Strategy<Value = String> {
    let leaf = prop_oneof![
        (-1000i32..1000).prop_map(|n| n.to_string()),
        "[a-z][a-z0-9_.]{0,8}".prop_map(|s| s.to_string()),
        "\\.[a-z][a-z0-9_]{0,6}".prop_map(|s| s.to_string()),
        "[#$][a-z][a-z0-9]{0,6}".prop_map(|s| s.to_string()),
        "\"[ -!#-~]{0,10}\"".prop_map(|s| s.to_string()),
        "/[A-Z]{1,3}".prop_map(|s| s.to_string()),
        Just(String::new()),
    ];
    leaf.prop_recursive(3, 12, 4, |inner| {
        prop_oneof![
            proptest::collection::vec(inner.clone(), 0..4)
                .prop_map(|v| format!("({})", v.join(", "))),
            proptest::collection::vec(inner.clone(), 1..4)
                .prop_map(|v| format!("#[{}]", v.join(","))),
            ("[a-z]{1,6}", proptest::collection::vec(inner.clone(), 1..3))
                .prop_map(|(n, v)| format!("{n}[{}]", v.join(","))),
            (inner.clone(), inner).prop_map(|(a, b)| format!("{a} + {b}")),
        ]
    })
}

fn line() -> impl Strategy<Value = (String, String)> {
    (
        word(),
        proptest::collection::vec(arg(), 0..6),
        prop_oneof![Just(", "), Just(" "), Just(",")],
    )
        .prop_map(|(w, args, sep)| {
            (
                w.clone(),
                format!("{} {}", w.to_uppercase(), args.join(sep)),
            )
        })
        // A word followed by `=` or `[` is an assignment, and `word:` a label.
        .prop_filter("not an assignment or a label", |(_, l)| {
            let rest = l.split_once(' ').map_or("", |(_, r)| r).trim_start();
            !rest.starts_with('=') && !rest.starts_with('[') && !rest.starts_with(':')
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(cases(300)))]

    #[test]
    fn a_well_formed_line_of_a_word_not_run_loads_as_not_emulated((word, text) in line()) {
        let src = format!(".PROGRAM p()\n  {text}\n.END\n");
        let m = match fs020n_as::parse("t.as", &src) {
            Ok(m) => m,
            Err(e) => return Err(TestCaseError::fail(format!("{src:?}: {e}"))),
        };
        let body = &m.programs[0].body;
        prop_assert_eq!(body.len(), 1, "{:?}", src);
        match &body[0].kind {
            StmtKind::NotEmulated { instruction, .. } => {
                let first = instruction.split([' ', '(']).next().unwrap_or("");
                prop_assert_eq!(first.to_ascii_lowercase(), word.clone());
            }
            other => return Err(TestCaseError::fail(format!("{src:?}: {other:?}"))),
        }
        prop_assert!(fs020n_as::Interpreter::new(&[m], fs020n_as::Config::default()).is_ok());
    }

    #[test]
    fn an_unbalanced_line_of_a_word_not_run_is_refused_at_its_line((_, text) in line(), cut in 0usize..3) {
        let broken = match cut {
            0 => format!("{text} ("),
            1 => format!("{text} ]"),
            _ => format!("{text} \"open"),
        };
        let src = format!(".PROGRAM p()\n  {broken}\n.END\n");
        let e = fs020n_as::parse("t.as", &src);
        prop_assert!(e.is_err(), "{:?}", src);
        if let Err(e) = e {
            prop_assert_eq!(e.errors[0].span.line, 2);
            prop_assert!(e.errors[0].message.contains("a controller refuses this line too"));
        }
    }
}

#[test]
fn a_large_file_of_not_emulated_lines_loads() {
    let mut src = String::from(".PROGRAM p()\n");
    for k in 0..20_000 {
        src.push_str(&format!("  COLRON {k}, (a + {k}), #[1,2,3], \"s\"\n"));
    }
    src.push_str(".END\n");
    let m = fs020n_as::parse("big.as", &src).expect("loads");
    assert_eq!(m.programs[0].body.len(), 20_000);
}
