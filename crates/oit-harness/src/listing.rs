//! What `oit techniques` prints: text for people, JSON for scripts, and the Markdown tables
//! the README and docs/coloured-transmission.md hold (generated, never edited by hand: a test
//! in crates/oit-cli/tests/cli.rs compares them).

use oit_gpu::{Allowed, ParamInfo};
use oit_results::report::md_cell;

/// `oit techniques`: every technique with its parameters and defaults.
pub fn techniques_help() -> String {
    let mut out = String::new();
    for info in crate::registry() {
        out.push_str(&format!("{}\n    {}\n", info.name, info.description));
        for p in &info.params {
            out.push_str(&format!(
                "    {}={} (default {}): {}\n",
                p.key, p.allowed, p.default, p.description
            ));
        }
        out.push_str(&format!(
            "    canonical default: {}\n",
            info.default_spec().canonical()
        ));
    }
    out
}

/// `oit techniques --json`: every technique with its parameters as JSON, for scripts. An
/// integer parameter has `min` and `max` (and the words it also takes); a word parameter its
/// `values`.
pub fn techniques_json() -> String {
    let list: Vec<serde_json::Value> = crate::registry()
        .iter()
        .map(|info| {
            let params: Vec<serde_json::Value> = info
                .params
                .iter()
                .map(|p| {
                    let mut param = serde_json::json!({
                        "key": p.key,
                        "default": p.default,
                        "description": p.description,
                    });
                    match p.allowed {
                        Allowed::Values(values) => {
                            param["values"] = serde_json::json!(values);
                        }
                        Allowed::Integer { min, max, words } => {
                            param["min"] = serde_json::json!(min);
                            param["max"] = serde_json::json!(max);
                            param["values"] = serde_json::json!(words);
                        }
                    }
                    param
                })
                .collect();
            serde_json::json!({
                "name": info.name,
                "description": info.description,
                "default_spec": info.default_spec().canonical(),
                "params": params,
            })
        })
        .collect();
    serde_json::to_string_pretty(&list).expect("JSON values serialize")
}

/// Which generated Markdown table `oit techniques --markdown` prints.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MarkdownTable {
    /// Every technique: its parameters (allowed values, default), its family folder and what
    /// it is (README.md).
    Techniques,
    /// What each technique does with coloured transmittance (docs/coloured-transmission.md);
    /// neighbours that do the same share a row.
    Transmission,
    /// What each technique does with `add`, `subtract` and `multiply`, from its
    /// `Technique::operator` declarations ([`crate::operators_markdown`]).
    Operators,
}

/// `oit techniques --markdown TABLE`: a Markdown table generated from the registry, with
/// links relative to the workspace root's README (techniques) or docs/ (transmission).
pub fn techniques_markdown(table: MarkdownTable) -> String {
    let mut out = String::new();
    match table {
        MarkdownTable::Techniques => {
            out.push_str("| technique | parameters | family | what it is |\n|---|---|---|---|\n");
            let by_family = crate::FAMILIES.iter().flat_map(|family| {
                (family.techniques)()
                    .into_iter()
                    .map(|t| (family.folder, t))
            });
            for (family, info) in by_family {
                let params: Vec<String> = info.params.iter().map(param_cell).collect();
                out.push_str(&format!(
                    "| `{}` | {} | [{family}](techniques/{family}/README.md) | {} |\n",
                    info.name,
                    if params.is_empty() {
                        "–".to_owned()
                    } else {
                        params.join("<br>")
                    },
                    md_cell(info.description),
                ));
            }
        }
        MarkdownTable::Operators => out.push_str(&crate::operators_markdown()),
        MarkdownTable::Transmission => {
            out.push_str("| technique | coloured transmittance |\n|---|---|\n");
            let registry = crate::registry();
            let mut rows: Vec<(Vec<&str>, &str)> = Vec::new();
            for info in &registry {
                match rows.last_mut() {
                    Some((names, text)) if *text == info.transmission => names.push(info.name),
                    _ => rows.push((vec![info.name], info.transmission)),
                }
            }
            for (names, text) in rows {
                let names: Vec<String> = names.iter().map(|n| format!("`{n}`")).collect();
                out.push_str(&format!("| {} | {} |\n", names.join(", "), md_cell(text)));
            }
        }
    }
    out
}

/// One parameter as a table cell: `key`: allowed (default d).
fn param_cell(param: &ParamInfo) -> String {
    let allowed = match param.allowed {
        Allowed::Values(values) => values.join(" \\| "),
        Allowed::Integer { min, max, words } => {
            // A limit no one reaches (u32::MAX and above) is a type's, not a technique's.
            let range = if max >= u64::from(u32::MAX) {
                format!("≥ {min}")
            } else {
                format!("{min}–{max}")
            };
            let mut all = vec![range];
            all.extend(words.iter().map(|w| (*w).to_owned()));
            all.join(" \\| ")
        }
    };
    format!("`{}`: {allowed} (default {})", param.key, param.default)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_technique_has_one_row_and_every_family_a_link() {
        let table = techniques_markdown(MarkdownTable::Techniques);
        let rows: Vec<&str> = table.lines().skip(2).collect();
        let registry = crate::registry();
        assert_eq!(rows.len(), registry.len());
        for (row, info) in rows.iter().zip(&registry) {
            assert!(row.starts_with(&format!("| `{}` |", info.name)), "{row}");
            // Four cells: a `|` inside a description would have made more.
            assert_eq!(row.matches(" | ").count(), 3, "{row}");
        }
        for family in crate::FAMILIES {
            let readme = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../../techniques")
                .join(family.folder)
                .join("README.md");
            assert!(readme.is_file(), "{} is missing", readme.display());
            assert!(table.contains(&format!("(techniques/{}/README.md)", family.folder)));
        }
    }

    #[test]
    fn neighbours_that_treat_transmission_alike_share_a_row() {
        let table = techniques_markdown(MarkdownTable::Transmission);
        let registry = crate::registry();
        let first_cells: String = table
            .lines()
            .skip(2)
            .map(|row| row.split(" | ").next().unwrap())
            .collect();
        for info in &registry {
            assert_eq!(
                first_cells.matches(&format!("`{}`", info.name)).count(),
                1,
                "{} must be named once",
                info.name
            );
            assert!(!info.transmission.is_empty(), "{} says nothing", info.name);
        }
        // The five sorted forms share one text, so one row.
        let sorted_row = table
            .lines()
            .find(|l| l.starts_with("| `unsorted`"))
            .unwrap();
        assert!(sorted_row.contains("`cull-split`"), "{sorted_row}");
    }
}
