//! The config reference, generated from the schema types: a JSON Schema for editors
//! (`docs/config.schema.json`: Taplo / Even Better TOML complete and check config files with it)
//! and a page for readers (`docs/config-reference.md`). Both are committed and a test checks
//! them against what this module generates (`PLATOON_BLESS=1 cargo test -p platoon-config
//! --test config reference::` rewrites them, locally: with `CI=true` it refuses), so the
//! reference cannot
//! drift from the code: the keys, their
//! types, their defaults (taken from the code, not from comments) and their doc comments.

use crate::tagged::{alternatives, raw_schema, resolve, selector_of};
use serde_json::{Map, Value};
use std::fmt::Write;

/// The JSON Schema of a scenario config file: [`crate::schema::Config`]'s, with each tagged table's
/// variants closed (a variant lists the table's common keys beside its own and no others), so
/// that an editor flags the keys of another `rule` or `kind` as it flags a typo.
pub fn json_schema() -> Value {
    let mut schema = raw_schema();
    let root = schema.clone();
    close_variants(&root, &mut schema, 0);
    if let Some(o) = schema.as_object_mut() {
        o.insert("title".into(), "platoon scenario config".into());
    }
    schema
}

/// `docs/config.schema.json`: [`json_schema`] as pretty JSON.
pub fn schema_json() -> String {
    let mut s = serde_json::to_string_pretty(&json_schema()).expect("a schema serialises");
    s.push('\n');
    s
}

fn close_variants(root: &Value, schema: &mut Value, depth: usize) {
    if depth > 32 {
        return;
    }
    if selector_of(root, schema).is_some() {
        let common = schema.get("properties").cloned();
        if let Some(variants) = schema.get_mut("oneOf").and_then(Value::as_array_mut) {
            for v in variants {
                let Some(v) = v.as_object_mut() else { continue };
                if let (Some(Value::Object(common)), Some(Value::Object(props))) =
                    (&common, v.get_mut("properties"))
                {
                    for (k, s) in common {
                        props.entry(k.clone()).or_insert_with(|| s.clone());
                    }
                }
                v.insert("additionalProperties".into(), false.into());
            }
        }
    }
    match schema {
        Value::Object(o) => {
            for v in o.values_mut() {
                close_variants(root, v, depth + 1);
            }
        }
        Value::Array(a) => {
            for v in a {
                close_variants(root, v, depth + 1);
            }
        }
        _ => {}
    }
}

/// Markdown table cell text: one line, pipes escaped.
fn cell(s: &str) -> String {
    let one_line = s
        .split("\n\n")
        .map(|p| p.split_whitespace().collect::<Vec<_>>().join(" "))
        .collect::<Vec<_>>()
        .join("<br>");
    one_line.replace('|', "\\|")
}

fn description(schema: &Value) -> Option<&str> {
    schema.get("description").and_then(Value::as_str)
}

/// A TOML literal for a JSON default.
fn toml_literal(v: &Value) -> String {
    match v {
        Value::String(s) if s == "inf" => "inf".into(),
        Value::String(s) => format!("{s:?}"),
        Value::Array(a) => format!(
            "[{}]",
            a.iter().map(toml_literal).collect::<Vec<_>>().join(", ")
        ),
        Value::Number(n) if n.is_f64() => {
            let x = n.as_f64().unwrap_or_default();
            if x.fract() == 0.0 && x.abs() < 1e15 {
                format!("{x:.1}")
            } else {
                format!("{x}")
            }
        }
        Value::Object(o) => format!(
            "{{ {} }}",
            o.iter()
                .map(|(k, v)| format!("{k} = {}", toml_literal(v)))
                .collect::<Vec<_>>()
                .join(", ")
        ),
        other => other.to_string(),
    }
}

/// The constants of a string enum (`oneOf` of `const`s, or `enum`), with their descriptions.
fn constants(root: &Value, schema: &Value) -> Option<Vec<(String, Option<String>)>> {
    let schema = resolve(root, schema);
    if let Some(list) = schema.get("enum").and_then(Value::as_array) {
        return Some(
            list.iter()
                .filter_map(|v| v.as_str().map(|s| (s.to_string(), None)))
                .collect(),
        );
    }
    let list = schema.get("oneOf")?.as_array()?;
    list.iter()
        .map(|v| {
            let v = resolve(root, v);
            let c = v.get("const")?.as_str()?.to_string();
            Some((c, description(v).map(str::to_string)))
        })
        .collect()
}

