//! Where in a scene file an error is: the line of each key (from the TOML parser's spans), and
//! the error that carries it.

/// An error at a line of the scene file (1-based): [`load_scene`](super::load_scene) shows it as
/// `FILE:LINE: message`, [`parse_scene`](super::parse_scene) as `line LINE: message`.
#[derive(Debug)]
pub(super) struct AtLine {
    pub(super) line: usize,
    pub(super) msg: String,
}

impl std::fmt::Display for AtLine {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "line {}: {}", self.line, self.msg)
    }
}

impl std::error::Error for AtLine {}

/// The 1-based line of byte `at` of `text`.
pub(super) fn line_of(text: &str, at: usize) -> usize {
    text.get(..at).unwrap_or(text).matches('\n').count() + 1
}

/// One step of a key's path in the scene file: a key of a table, or an element of an array.
#[derive(Clone, Copy)]
pub(super) enum Seg<'a> {
    K(&'a str),
    I(usize),
}
pub(super) use Seg::{I, K};

/// The lines of every key of a scene file (toml's spans, [`toml::de::DeTable`]), so that
/// every error names its FILE:LINE as well as its key.
pub(super) struct Lines<'a> {
    pub(super) text: &'a str,
    root: Option<toml::Spanned<toml::de::DeTable<'a>>>,
}

impl<'a> Lines<'a> {
    pub(super) fn new(text: &'a str) -> Self {
        Lines {
            text,
            root: toml::de::DeTable::parse(text).ok(),
        }
    }

    /// The 1-based line of the key at `path` (an array element: its `[[…]]` header), or of
    /// the deepest table on the path that exists (a missing key: the table that lacks it).
    pub(super) fn line(&self, path: &[Seg]) -> usize {
        use toml::de::DeValue;
        let Some(root) = &self.root else { return 1 };
        let mut at = 0;
        let mut table = Some(root.get_ref());
        let mut array = None;
        for seg in path {
            let next = match seg {
                K(k) => table.and_then(|t| {
                    t.iter()
                        .find(|(key, _)| key.get_ref().as_ref() == *k)
                        .map(|(key, v)| (key.span().start, v))
                }),
                I(i) => {
                    array.and_then(|a: &toml::de::DeArray| a.get(*i).map(|v| (v.span().start, v)))
                }
            };
            let Some((start, v)) = next else { break };
            at = start;
            (table, array) = match v.get_ref() {
                DeValue::Table(t) => (Some(t), None),
                DeValue::Array(a) => (None, Some(a)),
                _ => (None, None),
            };
        }
        line_of(self.text, at)
    }

    /// An error at the line of `path`: [`AtLine`] (kept as it is when it already has one).
    pub(super) fn at(&self, path: &[Seg]) -> impl FnOnce(anyhow::Error) -> anyhow::Error + use<> {
        let line = self.line(path);
        move |e| {
            if e.downcast_ref::<AtLine>().is_some() {
                e
            } else {
                AtLine {
                    line,
                    msg: format!("{e:#}"),
                }
                .into()
            }
        }
    }
}
