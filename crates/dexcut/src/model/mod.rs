//! Data only: the serde schema types of summary.json ([`summary`]) and the
//! typed list of warnings ([`warnings`]) that a run, the commands and the
//! report share.

pub mod summary;
pub mod warnings;
