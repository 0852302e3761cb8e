//! Functions of locations and names: `DISTANCE`, `DX`/`DY`/`DZ`, `FRAME`, `ROUND`, and
//! `EXISTREAL`/`EXISTCHAR`/`EXISTJOINT`/`EXISTTRANS`/`EXISTPROGRAM`, with exact values.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

mod common;

use common::{pc, run_pc};
use fs020n_proto::ErrorCode;

fn close(a: f32, b: f32) -> bool {
    (a - b).abs() < 1.0e-3
}

#[test]
fn distance_is_the_straight_line_between_two_positions_in_mm() {
    let (i, _) = run_pc(
        "  d = DISTANCE(TRANS(1, 2, 3, 10, 20, 30), TRANS(4, 6, 15, 0, 0, 0))\n\
  POINT a = TRANS(-5, 0, 0)\n\
  z = DISTANCE(a, a)",
        0.1,
    );
    assert_eq!(i.real("d"), Some(13.0));
    assert_eq!(i.real("z"), Some(0.0));
}

#[test]
fn dx_dy_dz_are_the_position_components() {
    let (i, _) = run_pc(
        "  POINT t = TRANS(12.5, -7, 300, 90, 45, 0)\n\
  x = DX(t)\n\
  y = DY(t)\n\
  z = DZ(SHIFT(t BY 0, 0, 10))",
        0.1,
    );
    assert_eq!(i.real("x"), Some(12.5));
    assert_eq!(i.real("y"), Some(-7.0));
    assert_eq!(i.real("z"), Some(310.0));
}

fn frame_of(args: &str) -> [f32; 6] {
    let (i, _) = run_pc(
        &format!("  POINT f = FRAME({args})\n  DECOMPOSE v[0] = f"),
        0.1,
    );
    std::array::from_fn(|k| i.real_at("v", &[k as i32]).expect("decomposed"))
}

#[test]
fn frame_with_x_along_base_x_and_the_third_point_on_plus_y_is_unrotated() {
    let f = frame_of("TRANS(0, 0, 0), TRANS(100, 0, 0), TRANS(30, 100, 0), TRANS(500, 200, 300)");
    assert_eq!(f, [500.0, 200.0, 300.0, 0.0, 0.0, 0.0]);
}

#[test]
fn frame_with_x_along_base_y_is_turned_90_degrees_about_z() {
    let f = frame_of("TRANS(10, 10, 0), TRANS(10, 60, 0), TRANS(-20, 0, 0), TRANS(0, 0, 0)");
    let want = [0.0, 0.0, 0.0, 0.0, 0.0, 90.0];
    assert!(f.iter().zip(want).all(|(a, b)| close(*a, b)), "{f:?}");
}

#[test]
fn frame_with_x_along_base_z_and_y_along_base_x() {
    // X = (0,0,1), Y = (1,0,0), Z = X × Y = (0,1,0): O 90, A 90, T 180 (Z-Y-Z).
    let f = frame_of("TRANS(0, 0, 0), TRANS(0, 0, 10), TRANS(10, 0, 5), TRANS(1, 2, 3)");
    let want = [1.0, 2.0, 3.0, 90.0, 90.0, 180.0];
    assert!(f.iter().zip(want).all(|(a, b)| close(*a, b)), "{f:?}");
}

#[test]
fn frame_of_points_on_one_line_stops_the_task() {
    let (i, s) = run_pc(
        "  POINT f = FRAME(TRANS(0, 0, 0), TRANS(10, 0, 0), TRANS(20, 0, 0), TRANS(0, 0, 0))\n\
  after = 1",
        0.1,
    );
    assert_eq!(i.real("after"), None);
    assert_eq!(s.raised.len(), 1, "{:?}", s.raised);
    assert!(
        s.terminal
            .iter()
            .any(|(_, l)| l.contains("FRAME: the first three points")),
        "{:?}",
        s.terminal
    );
}

