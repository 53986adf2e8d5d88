//! Exact ground truth for every delivery (issue 51): the per-message dataset (`detections.csv`)
//! has a row for every delivery the injector made, to every receiver (the leader included,
//! also those the receivers refused, with what refused them), and its labels are what the
//! injector did to each delivery, by the injector's own log: the built-in channel's
//! `channel.csv` for the catalogue's maneuver attacks, and a Python plug-in's log
//! (`bridge/examples/maneuver_truth.py`) for one that forges, alters and replays maneuver
//! messages.
use crate::common::{json, ok, platoon, repo};
use std::collections::BTreeMap;
use std::path::Path;
use std::rc::Rc;

/// A CSV file as rows of named columns. A row keeps its record (one buffer) and reads a field
/// by its column's name: the datasets have hundreds of thousands of rows of 26 columns, and a
/// map of owned strings per row cost the test most of its time.
fn table(path: &Path) -> Vec<Row> {
    let mut r = csv::Reader::from_path(path).unwrap();
    let columns: Rc<[String]> = r.headers().unwrap().iter().map(String::from).collect();
    r.records()
        .map(|x| Row {
            columns: Rc::clone(&columns),
            record: x.unwrap(),
        })
        .collect()
}

/// A row of [`table`]: `row["label"]` is its `label` field.
struct Row {
    columns: Rc<[String]>,
    record: csv::StringRecord,
}

impl std::ops::Index<&str> for Row {
    type Output = str;

    fn index(&self, column: &str) -> &str {
        let i = self
            .columns
            .iter()
            .position(|c| c == column)
            .unwrap_or_else(|| panic!("no column {column} in {:?}", self.columns));
        &self.record[i]
    }
}

/// The row as its columns' names and values (what a failing assertion prints).
impl std::fmt::Debug for Row {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_map()
            .entries(self.columns.iter().zip(self.record.iter()))
            .finish()
    }
}

/// A delivery's key: step, receiver, sender, seq.
type Key = (u64, u16, u16, u32);

fn key(r: &Row) -> Key {
    let n = |c: &str| r[c].parse::<u64>().unwrap();
    (
        n("step"),
        n("receiver") as u16,
        n("sender") as u16,
        n("seq") as u32,
    )
}

/// Every delivery has its row: the dataset's rows are the wire's deliveries.
fn one_row_per_delivery(run: &Path, rows: &[Row]) {
    let w = &json(&run.join("summary.json"))["wire"]["totals"];
    let delivered: u64 = ["delivered_as_sent", "altered", "injected"]
        .iter()
        .map(|c| w[c].as_u64().unwrap())
        .sum();
    assert_eq!(rows.len() as u64, delivered, "{}", run.display());
}

/// The catalogue's maneuver attacks, each on the config the docs run it on, with the
/// followers' plausibility checks on (the dataset's condition).
const CATALOGUE: [(&str, &str, &str); 10] = [
    (
        "fake join request",
        "configs/join.toml",
        "kind = \"forge_maneuver\"\nmessage = \"join_request\"\nsenders = [4]\nreceivers = [0]\n\
         start_s = 3.0\nend_s = 3.2\n",
    ),
    (
        "lying joiner",
        "configs/join.toml",
        "kind = \"forge_maneuver\"\nmessage = \"in_position\"\nsenders = [4]\nreceivers = [0]\n\
         start_s = 6.0\nend_s = 6.2\n",
    ),
    (
        "forged leave",
        "configs/leave.toml",
        "kind = \"forge_maneuver\"\nmessage = \"leave_notice\"\nsenders = [2]\nreceivers = [0]\n\
         start_s = 10.0\nend_s = 10.2\n",
    ),
    (
        "forged leave to everyone",
        "configs/leave.toml",
        "kind = \"forge_maneuver\"\nmessage = \"leave_notice\"\nsenders = [2]\n\
         start_s = 10.0\nend_s = 10.2\n",
    ),
    (
        "forged split",
        "configs/split.toml",
        "kind = \"forge_maneuver\"\nmessage = \"split_notice\"\nsenders = [2]\nreceivers = [0]\n\
         start_s = 10.0\nend_s = 10.2\n",
    ),
    (
        "forged merge report",
        "configs/merge.toml",
        "kind = \"forge_maneuver\"\nmessage = \"in_position\"\nsenders = [3]\nreceivers = [0]\n\
         start_s = 6.0\nend_s = 6.2\n",
    ),
    (
        "forged head in a middle join",
        "configs/join-middle.toml",
        "kind = \"forged_head\"\nsenders = [1]\ninsider = true\nstart_s = 4.0\nend_s = 40.0\n",
    ),
    (
        "jammed move-in",
        "configs/join-middle.toml",
        "kind = \"jam_maneuvers\"\nmessages = [\"move_in\"]\n",
    ),
    (
        "jammed merge updates",
        "configs/merge.toml",
        "kind = \"jam_maneuvers\"\nmessages = [\"update\"]\nstart_s = 5.0\n",
    ),
    (
        "replayed leader",
        "configs/join.toml",
        "kind = \"replay\"\nlag_s = 8.0\nsenders = [0]\nstart_s = 10.0\nend_s = 10.5\n",
    ),
];

