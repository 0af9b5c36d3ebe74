//! Build script: nothing to do unless a C++ backend feature is enabled.
fn main() {
    println!("cargo:rerun-if-changed=build.rs");
}
