//! The nomen command line: convert motion capture, evaluate results, and (later) simulate and run the engine.
fn main() {}
