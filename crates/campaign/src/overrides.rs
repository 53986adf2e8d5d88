//! Setting scenario keys by dotted path (`channel.attacks[0].loss`) on a config's TOML value.

/// One segment of a dotted path: a table key, optionally indexed into an array.
#[derive(Debug, Clone, PartialEq)]
struct Segment<'a> {
    key: &'a str,
    index: Option<usize>,
}

fn segments(path: &str) -> Result<Vec<Segment<'_>>, String> {
    if path.is_empty() {
        return Err("the key is empty".into());
    }
    path.split('.')
        .map(|part| {
            let (key, index) = match part.split_once('[') {
                None => (part, None),
                Some((key, rest)) => {
                    let Some(n) = rest.strip_suffix(']') else {
                        return Err(format!("`{part}`: an index is written `name[0]`"));
                    };
                    let n = n
                        .parse()
                        .map_err(|_| format!("`{part}`: `{n}` is not an index"))?;
                    (key, Some(n))
                }
            };
            if key.is_empty()
                || !key
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
            {
                return Err(format!("`{part}` is not a key"));
            }
            Ok(Segment { key, index })
        })
        .collect()
}

/// Sets `path` to `value` in `root`, creating missing tables on the way (not arrays: an index
/// must exist). Errors say which part of the path does not fit.
pub fn set(root: &mut toml::Value, path: &str, value: toml::Value) -> Result<(), String> {
    let segs = segments(path)?;
    let mut here = root;
    let mut walked = String::new();
    for (i, seg) in segs.iter().enumerate() {
        let last = i + 1 == segs.len();
        if !walked.is_empty() {
            walked.push('.');
        }
        walked.push_str(seg.key);
        let Some(table) = here.as_table_mut() else {
            return Err(format!("`{walked}`: its parent is not a table"));
        };
        if last && seg.index.is_none() {
            table.insert(seg.key.to_string(), value);
            return Ok(());
        }
        if seg.index.is_some() && !table.contains_key(seg.key) {
            return Err(format!(
                "`{walked}[{}]`: the base scenario has 0 entries there",
                seg.index.unwrap_or(0)
            ));
        }
        let entry = table
            .entry(seg.key.to_string())
            .or_insert_with(|| toml::Value::Table(Default::default()));
        here = match seg.index {
            None => entry,
            Some(n) => {
                let Some(array) = entry.as_array_mut() else {
                    return Err(format!("`{walked}` is not an array in the base scenario"));
                };
                let len = array.len();
                let Some(item) = array.get_mut(n) else {
                    return Err(format!(
                        "`{walked}[{n}]`: the base scenario has {len} entries there"
                    ));
                };
                walked.push_str(&format!("[{n}]"));
                if last {
                    *item = value;
                    return Ok(());
                }
                item
            }
        };
    }
    unreachable!("the loop returns at the last segment")
}

/// Whether `path` is `prefix` or lies below it (`trigger.phi` is below `trigger`).
fn under(path: &str, prefix: &str) -> bool {
    path == prefix
        || path
            .strip_prefix(prefix)
            .is_some_and(|r| r.starts_with('.') || r.starts_with('['))
}

