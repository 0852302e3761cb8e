//! The interface panel's instructions (AS-E p.6-96…6-100): what the panel would show is kept,
//! and the program goes on.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

mod common;

use common::*;
use fs020n_as::{Interpreter, TaskId};
use fs020n_proto::ErrorCode;

fn rows(i: &Interpreter, window: usize) -> Vec<&str> {
    i.interface_panel().windows[window - 1]
        .rows
        .iter()
        .map(String::as_str)
        .collect()
}

#[test]
fn ifpwprint_clears_the_window_and_ifpwoverwrite_keeps_the_other_rows_as_the_manual_shows() {
    // AS-E p.5-117: from a window showing "This is a pen", one word a row.
    let body = "  IFPWPRINT 1 = \"This\", \"is\", \"a\", \"pen\"\n  \
                IFPWPRINT 2 = \"This\", \"is\", \"a\", \"pen\"\n  \
                IFPWPRINT 1, 3, 1, 7, 10 = \"my\"\n  \
                IFPWOVERWRITE 2, 3, 1, 7, 10 = \"my\"\n  \
                done = 1";
    let (i, _) = run_pc(body, 0.1);
    assert_eq!(i.real("done"), Some(1.0), "the program went on");
    assert_eq!(rows(&i, 1), ["", "", "my", ""]);
    assert_eq!(rows(&i, 2), ["This", "is", "my", "pen"]);
    let w = &i.interface_panel().windows[0];
    assert_eq!(
        (w.row, w.column, w.background, w.label_colour),
        (3, 1, 7, 10)
    );
}

#[test]
fn omitted_places_take_the_windows_last_and_long_strings_wrap_at_the_column() {
    let body = "  IFPWPRINT 3, 2, 5, 1, 9 = \"ab\"\n  \
                IFPWPRINT 3 = \"cd\" + $CHR(9) + \"e\"\n  \
                $long = \"\"\n  \
                FOR k = 1 TO 80\n    $long = $long + \"x\"\n  END\n  \
                IFPWOVERWRITE 4, 3, 70 = $long, \"next\"";
    let (i, _) = run_pc(body, 0.5);
    // Row 2, column 5 again; a control character shows as a blank.
    assert_eq!(rows(&i, 3), ["", "    cd e", "", ""]);
    // 80 characters from column 70 of row 3: 9 there, the rest at column 70 of the next
    // rows; "next" falls outside the window and is not shown.
    let r = rows(&i, 4);
    assert_eq!(r[2], format!("{}{}", " ".repeat(69), "x".repeat(9)));
    assert_eq!(r[3], format!("{}{}", " ".repeat(69), "x".repeat(9)));
    assert_eq!(r[0], "");
}

#[test]
fn ifplabel_changes_only_the_labels_given_and_ifptitle_names_a_page() {
    let body = "  IFPLABEL 10, \"one\", \"two\", \"three\", \"four\"\n  \
                IFPLABEL 10, , ,\"label 3\"\n  \
                IFPTITLE 2, \"Cell\"";
    let (i, _) = run_pc(body, 0.1);
    let p = i.interface_panel();
    assert_eq!(p.labels[&10], ["one", "two", "label 3", "four"]);
    assert_eq!(p.titles[&2], "Cell");
}

#[test]
fn a_window_or_place_out_of_range_is_an_illegal_value() {
    for body in [
        "  IFPWPRINT 9 = \"x\"",
        "  IFPWPRINT 1, 5 = \"x\"",
        "  IFPWPRINT 1, 1, 71 = \"x\"",
        "  IFPWPRINT 1, 1, 1, 16 = \"x\"",
        "  IFPLABEL 113, \"x\"",
    ] {
        let (_, s) = run_pc(body, 0.1);
        assert_eq!(s.raised, [ErrorCode::VALUE_OUT_OF_RANGE], "{body}");
        let lines = s.lines_of(TaskId::Pc(1));
        assert!(
            lines.iter().any(|l| l.starts_with("(E0106)")),
            "{body}: {lines:?}"
        );
    }
}

#[test]
fn the_panel_instructions_load_as_emulated() {
    let src = pc("  IFPWPRINT 1 = \"a\"\n  IFPWOVERWRITE 1 = \"b\"\n  IFPLABEL 1, \"c\"\n  IFPTITLE 1, \"d\"");
    let i = Interpreter::from_source("p.as", &src, fs020n_as::Config::default()).expect("loads");
    assert!(i.warnings().is_empty(), "{:?}", i.warnings());
}
