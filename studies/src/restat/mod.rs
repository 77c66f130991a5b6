//! Results pages restated by the statistics of docs/design.md §7: from each page's per-seed rows
//! (committed beside the study as a tab-separated file, [`per_seed`]), a section of the page
//! with each cell's mean and its percentile bootstrap interval, counts of runs with their exact
//! intervals, and every verdict the page states judged twice: by the page's own rule (labelled
//! pre-registered where it was fixed before the runs) and by an exact test, each with its
//! sensitivity and its power.
//!
//! Why a program and not an edit: the numbers on a page come from a command a reader can run
//! again; `restat --check` (run by the studies' tests) fails when a page's section is not what
//! its rows and this code give, or when a row of the file is not on the page.
//!
//! The section is the page's `## Bootstrap intervals and exact tests`, up to the next `## `
//! heading; `restat` replaces it and leaves the rest of the page alone. A new page gets the
//! heading by hand, where the section belongs.

pub mod badminton_teams;
pub mod compare_step;
pub mod dcp_variants;
pub mod dcp_vs_ddpg;
pub mod four_agents;
pub mod learning_check;
pub mod margin_study;
pub mod per_seed;
pub mod quantisation_cost;
pub mod text;

use anyhow::{bail, ensure, Context, Result};
use host_trainer::stats::{REPS, SEED};

use per_seed::PerSeed;

/// The heading of the section `restat` writes.
pub const HEADING: &str = "## Bootstrap intervals and exact tests";

/// A page `restat` rebuilds.
pub struct Page {
    /// Its name on the command line, and its file's stem.
    pub name: &'static str,
    /// The per-seed files it reads, from the repository root.
    pub tables: &'static [&'static str],
    /// The page that shows the files' rows, where not the page itself.
    pub rows_on: Option<&'static str>,
    /// The section's body from the tables.
    pub build: fn(&[PerSeed]) -> Result<String>,
    /// Checks that the rows of the tables are on the page that shows them (its name and
    /// text): [`lines_on_page`] where each row is a table line of that page.
    pub rows_shown: fn(&[PerSeed], &str, &str) -> Result<()>,
}

impl Page {
    /// The page's path from the repository root.
    pub fn path(&self) -> String {
        format!("docs/results/{}.md", self.name)
    }

    /// The page whose table lines must hold every row of the files.
    pub fn rows_page(&self) -> String {
        self.rows_on.map_or_else(|| self.path(), str::to_string)
    }
}

/// Every page `restat` rebuilds.
pub const PAGES: [Page; 8] = [
    dcp_vs_ddpg::PAGE,
    four_agents::PAGE,
    dcp_variants::PAGE,
    badminton_teams::PAGE,
    quantisation_cost::PAGE,
    compare_step::PAGE,
    learning_check::PAGE,
    margin_study::PAGE,
];

/// The page called `name`.
pub fn page(name: &str) -> Result<&'static Page> {
    PAGES.iter().find(|p| p.name == name).with_context(|| {
        let names: Vec<&str> = PAGES.iter().map(|p| p.name).collect();
        format!("no page {name:?} (pages: {})", names.join(", "))
    })
}

/// What every section says of its statistics, after the line naming its command.
fn method() -> String {
    format!(
        "Means are over the seeds as this page prints them (rounded), each with its 95 % \
         percentile bootstrap interval ({} resamples of the seeds, seed {SEED}): it stays \
         within the values seen, and \"(all 5 equal)\" marks seeds that all gave one value. \
         Over five seeds it is narrow (it holds the mean of normal values about 83 % of the \
         time, not 95 %): it shows the seeds' spread, and the tests decide. A count of runs has \
         the exact Clopper–Pearson 95 % interval of its rate. Each verdict the page states is \
         judged by the page's rule, labelled pre-registered where the protocol fixed it before \
         the runs, and by an exact two-sided test at α = 0.05 (the sign-flip permutation test \
         of differences paired by seed; McNemar's exact test of paired pass/fail outcomes); \
         each with its sensitivity (the fewest runs whose change flips it: a run changed to the \
         lowest or highest value of the arm it is compared with, a pass/fail outcome flipped, \
         up to three runs at once) and each comparison with its power (the normal \
         approximation of Colas et al., 2018, at the observed effect and spread) and the pairs \
         that power 0.8 needs. Why these: [design.md \
         §7](../design.md#7-how-results-are-reported).\n",
        text::thousands(REPS)
    )
}

