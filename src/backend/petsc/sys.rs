//! The raw C bindings bindgen generates from `petscsnes.h` at build time (`build.rs`, feature
//! `petsc`): only the functions on the build script's allow-list and the types they use.
//! Everything here is `unsafe` to call; [`super::runtime`] and the solver modules wrap it.
#![allow(
    non_upper_case_globals,
    non_camel_case_types,
    non_snake_case,
    dead_code,
    missing_docs,
    unreachable_pub,
    clippy::all,
    clippy::pedantic
)]

include!(concat!(env!("OUT_DIR"), "/petsc_bindings.rs"));
