//! `restat`: a results page's section "Bootstrap intervals and exact tests", rebuilt from the
//! page's per-seed rows (docs/design.md §7; the pages and their rows: `studies::restat`).
//!
//! ```sh
//! cargo run --release -p studies --bin restat -- --commit COMMIT            # every page
//! cargo run --release -p studies --bin restat -- dcp-vs-ddpg --commit COMMIT
//! cargo run --release -p studies --bin restat -- --check                    # as the tests do
//! ```
//!
//! `--commit COMMIT` names the commit whose code is running (the section says it); `--check`
//! rebuilds each section with the commit it names and fails if the page differs, or if a row of
//! its per-seed file is not on the page. Run from the repository root.

use std::path::Path;
use std::process::ExitCode;

use anyhow::{bail, Context, Result};
use studies::restat::{
    check_rows, check_section, commit_of, page, read_tables, section, splice, Page, PAGES,
};

const USAGE: &str = "usage: restat [PAGE...] (--commit COMMIT | --check)";

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("restat: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run() -> Result<()> {
    let (mut names, mut commit, mut check) = (Vec::new(), None, false);
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--commit" => commit = Some(args.next().context(USAGE)?),
            "--check" => check = true,
            flag if flag.starts_with('-') => bail!("unknown flag {flag}\n{USAGE}"),
            name => names.push(page(name)?),
        }
    }
    if names.is_empty() {
        names = PAGES.iter().collect();
    }
    let root = Path::new(".");
    match (check, commit) {
        (true, None) => names.iter().try_for_each(|p| check_page(root, p)),
        (false, Some(c)) => names.iter().try_for_each(|p| write_page(root, p, &c)),
        _ => bail!("{USAGE}"),
    }
}

fn write_page(root: &Path, page: &Page, commit: &str) -> Result<()> {
    let path = root.join(page.path());
    let text = std::fs::read_to_string(&path).with_context(|| page.path())?;
    let tables = read_tables(root, page)?;
    let rows_page =
        std::fs::read_to_string(root.join(page.rows_page())).with_context(|| page.rows_page())?;
    check_rows(page, &tables, &rows_page)?;
    let new = splice(&text, &section(page, &tables, commit)?).with_context(|| page.path())?;
    std::fs::write(&path, &new).with_context(|| page.path())?;
    println!("{}: section rebuilt at commit {commit}", page.path());
    Ok(())
}

fn check_page(root: &Path, page: &Page) -> Result<()> {
    let text = std::fs::read_to_string(root.join(page.path())).with_context(|| page.path())?;
    let commit = commit_of(&text)
        .with_context(|| format!("{}: its section names no commit", page.path()))?;
    let tables = read_tables(root, page)?;
    let rows_page =
        std::fs::read_to_string(root.join(page.rows_page())).with_context(|| page.rows_page())?;
    check_rows(page, &tables, &rows_page)?;
    check_section(page, &text, &section(page, &tables, &commit)?)?;
    println!("{}: up to date", page.path());
    Ok(())
}
