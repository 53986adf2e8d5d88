//! The co-simulated run: the processes over iceoryx2, what they measured, and the run's
//! `run.json`.
use super::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// `timing.json`'s `peak_rss_mib`: the peak resident memory of `platoon run` itself (which
/// records and writes the outputs) and of each node process.
pub(super) fn peak_rss_mib(nodes: &[(&str, u64)]) -> serde_json::Value {
    let mib = |kib: u64| (kib as f64 / 1024.0 * 10.0).round() / 10.0;
    let mut m = serde_json::Map::new();
    if let Some(own) = platoon_runtime::peak_rss_kib(None) {
        m.insert("platoon_run".into(), mib(own).into());
    }
    for (node, kib) in nodes {
        m.insert((*node).into(), mib(*kib).into());
    }
    m.into()
}

/// The warning about samples that repeated a step, if any did.
fn duplicates_warning(d: &platoon_runtime::DuplicateSamples) -> Option<String> {
    let total = d.total();
    (total > 0).then(|| {
        let (samples, they) = if total == 1 {
            ("sample", "it was")
        } else {
            ("samples", "they were")
        };
        format!(
            "warning: {total} {samples} repeated a step already published (states {}, tx {}, rx {}, commands {}); {they} dropped, but duplicates slow the run (timing.json counts them)",
            d.states, d.tx, d.rx, d.commands
        )
    })
}

