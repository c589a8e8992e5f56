//! The `indoorloc` binary.
fn main() {}
