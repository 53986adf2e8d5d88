//! `platoon search`: the arguments, the signals, what is printed and the exit codes; the search
//! itself is [`platoon_app::search`].
use crate::outdir::OutDir;
use crate::Result;
use platoon_app::search::{SearchOptions, SearchOutcome};
use std::path::{Path, PathBuf};

/// Arguments of `platoon search` (the help text is on the command in main.rs).
#[derive(Debug, clap::Args)]
#[command(mut_arg("out", |a| a.help("Output directory [default: runs/<search name>]")))]
pub struct Args {
    /// The search file (TOML; campaigns/worst-dos.toml is a commented example) [default: the
    /// paper scenario under its Assumption 2, 1000 evaluations of max_spacing_error_m].
    pub search: Option<PathBuf>,
    #[command(flatten)]
    pub output: OutDir,
    #[command(flatten)]
    pub executor: crate::campaign::Executors,
    /// Override `evaluations` (runs per strategy; a quick pilot).
    #[arg(long)]
    pub evaluations: Option<usize>,
    /// Skip the PNG figures.
    #[arg(long)]
    pub no_plots: bool,
}

pub fn run(args: Args) -> Result<()> {
    let search = match &args.search {
        Some(file) => platoon_app::search::load(file, args.evaluations)?,
        None => platoon_app::search::parse("", Path::new("search.toml"), args.evaluations)?,
    };
    let executor = args.executor.build();
    let out = crate::campaign::out_dir(args.output.out.clone(), &search.name);
    let (interrupt, stop) =
        crate::campaign::stop_on_signal("stopping: no new batch starts; what is done is written")?;
    let opts = SearchOptions {
        force: args.output.force,
        plots: !args.no_plots,
    };
    let bar = crate::progress::Bar::cells();
    let outcome = platoon_app::search::run(&search, &out, &opts, &*executor, &stop, &bar)?;
    print(&search, &outcome);
    if outcome.stopped.is_some() {
        interrupt.exit(&format!(
            "interrupted: what was done is in {}",
            outcome.dir.display()
        ));
    }
    Ok(())
}

fn print(search: &platoon_app::search::Search, outcome: &SearchOutcome) {
    let harm = search.harm.name();
    let f = |h: Option<f64>| h.map_or("-".to_string(), |h| format!("{h:.2}"));
    for p in &outcome.problems {
        if let Some(why) = &p.not_run {
            println!("{}: not run ({why})", p.label);
            continue;
        }
        println!("{}: {harm}", p.label);
        for m in &p.methods {
            let best = m.best.as_ref();
            println!(
                "  {:<7} {:>9} in {:>4} runs{}: {} ({}), {:.1} s",
                m.method,
                f(best.and_then(|b| b.harm)),
                m.evaluations,
                best.map_or(String::new(), |b| format!(" (at run {})", b.evaluation)),
                best.map_or("-".into(), |b| b.text.clone()),
                best.and_then(|b| b.class)
                    .map_or("-".into(), |c| c.to_string()),
                m.wall_s
            );
        }
        if let Some(r) = &p.reference {
            println!(
                "  {:<7} {:>9} reference: {} ({})",
                "",
                f(r.harm),
                r.text,
                r.class.map_or("-".into(), |c| c.to_string())
            );
        }
    }
    println!(
        "{} in {:.1} s; outputs: {}",
        if outcome.committed { "done" } else { "stopped" },
        outcome.wall_s,
        outcome.dir.display()
    );
}
