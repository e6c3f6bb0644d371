//! Where a key of a TOML file is: its path as messages name it
//! (`stock.grid`, `tools[1].number`) and its `FILE:LINE:COL`, read from the
//! file's spanned table (toml's `DeTable`). Every error about a job key
//! (serde's type errors, the range checks) is placed at the key's own line
//! and column with it.

use toml::de::{DeTable, DeValue};
use toml::Spanned;

/// The keys of one TOML text, with their places.
pub struct KeyPlaces<'a> {
    /// The file as messages name it.
    name: &'a str,
    text: &'a str,
    /// The spanned table (`None` where the text is not TOML: its error has
    /// its own place).
    table: Option<Spanned<DeTable<'a>>>,
}

/// One step of a key path: a key of a table or an entry of an array.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Step<'p> {
    Key(&'p str),
    Index(usize),
}

/// The steps of a key path such as `tools[1].diameter`; `None` where it is
/// not one.
fn steps(path: &str) -> Option<Vec<Step<'_>>> {
    let mut out = Vec::new();
    for part in path.split('.') {
        let (key, mut rest) = part.split_at(part.find('[').unwrap_or(part.len()));
        if key.is_empty()
            || !key
                .bytes()
                .all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-')
        {
            return None;
        }
        out.push(Step::Key(key));
        while let Some(inner) = rest.strip_prefix('[') {
            let close = inner.find(']')?;
            out.push(Step::Index(inner[..close].parse().ok()?));
            rest = &inner[close + 1..];
        }
        if !rest.is_empty() {
            return None;
        }
    }
    Some(out)
}

/// The key path a message begins with: `tools[1].diameter (mm) must …` →
/// `tools[1].diameter`; `stock.min (mm)[2] must …` → `stock.min[2]`.
fn leading_path(message: &str) -> Option<String> {
    let first = message.split([' ', ':', ',']).next()?;
    // A unit in parentheses between the key and its index.
    let rest = &message[first.len()..];
    let index = rest
        .strip_prefix(" (")
        .and_then(|r| r.split_once(')'))
        .and_then(|(_, after)| after.starts_with('[').then_some(after))
        .and_then(|after| after.split_once(']'))
        .map(|(i, _)| format!("{i}]"));
    let path = format!("{first}{}", index.unwrap_or_default());
    let valid = steps(&path).is_some();
    valid.then_some(path)
}

