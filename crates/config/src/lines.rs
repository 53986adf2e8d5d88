//! Where a key stands in a TOML file: the line an error about it names, for every file format
//! (scenario, campaign, search) read through this crate.

use serde::de::{Deserialize, Deserializer, MapAccess, SeqAccess, Visitor};
use std::collections::BTreeMap;
use std::fmt;

/// A parsed TOML document that remembers where each value starts.
#[derive(Debug, Default)]
pub struct KeyLines {
    root: Node,
    text: String,
}

#[derive(Debug, Default)]
enum Node {
    #[default]
    Leaf,
    Table(BTreeMap<String, (usize, Node)>),
    Array(Vec<(usize, Node)>),
}

impl KeyLines {
    /// The document `text` (an unparsable one knows no lines).
    pub fn new(text: &str) -> Self {
        let root = toml::from_str::<Node>(text)
            .or_else(|_| toml::from_str::<Node>(&with_parent_tables(text)))
            .unwrap_or_default();
        Self {
            root,
            text: text.to_string(),
        }
    }

    /// The 1-based line where the value of the key at `path` starts, each segment a table key
    /// or an array index (`["set", "simulation.dt_s"]`, `["axes", "2", "key"]`).
    pub fn line(&self, path: &[&str]) -> Option<usize> {
        let mut node = &self.root;
        let mut at = None;
        for segment in path {
            let (start, next) = match node {
                Node::Table(t) => t.get(*segment)?,
                Node::Array(a) => a.get(segment.parse::<usize>().ok()?)?,
                Node::Leaf => return None,
            };
            at = Some(*start);
            node = next;
        }
        at.map(|at| line_at(&self.text, at))
    }

    /// [`Self::line`] of a dotted key with indices, as errors name keys
    /// (`budget.max_jammed_s`, `study.laws[2]`).
    pub fn line_of(&self, key: &str) -> Option<usize> {
        let segments: Vec<&str> = key
            .split(['.', '[', ']'])
            .filter(|s| !s.is_empty())
            .collect();
        self.line(&segments)
    }
}

/// `text` with a header appended for every table that only a deeper header opens (`[sumo]`
/// for a file whose `[[sumo.ahead]]` comes without it): the parser gives such an implicit
/// table no place, which its spans cannot take. Appended at the end, so every line keeps its
/// number.
fn with_parent_tables(text: &str) -> String {
    let headers: Vec<&str> = text
        .lines()
        .filter_map(|l| {
            let l = l.trim();
            let l = l.split('#').next()?.trim();
            l.strip_prefix("[[")
                .and_then(|h| h.strip_suffix("]]"))
                .or_else(|| l.strip_prefix('[').and_then(|h| h.strip_suffix(']')))
                .map(str::trim)
        })
        .collect();
    let mut out = text.to_string();
    let mut added: Vec<String> = Vec::new();
    for h in &headers {
        let parts: Vec<&str> = h.split('.').map(str::trim).collect();
        for n in 1..parts.len() {
            let parent = parts[..n].join(".");
            if !headers.iter().any(|x| *x == parent) && !added.contains(&parent) {
                out.push_str(&format!("\n[{parent}]\n"));
                added.push(parent);
            }
        }
    }
    out
}

/// The 1-based line of byte `at` of `text`.
pub(crate) fn line_at(text: &str, at: usize) -> usize {
    let mut at = at.min(text.len());
    while !text.is_char_boundary(at) {
        at -= 1;
    }
    text[..at].lines().count().max(1) + usize::from(text[..at].ends_with('\n'))
}

impl<'de> Deserialize<'de> for Node {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(NodeVisitor)
    }
}

fn start(v: toml::Spanned<Node>) -> (usize, Node) {
    let at = v.span().start;
    (at, v.into_inner())
}

struct NodeVisitor;

impl<'de> Visitor<'de> for NodeVisitor {
    type Value = Node;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("a TOML value")
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Node, A::Error> {
        let mut t = BTreeMap::new();
        while let Some(k) = map.next_key::<String>()? {
            let v: toml::Spanned<Node> = map.next_value()?;
            t.insert(k, start(v));
        }
        Ok(Node::Table(t))
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Node, A::Error> {
        let mut a = Vec::new();
        while let Some(v) = seq.next_element::<toml::Spanned<Node>>()? {
            a.push(start(v));
        }
        Ok(Node::Array(a))
    }

    fn visit_bool<E>(self, _: bool) -> Result<Node, E> {
        Ok(Node::Leaf)
    }
    fn visit_i64<E>(self, _: i64) -> Result<Node, E> {
        Ok(Node::Leaf)
    }
    fn visit_u64<E>(self, _: u64) -> Result<Node, E> {
        Ok(Node::Leaf)
    }
    fn visit_f64<E>(self, _: f64) -> Result<Node, E> {
        Ok(Node::Leaf)
    }
    fn visit_str<E>(self, _: &str) -> Result<Node, E> {
        Ok(Node::Leaf)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_are_found_on_their_own_lines() {
        let text = "seed = 1\n\n[budget]\nmax_jammed_s = 3.0\n[study]\nlaws = [\n  \"paper\",\n  \"acc\",\n]\n[set]\n\"simulation.dt_s\" = 0.01\n[[axes]]\nkey = \"a\"\n[[axes]]\nkey = \"b\"\n";
        let l = KeyLines::new(text);
        assert_eq!(l.line_of("seed"), Some(1));
        assert_eq!(l.line_of("budget.max_jammed_s"), Some(4));
        assert_eq!(l.line_of("study.laws[1]"), Some(8));
        assert_eq!(l.line(&["set", "simulation.dt_s"]), Some(11));
        assert_eq!(l.line(&["axes", "1", "key"]), Some(15));
        assert_eq!(l.line_of("nowhere"), None);
        // An array of tables under a table the file never opens.
        let l = KeyLines::new("[a]\nx = 1\n\n[[b.c]]\ny = 2\n");
        assert_eq!(l.line_of("a.x"), Some(2));
        assert_eq!(l.line_of("b.c[0].y"), Some(5));
        assert_eq!(l.line_of("b.c[0]"), Some(4));
    }
}
