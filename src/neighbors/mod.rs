//! Neighbour search (owned by the neighbour work in progress).
