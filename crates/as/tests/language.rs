//! The language: values, operators, functions, formats, control flow, calls, data sections,
//! runtime errors with their AS codes, and load errors with file:line:column.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

mod common;

use std::time::Duration;

use common::*;
use fs020n_as::TaskId;
use fs020n_proto::ErrorCode;

#[test]
fn reals_are_32_bit() {
    let (i, _) = run_pc(
        "  a = 16777216 + 1\n  b = 0.1 + 0.2\n  c = 1 / 3\n  d = 1E38 * 10 / 10\n",
        0.1,
    );
    assert_eq!(i.real("a"), Some(16_777_216.0));
    assert_eq!(i.real("b"), Some(0.1f32 + 0.2f32));
    assert_eq!(i.real("c"), Some(1.0f32 / 3.0));
    // 1E39 overflows a 32-bit real: E0109, the task stops before d is assigned.
    assert_eq!(i.real("d"), None);
}

#[test]
fn operators_and_precedence() {
    let (i, s) = run_pc(
        "  a = 2 + 3 * 4 ^ 2\n\
         b = -2 ^ 2\n\
         c = 7 MOD 3 + (-7 MOD 3) * 10\n\
         d = NOT 1 == 2\n\
         e = 3 AND 0\n\
         f = 3 OR 0\n\
         g = 1 XOR 1\n\
         h = 12 BAND 10\n\
         k = 12 BOR 3\n\
         l = 12 BXOR 10\n\
         m = COM 0\n\
         n = 1 < 2 AND 2 <= 2 AND 3 > 2 AND 3 >= 3 AND 1 <> 2\n\
         o = TRUE + FALSE * 2 + ON\n\
         p = 10 - 2 - 3\n\
         q = 2 ^ 3 ^ 2\n\
         r = \"abc\" < \"abd\"\n",
        0.1,
    );
    assert!(s.raised.is_empty(), "{:?}", s.terminal);
    let r = |n: &str| i.real(n).unwrap_or_else(|| panic!("{n} not set"));
    assert_eq!(r("a"), 50.0);
    assert_eq!(r("b"), -4.0);
    assert_eq!(r("c"), 1.0 - 10.0);
    // Unary NOT binds tighter than ==: (NOT 1) == 2 (AS-E p.3-22).
    assert_eq!(r("d"), 0.0);
    assert_eq!(r("e"), 0.0);
    assert_eq!(r("f"), -1.0);
    assert_eq!(r("g"), 0.0);
    assert_eq!(r("h"), 8.0);
    assert_eq!(r("k"), 15.0);
    assert_eq!(r("l"), 6.0);
    assert_eq!(r("m"), -1.0);
    assert_eq!(r("n"), -1.0);
    assert_eq!(r("o"), -2.0);
    assert_eq!(r("p"), 5.0);
    assert_eq!(r("q"), 512.0);
    assert_eq!(r("r"), -1.0);
}

#[test]
fn numeric_functions() {
    let (i, s) = run_pc(
        "  a = ABS(-2.5) + SQRT(16)\n\
         b = SIN(30)\n\
         c = COS(60)\n\
         d = ATAN2(1, 1)\n\
         e = INT(-1.7) * 10 + INT(1.7)\n\
         f = MAXVAL(3, 9, -1) * 10 + MINVAL(3, 9, -1)\n\
         g = VAL(\"12abc\") + VAL(\"  1.5E2x\") + VAL(\"\") + VAL(\"abc\")\n\
         h = VAL(\"^HFF\") + VAL(\"101\", 1) + VAL(\"1f\", 2)\n\
         k = LEN(\"hello\") * 100 + ASC(\"A\") + ASC(\"\")\n\
         l = INSTR(\"a,b,c\", \",\") * 10 + INSTR(3, \"a,b,c\", \",\")\n\
         m = INSTR(\"abc\", \"x\")\n\
         n = DEXT(#PPOINT(1, 2, 3, 4, 5, 6), 5)\n",
        0.1,
    );
    assert!(s.raised.is_empty(), "{:?}", s.terminal);
    let r = |n: &str| i.real(n).unwrap_or_else(|| panic!("{n} not set"));
    assert_eq!(r("a"), 6.5);
    assert!((r("b") - 0.5).abs() < 1e-6);
    assert!((r("c") - 0.5).abs() < 1e-6);
    assert!((r("d") - 45.0).abs() < 1e-5);
    assert_eq!(r("e"), -9.0);
    assert_eq!(r("f"), 89.0);
    assert_eq!(r("g"), 162.0);
    assert_eq!(r("h"), 255.0 + 5.0 + 31.0);
    assert_eq!(r("k"), 500.0 + 65.0 - 1.0);
    assert_eq!(r("l"), 24.0);
    assert_eq!(r("m"), 0.0);
    assert_eq!(r("n"), 5.0);
}

