//! A command's output folder: checked before the work, built in a private
//! staging folder and swapped into place whole at the end
//! ([`export::atomic::Staging`]), so a failure, a full disk or `kill -9`
//! leaves the complete previous results or the complete new ones.
//! Outputs never overwrite inputs: a folder holding the job's own inputs is
//! refused unless `--force`, which keeps those inputs in the new folder.

use std::path::{Path, PathBuf};

use crate::error::{fail, Error, Result};
use export::atomic::Staging;

/// A results folder being written.
pub struct OutDir {
    stage: Staging,
    /// Inputs inside the target (absolute path, path relative to the target),
    /// kept in the new folder (`--force` only).
    kept: Vec<(PathBuf, PathBuf)>,
}

/// Inputs of the run that lie inside `out`, as (input, path relative to `out`).
fn inputs_inside(out: &Path, inputs: &[PathBuf]) -> Vec<(PathBuf, PathBuf)> {
    let Ok(out) = out.canonicalize() else {
        return Vec::new();
    };
    inputs
        .iter()
        .filter_map(|p| {
            let abs = p.canonicalize().ok()?;
            let rel = abs.strip_prefix(&out).ok()?.to_path_buf();
            Some((abs, rel))
        })
        .collect()
}

impl OutDir {
    /// Check `out` and start staging its new content. `inputs`: every file the
    /// run reads (job, program, meshes, servo data).
    pub fn begin(out: &Path, inputs: &[PathBuf], force: bool) -> Result<OutDir> {
        // `.` or `..` by the name of the folder it is.
        let named;
        let out = if out.file_name().is_none() {
            named = out.canonicalize().unwrap_or_else(|_| out.to_path_buf());
            named.as_path()
        } else {
            out
        };
        let inside = inputs_inside(out, inputs);
        if !inside.is_empty() && !force {
            // `--force` is offered only where it works: a folder that is not
            // a results folder is never replaced, `--force` or not.
            export::atomic::check_replaceable(out)
                .map_err(|e| Error::io("cannot use output folder", out, e))?;
            let names: Vec<String> = inside
                .iter()
                .map(|(a, _)| a.display().to_string())
                .collect();
            fail!(request,
                "output folder {} holds this run's inputs ({}); the run would replace them: choose another --out, or give --force to keep the inputs in the new results",
                out.display(),
                names.join(", ")
            );
        }
        let stage =
            Staging::begin(out).map_err(|e| Error::io("cannot use output folder", out, e))?;
        Ok(OutDir {
            stage,
            kept: inside,
        })
    }

    /// Where the run writes its files.
    pub fn path(&self) -> &Path {
        self.stage.path()
    }

    /// The folder the results will be in.
    pub fn target(&self) -> &Path {
        self.stage.target()
    }

    pub fn run_id(&self) -> String {
        self.stage.run_id().to_string()
    }

    /// Keep the inputs inside the folder (unless an output took their name:
    /// that is what `--force` allows), then swap the new folder into place.
    pub fn commit(self, command: &str) -> Result<()> {
        for (abs, rel) in &self.kept {
            let dest = self.stage.path().join(rel);
            if dest.exists() {
                continue;
            }
            if let Some(parent) = dest.parent() {
                std::fs::create_dir_all(parent)
                    .map_err(|e| Error::io("cannot create", parent, e))?;
            }
            std::fs::copy(abs, &dest).map_err(|e| Error::io("cannot keep input", abs, e))?;
        }
        let target = self.stage.target().to_path_buf();
        self.stage
            .commit(command)
            .map_err(|e| Error::io("cannot move the results into", &target, e))?;
        Ok(())
    }
}
