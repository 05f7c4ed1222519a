//! `oit techniques --markdown operators`: what every technique does with the blend operators
//! `add`, `subtract` and `multiply`, generated from each one's `Technique::operator`
//! declaration (its default configuration), never written by hand.

use oit_gpu::{Caps, FormatCaps, PROBED_FORMATS, Support, TechniqueSpec};
use oit_results::report::md_cell;
use oit_scene::BlendOperator;

/// An adapter with every feature the techniques ask for (float32 blending, 64-bit atomics, ray queries,
/// every probed format renderable and blendable, 8 colour attachments of 128 bytes a sample),
/// with or without dual-source blending: the one feature on which an operator's support turns.
fn table_caps(dual_source_blending: bool) -> Caps {
    let full = FormatCaps {
        renderable: true,
        blendable: true,
        filterable: true,
        storage_read_write: true,
        multisample_x4: true,
    };
    Caps {
        backend: oit_gpu::wgpu::Backend::Vulkan,
        float32_blendable: true,
        timestamps: true,
        timestamps_inside_encoders: true,
        timestamps_inside_passes: true,
        adapter_specific_format_features: true,
        dual_source_blending,
        int64_atomics: true,
        ray_query: true,
        max_texture_dimension_2d: 16384,
        max_color_attachments: 8,
        max_color_attachment_bytes_per_sample: 128,
        max_storage_buffers_per_shader_stage: 16,
        max_buffer_size: 1 << 32,
        max_storage_buffer_binding_size: 1 << 31,
        min_uniform_buffer_offset_alignment: 256,
        formats: PROBED_FORMATS
            .iter()
            .map(|f| (format!("{f:?}"), full))
            .collect(),
    }
}

/// A table cell: exact, approximate: what, or no: why.
fn cell(support: Support) -> String {
    match support {
        Support::Exact => "exact".to_owned(),
        Support::Approximate(what) => format!("approximate: {}", md_cell(what)),
        Support::Unsupported(why) => format!("no: {}", md_cell(why)),
    }
}

/// The cell of `operator` for `technique`: its declaration with dual-source blending, and what
/// changes without it.
fn operator_cell(technique: &dyn oit_gpu::Technique, operator: BlendOperator) -> String {
    let with = technique.operator(operator, &table_caps(true));
    let without = technique.operator(operator, &table_caps(false));
    if with == without {
        cell(with)
    } else {
        format!(
            "{}; without dual-source blending {}",
            cell(with),
            cell(without)
        )
    }
}

/// The Markdown table: one row per technique (neighbours that declare the same share a row),
/// one column per non-`over` operator.
pub fn operators_markdown() -> String {
    let operators: Vec<BlendOperator> = BlendOperator::ALL
        .into_iter()
        .filter(|&op| op != BlendOperator::Over)
        .collect();
    let mut out = String::from("| technique |");
    for op in &operators {
        out.push_str(&format!(" `{}` |", op.name()));
    }
    out.push_str("\n|---|");
    out.push_str(&"---|".repeat(operators.len()));
    out.push('\n');
    let registry = crate::registry();
    let mut rows: Vec<(Vec<&str>, Vec<String>)> = Vec::new();
    for info in &registry {
        let cells = match TechniqueSpec::build(&info.default_spec().canonical(), &registry) {
            Ok(technique) => operators
                .iter()
                .map(|&op| operator_cell(technique.as_ref(), op))
                .collect(),
            Err(e) => vec![format!("no: {}", md_cell(&e.to_string())); operators.len()],
        };
        match rows.last_mut() {
            Some((names, same)) if *same == cells => names.push(info.name),
            _ => rows.push((vec![info.name], cells)),
        }
    }
    for (names, cells) in rows {
        let names: Vec<String> = names.iter().map(|n| format!("`{n}`")).collect();
        out.push_str(&format!(
            "| {} | {} |\n",
            names.join(", "),
            cells.join(" | ")
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_technique_has_a_row_and_the_exact_ones_say_exact() {
        let table = operators_markdown();
        for info in crate::registry() {
            assert!(table.contains(&format!("`{}`", info.name)), "{}", info.name);
        }
        let row = |name: &str| {
            table
                .lines()
                .find(|l| l.contains(&format!("`{name}`")))
                .unwrap_or_else(|| panic!("no row for {name}"))
                .to_owned()
        };
        // Peeling composites any (P, t) pair in float targets.
        assert!(row("front-peel").matches("| exact").count() == 3, "{table}");
        // The k-buffer's sign bit needs the two-chain layout: unsupported without dual-source.
        assert!(
            row("k-buffer").contains("without dual-source blending no:"),
            "{table}"
        );
        assert_eq!(
            table.lines().next(),
            Some("| technique | `add` | `subtract` | `multiply` |")
        );
    }
}