#[test]
fn round_goes_to_the_nearest_integer_halves_away_from_zero() {
    let (i, _) = run_pc(
        "  a = ROUND(2.4)\n  b = ROUND(2.5)\n  c = ROUND(-2.5)\n  d = ROUND(-0.6)\n  e = ROUND(7)",
        0.1,
    );
    assert_eq!(
        ["a", "b", "c", "d", "e"].map(|n| i.real(n)),
        [Some(2.0), Some(3.0), Some(-3.0), Some(-1.0), Some(7.0)]
    );
}

#[test]
fn exist_functions_say_whether_a_global_or_a_program_exists() {
    let (i, _) = run_pc(
        "  IF FALSE THEN\n    never = 1\n  END\n\
  a = 1\n\
  arr[3] = 2\n\
  $s = \"x\"\n\
  POINT #j = #PPOINT(0, 0, 0, 0, 0, 0)\n\
  POINT t = TRANS(0, 0, 0)\n\
  r1 = EXISTREAL(\"a\")\n\
  r2 = EXISTREAL(\"ARR\")\n\
  r3 = EXISTREAL(\"never\")\n\
  r4 = EXISTREAL(\"unknown\")\n\
  c1 = EXISTCHAR(\"$s\")\n\
  c2 = EXISTCHAR(\"s\")\n\
  c3 = EXISTCHAR(\"a\")\n\
  j1 = EXISTJOINT(\"#j\")\n\
  j2 = EXISTJOINT(\"t\")\n\
  t1 = EXISTTRANS(\"t\")\n\
  t2 = EXISTTRANS(\"j\")\n\
  p1 = EXISTPROGRAM(\"autostart.pc\")\n\
  p2 = EXISTPROGRAM(\"elsewhere\")",
        0.1,
    );
    let v = |n: &str| i.real(n).expect(n);
    assert_eq!([v("r1"), v("r2"), v("r3"), v("r4")], [-1.0, -1.0, 0.0, 0.0]);
    assert_eq!([v("c1"), v("c2"), v("c3")], [-1.0, -1.0, 0.0]);
    assert_eq!([v("j1"), v("j2"), v("t1"), v("t2")], [-1.0, 0.0, -1.0, 0.0]);
    assert_eq!([v("p1"), v("p2")], [-1.0, 0.0]);
}

#[test]
fn existdata_names_the_kind_by_its_data_section_letter() {
    let (i, _) = run_pc(
        "  a = 1\n\
  POINT t = TRANS(0, 0, 0)\n\
  .$n = \"t\"\n\
  e1 = EXISTDATA(.$n, T)\n\
  e2 = EXISTDATA(\"a\", T)\n\
  e3 = EXISTDATA(\"a\", R)\n\
  e4 = EXISTDATA(\"nothing\", R)\n\
  IF EXISTDATA(\"pick\", T) == OFF THEN\n\
    POINT pick = t\n\
  END\n\
  e5 = EXISTDATA(\"pick\", T)",
        0.1,
    );
    let v = |n: &str| i.real(n).expect(n);
    assert_eq!(
        [v("e1"), v("e2"), v("e3"), v("e4"), v("e5")],
        [-1.0, 0.0, -1.0, 0.0, -1.0]
    );
}

#[test]
fn strtopos_reads_the_pose_variable_a_string_names_of_either_kind() {
    // AS-E p.9-36: `$A = "#pos"`, `STRTOPOS($A)`: the value of the variable the string names.
    let (i, s) = run_pc(
        "  POINT #pos = #PPOINT(10, 20, -80, 0, -60, 15)\n\
  POINT grip[2] = TRANS(100, 200, 300, 0, 180, 0)\n\
  $a = \"#pos\"\n\
  DECOMPOSE j[0] = STRTOPOS($a)\n\
  DECOMPOSE t[0] = STRTOPOS(\"GRIP[2]\")\n\
  $none = \"nowhere\"\n\
  DECOMPOSE n[0] = STRTOPOS($none)",
        0.1,
    );
    let v = |n: &str, k: i32| i.real_at(n, &[k]).expect(n);
    assert_eq!([v("j", 0), v("j", 2), v("j", 5)], [10.0, -80.0, 15.0]);
    assert_eq!([v("t", 0), v("t", 2), v("t", 4)], [100.0, 300.0, 180.0]);
    assert_eq!(i.real_at("n", &[0]), None);
    assert_eq!(
        s.raised,
        vec![ErrorCode(-30103)],
        "an undefined name is E0103"
    );
}

