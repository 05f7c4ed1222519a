//! README tables copied from the published results, never by hand.
//!
//! A line `<!-- results-table: docs/results/lavapipe/suite/results.md#Summary over the suite -->`
//! in a Markdown file is followed by a table (its `|` lines). `cargo xtask results` replaces that
//! table with the first table under the named heading of the named results.md, and a test
//! checks that every such table in README.md still equals its source, so a README number
//! cannot drift from the measurement it quotes.
//!
//! A line `<!-- generated: oit ARGS -->` (README.md, docs/coloured-transmission.md) is followed
//! by the table `oit ARGS` prints (the technique registry's); `cargo xtask readme-tables`
//! rewrites it and crates/oit-cli/tests/cli.rs checks it.

use std::path::Path;

use anyhow::{Context, Result, bail};

/// What opens a marker comment; the rest of the line is `PATH#HEADING -->`.
const MARKER: &str = "<!-- results-table: ";

/// One marker: the results file (relative to the workspace root) and the heading text whose
/// first table is copied.
#[derive(Debug, PartialEq)]
struct Source<'a> {
    path: &'a str,
    heading: &'a str,
}

/// Parses a marker line, or None for any other line.
fn marker<'a>(line: &'a str, what: &str, number: usize) -> Result<Option<Source<'a>>> {
    let Some(rest) = line.trim().strip_prefix(MARKER) else {
        return Ok(None);
    };
    let Some(spec) = rest.strip_suffix("-->").map(str::trim) else {
        bail!("{what}:{number}: a results-table marker must end with `-->` on the same line");
    };
    let Some((path, heading)) = spec.split_once('#') else {
        bail!("{what}:{number}: a results-table marker names `PATH#HEADING`, got `{spec}`");
    };
    Ok(Some(Source {
        path: path.trim(),
        heading: heading.trim(),
    }))
}

/// The first table (consecutive `|` lines) after the heading line whose text (without the
/// leading `#`s) is `heading`.
fn table_under<'a>(markdown: &'a str, heading: &str, what: &str) -> Result<Vec<&'a str>> {
    let mut lines = markdown.lines();
    lines
        .by_ref()
        .find(|l| l.starts_with('#') && l.trim_start_matches('#').trim() == heading)
        .with_context(|| format!("{what}: no heading `{heading}`"))?;
    let table: Vec<&str> = lines
        .skip_while(|l| !l.starts_with('|'))
        .take_while(|l| l.starts_with('|'))
        .collect();
    if table.len() < 3 {
        bail!("{what}: no table (header, rule and a row) under `{heading}`");
    }
    Ok(table)
}

/// The rows of a Markdown table, header and rule first.
type Rows = Vec<String>;

/// `document` with the table after every marker line replaced: `table_for(line, number)`
/// says whether a line is a marker and, if so, gives the rows of its table. A marker must be
/// followed directly by the table it replaces. `what` names the document in errors.
fn replace_tables(
    document: &str,
    what: &str,
    table_for: &dyn Fn(&str, usize) -> Result<Option<Rows>>,
) -> Result<String> {
    let mut out = String::with_capacity(document.len());
    let mut lines = document.lines().enumerate().peekable();
    while let Some((i, line)) = lines.next() {
        out.push_str(line);
        out.push('\n');
        let Some(table) = table_for(line, i + 1)? else {
            continue;
        };
        if lines.peek().is_none_or(|(_, l)| !l.starts_with('|')) {
            bail!(
                "{what}:{}: a table marker must be followed directly by its table",
                i + 1
            );
        }
        while lines.next_if(|(_, l)| l.starts_with('|')).is_some() {}
        for row in table {
            out.push_str(&row);
            out.push('\n');
        }
    }
    Ok(out)
}