#[test]
fn strings_and_decode() {
    let (i, s) = run_pc(
        "  $s = \"hello\" + \" \" + \"world\"\n\
         $m = $MID($s, 7, 3) + $MID($s, 10) + $MID($s, 50)\n\
         $l = $LEFT($s, 2) + $RIGHT($s, 2) + $LEFT($s, 99)\n\
         $c = $CHR(65) + $CHR(66)\n\
         $in = \"1040  3 1 50\"\n\
         $t1 = $DECODE($in, \" \", 0)\n\
         $b1 = $DECODE($in, \" \", 1)\n\
         $t2 = $DECODE($in, \" \", 0)\n\
         $rest = $in\n\
         $lead = \" x\"\n\
         $e = $DECODE($lead, \" \", 0)\n\
         $set = \"a;B,c\"\n\
         $d = $DECODE($set, \",b\", 0)\n\
         $none = \"abc\"\n\
         $all = $DECODE($none, \" \", 0)\n\
         n = LEN($none)\n\
         $err = $ERROR(-30102)\n",
        0.1,
    );
    assert!(s.raised.is_empty(), "{:?}", s.terminal);
    let st =
        |n: &str| String::from_utf8(i.string(n).unwrap_or_else(|| panic!("${n} not set"))).unwrap();
    assert_eq!(st("s"), "hello world");
    assert_eq!(st("m"), "world");
    assert_eq!(st("l"), "heldhello world");
    assert_eq!(st("c"), "AB");
    assert_eq!(st("t1"), "1040");
    assert_eq!(st("b1"), "  ", "mode 1 cuts the whole run of blanks");
    assert_eq!(st("t2"), "3");
    assert_eq!(st("rest"), " 1 50");
    assert_eq!(st("e"), "", "a leading delimiter gives an empty token");
    assert_eq!(st("lead"), " x");
    assert_eq!(st("d"), "a;", "delimiters are a case-insensitive set");
    assert_eq!(st("set"), "B,c");
    assert_eq!(st("all"), "abc");
    assert_eq!(i.real("n"), Some(0.0));
    assert_eq!(st("err"), "Variable is not defined");
}

#[test]
fn encode_formats() {
    let (i, s) = run_pc(
        "  $a = $ENCODE(1040, 0, -1, 12.5)\n\
         $b = $ENCODE(/F10.3, 12.5, -90, 1000000)\n\
         $c = $ENCODE(\"x=\", /I4, 41.6, /D, 3, /L, 7, /X2, \"|\")\n\
         $d = $ENCODE(/E10.2, 1234.5, /F5.2, 12.66666, 1000)\n\
         $e = $ENCODE(/H4, 255, /J4, 255, /K4, -7, 0.001)\n\
         $f = $ENCODE(0.1, 1/3)\n",
        0.1,
    );
    assert!(s.raised.is_empty(), "{:?}", s.terminal);
    let st = |n: &str| String::from_utf8(i.string(n).unwrap()).unwrap();
    assert_eq!(st("a"), " 1040 0 -1 12.5");
    assert_eq!(
        st("b"),
        "    12.500   -90.000**********",
        "a format carries on within a call"
    );
    assert_eq!(st("c"), "x=  42 37  |");
    assert_eq!(st("d"), "  1.23E+0312.67*****");
    assert_eq!(st("e"), "  FF00FF-0070000");
    assert_eq!(st("f"), " 0.1 0.33333334");
}

#[test]
fn print_and_type() {
    let (_, s) = run_pc(
        "  PRINT \"a\", 1, /F6.2, 2\n\
         TYPE /S, \"no line feed \"\n\
         PRINT \"joined\"\n\
         PRINT 2: \"device\", /C1, \"second\"\n\
         PRINT\n",
        0.1,
    );
    assert_eq!(
        printed(&s),
        vec!["a 1  2.00", "no line feed joined", "device", "second", ""]
    );
}

