//! G-code reading into a motion path (lines, exact arcs, dwells) with the
//! source line of every segment.
pub mod path;
pub use path::{Geometry, Motion, Path, Plane, Segment};