/// The section for `page` from `tables`, naming `commit` as the code that built it.
pub fn section(page: &Page, tables: &[PerSeed], commit: &str) -> Result<String> {
    let files: Vec<String> = page.tables.iter().map(|t| format!("`{t}`")).collect();
    let body = (page.build)(tables)?;
    Ok(format!(
        "{HEADING}\n\nRebuilt by `cargo run --release -p studies --bin restat -- {} --commit \
         {commit}` at commit {commit}, from the per-seed rows of this page as committed in {}. \
         {}\n{body}",
        page.name,
        files.join(" and "),
        method()
    ))
}

/// The commit the section of `text` names as the code that built it.
pub fn commit_of(text: &str) -> Option<String> {
    let (_, after) = text.split_once(HEADING)?;
    let (_, rest) = after.split_once(" --commit ")?;
    let commit: String = rest.chars().take_while(|c| c.is_ascii_hexdigit()).collect();
    (!commit.is_empty()).then_some(commit)
}

/// `text` with its section (from [`HEADING`] to the next `## ` heading) replaced by `section`.
///
/// ```
/// use studies::restat::{splice, HEADING};
/// let page = format!("# P\n\n{HEADING}\n\nold\n\n## Next\n\nkept\n");
/// let new = splice(&page, &format!("{HEADING}\n\nnew\n")).unwrap();
/// assert_eq!(new, format!("# P\n\n{HEADING}\n\nnew\n\n## Next\n\nkept\n"));
/// assert!(splice("# P\n", "x").is_err());
/// ```
pub fn splice(text: &str, section: &str) -> Result<String> {
    let start = text
        .match_indices(HEADING)
        .map(|(i, _)| i)
        .find(|&i| i == 0 || text[..i].ends_with('\n'))
        .with_context(|| format!("no line {HEADING:?}: add it where the section belongs"))?;
    let after = start + HEADING.len();
    let end = text[after..]
        .find("\n## ")
        .map_or(text.len(), |i| after + i + 1);
    let mut out = String::with_capacity(text.len() + section.len());
    out.push_str(&text[..start]);
    out.push_str(section.trim_end());
    out.push('\n');
    if end < text.len() {
        out.push('\n');
    }
    out.push_str(&text[end..]);
    Ok(out)
}

/// Reads the page's tables from the repository root `root`.
pub fn read_tables(root: &std::path::Path, page: &Page) -> Result<Vec<PerSeed>> {
    page.tables
        .iter()
        .map(|t| PerSeed::read(&root.join(t)))
        .collect()
}

/// Checks that every row of `tables` is a table line of the page `name` (its `text`).
pub fn lines_on_page(tables: &[PerSeed], name: &str, text: &str) -> Result<()> {
    tables.iter().try_for_each(|t| t.check_on(name, text))
}

/// Checks that the page that shows the rows of `tables` (its text, `rows_page`) holds them.
pub fn check_rows(page: &Page, tables: &[PerSeed], rows_page: &str) -> Result<()> {
    (page.rows_shown)(tables, &page.rows_page(), rows_page)
}

/// The verdict of a check: the page's section as it stands against the one rebuilt.
pub fn check_section(page: &Page, text: &str, rebuilt: &str) -> Result<()> {
    let Some((_, current)) = text.split_once(HEADING) else {
        bail!("{}: no section {HEADING:?}", page.path());
    };
    let current = match current.find("\n## ") {
        Some(end) => &current[..end + 1],
        None => current,
    };
    let rebuilt = rebuilt.trim_start_matches(HEADING);
    ensure!(
        current.trim_end() == rebuilt.trim_end(),
        "{}: the section differs from what its rows give; rebuild it with `restat {} --commit \
         COMMIT`",
        page.path(),
        page.name
    );
    Ok(())
}

#[cfg(test)]
pub(crate) mod tests {
    use super::per_seed::PerSeed;

    /// A committed per-seed file, from the repository root.
    pub(crate) fn committed(path: &str) -> PerSeed {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .parent()
            .expect("the crate lives in the workspace");
        PerSeed::read(&root.join(path)).expect("a committed per-seed file")
    }
}
