//! The tagged tables of a config, read from its JSON Schema (derived here, [`raw_schema`]): the
//! tables whose selector key (`trigger.rule`, `attack.kind`, `channel.attacks[].kind`,
//! `platoon.spacing_policy`, `topology.preset`, `plant.tau.kind`, `leader.profile.kind`, ...)
//! decides which other keys they hold. The schema enums are the one list of those keys; this
//! module serves it to whoever needs it: error messages that name the key at fault
//! ([`diagnose`]) and campaigns that drop the keys a new selector value does not use
//! (`platoon_campaign::drop_excluded`).

use crate::error::{KeyError, Reason};
use serde_json::{Map, Value};
use std::sync::OnceLock;

/// The schema as schemars derives it from [`crate::schema::Config`] (JSON Schema draft 7, the dialect
/// TOML editors support best).
pub(crate) fn raw_schema() -> Value {
    schemars::generate::SchemaSettings::draft07()
        .into_generator()
        .into_root_schema_for::<crate::schema::Config>()
        .to_value()
}

/// A table whose selector key picks the other keys it may hold.
#[derive(Debug, Clone, PartialEq)]
pub struct TaggedTable {
    /// Where it is: a dotted path, `[]` standing for every element of an array
    /// (`channel.attacks[]`).
    pub path: String,
    /// The selector key (`rule`, `kind`, `spacing_policy`, `preset`).
    pub selector: String,
    /// The value an absent selector means, when it may be absent.
    pub default: Option<String>,
    /// The keys the table has whatever the selector says (the selector aside), sorted.
    pub common: Vec<String>,
    /// One per value of the selector.
    pub variants: Vec<TaggedVariant>,
}

/// One value of a selector and the keys it brings.
#[derive(Debug, Clone, PartialEq)]
pub struct TaggedVariant {
    /// The selector's value (`dynamic`).
    pub tag: String,
    /// What it means.
    pub description: Option<String>,
    /// Its own keys (the selector and the common keys aside), sorted.
    pub keys: Vec<String>,
    /// Those of its keys that have no default.
    pub required: Vec<String>,
    /// Each key's schema.
    schemas: Map<String, Value>,
}

impl TaggedTable {
    /// The variant the selector's value names, `None` for an unknown value.
    pub fn variant(&self, tag: &str) -> Option<&TaggedVariant> {
        self.variants.iter().find(|v| v.tag == tag)
    }

    /// Whether `key` may be in the table when the selector says `tag`.
    pub fn allows(&self, tag: &str, key: &str) -> bool {
        key == self.selector
            || self.common.iter().any(|k| k == key)
            || self
                .variant(tag)
                .is_some_and(|v| v.keys.iter().any(|k| k == key))
    }

    /// Whether `path` (concrete: `channel.attacks[2]`) is this table.
    pub fn matches(&self, path: &str) -> bool {
        pattern(path) == self.path
    }

    /// The selector's value in `table`: the given one, or the default.
    pub fn tag_of<'a>(&'a self, table: &'a toml::Table) -> Option<&'a str> {
        match table.get(&self.selector) {
            Some(v) => v.as_str(),
            None => self.default.as_deref(),
        }
    }

    /// What the selector is called in messages: its last word (`rule`, `kind`, `policy`).
    fn noun(&self) -> &str {
        self.selector.rsplit('_').next().unwrap_or(&self.selector)
    }

    fn tags(&self) -> String {
        let tags: Vec<&str> = self.variants.iter().map(|v| v.tag.as_str()).collect();
        match tags.split_last() {
            Some((last, rest)) if !rest.is_empty() => format!("{} or {last}", rest.join(", ")),
            _ => tags.join(""),
        }
    }
}

/// `channel.attacks[3].kind` -> `channel.attacks[].kind`.
fn pattern(path: &str) -> String {
    let mut out = String::with_capacity(path.len());
    let mut in_index = false;
    for c in path.chars() {
        match c {
            '[' => {
                in_index = true;
                out.push_str("[]");
            }
            ']' => in_index = false,
            _ if in_index => {}
            _ => out.push(c),
        }
    }
    out
}

/// Every tagged table of a config.
pub fn tagged_tables() -> &'static [TaggedTable] {
    static TABLES: OnceLock<Vec<TaggedTable>> = OnceLock::new();
    TABLES.get_or_init(|| {
        let schema = raw_schema();
        let mut out = Vec::new();
        walk(&schema, &schema, "", &mut out, 0);
        out
    })
}

