//! Tests of the mesh crate: one binary, modules per concern.
mod distance;
mod fill;
mod fixtures;
mod geometry;
mod load;
mod solid;
