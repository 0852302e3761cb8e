//! Files are bytes in the code page of the controller or the editor: none is refused for its
//! encoding, comments may hold any bytes, and the bytes of strings survive as written.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use fs020n_as::ast::DataValue;
use fs020n_as::{parse_bytes, Config, LoadOptions, Loaded};

/// Loads `bytes` and returns the global string `$s`.
fn string_s(bytes: &[u8]) -> Vec<u8> {
    let l = Loaded::from_bytes("enc.as", bytes, &LoadOptions::new(), Config::default())
        .unwrap_or_else(|e| panic!("{e}"));
    l.interpreter.string("s").expect("$s is set")
}

fn data_file(string: &[u8], comment: &[u8]) -> Vec<u8> {
    let mut v = b".STRINGS\r\n$s = \"".to_vec();
    v.extend_from_slice(string);
    v.extend_from_slice(b"\" ; ");
    v.extend_from_slice(comment);
    v.extend_from_slice(b"\r\n.END\r\n");
    v
}

#[test]
fn shift_jis_strings_and_comments_keep_their_bytes() {
    // "テスト" and "コメント" in Shift-JIS.
    let s = b"\x83\x65\x83\x58\x83\x67";
    assert_eq!(
        string_s(&data_file(s, b"\x83\x52\x83\x81\x83\x93\x83\x67")),
        s
    );
}

#[test]
fn gbk_strings_and_comments_keep_their_bytes() {
    // "机器人" and "注释" in GBK.
    let s = b"\xbb\xfa\xc6\xf7\xc8\xcb";
    assert_eq!(string_s(&data_file(s, b"\xd7\xa2\xca\xcd")), s);
}

#[test]
fn windows_1250_strings_and_comments_keep_their_bytes() {
    // "chwytak zamknięty" and "ŁĄCZ" in Windows-1250.
    let s = b"chwytak zamkni\xeaty";
    assert_eq!(string_s(&data_file(s, b"\xa3\xa5CZ")), s);
}

#[test]
fn utf8_strings_keep_their_bytes() {
    let s = "größer — ロボット".as_bytes();
    assert_eq!(string_s(&data_file(s, "ümlaut".as_bytes())), s);
}

#[test]
fn damaged_bytes_load() {
    // A UTF-8 sequence cut short, a lone continuation byte, an invalid byte.
    let s = b"\xe3\x83 \x80 \xff";
    assert_eq!(string_s(&data_file(s, b"\xc3\x28 \xfe\xfe")), s);
}

#[test]
fn a_program_with_shift_jis_comments_runs_and_prints_its_bytes() {
    use fs020n_as::testing::VirtualSystem;
    let text = b".PROGRAM autostart.pc() #0 ; \x83\x52\x83\x81\r\n  $s = \"\x83\x65\x83\x58\x83\x67\" ; \x83\x52\r\n  PRINT $s\r\n.END\r\n";
    let mut i = Loaded::from_bytes("sjis.as", text, &LoadOptions::new(), Config::default())
        .expect("loads")
        .interpreter;
    let mut sys = VirtualSystem::new();
    i.start(&mut sys);
    i.run_until(&mut sys, std::time::Duration::from_millis(50));
    assert_eq!(i.string("s").expect("set"), b"\x83\x65\x83\x58\x83\x67");
}

#[test]
fn columns_count_characters_in_utf8_lines_and_bytes_in_other_code_pages() {
    // UTF-8: "é" is one column, so `?` stands at column 12.
    let e = parse_bytes(
        "c.as",
        ".PROGRAM p()\n  $s = \"é\" ? 1\n.END\n".as_bytes(),
        &LoadOptions::new(),
    )
    .unwrap_err();
    assert_eq!(e.errors[0].span.col, 12);
    // Shift-JIS: the two bytes of "テ" are two columns, so `?` stands at column 13.
    let e = parse_bytes(
        "c.as",
        b".PROGRAM p()\n  $s = \"\x83\x65\" ? 1\n.END\n",
        &LoadOptions::new(),
    )
    .unwrap_err();
    assert_eq!(e.errors[0].span.col, 13);
}

#[test]
fn a_non_ascii_byte_in_code_is_an_error_naming_it() {
    let e = parse_bytes(
        "c.as",
        b".PROGRAM p()\n  a\xff = 1\n.END\n",
        &LoadOptions::new(),
    )
    .unwrap_err();
    assert_eq!(
        e.to_string(),
        "c.as:2:4: unexpected character byte 0xFF (outside a string or a comment)"
    );
}

#[test]
fn no_break_and_ideographic_spaces_and_a_byte_order_mark_read_as_blanks() {
    let text = "\u{feff}.PROGRAM p()\n  a\u{a0}=\u{3000}1\n.END\n";
    let m = parse_bytes("b.as", text.as_bytes(), &LoadOptions::new()).expect("loads");
    assert_eq!(m.programs[0].body.len(), 1);
}

#[test]
fn text_and_bytes_entry_points_agree() {
    let text = ".PROGRAM p()\r\n  $s = \"ü\" ; ö\r\n.END\r\n.STRINGS\r\n$t = \"ä\"\r\n.END\r\n";
    let a = fs020n_as::parse("x.as", text).expect("loads");
    let b = parse_bytes("x.as", text.as_bytes(), &LoadOptions::new()).expect("loads");
    assert_eq!(a, b);
    assert_eq!(a.data[0].value, DataValue::Str("ä".as_bytes().to_vec()));
}

mod no_panic_on_bytes {
    use fs020n_as::lint::Generation;
    use fs020n_as::{check, parse_bytes, LoadOptions};
    use proptest::prelude::*;

    /// Pieces of backups and programs, with bytes of several code pages, to splice together.
    const PIECES: &[&[u8]] = &[
        b".PROGRAM a() #0\r\n",
        b".program b (.$d[], .x)\n",
        b".END\r\n",
        b"   .END  \n",
        b".NETCONF 1.2.3.4\n",
        b".SIG_COMMENT\n",
        b".SYSDATA\nSWITCH AUTOSTART.PC ON\n",
        b".REALS\nx = ^H10\n",
        b".STRINGS\n$s = \"\x83\x65\"\n",
        b"JOINT SPEED9 #[0,1]\n",
        b"1 TOOL t\n",
        b"  IF a != 1 | b THEN\n",
        b"  END\n",
        b"  CALL b(.$d[], 1)\n",
        b"  TCP_RECV .r, .s, .$b[1], .n, 0.5, 9\n",
        b"  very_long_variable_name_1 = 2\n",
        b"; \xbb\xfa \xff\xfe\n",
        b"\xef\xbb\xbf\xe3\x80\x80\xc2\xa0\r",
        b".*\n",
        b".UNKNOWN 1\n",
    ];

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]

        #[test]
        fn arbitrary_bytes_never_panic_the_loader_or_the_check(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
            let _ = parse_bytes("f.as", &bytes, &LoadOptions::new().stub("tool"));
            let _ = check("f.as", &bytes, &LoadOptions::new(), Some(Generation::D));
        }

        #[test]
        fn spliced_backups_never_panic_the_loader_or_the_check(picks in proptest::collection::vec(0..PIECES.len(), 0..30)) {
            let bytes: Vec<u8> = picks.iter().flat_map(|&k| PIECES[k].iter().copied()).collect();
            let _ = parse_bytes("f.as", &bytes, &LoadOptions::new());
            let r = check("f.as", &bytes, &LoadOptions::new(), None);
            prop_assert!(r.loaded || !r.errors.is_empty());
        }
    }
}
