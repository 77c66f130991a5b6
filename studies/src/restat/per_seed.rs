//! A page's per-seed table, committed as a tab-separated file: a comment line saying which page
//! and commit it came from, a header of the page table's column names, and one line per row,
//! each cell exactly as the page prints it (so the page's row is the file's line joined with
//! ` | `, and a test can find every row on the page).

use std::path::{Path, PathBuf};

use anyhow::{bail, ensure, Context, Result};

/// The rows of one per-seed table.
#[derive(Clone, Debug)]
pub struct PerSeed {
    /// The file it was read from.
    pub path: PathBuf,
    /// The comment lines, without their `# `: where the rows came from.
    pub source: Vec<String>,
    /// The column names.
    pub header: Vec<String>,
    /// The cells of each row, in the file's order.
    pub rows: Vec<Vec<String>>,
}

impl PerSeed {
    /// Reads `path`.
    pub fn read(path: &Path) -> Result<PerSeed> {
        let text = std::fs::read_to_string(path).with_context(|| format!("{}", path.display()))?;
        PerSeed::parse(path, &text)
    }

    /// Parses the text of a per-seed file; `path` names it in errors.
    ///
    /// ```
    /// use std::path::Path;
    /// use studies::restat::per_seed::PerSeed;
    /// let text = "# from a page\nalgo\tseed\tsuccess\ndcp\t0\t1.00\nddpg\t0\t0.83\n";
    /// let t = PerSeed::parse(Path::new("t.tsv"), text).unwrap();
    /// assert_eq!(t.values(&[("algo", "ddpg")], "success").unwrap(), vec![0.83]);
    /// assert_eq!(t.page_lines()[1], "| dcp | 0 | 1.00 |");
    /// assert!(PerSeed::parse(Path::new("t.tsv"), "a\tb\n1\n").is_err());
    /// ```
    pub fn parse(path: &Path, text: &str) -> Result<PerSeed> {
        let mut source = Vec::new();
        let mut lines = text.lines().enumerate().filter(|(_, l)| !l.is_empty());
        let header = loop {
            let Some((_, line)) = lines.next() else {
                bail!("{}: no header line", path.display());
            };
            match line.strip_prefix('#') {
                Some(comment) => source.push(comment.trim().to_string()),
                None => break cells(line),
            }
        };
        let rows = lines
            .map(|(i, line)| {
                let row = cells(line);
                ensure!(
                    row.len() == header.len(),
                    "{}:{}: {} cells where the header has {}",
                    path.display(),
                    i + 1,
                    row.len(),
                    header.len()
                );
                Ok(row)
            })
            .collect::<Result<_>>()?;
        Ok(PerSeed {
            path: path.to_path_buf(),
            source,
            header,
            rows,
        })
    }

    /// The index of the column `name`.
    pub fn column(&self, name: &str) -> Result<usize> {
        self.header
            .iter()
            .position(|h| h == name)
            .with_context(|| format!("{}: no column {name:?}", self.path.display()))
    }

    /// The rows whose cells equal every `(column, value)` of `filter`, in the file's order.
    pub fn select(&self, filter: &[(&str, &str)]) -> Result<Vec<&Vec<String>>> {
        let at: Vec<(usize, &str)> = filter
            .iter()
            .map(|(c, v)| Ok((self.column(c)?, *v)))
            .collect::<Result<_>>()?;
        Ok(self
            .rows
            .iter()
            .filter(|row| at.iter().all(|(i, v)| row[*i] == *v))
            .collect())
    }

    /// The numbers of `column` in the rows `filter` selects, in the file's order; an error if a
    /// cell is not a number or no row is selected.
    pub fn values(&self, filter: &[(&str, &str)], column: &str) -> Result<Vec<f64>> {
        let c = self.column(column)?;
        let rows = self.select(filter)?;
        ensure!(
            !rows.is_empty(),
            "{}: no row with {filter:?}",
            self.path.display()
        );
        rows.iter()
            .map(|row| {
                row[c].parse::<f64>().with_context(|| {
                    format!(
                        "{}: {column} = {:?} is not a number",
                        self.path.display(),
                        row[c]
                    )
                })
            })
            .collect()
    }

    /// The distinct values of `column`, in first-seen order.
    pub fn distinct(&self, column: &str) -> Result<Vec<String>> {
        let c = self.column(column)?;
        let mut seen: Vec<String> = Vec::new();
        for row in &self.rows {
            if !seen.contains(&row[c]) {
                seen.push(row[c].clone());
            }
        }
        Ok(seen)
    }

    /// The table's lines as the page prints them, each `| a | b | c |`: the header, then every
    /// row (the alignment line left out).
    pub fn page_lines(&self) -> Vec<String> {
        std::iter::once(&self.header)
            .chain(&self.rows)
            .map(|cells| format!("| {} |", cells.join(" | ")))
            .collect()
    }

    /// An error naming the first row of the file that `page` (its text) does not hold as a
    /// table line.
    pub fn check_on(&self, page_name: &str, page: &str) -> Result<()> {
        let lines: Vec<&str> = page.lines().map(str::trim_end).collect();
        for line in self.page_lines() {
            ensure!(
                lines.contains(&line.as_str()),
                "{}: the row {line:?} is not on {page_name}",
                self.path.display()
            );
        }
        Ok(())
    }
}

fn cells(line: &str) -> Vec<String> {
    line.split('\t').map(|c| c.trim().to_string()).collect()
}
