//! The CLI's JSON report, written episode by episode.
//!
//! The file is exactly `serde_json::to_string_pretty(&report)` of the full [`Report`] (same
//! keys, same order, same bytes), but the records are never all in memory: each one is
//! appended to a spool file (`.NAME.episodes.tmp-PID-N`, next to the report) as soon as its
//! episode ends. The summary comes first in the document and is known only at the end, so
//! [`JsonReportWriter::finish`] then writes the summary, copies the spool behind it and
//! commits the report atomically ([`crate::files::AtomicFile`]). Until then nothing is visible
//! at the report's path; on an error, or when the writer is dropped, both temporary files are
//! removed.

use std::fs;
use std::io::{self, Write};
use std::path::{Path, PathBuf};

use super::metrics::EpisodeRecord;
use super::test_protocol::Report;
use crate::files::AtomicFile;

/// How `to_string_pretty` ends a report whose `episodes` is empty (the key comes last).
const EMPTY_TAIL: &str = "[]\n}";

/// Indentation of a record inside the report's `episodes` array (two levels of two spaces).
const RECORD_INDENT: &str = "    ";

/// A JSON report being written (see the module docs).
///
/// ```
/// use firmware_sim::nav::straight::Straight;
/// use firmware_sim::nav::test_protocol::{evaluate_controller, evaluate_streaming, EvalConfig};
/// use firmware_sim::nav::json_report::JsonReportWriter;
/// use firmware_sim::nav::scenario::Scenario;
/// let dir = std::env::temp_dir().join(format!("json-report-doc-{}", std::process::id()));
/// std::fs::create_dir_all(&dir).unwrap();
/// let path = dir.join("report.json");
/// let s = Scenario::builtin("nav-walls").unwrap();
/// let cfg = EvalConfig { episodes: 3, ..EvalConfig::default() };
/// let mut json = JsonReportWriter::create(&path).unwrap();
/// let report = evaluate_streaming(&mut Straight { max_step: 0.25 }, &s, &cfg, |e| json.episode(&e))
///     .unwrap();
/// json.finish(&report).unwrap();
/// // The same bytes as the pretty-printed full report (timing aside, which is wall-clock).
/// let mut full = evaluate_controller(&mut Straight { max_step: 0.25 }, &s, &cfg).unwrap();
/// full.timing = report.timing;
/// assert_eq!(std::fs::read_to_string(&path).unwrap(), serde_json::to_string_pretty(&full).unwrap());
/// # std::fs::remove_dir_all(&dir).unwrap();
/// ```
#[derive(Debug)]
pub struct JsonReportWriter {
    path: PathBuf,
    spool: AtomicFile,
    records: u64,
}

impl JsonReportWriter {
    /// Starts a report at `path` (nothing appears there before [`JsonReportWriter::finish`]).
    pub fn create(path: &Path) -> io::Result<JsonReportWriter> {
        let name = path
            .file_name()
            .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "is not a file path"))?;
        let mut spool_name = name.to_os_string();
        spool_name.push(".episodes");
        // Never committed: `AtomicFile` gives it a unique temporary name and removes it on
        // drop, and a spool left by a killed run is swept like any other temporary.
        let spool = AtomicFile::create(&path.with_file_name(spool_name))?;
        Ok(JsonReportWriter {
            path: path.to_path_buf(),
            spool,
            records: 0,
        })
    }

    /// Appends one episode's record.
    pub fn episode(&mut self, record: &EpisodeRecord) -> io::Result<()> {
        if self.records > 0 {
            self.spool.write_all(b",\n")?;
        }
        let text = serde_json::to_string_pretty(record)?;
        // A record holds no strings, so every line break is one of the printer's own.
        for (i, line) in text.lines().enumerate() {
            if i > 0 {
                self.spool.write_all(b"\n")?;
            }
            self.spool.write_all(RECORD_INDENT.as_bytes())?;
            self.spool.write_all(line.as_bytes())?;
        }
        self.records += 1;
        Ok(())
    }

    /// Writes the report: `report`'s summary (its own `episodes` are ignored: the file holds
    /// the records given to [`JsonReportWriter::episode`]), then the records, and commits it.
    pub fn finish(mut self, report: &Report) -> io::Result<()> {
        let head = summary_json(report)?;
        let mut out = AtomicFile::create(&self.path)?;
        out.write_all(head.as_bytes())?;
        if self.records == 0 {
            out.write_all(EMPTY_TAIL.as_bytes())?;
        } else {
            out.write_all(b"[\n")?;
            self.spool.flush()?;
            io::copy(&mut fs::File::open(self.spool.temp_path())?, &mut out)?;
            out.write_all(b"\n  ]\n}")?;
        }
        out.commit()
    }
}

