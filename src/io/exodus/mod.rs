//! Exodus II files (owned by the exodus work in progress).