/// `document` with the table after every results-table marker replaced by its source's table,
/// read through `read` (a path relative to the workspace root → its text).
fn splice(document: &str, what: &str, read: &dyn Fn(&str) -> Result<String>) -> Result<String> {
    replace_tables(document, what, &|line, number| {
        let Some(source) = marker(line, what, number)? else {
            return Ok(None);
        };
        let text = read(source.path)?;
        let table = table_under(&text, source.heading, source.path)?;
        Ok(Some(table.into_iter().map(str::to_owned).collect()))
    })
}

/// Reads a file relative to `root`, naming it in the error.
fn read_under(root: &Path, path: &str) -> Result<String> {
    let full = root.join(path);
    std::fs::read_to_string(&full).with_context(|| full.display().to_string())
}

/// Replaces `root/doc` by `after` atomically, and only when it differs from `before`.
fn write_if_changed(root: &Path, doc: &str, before: &str, after: &str) -> Result<()> {
    if after != before {
        let path = root.join(doc);
        let staging = path.with_extension("md.xtask-tmp");
        std::fs::write(&staging, after).with_context(|| staging.display().to_string())?;
        std::fs::rename(&staging, &path).with_context(|| path.display().to_string())?;
    }
    Ok(())
}

/// How many lines of `document` open with `prefix` (after indentation).
fn count_markers(document: &str, prefix: &str) -> usize {
    document
        .lines()
        .filter(|l| l.trim().starts_with(prefix))
        .count()
}

/// Rewrites the marked tables of `root/README.md` from the results they name. Returns how many
/// tables it holds.
pub fn update_readme(root: &Path) -> Result<usize> {
    let before = read_under(root, "README.md")?;
    let after = splice(&before, "README.md", &|p| read_under(root, p))?;
    write_if_changed(root, "README.md", &before, &after)?;
    Ok(count_markers(&before, MARKER))
}

/// What opens a generated-table marker; the rest of the line is `ARGS -->`.
const GENERATED: &str = "<!-- generated: oit ";

/// The documents that hold generated tables.
pub const GENERATED_IN: &[&str] = &["README.md", "docs/coloured-transmission.md"];

/// `document` with the table after every generated-table marker replaced by what `run` (the
/// `oit` arguments → its stdout) prints.
fn splice_generated(
    document: &str,
    what: &str,
    run: &dyn Fn(&str) -> Result<String>,
) -> Result<String> {
    replace_tables(document, what, &|line, number| {
        let Some(rest) = line.trim().strip_prefix(GENERATED) else {
            return Ok(None);
        };
        let Some(args) = rest.strip_suffix("-->").map(str::trim) else {
            bail!("{what}:{number}: a generated marker must end with `-->` on the same line");
        };
        let table = run(args).with_context(|| format!("{what}:{number}: `oit {args}`"))?;
        Ok(Some(table.lines().map(str::to_owned).collect()))
    })
}

/// Rewrites the generated tables of [`GENERATED_IN`] under `root`. Returns how many there are.
pub fn update_generated(root: &Path, run: &dyn Fn(&str) -> Result<String>) -> Result<usize> {
    let mut tables = 0;
    for doc in GENERATED_IN {
        let before = read_under(root, doc)?;
        let after = splice_generated(&before, doc, run)?;
        write_if_changed(root, doc, &before, &after)?;
        tables += count_markers(&before, GENERATED);
    }
    Ok(tables)
}

#[cfg(test)]
mod tests {
    use super::*;

    const RESULTS: &str = "# r\n\n## Summary over the suite\n\nText.\n\n| a | b |\n|---|---:|\n| x | 1.00 |\n| y | 2.00 |\n\n## Other\n\n| c |\n|---|\n| z |\n";

    fn read(path: &str) -> Result<String> {
        match path {
            "docs/r.md" => Ok(RESULTS.to_owned()),
            other => bail!("{other}: not found"),
        }
    }