/// The label the built-in channel's log gives a delivery: what it did to it (no line: delivered
/// as sent), and the labels that fit (a replayed packet is `replayed` to a receiver that got it
/// before, `delayed` to one that never did, its original having been replaced).
fn expected(actions: &[String]) -> &'static [&'static str] {
    if actions.iter().any(|a| a == "altered") {
        &["altered"]
    } else if actions.iter().any(|a| a == "replayed") {
        &["replayed", "delayed"]
    } else if actions.iter().any(|a| a == "delivered_late") {
        &["delayed"]
    } else {
        &["genuine"]
    }
}

/// For every catalogue maneuver attack (in process; the transports agree bit for bit on the
/// dataset, tests/cosim.rs): a row per delivery, each labelled as the channel's log says, the
/// leader's copies and the refused deliveries included, and every rewritten maneuver message
/// `altered` in its `maneuver` field.
#[test]
fn the_catalogues_maneuver_attacks_are_labelled_as_the_channel_logged_them() {
    let tmp = tempfile::tempdir().unwrap();
    for (n, (name, config, attack)) in CATALOGUE.iter().enumerate() {
        let mut text = std::fs::read_to_string(repo().join(config)).unwrap();
        if *name == "lying joiner" {
            // The leader's check too: its refusals have rows.
            text = text.replace("[maneuvers]\n", "[maneuvers]\ncheck_reports = true\n");
        }
        text.push_str(&format!(
            "\n[[channel.attacks]]\n{attack}\n[detection.plausibility]\n"
        ));
        let c = tmp.path().join(format!("{n}.toml"));
        std::fs::write(&c, text).unwrap();
        let out = format!("r{n}");
        let c = c.to_str().unwrap();
        let args = [
            "run",
            c,
            "--out",
            &out,
            "--no-plots",
            "--transport",
            "inproc",
        ];
        ok(&platoon(&args, tmp.path()));
        let run = tmp.path().join(&out);
        let rows = table(&run.join("detections.csv"));
        one_row_per_delivery(&run, &rows);
        let mut log: BTreeMap<Key, Vec<String>> = BTreeMap::new();
        for e in table(&run.join("channel.csv")) {
            log.entry(key(&e))
                .or_default()
                .push(e["action"].to_string());
        }
        let mut by_label = BTreeMap::<&str, u64>::new();
        let mut to_leader = 0;
        for r in &rows {
            let actions = log.get(&key(r)).cloned().unwrap_or_default();
            let label = &r["label"];
            assert!(
                expected(&actions).contains(&label),
                "{name}: {r:?} labelled {label}, the channel logged {actions:?}"
            );
            if label == "altered" && attack.contains("forge_maneuver") {
                assert_eq!(&r["fields"], "maneuver", "{name}: {r:?}");
            }
            if label == "altered" && attack.contains("forged_head") {
                assert_eq!(&r["fields"], "head", "{name}: {r:?}");
            }
            *by_label
                .entry(match label {
                    "genuine" => "genuine",
                    _ => "attacked",
                })
                .or_default() += 1;
            to_leader += u64::from(&r["receiver"] == "0");
        }
        assert!(to_leader > 0, "{name}: the leader's receipts have rows");
        if ["forge_maneuver", "forged_head", "replay"]
            .iter()
            .any(|k| attack.contains(k))
        {
            assert!(by_label.get("attacked").is_some_and(|&a| a > 0), "{name}");
            // What the channel altered or replayed and delivered has its row.
            let rows_by_key: BTreeMap<Key, &Row> = rows.iter().map(|r| (key(r), r)).collect();
            let delivered_attacks = log
                .iter()
                .filter(|(_, a)| a.iter().any(|a| a == "altered" || a == "replayed"))
                .filter(|(k, _)| rows_by_key.contains_key(k))
                .count() as u64;
            assert_eq!(by_label["attacked"], delivered_attacks, "{name}");
        }
        if *name == "replayed leader" {
            // The followers' sequence filter refuses the replays; they still have rows.
            assert!(
                rows.iter()
                    .any(|r| &r["refused_by"] == "stale_seq" && &r["label"] == "replayed"),
                "{name}"
            );
        }
        if *name == "fake join request" {
            // The joiner's own requests, numbered below the forged one, reach the leader and
            // its machine drops them as old: genuine, and said so.
            assert!(
                rows.iter().any(|r| &r["receiver"] == "0"
                    && &r["maneuver"] == "join_request"
                    && &r["label"] == "genuine"
                    && &r["refused_by"] == "maneuver_seq"),
                "{name}"
            );
        }
        if *name == "lying joiner" {
            assert!(
                rows.iter().any(|r| &r["receiver"] == "0"
                    && &r["refused_by"] == "check_reports"
                    && &r["label"] == "altered"),
                "{name}: the leader's check refused the forged reports"
            );
        }
        if *name == "forged leave to everyone" {
            // The followers' copies too.
            assert!(
                rows.iter().any(|r| &r["receiver"] != "0"
                    && &r["maneuver"] == "leave_notice"
                    && &r["label"] == "altered"),
                "{name}"
            );
        }
    }
}

