//! Expressions (owned by the expression work in progress).
