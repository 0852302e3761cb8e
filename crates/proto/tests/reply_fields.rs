//! Every reply field of spec §3: where it sits in the exact bytes, and how it decodes.

mod common;

use common::*;
use fs020n_proto::number::{format_default_int, format_f10_3, F10_OVERFLOW, F10_WIDTH};
use fs020n_proto::{
    ErrorClass, ErrorCode, JointsDeg, Status, Timer, PROTOCOL_VERSION, REPLY_FIELDS,
};

/// The blank-separated tokens of an encoded reply whose real fields do not touch.
fn tokens(s: &Status) -> Vec<String> {
    s.encode().split_whitespace().map(str::to_owned).collect()
}

#[test]
fn reply_has_fourteen_fields_and_one_final_blank() {
    let s = spec_example_status();
    let text = s.encode();
    assert_eq!(REPLY_FIELDS, 14);
    assert_eq!(tokens(&s).len(), REPLY_FIELDS);
    assert!(
        text.starts_with(' '),
        "each integer is preceded by one blank"
    );
    assert!(text.ends_with(" ") && !text.ends_with("  "));
    assert!(
        !text.contains('\n') && !text.contains('\r'),
        "no terminator"
    );
    // Seven integers with their blanks, then exactly 70 characters, then the final blank.
    let head = " 1040 0 -1 -1 0 -1 -1";
    assert!(text.starts_with(head));
    assert_eq!(text.len(), head.len() + 7 * F10_WIDTH + 1);
}

#[test]
fn each_switch_sits_in_its_own_field() {
    // (field index, setter) for fields 3–7: true is -1, false is 0.
    type Setter = fn(&mut Status, bool);
    let fields: [(usize, Setter); 5] = [
        (2, |s, v| s.run = v),
        (3, |s, v| s.repeat = v),
        (4, |s, v| s.teach_lock = v),
        (5, |s, v| s.power = v),
        (6, |s, v| s.task_running = v),
    ];
    for (index, set) in fields {
        for value in [false, true] {
            let mut s = Status::default();
            set(&mut s, value);
            let t = tokens(&s);
            for (k, tok) in t[2..7].iter().enumerate() {
                let expect = if k + 2 == index && value { "-1" } else { "0" };
                assert_eq!(
                    tok,
                    expect,
                    "field {} with field {} = {value}",
                    k + 3,
                    index + 1
                );
            }
            assert_eq!(Status::decode(&s.encode()), Ok(s));
        }
    }
}

#[test]
fn version_field_is_the_servers_constant() {
    let s = Status::default();
    assert_eq!(s.version, PROTOCOL_VERSION);
    assert_eq!(tokens(&s)[0], "1040");
    // Decoding keeps whatever the peer sent: the client decides what a wrong version means.
    let odd = Status::decode("7 0 0 0 0 0 0 0 0 0 0 0 0 0 ").unwrap();
    assert_eq!(odd.version, 7);
}

#[test]
fn error_field_encodes_each_class() {
    let codes = [
        (ErrorCode::NONE, "0", "none"),
        (ErrorCode::new(ErrorClass::P, 1001), "-11001", "P1001"),
        (ErrorCode::new(ErrorClass::W, 1004), "-21004", "W1004"),
        (ErrorCode::DESTINATION_OUT_OF_RANGE, "-31088", "E1088"),
        (ErrorCode::EMERGENCY_STOP, "-33808", "E3808"),
        (ErrorCode::MOTOR_POWER_OFF, "-31135", "E1135"),
        (ErrorCode::new(ErrorClass::D, 952), "-40952", "D0952"),
        (ErrorCode(-5), "-5", "code -5"),
        (ErrorCode(i32::MIN), "-2147483648", "code -2147483648"),
        (ErrorCode(i32::MAX), "2147483647", "code 2147483647"),
    ];
    for (code, wire, name) in codes {
        let s = Status {
            error: code,
            ..Status::default()
        };
        assert_eq!(tokens(&s)[1], wire);
        assert_eq!(code.to_string(), name);
        assert_eq!(Status::decode(&s.encode()).unwrap().error, code);
    }
    // Out of the 32-bit range: not an AS error number.
    let text = " 1040 -2147483649 0 0 0 0 0     0.000     0.000     0.000     0.000     0.000     0.000     0.000 ";
    assert!(matches!(
        Status::decode(text),
        Err(fs020n_proto::DecodeError::NotInteger { field: 2, .. })
    ));
}

#[test]
fn the_named_error_codes() {
    for (raw, class, number) in [
        (-11000, ErrorClass::P, 1000),
        (-11001, ErrorClass::P, 1001),
        (-11002, ErrorClass::P, 1002),
        (-11009, ErrorClass::P, 1009),
        (-11013, ErrorClass::P, 1013),
        (-31082, ErrorClass::E, 1082),
        (-31087, ErrorClass::E, 1087),
        (-31088, ErrorClass::E, 1088),
        (-31130, ErrorClass::E, 1130),
        (-31135, ErrorClass::E, 1135),
        (-33808, ErrorClass::E, 3808),
        (-36007, ErrorClass::E, 6007),
        (-36008, ErrorClass::E, 6008),
    ] {
        let code = ErrorCode(raw);
        assert_eq!(code.class(), Some(class));
        assert_eq!(code.number(), Some(number));
        assert_eq!(ErrorCode::new(class, number), code);
        assert!(code.message().is_some(), "{code}");
        assert_eq!(
            format!("{}{number:04}", class.letter()).parse::<ErrorCode>(),
            Ok(code)
        );
    }
}