#[test]
fn control_flow() {
    let (i, s) = run_pc(
        "  n = 0\n\
         FOR .i = 1 TO 10 STEP 3\n\
           n = n + .i\n\
         END\n\
         m = 0\n\
         FOR .i = 5 TO 1 STEP -2\n\
           m = m * 10 + .i\n\
         END\n\
         z = 0\n\
         FOR .i = 3 TO 1\n\
           z = 1\n\
         END\n\
         w = 0\n\
         WHILE w < 5 DO\n\
           w = w + 2\n\
         END\n\
         d = 0\n\
         DO\n\
           d = d + 1\n\
         UNTIL d >= 1\n\
         IF w == 6 THEN\n\
           IF d == 2 THEN\n\
             x = 1\n\
           ELSE\n\
             x = 2\n\
           END\n\
         ELSE\n\
           x = 3\n\
         END\n\
         FOR .k = 1 TO 4\n\
           CASE .k OF\n\
             VALUE 1, 3:\n\
               c[.k] = 10\n\
             VALUE 2:\n\
               c[.k] = 20\n\
             ANY :\n\
               c[.k] = 30\n\
           END\n\
         END\n\
         $k = \"b\"\n\
         CASE $k OF\n\
           VALUE \"a\":\n\
             sc = 1\n\
           VALUE \"b\", \"c\":\n\
             sc = 2\n\
         END\n\
         g = 0\n\
       again:\n\
         g = g + 1\n\
         IF g < 3 GOTO again\n\
         WHILE TRUE DO\n\
           FOR .j = 1 TO 100\n\
             IF .j == 7 GOTO out\n\
           END\n\
         END\n\
       out:\n\
         j = .j\n",
        0.2,
    );
    assert!(s.raised.is_empty(), "{:?}", s.terminal);
    let r = |n: &str| i.real(n).unwrap_or_else(|| panic!("{n} not set"));
    assert_eq!(r("n"), 1.0 + 4.0 + 7.0 + 10.0);
    assert_eq!(r("m"), 531.0);
    assert_eq!(r("z"), 0.0, "a FOR past its limit runs zero times");
    assert_eq!(r("w"), 6.0);
    assert_eq!(r("d"), 1.0);
    assert_eq!(r("x"), 2.0);
    assert_eq!(i.real_at("c", &[1]), Some(10.0));
    assert_eq!(i.real_at("c", &[2]), Some(20.0));
    assert_eq!(i.real_at("c", &[3]), Some(10.0));
    assert_eq!(i.real_at("c", &[4]), Some(30.0));
    assert_eq!(r("sc"), 2.0);
    assert_eq!(r("g"), 3.0);
    assert_eq!(r("j"), 7.0);
}

#[test]
fn calls_parameters_and_locals() {
    let src = ".PROGRAM autostart.pc()\n\
                 .x = 1\n\
                 CALL sub(5, \"s\")\n\
                 a = .x\n\
                 CALL sub(6, \"t\")\n\
                 v = 10\n\
                 CALL twice(v)\n\
                 CALL deep(0)\n\
               .END\n\
               .PROGRAM sub(.n, .$s)\n\
                 .x = .n * 2\n\
                 last = .x\n\
                 $last = .$s\n\
                 RETURN\n\
                 last = -1\n\
               .END\n\
               .PROGRAM twice(.v)\n\
                 .v = .v * 2\n\
               .END\n\
               .PROGRAM deep(.d)\n\
                 depth = .d\n\
                 CALL deep(.d + 1)\n\
               .END\n";
    let (mut i, mut s) = start(src);
    i.run_until(&mut s, ms(100));
    // Locals are per program: autostart.pc's .x is its own.
    assert_eq!(i.real("a"), Some(1.0));
    assert_eq!(i.real("last"), Some(12.0));
    assert_eq!(i.string("last"), Some(b"t".to_vec()));
    assert_eq!(
        i.real("v"),
        Some(20.0),
        "by-reference parameter written back"
    );
    // Runaway recursion stops with E0118 at the CALL depth limit (32 frames).
    assert_eq!(i.real("depth"), Some(30.0));
    assert_eq!(s.raised, vec![ErrorCode(-30118)]);
    assert!(
        s.lines_of(TaskId::Pc(1))
            .iter()
            .any(|l| l.starts_with("(E0118)")),
        "{:?}",
        s.terminal
    );
}

