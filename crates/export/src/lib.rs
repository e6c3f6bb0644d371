//! Output writers: atomic files, CSV/JSON, PNG maps, GLB meshes, the HTML report.
pub mod atomic;