impl<'a> KeyPlaces<'a> {
    /// The keys of `text`, a file named `name` in messages.
    pub fn new(name: &'a str, text: &'a str) -> KeyPlaces<'a> {
        KeyPlaces {
            name,
            text,
            table: DeTable::parse(text).ok(),
        }
    }

    /// `FILE:LINE:COL` of byte `offset`.
    pub fn at(&self, offset: usize) -> String {
        super::job::location(self.name, self.text, offset)
    }

    /// Where the key `path` is written (the key itself; for an array entry,
    /// the entry), or the deepest table on the path that the file has:
    /// `None` where not even its first key is in the file.
    fn span_of(&self, path: &str) -> Option<std::ops::Range<usize>> {
        self.span_along(path).map(|(span, _)| span)
    }

    /// [`KeyPlaces::span_of`], and whether the whole path is in the file.
    fn span_along(&self, path: &str) -> Option<(std::ops::Range<usize>, bool)> {
        let steps = steps(path)?;
        let mut found_steps = 0;
        let mut table: &DeTable = self.table.as_ref()?.get_ref();
        let mut value: Option<&DeValue> = None;
        let mut found = None;
        for &step in &steps {
            let next = match (step, value) {
                (Step::Key(k), None) | (Step::Key(k), Some(DeValue::Table(_))) => {
                    if let Some(DeValue::Table(t)) = value {
                        table = t;
                    }
                    table
                        .iter()
                        .find(|(key, _)| key.get_ref().as_ref() == k)
                        .map(|(key, v)| (key.span(), v))
                }
                (Step::Index(i), Some(DeValue::Array(a))) => a.get(i).map(|v| (v.span(), v)),
                _ => None,
            };
            let Some((span, v)) = next else { break };
            found = Some(span);
            found_steps += 1;
            value = Some(v.get_ref());
        }
        found.map(|span| (span, found_steps == steps.len()))
    }

    /// [`KeyPlaces::of_message`] of a message about a key of the table
    /// `prefix` (an operation's, `operations[1]`): where that table has the
    /// key, else where the file's top level has it.
    pub fn of_message_under(&self, prefix: &str, message: &str) -> String {
        let under = leading_path(message)
            .and_then(|p| self.span_along(&format!("{prefix}.{p}")))
            .filter(|&(_, whole)| whole);
        match under {
            Some((span, _)) => self.at(span.start),
            None => self.of_message(message),
        }
    }

    /// `FILE:LINE:COL` of the key a message begins with (see
    /// [`KeyPlaces::span_of`]), or the file's name alone.
    pub fn of_message(&self, message: &str) -> String {
        leading_path(message)
            .and_then(|p| self.span_of(&p))
            .map_or_else(|| self.name.to_string(), |s| self.at(s.start))
    }

    /// The path of the innermost key (or array entry) whose key or value
    /// holds byte `offset`.
    pub fn path_at(&self, offset: usize) -> Option<String> {
        // Depth first through every table: a header table's span is its
        // header, not its keys, so a parent need not hold the offset.
        fn walk_table(t: &DeTable, offset: usize, path: &str) -> Option<String> {
            t.iter().find_map(|(k, v)| {
                let here = if path.is_empty() {
                    k.get_ref().to_string()
                } else {
                    format!("{path}.{}", k.get_ref())
                };
                walk(v.get_ref(), offset, &here).or_else(|| {
                    (k.span().contains(&offset) || v.span().contains(&offset)).then_some(here)
                })
            })
        }
        fn walk(value: &DeValue, offset: usize, path: &str) -> Option<String> {
            match value {
                DeValue::Table(t) => walk_table(t, offset, path),
                DeValue::Array(a) => a.iter().enumerate().find_map(|(i, v)| {
                    let here = format!("{path}[{i}]");
                    walk(v.get_ref(), offset, &here)
                        .or_else(|| v.span().contains(&offset).then_some(here))
                }),
                _ => None,
            }
        }
        walk_table(self.table.as_ref()?.get_ref(), offset, "")
    }

    /// A TOML or serde error as `FILE:LINE:COL: key.path: message`: the key
    /// named where the error's place lies inside one.
    pub fn de_error(&self, e: &toml::de::Error) -> String {
        // A message of our own that names its key (a shape's keys checked
        // against its kind): at that key.
        if let Some(s) = leading_path(e.message()).and_then(|p| self.span_of(&p)) {
            return format!("{}: {}", self.at(s.start), e.message());
        }
        match e.span() {
            Some(s) => {
                let key = self
                    .path_at(s.start)
                    .map(|p| format!("{p}: "))
                    .unwrap_or_default();
                format!("{}: {key}{}", self.at(s.start), e.message())
            }
            None => format!("{}: {}", self.name, e.message()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = "[stock]\nkind = \"box\"\ngrid = 0.5\n\n[[tools]]\nnumber = 1\n\n[[tools]]\nnumber = 2\ndiameter = 3\n";

    #[test]
    fn keys_are_found_where_they_are_written() {
        let k = KeyPlaces::new("job.toml", TEXT);
        assert_eq!(
            k.of_message("stock.grid (mm) must lie in …"),
            "job.toml:3:1"
        );
        assert_eq!(
            k.of_message("tools[1].diameter (mm) must …"),
            "job.toml:10:1"
        );
        assert_eq!(k.of_message("tools[1].number: tool 2 …"), "job.toml:9:1");
        // A key not written: the deepest table on its path that is.
        assert_eq!(k.of_message("stock.min (mm)[2] must …"), "job.toml:1:2");
        assert_eq!(k.of_message("the job needs a [tool]"), "job.toml");
        assert_eq!(
            k.path_at(TEXT.find("0.5").unwrap()).as_deref(),
            Some("stock.grid")
        );
        assert_eq!(
            k.path_at(TEXT.find("diameter").unwrap()).as_deref(),
            Some("tools[1].diameter")
        );
    }

    #[test]
    fn key_paths_are_read_from_messages() {
        assert_eq!(
            leading_path("stock.min (mm)[2] must").as_deref(),
            Some("stock.min[2]")
        );
        assert_eq!(
            leading_path("machine.accel (mm/s²) must").as_deref(),
            Some("machine.accel")
        );
        assert_eq!(
            leading_path("tools[0].number is missing").as_deref(),
            Some("tools[0].number")
        );
        assert_eq!(
            leading_path("give either one [tool]").as_deref(),
            Some("give")
        );
        assert_eq!(leading_path("[tool] x"), None);
    }
}