/// A key's type in words.
fn type_name(root: &Value, schema: &Value) -> String {
    let alts = alternatives(root, schema);
    if alts.len() > 1 {
        return alts
            .iter()
            .map(|s| type_name(root, s))
            .collect::<Vec<_>>()
            .join(" or ");
    }
    let schema = alts.first().copied().unwrap_or(schema);
    if let Some(cs) = constants(root, schema) {
        return cs
            .iter()
            .map(|(c, _)| format!("`\"{c}\"`"))
            .collect::<Vec<_>>()
            .join(", ");
    }
    let types: Vec<&str> = match schema.get("type") {
        Some(Value::String(t)) => vec![t.as_str()],
        Some(Value::Array(ts)) => ts
            .iter()
            .filter_map(Value::as_str)
            .filter(|t| *t != "null")
            .collect(),
        _ if selector_of(root, schema).is_some() => vec!["object"],
        _ => vec![],
    };
    match types.first().copied() {
        Some("array") => {
            let item = schema
                .get("items")
                .map(|i| type_name(root, i))
                .unwrap_or_else(|| "values".into());
            let min = schema.get("minItems").and_then(Value::as_u64);
            let max = schema.get("maxItems").and_then(Value::as_u64);
            match (min, max) {
                (Some(a), Some(b)) if a == b => format!("array of {a} ({item})"),
                _ => format!("array of ({item})"),
            }
        }
        Some("integer") => {
            if schema.get("minimum").and_then(Value::as_f64) == Some(0.0) {
                "integer >= 0".into()
            } else {
                "integer".into()
            }
        }
        Some("object") => "table".into(),
        Some(t) => t.into(),
        None => "any".into(),
    }
}

/// Whether `schema` is a table with keys of its own (documented in a section of its own).
fn is_table(root: &Value, schema: &Value) -> bool {
    let alts = alternatives(root, schema);
    alts.len() == 1 && (alts[0].get("properties").is_some() || selector_of(root, alts[0]).is_some())
}

/// The rows of a table's keys, and the nested tables to document after it.
fn rows(
    root: &Value,
    props: &Map<String, Value>,
    required: &[&str],
    path: &str,
    out: &mut String,
    nested: &mut Vec<(String, Value)>,
) {
    out.push_str("| key | type | default | description |\n|---|---|---|---|\n");
    for (key, s) in props {
        let mut desc = description(s)
            .or_else(|| description(resolve(root, s)))
            .unwrap_or("")
            .to_string();
        let table = is_table(root, s);
        let default = match s.get("default") {
            // A table's defaults are its keys'.
            Some(_) if table => "optional".into(),
            Some(d) => format!("`{}`", toml_literal(d)),
            None if required.contains(&key.as_str()) => "required".into(),
            None => "absent".into(),
        };
        let ty = if table {
            let child = if path.is_empty() {
                key.clone()
            } else {
                format!("{path}.{key}")
            };
            let item = resolve(root, s).get("items").is_some();
            nested.push((child.clone(), s.clone()));
            if item {
                format!("array of tables, see [`[[{child}]]`](#{})", anchor(&child))
            } else {
                format!("table, see [`[{child}]`](#{})", anchor(&child))
            }
        } else if let Some(entry) = s
            .get("additionalProperties")
            .filter(|a| a.is_object() && is_table(root, a))
        {
            // A table of tables by name (`[vehicle_classes.<name>]`).
            let child = if path.is_empty() {
                format!("{key}.<name>")
            } else {
                format!("{path}.{key}.<name>")
            };
            nested.push((child.clone(), entry.clone()));
            format!("tables by name, see [`[{child}]`](#{})", anchor(&child))
        } else {
            let array_of_tables = alternatives(root, s)
                .first()
                .and_then(|a| a.get("items"))
                .is_some_and(|i| is_table(root, i));
            if array_of_tables {
                let child = if path.is_empty() {
                    key.clone()
                } else {
                    format!("{path}.{key}")
                };
                let items = alternatives(root, s)[0]["items"].clone();
                nested.push((format!("{child}[]"), items));
                format!(
                    "array of tables, see [`[[{child}]]`](#{})",
                    anchor(&format!("{child}[]"))
                )
            } else {
                type_name(root, s)
            }
        };
        if let Some(cs) = alternatives(root, s)
            .first()
            .and_then(|a| constants(root, a))
            .filter(|cs| cs.iter().any(|(_, d)| d.is_some()))
        {
            for (c, d) in cs {
                let _ = write!(desc, "\n\n`\"{c}\"`: {}", d.unwrap_or_default());
            }
        }
        let _ = writeln!(
            out,
            "| `{key}` | {} | {default} | {} |",
            cell(&ty),
            cell(&desc)
        );
    }
}