#[test]
fn strtopos_is_a_motion_target_and_not_emulated_where_its_kind_must_be_known_at_load() {
    let src = format!(
        "{}.PROGRAM rob()\n  $a = \"#pos\"\n  JMOVE STRTOPOS($a)\n  BREAK\n  DECOMPOSE at[0] = #HERE\n.END\n",
        pc("  POINT #pos = #PPOINT(10, 20, -80, 0, -60, 15)\n  MC EXECUTE rob")
    );
    let (mut i, mut s) = common::start(&src);
    i.run_until(&mut s, common::ms(10_000));
    assert!(s.raised.is_empty(), "{:?}", s.raised);
    assert!((i.real_at("at", &[1]).expect("at") - 20.0).abs() < 1e-3);
    let w = fs020n_as::Interpreter::from_source(
        "t.as",
        &pc("  POINT p = STRTOPOS($a)"),
        fs020n_as::Config::default(),
    )
    .map(|i| {
        i.warnings()
            .iter()
            .map(|w| w.to_string())
            .collect::<Vec<_>>()
    })
    .unwrap_or_default();
    assert!(w.iter().any(|w| w.contains("STRTOPOS here")), "{w:?}");
}

#[test]
fn strtoval_reads_the_real_a_string_names() {
    // AS-E p.9-37: VAR = 5, $VA = "VAR", STRTOVAL($VA) + 6 is 11.
    let (i, s) = run_pc(
        "  var = 5\n  count[3] = 7\n  $va = \"VAR\"\n  total = STRTOVAL($va) + 6\n  third = STRTOVAL(\"count[3]\")\n  never = STRTOVAL(\"nothing\")",
        0.1,
    );
    assert_eq!(i.real("total"), Some(11.0));
    assert_eq!(i.real("third"), Some(7.0));
    assert_eq!(i.real("never"), None);
    assert_eq!(s.raised, vec![ErrorCode(-30102)]);
}

#[test]
fn maxindex_and_minindex_give_the_indices_an_array_uses() {
    // AS-E p.9-16: −1 for a variable that is no array, −2 for one not defined.
    let (i, s) = run_pc(
        "  POINT #pos[0] = #PPOINT(0)\n  POINT #pos[100] = #PPOINT(0)\n\
  POINT #place[1,1] = #PPOINT(0)\n  POINT #place[1,5] = #PPOINT(0)\n\
  $s[2] = \"a\"\n  $s[7] = \"b\"\n  plain = 1\n\
  a = MAXINDEX(\"#pos\")\n  b = MAXINDEX(\"#place\", 2)\n  c = MININDEX(\"#place\", 2)\n\
  d = MININDEX(\"$s\")\n  e = MAXINDEX(\"plain\")\n  f = MAXINDEX(\"nothing\")\n\
  g = EXISTINTEGER(\"@n\")\n  @n = 3\n  h = EXISTINTEGER(\"@n\")\n  $pad = \"a\" + $SPACE(2) + \"b\"",
        0.1,
    );
    assert!(s.raised.is_empty(), "{:?}", s.raised);
    let v = |n: &str| i.real(n).expect(n);
    assert_eq!(
        [v("a"), v("b"), v("c"), v("d"), v("e"), v("f")],
        [100.0, 5.0, 1.0, 2.0, -1.0, -2.0]
    );
    assert_eq!([v("g"), v("h")], [0.0, -1.0]);
    assert_eq!(i.string("pad"), Some(b"a  b".to_vec()));
}
