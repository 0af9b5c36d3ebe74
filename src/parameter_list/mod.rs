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

use std::any::Any;
use std::fmt;

/// A model's typed parameters seen through a trait object (the deck keeps each model's own
/// parameter type behind its registry's trait): compared and given back as their type. Every
/// `PartialEq` type with the other bounds has it.
pub trait TypedParameters: Any + fmt::Debug + Send + Sync {
    /// The parameters as `Any`, to get the typed value back.
    fn as_any(&self) -> &dyn Any;

    /// True when `other` holds the same type and value.
    fn same_as(&self, other: &dyn Any) -> bool;
}

impl<T: Any + fmt::Debug + Send + Sync + PartialEq> TypedParameters for T {
    fn as_any(&self) -> &dyn Any {
        self
    }

    fn same_as(&self, other: &dyn Any) -> bool {
        other.downcast_ref::<T>() == Some(self)
    }
}