/// The anchor of a table's heading: `channel.attacks[]` -> `channel-attacks`.
/// A table schema's keys (`properties`), if it lists any.
fn properties(schema: &Value) -> Option<&Map<String, Value>> {
    schema.get("properties").and_then(Value::as_object)
}

/// The keys a table schema requires (`required`).
fn required(schema: &Value) -> Vec<&str> {
    schema
        .get("required")
        .and_then(Value::as_array)
        .into_iter()
        .flatten()
        .filter_map(Value::as_str)
        .collect()
}

fn anchor(path: &str) -> String {
    path.chars()
        .filter_map(|c| match c {
            'a'..='z' | '0'..='9' | '_' => Some(c),
            'A'..='Z' => Some(c.to_ascii_lowercase()),
            '.' => Some('-'),
            _ => None,
        })
        .collect()
}

fn section(root: &Value, path: &str, schema: &Value, out: &mut String, depth: usize) {
    if depth > 8 {
        return;
    }
    let schema_alts = alternatives(root, schema);
    let Some(schema) = schema_alts.first().copied() else {
        return;
    };
    let (heading, display) = match path.strip_suffix("[]") {
        Some(p) => (format!("[[{p}]]"), path),
        None => (format!("[{path}]"), path),
    };
    let _ = writeln!(out, "<a id=\"{}\"></a>\n", anchor(display));
    let _ = writeln!(out, "{} `{heading}`\n", "#".repeat(2 + depth.min(1)));
    if let Some(d) = description(schema) {
        let _ = writeln!(out, "{}\n", d.trim());
    }
    let mut nested = Vec::new();
    let selector = selector_of(root, schema);
    let empty = Map::new();
    let props = properties(schema).unwrap_or(&empty);
    let required_keys = required(schema);
    if let Some(sel) = &selector {
        let variants = schema["oneOf"].as_array().cloned().unwrap_or_default();
        let tags: Vec<String> = variants
            .iter()
            .filter_map(|v| resolve(root, v)["properties"][sel]["const"].as_str())
            .map(|t| format!("`\"{t}\"`"))
            .collect();
        let default = variants.iter().find_map(|v| {
            let p = &resolve(root, v)["properties"][sel];
            p.get("default").map(toml_literal)
        });
        let _ = writeln!(
            out,
            "`{sel}` picks the other keys the table takes: {}{}. A key of another `{sel}` is an \
             error.\n",
            tags.join(", "),
            default.map_or_else(
                || " (required)".to_string(),
                |d| format!(" (default `{d}`)")
            )
        );
    }
    if !props.is_empty() {
        if selector.is_some() {
            out.push_str("Keys of every variant:\n\n");
        }
        rows(root, props, &required_keys, path, out, &mut nested);
        out.push('\n');
    }
    if let Some(sel) = &selector {
        for v in schema["oneOf"].as_array().into_iter().flatten() {
            let v = resolve(root, v);
            let tag = v["properties"][sel]["const"].as_str().unwrap_or_default();
            let _ = writeln!(
                out,
                "**`{sel} = \"{tag}\"`**: {}\n",
                v.get("description")
                    .and_then(Value::as_str)
                    .unwrap_or("")
                    .trim()
            );
            let mut own = v["properties"].as_object().cloned().unwrap_or_default();
            own.remove(sel);
            if own.is_empty() {
                out.push_str("No other keys.\n\n");
                continue;
            }
            rows(root, &own, &required(v), path, out, &mut nested);
            out.push('\n');
        }
    }
    for (child, s) in nested {
        section(root, &child, &s, out, depth + 1);
    }
}