/// Runs the scenario across processes over iceoryx2. A failed run still returns what it
/// recorded, with the summary marked incomplete, and the error.
pub(super) fn cosimulate(
    scenario: &Scenario,
    output: &platoon_config::OutputConfig,
    dir: &RunDir,
    opts: &RunOptions,
    plant: Option<crate::sumo::SumoPlant>,
    stop: &Stop,
    progress: &dyn Progress,
) -> Result<(Plotted, Summary, Option<platoon_runtime::CosimError>)> {
    let logs = dir.path("logs");
    std::fs::create_dir_all(&logs).with_context(|| format!("creating {}", logs.display()))?;
    let (injector, controller, after) = programs(opts);
    let plant_kind = match plant {
        Some(_) => PlantKind::Sumo,
        None => PlantKind::Native,
    };
    // Traffic that can touch the platoon: the trajectories say what the radars saw.
    let radar = !scenario.cut_ins.is_empty() || plant.as_ref().is_some_and(|p| p.near_platoon);
    let (plant, env, traffic) = match plant {
        Some(p) => (p.program, p.env, p.traffic),
        None => (platoon_runtime::Program::Builtin, Vec::new(), 0),
    };
    // A plug-in imports the Python SDK from wherever it is: the bridge goes on its PYTHONPATH
    // (if there is no bridge, a Python plug-in's import error is quoted when it dies).
    let plugins = [&injector, &controller, &plant]
        .into_iter()
        .any(|p| *p != platoon_runtime::Program::Builtin);
    let python_path = plugins.then(|| crate::sumo::bridge_dir().ok()).flatten();
    let run_id = platoon_runtime::new_run_id();
    write_run_json(dir, &run_id, scenario, opts.observers)?;
    progress.message(&format!(
        "run id {run_id}; observers: {} (docs/observer-contract.md)",
        dir.path("run.json").display()
    ));
    let facts = platoon_runtime::plugin::RunFacts::of(&run_id, scenario, plant_kind);
    dir.write(
        platoon_runtime::plugin::RUN_FACTS_FILE,
        &serde_json::to_vec_pretty(&facts)?,
    )?;
    let exe = match &opts.node_program {
        Some(p) => p.clone(),
        None => crate::platoon_program()?,
    };
    // The orchestrator stops on `halt`: the caller's stop, or physics that left the model.
    let halt = Arc::new(AtomicBool::new(false));
    let rt = platoon_runtime::Options {
        run_id,
        exe,
        config: std::path::absolute(dir.path("config.toml"))
            .context("resolving the run directory")?,
        facts: Some(
            std::path::absolute(dir.path(platoon_runtime::plugin::RUN_FACTS_FILE))
                .context("resolving the run directory")?,
        ),
        // With jammers as transmitters the links' outages are read from it, wanted or not.
        channel_log: ((injector == platoon_runtime::Program::Builtin || after)
            && (output.writes(platoon_config::OutputFile::Channel)
                || !scenario.jammers.is_empty()))
        .then(|| dir.path("channel.csv")),
        injector,
        controller,
        plant,
        traffic,
        radar,
        env,
        log_dir: Some(logs),
        python_path,
        step_timeout: opts.step_timeout,
        ready_timeout: opts.ready_timeout,
        stop: Some(halt.clone()),
        observers: opts.observers,
        cpus: opts.cpus.clone(),
        channel_first: after,
    };
    let steps = scenario.steps + 1;
    progress.start("co-simulating", steps);
    let mut files = RunFiles::create(scenario, output, dir, false, radar)?;
    let mut metrics = platoon_sim::FleetMetrics::new(scenario);
    let mut failure: Option<RunError> = None;
    let names = scenario.control.detection.names();
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    let mut check = platoon_sim::model_check::ModelCheck::new(scenario);
    let mut left_model = None;
    let done = Arc::new(AtomicBool::new(false));
    let relay = relay_stop(stop.flag.clone(), halt.clone(), done.clone());
    let result = platoon_runtime::orchestrate(&rt, scenario, |rows, wire, scored| {
        if left_model.is_some() {
            // The run stops at the step that left the model, as in process.
            return;
        }
        if failure.is_none() {
            let written = if scored.is_empty() {
                Ok(())
            } else {
                files.detections(&names, scored)
            };
            if let Err(e) = written.and_then(|()| files.step(rows, wire)) {
                failure = Some(e.into());
            }
        }
        metrics.push_wire(wire);
        metrics.push(rows);
        left_model = check.push(rows);
        if left_model.is_some() {
            halt.store(true, Ordering::SeqCst);
        }
        if rows[0].step.is_multiple_of(1000) {
            progress.at(rows[0].step);
        }
    });
    done.store(true, Ordering::SeqCst);
    relay.join().ok();
    progress.finish();
    if let Some(e) = failure {
        return Err(e);
    }
    files.finish()?;
    let rows = files.into_plotted();
    match result {
        Ok(outcome) => {
            link_outages(scenario, output, dir, &mut metrics)?;
            write_timing(dir, &outcome, progress)?;
            let mut summary = metrics.finish(outcome.rejected);
            summary.channel = outcome.radio;
            summary.detection = outcome.detection;
            summary.security = (scenario.control.security)
                .as_ref()
                .map(|p| platoon_sim::SecuritySummary::of(p, &outcome.seals, metrics.revoked()));
            summary.judge_revocations();
            channel_log_format(scenario, output, dir)?;
            Ok((rows, summary, None))
        }
        Err(e) => {
            let mut summary = metrics.finish(Default::default());
            summary.complete = false;
            if let (Some(exit), platoon_runtime::CosimError::Interrupted { .. }) = (&left_model, &e)
            {
                summary.error = Some(exit.to_string());
                return Ok((rows, summary, None));
            }
            summary.error = Some(OtherError::report(&e));
            Ok((rows, summary, Some(e)))
        }
    }
}

/// The injector and controller processes `opts` asks for (a shell command, else the built-in
/// node), and whether the injector runs after the config's attacks.
fn programs(opts: &RunOptions) -> (platoon_runtime::Program, platoon_runtime::Program, bool) {
    let injector = match &opts.injector {
        Some(i) => platoon_runtime::Program::Shell(i.command.clone()),
        None => platoon_runtime::Program::Builtin,
    };
    let controller = match &opts.controller {
        Some(command) => platoon_runtime::Program::Shell(command.clone()),
        None => platoon_runtime::Program::Builtin,
    };
    let after = opts
        .injector
        .as_ref()
        .is_some_and(|i| i.mode == InjectorMode::After);
    (injector, controller, after)
}

