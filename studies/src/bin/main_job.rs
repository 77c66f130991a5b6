//! `main-job`: the main job's study page (docs/results/main-job.md) from its queue's folders.
//!
//! ```sh
//! cargo run --release -p studies --bin main-job -- --runs runs/main-job --save-record \
//!     --page docs/results/main-job.md --commit ae1b220 --cpu "2-vCPU AMD EPYC"
//! ```
//!
//! Replaces the page's `## Results` section (everything after that heading); the protocol
//! above it, fixed before the runs, is left as it is. Lines in the committed record
//! (`experiments/main-job/record.tsv`) are read from it, the others from `--runs`; with
//! `--save-record`, every finished line read from `--runs` is added to the record first, with
//! `--commit` and `--cpu`.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::Parser;
use studies::main_job::{load, read_record, record_row, render, today_rows};

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
    /// The finished lines kept across machines.
    #[arg(long, default_value = "experiments/main-job/record.tsv")]
    lines_record: PathBuf,
    /// Add every finished line read from `--runs` to `--lines-record` (with `--commit` and
    /// `--cpu`) before rendering.
    #[arg(long)]
    save_record: bool,
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
    let kept = read_record(&args.lines_record)?;
    let lines = load(&args.plan, &args.runs, &kept)?;
    if args.save_record {
        let new: Vec<String> = lines
            .iter()
            .filter(|l| l.origin.is_none())
            .filter_map(|l| record_row(l, &args.commit, &args.cpu))
            .collect();
        if !new.is_empty() {
            let path = &args.lines_record;
            let mut text = std::fs::read_to_string(path)
                .with_context(|| format!("cannot read {}", path.display()))?;
            if !text.is_empty() && !text.ends_with('\n') {
                text.push('\n');
            }
            for row in &new {
                text.push_str(row);
                text.push('\n');
            }
            write_whole(path, &text)?;
            eprintln!(
                "main-job: {} finished line(s) added to {}",
                new.len(),
                path.display()
            );
        }
    }
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
    write_whole(&args.page, &text)
}

/// Written beside the file and renamed into place: a reader never sees half a file.
fn write_whole(path: &std::path::Path, text: &str) -> Result<()> {
    let tmp = path.with_extension("partial");
    std::fs::write(&tmp, text).with_context(|| format!("cannot write {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("cannot write {}", path.display()))
}
