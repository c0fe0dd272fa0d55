//! The checked library as bytes (`Library::encode_checked` / `decode_checked`): what a
//! session's keeper publishes so that other processes read the Library Space instead of
//! parsing and checking it. Decoded, it must be the library the sources make; an encoding of
//! other sources, another format, or damaged must be refused with the reason, never misread.

use robosim_library::{Library, Params, StaleEncoding, sources_digest};

fn standard() -> &'static Library {
    robosim_library::standard_library().expect("standard library")
}

#[test]
fn the_standard_library_decoded_lists_and_evaluates_as_parsed() {
    let lib = standard();
    let files = lib.sources();
    let bytes = lib.encode_checked();
    let decoded = Library::decode_checked(&bytes, &files).expect("decodes");
    assert_eq!(decoded.declarations(), lib.declarations());
    assert_eq!(decoded.sources(), files);
    for name in ["puma560", "space_station", "downhand_welding_cell", "panda"] {
        assert_eq!(
            decoded.params(name).expect("params"),
            lib.params(name).expect("params"),
            "{name}"
        );
        assert_eq!(
            decoded.evaluate(name, &Params::new()).expect("evaluates"),
            lib.evaluate(name, &Params::new()).expect("evaluates"),
            "{name}"
        );
    }
    // With a parameter: the expression is parsed against the decoded library's sources.
    let p = Params::new().expr("upper_arm", "300 mm");
    assert_eq!(
        decoded
            .evaluate("surgical_positioner", &p)
            .expect("evaluates"),
        lib.evaluate("surgical_positioner", &p).expect("evaluates")
    );
    // Errors are located in the right file and line.
    let e = decoded
        .evaluate(
            "surgical_positioner",
            &Params::new().expr("upper_arm", "5 deg"),
        )
        .expect_err("an angle is not a length");
    let e2 = lib
        .evaluate(
            "surgical_positioner",
            &Params::new().expr("upper_arm", "5 deg"),
        )
        .expect_err("an angle is not a length");
    assert_eq!(e.to_string(), e2.to_string());
}

#[test]
fn an_encoding_of_other_sources_is_refused_with_both_digests() {
    let lib = standard();
    let bytes = lib.encode_checked();
    let mut files = lib.sources();
    files[0].1.push_str("\n// edited\n");
    match Library::decode_checked(&bytes, &files) {
        Err(StaleEncoding::Digest { found, expected }) => {
            assert_eq!(found, sources_digest(&lib.sources()));
            assert_eq!(expected, sources_digest(&files));
        }
        other => panic!("{other:?}"),
    }
    // A file renamed is another source too.
    let mut files = lib.sources();
    files[0].0.push('x');
    assert!(matches!(
        Library::decode_checked(&bytes, &files),
        Err(StaleEncoding::Digest { .. })
    ));
}

#[test]
fn damaged_truncated_or_foreign_encodings_are_refused_with_the_reason() {
    let lib = standard();
    let files = lib.sources();
    let bytes = lib.encode_checked();
    let refuse = |b: &[u8]| Library::decode_checked(b, &files).expect_err("refused");
    assert_eq!(refuse(&bytes[..10]), StaleEncoding::Short(10));
    let mut b = bytes.clone();
    b[0] = b'X';
    assert_eq!(refuse(&b), StaleEncoding::Magic);
    let mut b = bytes.clone();
    b[8] = 99;
    assert!(matches!(
        refuse(&b),
        StaleEncoding::Format { found: 99, .. }
    ));
    let mut b = bytes.clone();
    b[12] ^= 1;
    assert!(matches!(refuse(&b), StaleEncoding::Layout { .. }));
    // One bit flipped anywhere in the payload: the checksum says so.
    for at in [bytes.len() / 3, bytes.len() / 2, bytes.len() - 1] {
        let mut b = bytes.clone();
        b[at] ^= 0x10;
        assert_eq!(refuse(&b), StaleEncoding::Checksum, "byte {at}");
    }
    // Cut short: the length says so.
    assert!(matches!(
        refuse(&bytes[..bytes.len() - 5]),
        StaleEncoding::Length { .. }
    ));
    // The reason reads as a sentence.
    let e = refuse(&bytes[..10]).to_string();
    assert!(e.contains("shorter than its header"), "{e}");
}

#[test]
fn a_user_library_round_trips_with_its_own_sources() {
    let text = "colour red = rgb(1, 0, 0)\n\nsolid bar(length = 0.5 m, width = 4 cm) {\n    colour: red\n    part box(length, width, width) at translate(-length / 2, 0, 0)\n}\n\nrobot planar(l1 = 0.5 m) {\n    link one {\n        joint: revolute\n        a: l1\n        mass: 2 kg\n        part bar(length: l1)\n    }\n}\n";
    let lib = Library::from_source("mine.rsl", text).unwrap_or_else(|e| panic!("{e}"));
    let files = lib.sources();
    let decoded = Library::decode_checked(&lib.encode_checked(), &files).expect("decodes");
    assert_eq!(decoded.declarations(), lib.declarations());
    assert_eq!(
        decoded
            .evaluate("planar", &Params::new().si("l1", 0.7))
            .expect("evaluates"),
        lib.evaluate("planar", &Params::new().si("l1", 0.7))
            .expect("evaluates")
    );
    // The standard library's encoding does not stand for this one.
    assert!(matches!(
        Library::decode_checked(&standard().encode_checked(), &files),
        Err(StaleEncoding::Digest { .. })
    ));
}
