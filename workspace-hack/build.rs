//! Empty: a build script makes Cargo unify the build dependencies' features as well.

fn main() {}