/// A Python plug-in that forges a leave notice with the victim's next sequence number (to the
/// leader, which ejects the victim, and to the followers, which refuse it as stale), alters a
/// beacon into an in-position report and replays the leader's formation updates 8 s later
/// (refused as stale): over iceoryx2, the dataset's labels are the plug-in's own log, delivery
/// for delivery (the leader's copies and the refused ones included), and the victim's genuine
/// packet with the number the forger used first is `genuine`.
#[test]
fn a_python_plugins_forgeries_alterations_and_replays_are_labelled_as_its_log_says() {
    let tmp = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(repo().join("configs/leave.toml")).unwrap()
        + "\n[detection.plausibility]\n";
    let c = tmp.path().join("leave-detected.toml");
    std::fs::write(&c, text).unwrap();
    let log = tmp.path().join("injector.csv");
    let python = repo().join("bridge/.venv/bin/python");
    let plugin = repo().join("bridge/examples/maneuver_truth.py");
    let injector = format!(
        "{} {} {} 2 10",
        python.display(),
        plugin.display(),
        log.display()
    );
    let c = c.to_str().unwrap();
    let args = [
        "run",
        c,
        "--out",
        "r",
        "--no-plots",
        "--injector",
        &injector,
    ];
    ok(&platoon(&args, tmp.path()));
    let run = tmp.path().join("r");
    let rows = table(&run.join("detections.csv"));
    one_row_per_delivery(&run, &rows);
    let did = table(&log);
    assert_eq!(rows.len(), did.len(), "a row per delivery the plug-in made");
    let label_of = |action: &str| match action {
        "pass" => "genuine",
        "forge" => "forged",
        "alter" => "altered",
        "replay" => "replayed",
        other => panic!("action {other}"),
    };
    // Both in delivery order, step by step.
    let mut counts = BTreeMap::<String, u64>::new();
    for (r, d) in rows.iter().zip(&did) {
        assert_eq!(key(r), key(d), "the same delivery");
        assert_eq!(
            &r["label"],
            label_of(&d["action"]),
            "{r:?} was {}",
            &d["action"]
        );
        *counts.entry(d["action"].to_string()).or_default() += 1;
        match &d["action"] {
            "alter" => assert_eq!(&r["fields"], "maneuver"),
            "forge" => assert_eq!(&r["maneuver"], "leave_notice"),
            _ => {}
        }
    }
    assert!(
        counts["forge"] >= 2 && counts["alter"] == 1 && counts["replay"] > 0,
        "{counts:?}"
    );
    // The forged notice reached the leader (a row of receiver 0, accepted: it ejects the
    // victim), and the followers refused their copies as stale.
    let forged: Vec<_> = rows.iter().filter(|r| &r["label"] == "forged").collect();
    assert!(forged
        .iter()
        .any(|r| &r["receiver"] == "0" && r["refused_by"].is_empty()));
    assert!(forged
        .iter()
        .filter(|r| &r["receiver"] != "0")
        .all(|r| &r["refused_by"] == "stale_seq"));
    assert!(rows
        .iter()
        .filter(|r| &r["label"] == "replayed")
        .all(|r| &r["refused_by"] == "stale_seq"));
    // The victim's own packet with the number the forger used first: genuine, to everyone.
    let used = &forged[0]["seq"];
    let own: Vec<_> = rows
        .iter()
        .filter(|r| &r["sender"] == "2" && &r["seq"] == used && &r["label"] != "forged")
        .collect();
    assert!(!own.is_empty(), "the victim sent its next packet");
    assert!(own.iter().all(|r| &r["label"] == "genuine"), "{own:?}");
    // Maneuver rewrites count as altered on the wire and in the summary.
    let s = json(&run.join("summary.json"));
    assert_eq!(s["wire"]["totals"]["altered"], 1, "{}", s["wire"]);
}