/// The schema `$ref` points to, or `schema` itself.
pub(crate) fn resolve<'a>(root: &'a Value, schema: &'a Value) -> &'a Value {
    match schema.get("$ref").and_then(Value::as_str) {
        Some(r) => r
            .strip_prefix('#')
            .and_then(|p| root.pointer(p))
            .map_or(schema, |s| resolve(root, s)),
        None => match schema.get("allOf").and_then(Value::as_array) {
            // A `$ref` with a description beside it (draft 7 keeps them apart).
            Some(all) if all.len() == 1 => resolve(root, &all[0]),
            _ => schema,
        },
    }
}

/// The alternatives of `schema` (`anyOf`/`oneOf` of an `Option`), resolved, without `null`.
pub(crate) fn alternatives<'a>(root: &'a Value, schema: &'a Value) -> Vec<&'a Value> {
    let schema = resolve(root, schema);
    match schema.get("anyOf").and_then(Value::as_array) {
        Some(list) => list
            .iter()
            .map(|s| resolve(root, s))
            .filter(|s| s.get("type").and_then(Value::as_str) != Some("null"))
            .collect(),
        None => vec![schema],
    }
}

/// The selector of a `oneOf` whose every entry is an object with one `const` property, the same.
pub(crate) fn selector_of(root: &Value, schema: &Value) -> Option<String> {
    let entries = schema.get("oneOf")?.as_array()?;
    let mut selector: Option<String> = None;
    for e in entries {
        let e = resolve(root, e);
        let props = e.get("properties")?.as_object()?;
        let consts: Vec<&String> = props
            .iter()
            .filter(|(_, p)| p.get("const").is_some())
            .map(|(k, _)| k)
            .collect();
        let [only] = consts[..] else { return None };
        match &selector {
            None => selector = Some(only.clone()),
            Some(s) if s == only => {}
            Some(_) => return None,
        }
    }
    selector
}

fn walk(root: &Value, schema: &Value, path: &str, out: &mut Vec<TaggedTable>, depth: usize) {
    if depth > 16 {
        return;
    }
    for schema in alternatives(root, schema) {
        if let Some(items) = schema.get("items") {
            walk(root, items, &format!("{path}[]"), out, depth + 1);
            continue;
        }
        let child = |k: &str| {
            if path.is_empty() {
                k.to_string()
            } else {
                format!("{path}.{k}")
            }
        };
        let common = schema.get("properties").and_then(Value::as_object);
        if let Some(selector) = selector_of(root, schema) {
            let mut variants = Vec::new();
            let mut default = None;
            for e in schema["oneOf"].as_array().into_iter().flatten() {
                let e = resolve(root, e);
                let props = e["properties"].as_object().cloned().unwrap_or_default();
                let tag = props[&selector]["const"]
                    .as_str()
                    .unwrap_or_default()
                    .to_string();
                let required: Vec<String> = e
                    .get("required")
                    .and_then(Value::as_array)
                    .into_iter()
                    .flatten()
                    .filter_map(|r| r.as_str())
                    .filter(|r| *r != selector)
                    .map(str::to_string)
                    .collect();
                if props[&selector].get("default").is_some() {
                    default = Some(tag.clone());
                }
                let mut schemas = props;
                schemas.remove(&selector);
                for (k, s) in &schemas {
                    walk(root, s, &child(k), out, depth + 1);
                }
                variants.push(TaggedVariant {
                    tag,
                    description: e
                        .get("description")
                        .and_then(Value::as_str)
                        .map(str::to_string),
                    keys: schemas.keys().cloned().collect(),
                    required,
                    schemas,
                });
            }
            out.push(TaggedTable {
                path: path.to_string(),
                selector,
                default,
                common: common
                    .map(|c| c.keys().cloned().collect())
                    .unwrap_or_default(),
                variants,
            });
        }
        for (k, s) in common.into_iter().flatten() {
            walk(root, s, &child(k), out, depth + 1);
        }
    }
}

