//! Geometry to points.