/// The concrete paths of `pattern` (`channel.attacks[]`) in `root`, with their tables.
fn instances<'a>(root: &'a mut toml::Value, pattern: &str) -> Vec<(String, &'a mut toml::Table)> {
    let mut here: Vec<(String, &'a mut toml::Value)> = vec![(String::new(), root)];
    for part in pattern.split('.') {
        let (key, arrays) = match part.find('[') {
            Some(i) => (&part[..i], part[i..].matches("[]").count()),
            None => (part, 0),
        };
        let mut next = Vec::new();
        for (path, value) in here {
            let Some(v) = value.get_mut(key) else {
                continue;
            };
            let path = if path.is_empty() {
                key.to_string()
            } else {
                format!("{path}.{key}")
            };
            let mut level = vec![(path, v)];
            for _ in 0..arrays {
                level = level
                    .into_iter()
                    .filter_map(|(p, v)| v.as_array_mut().map(|a| (p, a)))
                    .flat_map(|(p, a)| {
                        a.iter_mut()
                            .enumerate()
                            .map(move |(i, v)| (format!("{p}[{i}]"), v))
                    })
                    .collect();
            }
            next.extend(level);
        }
        here = next;
    }
    here.into_iter()
        .filter_map(|(p, v)| v.as_table_mut().map(|t| (p, t)))
        .collect()
}

/// After a campaign set `touched` keys: drops the keys of the base that the new values make
/// invalid, unless the campaign set them itself. In a tagged table (`platoon_config::
/// tagged_tables`: `trigger`, `attack`, `channel.attacks[i]`, `platoon`, `topology`, ...),
/// when the campaign sets the selector, the keys the new `rule` or `kind` does not take go
/// (`trigger.rule = "static"` drops `trigger.phi`, ...); and `platoon.initial_states` and
/// `platoon.formation` exclude each other.
pub fn drop_excluded(root: &mut toml::Value, touched: &[&str]) {
    let set_by_campaign = |key: &str| touched.iter().any(|t| under(t, key));
    for t in platoon_config::tagged_tables() {
        for (path, table) in instances(root, &t.path) {
            if !set_by_campaign(&format!("{path}.{}", t.selector)) {
                continue;
            }
            let Some(tag) = t.tag_of(table).map(str::to_string) else {
                continue;
            };
            if t.variant(&tag).is_none() {
                continue;
            }
            table.retain(|k, _| t.allows(&tag, k) || set_by_campaign(&format!("{path}.{k}")));
        }
    }
    if let Some(p) = root.get_mut("platoon").and_then(|t| t.as_table_mut()) {
        if set_by_campaign("platoon.formation") && !set_by_campaign("platoon.initial_states") {
            p.remove("initial_states");
        }
        if set_by_campaign("platoon.initial_states") && !set_by_campaign("platoon.formation") {
            p.remove("formation");
        }
    }
}

/// A config edited as a whole from `origin`, the resolved config it was made from (the Python
/// package's dicts, which hold every key of their variants): in each tagged table whose `rule`
/// or `kind` now differs from the origin's, drops the keys of the old variant that the new one
/// does not take and that still hold the origin's value, so switching `trigger.rule` needs no
/// clean-up. A key the edit added or changed is kept, and stays an error that names it.
pub fn drop_switched_variants(root: &mut toml::Value, origin: &toml::Value) {
    let mut origin = origin.clone();
    for t in platoon_config::tagged_tables() {
        let before: std::collections::HashMap<String, toml::Table> =
            instances(&mut origin, &t.path)
                .into_iter()
                .map(|(p, table)| (p, table.clone()))
                .collect();
        for (path, table) in instances(root, &t.path) {
            let Some(old) = before.get(&path) else {
                continue;
            };
            let Some(tag) = t.tag_of(table).map(str::to_string) else {
                continue;
            };
            if t.variant(&tag).is_none() || t.tag_of(old) == Some(tag.as_str()) {
                continue;
            }
            table.retain(|k, v| t.allows(&tag, k) || old.get(k) != Some(v));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn doc(text: &str) -> toml::Value {
        toml::from_str(text).unwrap()
    }

    #[test]
    fn a_switched_rule_drops_the_old_rules_untouched_keys_only() {
        let origin = doc("[trigger]\nrule = \"dynamic\"\neta = 0.5\nphi = 0.3\n");
        let mut v = doc("[trigger]\nrule = \"static\"\neta = 0.5\nphi = 0.4\ntypo = 1\n");
        drop_switched_variants(&mut v, &origin);
        let t = v["trigger"].as_table().unwrap();
        // eta untouched: dropped; phi changed and typo added by the edit: kept (and refused).
        assert!(t.get("eta").is_none(), "{t:?}");
        assert!(t.get("phi").is_some() && t.get("typo").is_some(), "{t:?}");
        // The same rule: nothing is dropped.
        let mut same = origin.clone();
        drop_switched_variants(&mut same, &origin);
        assert_eq!(same, origin);
    }

    #[test]
    fn sets_nested_and_indexed_keys() {
        let mut v = doc("[a]\nb = 1\n[[c]]\nd = 2\n[[c]]\nd = 3\n");
        set(&mut v, "a.b", toml::Value::Integer(5)).unwrap();
        set(&mut v, "c[1].d", toml::Value::Float(0.5)).unwrap();
        set(&mut v, "x.y.z", toml::Value::Boolean(true)).unwrap();
        assert_eq!(v["a"]["b"].as_integer(), Some(5));
        assert_eq!(v["c"][1]["d"].as_float(), Some(0.5));
        assert_eq!(v["c"][0]["d"].as_integer(), Some(2));
        assert_eq!(v["x"]["y"]["z"].as_bool(), Some(true));
    }

    #[test]
    fn refuses_paths_that_do_not_fit() {
        let mut v = doc("[a]\nb = 1\nc = [1]\n");
        let e = set(&mut v, "a.b.c", toml::Value::Integer(1)).unwrap_err();
        assert!(e.contains("`a.b.c`"), "{e}");
        let e = set(&mut v, "a.c[3]", toml::Value::Integer(1)).unwrap_err();
        assert!(e.contains("has 1 entries"), "{e}");
        let e = set(&mut v, "a.b[0]", toml::Value::Integer(1)).unwrap_err();
        assert!(e.contains("not an array"), "{e}");
        assert!(set(&mut v, "a..b", toml::Value::Integer(1)).is_err());
        assert!(set(&mut v, "a.c[x]", toml::Value::Integer(1)).is_err());
    }

    #[test]
    fn a_new_rule_drops_the_old_rules_parameters_unless_set() {
        let mut v = doc("[trigger]\nrule = \"static\"\nphi = 1.0\nrho = 0.5\nh_s = 0.02\n");
        drop_excluded(&mut v, &["trigger.rule", "trigger.rho"]);
        assert!(v["trigger"].get("phi").is_none());
        assert!(
            v["trigger"].get("rho").is_some(),
            "set by the campaign: kept"
        );
        assert!(v["trigger"].get("h_s").is_some(), "not a rule's parameter");
        let mut v = doc("[trigger]\nrule = \"static\"\nphi = 1.0\n");
        drop_excluded(&mut v, &["control.gain"]);
        assert!(
            v["trigger"].get("phi").is_some(),
            "rule not touched: left alone"
        );
    }

    #[test]
    fn a_new_kind_drops_the_old_kinds_keys_in_every_tagged_table() {
        let mut v = doc(
            "[attack]\nkind = \"intervals\"\nperiod_s = 2.0\nintervals = [[1.0, 2.0]]\n\
             [[channel.attacks]]\nkind = \"bernoulli\"\np_good_bad = 0.1\np_bad_good = 0.2\n\
             loss_good = 0.0\nloss_bad = 1.0\nstart_s = 0.0\nsenders = [1]\n\
             [[channel.attacks]]\nkind = \"delay\"\ndelay_s = 0.1\n\
             [platoon]\nspacing_policy = \"constant\"\ntime_headway_s = 1.0\nfollowers = 4\n\
             [topology]\npreset = \"pf\"\nadjacency = [[0.0]]\npinning = [1.0]\n",
        );
        drop_excluded(
            &mut v,
            &[
                "attack.kind",
                "channel.attacks[0].kind",
                "channel.attacks[0].loss",
                "platoon.spacing_policy",
                "topology.preset",
            ],
        );
        let keys = |t: &toml::Value| t.as_table().unwrap().keys().cloned().collect::<Vec<_>>();
        assert_eq!(
            keys(&v["attack"]),
            ["intervals", "kind"],
            "period_s is a periodic key"
        );
        assert_eq!(
            keys(&v["channel"]["attacks"][0]),
            ["kind", "senders", "start_s"],
            "the Gilbert-Elliott keys go, the keys of every kind stay"
        );
        assert_eq!(
            keys(&v["channel"]["attacks"][1]),
            ["delay_s", "kind"],
            "its kind was not set: left alone"
        );
        assert_eq!(keys(&v["platoon"]), ["followers", "spacing_policy"]);
        assert_eq!(keys(&v["topology"]), ["preset"]);
    }

    #[test]
    fn formation_replaces_initial_states() {
        let mut v =
            doc("[platoon]\ninitial_states = [[0.0, 1.0, 0.0]]\n[platoon.formation]\nseed = 3\n");
        drop_excluded(&mut v, &["platoon.formation.seed"]);
        assert!(v["platoon"].get("initial_states").is_none());
        assert!(v["platoon"].get("formation").is_some());
    }
}