/// `docs/config-reference.md`: every key of a scenario config with its type, default and
/// description, table by table.
pub fn reference_markdown() -> String {
    file_reference(
        &raw_schema(),
        "Config reference",
        "platoon_config::reference_markdown() from the schema types in crates/config/src/schema.rs",
        "`PLATOON_BLESS=1 cargo test -p platoon-config --test config reference::`",
        "Every key of a scenario file, table by table. Unknown keys are errors. A key with a \
         default may be left out; `absent` means the key may be left out and its description \
         says what that means. A run writes its resolved config (every default written out) as \
         `config.toml` in its directory. Editors that read JSON Schemas (Taplo, Even Better TOML) \
         complete and check config files with [config.schema.json](config.schema.json): put \
         `#:schema ../docs/config.schema.json` (a path relative to the file) on its first line.",
    )
}

/// The reference page of any file format read through this crate (scenario, campaign, search),
/// from its JSON Schema `root`: the top level's keys, then each table's, with their types,
/// defaults and descriptions. `generator` and `bless` name what writes the page and the command
/// that rewrites it; `intro` opens it.
pub fn file_reference(
    root: &Value,
    title: &str,
    generator: &str,
    bless: &str,
    intro: &str,
) -> String {
    let mut out = String::new();
    let _ = write!(
        out,
        "# {title}\n\n<!-- Generated by {generator}; do not edit: {bless} rewrites it. -->\n\n"
    );
    if let Some(d) = description(root) {
        let _ = writeln!(out, "{}\n", d.trim());
    }
    let _ = write!(out, "{intro}\n\n");
    out.push_str("## Top level\n\n");
    let mut nested = Vec::new();
    let empty = Map::new();
    let props = properties(root).unwrap_or(&empty);
    rows(root, props, &required(root), "", &mut out, &mut nested);
    out.push('\n');
    for (child, s) in nested {
        section(root, &child, &s, &mut out, 0);
    }
    while out.ends_with("\n\n") {
        out.pop();
    }
    out
}

/// The JSON Schema of any serde type, as [`file_reference`] reads it (draft 7).
pub fn schema_of<T: schemars::JsonSchema>() -> Value {
    schemars::generate::SchemaSettings::draft07()
        .into_generator()
        .into_root_schema_for::<T>()
        .to_value()
}

/// Checks a committed generated file against what the code generates, or with `PLATOON_BLESS`
/// set rewrites it (refused where `CI` is set: CI checks the committed files, it does not make
/// them). `bless` is the command that rewrites it, for the message.
pub fn check_committed(path: &std::path::Path, generated: &str, bless: &str) -> Result<(), String> {
    let var = |k: &str| std::env::var_os(k).map(|v| v.to_string_lossy().into_owned());
    if let Some(ci) = var("PLATOON_BLESS").and(var("CI")) {
        if !matches!(ci.trim(), "" | "0" | "false") {
            return Err(format!(
                "PLATOON_BLESS is set with CI={ci}: CI checks the committed files and never \
                 rewrites them; bless locally and commit the result"
            ));
        }
    }
    if var("PLATOON_BLESS").is_some() {
        return std::fs::write(path, generated)
            .map_err(|e| format!("writing {}: {e}", path.display()));
    }
    let committed = std::fs::read_to_string(path).unwrap_or_default();
    if committed == generated {
        return Ok(());
    }
    let line = committed
        .lines()
        .zip(generated.lines())
        .position(|(a, b)| a != b)
        .unwrap_or_else(|| committed.lines().count().min(generated.lines().count()));
    Err(format!(
        "{} is not what the code generates (first difference at line {}): run `{bless}` and \
         commit it",
        path.display(),
        line + 1
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_schema_is_draft_7_with_closed_variants() {
        let schema = json_schema();
        assert_eq!(
            schema["$schema"].as_str(),
            Some("http://json-schema.org/draft-07/schema#")
        );
        let trigger = resolve(&schema, &schema["properties"]["trigger"]);
        for v in trigger["oneOf"].as_array().unwrap() {
            assert_eq!(v["additionalProperties"], Value::Bool(false));
            assert!(v["properties"].get("h_s").is_some(), "the common keys: {v}");
        }
    }
}