/// Whether a TOML value is valid under `schema` (the subset of JSON Schema the schema types
/// produce: types, properties, required and additional properties, items and their number,
/// constants, `oneOf`/`anyOf`/`allOf`, `$ref`): finds which key of a table a type error is
/// about, and checks that the published schema accepts what the loader accepts.
pub(crate) fn fits(root: &Value, schema: &Value, value: &toml::Value, depth: usize) -> bool {
    let schema = resolve(root, schema);
    if depth > 32 {
        return true;
    }
    if let Some(list) = schema.get("allOf").and_then(Value::as_array) {
        if !list.iter().all(|s| fits(root, s, value, depth + 1)) {
            return false;
        }
    }
    if let Some(list) = schema.get("anyOf").and_then(Value::as_array) {
        if !list.iter().any(|s| fits(root, s, value, depth + 1)) {
            return false;
        }
    }
    if let Some(list) = schema.get("oneOf").and_then(Value::as_array) {
        if list
            .iter()
            .filter(|s| fits(root, s, value, depth + 1))
            .count()
            != 1
        {
            return false;
        }
    }
    if let Some(c) = schema.get("const") {
        if c.as_str().is_none_or(|c| value.as_str() != Some(c)) {
            return false;
        }
    }
    if let Some(list) = schema.get("enum").and_then(Value::as_array) {
        if !list
            .iter()
            .any(|c| c.as_str().is_some_and(|c| value.as_str() == Some(c)))
        {
            return false;
        }
    }
    if let toml::Value::Table(table) = value {
        let empty = Map::new();
        let props = schema
            .get("properties")
            .and_then(Value::as_object)
            .unwrap_or(&empty);
        let required = schema.get("required").and_then(Value::as_array);
        if required
            .into_iter()
            .flatten()
            .filter_map(Value::as_str)
            .any(|k| !table.contains_key(k))
        {
            return false;
        }
        let closed = schema.get("additionalProperties") == Some(&Value::Bool(false));
        for (k, v) in table {
            let ok = match props.get(k) {
                Some(s) => fits(root, s, v, depth + 1),
                None => !closed,
            };
            if !ok {
                return false;
            }
        }
    }
    let types: Vec<&str> = match schema.get("type") {
        Some(Value::String(t)) => vec![t.as_str()],
        Some(Value::Array(ts)) => ts.iter().filter_map(Value::as_str).collect(),
        _ => return true,
    };
    let ok = types.iter().any(|t| match (*t, value) {
        ("number", toml::Value::Float(_) | toml::Value::Integer(_)) => true,
        ("integer", toml::Value::Integer(i)) => schema
            .get("minimum")
            .and_then(Value::as_f64)
            .is_none_or(|m| *i as f64 >= m),
        ("string", toml::Value::String(_)) => true,
        ("boolean", toml::Value::Boolean(_)) => true,
        ("object", toml::Value::Table(_)) => true,
        ("array", toml::Value::Array(_)) => true,
        _ => false,
    });
    if !ok {
        return false;
    }
    if let toml::Value::Array(items) = value {
        let len = items.len() as u64;
        if schema
            .get("minItems")
            .and_then(Value::as_u64)
            .is_some_and(|m| len < m)
            || schema
                .get("maxItems")
                .and_then(Value::as_u64)
                .is_some_and(|m| len > m)
        {
            return false;
        }
        if let Some(item) = schema.get("items") {
            return items.iter().all(|v| fits(root, item, v, depth + 1));
        }
    }
    true
}