#[test]
fn runtime_errors_stop_the_task_with_their_code() {
    let cases: &[(&str, i32, &str)] = &[
        (
            "  a = b + 1",
            -30102,
            "(E0102) variable not defined: b (assign it before reading it) (autostart.pc line 2)",
        ),
        (
            "  x[1] = 1\n  a = x[2]",
            -30102,
            "(E0102) variable not defined: x[2] (assign it before reading it) (autostart.pc line 3)",
        ),
        (
            "  .l = .m",
            -30102,
            "(E0102) variable not defined: .m (assign it before reading it) (autostart.pc line 2)",
        ),
        (
            "  $s = $t",
            -30104,
            "(E0104) string variable not defined: $t (assign it before reading it) (autostart.pc line 2)",
        ),
        (
            "  a = 1 / 0",
            -30108,
            "(E0108) division by zero (check the divisor before dividing) (autostart.pc line 2)",
        ),
        (
            "  a = 1 MOD 0",
            -30108,
            "(E0108) division by zero (check the divisor before dividing) (autostart.pc line 2)",
        ),
        (
            "  a[-1] = 0",
            -30115,
            "(E0115) array index out of range: -1 in a (indices go from 0 to 9999) (autostart.pc line 2)",
        ),
        (
            "  a[10000] = 0",
            -30115,
            "(E0115) array index out of range: 10000 in a (indices go from 0 to 9999) (autostart.pc line 2)",
        ),
        (
            "  a = SQRT(-1)",
            -30114,
            "(E0114) SQRT of a negative number: SQRT(-1) (autostart.pc line 2)",
        ),
        (
            "  a = 1E30 * 1E30",
            -30109,
            "(E0109) floating point overflow: * (autostart.pc line 2)",
        ),
        (
            "  JMOVE #PPOINT()",
            -31095,
            "(E1095) JMOVE/LMOVE is allowed only in robot programs (move it to the robot program) (autostart.pc line 2)",
        ),
        (
            "  $s = $CHR(65)\n  FOR .i = 1 TO 8\n    $s = $s + $s\n  END",
            -30110,
            "(E0110) string too long (256 characters, at most 255) (autostart.pc line 4)",
        ),
        (
            "  TCP_LISTEN .r, 80",
            -30106,
            "(E0106) value out of range: port 80 (8192 to 65535) (autostart.pc line 2)",
        ),
    ];
    for (body, code, message) in cases {
        let (i, s) = run_pc(&format!("{body}\n  done = 1"), 0.1);
        assert_eq!(s.raised, vec![ErrorCode(*code)], "{body}");
        assert_eq!(s.error, ErrorCode(*code));
        assert_eq!(i.real("done"), None, "{body}: the task stopped");
        assert!(
            printed(&s).contains(&message.to_string()),
            "{body}: {:?}",
            printed(&s)
        );
        let info = i.tasks(&s);
        assert_eq!(info[1].last_error.as_deref(), Some(*message));
        assert_eq!(info[1].state, fs020n_as::TaskState::Idle);
    }
}

#[test]
fn error_and_error_message_functions() {
    let (i, _) = run_pc("  e = ERROR\n  $m = $ERROR(-31088)\n  $z = $ERROR(0)", 0.1);
    assert_eq!(i.real("e"), Some(0.0));
    assert_eq!(
        i.string("m"),
        Some(b"Destination is out of motion range".to_vec())
    );
    assert_eq!(i.string("z"), Some(Vec::new()));
}

#[test]
fn arrays_have_up_to_three_dimensions() {
    let (i, s) = run_pc(
        "  t[1,2,3] = 6\n  t[1,2] = 3\n  t[1] = 1\n  a = t[1,2,3] + t[1,2] + t[1]\n  $s[2,2] = \"x\"\n  #p[1] = #PPOINT(1,2,3)\n  b = DEXT(#p[1], 3)",
        0.1,
    );
    assert!(s.raised.is_empty(), "{:?}", s.terminal);
    assert_eq!(i.real("a"), Some(10.0));
    assert_eq!(i.string_at("s", &[2, 2]), Some(b"x".to_vec()));
    assert_eq!(i.real("b"), Some(3.0));
}

