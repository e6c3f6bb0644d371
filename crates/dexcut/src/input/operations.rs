//! `[[operations]]`: programs run in order on one stock, each with its
//! tools and, over the job's, its own `[limits]` and `[machine]` keys
//! (docs/guide/job.md, "Operations"). Each operation is read into a job of
//! its own ([`Job::operation_jobs`]): the job's stock, cutting, servo,
//! offsets and design, the operation's program, its tools (else the job's),
//! and the job's `[limits]` and `[machine]` with the operation's keys put
//! over them.

use std::marker::PhantomData;
use std::path::PathBuf;

use serde::de::{DeserializeOwned, Deserializer};
use serde::{Deserialize, Serialize};

use super::job::{Job, LimitsSpec, MachineSpec, ProgramSpec, ToolSpec};
use super::tool_library::ToolLibrarySpec;
use crate::error::{fail, Error, Result};

/// One `[[operations]]` entry.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OperationSpec {
    /// What the shop calls it ("roughing"): names its results folder
    /// (`op1_roughing/`) and its lines in the report.
    pub name: String,
    /// Its program: a path (`program = "rough.nc"`), or a table with `path`
    /// and `feed` as `[program]` takes them.
    pub program: ProgramRef,
    /// Its one tool (as `[tool]`).
    pub tool: Option<ToolSpec>,
    /// Its tool table (as `[[tools]]`).
    #[serde(default)]
    pub tools: Vec<ToolSpec>,
    /// Its tool library (as `[tool_library]`), with its `tools` over it.
    pub tool_library: Option<ToolLibrarySpec>,
    /// Keys of `[limits]` for this operation, over the job's.
    pub limits: Option<Patch<LimitsSpec>>,
    /// Keys of `[machine]` for this operation, over the job's.
    pub machine: Option<Patch<MachineSpec>>,
}

/// An operation's program: a path, or `[program]`'s table.
#[derive(Clone, Debug)]
pub struct ProgramRef(pub ProgramSpec);

impl<'de> Deserialize<'de> for ProgramRef {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct Visit;
        impl<'de> serde::de::Visitor<'de> for Visit {
            type Value = ProgramRef;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a program's path, or a table with path (and feed)")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> std::result::Result<ProgramRef, E> {
                Ok(ProgramRef(ProgramSpec {
                    path: PathBuf::from(v),
                    feed: None,
                }))
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                map: A,
            ) -> std::result::Result<ProgramRef, A::Error> {
                ProgramSpec::deserialize(serde::de::value::MapAccessDeserializer::new(map))
                    .map(ProgramRef)
            }
        }
        d.deserialize_any(Visit)
    }
}

/// Keys of a table put over the job's table of type `T`: checked as a `T`
/// of their own when read (so an unknown key or a wrong type is refused at
/// its table's place), kept as written so that only they replace the job's.
#[derive(Clone, Debug)]
pub struct Patch<T> {
    keys: toml::Table,
    of: PhantomData<T>,
}

impl<'de, T: DeserializeOwned> Deserialize<'de> for Patch<T> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        let keys = toml::Table::deserialize(d)?;
        toml::Value::Table(keys.clone())
            .try_into::<T>()
            .map_err(serde::de::Error::custom)?;
        Ok(Patch {
            keys,
            of: PhantomData,
        })
    }
}

impl<T: Serialize + DeserializeOwned> Patch<T> {
    /// `base` with these keys put over it.
    fn over(&self, base: &T, what: &str) -> Result<T> {
        let mut table = toml::Table::try_from(base)
            .map_err(|e| Error::job(format!("{what}: cannot merge: {e}")))?;
        for (k, v) in &self.keys {
            table.insert(k.clone(), v.clone());
        }
        toml::Value::Table(table)
            .try_into()
            .map_err(|e| Error::job(format!("{what}: {e}")))
    }
}

/// One operation of a job, read into a job of its own.
#[derive(Clone, Debug)]
pub struct Operation {
    /// 1-based position in the job.
    pub number: usize,
    /// Its `name`.
    pub name: String,
    /// Its results folder's name: `op{number}_{name}`, the name's characters
    /// other than letters, digits, `-` and `_` as `_`.
    pub folder: String,
    /// The job it runs: the job's keys with the operation's.
    pub job: Job,
}

impl Job {
    /// Each `[[operations]]` entry as a job of its own, checked (an error
    /// at the operation's key where it has it, else at the job's).
    pub fn operation_jobs(&self, keys: &super::toml_keys::KeyPlaces) -> Result<Vec<Operation>> {
        let mut out = Vec::with_capacity(self.operations.len());
        for (i, op) in self.operations.iter().enumerate() {
            let under = format!("operations[{i}]");
            let name = op.name.trim();
            if name.is_empty() || name.len() > 64 {
                let at = keys.of_message(&format!("{under}.name"));
                fail!(
                    job,
                    "{at}: invalid job: {under}.name must be 1 to 64 characters, got {:?}",
                    op.name
                );
            }
            if let Some(j) = out.iter().position(|o: &Operation| o.name == name) {
                let at = keys.of_message(&format!("{under}.name"));
                fail!(job, "{at}: invalid job: {under}.name {name:?} is operation {}'s too: each operation needs its own name", j + 1);
            }
            let folder: String = name
                .chars()
                .map(|c| {
                    if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                        c
                    } else {
                        '_'
                    }
                })
                .collect();
            let mut job = self.clone();
            job.operations = Vec::new();
            job.program = Some(op.program.0.clone());
            // The operation's tools replace the job's, a job's tool library
            // with them.
            if op.tool.is_some() || !op.tools.is_empty() || op.tool_library.is_some() {
                job.tool = op.tool.clone();
                job.tools = op.tools.clone();
                job.tool_library = op.tool_library.clone();
                job.library = None;
                job.library_tools = 0;
                if let Some(spec) = &op.tool_library {
                    let at = keys.of_message(&format!("{under}.tool_library.path"));
                    job.attach_library(spec, &self.base_dir)
                        .map_err(|e| e.context(format!("{at}: {under}.tool_library")))?;
                }
            }
            if let Some(p) = &op.limits {
                job.limits = p.over(&self.limits, &format!("{under}.limits"))?;
            }
            if let Some(p) = &op.machine {
                job.machine = p.over(&self.machine, &format!("{under}.machine"))?;
            }
            if let Err(e) = job.validate() {
                let at = keys.of_message_under(&under, &e.to_string());
                return Err(e.context(format!("{at}: invalid job (operation {} {name:?})", i + 1)));
            }
            out.push(Operation {
                number: i + 1,
                name: name.to_string(),
                folder: format!("op{}_{folder}", i + 1),
                job,
            });
        }
        Ok(out)
    }
}
