//! `host-trainer`: the command line (being written).
fn main() {}