    #[test]
    fn the_marked_table_is_replaced_and_the_rest_kept() {
        let readme = "intro\n<!-- results-table: docs/r.md#Summary over the suite -->\n| a | b |\n|---|---:|\n| x | 9.99 |\n\nafter\n<!-- results-table: docs/r.md#Other -->\n| old |\n|---|\n| row |\nend\n";
        let spliced = splice(readme, "README.md", &read).unwrap();
        assert_eq!(
            spliced,
            "intro\n<!-- results-table: docs/r.md#Summary over the suite -->\n| a | b |\n|---|---:|\n| x | 1.00 |\n| y | 2.00 |\n\nafter\n<!-- results-table: docs/r.md#Other -->\n| c |\n|---|\n| z |\nend\n"
        );
        // Splicing twice changes nothing.
        assert_eq!(splice(&spliced, "README.md", &read).unwrap(), spliced);
    }

    #[test]
    fn bad_markers_name_the_line_and_what_is_wrong() {
        let cases = [
            (
                "<!-- results-table: docs/r.md#Nope -->\n| a |\n|---|\n| b |\n",
                "docs/r.md: no heading `Nope`",
            ),
            (
                "<!-- results-table: docs/gone.md#Other -->\n| a |\n",
                "docs/gone.md: not found",
            ),
            (
                "x\n<!-- results-table: docs/r.md -->\n| a |\n",
                "README.md:2: a results-table marker names `PATH#HEADING`",
            ),
            (
                "<!-- results-table: docs/r.md#Other\n| a |\n",
                "README.md:1: a results-table marker must end with `-->`",
            ),
            (
                "<!-- results-table: docs/r.md#Other -->\n\n| a |\n",
                "README.md:1: a table marker must be followed directly by its table",
            ),
        ];
        for (readme, expected) in cases {
            let error = format!("{:#}", splice(readme, "README.md", &read).unwrap_err());
            assert!(error.contains(expected), "{error:?} lacks {expected:?}");
        }
    }

    #[test]
    fn a_generated_table_is_replaced_by_what_oit_prints() {
        let run = |args: &str| -> Result<String> {
            match args {
                "techniques --markdown techniques" => Ok("| t |\n|---|\n| new |\n".to_owned()),
                other => bail!("unexpected {other}"),
            }
        };
        let doc = "a\n<!-- generated: oit techniques --markdown techniques -->\n| t |\n|---|\n| old |\n| gone |\nb\n";
        let spliced = splice_generated(doc, "README.md", &run).unwrap();
        assert_eq!(
            spliced,
            "a\n<!-- generated: oit techniques --markdown techniques -->\n| t |\n|---|\n| new |\nb\n"
        );
        let error = format!(
            "{:#}",
            splice_generated("<!-- generated: oit scenes -->\n", "README.md", &run).unwrap_err()
        );
        assert!(
            error.contains("README.md:1: `oit scenes`: unexpected scenes"),
            "{error}"
        );
    }

    #[test]
    fn a_heading_without_a_table_is_an_error() {
        let text = "## Empty\n\nno table\n\n## Next\n";
        let error = format!("{:#}", table_under(text, "Empty", "r.md").unwrap_err());
        assert!(error.contains("no table"), "{error}");
    }

    /// The README's marked tables equal the published results they name: rerun
    /// `cargo xtask results` (or edit the results) rather than the README.
    #[test]
    fn readme_tables_equal_the_published_results() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"))
            .parent()
            .expect("xtask lives one level below the workspace root");
        let readme = read_under(root, "README.md").unwrap();
        let markers = count_markers(&readme, MARKER);
        assert!(
            markers >= 1,
            "README.md has {markers} results-table markers"
        );
        let spliced = splice(&readme, "README.md", &|p| read_under(root, p)).unwrap();
        for (number, (now, wanted)) in readme.lines().zip(spliced.lines()).enumerate() {
            assert_eq!(
                now,
                wanted,
                "README.md:{} differs from the results it quotes; run `cargo xtask results` or `cargo xtask readme-tables`",
                number + 1
            );
        }
        assert_eq!(readme.lines().count(), spliced.lines().count());
    }
}