/// timing.json: the run's stage timing, the samples a node published twice and each node's
/// peak memory; a warning through `progress` when samples came twice.
fn write_timing(
    dir: &RunDir,
    outcome: &platoon_runtime::Outcome,
    progress: &dyn Progress,
) -> Result<()> {
    let mut timing = serde_json::to_value(&outcome.timing)?;
    timing["duplicate_samples"] = serde_json::to_value(outcome.duplicates)?;
    timing["peak_rss_mib"] = peak_rss_mib(&outcome.peak_rss_kib);
    let json = serde_json::to_string_pretty(&timing)? + "\n";
    dir.write("timing.json", json.as_bytes())?;
    if let Some(warning) = duplicates_warning(&outcome.duplicates) {
        progress.message(&warning);
    }
    Ok(())
}

/// Sets `halt` once `stop` is set, until `done`: the caller's stop reaches the orchestrator
/// within 20 ms.
fn relay_stop(
    stop: Arc<AtomicBool>,
    halt: Arc<AtomicBool>,
    done: Arc<AtomicBool>,
) -> std::thread::JoinHandle<()> {
    std::thread::spawn(move || {
        while !done.load(Ordering::SeqCst) {
            if stop.load(Ordering::SeqCst) {
                halt.store(true, Ordering::SeqCst);
            }
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
    })
}

/// With jammers as transmitters: the links' outages, from the channel log the injector node
/// wrote, step by step as the in-process run reads it; the log is removed if the output does not
/// want it.
fn link_outages(
    scenario: &Scenario,
    output: &platoon_config::OutputConfig,
    dir: &RunDir,
    metrics: &mut platoon_sim::FleetMetrics,
) -> Result<()> {
    let path = dir.path("channel.csv");
    if scenario.jammers.is_empty() || !path.exists() {
        return Ok(());
    }
    let mut reader =
        csv::Reader::from_path(&path).with_context(|| format!("reading {}", path.display()))?;
    let mut step: Vec<ChannelEvent> = Vec::new();
    for row in reader.deserialize::<ChannelEvent>() {
        let e = row.with_context(|| format!("reading {}", path.display()))?;
        if step.first().is_some_and(|f| f.step != e.step) {
            step.sort_by_key(|e| e.platoon);
            metrics.push_channel(&step);
            step.clear();
        }
        step.push(e);
    }
    step.sort_by_key(|e| e.platoon);
    metrics.push_channel(&step);
    if !output.writes(platoon_config::OutputFile::Channel) {
        std::fs::remove_file(&path).with_context(|| format!("removing {}", path.display()))?;
    }
    Ok(())
}

/// The injector node writes its channel log as CSV; with Parquet output it is converted, row
/// by row (memory stays flat), and the CSV removed.
fn channel_log_format(
    scenario: &Scenario,
    output: &platoon_config::OutputConfig,
    dir: &RunDir,
) -> Result<()> {
    let format = Format::of(output, scenario);
    let csv_path = dir.path("channel.csv");
    if format != Format::Parquet || !csv_path.exists() {
        return Ok(());
    }
    let mut table = Table::create(dir, "channel", format, true)?;
    let mut reader = csv::Reader::from_path(&csv_path)
        .with_context(|| format!("reading {}", csv_path.display()))?;
    for row in reader.deserialize::<ChannelEvent>() {
        table.write(row.with_context(|| format!("reading {}", csv_path.display()))?)?;
    }
    table.finish()?;
    std::fs::remove_file(&csv_path).with_context(|| format!("removing {}", csv_path.display()))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_duplicates_warning_counts_in_words() {
        let mut d = platoon_runtime::DuplicateSamples::default();
        assert_eq!(duplicates_warning(&d), None);
        d.rx = 1;
        let one = duplicates_warning(&d).unwrap();
        assert!(
            one.starts_with("warning: 1 sample repeated a step"),
            "{one}"
        );
        assert!(
            one.contains("rx 1") && one.contains("it was dropped"),
            "{one}"
        );
        d.tx = 2;
        let three = duplicates_warning(&d).unwrap();
        assert!(
            three.starts_with("warning: 3 samples repeated a step"),
            "{three}"
        );
        assert!(three.contains("they were dropped"), "{three}");
    }
}
