//! Issue 34 item 10: a link file's AINERT with a negative mass was read as 0 kg without a word,
//! and a pseudo-inertia no body has was accepted. The reader refuses both, naming the file
//! and the rows.

use nalgebra::{Matrix3, Matrix4, Vector3};
use robosim_file_io::linkfile::{DhRow, LinkFile, pseudo_inertia};
use std::path::Path;

fn link(ainert: Matrix4<f64>) -> String {
    LinkFile {
        dh: DhRow::default(),
        joint_i: None,
        joint_i1: None,
        ainert,
        ajnt_i: Matrix4::identity(),
        ajnt_i1: Matrix4::identity(),
        amat: Matrix4::identity(),
        vectors: Vec::new(),
    }
    .to_text()
}

#[test]
fn link_file_negative_ainert_mass_is_refused_not_stored_as_zero() {
    let text = link(pseudo_inertia(-2.0, &Vector3::zeros(), &Matrix3::zeros()));
    let e = LinkFile::parse(&text, Path::new("NEG.L")).expect_err("negative mass");
    let msg = e.to_string();
    assert!(
        msg.starts_with("NEG.L: AINERT mass (line 6, column 4) is -2 kg"),
        "{msg}"
    );
}

#[test]
fn link_file_inertia_no_body_has_is_refused() {
    // a negative principal moment
    let i = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -5.0));
    let text = link(pseudo_inertia(3.0, &Vector3::new(0.1, 0.0, 0.0), &i));
    let e = LinkFile::parse(&text, Path::new("BAD.L")).expect_err("not PSD");
    assert!(e.to_string().contains("positive semi-definite"), "{e}");
    // a body's inertia reads back
    let i = Matrix3::from_diagonal(&Vector3::new(2.0, 3.0, 4.0));
    let text = link(pseudo_inertia(3.0, &Vector3::new(0.1, 0.2, 0.3), &i));
    LinkFile::parse(&text, Path::new("OK.L")).expect("a body");
}
