//! One list of a deck, read key by key: the format-neutral key tree with the line of every key
//! ([`tree`]), the typed reader that records which keys were asked for and turns the others
//! into "unknown key; did you mean …" errors ([`reader`]), and the error that names the file,
//! the key path and the line ([`error`]).
//!
//! It sits below both the deck ([`crate::io::deck`]) and the models that read their own keys
//! ([`crate::material`], [`crate::damage`]), so that a model's parameters are read in the
//! model's own file while the deck asks the model registries which model a name means.

pub(crate) mod error;
pub(crate) mod reader;
pub(crate) mod tree;