#[test]
fn computed_array_indices_truncate_toward_zero() {
    let (i, s) = run_pc(
        "  x = -0.99\n  y = 9999.9\n  z = 2.7\n  a[x] = 1\n  a[y] = 2\n  a[z] = 3\n  b = a[z] + a[x]\n  w = 9999.999\n  a[w + 1] = 4",
        0.1,
    );
    assert_eq!(i.real_at("a", &[0]), Some(1.0));
    assert_eq!(i.real_at("a", &[9999]), Some(2.0));
    assert_eq!(i.real_at("a", &[2]), Some(3.0));
    assert_eq!(i.real("b"), Some(4.0));
    // 10000.999 truncates to 10000: out of range (E0115), the task stops there.
    assert_eq!(s.error, ErrorCode(-30115), "{:?}", s.terminal);
}

#[test]
fn data_sections_load_into_globals() {
    let src = ".PROGRAM autostart.pc()\n  a = count + tab[2]\n  $b = $name + \"!\"\n  c = DEXT(#home, 3)\n  d = DEXT(pick, 3)\n.END\n\
               .REALS\ncount = 2.5\ntab[2] = -1\n.END\n\
               .STRINGS\n$name = \"fs020n\"\n.END\n\
               .JOINTS\n#home 0 0 -90 0 -90 0\n.END\n\
               .TRANS\npick 850 0 1153.5 0 180 0\n.END\n";
    let (mut i, mut s) = start(src);
    i.run_until(&mut s, ms(50));
    assert_eq!(i.real("a"), Some(1.5));
    assert_eq!(i.string("b"), Some(b"fs020n!".to_vec()));
    assert_eq!(i.real("c"), Some(-90.0));
    assert_eq!(i.real("d"), Some(1153.5));
    assert_eq!(i.joints("home"), Some([0.0, 0.0, -90.0, 0.0, -90.0, 0.0]));
}

#[test]
fn timers_and_twait() {
    let (i, _) = run_pc(
        "  TIMER 1 = 0\n  TWAIT 0.5\n  a = TIMER(1)\n  TIMER 2 = 10\n  b = TIMER(2)\n  c = TIMER(0)\n  d = TIMER(7)",
        1.0,
    );
    // TIMER 1 = 0 at 20 µs, TWAIT from 40 µs to 540 µs + 0.5 s, read at 540 µs: 0.500 s.
    assert_eq!(i.real("a"), Some(0.5));
    assert_eq!(i.real("b"), Some(10.0));
    assert_eq!(i.real("c"), Some(0.5));
    assert_eq!(i.real("d"), Some(0.0), "a timer never set reads 0");
}

#[test]
fn load_errors_name_file_line_column_and_what_was_expected() {
    let cases = [
        (pc("  a = \"text\""), "test.as:2:7: expected a real value, found a string"),
        (pc("  $s = 1 + 2"), "test.as:2:10: expected a string, found a real"),
        (pc("  a = SIN(1, 2)"), "test.as:2:7: SIN takes 1 argument(s), found 2"),
        (pc("  x:\n  x:"), "test.as:3:3: label x is defined twice (first at line 2)"),
        (pc("  a = \"s\" - \"t\""), "test.as:2:11: strings take only + (join) and comparisons"),
        (pc("  PRINT #PPOINT(1)"), "test.as:2:9: PRINT and $ENCODE take reals and strings, found a joint point (DECOMPOSE it into reals first)"),
        (pc("  $x = $DECODE(\"abc\", \" \", 0)"), "test.as:2:16: the first argument of $DECODE must be a string variable (it is cut)"),
        (pc("  TRUE = 1"), "test.as:2:3: TRUE is a reserved word and cannot be assigned"),
    ];
    for (src, want) in cases {
        assert_eq!(load_error(&src), want);
    }
}

#[test]
fn abbreviated_keywords() {
    let src = ".PROGRAM autostart.pc()\n  TY \"typed\"\n  PRIN \"printed\"\n  TW 0.01\n  MC EXEC rob\n  MC SP 50\n.END\n.PROGRAM rob()\n  JM #PPOINT(0,0,-90,0,-90,0)\n.END\n";
    let (mut i, mut s) = start(src);
    i.run_until(&mut s, ms(100));
    assert_eq!(printed(&s), vec!["typed", "printed"]);
    assert_eq!(s.monitor_speed, 50.0);
    assert_eq!(s.motions.len(), 1);
}

