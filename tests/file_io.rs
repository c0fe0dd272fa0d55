//! The file interface across processes (issue #15).

mod common;

#[test]
fn placeholder() {}