/// Why the table at `path` (concrete, `channel.attacks[1]`), a tagged table that did not
/// deserialise with `message`, is wrong, said of the key at fault ([`Reason::Schema`]).
/// `None` when `path` is no tagged table or nothing more precise is found.
pub(crate) fn diagnose(path: &str, value: &toml::Value, message: &str) -> Option<KeyError> {
    let t = tagged_tables().iter().find(|t| t.matches(path))?;
    let table = value.as_table()?;
    // `key` of the table is wrong, as `message` says.
    let at = |k: &str, message: String| {
        let key = if path.is_empty() {
            k.to_string()
        } else {
            format!("{path}.{k}")
        };
        KeyError::new(key, Reason::Schema(message))
    };
    let sel = &t.selector;
    let tag = match table.get(sel) {
        None => match &t.default {
            Some(d) => d.as_str(),
            None => {
                return Some(at(sel, format!("missing; use {}", t.tags())));
            }
        },
        Some(v) => match v.as_str() {
            Some(s) if t.variant(s).is_some() => s,
            _ => {
                return Some(at(
                    sel,
                    format!("unknown {} {}; use {}", t.noun(), v, t.tags()),
                ))
            }
        },
    };
    let variant = t.variant(tag)?;
    let said = |tag: &str| format!("{sel} = \"{tag}\"");
    for key in table.keys() {
        if t.allows(tag, key) {
            continue;
        }
        let owners: Vec<String> = t
            .variants
            .iter()
            .filter(|v| v.keys.contains(key))
            .map(|v| said(&v.tag))
            .collect();
        if owners.is_empty() {
            let mut expected: Vec<String> = vec![sel.clone()];
            expected.extend(t.common.iter().cloned());
            expected.extend(variant.keys.iter().cloned());
            let expected: Vec<String> = expected.iter().map(|k| format!("`{k}`")).collect();
            return Some(at(
                key,
                format!(
                    "unknown field `{key}`, expected one of {}",
                    expected.join(", ")
                ),
            ));
        }
        return Some(at(
            key,
            format!(
                "is not used with {}; it is only used with {}; remove it",
                said(tag),
                owners.join(" or ")
            ),
        ));
    }
    for key in &variant.required {
        if !table.contains_key(key) {
            return Some(at(key, format!("missing: required with {}", said(tag))));
        }
    }
    let root = raw_schema();
    for (key, v) in table {
        if let Some(s) = variant.schemas.get(key) {
            if !fits(&root, s, v, 0) {
                return Some(at(key, message.to_string()));
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(path: &str) -> &'static TaggedTable {
        tagged_tables()
            .iter()
            .find(|t| t.path == path)
            .unwrap_or_else(|| panic!("no tagged table {path}: {:#?}", tagged_tables()))
    }

    #[test]
    fn the_schema_names_every_tagged_table_with_its_keys() {
        let paths: Vec<&str> = tagged_tables().iter().map(|t| t.path.as_str()).collect();
        for p in [
            "trigger",
            "attack",
            "channel.attacks[]",
            "platoon",
            "topology",
            "plant.tau",
            "plant.tau_per_vehicle[]",
            "leader.profile",
        ] {
            assert!(paths.contains(&p), "{p} in {paths:?}");
        }
        let trigger = table("trigger");
        assert_eq!(trigger.selector, "rule");
        assert_eq!(trigger.default, None);
        assert_eq!(trigger.common, ["check_period_s", "h_s", "resilient"]);
        let dynamic = trigger.variant("dynamic").unwrap();
        assert_eq!(dynamic.keys, ["eta", "phi", "rho", "theta0"]);
        assert_eq!(dynamic.required, ["phi", "rho", "eta", "theta0"]);
        let mixed = trigger.variant("mixed").unwrap();
        assert_eq!(mixed.keys, ["alpha", "mu"]);
        assert!(mixed.required.is_empty(), "mu and alpha default to 0");
        assert!(trigger.variant("static").unwrap().keys.is_empty());

        let link = table("channel.attacks[]");
        assert_eq!(link.selector, "kind");
        assert_eq!(
            link.common,
            [
                "acts_as",
                "end_s",
                "key_of",
                "receivers",
                "senders",
                "start_s"
            ],
            "the keys every link attack has"
        );
        let tags: Vec<&str> = link.variants.iter().map(|v| v.tag.as_str()).collect();
        assert_eq!(
            tags,
            [
                "bernoulli",
                "gilbert_elliott",
                "delay",
                "range_jamming",
                "replay",
                "false_data",
                "random_offset",
                "drift",
                "feigned_braking",
                "accel_scale",
                "forged_head",
                "jam_maneuvers",
                "forge_maneuver"
            ]
        );
        assert!(link.matches("channel.attacks[12]"));

        let platoon = table("platoon");
        assert_eq!(platoon.selector, "spacing_policy");
        assert_eq!(platoon.default.as_deref(), Some("constant"));
        assert_eq!(
            platoon.variant("time_headway").unwrap().required,
            ["time_headway_s"]
        );
        assert_eq!(table("topology").common, Vec::<String>::new());
        assert_eq!(
            table("attack").variant("periodic").unwrap().required,
            ["period_s", "duration_s"]
        );
    }

    #[test]
    fn pattern_erases_indices() {
        assert_eq!(pattern("channel.attacks[3].kind"), "channel.attacks[].kind");
        assert_eq!(pattern("a[1][22]"), "a[][]");
    }
}