#[test]
fn locals_start_undefined_in_each_call_unless_persistent() {
    let src = ".PROGRAM autostart.pc()\n  CALL acc(2, TRUE)\n  CALL acc(3, FALSE)\n.END\n\
               .PROGRAM acc(.n, .first)\n  IF .first THEN\n    .total = 0\n  END\n  .total = .total + .n\n  total = .total\n.END\n";
    let (mut i, mut s) = start(src);
    i.run_until(&mut s, ms(10));
    assert_eq!(i.real("total"), Some(2.0));
    assert_eq!(
        s.raised,
        vec![ErrorCode(-30102)],
        "the second call's .total is a new, undefined local"
    );
    let cfg = fs020n_as::Config {
        persistent_locals: true,
        ..fs020n_as::Config::default()
    };
    let (mut i, mut s) = start_with(src, cfg);
    i.run_until(&mut s, ms(10));
    assert_eq!(
        i.real("total"),
        Some(5.0),
        "persistent locals keep their values between calls"
    );
    assert!(s.raised.is_empty());
}

#[test]
fn an_error_inside_a_run_of_computation_names_its_line_steps_and_time() {
    // 199 steps of pure computation (two FOR loops over arrays), then the 200th step, the
    // 50th addition, reads x[50], which was never assigned.
    let body = "  FOR .i = 1 TO 49\n    x[.i] = .i\n  END\n  .s = 0\n  FOR .i = 1 TO 60\n    \
                .s = .s + x[.i]\n  END";
    let (i, s) = run_pc(&format!("{body}\n  done = 1"), 0.1);
    assert_eq!(s.raised, vec![ErrorCode(-30102)]);
    let message =
        "(E0102) variable not defined: x[50] (assign it before reading it) (autostart.pc line 7)";
    let info = i.tasks(&s);
    assert_eq!(info[1].last_error.as_deref(), Some(message));
    assert_eq!(info[1].steps, 200, "the failed step counts");
    assert_eq!(i.real("done"), None);
    // Step k runs at (k − 1) × 20 µs: the error is reported at the 200th step's time.
    let at = i
        .terminal()
        .find(|l| l.text == message)
        .map(|l| l.at)
        .expect("the error is on the terminal");
    assert_eq!(at, Duration::from_micros(199 * 20));
    // The same sum over defined elements: every step done, the loop's time exact.
    let body = "  FOR .i = 1 TO 60\n    x[.i+1] = .i\n  END\n  .s = 0\n  FOR .i = 1 TO 60\n    \
                .s = .s + x[.i+1] * 2\n  END\n  s = .s";
    let (i, s) = run_pc(body, 0.1);
    assert!(s.raised.is_empty(), "{:?}", printed(&s));
    assert_eq!(i.real("s"), Some(3660.0));
    // FOR, 60 × (assignment, NEXT), `.s = 0`, FOR, 60 × 2, `s = .s`, the END.
    assert_eq!(i.tasks(&s)[1].steps, 1 + 120 + 1 + 1 + 120 + 1 + 1);
}

#[test]
fn backslash_escapes_in_string_constants_are_the_bytes_they_name() {
    // `"\005"` is how saves hold a non-printing byte; programs end their TCP lines with
    // `"\n"`; another backslash stays as written.
    let (i, _) = run_pc(
        "  $a = \"OK\\n\"\n  a = LEN($a)\n  b = ASC($a, 3)\n  $c = \"\\r\\t\\\\\\005\"\n  c = LEN($c)\n  d = ASC($c, 4)\n  $e = \"C:\\data\"\n  e = LEN($e)\n  IF $a == \"OK\" + $CHR(10) THEN\n    f = 1\n  END",
        0.1,
    );
    assert_eq!(i.real("a"), Some(3.0));
    assert_eq!(i.real("b"), Some(10.0));
    assert_eq!(i.real("c"), Some(4.0));
    assert_eq!(i.real("d"), Some(5.0));
    assert_eq!(i.real("e"), Some(7.0), "\\d is no escape");
    assert_eq!(i.real("f"), Some(1.0));
    assert_eq!(i.string("e"), Some(b"C:\\data".to_vec()));
}
