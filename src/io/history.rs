//! CSV history of global variables (owned by the exodus work in progress).
