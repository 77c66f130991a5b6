//! `standard-tasks`: the standard-tasks page from the grid's runs.
//!
//! ```sh
//! cargo run --release -p studies --bin standard-tasks -- --runs runs/standard-tasks \
//!     --page docs/results/standard-tasks.md
//! ```
//!
//! Replaces the page's `## Results` section (everything after that heading) and writes the
//! learning curves beside the page, in `standard-tasks/`; the protocol above the heading, fixed
//! before the runs, is left as it is.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::Parser;
use studies::standard_tasks::{load, render};

#[derive(Parser, Debug)]
#[command(
    name = "standard-tasks",
    about = "The standard-tasks page from the grid's runs"
)]
struct Args {
    /// The grid's folder (`python3 -m margin_safe_rl.standard_tasks run --out`).
    #[arg(long)]
    runs: PathBuf,
    /// The page whose `## Results` section is rewritten.
    #[arg(long)]
    page: PathBuf,
    /// The commit the runs were measured on (default: this checkout's HEAD).
    #[arg(long)]
    commit: Option<String>,
    /// Accept tiny runs (`run --steps`), as CI's check of the machinery does; never for the
    /// committed page.
    #[arg(long)]
    tiny: bool,
}

const HEADING: &str = "\n## Results\n";

fn main() -> ExitCode {
    match run(Args::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("standard-tasks: {e:#}");
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
    let grid = load(&args.runs, args.tiny)?;
    let commit = match args.commit {
        Some(c) => c,
        None => head()?,
    };
    let stem = args
        .page
        .file_stem()
        .context("the page has no file name")?
        .to_string_lossy()
        .into_owned();
    let (results, figures) = render(&grid, &commit, &stem);
    let dir = args.page.with_file_name(&stem);
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    for (name, svg) in figures {
        write_atomic(&dir.join(name), &svg)?;
    }
    let text = format!("{}{HEADING}\n{results}", &page[..cut]);
    write_atomic(&args.page, &text)
}

fn head() -> Result<String> {
    let out = std::process::Command::new("git")
        .args(["rev-parse", "--short", "HEAD"])
        .output()
        .context("cannot run git to name the commit (give --commit)")?;
    anyhow::ensure!(out.status.success(), "git rev-parse failed (give --commit)");
    Ok(String::from_utf8_lossy(&out.stdout).trim().to_string())
}

/// Written beside the target and renamed into place: a reader never sees half a page.
fn write_atomic(path: &std::path::Path, text: &str) -> Result<()> {
    let tmp = path.with_extension("partial");
    std::fs::write(&tmp, text).with_context(|| format!("cannot write {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("cannot write {}", path.display()))
}
