//! `main-job`: the main job's study page (docs/results/main-job.md) from its queue's folders.
//!
//! ```sh
//! cargo run --release -p studies --bin main-job -- --runs runs/main-job \
//!     --page docs/results/main-job.md --commit ae1b220 --cpu "2-vCPU AMD EPYC"
//! ```
//!
//! Replaces the page's `## Results` section (everything after that heading); the protocol
//! above it, fixed before the runs, is left as it is.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::Parser;
use studies::main_job::{load, render, today_rows};

#[derive(Parser, Debug)]
#[command(
    name = "main-job",
    about = "The main job's study page from its queue's folders"
)]
struct Args {
    /// The queue's folder (`experiments/main-job/run.sh OUT`).
    #[arg(long)]
    runs: PathBuf,
    /// The page whose `## Results` section is rewritten.
    #[arg(long)]
    page: PathBuf,
    /// The queue's plan.
    #[arg(long, default_value = "experiments/main-job/plan.txt")]
    plan: PathBuf,
    /// The margin study's records, whose A0 rows are today's single run.
    #[arg(long, default_values = ["experiments/margin/record/screen.jsonl", "experiments/margin/record/confirm.jsonl"])]
    record: Vec<PathBuf>,
    /// The commit of the binary the queue ran.
    #[arg(long)]
    commit: String,
    /// The machine, as the page names it.
    #[arg(long)]
    cpu: String,
    /// A note printed under the results' first line (what ran beside the queue, a line stopped
    /// and continued); may be given several times.
    #[arg(long)]
    note: Vec<String>,
}

const HEADING: &str = "\n## Results\n";

fn main() -> ExitCode {
    match run(Args::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("main-job: {e:#}");
            ExitCode::from(2)
        }
    }
}

fn run(args: Args) -> Result<()> {
    let page = std::fs::read_to_string(&args.page)
        .with_context(|| format!("cannot read {}", args.page.display()))?;
    let cut = page
        .find(HEADING)
        .with_context(|| format!("{} has no \"## Results\" heading", args.page.display()))?;
    let lines = load(&args.plan, &args.runs)?;
    let records: Vec<&std::path::Path> = args.record.iter().map(PathBuf::as_path).collect();
    let today = today_rows(&records)?;
    let mut results = render(&lines, &today, &args.commit, &args.cpu);
    if !args.note.is_empty() {
        // After the first paragraph (the commit, the machine and the lines in).
        let at = results.find("\n\n").map_or(results.len(), |i| i + 2);
        let notes: String = args.note.iter().map(|n| format!("{n}\n\n")).collect();
        results.insert_str(at, &notes);
    }
    let text = format!("{}{HEADING}\n{results}", &page[..cut]);
    // Written beside the page and renamed into place: a reader never sees half a page.
    let tmp = args.page.with_extension("partial");
    std::fs::write(&tmp, text).with_context(|| format!("cannot write {}", tmp.display()))?;
    std::fs::rename(&tmp, &args.page)
        .with_context(|| format!("cannot write {}", args.page.display()))
}