/// The dataset of catalogue attacks whose deliveries the receivers refuse (a replay of the
/// leader's packets, refused as stale), that forge a leave notice to the leader, or a join
/// request whose number makes the leader's machine drop the joiner's own as old, is the same
/// bytes over iceoryx2 as in process: the refusals' reasons cross the wire.
#[test]
fn refused_and_leader_rows_are_the_same_bytes_on_both_transports() {
    let tmp = tempfile::tempdir().unwrap();
    let leave = "\n[[channel.attacks]]\nkind = \"replay\"\nlag_s = 8.0\nsenders = [0]\n\
                 start_s = 10.0\nend_s = 10.5\n\n[[channel.attacks]]\n\
                 kind = \"forge_maneuver\"\nmessage = \"leave_notice\"\nsenders = [2]\n\
                 receivers = [0]\nstart_s = 12.0\nend_s = 12.2\n";
    let join = format!("\n[[channel.attacks]]\n{}", CATALOGUE[0].2);
    for (n, (config, attacks, expect)) in [
        ("configs/leave.toml", leave, "stale_seq"),
        ("configs/join.toml", join.as_str(), "maneuver_seq"),
    ]
    .into_iter()
    .enumerate()
    {
        let text = std::fs::read_to_string(repo().join(config)).unwrap()
            + attacks
            + "\n[detection.plausibility]\n";
        let c = tmp.path().join(format!("{n}.toml"));
        std::fs::write(&c, text).unwrap();
        let c = c.to_str().unwrap();
        for transport in ["iceoryx2", "inproc"] {
            let out = format!("{n}-{transport}");
            let args = [
                "run",
                c,
                "--out",
                &out,
                "--no-plots",
                "--transport",
                transport,
            ];
            ok(&platoon(&args, tmp.path()));
        }
        let read = |t: &str| std::fs::read(tmp.path().join(format!("{n}-{t}/detections.csv")));
        assert!(
            read("iceoryx2").unwrap() == read("inproc").unwrap(),
            "{config}: detections.csv differs"
        );
        let rows = table(&tmp.path().join(format!("{n}-iceoryx2/detections.csv")));
        assert!(rows.iter().any(|r| &r["refused_by"] == expect), "{config}");
        assert!(
            rows.iter()
                .any(|r| &r["receiver"] == "0" && &r["label"] == "altered"),
            "{config}"
        );
    }
}