#[test]
fn timer_field() {
    for (t, wire) in [
        (0.0, "0.000"),
        (0.001, "0.001"),
        (12.5, "12.500"),
        (86_400.0, "86400.000"),
        (999_999.999, "999999.999"),
    ] {
        let s = Status {
            timer: Timer::Seconds(t),
            ..Status::default()
        };
        let text = s.encode();
        let at = text.len() - 1 - 7 * F10_WIDTH;
        assert_eq!(
            &text[at..at + F10_WIDTH],
            format!("{wire:>10}"),
            "timer {t} in 10 characters"
        );
        let back = Status::decode(&s.encode()).unwrap();
        assert_eq!(back.timer, Timer::Seconds(t));
        assert_eq!(back.timer.seconds(), Some(t));
    }
    // After about 11.6 days the timer no longer fits /F10.3.
    let days = 1_000_000.0 / 86_400.0;
    assert!((11.5..11.6).contains(&days));
    let s = Status {
        timer: Timer::Seconds(1_000_000.0),
        ..Status::default()
    };
    let text = s.encode();
    let at = text.len() - 1 - 7 * F10_WIDTH;
    assert_eq!(&text[at..at + F10_WIDTH], F10_OVERFLOW);
    assert_eq!(Status::decode(&s.encode()).unwrap().timer, Timer::Overflow);
    assert_eq!(Timer::Overflow.seconds(), None);
}

#[test]
fn joint_fields() {
    let joints = [-160.0, 140.0, -155.0, 270.0, -145.0, -360.0];
    let s = status_with(Timer::Seconds(1.0), joints);
    let text = s.encode();
    for (k, j) in joints.iter().enumerate() {
        let at = 21 + (k + 1) * F10_WIDTH;
        assert_eq!(&text[at..at + F10_WIDTH], format_f10_3(*j), "JT{}", k + 1);
    }
    assert_eq!(
        Status::decode(&text).unwrap().joints,
        JointsDeg::new(joints)
    );
    // Three decimals are kept, the rest is rounded.
    let s = status_with(
        Timer::Seconds(1.0),
        [0.0004, 0.0005, -0.0004, 1.2345, -1.2355, 1e-9],
    );
    let back = Status::decode(&s.encode()).unwrap();
    assert_eq!(back.joints.values(), [0.0, 0.001, 0.0, 1.234, -1.236, 0.0]);
}

#[test]
fn f10_3_boundaries() {
    assert_eq!(format_f10_3(99999.9995), "100000.000");
    assert_eq!(format_f10_3(-99_999.999), "-99999.999");
    assert_eq!(format_f10_3(-99999.9995), F10_OVERFLOW);
    assert_eq!(format_f10_3(999_999.999), "999999.999");
    assert_eq!(format_f10_3(999999.9995), F10_OVERFLOW);
    assert_eq!(format_f10_3(f64::INFINITY), F10_OVERFLOW);
    assert_eq!(format_f10_3(-0.0), "     0.000");
    assert_eq!(format_f10_3(-0.0004), "     0.000");
    assert_eq!(format_f10_3(-0.0005), "    -0.001");
    for v in [0.0, 1.0, -1.0, 12.345, -99_999.999, 999_999.999, 1e6, -1e6] {
        assert_eq!(format_f10_3(v).len(), F10_WIDTH, "{v}");
    }
    assert_eq!(format_default_int(1040), " 1040");
    assert_eq!(format_default_int(0), " 0");
    assert_eq!(format_default_int(-1), " -1");
}

#[test]
fn a_joint_that_overflows_cannot_be_decoded() {
    // The controller prints asterisks; the decoder refuses to invent an angle.
    let s = status_with(Timer::Seconds(1.0), [0.0, 0.0, 1e6, 0.0, 0.0, 0.0]);
    assert_eq!(
        Status::decode(&s.encode()),
        Err(fs020n_proto::DecodeError::JointOverflow { joint: 3 })
    );
}

#[test]
fn default_and_display() {
    let d = Status::default();
    assert_eq!(
        d.encode(),
        " 1040 0 0 0 0 0 0     0.000     0.000     0.000     0.000     0.000     0.000     0.000 "
    );
    let shown = spec_example_status().to_string();
    assert_eq!(
        shown,
        "error none, RUN, REPEAT, lock OFF, power ON, program running, timer 12.500 s, \
         joints [0.000, 30.000, 0.000, 0.000, 0.000, 0.000] deg"
    );
    let s = Status {
        error: ErrorCode::EMERGENCY_STOP,
        timer: Timer::Overflow,
        teach_lock: true,
        ..Status::default()
    };
    let shown = s.to_string();
    assert!(
        shown.starts_with(
            "error E3808, HOLD, TEACH, lock ON, power OFF, program not running, timer overflow"
        ),
        "{shown}"
    );
}