/// The pretty JSON of `report` without its records, up to the `[` of the `episodes` array.
fn summary_json(report: &Report) -> io::Result<String> {
    let text = if report.episodes.is_empty() {
        serde_json::to_string_pretty(report)?
    } else {
        serde_json::to_string_pretty(&Report {
            episodes: Vec::new(),
            ..report.clone()
        })?
    };
    text.strip_suffix(EMPTY_TAIL)
        .map(str::to_string)
        .ok_or_else(|| io::Error::other("the report does not end with its episodes"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nav::reference::reference;
    use crate::nav::scenario::Scenario;
    use crate::nav::test_protocol::{evaluate_controller, evaluate_streaming, EvalConfig};

    fn scratch(tag: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("json-report-{tag}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).expect("scratch dir");
        dir
    }

    /// Regression: the CLI kept every record in memory to print the
    /// report. The streamed file must be byte for byte the pretty-printed full report, with
    /// trajectories, faults and one or many episodes.
    #[test]
    fn streamed_report_is_the_pretty_printed_full_report() {
        let dir = scratch("bytes");
        let s = Scenario::builtin("nav-walls").expect("builtin");
        for (episodes, record_trajectories) in [(1, false), (7, true)] {
            let cfg = EvalConfig {
                episodes,
                record_trajectories,
                faults: "dropout-nan:0.2,stuck:1@30".parse().expect("faults"),
                ..EvalConfig::default()
            };
            let path = dir.join("r.json");
            let mut json = JsonReportWriter::create(&path).expect("create");
            let mut c = reference("oracle", &s).expect("oracle");
            let report =
                evaluate_streaming(c.as_mut(), &s, &cfg, |e| json.episode(&e)).expect("streamed");
            json.finish(&report).expect("finish");
            let mut c = reference("oracle", &s).expect("oracle");
            let mut full = evaluate_controller(c.as_mut(), &s, &cfg).expect("full");
            full.timing = report.timing;
            let expected = serde_json::to_string_pretty(&full).expect("json");
            assert_eq!(fs::read_to_string(&path).expect("read"), expected);
        }
        // Only the report: the spool and the report's temporary file are gone.
        let names: Vec<_> = fs::read_dir(&dir).expect("list").collect();
        assert_eq!(names.len(), 1);
        fs::remove_dir_all(&dir).expect("cleanup");
    }

    #[test]
    fn a_dropped_writer_leaves_nothing() {
        let dir = scratch("dropped");
        let s = Scenario::builtin("nav-open").expect("builtin");
        let cfg = EvalConfig {
            episodes: 2,
            ..EvalConfig::default()
        };
        let mut json = JsonReportWriter::create(&dir.join("r.json")).expect("create");
        let mut c = reference("straight", &s).expect("straight");
        evaluate_streaming(c.as_mut(), &s, &cfg, |e| json.episode(&e)).expect("run");
        drop(json);
        assert_eq!(fs::read_dir(&dir).expect("list").count(), 0);
        fs::remove_dir_all(&dir).expect("cleanup");
    }
}
